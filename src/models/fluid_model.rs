//! What a fluid model owns: everything the generic layers (validation, `check`, the step, the
//! measurement, the summary) used to ask of it by name.
//!
//! # Adding a fluid model
//!
//! A fluid model is one directory (or file) in `src/models/` and one line of the registry
//! ([`crate::config::registry`]). Its parameter struct (the `[fluid]` table, serde with
//! `deny_unknown_fields`) implements
//!
//! - [`FluidModel`]: its cutoff, parameter validation, the integrators and observables it
//!   supports, its time-step limits, its `check` report, its memory, its blow-up detectors, the
//!   parts of its measured stress and what the analytic references need to know of it;
//! - [`BuildModels`]: the particle models a case of this fluid runs ([`ParticleModel`]): the
//!   fluid itself, and its companions (the dumbbell ensembles a CONNFFESSIT fluid carries).
//!
//! The generic layers call these through `case.fluid.model()` and never name a model; a
//! default method is what a model without the feature answers.

use super::interface::ParticleModel;
use crate::geometry::{Axis, Boundary, Lattice, VelocityProfile};
use crate::integrators::IntegratorCfg;
use crate::models::sph::{InclusionsCfg, WallsCfg};
use crate::observable::Observable;
use crate::spans::{CaseError, SpanIndex};

/// Contributions of the momentum flux of a fluid with central pair forces (DPD).
pub const CENTRAL_STRESS_PARTS: [&str; 5] =
    ["total", "kinetic", "conservative", "dissipative", "random"];

/// How the transverse-current correlators sample (`diagnostics.transverse_current_*`).
#[derive(Clone, Copy, Debug)]
pub struct TransverseCurrentSampling {
    /// Steps between samples.
    pub every: u64,
    /// Wavenumbers 2πj/L, j = 1 … modes.
    pub modes: usize,
    /// Longest lag of the correlators.
    pub time: f64,
}

/// What a fluid model may ask of the case it is part of (implemented by
/// [`crate::config::Case`]; the model layer does not depend on the case-file schema).
pub trait CaseView {
    /// 2 or 3.
    fn dimension(&self) -> usize;
    /// Seed of every random number of the run.
    fn seed(&self) -> u64;
    /// Box edge lengths.
    fn lengths(&self) -> &[f64];
    /// Shear rate γ̇ of the Lees–Edwards box (0: none).
    fn shear_rate(&self) -> f64;
    /// Boundary kind of each axis.
    fn boundaries(&self) -> Vec<Boundary>;
    /// The slab decomposition's axis.
    fn decomposition_axis(&self) -> Axis;
    /// Particle mass m.
    fn mass(&self) -> f64;
    /// The number density asked for (`particles.density`).
    fn number_density(&self) -> f64;
    /// The initial arrangement.
    fn lattice(&self) -> Lattice;
    /// Spacing Δ of the initial lattice.
    fn lattice_spacing(&self) -> f64;
    /// Cells of the initial lattice per axis and the particle count.
    fn lattice_counts(&self) -> (Vec<usize>, u64);
    /// The initial mean velocity field and its amplitude.
    fn velocity_profile(&self) -> (VelocityProfile, f64);
    /// The integrator.
    fn integrator(&self) -> &IntegratorCfg;
    /// Its time step Δt.
    fn dt(&self) -> f64 {
        self.integrator().dt()
    }
    /// φ of the exponential thermostat, when the case integrates its friction exactly.
    fn exponential_friction_factor(&self) -> Option<f64>;
    /// Steps of the run.
    fn steps(&self) -> u64;
    /// Whether the case lists observable `o`.
    fn wants(&self, o: Observable) -> bool;
    /// Bins of the profiles across y.
    fn profile_bins(&self) -> usize;
    /// Sampling of the transverse currents (`diagnostics.transverse_current_*`).
    fn transverse_current_sampling(&self) -> TransverseCurrentSampling;
    /// Boundary-particle walls.
    fn walls(&self) -> Option<&WallsCfg>;
    /// Rigid inclusions.
    fn inclusions(&self) -> Option<&InclusionsCfg>;
    /// Rows of wall particles beyond each face of the wall axis.
    fn wall_layer_count(&self, axis: usize) -> usize;
}

/// A body force that drives a fluid: the acceleration g, and whether it is the "reverse"
/// (double-Poiseuille) profile, g in one half of the box along y and −g in the other.
#[derive(Clone, Copy, Debug, Default)]
pub struct BodyForce<'a> {
    /// The acceleration, D components (empty: none).
    pub acceleration: &'a [f64],
    /// g(y) = +g for y < L_y/2 and −g above.
    pub reverse: bool,
}

impl BodyForce<'_> {
    /// Whether any component is non-zero.
    pub fn drives(&self) -> bool {
        self.acceleration.iter().any(|&g| g != 0.0)
    }

    /// g_x (0 without a force).
    pub fn x(&self) -> f64 {
        self.acceleration.first().copied().unwrap_or(0.0)
    }
}

/// The continuum a fluid model discretises, for the analytic references (start-up Couette and
/// Poiseuille, relaxation): an incompressible Oldroyd-B fluid (η_p = 0: Newtonian).
#[derive(Clone, Copy, Debug)]
pub struct Continuum {
    /// Mass density ρ₀.
    pub density: f64,
    /// Solvent viscosity η_s.
    pub solvent_viscosity: f64,
    /// The polymer, when the fluid has one.
    pub polymer: Option<ContinuumPolymer>,
}

/// The polymer of a [`Continuum`].
#[derive(Clone, Copy, Debug)]
pub struct ContinuumPolymer {
    /// Polymer viscosity η_p.
    pub viscosity: f64,
    /// Relaxation time λ.
    pub relaxation_time: f64,
    /// Whether its constitutive law is Oldroyd-B's (upper-convected Maxwell, Hookean
    /// dumbbells), whose start-up series the references know.
    pub oldroyd_b: bool,
}

/// Bytes per particle a fluid model needs beyond the engine's core arrays.
#[derive(Clone, Copy, Debug, Default)]
pub struct ModelMemory {
    /// Numbers (f64) per particle of the model's fields (checkpointed ones twice: the state and
    /// its copy at the last step start).
    pub numbers_per_particle: f64,
    /// Full neighbour lists kept beside the half list (4 bytes per directed entry each).
    pub full_lists: f64,
    /// Bytes of per-particle ensembles (dumbbells) an owned fluid particle carries.
    pub ensemble_bytes: f64,
}

/// Everything a fluid model declares about itself (module doc).
pub trait FluidModel: Send + Sync {
    /// The `kind` of its `[fluid]` table.
    fn kind(&self) -> &'static str;

    /// Interaction range of its pair forces.
    fn cutoff(&self) -> f64;

    /// The `[fluid]` key that sets [`Self::cutoff`] (for errors about the range).
    fn cutoff_key(&self) -> &'static str;

    /// Checks its `[fluid]` table (and the tables only it reads, `[walls]`, `[inclusions]`)
    /// against the case; the error names the file, line and column through `ix`.
    fn validate(&self, case: &dyn CaseView, ix: &SpanIndex) -> Result<(), CaseError>;

    /// Whether `integrator` can integrate it; `Err(message)` (about `integrator.kind`)
    /// otherwise.
    fn accepts_integrator(&self, integrator: &IntegratorCfg) -> Result<(), String>;

    /// The mean-field friction rate ω₀ of a thermostatted fluid (its velocity among neighbours
    /// at rest relaxes as e^{−ω₀t}) at number density `n` and mass `m`: what the exponential
    /// thermostat integrates exactly. `None`: no friction.
    fn friction_rate(&self, _dimension: usize, _n: f64, _m: f64) -> Option<f64> {
        None
    }

    /// Its time-step limits, each with its name, for the case's integrator; the run refuses a
    /// Δt above the smallest unless `run.beyond_stability_limits`.
    fn time_step_limits(&self, case: &dyn CaseView) -> Vec<(String, f64)>;

    /// Why a Δt beyond `limit` (the named, binding one) is refused, with what would help.
    fn time_step_error(&self, case: &dyn CaseView, dt: f64) -> Option<String> {
        let limits = self.time_step_limits(case);
        let (name, limit) = binding_limit(&limits)?;
        (dt > limit).then(|| {
            let all: Vec<String> = limits
                .iter()
                .map(|(n, l)| format!("{n} = {l:.4e}"))
                .collect();
            format!(
                "Δt = {dt} is beyond the {name} limit {limit:.4e} (limits: {}); use a smaller \
                 time step",
                all.join(", ")
            )
        })
    }

    /// The observables a case of this fluid records when `[diagnostics] observables` is left
    /// out.
    fn default_observables(&self, case: &dyn CaseView) -> Vec<Observable>;

    /// Whether it can produce observable `o` in this case; `Err(message)` otherwise (the
    /// generic conditions, shear or dimension, are checked by the caller).
    fn supports(&self, case: &dyn CaseView, o: Observable) -> Result<(), String>;

    /// The contributions its momentum flux (the `stress` observable) is split into; the first
    /// is "total" and the second "kinetic".
    fn stress_parts(&self) -> Vec<&'static str>;

    /// The particles it adds on top of the fluid lattice: the constituents of suspended rigid
    /// bodies ([`crate::rigid_bodies`]); `check` counts them apart from the solvent.
    fn constituent_count(&self, _case: &dyn CaseView) -> u64 {
        0
    }

    /// Whether its momentum flux is symmetric (central pair forces): `stress` then lists the
    /// upper triangle only.
    fn symmetric_stress(&self) -> bool {
        true
    }

    /// Its lines of the `check` report, at the case's number density `density`.
    fn report(&self, case: &dyn CaseView, density: f64, line: &mut dyn FnMut(String));

    /// Its lines of the `check` report's cost estimate, for `particles` particles (an upper
    /// bound where wall and inclusion particles are counted).
    fn cost_report(&self, _case: &dyn CaseView, _particles: f64, _line: &mut dyn FnMut(String)) {}

    /// Its memory per particle ([`ModelMemory`]).
    fn memory(&self, case: &dyn CaseView) -> ModelMemory;

    /// k_BT of a thermostatted fluid (the runaway and heating detectors, the fluctuation
    /// methods of the viscosity need it); `None` for an athermal fluid.
    fn thermal_energy(&self) -> Option<f64> {
        None
    }

    /// The peculiar kinetic energy, in k_BT, that no thermalised particle reaches: beyond it a
    /// particle has run away (∞: no detector).
    fn runaway_bound_in_kt(&self, _dimension: usize, _density: f64) -> f64 {
        f64::INFINITY
    }

    /// Whether a fluid at kinetic temperature `kinetic_temperature` (in energy units) at time
    /// `time` is heating without bound: the diagnosis when it is (`None`: no detector, or
    /// healthy).
    fn heating(
        &self,
        _kinetic_temperature: f64,
        _dimension: usize,
        _density: f64,
        _mass: f64,
        _time: f64,
    ) -> Option<String> {
        None
    }

    /// The body force that drives it.
    fn body_force(&self) -> BodyForce<'_> {
        BodyForce::default()
    }

    /// The viscosity it was built to have (a DPD fluid mapped from physical properties), which
    /// a reference may use as its solution's viscosity.
    fn target_viscosity(&self) -> Option<f64> {
        None
    }

    /// The per-particle quantities it offers to the snapshots in this case, besides the
    /// engine's (`output.snapshot_fields`; [`super::interface::SnapshotQuantity`]); its particle
    /// models give their values ([`ParticleModel::snapshot_values`]).
    fn snapshot_quantities(&self, _case: &dyn CaseView) -> Vec<super::interface::SnapshotQuantity> {
        Vec::new()
    }

    /// The continuum it discretises, when it has one ([`Continuum`]).
    fn continuum(&self) -> Option<Continuum> {
        None
    }
}

/// What a fluid model runs in D dimensions.
pub trait BuildModels<const D: usize> {
    /// The fluid's particle model.
    fn build_fluid(&self, case: &dyn CaseView) -> Box<dyn ParticleModel<D>>;

    /// The species of a scene with boundary particles (an SPH fluid's walls and inclusions):
    /// the table and the species of the particle at each initial position; `None` when every
    /// particle is fluid.
    fn species_layout(&self, _case: &dyn CaseView) -> Option<SpeciesLayout<D>> {
        None
    }

    /// The rigid bodies of spring-tied constituents it suspends ([`crate::rigid_bodies`]), whose
    /// constituents the engine adds after the fluid's particles; `None` without any.
    fn rigid_bodies(
        &self,
        _case: &dyn CaseView,
    ) -> Result<Option<crate::rigid_bodies::RigidBodies<D>>, String> {
        Ok(None)
    }

    /// Relaxes the uniformly random positions of a random start (`particles.lattice =
    /// "random"`: every fluid particle of the system, in id order, before the rank keeps its
    /// own) before the run proper; the default leaves them. Must depend on nothing but the
    /// case and the positions (every rank does it alike).
    fn relax_random_start(&self, _case: &dyn CaseView, _positions: &mut [[f64; D]]) {}

    /// The models it needs beside the fluid (attached after the species are known).
    fn build_companions(
        &self,
        _case: &dyn CaseView,
    ) -> Result<Vec<Box<dyn ParticleModel<D>>>, String> {
        Ok(Vec::new())
    }
}

/// What a fluid kind can do, known without a case: the registry reads it to check a case and
/// to say which kinds provide what ([`crate::config::registry`]).
pub trait KindTraits {
    /// Whether the kind carries boundary particles (`[walls]`, `[inclusions]`).
    const CARRIES_BOUNDARY_PARTICLES: bool = false;
    /// Its `[fluid]` keys, documented for the case-file reference (`mesorheo keys`).
    const KEYS: &'static [crate::key_doc::KeyDoc] = &[];
}

/// The species number of the particle whose initial position is the argument.
pub type SpeciesAt<const D: usize> = Box<dyn Fn(&[f64; D]) -> u8 + Send + Sync>;

/// The species of a scene ([`BuildModels::species_layout`]): the table, and the species of the
/// particle starting at a position.
pub struct SpeciesLayout<const D: usize> {
    /// The species, indexed by their number.
    pub table: Vec<crate::species::Species>,
    /// The species number of the particle whose initial position is the argument.
    pub species_at: SpeciesAt<D>,
}

/// The binding (smallest) of named limits, `None` when there are none.
pub fn binding_limit(limits: &[(String, f64)]) -> Option<(&str, f64)> {
    limits
        .iter()
        .fold(None, |best: Option<(&str, f64)>, (n, l)| match best {
            Some((_, b)) if b <= *l => best,
            _ => Some((n.as_str(), *l)),
        })
}

/// What a model answers, by default, for an observable that only some models provide: the
/// observable's own requirement (a model that provides it accepts it before calling this).
pub fn generic_support(o: Observable) -> Result<(), String> {
    let need = match o {
        Observable::ConstitutiveStress => {
            "\"constitutive_stress\" is the SPH particles' own stress σ̄; it needs an SPH \
             fluid that forms it (fluid.viscous_term = \"nested_summation\", a \
             [fluid.polymer], or [inclusions]); the momentum flux (\"viscosity\", \
             \"stress\") is measured for every fluid"
        }
        Observable::PolymerStressTrace => {
            "\"polymer_stress_trace\" needs a polymer stress ([fluid.polymer] of an SPH \
             fluid)"
        }
        Observable::ShearStressProfile => {
            "\"shear_stress_profile\" bins the DPD pair and kinetic stress; it needs [fluid] \
             kind = \"dpd\""
        }
        Observable::DensityProfile => {
            "\"density_profile\" is the SPH density per bin; it needs [fluid] kind = \"sph\""
        }
        Observable::GreenKuboViscosity => {
            "\"green_kubo_viscosity\" correlates the pair virial of a DPD fluid; it needs \
             [fluid] kind = \"dpd\""
        }
        Observable::Conformation => {
            "\"conformation\" is the mean of the particles' conformation vectors; it needs a \
             fluid whose particles carry one ([fluid] kind = \"generic_polymer\")"
        }
        Observable::TransverseCurrentViscosity => {
            "\"transverse_current_viscosity\" needs a thermal fluid, [fluid] kind = \"dpd\""
        }
        Observable::ColloidVelocityVariance => {
            "\"colloid_velocity_variance\" measures suspended rigid bodies; it needs \
             [fluid.colloids] of a DPD fluid (not fixed)"
        }
        Observable::ColloidSolventRdf => {
            "\"colloid_solvent_rdf\" bins the solvent about suspended rigid bodies; it needs \
             [fluid.colloids] of a DPD fluid"
        }
        _ => return Ok(()),
    };
    Err(need.to_string())
}
