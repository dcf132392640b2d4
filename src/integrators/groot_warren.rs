//! Groot–Warren modified velocity Verlet (Groot & Warren 1997, Eq. 23;
//! docs/theory/dpd_physical_parameters.md §1.5):
//!
//! ```text
//! r(t+Δt) = r + Δt v + ½ Δt² f(t)/m
//! ṽ       = v + λ Δt f(t)/m                   (velocity the new forces see)
//! f(t+Δt) = F(r(t+Δt), ṽ)
//! v(t+Δt) = v + ½ Δt (f(t) + f(t+Δt))/m       (stored as v_half = v + ½Δt f(t)/m, then + ½Δt f(t+Δt)/m)
//! ```
//!
//! λ = ½ is plain velocity Verlet (second order, symplectic without dissipation).
//!
//! ## The exponential thermostat (`thermostat = "exponential"`, SETD)
//!
//! The dissipative force is stiff at low mass: its mean-field rate is (n the number density;
//! docs/theory/dpd_physical_parameters.md §10 A7)
//!
//! ```text
//! ω₀ = γ n [w_D] / (d m),   [w_D] = ∫ w_D(r) dʳ
//! ```
//!
//! and the explicit step diverges once ω₀Δt > 2 (Nguyen 2021, Table 3.1: m = 0.01, ω₀ ≈ 8200,
//! diverging at Δt ≥ 2.5·10⁻⁴). The exponential scheme integrates the part of the dissipative
//! force that is linear in the particle's own velocity, −ω₀ v, exactly over the step: its
//! exponential-time-differencing update v ← e^{−ω₀Δt} v + (1 − e^{−ω₀Δt})/ω₀ · (F_rest/m) with the
//! rest F_rest = F + m ω₀ v taken at the start of the step is v ← v + φ Δt F/m with
//!
//! ```text
//! φ = (1 − e^{−x}) / x,   x = ω₀ Δt,
//! ```
//!
//! i.e. the dissipative force enters with the friction φγ. The noise is given the variance
//! that keeps fluctuation–dissipation at that friction, σ² = 2φγk_BT. In the mean-field limit
//! (one particle, dv = −ω₀ v dt + noise) velocity Verlet with λ = ½ then gives:
//!
//! ```text
//! ṽ' = e^{−x} ṽ + η                   (the predicted velocity: the exact decay per step)
//! v' = (1 − x_φ/2) ṽ + η/2,   x_φ = φx = 1 − e^{−x} < 1
//! ⟨v²⟩ = ⟨η²⟩ / (2 x_φ) = k_BT/m      (for any Δt; ⟨η²⟩ = 2φγ k_BT [w_D]nΔt/(d m²))
//! ```
//!
//! so the step is stable for every ω₀Δt (|e^{−x}| < 1) and the stored velocity keeps k_BT
//! exactly in that limit; what remains is the error of the pair correlations and of the
//! conservative force. The price: the dissipative momentum transfer, hence the dissipative
//! viscosity, is φη_D (φ = 0.68 at ω₀Δt = 0.82); `mesorheo check` prints φ.
//!
//! Where this departs from the [R] recipe of docs/theory/dpd_physical_parameters.md §1.5: ω₀ is
//! the mean-field rate of the fluid, one number, not a per-particle Σ_j w_D(r_ij): a per-particle
//! factor would break the pairwise antisymmetry of the forces (momentum conservation) and need
//! a halo pass for the ghosts' factors. And the noise variance is the one that makes the *stored*
//! velocity exact; the exact Ornstein–Uhlenbeck increment variance (1 − e^{−2x})/(2ω₀) would make
//! the predicted velocity ṽ exact and leave v cold by the factor (1 + e^{−x})/2 (0.72 at x = 0.82).

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
    /// How the dissipative and random forces are integrated.
    #[serde(default, skip_serializing_if = "is_explicit")]
    pub thermostat: Thermostat,
}

fn half() -> f64 {
    0.5
}

/// How the Groot–Warren step integrates the dissipative and random forces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Thermostat {
    /// With the conservative force, explicitly (stable for ω₀Δt < 2).
    #[default]
    Explicit,
    /// Exponential time differencing of the mean-field friction (module documentation):
    /// friction φγ and noise √φ σ, φ = (1 − e^{−ω₀Δt})/(ω₀Δt); stable at any ω₀Δt.
    Exponential,
}

fn is_explicit(t: &Thermostat) -> bool {
    *t == Thermostat::Explicit
}

/// The friction factor φ = (1 − e^{−x})/x of the exponential thermostat at x = ω₀Δt
/// (module documentation); 1 at x = 0, computed without cancellation for small x.
pub fn exponential_friction_factor(x: f64) -> f64 {
    if x < 1e-8 {
        1.0 - 0.5 * x
    } else {
        -(-x).exp_m1() / x
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// φ(x) = (1 − e^{−x})/x against hand values, and the mean-field algebra of the module
    /// documentation: with friction φω₀ and noise variance scaled by φ, the velocity-Verlet
    /// recursion (λ = ½) of one Ornstein–Uhlenbeck particle has the stationary ⟨v²⟩ = k_BT/m
    /// at any x, and the predicted velocity decays by e^{−x} per step.
    #[test]
    fn exponential_factor_keeps_the_mean_field_temperature_at_any_step() {
        assert_eq!(exponential_friction_factor(0.0), 1.0);
        assert!((exponential_friction_factor(1.0) - 0.632_120_558_828_557_7).abs() < 1e-15);
        assert!((exponential_friction_factor(1e-9) - (1.0 - 5e-10)).abs() < 1e-16);
        for x in [0.1, 0.82, 2.05, 4.1, 20.0] {
            let phi = exponential_friction_factor(x);
            let xf = phi * x;
            // State (ṽ, v) after the kick: ṽ' = (1 − x_φ) ṽ + η, v' = (1 − x_φ/2) ṽ + η/2,
            // η of variance q (per unit k_BT/m: q = 2 x_φ). Stationary moments:
            let q = 2.0 * xf;
            let var_pred = q / (1.0 - (1.0 - xf).powi(2));
            let var_v = (1.0 - 0.5 * xf).powi(2) * var_pred + 0.25 * q;
            assert!((var_v - 1.0).abs() < 1e-12, "x = {x}: ⟨v²⟩ = {var_v}");
            assert!(((1.0 - xf) - (-x).exp()).abs() < 1e-15);
            // The explicit step with the plain friction is exact too, but only while x < 2.
            let plain = (1.0 - (1.0 - x).powi(2)) > 0.0 && (1.0 - x).abs() < 1.0;
            assert_eq!(plain, x < 2.0);
        }
    }
}
