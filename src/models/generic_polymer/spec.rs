//! What the GENERIC polymer fluid owns besides its pass ([`FluidModel`]): validation (the
//! reduced keys or `[fluid.si]`, and the units' consistency with the box and the particles),
//! the integrators it accepts, its time-step limits and its `check` report.

use super::{ConformationDrift, GenericPolymer, GenericPolymerCfg};
use crate::integrators::IntegratorCfg;
use crate::models::fluid_model::{
    BuildModels, CaseView, FluidModel, KindTraits, ModelMemory, generic_support,
};
use crate::models::interface::ParticleModel;
use crate::observable::Observable;
use crate::spans::{CaseError, Segment, SpanIndex};

impl KindTraits for GenericPolymerCfg {
    const KEYS: &'static [crate::key_doc::KeyDoc] = super::keys::KEYS;
}

fn path(keys: &[&str]) -> Vec<Segment> {
    keys.iter()
        .map(|k| Segment::Key((*k).to_string()))
        .collect()
}

fn positive(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

impl GenericPolymerCfg {
    /// Dumbbells per fluid particle, N^d = n^d/n, at number density `n`.
    pub fn dumbbells_per_particle(&self, n: f64) -> f64 {
        self.parameters().dumbbell_density / n
    }

    /// The rate ν/(2λ_H) at which Q relaxes (ν = N^d under the printed drift).
    fn relaxation_rate(&self, n: f64) -> f64 {
        let p = self.parameters();
        let nu = match self.conformation_drift {
            ConformationDrift::SingleDumbbell => 1.0,
            ConformationDrift::PrintedGeneric => self.dumbbells_per_particle(n).max(1.0),
        };
        nu / (2.0 * p.relaxation_time)
    }

    fn check_units(&self, case: &dyn CaseView, ix: &SpanIndex) -> Result<(), CaseError> {
        let Some(si) = &self.si else {
            return Ok(());
        };
        for (key, value) in si.inputs() {
            if !positive(value) {
                return Err(ix.error(
                    &path(&["fluid", "si", key]),
                    format!("found {value}; must be finite and > 0 (SI units)"),
                ));
            }
        }
        let reduced = si.reduced();
        for (key, value) in self.reduced_keys() {
            if let Some(v) = value {
                return Err(ix.error(
                    &path(&["fluid", key]),
                    format!(
                        "fluid.{key} = {v} is given in reduced units beside [fluid.si], which \
                         sets it (the conversion gives {}); give either the reduced \
                         parameters or [fluid.si], not both",
                        match key {
                            "sound_speed" => reduced.sound_speed,
                            "solvent_viscosity" => reduced.solvent_viscosity,
                            "kt" => reduced.kt,
                            "spring_constant" => reduced.spring_constant,
                            "relaxation_time" => reduced.relaxation_time,
                            _ => reduced.dumbbell_density,
                        }
                    ),
                ));
            }
        }
        let lengths = case.lengths();
        if lengths.iter().any(|&l| (l - 1.0).abs() > 1e-12) {
            return Err(ix.error(
                &path(&["box", "lengths"]),
                format!(
                    "inconsistent units: [fluid.si] makes the box edge L₀ = {} m the length \
                     unit, so the box must be 1 along every axis (reduced); found {lengths:?}",
                    si.box_length
                ),
            ));
        }
        let rho = case.mass() * case.number_density();
        if (rho - 1.0).abs() > 1e-9 {
            return Err(ix.error(
                &path(&["particles", "mass"]),
                format!(
                    "inconsistent units: [fluid.si] makes ρ₀L₀³ = {:e} kg the mass unit, so the \
                     particles' mass density m·n must be 1 (reduced); found {} × {} = {rho} \
                     (use mass = {})",
                    si.density * si.box_length.powi(3),
                    case.mass(),
                    case.number_density(),
                    1.0 / case.number_density()
                ),
            ));
        }
        Ok(())
    }

    fn check_reduced(&self, ix: &SpanIndex) -> Result<(), CaseError> {
        if self.si.is_some() {
            return Ok(());
        }
        for (key, value) in self.reduced_keys() {
            let Some(v) = value else {
                let what = match key {
                    "kt" => "missing temperature: fluid.kt (k_BT) is required".to_string(),
                    _ => format!("missing fluid.{key}"),
                };
                return Err(ix.error(
                    &path(&["fluid"]),
                    format!(
                        "{what}; give every reduced parameter (sound_speed, \
                         solvent_viscosity, kt, spring_constant, relaxation_time, \
                         dumbbell_density) or the physical inputs in a [fluid.si] table \
                         (box_length, relaxation_time, temperature, solvent_viscosity, \
                         density, dumbbells, bead_radius, specific_gas_constant)"
                    ),
                ));
            };
            let ok = match key {
                "dumbbell_density" => v.is_finite() && v >= 0.0,
                _ => positive(v),
            };
            if !ok {
                let want = if key == "dumbbell_density" {
                    "≥ 0"
                } else {
                    "> 0"
                };
                return Err(ix.error(
                    &path(&["fluid", key]),
                    format!("found {v}; must be finite and {want}"),
                ));
            }
        }
        Ok(())
    }
}

impl FluidModel for GenericPolymerCfg {
    fn kind(&self) -> &'static str {
        "generic_polymer"
    }

    fn cutoff(&self) -> f64 {
        self.smoothing_length
    }

    fn cutoff_key(&self) -> &'static str {
        "smoothing_length"
    }

    fn validate(&self, case: &dyn CaseView, ix: &SpanIndex) -> Result<(), CaseError> {
        if !positive(self.smoothing_length) {
            return Err(ix.error(
                &path(&["fluid", "smoothing_length"]),
                format!("found {}; must be finite and > 0", self.smoothing_length),
            ));
        }
        self.check_reduced(ix)?;
        self.check_units(case, ix)?;
        if self.explicit_dumbbells == 0 {
            return Err(ix.error(
                &path(&["fluid", "explicit_dumbbells"]),
                "found 0; Model A needs at least one explicit dumbbell per particle (1, the \
                 default, is Model B: one conformation vector per particle)"
                    .to_string(),
            ));
        }
        if let Some(pt) = self.transport_pressure
            && !(pt.is_finite() && pt >= 0.0)
        {
            return Err(ix.error(
                &path(&["fluid", "transport_pressure"]),
                format!(
                    "found {pt}; the transport-velocity background pressure must be finite and \
                     ≥ 0 (0: the thesis's printed form, continuity density and no transport \
                     velocity; leave it out for the default c_s²ρ₀)"
                ),
            ));
        }
        if let Some(pb) = self.background_pressure {
            if !(pb.is_finite() && pb >= 0.0) {
                return Err(ix.error(
                    &path(&["fluid", "background_pressure"]),
                    format!(
                        "found {pb}; the momentum equation's background pressure must be \
                         finite and ≥ 0 (leave it out for the default {} c_s²ρ₀)",
                        super::DEFAULT_BACKGROUND_FRACTION
                    ),
                ));
            }
            if self.transport_pressure == Some(0.0) {
                return Err(ix.error(
                    &path(&["fluid", "background_pressure"]),
                    format!(
                        "fluid.background_pressure = {pb} is given with fluid.transport_pressure \
                         = 0: the printed form (continuity density) keeps the whole ideal-gas \
                         pressure c_s²ρ and takes no background pressure; drop one of the two"
                    ),
                ));
            }
        }
        Ok(())
    }

    fn accepts_integrator(&self, integrator: &IntegratorCfg) -> Result<(), String> {
        if self.transport_pressure != Some(0.0)
            && !matches!(integrator, IntegratorCfg::KickDriftKick(_))
        {
            return Err(
                "the GENERIC polymer fluid's transport velocity (fluid.transport_pressure, on by \
                 default) moves the particles with v + ½Δt a^t, which only kick_drift_kick \
                 does: use kick_drift_kick, or set fluid.transport_pressure = 0 for the printed \
                 form (continuity density) with heun"
                    .to_string(),
            );
        }
        match integrator {
            IntegratorCfg::Heun(_) | IntegratorCfg::KickDriftKick(_) => Ok(()),
            _ => Err(
                "the GENERIC polymer fluid needs an integrator that applies each step's noise \
                 once (docs/theory/generic_polymer_particle.md §3): use heun or \
                 kick_drift_kick"
                    .to_string(),
            ),
        }
    }

    fn time_step_limits(&self, case: &dyn CaseView) -> Vec<(String, f64)> {
        let p = self.parameters();
        let rho0 = case.mass() * case.number_density();
        // Measured (docs/validation.md, GENERIC polymer T1): the thesis's T1 case (Lucy
        // r_c = 4Δ, c_s = 37.2, η_s = 0.01, kick–drift–kick) heats from round-off to velocity
        // fluctuations of 3 (wall speed 0.6) within 20 steps at Δt = 0.47 r_c/c_s, while at
        // 0.23 r_c/c_s they settle near 0.15 (0.4 % of c_s): the continuity density's
        // two-stage update amplifies sound waves of ωΔt ≳ 1.
        let mut limits = vec![(
            "acoustic (CFL) 0.25 r_c/c_s".to_string(),
            0.25 * p.smoothing_length / p.sound_speed,
        )];
        if p.solvent_viscosity > 0.0 {
            limits.push((
                "viscous 0.125 r_c² ρ₀/η_s".to_string(),
                0.125 * p.smoothing_length * p.smoothing_length * rho0 / p.solvent_viscosity,
            ));
        }
        limits.push((
            "relaxation 0.2 (2λ_H/ν)".to_string(),
            0.2 / self.relaxation_rate(case.number_density()),
        ));
        limits
    }

    fn default_observables(&self, case: &dyn CaseView) -> Vec<Observable> {
        let mut out = vec![
            Observable::Temperature,
            Observable::Momentum,
            Observable::Conformation,
        ];
        if case.shear_rate() != 0.0 {
            // The particle-averaged polymer stress and the momentum flux side by side.
            out.extend([
                Observable::ConstitutiveStress,
                Observable::Viscosity,
                Observable::FirstNormalStressDifference,
            ]);
        }
        out
    }

    fn supports(&self, _case: &dyn CaseView, o: Observable) -> Result<(), String> {
        if matches!(o, Observable::ConstitutiveStress | Observable::Conformation) {
            return Ok(());
        }
        // The pair-virial observables are the momentum flux of the applied pair forces
        // (`super::momentum_flux`).
        generic_support(o)
    }

    fn stress_parts(&self) -> Vec<&'static str> {
        // the pair parts of `super::momentum_flux`, after the total and the kinetic part
        super::GENERIC_STRESS_PARTS.to_vec()
    }

    /// The friction lies along v_ij and the polymer term along Π·ω_ij: the momentum flux is
    /// not symmetric.
    fn symmetric_stress(&self) -> bool {
        false
    }

    fn report(&self, case: &dyn CaseView, density: f64, line: &mut dyn FnMut(String)) {
        let p = self.parameters();
        let dim = case.dimension();
        let (a, b) = p.friction_coefficients(dim);
        let rho0 = case.mass() * density;
        let model = if self.explicit_dumbbells > 1 {
            format!(
                "Model A, {} explicit dumbbells per particle",
                self.explicit_dumbbells
            )
        } else {
            "Model B".to_string()
        };
        line(format!(
            "GENERIC polymer fluid ({model}, isothermal, Hookean): Lucy r_c = {}, c_s = {:.6e}, \
             η_s = {:.6e}, k_BT = {:.6e}, H = {:.6e}, λ_H = {:.6e}, n^d = {:.6e}",
            p.smoothing_length,
            p.sound_speed,
            p.solvent_viscosity,
            p.kt,
            p.spring_constant,
            p.relaxation_time,
            p.dumbbell_density
        ));
        line(format!(
            "  derived: η_p = n^d k_BT λ_H = {:.6e}, Ψ₁ = 2η_pλ_H = {:.6e}, ⟨Q_aQ_a⟩_eq = \
             k_BT/H = {:.6e}, N^d per particle = {:.6e}, ρ₀ = {rho0}, friction (a, b) = \
             ({a:.6e}, {b:.6e}) for D = {dim}",
            p.polymer_viscosity(),
            2.0 * p.polymer_viscosity() * p.relaxation_time,
            p.equilibrium_component(),
            self.dumbbells_per_particle(density)
        ));
        line(format!(
            "  thesis constants (Eq. 4.66): C1 = 5η_s/3 = {:.6e}, C2² = {:.6e}, C3 = {:.6e}, \
             C4 = {:.6e}, C5 = {:.6e}; velocity noise {}, conformation drift {:?}, \
             conformation gradient {:?}",
            5.0 * p.solvent_viscosity / 3.0,
            p.equilibrium_component(),
            p.polymer_viscosity(),
            p.dumbbell_density * p.spring_constant,
            p.sound_speed * p.sound_speed,
            if self.velocity_noise { "on" } else { "off" },
            self.conformation_drift,
            self.conformation_gradient
        ));
        let pt = self.transport_pressure_at(rho0);
        if pt > 0.0 {
            let pb = self.background_pressure_at(rho0);
            let c2rho0 = p.sound_speed * p.sound_speed * rho0;
            line(format!(
                "  transport velocity: p_t = {pt:.6e} ({:.4} c_s²ρ₀); summation density, \
                 momentum pressure c_s²(ρ − ρ₀) + p_b + k_BTn^d with p_b = {pb:.6e} ({:.4} \
                 c_s²ρ₀), particles drift with v + ½Δt a^t \
                 (docs/theory/generic_polymer_particle.md §2.7)",
                pt / c2rho0,
                pb / c2rho0
            ));
        } else {
            line(
                "  transport velocity off (fluid.transport_pressure = 0): the thesis's printed \
                 form, continuity density (Eq. 4.60) and P = c_s²ρ + k_BTn^d"
                    .to_string(),
            );
        }
        if let Some(si) = &self.si {
            let ph = si.physical();
            line(format!(
                "  [fluid.si]: L₀ = {} m, λ_H = {} s, T₀ = {} K, η_s = {} Pa s, ρ₀ = {} kg/m³, \
                 N^d = {:e}, a = {} m, R_s = {} J/(kg K) → ζ = 6πη_s a = {:.4e} kg/s, H = \
                 {:.4e} kg/s², v₀ = {:.4e} m/s, η_p = {:.4e} Pa s, c_s = {:.4e} m/s",
                si.box_length,
                si.relaxation_time,
                si.temperature,
                si.solvent_viscosity,
                si.density,
                si.dumbbells,
                si.bead_radius,
                si.specific_gas_constant,
                ph.friction,
                ph.spring_constant,
                ph.velocity,
                ph.polymer_viscosity,
                ph.sound_speed
            ));
        }
        let dt = case.dt();
        for (name, limit) in self.time_step_limits(case) {
            line(format!(
                "  time step Δt = {dt}: {name} = {limit:.4e} [{}]",
                if dt <= limit { "ok" } else { "VIOLATED" }
            ));
        }
    }

    fn memory(&self, case: &dyn CaseView) -> ModelMemory {
        let d = case.dimension() as f64;
        // ρ, ρ̇, Q, Q̇ (state and a checkpoint copy) and the two-stage scratch; Model A: N_s
        // vectors Q and Q̇, and ⟨QQ⟩ (D²).
        let n_s = f64::from(self.explicit_dumbbells.max(1));
        let moment = if n_s > 1.0 { d * d } else { 0.0 };
        ModelMemory {
            numbers_per_particle: 2.0 * (2.0 + 3.0 * d * n_s) + 2.0 * (1.0 + d * n_s) + moment,
            full_lists: 1.0,
            ensemble_bytes: 0.0,
        }
    }

    fn thermal_energy(&self) -> Option<f64> {
        self.velocity_noise.then(|| self.parameters().kt)
    }

    fn continuum(&self) -> Option<crate::models::fluid_model::Continuum> {
        None
    }

    fn snapshot_quantities(
        &self,
        _case: &dyn CaseView,
    ) -> Vec<crate::models::interface::SnapshotQuantity> {
        use crate::models::interface::{SnapshotQuantity, SnapshotShape};
        vec![
            SnapshotQuantity {
                name: "density",
                shape: SnapshotShape::Scalar,
            },
            SnapshotQuantity {
                name: "conformation",
                shape: SnapshotShape::SymmetricTensor,
            },
        ]
    }
}

impl<const D: usize> BuildModels<D> for GenericPolymerCfg {
    fn build_fluid(&self, case: &dyn CaseView) -> Box<dyn ParticleModel<D>> {
        Box::new(GenericPolymer::<D>::new(
            self,
            case.mass(),
            case.number_density(),
            case.dt(),
            case.seed(),
        ))
    }
}
