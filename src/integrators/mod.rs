//! Time integrators, chosen in the case (`[integrator] kind = …`): components of the step
//! loop. A step has one or more *stages*; in each, the loop calls
//! [`Integrator::before_forces`], brings the ghosts up to date, evaluates the models' passes at
//! the new state, then calls [`Integrator::after_forces`].
//!
//! Besides positions and velocities, an integrator advances the fields the models declare as
//! integrated ([`crate::models::interface::ParticleModel::integrated_fields`]: a continuity
//! density with its rate, a stress with its constitutive rate), with the same scheme as the
//! velocity.
//!
//! | kind | stages | order | use |
//! |---|---|---|---|
//! | `groot_warren` | 1 | 2 (λ = ½) | DPD |
//! | `kick_drift_kick` | 1 | 2 | SPH: symplectic for the conservative part, neutrally stable sound waves |
//! | `heun` | 2 | 2 | SPH: predictor Δt, averaged corrector |
//! | `midpoint` | 2 | 2 | SPH: predictor Δt/2, corrector with the midpoint rate |
//! | `thesis_predictor_corrector` | 2 | 1 | Ellero 2004 Eqs. 2.49–2.50 as printed, to reproduce the text |

pub mod groot_warren;
pub mod sph_schemes;

use crate::particles::Particles;
use serde::{Deserialize, Serialize};

pub use groot_warren::{GrootWarren, GrootWarrenCfg, Thermostat, exponential_friction_factor};
pub use sph_schemes::{KickDriftKick, KickDriftKickCfg, TwoStage, TwoStageCfg, TwoStageVariant};

/// `[integrator]`, selected by `kind`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum IntegratorCfg {
    /// Groot–Warren modified velocity Verlet.
    GrootWarren(GrootWarrenCfg),
    /// Symplectic kick–drift–kick (velocity Verlet with predicted velocities).
    KickDriftKick(KickDriftKickCfg),
    /// Heun's second-order predictor–corrector.
    Heun(TwoStageCfg),
    /// The explicit midpoint rule.
    Midpoint(TwoStageCfg),
    /// Ellero 2004's predictor–corrector as printed (first order; to reproduce the text).
    ThesisPredictorCorrector(TwoStageCfg),
}

impl IntegratorCfg {
    /// Time step.
    pub fn dt(&self) -> f64 {
        match self {
            IntegratorCfg::GrootWarren(g) => g.dt,
            IntegratorCfg::KickDriftKick(k) => k.dt,
            IntegratorCfg::Heun(t)
            | IntegratorCfg::Midpoint(t)
            | IntegratorCfg::ThesisPredictorCorrector(t) => t.dt,
        }
    }

    /// Force evaluations per step.
    pub fn stages(&self) -> usize {
        match self {
            IntegratorCfg::GrootWarren(_) | IntegratorCfg::KickDriftKick(_) => 1,
            _ => 2,
        }
    }
}

/// A state field the integrator advances: `state` with `rate`, both extra fields of equal
/// width (indices into [`Particles::extra`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntegratedField {
    /// The state's field index.
    pub state: usize,
    /// Its rate's field index.
    pub rate: usize,
    /// Whether boundary particles (never moved) advance it too.
    pub boundary_particles: bool,
}

/// An integrator of the owned particles' positions, velocities and integrated fields.
pub trait Integrator<const D: usize>: Send + Sync {
    /// Name (for logs).
    fn name(&self) -> &'static str;

    /// Time step Δt.
    fn dt(&self) -> f64;

    /// Learns the field `c` the particles drift with in addition to their velocity, ṙ = v + c
    /// (a model's [`crate::models::interface::ParticleModel::drift_correction`]). The default
    /// refuses: case validation admits a drift correction only with an integrator that
    /// overrides this.
    fn bind_drift_correction(&mut self, field: usize) -> Result<(), String> {
        let _ = field;
        Err(format!(
            "the integrator {} does not move particles with a drift correction (XSPH); use \
             kick_drift_kick",
            self.name()
        ))
    }

    /// Force evaluations per step (default 1).
    fn stages(&self) -> usize {
        1
    }

    /// Learns the integrated fields and registers any scratch fields it keeps per particle
    /// (they must migrate with their particle: a rebuild may fall between two stages). Called
    /// once the models are attached, and again whenever the integrator is rebuilt.
    fn bind(&mut self, particles: &mut Particles<D>, integrated: &[IntegratedField]) {
        let _ = (particles, integrated);
    }

    /// Stage `stage` of the step from t to t + Δt: moves the owned particles and sets the
    /// velocities (and integrated fields) the stage's forces will see, using the forces and
    /// rates in the particles. Runs on the rank's worker pool.
    fn before_forces(&self, particles: &mut Particles<D>, stage: usize);

    /// Completes stage `stage` with the forces and rates just evaluated. Runs on the rank's
    /// worker pool.
    fn after_forces(&self, particles: &mut Particles<D>, stage: usize);
}
