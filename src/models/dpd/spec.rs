//! What the DPD fluid owns besides its forces ([`crate::models::FluidModel`]): validation of
//! its `[fluid]` table, its time-step limits, its `check` report, its blow-up detectors (a
//! runaway particle, a fluid heating without bound) and how it is built.

use super::DpdCfg;
use crate::integrators::IntegratorCfg;
use crate::models::fluid_model::CaseView;
use crate::models::fluid_model::{BodyForce, BuildModels, FluidModel, ModelMemory};
use crate::models::interface::ParticleModel;
use crate::observable::Observable;
use crate::spans::{CaseError, Segment, SpanIndex};

impl crate::models::fluid_model::KindTraits for DpdCfg {
    const KEYS: &'static [crate::key_doc::KeyDoc] = super::keys::KEYS;
}

impl FluidModel for DpdCfg {
    fn kind(&self) -> &'static str {
        "dpd"
    }

    fn cutoff(&self) -> f64 {
        self.cutoff
    }

    fn cutoff_key(&self) -> &'static str {
        "cutoff"
    }

    fn validate(&self, case: &dyn CaseView, ix: &SpanIndex) -> Result<(), CaseError> {
        validate_dpd(self, case.dimension(), ix)?;
        if let Some(colloids) = &self.colloids {
            colloids.validate(case, self.cutoff, ix)?;
        }
        Ok(())
    }

    fn accepts_integrator(&self, integrator: &IntegratorCfg) -> Result<(), String> {
        groot_warren_only(integrator)
    }

    fn friction_rate(&self, dimension: usize, n: f64, m: f64) -> Option<f64> {
        Some(super::time_step::dpd_mean_field_rate(self, dimension, n, m))
    }

    fn time_step_limits(&self, case: &dyn CaseView) -> Vec<(String, f64)> {
        let l = super::time_step::dpd_limits_of(self, case);
        let mut limits = vec![("measured DPD limit".to_string(), l.combined)];
        if let Some(colloids) = &self.colloids {
            limits.push((
                format!(
                    "colloid spring tie (√(H/m)Δt ≤ {})",
                    super::colloids::SPRING_LIMIT
                ),
                colloids.time_step_limit(case),
            ));
        }
        limits
    }

    fn time_step_error(&self, case: &dyn CaseView, dt: f64) -> Option<String> {
        use super::time_step::dpd_fit;
        let l = super::time_step::dpd_limits_of(self, case);
        if let Some(colloids) = &self.colloids {
            let limit = colloids.time_step_limit(case);
            if dt > limit {
                return Some(format!(
                    "Δt = {dt} is beyond the colloid spring tie's limit √(H/m)Δt ≤ {}                      (Δt ≤ {limit:.4e} at H = {}); use a smaller time step or a softer                      fluid.colloids.spring_stiffness",
                    super::colloids::SPRING_LIMIT,
                    colloids.spring_stiffness(case)
                ));
            }
        }
        if dt <= l.combined {
            return None;
        }
        let binding = if l.free_flight < l.dissipative.min(l.conservative) {
            "mostly the free flight's (a thermal particle crossing the cutoff in too few \
             steps): use a smaller time step"
        } else if l.dissipative < l.conservative {
            "mostly the dissipative force's: use a smaller time step, a smaller γ, or \
             thermostat = \"exponential\" (which integrates the friction exactly)"
        } else {
            "mostly the conservative force's (velocity Verlet in the cage of \
             neighbours): use a smaller time step or a softer a"
        };
        Some(format!(
            "Δt = {dt} is beyond the measured stability limit of this DPD fluid, \
             Δt ≤ S((Δt_C⁻ᵖ + Δt_D⁻ᵖ)^(p′/p) + Δt_F^(−p′))^(−1/p′) = {:.4e} (p = {}, p′ = {}, the \
             out-of-sample margin S = {}) with the \
             conservative part Δt_C = α/ω_E = {:.4e}, the dissipative part \
             Δt_D = {:.4e} and the free-flight part Δt_F = {:.4e} (see `mesorheo \
             check`); the limit is {binding}",
            l.combined,
            dpd_fit::NORM_EXPONENT,
            dpd_fit::FREE_FLIGHT_EXPONENT,
            dpd_fit::SCATTER_MARGIN,
            l.conservative,
            l.dissipative,
            l.free_flight
        ))
    }

    fn default_observables(&self, _case: &dyn CaseView) -> Vec<Observable> {
        crate::observable::Observable::thermal_defaults()
    }

    fn supports(&self, _case: &dyn CaseView, o: Observable) -> Result<(), String> {
        match o {
            Observable::ShearStressProfile
            | Observable::GreenKuboViscosity
            | Observable::TransverseCurrentViscosity => Ok(()),
            Observable::ColloidVelocityVariance
                if self.colloids.as_ref().is_some_and(|c| !c.fixed) =>
            {
                Ok(())
            }
            Observable::ColloidSolventRdf if self.colloids.is_some() => Ok(()),
            _ => crate::models::fluid_model::generic_support(o),
        }
    }

    fn constituent_count(&self, case: &dyn CaseView) -> u64 {
        self.colloids
            .as_ref()
            .map_or(0, |c| c.body_count(case) * c.shape.sites() as u64)
    }

    /// The central pair parts, and with colloids the tie springs' constraint virial
    /// ([`crate::rigid_bodies`], docs/theory/colloids.md "The suspension's stress").
    fn stress_parts(&self) -> Vec<&'static str> {
        let mut parts = crate::models::fluid_model::CENTRAL_STRESS_PARTS.to_vec();
        if self.colloids.is_some() {
            parts.push(crate::rigid_bodies::CONSTRAINT_STRESS_PART);
        }
        parts
    }

    fn report(&self, case: &dyn CaseView, density: f64, line: &mut dyn FnMut(String)) {
        dpd_report(case, self, density, line);
        if let Some(colloids) = &self.colloids {
            colloids.report(case, self.kt, line);
        }
        transverse_current_report(case, self, line);
    }

    fn memory(&self, _case: &dyn CaseView) -> ModelMemory {
        ModelMemory::default()
    }

    fn thermal_energy(&self) -> Option<f64> {
        Some(self.kt)
    }

    fn runaway_bound_in_kt(&self, dimension: usize, density: f64) -> f64 {
        runaway_energy_in_kt(self, dimension, density)
    }

    fn heating(
        &self,
        kinetic_temperature: f64,
        dimension: usize,
        density: f64,
        mass: f64,
        time: f64,
    ) -> Option<String> {
        let heated = kinetic_temperature / self.kt;
        let bound = heating_bound_in_kt(self, dimension, density, mass, time);
        (heated.is_nan() || heated > bound).then(|| {
            format!(
                "the fluid's kinetic temperature is {heated:.4} k_BT, beyond {bound:.4} k_BT \
                 ({HEATING_BOUND} × the thermostat's k_BT = {} plus what is left, under the \
                 thermostat, of the overlap energy a random start can release): a fluid \
                 heating without bound",
                self.kt
            )
        })
    }

    fn body_force(&self) -> BodyForce<'_> {
        BodyForce {
            acceleration: &self.body_force,
            reverse: self.body_force_profile == super::BodyForceProfile::Reverse,
        }
    }

    fn target_viscosity(&self) -> Option<f64> {
        self.physical.as_ref().map(|p| p.viscosity)
    }
}

impl<const D: usize> BuildModels<D> for DpdCfg {
    fn build_fluid(&self, case: &dyn CaseView) -> Box<dyn ParticleModel<D>> {
        let d = &as_integrated(case, self);
        let ly = case.lengths()[1];
        let mut model = super::DpdModel::<D>::new(d, case.dt(), case.seed()).with_body_force(
            d,
            case.mass(),
            ly,
        );
        if self.colloids.is_some() {
            model = model.with_constituents_from(case.lattice_counts().1);
        }
        if case.wants(Observable::ShearStressProfile) {
            Box::new(model.with_shear_stress_profile(case.profile_bins(), ly))
        } else {
            Box::new(model)
        }
    }

    /// The soft start ([`super::soft_start`]): `fluid.soft_start_sweeps` sweeps of overlap
    /// removal on the conservative potential's shape.
    fn relax_random_start(&self, case: &dyn CaseView, positions: &mut [[f64; D]]) {
        super::soft_start::relax_random_start(
            positions,
            case.lengths(),
            &case.boundaries(),
            self.cutoff,
            self.conservative_exponent,
            self.soft_start_sweeps(),
        );
    }

    fn rigid_bodies(
        &self,
        case: &dyn CaseView,
    ) -> Result<Option<crate::rigid_bodies::RigidBodies<D>>, String> {
        let Some(colloids) = &self.colloids else {
            return Ok(None);
        };
        let spec = colloids.spec(case, self.cutoff)?;
        Ok(Some(crate::rigid_bodies::RigidBodies::new(spec, case.dt())))
    }
}

/// The DPD fluid the step integrates: as given, or with the friction φγ (and so the noise
/// √φ σ) of the exponential thermostat ([`crate::integrators::groot_warren`]).
pub fn as_integrated(case: &dyn CaseView, d: &DpdCfg) -> DpdCfg {
    let mut d = d.clone();
    if let Some(phi) = case.exponential_friction_factor() {
        d.gamma *= phi;
    }
    d
}

/// The fluids integrated by Groot–Warren only (the SPH schemes need an SPH fluid).
pub(crate) fn groot_warren_only(integrator: &IntegratorCfg) -> Result<(), String> {
    if matches!(integrator, IntegratorCfg::GrootWarren(_)) {
        Ok(())
    } else {
        Err(
            "the SPH integrators (kick_drift_kick, heun, midpoint, thesis_predictor_corrector) \
             serve kind = \"sph\" fluids; use kind = \"groot_warren\" for this fluid"
                .to_string(),
        )
    }
}

/// Thermal part, in units of k_BT, of the peculiar kinetic energy beyond which a particle of a
/// thermostatted (DPD) fluid is a runaway (see [`runaway_energy_in_kt`]). In equilibrium a
/// particle exceeds E k_BT with probability ≈ 2√(E/π) e^{−E} (3D), 10⁻⁴² at E = 100: no
/// healthy run of 10⁶ particles over 10⁹ steps ever trips it, while a step beyond the
/// stability limit reaches it within a few steps of going wrong.
pub const RUNAWAY_KT: f64 = 100.0;

/// The kinetic temperature, in units of the thermostat's k_BT, beyond which an equilibrated DPD
/// fluid is heating without bound: checked at every sample (after the equilibration), with an
/// allowance for a random start's release of overlap energy ([`heating_bound_in_kt`]). A time step near the dissipative limit
/// heats the fluid gradually — 2D ρ = 4, a = 25, γ = 18.9 (`cases/dpd_equilibrium_2d.toml`,
/// 1000 steps): k_BT = 1.05, 1.17, 1.32, 1.62 at Δt = 0.040, 0.044, 0.046, 0.048, and a runaway
/// particle at 0.052 — so no single particle need pass [`RUNAWAY_KT`] before the fluid
/// is useless. Shear heating of a thermostatted fluid is a few per cent at γ̇ ~ 1.
pub const HEATING_BOUND: f64 = 2.0;

/// The heating bound of a DPD fluid at time t, in units of k_BT:
///
/// ```text
/// HEATING_BOUND + (2/D) (n/2) ∫ φ(r) dV / k_BT · e^{−ω₀ t},   φ(r) = a r_c (1 − r/r_c)^{s̄+1}/(s̄+1)
/// ∫ φ dV = 2π a r_c³ / ((s̄+1)(s̄+2)(s̄+3))          (2D)
///        = 8π a r_c⁴ / ((s̄+1)(s̄+2)(s̄+3)(s̄+4))     (3D)
/// ```
///
/// The second term is the temperature rise if the mean overlap energy of uniformly random
/// positions (a random start) turned into heat at once (5.24 k_BT for the 3D a = 25, ρ = 3
/// fluid), decaying at half the thermostat's mean-field rate ω₀ = γΣw_D/(D m)
/// ([`super::time_step::dpd_mean_field_rate`]): a quarter of the rate 2ω₀ at which the
/// thermostat removes kinetic energy, because the overlaps release their energy over the
/// structural relaxation, more slowly than it is removed (measured: the 2D a = 100, ρ = 4
/// random start at γ = 40, Δt = 0.02 still reads 2.34 k_BT at t = 0.2, where e^{−ω₀t} would
/// allow only 2.01).
pub fn heating_bound_in_kt(
    dpd: &DpdCfg,
    dimension: usize,
    density: f64,
    mass: f64,
    time: f64,
) -> f64 {
    let (a, rc, s) = (dpd.a.abs(), dpd.cutoff, dpd.conservative_exponent);
    let overlap = if dimension == 2 {
        2.0 * std::f64::consts::PI * a * rc.powi(3) / ((s + 1.0) * (s + 2.0) * (s + 3.0))
    } else {
        8.0 * std::f64::consts::PI * a * rc.powi(4)
            / ((s + 1.0) * (s + 2.0) * (s + 3.0) * (s + 4.0))
    };
    let start = (2.0 / dimension as f64) * 0.5 * density * overlap / dpd.kt;
    let rate = super::time_step::dpd_mean_field_rate(dpd, dimension, density, mass);
    HEATING_BOUND + start * (-0.5 * rate * time).exp()
}

/// The runaway bound of a DPD fluid in units of k_BT: RUNAWAY_KT + a n_c / k_BT, where
/// n_c = ρ V_d(r_c) is the mean number of neighbours within the cutoff. The second term is
/// twice the most potential energy a particle's neighbourhood can hold (each pair at most a/2),
/// so a violent start (random positions at a large a) that converts it to heat is not taken
/// for an instability; a genuine one grows without bound and passes any finite bound.
pub fn runaway_energy_in_kt(dpd: &DpdCfg, dimension: usize, density: f64) -> f64 {
    let neighbours = density * crate::geometry::ball_volume(dimension, dpd.cutoff);
    RUNAWAY_KT + dpd.a.abs() * neighbours / dpd.kt
}

/// What the transverse-current viscosity will resolve: each mode's Newtonian decay time
/// ρ/(η k²) with the kinetic-theory η, against the sampling interval and the longest lag.
fn transverse_current_report(case: &dyn CaseView, d: &DpdCfg, line: &mut dyn FnMut(String)) {
    if !case.wants(crate::observable::Observable::TransverseCurrentViscosity) {
        return;
    }
    let Ok(dimension) = crate::dpd_parameters::Dimension::try_from(case.dimension()) else {
        return;
    };
    let fluid = crate::dpd_parameters::DpdFluid {
        dimension,
        kt: d.kt,
        number_density: case.number_density(),
        mass: case.mass(),
        cutoff: d.cutoff,
        a: d.a,
        conservative_exponent: d.conservative_exponent,
        gamma: d.gamma,
        dissipative_exponent: d.weight_exponent,
    };
    let Ok(prediction) = fluid.predict() else {
        return;
    };
    let diag = case.transverse_current_sampling();
    let eta = prediction.total_viscosity;
    let rho = case.number_density() * case.mass();
    let length = case.lengths()[0];
    let interval = diag.every as f64 * case.dt();
    let decay = |j: usize| {
        let k = std::f64::consts::TAU * j as f64 / length;
        rho / (eta * k * k)
    };
    let modes = diag.modes;
    let slowest = decay(1);
    let fastest = decay(modes);
    let verdict_slow = if diag.time >= 3.0 * slowest {
        "ok"
    } else {
        "SHORT: the slowest mode will not have decayed; raise diagnostics.transverse_current_time"
    };
    let verdict_fast = if fastest >= 2.0 * interval {
        "ok"
    } else {
        "UNDER-RESOLVED: lower diagnostics.transverse_current_every or the modes"
    };
    line(format!(
        "transverse currents: k = 2πj/{length} for j = 1 … {modes}; Newtonian decay ρ/(ηk²) with \
         the kinetic-theory η = {eta:.4}: {slowest:.4} (k₁) … {fastest:.4} (k_{modes}); sampled \
         every {interval:.4} [{verdict_fast}], lags to {} [{verdict_slow}]; the error of η_k₁ \
         falls like √({slowest:.3}/run time)",
        diag.time
    ));
}

/// The DPD lines of the report: parameters, kinetic-theory estimates, time-step limits.
fn dpd_report(case: &dyn CaseView, d: &DpdCfg, density: f64, line: &mut dyn FnMut(String)) {
    let dim = case.dimension();
    let m = case.mass();
    let dt = case.dt();
    let lim = super::time_step::dpd_limits_of(d, case);
    let alpha = d.gamma * d.gamma * d.cutoff / (m * d.a.max(f64::MIN_POSITIVE));
    if let Some(physical) = &d.physical
        && let Ok(inputs) =
            super::physical::inputs_of(physical, dim, d.kt, d.cutoff, case.number_density(), m)
        && let Ok(mapped) = crate::dpd_parameters::map(&inputs)
    {
        for l in super::physical::report(&inputs, &mapped) {
            line(l);
        }
    }
    line(format!(
        "DPD: a = {}, γ = {}, k_BT = {}, r_c = {}, s = {}, s̄ = {}, σ = {:.4}, α = γ² r_c/(m a) = \
         {:.3}",
        d.a,
        d.gamma,
        d.kt,
        d.cutoff,
        d.weight_exponent,
        d.conservative_exponent,
        (2.0 * d.gamma * d.kt).sqrt(),
        alpha
    ));
    if dim == 3 && d.weight_exponent == 2.0 && d.conservative_exponent == 1.0 {
        // Kinetic-theory estimate (Groot & Warren 1997, Eq. 33, s = 2) and their EOS for c².
        let rho_m = density * m;
        let eta = 45.0 * d.kt / (4.0 * std::f64::consts::PI * d.gamma * d.cutoff.powi(3))
            + 2.0 * std::f64::consts::PI * d.gamma * density * density * d.cutoff.powi(5) / 1575.0;
        let c2 = d.kt / m + 2.0 * 0.101 * d.a * density * d.cutoff.powi(4) / m;
        line(format!(
            "rough estimates (Groot–Warren kinetic theory, s = 2, no conservative-force or pair \
             correlations): η ≈ {eta:.3} (the a = 25, γ = 4.5, ρ = 3 fluid measures 0.86, 11 % \
             lower: LAMMPS and mesorheo), sound speed c ≈ {:.3}",
            c2.sqrt()
        ));
        let shear = case.shear_rate();
        if shear != 0.0 {
            let ly = case.lengths()[1];
            let u = shear.abs() * ly / 2.0;
            line(format!(
                "shear: γ̇ = {shear}, Re = ρ γ̇ L_y²/η ≈ {:.3}, Ma = (γ̇ L_y/2)/c ≈ {:.3}",
                rho_m * shear.abs() * ly * ly / eta,
                u / c2.sqrt()
            ));
        }
    }
    let omega = super::time_step::dpd_mean_field_rate(d, dim, case.number_density(), m);
    let phi = case.exponential_friction_factor();
    match phi {
        Some(phi) => line(format!(
            "thermostat: exponential (SETD); ω₀Δt = {:.4} (ω₀ = γΣw_D/(d m) = {omega:.5}), \
             friction and noise variance × φ = (1 − e^{{−ω₀Δt}})/(ω₀Δt) = {phi:.5}: k_BT kept, \
             but the dissipative viscosity is φ η_D ({:.2} % below)",
            omega * dt,
            100.0 * (1.0 - phi)
        )),
        None => line(format!(
            "thermostat: explicit; ω₀Δt = {:.4} (ω₀ = γΣw_D/(d m) = {omega:.5}; the step \
             diverges past 2: thermostat = \"exponential\" integrates it exactly)",
            omega * dt
        )),
    }
    line(format!(
        "time step Δt = {dt}: stability limit S((Δt_C⁻ᵖ + Δt_D⁻ᵖ)^(p′/p) + Δt_F^(−p′))^(−1/p′) = {:.4} \
         [{}] (measured, p = {}, p′ = {}, out-of-sample margin S = {}, see docs/validation.md), \
         with the conservative part \
         Δt_C = α/ω_E = {:.4} (cage ω_E = {:.4}), the dissipative part Δt_D = {:.4} \
         (ω_D = γΣw_D/m = {:.4}, c = {:.3}{}) and the free-flight part Δt_F = {} r_c/√(k_BT/m) \
         = {:.4}; Groot–Warren accuracy guide Δt ≤ 0.06 at a = 25 [{}]",
        lim.combined,
        if dt <= lim.combined { "ok" } else { "VIOLATED" },
        super::time_step::dpd_fit::NORM_EXPONENT,
        super::time_step::dpd_fit::FREE_FLIGHT_EXPONENT,
        super::time_step::dpd_fit::SCATTER_MARGIN,
        lim.conservative,
        lim.cage_frequency,
        lim.dissipative,
        lim.friction_rate,
        lim.friction_coefficient,
        if phi.is_some() {
            ", lifted: exponential thermostat"
        } else {
            ""
        },
        if dim == 2 {
            super::time_step::dpd_fit::FREE_FLIGHT_2D
        } else {
            super::time_step::dpd_fit::FREE_FLIGHT_3D
        },
        lim.free_flight,
        if dt <= 0.06 {
            "ok"
        } else {
            "expect k_BT errors > few %"
        }
    ));
    let sweeps = d.soft_start_sweeps();
    if case.lattice() == crate::geometry::Lattice::Random && sweeps > 0 {
        line(format!(
            "random start: soft start, {sweeps} sweeps of overlap removal before step 0 \
             (fluid.soft_start_sweeps; docs/theory/dpd_soft_start.md): the start holds no denser \
             cluster than the fluid, and the steady-state limit applies"
        ));
    } else if case.lattice() == crate::geometry::Lattice::Random && phi.is_none() {
        let margin = if dim == 2 {
            super::time_step::dpd_fit::RANDOM_START_FRICTION_2D
        } else {
            super::time_step::dpd_fit::RANDOM_START_FRICTION_3D
        };
        line(format!(
            "random start: the dissipative part carries a margin × {margin} (at strong friction \
             the start's densest clusters blow a run up in its first 4–21 steps, at a step that \
             scatters 1.7× between seeds; docs/validation.md); the soft start \
             (fluid.soft_start_sweeps > 0, the default), a lattice start or thermostat = \
             \"exponential\" does not need it"
        ));
    }
}

/// `[fluid] kind = "dpd"`: the parameters' ranges.
fn validate_dpd(dpd: &DpdCfg, dim: usize, ix: &SpanIndex) -> Result<(), CaseError> {
    let fl = |key: &str| vec![Segment::Key("fluid".into()), Segment::Key(key.into())];

    if !(dpd.a.is_finite() && dpd.a >= 0.0) {
        return Err(ix.error(
            &fl("a"),
            format!("found {}; the repulsion a must be ≥ 0", dpd.a),
        ));
    }
    if !(dpd.gamma.is_finite() && dpd.gamma > 0.0) {
        return Err(ix.error(
            &fl("gamma"),
            format!("found {}; the dissipation γ must be > 0", dpd.gamma),
        ));
    }
    if !(dpd.kt.is_finite() && dpd.kt > 0.0) {
        return Err(ix.error(&fl("kt"), format!("found {}; k_BT must be > 0", dpd.kt)));
    }
    if !(dpd.cutoff.is_finite() && dpd.cutoff > 0.0) {
        return Err(ix.error(&fl("cutoff"), format!("found {}; must be > 0", dpd.cutoff)));
    }
    if !(dpd.weight_exponent.is_finite() && dpd.weight_exponent > 0.0) {
        return Err(ix.error(
            &fl("weight_exponent"),
            format!(
                "found {}; the exponent s of w_D = (1 − r/r_c)^s must be > 0 (2 standard, 0.5 \
             modified)",
                dpd.weight_exponent
            ),
        ));
    }
    if !dpd.body_force.is_empty()
        && (dpd.body_force.len() != dim || dpd.body_force.iter().any(|g| !g.is_finite()))
    {
        return Err(ix.error(
            &fl("body_force"),
            format!(
                "found {:?}; give {dim} finite components of the acceleration g",
                dpd.body_force
            ),
        ));
    }
    if let Some(sweeps) = dpd.soft_start_sweeps
        && sweeps > super::soft_start::MAX_SWEEPS
    {
        return Err(ix.error(
            &fl("soft_start_sweeps"),
            format!(
                "found {sweeps}; at most {} sweeps of overlap removal (each costs about a time \
                 step; the default {} removes the random placement's clusters, 0 turns the soft \
                 start off)",
                super::soft_start::MAX_SWEEPS,
                super::soft_start::DEFAULT_SWEEPS
            ),
        ));
    }
    if !(dpd.conservative_exponent.is_finite() && dpd.conservative_exponent > 0.0) {
        return Err(ix.error(
            &fl("conservative_exponent"),
            format!(
                "found {}; the exponent s̄ of w_C = (1 − r/r_c)^s̄ must be > 0 (1 standard)",
                dpd.conservative_exponent
            ),
        ));
    }
    Ok(())
}
