//! What a rank measures: the observables of a sample (the momentum flux, profiles, the
//! constitutive stress, the correlators of the fluctuation methods) and their exact global sums.

use super::*;

/// The bin of coordinate `y` among `bins` equal bins across [0, `ly`) (clamped to the ends).
pub(super) fn profile_bin(y: f64, ly: f64, bins: usize) -> usize {
    ((y / ly * bins as f64).floor().max(0.0) as usize).min(bins - 1)
}

/// Observables at one instant.
#[derive(Clone, Debug, Default)]
pub struct Measurement {
    /// Scalar values by name.
    pub scalars: Vec<(String, f64)>,
    /// Σ m|V|²/(degrees of freedom), V about the local mean velocity: k_BT of the fluid,
    /// whether or not the case asked for the temperature (the heating detector reads it).
    pub kinetic_temperature: f64,
    /// Binned u_x(y).
    pub profile: Option<Vec<f64>>,
}

/// The virial components the observables need: all for the stress tensor and the viscosity
/// (off-diagonal), the diagonal for the pressure and the normal stress differences, none for
/// the others.
pub(super) fn virial_scope(observables: &[Observable]) -> VirialScope {
    let needs = |o: &Observable| match o {
        Observable::Stress
        | Observable::Viscosity
        | Observable::GreenKuboViscosity
        | Observable::ShearStressProfile => VirialScope::Full,
        Observable::Pressure
        | Observable::FirstNormalStressDifference
        | Observable::SecondNormalStressDifference => VirialScope::Diagonal,
        Observable::Temperature
        | Observable::Momentum
        | Observable::VelocityProfile
        | Observable::WallShearStress
        | Observable::DensityProfile
        | Observable::PolymerStressTrace
        | Observable::ConstitutiveStress
        | Observable::Conformation
        | Observable::ColloidVelocityVariance
        | Observable::ColloidSolventRdf
        | Observable::CompositeViscosity
        | Observable::TransverseCurrentViscosity => VirialScope::Off,
    };
    let scopes: Vec<VirialScope> = observables.iter().map(needs).collect();
    if scopes.contains(&VirialScope::Full) {
        VirialScope::Full
    } else if scopes.contains(&VirialScope::Diagonal) {
        VirialScope::Diagonal
    } else {
        VirialScope::Off
    }
}

impl<'c, const D: usize> Simulation<'c, D> {
    /// Whether the current step is a sampling step.
    pub fn is_sample_step(&self) -> bool {
        let r = &self.case.run;
        self.step > r.equilibration && self.step.is_multiple_of(r.sample_every)
    }

    /// Whether the current step is recorded in the time series of the observables
    /// (`observables.csv`, the progress line): every `run.sample_every` steps from the first
    /// step on, equilibration included (a superset of [`Self::is_sample_step`]).
    pub fn is_record_step(&self) -> bool {
        self.step > 0 && self.step.is_multiple_of(self.case.run.sample_every)
    }

    /// The scalar observables of the current step, for the time series only (collective):
    /// nothing is averaged and no detector runs, so a step of the equilibration can be
    /// recorded without changing what the summary averages.
    pub(crate) fn record(&mut self) -> Vec<(String, f64)> {
        let t0 = Instant::now();
        let values = self.measure();
        self.times.diagnostics += t0.elapsed().as_secs_f64();
        values.scalars
    }

    /// Whether the current step feeds the Green–Kubo correlators (every step after
    /// equilibration, when asked).
    pub fn is_correlation_step(&self) -> bool {
        !self.series.green_kubo.is_empty() && self.step > self.case.run.equilibration
    }

    /// Feeds the symmetric traceless part of the current pressure tensor (kinetic +
    /// conservative + dissipative + random, the random forces the step used) to the block's
    /// Green–Kubo correlator (collective; exact sums, so the same on every rank).
    pub(crate) fn correlate(&mut self) {
        let t0 = Instant::now();
        let virial = self.current_virial();
        let n = self.particles.n_owned;
        let dd = D * D;
        // Kinetic, the three pair parts, the rigid bodies' constraint virial (zero without).
        let mut sums = vec![FixedSum::ZERO; 5 * dd];
        let (particles, species) = (&self.particles, &self.species);
        for (k, v) in particles.vel[..n].iter().enumerate() {
            if k % 2048 == 2047 {
                sums.iter_mut().for_each(FixedSum::normalize);
            }
            let s = &species[particles.species_of(k) as usize];
            if !s.is_fluid() {
                continue;
            }
            for a in 0..D {
                for b in 0..D {
                    sums[a * D + b].add(s.mass * v[a] * v[b]);
                }
            }
        }
        for (k, w) in virial.iter().enumerate() {
            sums[(k + 1) * dd..(k + 2) * dd].copy_from_slice(w);
        }
        if let Some(bodies) = &self.bodies {
            sums[4 * dd..].copy_from_slice(bodies.constraint_virial());
        }
        FixedSum::allreduce(self.comm, &mut sums);
        let volume = self.sim_box.volume();
        let tensor: Vec<f64> = (0..dd)
            .map(|i| (0..5).map(|k| sums[k * dd + i].value()).sum::<f64>() / volume)
            .collect();
        let channels = crate::green_kubo::traceless_symmetric(&tensor, D);
        let r = &self.case.run;
        let blocks = self.series.green_kubo.len();
        let b = crate::green_kubo::block_of(self.step, r.equilibration, r.steps, blocks);
        self.series.green_kubo[b].add(&channels);
        self.times.diagnostics += t0.elapsed().as_secs_f64();
    }

    /// Whether the current step feeds the transverse-current correlators (every
    /// `diagnostics.transverse_current_every` steps after equilibration, when asked).
    pub fn is_current_step(&self) -> bool {
        !self.series.transverse_current.is_empty()
            && self.step > self.case.run.equilibration
            && (self.step).is_multiple_of(self.case.diagnostics.transverse_current_every)
    }

    /// Feeds the transverse currents J⊥(k_j) of the fluid particles, j = 1 … modes, to the
    /// block's correlators ([`crate::transverse_current`]; collective, exact sums).
    pub(crate) fn sample_currents(&mut self) {
        let t0 = Instant::now();
        let modes = self.case.diagnostics.transverse_current_modes;
        let channels = crate::transverse_current::channels(D);
        let mut sums = vec![FixedSum::ZERO; modes * channels];
        let (particles, species) = (&self.particles, &self.species);
        let length = self.sim_box.lengths[0];
        let n = particles.n_owned;
        for (k, (x, v)) in particles.pos[..n]
            .iter()
            .zip(&particles.vel[..n])
            .enumerate()
        {
            if k % 2048 == 2047 {
                sums.iter_mut().for_each(FixedSum::normalize);
            }
            if species[particles.species_of(k) as usize].is_fluid() {
                crate::transverse_current::add_particle(&mut sums, x, v, length, modes);
            }
        }
        FixedSum::allreduce(self.comm, &mut sums);
        let r = &self.case.run;
        let blocks = self.series.transverse_current.len() / modes;
        let b = crate::green_kubo::block_of(self.step, r.equilibration, r.steps, blocks);
        for mode in 0..modes {
            let x: Vec<f64> = sums[mode * channels..(mode + 1) * channels]
                .iter()
                .map(FixedSum::value)
                .collect();
            self.series.transverse_current[b * modes + mode].add(&x);
        }
        self.times.diagnostics += t0.elapsed().as_secs_f64();
    }

    /// η_k and η₀ from the transverse-current correlators so far; `None` when the case does
    /// not ask for them.
    pub(crate) fn transverse_current(
        &self,
    ) -> Option<crate::transverse_current::TransverseCurrentEstimate> {
        let kt = self.case.fluid.model().thermal_energy()?;
        if self.series.transverse_current.is_empty() {
            return None;
        }
        let (count, mass, inverse_mass) = self.fluid_mass_moments();
        let fluid = crate::transverse_current::FluidState {
            particles: count,
            mass_density: mass / self.sim_box.volume(),
            kt_over_mass: kt * inverse_mass / count,
            length: self.sim_box.lengths[0],
        };
        let d = &self.case.diagnostics;
        Some(crate::transverse_current::estimate(
            &self.series.transverse_current,
            d.transverse_current_modes,
            d.transverse_current_every as f64 * self.dt,
            &fluid,
            D,
        ))
    }

    /// (N, Σ m, Σ 1/m) over the fluid particles of every rank (collective, exact).
    pub(super) fn fluid_mass_moments(&self) -> (f64, f64, f64) {
        let p = &self.particles;
        let mut sums = [FixedSum::ZERO; 3];
        for k in 0..p.n_owned {
            let s = &self.species[p.species_of(k) as usize];
            if s.is_fluid() {
                sums[0].add(1.0);
                sums[1].add(s.mass);
                sums[2].add(1.0 / s.mass);
            }
            if k % 2048 == 2047 {
                sums.iter_mut().for_each(FixedSum::normalize);
            }
        }
        FixedSum::allreduce(self.comm, &mut sums);
        (sums[0].value(), sums[1].value(), sums[2].value())
    }

    /// The Green–Kubo viscosity of the correlators so far ([`crate::green_kubo::estimate`]);
    /// `None` when the case does not ask for it.
    pub(crate) fn green_kubo(&self) -> Option<crate::green_kubo::GreenKuboEstimate> {
        let kt = self.case.fluid.model().thermal_energy()?;
        if self.series.green_kubo.is_empty() {
            return None;
        }
        Some(crate::green_kubo::estimate(
            &self.series.green_kubo,
            self.dt,
            self.sim_box.volume(),
            kt,
            self.case.diagnostics.green_kubo_time,
            D,
        ))
    }

    /// Samples every observable the case asked for (collective). A thermostatted (DPD) fluid
    /// whose kinetic temperature has passed [`crate::models::FluidModel::heating`] stops the run (the
    /// decision is on an exactly reduced sum, so every rank count stops alike).
    pub(crate) fn sample(&mut self) -> Result<(), Error> {
        self.sample_values().map(drop)
    }

    /// [`Self::sample`], returning the scalar values it averaged (collective).
    pub(crate) fn sample_values(&mut self) -> Result<Vec<(String, f64)>, Error> {
        let t0 = Instant::now();
        let values = self.measure();
        self.times.diagnostics += t0.elapsed().as_secs_f64();
        let density = self.total_particles as f64 / self.sim_box.volume();
        if let Some(heating) = self.case.fluid.model().heating(
            values.kinetic_temperature,
            D,
            density,
            self.case.particles.mass,
            self.time(),
        ) {
            return Err(Unstable::new(
                Quantity::Temperature,
                None,
                self.step,
                format!(
                    "{heating}, at step {}: {UNSTABLE}; reduce the time step",
                    self.step
                ),
            )
            .into());
        }
        for (name, v) in &values.scalars {
            self.series.push(name, *v);
        }
        if let Some(profile) = values.profile {
            self.series.profile.push(profile);
        }
        self.series.steps.push(self.step);
        Ok(values.scalars)
    }

    /// Instantaneous observables (collective).
    pub(crate) fn measure(&mut self) -> Measurement {
        let virial = self.current_virial();
        let case = &self.case;
        let sheared = self.sim_box.sheared();
        // Binned along y under shear, and in a walled channel whose profile is asked for (the
        // temperature is then profile-unbiased too).
        let walled_profile = (self
            .sim_box
            .boundaries
            .contains(&crate::geometry::Boundary::Wall)
            || case.body_forced())
            && case.wants(Observable::VelocityProfile);
        let bins = if sheared || walled_profile {
            case.diagnostics.profile_bins
        } else {
            1
        };
        let ly = self.sim_box.lengths[GRADIENT];
        let bin_of = |y: f64| profile_bin(y, ly, bins);
        let n = self.particles.n_owned;
        let (pos, vel) = (&self.particles.pos[..n], &self.particles.vel[..n]);
        // Boundary particles (walls, inclusions) are not fluid: left out of every average.
        let (particles, species) = (&self.particles, &self.species);
        let fluid = |k: usize| species[particles.species_of(k) as usize].is_fluid();
        // Every sum below is accumulated exactly ([`FixedSum`]) and reduced exactly over the
        // ranks, so the observables are bitwise the same for any decomposition, like the state.
        // Pass 1: bin counts and momenta → mean velocity per bin; Σ 1/m per bin (for the
        // degrees of freedom the subtraction removes).
        let mut first = vec![FixedSum::ZERO; bins * (2 + D)];
        for (k, (x, v)) in pos.iter().zip(vel).enumerate() {
            if k % 2048 == 2047 {
                first.iter_mut().for_each(FixedSum::normalize);
            }
            if !fluid(k) {
                continue;
            }
            let b = bin_of(x[GRADIENT]);
            first[b].add(1.0);
            for d in 0..D {
                first[bins + b * D + d].add(v[d]);
            }
            first[bins * (1 + D) + b].add(1.0 / species[particles.species_of(k) as usize].mass);
        }
        FixedSum::allreduce(self.comm, &mut first);
        let first: Vec<f64> = first.iter().map(FixedSum::value).collect();
        let mean: Vec<[f64; D]> = (0..bins)
            .map(|b| {
                let c = first[b].max(1.0);
                let mut u = [0.0; D];
                for d in 0..D {
                    u[d] = first[bins + b * D + d] / c;
                }
                u
            })
            .collect();
        // The local streaming velocity: the bin means interpolated linearly between bin centres
        // (periodically, with the Lees–Edwards jump ±γ̇L_y across the plane), so the profile
        // inside a bin is not counted as thermal motion (a constant bin mean would add
        // ρ m γ̇²Δ²/12 to P_xx and to k_BT).
        let jump = self.sim_box.le_velocity_jump();
        let width = ly / bins as f64;
        // The interpolation weights of the local mean at y: (bin, weight) twice.
        let weights = |y: f64| -> [(usize, f64); 2] {
            if bins == 1 {
                return [(0, 1.0), (0, 0.0)];
            }
            let s = y / width - 0.5;
            let k = s.floor();
            let t = s - k;
            let nb = bins as i64;
            [
                ((k as i64).rem_euclid(nb) as usize, 1.0 - t),
                ((k as i64 + 1).rem_euclid(nb) as usize, t),
            ]
        };
        let local_mean = |y: f64| -> [f64; D] {
            if bins == 1 {
                return mean[0];
            }
            let s = y / width - 0.5; // position in units of bin centres
            let k = s.floor();
            let t = s - k;
            let at = |b: i64| -> [f64; D] {
                let nb = bins as i64;
                let wrapped = b.rem_euclid(nb);
                let mut u = mean[wrapped as usize];
                u[0] += jump * ((b - wrapped) / nb) as f64;
                u
            };
            let (u0, u1) = (at(k as i64), at(k as i64 + 1));
            let mut u = [0.0; D];
            for d in 0..D {
                u[d] = (1.0 - t) * u0[d] + t * u1[d];
            }
            u
        };
        // Pass 2: kinetic tensor, peculiar momentum, virial.
        let dd = D * D;
        // Then the degrees of freedom per dimension the local mean leaves (below), and the
        // rigid bodies' constraint virial (zero without bodies).
        let mut second = vec![FixedSum::ZERO; dd + D + 3 * dd + 1 + dd];
        let dof_slot = dd + D + 3 * dd;
        let constraint_slot = dof_slot + 1;
        for (k, (x, v)) in pos.iter().zip(vel).enumerate() {
            if k % 2048 == 2047 {
                second.iter_mut().for_each(FixedSum::normalize);
            }
            if !fluid(k) {
                continue;
            }
            let m = species[particles.species_of(k) as usize].mass;
            // With V = (I − P)v, P_ij = φ_b(j)(y_i)/n_b(j) (the interpolated bin means), and
            // independent thermal velocities ⟨v_j²⟩ = k_BT/m_j per component:
            // ⟨Σ_i m_i V_i²⟩ = k_BT Σ_i [1 − 2P_ii + m_i Σ_b φ_b(y_i)² Σ_{j∈b} (1/m_j)/n_b²]
            // per dimension — N − B for piecewise-constant means of equal masses, more with
            // the interpolation.
            let own = bin_of(x[GRADIENT]);
            let mut kept = 1.0;
            for (b, phi) in weights(x[GRADIENT]) {
                let count = first[b];
                if count > 0.0 && phi != 0.0 {
                    if b == own {
                        kept -= 2.0 * phi / count;
                    }
                    kept += m * phi * phi * first[bins * (1 + D) + b] / (count * count);
                }
            }
            second[dof_slot].add(kept);
            let u = &local_mean(x[GRADIENT]);
            for a in 0..D {
                let va = v[a] - u[a];
                for b in 0..D {
                    second[a * D + b].add(m * va * (v[b] - u[b]));
                }
            }
            let mut p = *v;
            p[0] -= self.sim_box.streaming_velocity(x[GRADIENT]);
            for d in 0..D {
                second[dd + d].add(m * p[d]);
            }
        }
        for (k, w) in virial.iter().enumerate() {
            second[dd + D + k * dd..dd + D + (k + 1) * dd].copy_from_slice(w);
        }
        if let Some(bodies) = &self.bodies {
            second[constraint_slot..].copy_from_slice(bodies.constraint_virial());
        }
        FixedSum::allreduce(self.comm, &mut second);
        let second: Vec<f64> = second.iter().map(FixedSum::value).collect();
        let volume = self.sim_box.volume();
        let kinetic = &second[..dd];
        let mut parts: Vec<Vec<f64>> = vec![kinetic.iter().map(|k| k / volume).collect()];
        for k in 0..3 {
            let w = &second[dd + D + k * dd..dd + D + (k + 1) * dd];
            parts.push(w.iter().map(|x| x / volume).collect());
        }
        if self.bodies.is_some() {
            let w = &second[constraint_slot..];
            parts.push(w.iter().map(|x| x / volume).collect());
        }
        // The momentum flux: kinetic part plus every model's pair virial (for SPH, the pair
        // forces of the momentum equation: `crate::models::sph::momentum_flux`) plus the rigid
        // bodies' constraint virial (docs/theory/colloids.md).
        let total: Vec<f64> = (0..dd).map(|i| parts.iter().map(|p| p[i]).sum()).collect();
        let trace_k: f64 = (0..D).map(|a| kinetic[a * D + a]).sum();
        // k_BT = Σ m V²/(degrees of freedom the local-mean subtraction leaves): unbiased for
        // any bin occupancy (N·D − B·D would overstate k_BT by the interpolation's share,
        // ≈ 10 % at 10 particles per bin).
        let dof = (D as f64) * second[dof_slot];
        let mut out = Measurement {
            kinetic_temperature: trace_k / dof,
            ..Measurement::default()
        };
        let pt = |a: usize, b: usize| total[a * D + b];
        let ctx = MeasureContext {
            species: &self.species,
            lengths: self.sim_box.lengths,
            shear_rate: self.sim_box.shear_rate,
            profile_bins: case.diagnostics.profile_bins,
        };
        for o in &case.diagnostics.observables {
            // An observable of a model's own fields: its exact sums, reduced over the ranks.
            if let Some(model) = self.models.iter().find(|m| m.measures(*o)) {
                let mut sums = model.observable_sums(*o, &self.particles, &ctx);
                FixedSum::allreduce(self.comm, &mut sums);
                let sums: Vec<f64> = sums.iter().map(FixedSum::value).collect();
                out.scalars.extend(model.observable_values(*o, &sums, &ctx));
                continue;
            }
            match o {
                Observable::Temperature => out.scalars.push(("temperature".into(), trace_k / dof)),
                Observable::Pressure => out.scalars.push((
                    "pressure".into(),
                    (0..D).map(|a| pt(a, a)).sum::<f64>() / D as f64,
                )),
                Observable::Stress => {
                    let all: Vec<&Vec<f64>> = std::iter::once(&total).chain(parts.iter()).collect();
                    let names = crate::config::observables::stress_parts(case);
                    for (part, tensor) in names.iter().zip(all) {
                        for (a, b, c) in crate::config::observables::stress_components(case) {
                            out.scalars
                                .push((format!("stress_{part}_{c}"), tensor[a * D + b]));
                        }
                    }
                }
                Observable::Viscosity => out
                    .scalars
                    .push(("viscosity".into(), -pt(0, 1) / self.sim_box.shear_rate)),
                // Not a sampled series: the correlators are fed every step ([`Self::correlate`]).
                Observable::GreenKuboViscosity | Observable::TransverseCurrentViscosity => {}
                Observable::FirstNormalStressDifference => out
                    .scalars
                    .push(("first_normal_stress_difference".into(), pt(1, 1) - pt(0, 0))),
                Observable::SecondNormalStressDifference => out.scalars.push((
                    "second_normal_stress_difference".into(),
                    pt(2, 2) - pt(1, 1),
                )),
                Observable::Momentum => {
                    for d in 0..D {
                        out.scalars
                            .push((format!("momentum_{}", ["x", "y", "z"][d]), second[dd + d]));
                    }
                }
                Observable::VelocityProfile => {
                    out.profile = Some(mean.iter().map(|u| u[0]).collect());
                }
                Observable::ShearStressProfile => {
                    // τ_xy(b) = −[Σ_{i∈b} m V_x V_y + W_xy(b)]/V_b ([`crate::models::stress_profile`]),
                    // V about the local mean velocity of the temperature.
                    let nb = case.diagnostics.profile_bins;
                    let mut sums = match &self.shear_virial_profile {
                        Some((step, w)) if *step == self.step => w.clone(),
                        _ => vec![FixedSum::ZERO; nb],
                    };
                    for (k, (x, v)) in pos.iter().zip(vel).enumerate() {
                        if k % 2048 == 2047 {
                            sums.iter_mut().for_each(FixedSum::normalize);
                        }
                        if !fluid(k) {
                            continue;
                        }
                        let m = species[particles.species_of(k) as usize].mass;
                        let u = local_mean(x[GRADIENT]);
                        sums[profile_bin(x[GRADIENT], ly, nb)]
                            .add(m * (v[0] - u[0]) * (v[1] - u[1]));
                    }
                    sums.iter_mut().for_each(FixedSum::normalize);
                    FixedSum::allreduce(self.comm, &mut sums);
                    let bin_volume = self.sim_box.volume() / nb as f64;
                    for (b, w) in sums.iter().enumerate() {
                        out.scalars.push((
                            format!("{SHEAR_STRESS_PROFILE_PREFIX}{b:04}"),
                            -w.value() / bin_volume,
                        ));
                    }
                }
                Observable::ColloidVelocityVariance => {
                    // The body table is the same on every rank: no reduction.
                    if let Some(bodies) = &self.bodies {
                        let [v, w] = bodies.velocity_variances(&self.sim_box);
                        let [vn, wn] = crate::observable::COLLOID_VELOCITY_VARIANCE_NAMES;
                        out.scalars.push((vn.into(), v));
                        out.scalars.push((wn.into(), w));
                    }
                }
                Observable::ColloidSolventRdf => {
                    // g(r) of the solvent about the bodies' cloud centres ([`crate::rigid_bodies::rdf`]):
                    // exact pair counts over the ranks, normalised by each shell's ideal-gas count.
                    if let Some(bodies) = &self.bodies {
                        let width = case.diagnostics.rdf_bin_width;
                        let bins = case.diagnostics.rdf_bins(&self.sim_box.lengths[..]);
                        let (counts, solvent) = bodies.solvent_rdf_counts(
                            &self.particles,
                            &self.sim_box,
                            self.step,
                            (width, bins),
                            fluid,
                            self.comm,
                        );
                        let density = solvent / self.sim_box.volume();
                        let n_bodies = bodies.bodies().len() as f64;
                        let g = crate::rigid_bodies::rdf::normalise(
                            &counts, width, D, n_bodies, density,
                        );
                        for (b, gb) in g.into_iter().enumerate() {
                            out.scalars.push((
                                format!("{}{b:04}", crate::observable::COLLOID_SOLVENT_RDF_PREFIX),
                                gb,
                            ));
                        }
                    }
                }
                // Measured by the model whose fields they are (above); `check` refuses
                // them for a fluid without those fields.
                Observable::ConstitutiveStress
                | Observable::Conformation
                | Observable::PolymerStressTrace
                | Observable::DensityProfile
                | Observable::WallShearStress
                | Observable::CompositeViscosity => {}
            }
        }
        out
    }
}
