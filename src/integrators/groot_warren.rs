//! Groot–Warren modified velocity Verlet (Groot & Warren 1997, Eq. 23; spec
//! `dpd-physical-parameters.md` §1.5):
//!
//! ```text
//! r(t+Δt) = r + Δt v + ½ Δt² f(t)/m
//! ṽ       = v + λ Δt f(t)/m                   (velocity the new forces see)
//! f(t+Δt) = F(r(t+Δt), ṽ)
//! v(t+Δt) = v + ½ Δt (f(t) + f(t+Δt))/m       (stored as v_half = v + ½Δt f(t)/m, then + ½Δt f(t+Δt)/m)
//! ```
//!
//! λ = ½ is plain velocity Verlet (second order, symplectic without dissipation).

use super::Integrator;
use crate::particles::Particles;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// `[integrator] kind = "groot_warren"`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GrootWarrenCfg {
    /// Time step Δt.
    pub dt: f64,
    /// Velocity-prediction factor λ (0.5 = plain velocity Verlet).
    #[serde(default = "half")]
    pub lambda: f64,
}

fn half() -> f64 {
    0.5
}

/// The integrator for particles of mass `mass`.
#[derive(Clone, Debug)]
pub struct GrootWarren {
    dt: f64,
    lambda: f64,
    inv_mass: f64,
}

impl GrootWarren {
    /// With time step, λ and particle mass.
    pub fn new(cfg: &GrootWarrenCfg, mass: f64) -> Self {
        Self {
            dt: cfg.dt,
            lambda: cfg.lambda,
            inv_mass: 1.0 / mass,
        }
    }
}

impl<const D: usize> Integrator<D> for GrootWarren {
    fn name(&self) -> &'static str {
        "groot_warren"
    }

    fn dt(&self) -> f64 {
        self.dt
    }

    fn before_forces(&self, p: &mut Particles<D>) {
        let (dt, lambda, inv_m) = (self.dt, self.lambda, self.inv_mass);
        let n = p.n_owned;
        p.pos[..n]
            .par_iter_mut()
            .zip(p.vel[..n].par_iter_mut())
            .zip(p.vel_half.par_iter_mut())
            .zip(p.force.par_iter())
            .for_each(|(((x, v), vh), f)| {
                for d in 0..D {
                    let acc = f[d] * inv_m;
                    x[d] += dt * v[d] + 0.5 * dt * dt * acc;
                    vh[d] = v[d] + 0.5 * dt * acc;
                    v[d] += lambda * dt * acc;
                }
            });
    }

    fn after_forces(&self, p: &mut Particles<D>) {
        let (dt, inv_m) = (self.dt, self.inv_mass);
        let n = p.n_owned;
        p.vel[..n]
            .par_iter_mut()
            .zip(p.vel_half.par_iter())
            .zip(p.force.par_iter())
            .for_each(|((v, vh), f)| {
                for d in 0..D {
                    v[d] = vh[d] + 0.5 * dt * f[d] * inv_m;
                }
            });
    }
}
