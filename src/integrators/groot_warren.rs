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
use crate::species::{Motion, Species};
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

/// The integrator for particles of mass `mass` (one species), or of several species.
#[derive(Clone, Debug)]
pub struct GrootWarren {
    dt: f64,
    lambda: f64,
    inv_mass: f64,
    /// With several species: each one's 1/m and motion.
    species: Vec<(f64, Motion)>,
}

impl GrootWarren {
    /// With time step, λ and particle mass.
    pub fn new(cfg: &GrootWarrenCfg, mass: f64) -> Self {
        Self {
            dt: cfg.dt,
            lambda: cfg.lambda,
            inv_mass: 1.0 / mass,
            species: Vec::new(),
        }
    }

    /// For a scene with the species `table` (indexed by [`Particles::species`]).
    pub fn with_species(mut self, table: &[Species]) -> Self {
        self.species = table.iter().map(|s| (1.0 / s.mass, s.motion)).collect();
        self
    }

    /// The step of a particle of several-species scene: free ones as in the one-species
    /// loop, prescribed ones at their velocity, frozen ones not at all.
    fn before_forces_by_species<const D: usize>(&self, p: &mut Particles<D>) {
        let (dt, lambda) = (self.dt, self.lambda);
        let n = p.n_owned;
        let species = p.species.as_deref().expect("a several-species scene");
        p.pos[..n]
            .par_iter_mut()
            .zip(p.vel[..n].par_iter_mut())
            .zip(p.vel_half.par_iter_mut())
            .zip(p.force.par_iter())
            .zip(species[..n].par_iter())
            .for_each(|((((x, v), vh), f), &s)| match self.species[s as usize] {
                (inv_m, Motion::Free) => {
                    for d in 0..D {
                        let acc = f[d] * inv_m;
                        x[d] += dt * v[d] + 0.5 * dt * dt * acc;
                        vh[d] = v[d] + 0.5 * dt * acc;
                        v[d] += lambda * dt * acc;
                    }
                }
                (_, Motion::Prescribed(u)) => {
                    for d in 0..D {
                        x[d] += dt * u[d];
                    }
                    v.copy_from_slice(&u[..D]);
                    vh.copy_from_slice(&u[..D]);
                }
                (_, Motion::Frozen) => {}
            });
    }
}

impl<const D: usize> Integrator<D> for GrootWarren {
    fn name(&self) -> &'static str {
        "groot_warren"
    }

    fn dt(&self) -> f64 {
        self.dt
    }

    fn before_forces(&self, p: &mut Particles<D>, _stage: usize) {
        if !self.species.is_empty() {
            return self.before_forces_by_species(p);
        }
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

    fn after_forces(&self, p: &mut Particles<D>, _stage: usize) {
        let (dt, inv_m) = (self.dt, self.inv_mass);
        let n = p.n_owned;
        if let Some(species) = p.species.as_deref() {
            p.vel[..n]
                .par_iter_mut()
                .zip(p.vel_half.par_iter())
                .zip(p.force.par_iter())
                .zip(species[..n].par_iter())
                .for_each(|(((v, vh), f), &s)| {
                    if let (inv_m, Motion::Free) = self.species[s as usize] {
                        for d in 0..D {
                            v[d] = vh[d] + 0.5 * dt * f[d] * inv_m;
                        }
                    }
                });
            return;
        }
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
