//! Time-step limits that `check` reports and the validation enforces.
//!
//! DPD (explicit in the velocity-dependent dissipative force):
//!
//! ```text
//! Σ_j w_D(r_ij) ≈ n ∫ w_D dV = n 4π r_c³ · 2 / ((s+1)(s+2)(s+3))     (3D)
//!                            = n 2π r_c² / ((s+1)(s+2))               (2D)
//! Δt_D = m / (γ Σ_j w_D)          relaxation of the relative velocity in one step
//! ω²   = (a / r_c) N_c / (D m),   N_c = n V_D(r_c) neighbours,   Δt_C = 2 / ω  (Verlet)
//! ```
//!
//! Δt_D is the step at which the explicit update over-corrects the relative velocity of a
//! particle and its neighbourhood; beyond Δt_C the conservative oscillation of a particle in
//! its cage is unstable under velocity Verlet. Groot & Warren (1997) recommend Δt ≈ 0.04–0.06 at
//! a = 25, γ = 4.5, ρ = 3 for k_BT within a few per cent: that accuracy limit is reported, not
//! enforced (see the k_BT-vs-Δt curve in docs/validation.md).
//!
//! SPH (the summation gas): the acoustic CFL limit Δt < 0.25 h / c (Monaghan 1992; spec
//! `sph-maxwell.md` §1).

use crate::models::dpd::DpdCfg;

/// Time-step limits of a DPD case.
#[derive(Clone, Copy, Debug)]
pub struct DpdLimits {
    /// Expected neighbours inside the cutoff.
    pub neighbours: f64,
    /// Σ_j w_D at the mean density.
    pub sum_wd: f64,
    /// Dissipative stability limit Δt_D.
    pub dissipative: f64,
    /// Conservative (Verlet) stability limit Δt_C.
    pub conservative: f64,
}

/// Volume of the D-ball of radius r.
pub fn ball_volume(dimension: usize, r: f64) -> f64 {
    if dimension == 2 {
        std::f64::consts::PI * r * r
    } else {
        4.0 / 3.0 * std::f64::consts::PI * r * r * r
    }
}

/// The acoustic (CFL) limit 0.25 h / c of an SPH fluid with smoothing length h and sound
/// speed c.
pub fn cfl_limit(smoothing_length: f64, sound_speed: f64) -> f64 {
    0.25 * smoothing_length / sound_speed
}

/// Limits for the DPD fluid `d` in `dimension` dimensions at number density `n` and particle
/// mass `m`.
pub fn dpd_limits(d: &DpdCfg, dimension: usize, n: f64, m: f64) -> DpdLimits {
    let s = d.weight_exponent;
    let rc = d.cutoff;
    let dim = dimension;
    let sum_wd = if dim == 2 {
        n * 2.0 * std::f64::consts::PI * rc * rc / ((s + 1.0) * (s + 2.0))
    } else {
        n * 4.0 * std::f64::consts::PI * rc.powi(3) * 2.0 / ((s + 1.0) * (s + 2.0) * (s + 3.0))
    };
    let neighbours = n * ball_volume(dim, rc);
    let omega2 = d.a / rc * neighbours / (dim as f64 * m);
    DpdLimits {
        neighbours,
        sum_wd,
        dissipative: m / (d.gamma * sum_wd),
        conservative: if omega2 > 0.0 {
            2.0 / omega2.sqrt()
        } else {
            f64::INFINITY
        },
    }
}
