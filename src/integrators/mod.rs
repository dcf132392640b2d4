//! Time integrators, chosen in the case (`[integrator] kind = …`): components of the step
//! loop, which calls [`Integrator::before_forces`], evaluates the models' passes at the new
//! positions, then calls [`Integrator::after_forces`].

pub mod groot_warren;

use crate::particles::Particles;

pub use groot_warren::GrootWarren;

/// A two-half-step integrator of the owned particles' positions and velocities.
pub trait Integrator<const D: usize>: Send + Sync {
    /// Name (for logs).
    fn name(&self) -> &'static str;

    /// Time step Δt.
    fn dt(&self) -> f64;

    /// From t to t + Δt: moves the owned particles and sets the velocities the new forces
    /// will see, using the forces of t (in `particles.force`). Runs on the rank's worker pool.
    fn before_forces(&self, particles: &mut Particles<D>);

    /// Completes the step with the forces of t + Δt. Runs on the rank's worker pool.
    fn after_forces(&self, particles: &mut Particles<D>);
}
