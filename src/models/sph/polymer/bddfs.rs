//! `model = "bddfs"` (CONNFFESSIT with distribution-function storing): the dumbbells of
//! `dumbbells`, but each fluid particle keeps only their histogram on a Q-grid of `cells` per
//! axis over [−`q_max`, `q_max`]^D and regenerates them every step
//! ([`crate::models::bddfs`]; the companion model is the same
//! [`crate::models::dumbbell_ensemble`] in histogram storage). The stress is the Kramers
//! stress G(⟨Q'F(Q')⟩ − I) of the advanced connectors, as for `dumbbells`: this law has no
//! rate, and its rheology is that of `dumbbells` plus the grid's diffusion (`check`).

use super::dumbbells::Dumbbells;
use super::{Law, LawParams, PolymerCfg};

/// `model = "bddfs"`.
pub struct Bddfs;

impl Law for Bddfs {
    const ENSEMBLE: bool = true;
    const KEYS: &'static [&'static str] = &[
        "per_particle",
        "spring",
        "b",
        "scheme",
        "noise",
        "cells",
        "q_max",
    ];

    /// N_d is required; the grid keys are checked with the ensemble's
    /// ([`crate::models::dumbbell_settings::validate_histogram_grid`]).
    fn validate(cfg: &PolymerCfg) -> Result<(), (&'static str, String)> {
        if cfg.per_particle.is_none() {
            return Err((
                "model",
                "model = \"bddfs\" needs per_particle = N_d, the dumbbells each fluid particle \
                 regenerates from its histogram every step (10²–10⁴ typical)"
                    .to_string(),
            ));
        }
        Ok(())
    }

    fn rate<const D: usize>(_: &LawParams, _: &[f64], _: &[[f64; D]; D], _: &mut [f64]) {
        unreachable!("BDDFS histograms have no constitutive rate (`ConstitutiveLaw::of`)")
    }

    /// As `dumbbells` (the grid's diffusion aside).
    fn oldroyd_b(cfg: &PolymerCfg) -> bool {
        <Dumbbells as Law>::oldroyd_b(cfg)
    }

    /// As `dumbbells`.
    fn zero_shear_factor(cfg: &PolymerCfg, dimension: usize) -> Option<(f64, &'static str)> {
        <Dumbbells as Law>::zero_shear_factor(cfg, dimension)
    }

    /// The grid, its artificial diffusion against the Brownian Δt/λ (a warning with the n_c
    /// that brings it to 1 %), and the memory per particle of BDDFS and of explicit dumbbells
    /// ([`crate::models::bddfs::check_lines`]).
    fn check_lines(cfg: &PolymerCfg, dimension: usize, dt: f64) -> Vec<String> {
        cfg.histogram_grid().map_or_else(Vec::new, |grid| {
            crate::models::bddfs::check_lines(
                &grid,
                cfg.per_particle.unwrap_or(0),
                dimension,
                dt,
                cfg.relaxation_time,
            )
        })
    }

    /// As `dumbbells`.
    fn steady_shear_tension(cfg: &PolymerCfg, shear_rate: f64, dimension: usize) -> f64 {
        <Dumbbells as Law>::steady_shear_tension(cfg, shear_rate, dimension)
    }
}
