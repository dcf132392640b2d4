//! The SPH fluid as a particle model: its fields, passes, finishes and state update.

use super::*;
#[allow(unused_imports)]
use crate::error::{Error, Quantity, UNSTABLE, Unstable};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Pass {
    Density,
    /// The inclusion particles' fitted image velocities ([`ImageKernel`]).
    InclusionImage,
    Gradient,
    Momentum,
    /// Mirror walls: the boundary particles' density and velocity from their mirror points.
    WallMirror,
    /// MSPH: every system assembled and factored, the velocity gradient solved.
    MsphGradient,
    /// Mirror walls: the boundary particles' stresses extrapolated from their mirror points.
    WallStress,
    /// MSPH: ∇·σ, σ = −pI + σ̄ + τ, into the forces.
    MsphDivergence,
}

/// The SPH fluid: parameters, its passes and its field indices.
pub struct SphModel<const D: usize> {
    pub(super) cfg: SphCfg,
    pub(super) mass: f64,
    pub(super) passes: Vec<Pass>,
    pub(super) boundaries: Boundaries<D>,
    /// The inclusions' layout (to give their particles their offsets).
    pub(super) inclusions: Option<InclusionsCfg>,
    pub(super) body_force: [f64; D],
    pub(super) density: usize,
    pub(super) rate: Option<usize>,
    pub(super) stress: Option<usize>,
    /// The drift correction v̂ − v (XSPH and/or the transport velocity).
    pub(super) xsph: Option<usize>,
    /// Δt, for the transport velocity's ½Δt a_t (0 until [`Self::with_transport_step`]).
    pub(super) transport_step: f64,
    /// The traction moments of the inclusion particles ([`INCLUSION_TRACTION_MOMENT`]).
    pub(super) traction_moment: Option<usize>,
    /// The constitutive polymer model (none for a Newtonian fluid or dumbbell ensembles).
    pub(super) polymer: Option<ConstitutiveLaw>,
    /// τ (either kind of polymer), dτ/dt (constitutive) and G (dumbbells).
    pub(super) polymer_stress: Option<usize>,
    pub(super) polymer_rate: Option<usize>,
    pub(super) velocity_gradient: Option<usize>,
    /// Velocity-gradient estimates left uncorrected (det M_i too small) on this rank.
    pub(super) uncorrected_gradients: u64,
    /// Mirror walls (`[walls] treatment = "mirror"`).
    pub(super) mirror: Option<MirrorWalls<D>>,
    /// The MSPH systems of the owned particles, from the last gradient pass.
    pub(super) local: Vec<Local<D>>,
    /// MSPH systems solved to first order / left undetermined on this rank (particle ×
    /// evaluation).
    pub(super) msph_first_order: u64,
    pub(super) msph_undetermined: u64,
    /// Mirror fits that fell back (on this rank).
    pub(super) mirror_fallbacks: FitFallbacks,
    /// Per-particle values of the fields an MSPH pass differentiates (scratch).
    pub(super) values: Vec<f64>,
    pub(super) p_over_rho2: Vec<f64>,
    pub(super) inv_density: Vec<f64>,
    pub(super) stress_over_rho2: Vec<f64>,
    pub(super) sums: Vec<f64>,
    pub(super) scatter: ScatterBuffers,
    /// Whether the momentum pass of this evaluation also forms the momentum flux
    /// ([`momentum_flux`]; the diagnostics asked for the virial).
    pub(super) flux_wanted: bool,
    /// The momentum flux of the last momentum pass that formed it, for the engine.
    pub(super) flux:
        Option<Result<crate::models::pair_loop::Virial, crate::models::gather::PairError>>,
}

impl<const D: usize> SphModel<D> {
    /// The fluid of particles of mass `mass`, in a box of edge lengths `lengths` with lattice
    /// spacing `spacing` (the default range of the wall repulsion), with the walls and
    /// inclusions given.
    pub fn new(
        cfg: &SphCfg,
        mass: f64,
        lengths: &[f64; D],
        spacing: f64,
        walls: Option<&WallsCfg>,
        inclusions: Option<&InclusionsCfg>,
    ) -> Self {
        let mut passes = Vec::new();
        if cfg.density == DensityMethod::Summation {
            passes.push(Pass::Density);
        }
        let mirror_walls = walls.is_some_and(|w| w.treatment == WallTreatment::Mirror);
        let fitted_images = cfg.derivatives == Derivatives::Sph
            && inclusions.is_some_and(|inc| inc.images == InclusionImages::Fitted);
        if fitted_images {
            passes.push(Pass::InclusionImage);
        }
        if cfg.derivatives == Derivatives::Msph {
            if mirror_walls {
                passes.push(Pass::WallMirror);
            }
            passes.push(Pass::MsphGradient);
            let stressed =
                cfg.viscous_term == ViscousTerm::NestedSummation || cfg.polymer.is_some();
            if mirror_walls && stressed {
                passes.push(Pass::WallStress);
            }
            passes.push(Pass::MsphDivergence);
        } else if Self::forms_viscous_stress(cfg, inclusions.is_some()) || cfg.polymer.is_some() {
            passes.push(Pass::Gradient);
        }
        passes.push(Pass::Momentum);
        let mirror = walls.filter(|_| mirror_walls).map(|w| {
            let axis = w.axis.index();
            MirrorWalls {
                axis,
                planes: [0.0, lengths[axis]],
                thickness: w.thickness.unwrap_or(2.0 * cfg.support()) + spacing,
            }
        });
        let walls = walls.map(|w| {
            let axis = w.axis.index();
            let vel = |u: &[f64]| std::array::from_fn(|d| u.get(d).copied().unwrap_or(0.0));
            WallGeometry {
                axis,
                planes: [0.0, lengths[axis]],
                velocity: [vel(&w.lower_velocity), vel(&w.upper_velocity)],
                morris: w.treatment == WallTreatment::Morris,
                mirror_velocity: usize::MAX,
                beta_max: w.morris_cap,
                min_distance: 0.5 * spacing,
                strength: w
                    .repulsion_strength
                    .unwrap_or(cfg.sound_speed * cfg.sound_speed),
                range: w.repulsion_range.unwrap_or(spacing),
            }
        });
        let inclusions_geometry = inclusions.map(|inc| InclusionGeometry {
            radius: inc.radius,
            traction_moments: false,
            mirror_pressure: inc.mirror_pressure,
            beta_max: inc.morris_cap,
            min_distance: 0.5 * spacing,
            offset: usize::MAX,
            image: usize::MAX,
        });
        Self {
            cfg: cfg.clone(),
            mass,
            passes,
            boundaries: Boundaries {
                walls,
                inclusions: inclusions_geometry,
            },
            inclusions: inclusions.cloned(),
            body_force: std::array::from_fn(|d| cfg.body_force.get(d).copied().unwrap_or(0.0)),
            density: usize::MAX,
            rate: None,
            stress: None,
            xsph: None,
            transport_step: 0.0,
            traction_moment: None,
            polymer: cfg.polymer.as_ref().and_then(ConstitutiveLaw::of),
            polymer_stress: None,
            polymer_rate: None,
            velocity_gradient: None,
            uncorrected_gradients: 0,
            mirror,
            local: Vec::new(),
            msph_first_order: 0,
            msph_undetermined: 0,
            mirror_fallbacks: FitFallbacks::default(),
            values: Vec::new(),
            p_over_rho2: Vec::new(),
            inv_density: Vec::new(),
            stress_over_rho2: Vec::new(),
            sums: Vec::new(),
            scatter: ScatterBuffers::default(),
            flux_wanted: false,
            flux: None,
        }
    }

    /// The same fluid, with the inclusions' traction moments ([`INCLUSION_TRACTION_MOMENT`])
    /// accumulated by the momentum pass when `measure` (the `composite_viscosity` observable);
    /// otherwise no pass spends work on them.
    pub fn with_traction_moments(mut self, measure: bool) -> Self {
        if let Some(g) = &mut self.boundaries.inclusions {
            g.traction_moments = measure;
        }
        self
    }

    /// The stress fields the momentum equation reads (the nested summation's σ̄, the polymer
    /// τ): their ghost copies must be fresh before it.
    pub(super) fn stress_fields(&self) -> Vec<&'static str> {
        let mut out = Vec::new();
        if self.cfg.viscous_term == ViscousTerm::NestedSummation {
            out.push(VISCOUS_STRESS);
        }
        if self.cfg.polymer.is_some() {
            out.push(POLYMER_STRESS);
        }
        out
    }

    /// Whether the particles drift with v̂ = v + c (XSPH, the transport velocity or both).
    pub(super) fn moves_with_drift_correction(&self) -> bool {
        self.cfg.xsph != 0.0 || self.cfg.transport_pressure != 0.0
    }

    /// The time step Δt of the run, which the transport velocity's ½Δt a_t needs.
    pub fn with_transport_step(mut self, dt: f64) -> Self {
        self.transport_step = dt;
        self
    }

    pub(super) fn measures_traction(&self) -> bool {
        self.boundaries
            .inclusions
            .is_some_and(|g| g.traction_moments)
    }

    /// Whether the fluid forms its Newtonian stress η(G + Gᵀ − (2/d) tr G I): with the nested
    /// summation it enters the momentum equation; with Morris's term it is only measured (the
    /// viscometric observables), when a polymer or inclusions make the run a viscometric one.
    pub(super) fn forms_viscous_stress(cfg: &SphCfg, inclusions: bool) -> bool {
        cfg.viscous_term == ViscousTerm::NestedSummation
            || ((cfg.polymer.is_some() || inclusions) && cfg.viscosity > 0.0)
    }

    /// Whether the momentum pass gathers its sums in lanes (`lanes.rs`): on a CPU with
    /// AVX-512 (elsewhere the AVX2 scatter is faster than the portable lanes), fluid only, the
    /// pressure, Morris's term and the nested summation's stress in pair form, nothing else
    /// accumulated. (The kernel checks the same at run time and scatters when it does not
    /// hold.)
    pub(super) fn momentum_in_lanes(&self) -> bool {
        Isa::current().has_avx512()
            && self.passes.contains(&Pass::Momentum)
            && !self.boundaries.any()
            && self.inclusions.is_none()
            && self.polymer_stress.is_none()
            && self.xsph.is_none()
            && self.traction_moment.is_none()
            && self.cfg.derivatives == Derivatives::Sph
    }

    pub(super) fn typical(&self) -> (f64, f64, f64) {
        let c0 = self.cfg.sound_speed;
        let rho0 = self.cfg.rest_density;
        let dw = with_kernel!(self.cfg.kernel, self.cfg.smoothing_length, D, |k| k
            .max_abs_dw());
        let w0 = with_kernel!(self.cfg.kernel, self.cfg.smoothing_length, D, |k| k.w(0.0));
        let gradient = self.mass / rho0 * c0 * dw;
        let momentum = self.mass * self.mass * (c0 * c0 / rho0) * dw;
        (self.mass * w0, gradient, momentum)
    }

    /// What follows the velocity gradient G_i (`sums`: D² per owned particle, row-major
    /// ∂v^a/∂x^b): the nested summation's Newtonian stress (1 − s) η (G + Gᵀ − (2/d) tr G I),
    /// the dumbbells' κ, the constitutive polymer rate.
    pub(super) fn finish_gradient(&mut self, p: &mut Particles<D>, sums: &[f64]) {
        if let Some(stress) = self.stress {
            let eta = self.cfg.viscosity * (1.0 - self.cfg.morris_share);
            let out = &mut p.extra[stress].data;
            for (i, g) in sums.chunks_exact(D * D).enumerate() {
                let trace: f64 = (0..D).map(|a| g[a * D + a]).sum();
                for a in 0..D {
                    for b in 0..D {
                        let mut s = g[a * D + b] + g[b * D + a];
                        if a == b {
                            s -= 2.0 / D as f64 * trace;
                        }
                        out[i * D * D + a * D + b] = eta * s;
                    }
                }
            }
        }
        if let Some(g) = self.velocity_gradient {
            // The dumbbells' κ for their next step (row-major ∂v^a/∂x^b).
            p.extra[g].data[..sums.len()].copy_from_slice(sums);
        }
        if let (Some(model), Some(tau), Some(rate)) =
            (self.polymer, self.polymer_stress, self.polymer_rate)
        {
            let w = packed_width(D);
            let mut row = [0.0; 6];
            let mut out = [0.0; 6];
            for (i, g) in sums.chunks_exact(D * D).enumerate() {
                row[..w].copy_from_slice(&p.extra[tau].data[i * w..(i + 1) * w]);
                let g: [[f64; D]; D] =
                    std::array::from_fn(|a| std::array::from_fn(|b| g[a * D + b]));
                model.rate::<D>(&row[..w], &g, &mut out[..w]);
                p.extra[rate].data[i * w..(i + 1) * w].copy_from_slice(&out[..w]);
            }
        }
    }

    /// The MSPH and mirror-wall passes (`[fluid] derivatives = "msph"`,
    /// docs/theory/msph_dumbbells.md §1.3, §1.6, §5.1), with the truncated Gaussian kernel.
    pub(super) fn run_msph(
        &mut self,
        pass: Pass,
        p: &mut Particles<D>,
        full: &FullList,
    ) -> Result<(), msph::NotFinite> {
        let h = self.cfg.smoothing_length;
        let kernel = kernels::TruncatedGaussian::new(h, D);
        let nu = unknowns(D);
        let n = p.n_owned;
        let fluid_only = self.boundaries.walls.is_none_or(|_| self.mirror.is_some());
        match pass {
            Pass::WallMirror => {
                let Some(mirror) = self.mirror else {
                    return Ok(());
                };
                let (density, velocity) = (
                    self.density,
                    self.boundaries
                        .walls
                        .map_or(usize::MAX, |w| w.mirror_velocity),
                );
                let wall_velocity = self.boundaries.walls.map_or([[0.0; D]; 2], |w| w.velocity);
                let mut fitted: Vec<(usize, [f64; D], f64)> = Vec::new();
                let fallbacks = {
                    let pr = &*p;
                    mirror.fit(
                        &kernel,
                        pr,
                        D + 1,
                        |f, out| {
                            out[0] = pr.extra[density].data[f];
                            out[1..].copy_from_slice(&pr.vel[f]);
                        },
                        |fit| {
                            let u = wall_velocity[fit.side];
                            fitted.push((
                                fit.particle,
                                std::array::from_fn(|d| 2.0 * u[d] - fit.value[1 + d]),
                                fit.value[0],
                            ));
                        },
                    )
                };
                self.mirror_fallbacks.shepard += fallbacks.shepard;
                self.mirror_fallbacks.empty += fallbacks.empty;
                // Boundary particles without a fit keep ρ₀ and their wall's velocity.
                for w in 0..n {
                    let s = p.species_of(w);
                    if is_wall(s) {
                        let u = wall_velocity[usize::from(s == UPPER_WALL)];
                        p.extra[density].data[w] = self.cfg.rest_density;
                        p.extra[velocity].data[w * D..(w + 1) * D].copy_from_slice(&u);
                    }
                }
                for (w, v, rho) in fitted {
                    p.extra[density].data[w] = rho;
                    p.extra[velocity].data[w * D..(w + 1) * D].copy_from_slice(&v);
                }
                Ok(())
            }
            Pass::MsphGradient => {
                // The velocity each particle contributes: a mirror wall's fitted one.
                let mirror_velocity = self
                    .boundaries
                    .walls
                    .map_or(usize::MAX, |w| w.mirror_velocity);
                let mut values = std::mem::take(&mut self.values);
                values.clear();
                for j in 0..p.len() {
                    let s = p.species_of(j);
                    if mirror_velocity != usize::MAX && is_wall(s) {
                        values
                            .extend_from_slice(&p.extra[mirror_velocity].data[j * D..(j + 1) * D]);
                    } else {
                        values.extend_from_slice(&p.vel[j]);
                    }
                }
                let k = MomentKernel {
                    kernel,
                    mass: self.mass,
                    density: &p.extra[self.density].data,
                    values: &values,
                    fields: D,
                    matrix: true,
                    fluid_only,
                };
                let mut sums = std::mem::take(&mut self.sums);
                let r = k.gather(p, full, &mut sums);
                let width = nu * nu + nu * D;
                let result = r.map(|()| {
                    // Per particle: its derivative form and its D² gradient, on the pool.
                    let solved: Vec<(Local<D>, [f64; 9])> = sums
                        .par_chunks_exact(width)
                        .enumerate()
                        .with_min_len(16)
                        .map(|(i, row)| {
                            let mut g = [0.0; 9];
                            if !k.active(p, i) {
                                return (Local::Undetermined, g);
                            }
                            let local = Local::<D>::new(&row[..nu * nu], h);
                            for a in 0..D {
                                let b = &row[nu * nu + a * nu..nu * nu + (a + 1) * nu];
                                let ga = local.gradient(b, values[i * D + a]);
                                g[a * D..(a + 1) * D].copy_from_slice(&ga);
                            }
                            (local, g)
                        })
                        .collect();
                    self.local.clear();
                    let mut gradient = vec![0.0; n * D * D];
                    for (i, (local, g)) in solved.into_iter().enumerate() {
                        if k.active(p, i) {
                            match local {
                                Local::Second { .. } => {}
                                Local::First { .. } => self.msph_first_order += 1,
                                Local::Undetermined => self.msph_undetermined += 1,
                            }
                        }
                        gradient[i * D * D..(i + 1) * D * D].copy_from_slice(&g[..D * D]);
                        self.local.push(local);
                    }
                    gradient
                });
                self.sums = sums;
                self.values = values;
                let gradient = result?;
                self.finish_gradient(p, &gradient);
                Ok(())
            }
            Pass::WallStress => {
                let Some(mirror) = self.mirror else {
                    return Ok(());
                };
                let pw = packed_width(D);
                let polymer = self.polymer_stress;
                let viscous = self
                    .stress
                    .filter(|_| self.cfg.viscous_term == ViscousTerm::NestedSummation);
                let count = polymer.map_or(0, |_| pw) + viscous.map_or(0, |_| D * D);
                let mut fitted: Vec<(usize, Vec<f64>)> = Vec::new();
                let fallbacks = {
                    let pr = &*p;
                    mirror.fit(
                        &kernel,
                        pr,
                        count,
                        |f, out| {
                            let mut k = 0;
                            if let Some(t) = polymer {
                                out[..pw].copy_from_slice(&pr.extra[t].data[f * pw..(f + 1) * pw]);
                                k = pw;
                            }
                            if let Some(v) = viscous {
                                out[k..]
                                    .copy_from_slice(&pr.extra[v].data[f * D * D..(f + 1) * D * D]);
                            }
                        },
                        |fit| {
                            let extrapolated = (0..count)
                                .map(|q| {
                                    fit.value[q]
                                        + (0..D)
                                            .map(|d| fit.slope[q * D + d] * fit.offset[d])
                                            .sum::<f64>()
                                })
                                .collect();
                            fitted.push((fit.particle, extrapolated));
                        },
                    )
                };
                self.mirror_fallbacks.shepard += fallbacks.shepard;
                self.mirror_fallbacks.empty += fallbacks.empty;
                for w in 0..n {
                    let s = p.species_of(w);
                    if is_wall(s) {
                        if let Some(t) = polymer {
                            p.extra[t].data[w * pw..(w + 1) * pw].fill(0.0);
                        }
                        if let Some(v) = viscous {
                            p.extra[v].data[w * D * D..(w + 1) * D * D].fill(0.0);
                        }
                    }
                }
                for (w, values) in fitted {
                    if let Some(t) = polymer {
                        p.extra[t].data[w * pw..(w + 1) * pw].copy_from_slice(&values[..pw]);
                    }
                    if let Some(v) = viscous {
                        let k = polymer.map_or(0, |_| pw);
                        p.extra[v].data[w * D * D..(w + 1) * D * D].copy_from_slice(&values[k..]);
                    }
                }
                Ok(())
            }
            Pass::MsphDivergence => {
                // σ = −pI + σ̄ + τ of every particle, packed symmetric.
                let pw = packed_width(D);
                let polymer = self.polymer_stress;
                let viscous = self
                    .stress
                    .filter(|_| self.cfg.viscous_term == ViscousTerm::NestedSummation);
                let mut values = std::mem::take(&mut self.values);
                values.clear();
                for j in 0..p.len() {
                    let pressure = self.cfg.pressure(p.extra[self.density].data[j]);
                    for a in 0..D {
                        for b in a..D {
                            let mut s = if a == b { -pressure } else { 0.0 };
                            if let Some(t) = polymer {
                                s += p.extra[t].data[j * pw + packed_index::<D>(a, b)];
                            }
                            if let Some(v) = viscous {
                                s += p.extra[v].data[j * D * D + a * D + b];
                            }
                            values.push(s);
                        }
                    }
                }
                // The packed order of (a, b), a ≤ b, as pushed above.
                let order: Vec<(usize, usize)> =
                    (0..D).flat_map(|a| (a..D).map(move |b| (a, b))).collect();
                let k = MomentKernel {
                    kernel,
                    mass: self.mass,
                    density: &p.extra[self.density].data,
                    values: &values,
                    fields: pw,
                    matrix: false,
                    fluid_only,
                };
                let mut sums = std::mem::take(&mut self.sums);
                let r = k.gather(p, full, &mut sums);
                let result = r.map(|()| {
                    let local = &self.local;
                    let divergence: Vec<[f64; D]> = sums
                        .par_chunks_exact(nu * pw)
                        .enumerate()
                        .with_min_len(16)
                        .map(|(i, row)| {
                            let mut div = [0.0; D];
                            let Some(local) = local.get(i) else {
                                return div;
                            };
                            for (q, &(a, b)) in order.iter().enumerate() {
                                let g =
                                    local.gradient(&row[q * nu..(q + 1) * nu], values[i * pw + q]);
                                // ∂_b σ_ab into component a, and ∂_a σ_ba into b.
                                div[a] += g[b];
                                if a != b {
                                    div[b] += g[a];
                                }
                            }
                            div
                        })
                        .collect();
                    for (i, div) in divergence.iter().enumerate() {
                        let m_over_rho = self.mass / p.extra[self.density].data[i];
                        for d in 0..D {
                            p.force[i][d] += m_over_rho * div[d];
                        }
                    }
                });
                self.sums = sums;
                self.values = values;
                result
            }
            _ => unreachable!("not an MSPH pass"),
        }
    }

    pub(super) fn run<K: Kernel>(
        &mut self,
        kernel: K,
        pass: Pass,
        p: &mut Particles<D>,
        list: &NeighbourList<D>,
        full: &FullList,
    ) -> Result<(), crate::models::gather::PairError> {
        // Bounds of the exact sums. The scales exist to stop a blown-up run (a term not finite
        // or absurdly large) with the pair named; the fixed-point sum resolves 2⁻¹⁰² of its
        // scale, so a headroom of 10⁸ over a term's typical size still resolves it to ~10⁻²³.
        const HEADROOM: f64 = 1e8;
        let (density_scale, gradient_scale, momentum_scale) = self.typical();
        let mut sums = std::mem::take(&mut self.sums);
        let n = p.n_owned;
        let result = match pass {
            Pass::Density => {
                let k = DensityKernel {
                    kernel,
                    mass: self.mass,
                    // Each term is at most m W(0): an exact bound.
                    scales: [Scale::covering(density_scale)],
                };
                scatter(&k, p, list, &mut self.scatter, &mut sums).map(|()| {
                    p.extra[self.density].data[..n].copy_from_slice(&sums);
                })
            }
            Pass::InclusionImage => {
                let Some(geometry) = self.boundaries.inclusions else {
                    return Ok(());
                };
                let velocity = self.cfg.sound_speed;
                let w0 = kernel.w(0.0);
                let support = self.cfg.support();
                // Terms: W d² ≤ W(0) r_s², W d |u| ≤ W(0) r_s c₀ (velocities of order c₀ at
                // most in a run that has not blown up).
                let mut scales = vec![Scale::covering(HEADROOM * w0 * support * support)];
                scales.extend(vec![
                    Scale::covering(HEADROOM * w0 * support * velocity);
                    1 + D
                ]);
                let k = ImageKernel {
                    kernel,
                    radius: geometry.radius,
                    offset: geometry.offset,
                    scales,
                };
                gather(&k, p, full, &mut sums).map(|()| {
                    finish_images(p, &sums, geometry.radius, geometry.offset, geometry.image);
                })
            }
            Pass::Gradient => {
                let corrected = self.cfg.velocity_gradient == GradientEstimate::Corrected;
                let mut scales = vec![Scale::covering(HEADROOM * gradient_scale); D * D];
                if corrected {
                    // M_i terms: (m/ρ) |W'| r ≤ the gradient terms' bound with r_s for c₀.
                    let lattice = gradient_scale / self.cfg.sound_speed * self.cfg.support();
                    scales.extend(vec![Scale::covering(HEADROOM * lattice); D * D]);
                }
                let width = scales.len();
                let k = GradientKernel {
                    kernel,
                    mass: self.mass,
                    density: &p.extra[self.density].data,
                    boundaries: self.boundaries,
                    corrected,
                    scales,
                };
                // Fluid only, with AVX-512: the vector lanes; otherwise the generic lanes
                // (scalar pair terms, vector fixed-point words); failing both, pair by pair.
                let isa = Isa::current();
                let r = if (isa.has_avx512() && k.gather_lanes(isa, p, full.lanes(), &mut sums))
                    || gather_in_lanes(isa, &k, p, full, &mut sums)
                {
                    Ok(())
                } else {
                    gather(&k, p, full, &mut sums)
                };
                r.map(|()| {
                    if corrected {
                        self.uncorrected_gradients +=
                            apply_gradient_correction::<D>(&mut sums, width) as u64;
                        // The rows become G_i alone, D² wide, for what follows.
                        let mut w = 0;
                        for r in 0..sums.len() / width {
                            for q in 0..D * D {
                                sums[w] = sums[r * width + q];
                                w += 1;
                            }
                        }
                        sums.truncate(w);
                    }
                    self.finish_gradient(p, &sums);
                })
            }
            Pass::Momentum => {
                let c2 = self.cfg.sound_speed * self.cfg.sound_speed;
                let c0_velocity = self.cfg.sound_speed;
                let (eos, rho0) = (self.cfg.equation_of_state, self.cfg.rest_density);
                let density = &p.extra[self.density].data;
                self.p_over_rho2.clear();
                let background = self.cfg.background_pressure;
                // One loop per equation of state, so that each vectorises (the same
                // operations as the match inside the loop).
                if background == 0.0 {
                    match eos {
                        EquationOfState::Tait => {
                            self.p_over_rho2.extend(density.iter().map(|&rho| {
                                SphCfg::pressure_over_rho2(EquationOfState::Tait, c2, rho0, rho)
                            }))
                        }
                        EquationOfState::Quadratic => {
                            self.p_over_rho2.extend(density.iter().map(|&rho| {
                                SphCfg::pressure_over_rho2(
                                    EquationOfState::Quadratic,
                                    c2,
                                    rho0,
                                    rho,
                                )
                            }))
                        }
                    }
                } else {
                    self.p_over_rho2.extend(density.iter().map(|&rho| {
                        SphCfg::pressure_over_rho2(eos, c2, rho0, rho) + background / (rho * rho)
                    }));
                }
                self.inv_density.clear();
                self.inv_density
                    .extend(density.iter().map(|&rho| 1.0 / rho));
                let lanes = self.momentum_in_lanes();
                self.stress_over_rho2.clear();
                if let Some(stress) = self
                    .stress
                    .filter(|_| lanes && self.cfg.viscous_term == ViscousTerm::NestedSummation)
                {
                    let stress = &p.extra[stress].data;
                    self.stress_over_rho2.extend(
                        stress
                            .chunks_exact(D * D)
                            .zip(density)
                            .flat_map(|(s, &rho)| s.iter().map(move |&c| c / (rho * rho))),
                    );
                }
                let continuity = self.rate.is_some();
                let xsph_first = D + usize::from(continuity);
                let moment_first = xsph_first + if self.xsph.is_some() { D } else { 0 };
                let width = moment_first
                    + if self.traction_moment.is_some() {
                        D * D
                    } else {
                        0
                    };
                let mut scales = vec![Scale::covering(HEADROOM * momentum_scale); width];
                let mut parities = vec![Parity::Odd; width];
                if continuity {
                    scales[D] = Scale::covering(HEADROOM * gradient_scale * rho0);
                    parities[D] = Parity::Even;
                }
                // XSPH terms: at most ε (m/ρ) W(0) |v|, |v| bounded by c₀ in any sane run;
                // transport terms: ½Δt m p_t (2/ρ²) |∇W| (a pressure term's m² (p/ρ²) |∇W|
                // times ½Δt/m, with p_t for p), ρ ≥ ρ₀/2 in any sane run.
                let transport = 0.5 * self.transport_step * self.cfg.transport_pressure;
                let transport_scale = momentum_scale / self.mass * transport * 8.0 / (c2 * rho0);
                for scale in &mut scales[xsph_first..moment_first] {
                    *scale = Scale::covering(
                        HEADROOM * (density_scale / rho0 * c0_velocity + transport_scale),
                    );
                }
                // Traction moments: a pair force times a radius.
                let radius = self.inclusions.as_ref().map_or(0.0, |inc| inc.radius);
                for scale in &mut scales[moment_first..] {
                    *scale = Scale::covering(HEADROOM * momentum_scale * radius);
                }
                let k = MomentumKernel {
                    kernel,
                    mass: self.mass,
                    density,
                    inv_density: &self.inv_density,
                    p_over_rho2: &self.p_over_rho2,
                    // With Morris's term a polymer fluid's viscous stress is only measured.
                    stress: self
                        .stress
                        .filter(|_| self.cfg.viscous_term == ViscousTerm::NestedSummation)
                        .map(|s| p.extra[s].data.as_slice()),
                    stress_over_rho2: (!self.stress_over_rho2.is_empty())
                        .then_some(self.stress_over_rho2.as_slice()),
                    polymer: self.polymer_stress.map(|s| p.extra[s].data.as_slice()),
                    two_eta_morris: match self.cfg.viscous_term {
                        ViscousTerm::Morris => 2.0 * self.cfg.viscosity,
                        ViscousTerm::NestedSummation => {
                            2.0 * self.cfg.viscosity * self.cfg.morris_share
                        }
                    },
                    regulariser: self.cfg.morris_regularisation
                        * self.cfg.smoothing_length
                        * self.cfg.smoothing_length,
                    continuity,
                    xsph_eps_mass: self.cfg.xsph * self.mass,
                    transport: -transport * self.mass,
                    pairwise_stress: self.cfg.derivatives == Derivatives::Sph,
                    boundaries: self.boundaries,
                    scales,
                    parities,
                };
                // The momentum flux, on the steps the diagnostics sample (with MSPH derivatives
                // the stresses are not pair forces: validation refuses the flux there).
                let flux = (self.flux_wanted && k.pairwise_stress)
                    .then(|| momentum_flux::momentum_virial(&k, p, list));
                let gathered = lanes && k.gather_lanes(Isa::current(), p, full.lanes(), &mut sums);
                let r = if gathered {
                    Ok(())
                } else {
                    scatter(&k, p, list, &mut self.scatter, &mut sums)
                };
                self.flux = flux;
                r.map(|()| {
                    let mf: [f64; D] = std::array::from_fn(|d| self.mass * self.body_force[d]);
                    let species = p.species.as_deref();
                    for (i, s) in sums.chunks_exact(width).enumerate() {
                        let fluid = species.is_none_or(|sp| sp[i] == FLUID);
                        let f = &mut p.force[i];
                        for d in 0..D {
                            f[d] += s[d];
                            if fluid {
                                f[d] += mf[d];
                            }
                        }
                    }
                    if let Some(rate) = self.rate {
                        let out = &mut p.extra[rate].data;
                        for (i, s) in sums.chunks_exact(width).enumerate() {
                            out[i] = s[D];
                        }
                    }
                    if let Some(xsph) = self.xsph {
                        let out = &mut p.extra[xsph].data;
                        for (i, s) in sums.chunks_exact(width).enumerate() {
                            out[i * D..(i + 1) * D].copy_from_slice(&s[xsph_first..moment_first]);
                        }
                    }
                    if let Some(moment) = self.traction_moment {
                        let out = &mut p.extra[moment].data;
                        for (i, s) in sums.chunks_exact(width).enumerate() {
                            out[i * D * D..(i + 1) * D * D].copy_from_slice(&s[moment_first..]);
                        }
                    }
                })
            }
            Pass::WallMirror | Pass::MsphGradient | Pass::WallStress | Pass::MsphDivergence => {
                unreachable!("MSPH passes run in run_msph")
            }
        };
        self.sums = sums;
        result
    }
}

impl<const D: usize> ParticleModel<D> for SphModel<D> {
    fn name(&self) -> &'static str {
        "sph"
    }

    fn cutoff(&self) -> f64 {
        if self.cfg.derivatives == Derivatives::Msph {
            // MSPH counts the neighbours at exactly r = 2h (W'(2h) ≠ 0).
            self.cfg.support() * (1.0 + 1e-9)
        } else {
            self.cfg.support()
        }
    }

    fn fields(&self) -> Vec<FieldSpec> {
        let mut f = Vec::new();
        if self.cfg.density == DensityMethod::Summation {
            f.push(FieldSpec {
                name: DENSITY,
                kind: FieldKind::Scalar,
                flags: FieldFlags::DERIVED,
            });
        } else {
            f.push(FieldSpec {
                name: DENSITY,
                kind: FieldKind::Scalar,
                flags: FieldFlags::STATE,
            });
            f.push(FieldSpec {
                name: DENSITY_RATE,
                kind: FieldKind::Scalar,
                flags: FieldFlags::STATE,
            });
        }
        if Self::forms_viscous_stress(&self.cfg, self.inclusions.is_some()) {
            f.push(FieldSpec {
                name: VISCOUS_STRESS,
                kind: FieldKind::Tensor,
                flags: FieldFlags::DERIVED,
            });
        }
        match &self.cfg.polymer {
            Some(poly) if poly.is_ensemble() => {
                // τ is the ensembles' Kramers stress, derived anew after every ensemble step
                // (and on restart) from the connectors, which are the state.
                f.push(FieldSpec {
                    name: POLYMER_STRESS,
                    kind: FieldKind::Values(packed_width(D)),
                    flags: FieldFlags::DERIVED,
                });
                // Like the forces: of the last evaluation, used by the next ensemble step, so
                // kept across a restart.
                f.push(FieldSpec {
                    name: VELOCITY_GRADIENT,
                    kind: FieldKind::Tensor,
                    flags: FieldFlags::STATE,
                });
            }
            Some(_) => {
                for name in [POLYMER_STRESS, POLYMER_STRESS_RATE] {
                    // The rate, like the forces: of the last evaluation, used by the next step.
                    f.push(FieldSpec {
                        name,
                        kind: FieldKind::Values(packed_width(D)),
                        flags: FieldFlags::STATE,
                    });
                }
            }
            None => {}
        }
        if self.mirror.is_some() {
            f.push(FieldSpec {
                name: MIRROR_VELOCITY,
                kind: FieldKind::Vector,
                flags: FieldFlags::DERIVED,
            });
        }
        if self.inclusions.is_some() {
            f.push(FieldSpec {
                name: INCLUSION_OFFSET,
                kind: FieldKind::Vector,
                flags: FieldFlags::STATE,
            });
        }
        if self.passes.contains(&Pass::InclusionImage) {
            f.push(FieldSpec {
                name: INCLUSION_IMAGE_VELOCITY,
                kind: FieldKind::Vector,
                flags: FieldFlags::DERIVED,
            });
        }
        if self.measures_traction() {
            f.push(FieldSpec {
                name: INCLUSION_TRACTION_MOMENT,
                kind: FieldKind::Tensor,
                flags: FieldFlags::DERIVED,
            });
        }
        if self.moves_with_drift_correction() {
            // Like the forces: of the last evaluation, used by the next drift, so kept across a
            // restart.
            f.push(FieldSpec {
                name: XSPH_CORRECTION,
                kind: FieldKind::Vector,
                flags: FieldFlags::STATE,
            });
        }
        f
    }

    fn drift_correction(&self) -> Option<&'static str> {
        self.moves_with_drift_correction()
            .then_some(XSPH_CORRECTION)
    }

    fn passes(&self) -> Vec<PassSpec> {
        let mut density_refreshed = false;
        // The inclusion offsets never change; the ghosts get them before the first pass that
        // sees a boundary velocity (they persist until the next rebuild).
        let mut offsets_refreshed = self.inclusions.is_none();
        // The fitted image velocities, formed on the owners, reach the ghosts before the first
        // pass that sees a boundary velocity after them.
        let mut images_pending = false;
        self.passes
            .iter()
            .map(|pass| match pass {
                Pass::Density => PassSpec {
                    name: "summation density",
                    ghost_fields: Vec::new(),
                },
                Pass::InclusionImage => {
                    images_pending = true;
                    PassSpec {
                        name: "inclusion image velocities",
                        ghost_fields: Vec::new(),
                    }
                }
                Pass::Gradient => {
                    density_refreshed = true;
                    let mut ghost_fields = vec![DENSITY];
                    if !offsets_refreshed {
                        ghost_fields.push(INCLUSION_OFFSET);
                        offsets_refreshed = true;
                    }
                    if images_pending {
                        ghost_fields.push(INCLUSION_IMAGE_VELOCITY);
                        images_pending = false;
                    }
                    PassSpec {
                        name: "velocity gradient",
                        ghost_fields,
                    }
                }
                Pass::Momentum => {
                    let mut ghost_fields = Vec::new();
                    if !density_refreshed {
                        ghost_fields.push(DENSITY);
                    }
                    if !offsets_refreshed {
                        ghost_fields.push(INCLUSION_OFFSET);
                    }
                    if images_pending {
                        ghost_fields.push(INCLUSION_IMAGE_VELOCITY);
                    }
                    if self.cfg.derivatives == Derivatives::Sph {
                        ghost_fields.extend(self.stress_fields());
                    }
                    PassSpec {
                        name: "momentum",
                        ghost_fields,
                    }
                }
                Pass::WallMirror => PassSpec {
                    name: "mirror walls: density and velocity",
                    ghost_fields: vec![DENSITY],
                },
                Pass::MsphGradient => {
                    density_refreshed = true;
                    let mut ghost_fields = vec![DENSITY];
                    if self.mirror.is_some() {
                        ghost_fields.push(MIRROR_VELOCITY);
                    }
                    PassSpec {
                        name: "MSPH velocity gradient",
                        ghost_fields,
                    }
                }
                Pass::WallStress => PassSpec {
                    name: "mirror walls: stress",
                    ghost_fields: self.stress_fields(),
                },
                Pass::MsphDivergence => PassSpec {
                    name: "MSPH stress divergence",
                    ghost_fields: self.stress_fields(),
                },
            })
            .collect()
    }

    fn uses_full_list(&self) -> bool {
        // The velocity-gradient passes gather (their terms carry 1/ρ_j, not symmetric); the
        // density pass scatters from the half list, and so does the momentum pass except in
        // a fluid-only scheme, whose momentum sums are gathered in lanes (`lanes`).
        self.passes.contains(&Pass::Gradient)
            || self.passes.contains(&Pass::InclusionImage)
            || self.passes.contains(&Pass::MsphGradient)
            || self.momentum_in_lanes()
    }

    fn integrated_fields(&self) -> Vec<Integrated> {
        let mut out = Vec::new();
        if self.cfg.density == DensityMethod::Continuity {
            out.push(Integrated {
                state: DENSITY,
                rate: DENSITY_RATE,
                boundary_particles: false,
            });
        }
        if self.polymer.is_some() {
            out.push(Integrated {
                state: POLYMER_STRESS,
                rate: POLYMER_STRESS_RATE,
                boundary_particles: true,
            });
        }
        out
    }

    fn snapshot_values(&self, name: &str, p: &Particles<D>) -> Option<Vec<f64>> {
        let n = p.n_owned;
        let rho = &p.extra[self.density].data[..n];
        match name {
            "density" => Some(rho.to_vec()),
            "pressure" => Some(rho.iter().map(|&r| self.cfg.pressure(r)).collect()),
            "polymer_stress" => {
                let f = &p.extra[self.polymer_stress?];
                Some(f.data[..n * f.width].to_vec())
            }
            _ => None,
        }
    }

    fn attach(&mut self, p: &mut Particles<D>, restarted: bool) -> Result<(), Error> {
        self.density = p
            .extra_index(DENSITY)
            .ok_or("the density field is not registered")?;
        self.rate = p.extra_index(DENSITY_RATE);
        self.stress = p.extra_index(VISCOUS_STRESS);
        self.xsph = p.extra_index(XSPH_CORRECTION);
        self.traction_moment = p.extra_index(INCLUSION_TRACTION_MOMENT);
        if self.cfg.polymer.is_some() {
            let tau = p
                .extra_index(POLYMER_STRESS)
                .ok_or("the polymer stress field is not registered")?;
            self.polymer_stress = Some(tau);
        }
        if self.polymer.is_some() {
            let rate = p
                .extra_index(POLYMER_STRESS_RATE)
                .ok_or("the polymer stress rate field is not registered")?;
            self.polymer_rate = Some(rate);
        }
        self.velocity_gradient = p.extra_index(VELOCITY_GRADIENT);
        if self.mirror.is_some()
            && let Some(w) = &mut self.boundaries.walls
        {
            w.mirror_velocity = p
                .extra_index(MIRROR_VELOCITY)
                .ok_or("the mirror velocity field is not registered")?;
        }
        if !restarted && self.rate.is_some() {
            // Continuity density starts at ρ₀ (the lattice is uniform).
            p.extra[self.density].data.fill(self.cfg.rest_density);
        }
        if let (Some(inc), Some(geometry)) = (&self.inclusions, &mut self.boundaries.inclusions) {
            let offset = p
                .extra_index(INCLUSION_OFFSET)
                .ok_or("the inclusion offset field is not registered")?;
            geometry.offset = offset;
            if self.passes.contains(&Pass::InclusionImage) {
                geometry.image = p
                    .extra_index(INCLUSION_IMAGE_VELOCITY)
                    .ok_or("the inclusion image velocity field is not registered")?;
            }
            if !restarted {
                // The particles inside a disc are its boundary particles (the species the
                // engine gives them follows the same test, [`InclusionsCfg::offset`]).
                for i in 0..p.n_owned {
                    if let Some(o) = inc.offset(&p.pos[i]) {
                        p.extra[offset].data[i * D..(i + 1) * D].copy_from_slice(&o);
                    }
                }
            }
        }
        Ok(())
    }

    fn measures(&self, o: crate::observable::Observable) -> bool {
        self.measures_observable(o)
    }

    fn observable_sums(
        &self,
        o: crate::observable::Observable,
        particles: &Particles<D>,
        ctx: &crate::models::interface::MeasureContext<'_, D>,
    ) -> Vec<crate::fixed_sum::FixedSum> {
        self.sums_of(o, particles, ctx)
    }

    fn observable_values(
        &self,
        o: crate::observable::Observable,
        sums: &[f64],
        ctx: &crate::models::interface::MeasureContext<'_, D>,
    ) -> Vec<(String, f64)> {
        self.values_of(o, sums, ctx)
    }

    fn counted_warnings(&self) -> Vec<(u64, &'static str)> {
        vec![
            (
                self.msph_first_order,
                "{n} MSPH systems (particle × evaluation) were solved to first order only: \
                 their h-scaled moment matrix had a 1-norm condition number above 10⁴ (a \
                 sparse or one-sided neighbourhood)",
            ),
            (
                self.msph_undetermined,
                "{n} MSPH systems (particle × evaluation) determined no derivative at all \
                 (an isolated particle): its gradients were set to zero",
            ),
            (
                self.mirror_fallbacks.shepard,
                "{n} mirror-wall fits (boundary particle × pass) had too few fluid particles \
                 for a linear fit and took their weighted mean",
            ),
            (
                self.mirror_fallbacks.empty,
                "{n} mirror-wall fits (boundary particle × pass) found no fluid particle within \
                 2h of the mirror point and kept ρ₀, the wall velocity and zero stress",
            ),
            (
                self.uncorrected_gradients,
                "{n} velocity-gradient estimates (particle × evaluation) kept the plain SPH form: \
             their moment matrix M_i had det M_i < 10⁻³ (too few neighbours); check the \
             neighbour count or the support",
            ),
        ]
    }

    fn pass(&mut self, pass: usize, ctx: PassContext<'_, D>) -> Result<PassOutput, Error> {
        let kind = self.passes[pass];
        let (kernel, h) = (self.cfg.kernel, self.cfg.smoothing_length);
        let (p, list, full) = (ctx.particles, ctx.list, ctx.full);
        let step = ctx.step;
        if matches!(kind, Pass::Momentum | Pass::MsphDivergence) {
            check_density(p, self.density, step)?;
        }
        self.flux_wanted = ctx.virial != crate::models::pair_loop::VirialScope::Off;
        let context = format!("SPH pass {kind:?}");
        match kind {
            Pass::WallMirror | Pass::MsphGradient | Pass::WallStress | Pass::MsphDivergence => {
                self.run_msph(kind, p, full).map_err(|e| {
                    Unstable::new(
                        Quantity::MomentSums,
                        Some(e.gid),
                        step,
                        format!("{e} ({context} at step {step})"),
                    )
                })
            }
            _ => with_kernel!(kernel, h, D, |k| self.run(k, kind, p, list, full))
                .map_err(|e| e.at_step(Quantity::PairForce, step, &context)),
        }?;
        let virial = self
            .flux
            .take()
            .transpose()
            .map_err(|e| e.at_step(Quantity::MomentumFlux, step, "SPH momentum flux"))?;
        Ok(PassOutput {
            virial,
            ..PassOutput::default()
        })
    }
}

/// Blow-up detector: a fluid particle whose density is zero, negative or not finite (continuity
/// density under too large a step, or a NaN from elsewhere) stops the run before the equation
/// of state turns it into a pressure, naming the particle (the lowest id on this rank).
pub(super) fn check_density<const D: usize>(
    p: &Particles<D>,
    density: usize,
    step: u64,
) -> Result<(), Unstable> {
    let rho = &p.extra[density].data;
    let bad = (0..p.n_owned)
        .filter(|&i| p.species_of(i) == FLUID && !(rho[i] > 0.0 && rho[i].is_finite()))
        .min_by_key(|&i| p.gid[i]);
    match bad {
        None => Ok(()),
        Some(i) => Err(Unstable::new(
            Quantity::Density,
            Some(p.gid[i]),
            step,
            format!(
                "particle {} has density ρ = {:e} (it must be positive and finite) at step \
                 {step}: {UNSTABLE} (reduce the time step, or use summation density, which \
                 cannot go negative)",
                p.gid[i], rho[i]
            ),
        )),
    }
}
