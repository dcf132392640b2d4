//! What the SPH fluid owns besides its passes ([`crate::models::FluidModel`]): validation
//! (`super::validate`), time-step limits (`super::time_step`), the observables it forms, its
//! `check` report, its memory, and how it is built with its companions (the dumbbell
//! ensembles of CONNFFESSIT).

use super::{DensityMethod, Derivatives, SphCfg, SphModel, ViscousTerm};
use crate::integrators::IntegratorCfg;
use crate::models::fluid_model::CaseView;
use crate::models::fluid_model::{
    BodyForce, BuildModels, Continuum, ContinuumPolymer, FluidModel, KindTraits, ModelMemory,
    SpeciesLayout, generic_support,
};
use crate::models::interface::ParticleModel;
use crate::observable::Observable;
use crate::spans::{CaseError, SpanIndex};

/// The smallest transport pressure, in units of the steady-shear tension τ_xx, that holds a
/// CONNFFESSIT fluid's particles ordered against its ensembles' noise (measured at Wi = 4:
/// 6 τ_xx reads η +4 %, 12.5 τ_xx +0.4 %; docs/validation.md).
pub const TRANSPORT_PRESSURE_PER_TENSION: f64 = 12.0;

impl KindTraits for SphCfg {
    const CARRIES_BOUNDARY_PARTICLES: bool = true;
    const KEYS: &'static [crate::key_doc::KeyDoc] = super::keys::KEYS;
}

impl FluidModel for SphCfg {
    fn kind(&self) -> &'static str {
        "sph"
    }

    fn cutoff(&self) -> f64 {
        self.support()
    }

    fn cutoff_key(&self) -> &'static str {
        "smoothing_length"
    }

    fn validate(&self, case: &dyn CaseView, ix: &SpanIndex) -> Result<(), CaseError> {
        super::validate::validate_sph(case, self, ix)
    }

    fn accepts_integrator(&self, integrator: &IntegratorCfg) -> Result<(), String> {
        if matches!(integrator, IntegratorCfg::GrootWarren(_))
            && self.density == DensityMethod::Continuity
        {
            return Err(
                "groot_warren does not integrate the continuity density; use \
                        kick_drift_kick, heun or midpoint"
                    .to_string(),
            );
        }
        Ok(())
    }

    fn time_step_limits(&self, case: &dyn CaseView) -> Vec<(String, f64)> {
        super::time_step::sph_limits(self, case.inclusions().is_some())
            .into_iter()
            .map(|(n, l)| (n.to_string(), l))
            .collect()
    }

    /// Momentum and, in a sheared box, the viscometric functions.
    fn default_observables(&self, case: &dyn CaseView) -> Vec<Observable> {
        let mut o = vec![Observable::Momentum];
        if case.shear_rate() != 0.0 {
            o.extend([
                Observable::Viscosity,
                Observable::FirstNormalStressDifference,
            ]);
            if case.dimension() == 3 {
                o.push(Observable::SecondNormalStressDifference);
            }
        }
        o
    }

    fn supports(&self, case: &dyn CaseView, o: Observable) -> Result<(), String> {
        match o {
            // The SPH constitutive stress σ̄ (viscous stress of the nested summation + polymer
            // stress) must be the whole deviatoric stress to be a viscometric measurement.
            Observable::ConstitutiveStress
                if self.viscous_term == ViscousTerm::NestedSummation
                    || self.polymer.is_some()
                    || (case.inclusions().is_some() && self.viscosity > 0.0) =>
            {
                Ok(())
            }
            _ if o.needs_pair_virial() && self.derivatives == Derivatives::Msph => Err(format!(
                "\"{}\" needs the momentum flux of pair forces, and with fluid.derivatives \
                 = \"msph\" the stresses enter as a per-particle divergence, not as pair \
                 forces; use \"constitutive_stress\" (the particles' own stress), or \
                 fluid.derivatives = \"sph\"",
                o.name()
            )),
            Observable::PolymerStressTrace if self.polymer.is_some() => Ok(()),
            Observable::DensityProfile => Ok(()),
            _ => generic_support(o),
        }
    }

    fn stress_parts(&self) -> Vec<&'static str> {
        // the pair parts of `super::momentum_flux`, after the total and the kinetic part
        vec!["total", "kinetic", "pressure", "viscous", "polymer"]
    }

    /// Morris's viscous force lies along v_ij and an inclusion takes a couple: the momentum
    /// flux is not symmetric.
    fn symmetric_stress(&self) -> bool {
        false
    }

    fn report(&self, case: &dyn CaseView, _density: f64, line: &mut dyn FnMut(String)) {
        let sph = self;
        let dt = case.dt();
        line(format!(
            "SPH: {} kernel h = {} (support {}), ρ₀ = {}, c₀ = {}, η = {}, {:?} EOS, {:?} \
             density, {:?} viscous term",
            sph.kernel.name(),
            sph.smoothing_length,
            sph.support(),
            sph.rest_density,
            sph.sound_speed,
            sph.viscosity,
            sph.equation_of_state,
            sph.density,
            sph.viscous_term
        ));
        if sph.derivatives == crate::models::sph::Derivatives::Msph {
            let morris = match sph.viscous_term {
                crate::models::sph::ViscousTerm::Morris => sph.viscosity,
                crate::models::sph::ViscousTerm::NestedSummation => {
                    sph.viscosity * sph.morris_share
                }
            };
            line(format!(
                "derivatives: MSPH (Zhang–Batra {0}×{0} moment systems, exact for quadratic \
                 fields); Morris (damping) viscosity {morris}",
                crate::models::sph::msph::unknowns(case.dimension())
            ));
            if morris == 0.0 {
                line(
                    "note: MSPH derivatives do not damp particle-scale velocity modes \
                     (docs/theory/msph_dumbbells.md §5.1); give a Morris viscosity \
                     (morris_share ≈ 0.1, or viscous_term = \"morris\" for the solvent)"
                        .to_string(),
                );
            }
        } else if sph.kernel == crate::models::sph::kernels::KernelKind::TruncatedGaussian {
            line(
                "note: the truncated Gaussian has W′(2h) ≠ 0 (pair forces jump as neighbours \
                 cross the support); with pairwise SPH the paper's channel came out 7–99 % \
                 off (docs/validation.md); it is MSPH's kernel: derivatives = \"msph\""
                    .to_string(),
            );
        }
        if sph.derivatives == crate::models::sph::Derivatives::Sph && sph.morris_share > 0.0 {
            line(format!(
                "viscosity split: {} by the nested summation, {} by Morris's term",
                sph.viscosity * (1.0 - sph.morris_share),
                sph.viscosity * sph.morris_share
            ));
        }
        if let Some(poly) = &sph.polymer {
            let gamma = case.shear_rate();
            let de = if gamma != 0.0 {
                format!(", De = λγ̇ = {}", poly.relaxation_time * gamma.abs())
            } else {
                String::new()
            };
            if poly.is_ensemble() {
                line(format!(
                    "dumbbells: {} per fluid particle, spring {:?}, scheme {:?}, {}; Kramers \
                     stress G(⟨QF(Q)⟩ − I) with G = η_p/λ = {}; noise {}",
                    poly.per_particle.unwrap_or(0),
                    poly.spring_law(),
                    poly.scheme_or_default(),
                    match poly.histogram_grid() {
                        Some(_) => "stored as BDDFS histograms".to_string(),
                        None => format!("{:?} precision", poly.connector_precision()),
                    },
                    poly.modulus(),
                    match poly.ensemble_noise() {
                        crate::models::dumbbell_settings::EnsembleNoise::Independent =>
                            "independent per particle",
                        crate::models::dumbbell_settings::EnsembleNoise::ConfigurationFields =>
                            "shared (Brownian configuration fields: the mean stress averages \
                             N_d independent dumbbells)",
                    }
                ));
            }
            for l in poly.model.check_lines(poly, case.dimension(), case.dt()) {
                line(l);
            }
            // A finitely extensible law: the zero-shear polymer viscosity is below η_p.
            let zero_shear = poly.model.zero_shear_factor(poly, case.dimension());
            let fene = zero_shear.map_or(1.0, |(f, _)| f);
            line(format!(
                "polymer: {:?}{}, η_p = {}, λ = {}, modulus η_p/λ = {}{de}; zero-shear \
                 viscosity η₀ = η + η_p{} = {:.6}, background pressure {}",
                poly.model,
                if poly.rotation {
                    ""
                } else {
                    " (rotation terms off)"
                },
                poly.viscosity,
                poly.relaxation_time,
                poly.viscosity / poly.relaxation_time,
                zero_shear.map_or(String::new(), |(_, label)| format!(" {label}")),
                sph.viscosity + poly.viscosity * fene,
                sph.background_pressure
            ));
            // The polymer stress passes through two SPH derivatives (G from v, then ∇·τ in
            // pair form); on the initial cubic lattice each scales a linear field by the
            // kernel's lattice sum, which does not tend to 1 as Δ → 0 at fixed r_s/Δ.
            let spacing = case.lattice_spacing();
            // (A support of more than 16 spacings has sums within 10⁻³ of 1 and would cost
            // a long loop.)
            if sph.derivatives == crate::models::sph::Derivatives::Sph
                && case.lattice() == crate::geometry::Lattice::Cubic
                && sph.support() / spacing <= 16.0
            {
                let sum =
                    crate::with_kernel!(sph.kernel, sph.smoothing_length, case.dimension(), |k| {
                        crate::models::sph::kernels::cubic_lattice_derivative_sum(
                            &k,
                            spacing,
                            case.dimension(),
                        )
                    });
                let corrected =
                    sph.velocity_gradient == crate::models::sph::GradientEstimate::Corrected;
                let factor = if corrected { sum } else { sum * sum };
                if (factor - 1.0).abs() > 0.01 {
                    line(format!(
                        "  note: on this lattice the SPH derivative of a linear field is \
                         {sum:.4} of the exact one (support {:.2}Δ), and the polymer stress \
                         passes through {}: η_p acts as {factor:.4} η_p and elastic waves \
                         run at {:.4} of √(η_p/(ρ₀λ)) at any Δ (measured, Oldroyd-B start-up \
                         Couette, λ = 0.05, β = 0.1: at Lucy 2.5Δ 1.3 % of U at t = 0.1 even \
                         at Δ = 0.005, at 3Δ 0.06 %; tools/sph_couette_rows.py); Lucy 3Δ \
                         gives 1.0008",
                        sph.support() / spacing,
                        if corrected {
                            "one (its ∇·τ; the corrected G is exact)"
                        } else {
                            "two (G, then ∇·τ)"
                        },
                        factor.sqrt()
                    ));
                }
            }
            if gamma != 0.0 {
                let de = poly.relaxation_time * gamma.abs();
                let tension = poly
                    .model
                    .steady_shear_tension(poly, gamma, case.dimension());
                line(format!(
                    "  steady-shear tension τ_xx ≈ {tension:.4}; background pressure {} = \
                     {:.1} τ_xx",
                    sph.background_pressure,
                    sph.background_pressure / tension
                ));
                if sph.transport_pressure > 0.0 {
                    line(format!(
                        "  transport velocity: p_t = {} = {:.1} τ_xx moves the particles only; \
                         unlike a background pressure it adds no lattice virial to the measured \
                         N₁ (docs/theory/sph_maxwell.md §1.14)",
                        sph.transport_pressure,
                        sph.transport_pressure / tension
                    ));
                    if poly.is_ensemble()
                        && sph.transport_pressure < TRANSPORT_PRESSURE_PER_TENSION * tension
                    {
                        // docs/validation.md, "Wi = 4: the transport pressure against τ_xx".
                        line(format!(
                            "  note: below {TRANSPORT_PRESSURE_PER_TENSION} τ_xx the transport \
                             velocity does not hold the particles the ensembles' noise disorders \
                             (measured, CONNFFESSIT shear at Wi = 4, τ_xx = 16, 1 000 dumbbells \
                             per particle, Lucy 4Δ: p_t = 3 and 6 τ_xx read η +5.0 % and +4.0 %, \
                             12.5 τ_xx +0.4 %, 25 τ_xx −0.8 % with the particles' own stress \
                             within 0.2 %): raise fluid.transport_pressure to about {:.0}",
                            2.0 * TRANSPORT_PRESSURE_PER_TENSION * tension
                        ));
                    }
                } else if sph.background_pressure > 0.0 {
                    line(format!(
                        "  note: the background pressure's pair forces carry momentum, and on a \
                         sheared lattice their virial adds about 0.005 p_b = {:.3} to the \
                         measured N₁ (docs/theory/sph_maxwell.md §1.14); \
                         fluid.transport_pressure in its place keeps the particles ordered \
                         without it",
                        0.005 * sph.background_pressure
                    ));
                }
                if sph.background_pressure < 4.0 * tension && sph.transport_pressure == 0.0 {
                    line(
                        "  note: below 4 τ_xx the tension feeds the SPH tensile instability \
                         (measured: Oldroyd-B and dumbbells at Wi = 3 with p_b = 1.7 τ_xx drift \
                         to η +6 %, N₁ +10 %; 5 τ_xx holds 0.3 %): raise \
                         fluid.background_pressure"
                            .into(),
                    );
                }
                let shared = poly.ensemble_noise()
                    == crate::models::dumbbell_settings::EnsembleNoise::ConfigurationFields;
                if poly.is_ensemble() && shared {
                    // The twin test (tests/sph_suite/connffessit.rs) and the sweep of
                    // tools/coupled_bias.py --noise configuration_fields.
                    line(format!(
                        "  configuration fields: every particle carries the same ensemble in \
                         homogeneous shear, so the coupling adds only the pair sums' lattice \
                         error (measured against the homogeneous twin at Wi = 2 and 4: η \
                         −0.24 %, N₁ within ±0.8 %); the error bar is that of {} dumbbells, \
                         not of {} times the particle count (docs/validation.md)",
                        poly.per_particle.unwrap_or(0),
                        poly.per_particle.unwrap_or(0),
                    ));
                } else if poly.is_ensemble() && sph.transport_pressure > 0.0 {
                    // The default scene's seeds and the longer runs of docs/validation.md
                    // ("The background pressure's virial, and the transport velocity").
                    line(format!(
                        "  expected bias of the measured η and N₁ (the momentum flux; 2D \
                         CONNFFESSIT shear, Lucy 4Δ, the transport velocity at p_t ≥ 12 τ_xx; \
                         measured 2026-11-27, tools/coupled_bias.py and docs/validation.md): \
                         1 000 dumbbells per particle: within 0.05 % (η) and 0.35 % (N₁) at \
                         Wi ≤ 1, −0.5 % and −0.7 % at Wi = 2, +0.4 % and +0.6 % at Wi = 4 \
                         (p_t = 12.5 τ_xx; −0.8 %, −0.7 % at 25 τ_xx); 100 per particle: η \
                         −0.3 to −0.9 %, N₁ −0.8 to −1.4 % at Wi = 0.5–2; a 3Δ support reads \
                         about 1 % lower. This scene: Wi = {de:.3}, {} dumbbells per particle, \
                         support {:.2}Δ, p_t = {:.1} τ_xx",
                        poly.per_particle.unwrap_or(0),
                        sph.support() / case.lattice_spacing(),
                        sph.transport_pressure / tension
                    ));
                } else if poly.is_ensemble() {
                    // The measured bias of the coupled shear (tools/coupled_bias.py, the
                    // table in docs/validation.md): what a user can expect at these settings.
                    line(format!(
                        "  expected bias of the measured η and N₁ (the momentum flux; 2D \
                         CONNFFESSIT shear, Lucy 3Δ, measured 2026-11-26, docs/validation.md): \
                         Wi ≤ 1, p_b = 5: η +1.5 % with 100 dumbbells per particle, +0.1 % \
                         with 1 000 (the noisy ensembles disorder the particles; p_b = 20 \
                         raises it); Wi = 2–4 with p_b = 5 τ_xx: η within ±2.5 %, N₁ within \
                         ±4.5 %; p_b below 5 τ_xx: errors of 3–17 %. This scene: Wi = {de:.3}, \
                         {} dumbbells per particle, p_b = {:.1} τ_xx; noise = \
                         \"configuration_fields\" removes the bias (check's note there)",
                        poly.per_particle.unwrap_or(0),
                        sph.background_pressure / tension
                    ));
                }
            }
        }
        let (binding, _) = super::time_step::sph_binding_limit(sph, case.inclusions().is_some());
        for (name, limit) in super::time_step::sph_limits(sph, case.inclusions().is_some()) {
            line(format!(
                "time step Δt = {dt}: {name} = {limit:.4e} [{}{}]",
                if dt <= limit { "ok" } else { "VIOLATED" },
                if name == binding { ", binding" } else { "" }
            ));
        }
        if let Some(w) = case.walls() {
            let axis = w.axis.index();
            let layers = case.wall_layer_count(axis);
            let (cells, _) = case.lattice_counts();
            let across: usize = (0..case.dimension())
                .filter(|&d| d != axis)
                .map(|d| cells[d])
                .product();
            line(format!(
                "walls along {}: {layers} boundary rows each side, {} boundary particles in \
                 all (besides the fluid's; {:?}), lower at {:?}, upper at {:?}",
                ["x", "y", "z"][axis],
                2 * layers * across,
                w.treatment,
                w.lower_velocity,
                w.upper_velocity
            ));
            // Morris's factor for the first fluid row (d_i = Δ/2) and the deepest image
            // inside the support (d_j ≤ r_s − Δ/2): β = 1 + d_j/d_i ≤ 2r_s/Δ.
            let spacing = case.lattice_spacing();
            let widest = 2.0 * sph.kernel.support_factor() * sph.smoothing_length / spacing;
            let uncapped = (widest + 1e-9).floor() - 1.0;
            if w.treatment == crate::models::sph::WallTreatment::Morris && w.morris_cap < uncapped {
                line(format!(
                    "  note: the cap β ≤ {} clips Morris's images of the first fluid row (β = \
                     1 + d_j/d_i reaches ≈ {widest:.1}): a partial slip (measured in the \
                     paper's channel: +2.6 % Newtonian, +4.5 % UCM at the centre with 1.5); \
                     flat walls keep the factor bounded, so walls.morris_cap = {} removes it",
                    w.morris_cap, uncapped
                ));
            }
        }
        if let Some(inc) = case.inclusions() {
            let phi = inc.volume_fraction(case.lengths());
            let shape = if case.dimension() == 2 {
                "discs"
            } else {
                "spheres"
            };
            let images = match inc.images {
                crate::models::sph::InclusionImages::Fitted => {
                    "fitted image velocities (a profile vanishing at the surface)".to_string()
                }
                crate::models::sph::InclusionImages::Morris => {
                    format!("Morris images capped at β = {}", inc.morris_cap)
                }
            };
            line(format!(
                "inclusions: {} fixed {shape} of radius {}, volume fraction φ = {phi:.5}, \
                 {images}; a Newtonian fluid's mean stress over the \
                 fluid is exactly 1/(1 − φ) = {:.5} of ηγ̇{}",
                inc.centres.len(),
                inc.radius,
                1.0 / (1.0 - phi),
                if case.dimension() == 2 {
                    format!(
                        "; dilute composite viscosity η(1 + 3φ) = {:.5} η (fixed discs)",
                        1.0 + 3.0 * phi
                    )
                } else {
                    String::new()
                }
            ));
        }
    }

    /// The dumbbell-steps of the ensembles and their time.
    fn cost_report(&self, case: &dyn CaseView, particles: f64, line: &mut dyn FnMut(String)) {
        if let Some(p) = self.polymer.as_ref().filter(|p| p.is_ensemble()) {
            // An upper bound: wall and inclusion particles carry none.
            let work = particles * p.per_particle.unwrap_or(0) as f64 * case.steps() as f64;
            line(format!(
                "dumbbells: ≤ {work:.3e} dumbbell-steps; at ~5·10⁷ per second per core \
                 (Hookean, docs/performance.md) about {:.1} core-seconds",
                work / 5e7
            ));
        }
    }

    /// The fluid's fields, its full neighbour list and the interleaved rows of its lanes, and
    /// the dumbbells a fluid particle carries.
    fn memory(&self, case: &dyn CaseView) -> ModelMemory {
        ModelMemory {
            numbers_per_particle: if case.dimension() == 2 {
                field_numbers::<2>(case, self)
            } else {
                field_numbers::<3>(case, self)
            },
            full_lists: 2.0,
            ensemble_bytes: self
                .polymer
                .as_ref()
                .filter(|p| p.is_ensemble())
                .map_or(0.0, |p| p.bytes_per_particle(case.dimension())),
        }
    }

    fn body_force(&self) -> BodyForce<'_> {
        BodyForce {
            acceleration: &self.body_force,
            reverse: false,
        }
    }

    fn snapshot_quantities(
        &self,
        _case: &dyn CaseView,
    ) -> Vec<crate::models::interface::SnapshotQuantity> {
        use crate::models::interface::{SnapshotQuantity, SnapshotShape};
        let mut q = vec![
            SnapshotQuantity {
                name: "density",
                shape: SnapshotShape::Scalar,
            },
            SnapshotQuantity {
                name: "pressure",
                shape: SnapshotShape::Scalar,
            },
        ];
        if let Some(polymer) = &self.polymer {
            q.push(SnapshotQuantity {
                name: "polymer_stress",
                shape: SnapshotShape::SymmetricTensor,
            });
            // ⟨QQ⟩ of explicit dumbbells (a BDDFS histogram keeps no connectors between steps).
            if polymer.is_ensemble() && polymer.histogram_grid().is_none() {
                q.push(SnapshotQuantity {
                    name: "conformation",
                    shape: SnapshotShape::SymmetricTensor,
                });
            }
        }
        q
    }

    fn continuum(&self) -> Option<Continuum> {
        Some(Continuum {
            density: self.rest_density,
            solvent_viscosity: self.viscosity,
            polymer: self.polymer.as_ref().map(|p| ContinuumPolymer {
                viscosity: p.viscosity,
                relaxation_time: p.relaxation_time,
                oldroyd_b: p.model.is_oldroyd_b(p),
            }),
        })
    }
}

/// Numbers per particle of the fluid's fields (checkpointed ones twice).
fn field_numbers<const D: usize>(case: &dyn CaseView, sph: &SphCfg) -> f64 {
    BuildModels::<D>::build_fluid(sph, case)
        .fields()
        .iter()
        .map(|f| {
            let copies = if f.flags.checkpointed { 2 } else { 1 };
            (f.kind.width(D) * copies) as f64
        })
        .sum()
}

impl<const D: usize> BuildModels<D> for SphCfg {
    /// Walls (fluid, lower wall, upper wall; beyond the box along the wall axis) and
    /// inclusions (the particles inside a disc or ball).
    fn species_layout(&self, case: &dyn CaseView) -> Option<SpeciesLayout<D>> {
        if case.walls().is_none() && case.inclusions().is_none() {
            return None;
        }
        let table =
            super::boundary_species::<D>(case.walls(), case.inclusions().is_some(), case.mass());
        let wall_axis = case.walls().map(|w| {
            let axis = w.axis.index();
            (axis, case.lengths()[axis])
        });
        let inclusions = case.inclusions().cloned();
        Some(SpeciesLayout {
            table,
            species_at: Box::new(move |x: &[f64; D]| match wall_axis {
                Some((axis, _)) if x[axis] < 0.0 => super::LOWER_WALL,
                Some((axis, l)) if x[axis] >= l => super::UPPER_WALL,
                _ if inclusions
                    .as_ref()
                    .is_some_and(|inc| inc.offset(x).is_some()) =>
                {
                    super::INCLUSION
                }
                _ => super::FLUID,
            }),
        })
    }

    fn build_fluid(&self, case: &dyn CaseView) -> Box<dyn ParticleModel<D>> {
        let lengths = std::array::from_fn(|d| case.lengths()[d]);
        let composite = case.wants(Observable::CompositeViscosity);
        Box::new(
            SphModel::<D>::new(
                self,
                case.mass(),
                &lengths,
                case.lattice_spacing(),
                case.walls(),
                case.inclusions(),
            )
            .with_traction_moments(composite)
            .with_transport_step(case.dt()),
        )
    }

    /// The dumbbell ensembles of a CONNFFESSIT fluid (`[fluid.polymer] model =
    /// "dumbbells"`), carried by the fluid species only, stepping with the SPH velocity
    /// gradient.
    fn build_companions(
        &self,
        case: &dyn CaseView,
    ) -> Result<Vec<Box<dyn ParticleModel<D>>>, String> {
        let mut out: Vec<Box<dyn ParticleModel<D>>> = Vec::new();
        if let Some(poly) = self.polymer.as_ref().filter(|p| p.is_ensemble()) {
            let carrier =
                (case.walls().is_some() || case.inclusions().is_some()).then_some(super::FLUID);
            out.push(Box::new(
                crate::models::dumbbell_ensemble::DumbbellEnsemble::<D>::of_fluid(
                    poly,
                    case.dt(),
                    case.seed(),
                    super::VELOCITY_GRADIENT,
                    carrier,
                )?,
            ));
        }
        Ok(out)
    }
}
