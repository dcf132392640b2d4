//! Analytic solutions the runs check themselves against: start-up flows in a channel of width
//! L between walls at y = 0 and y = L, fluid at rest at t = 0, kinematic viscosity ν = η/ρ₀
//! (spec `sph-maxwell.md` §3 T1–T2; Ellero 2004 Eqs. 2.54 and 2.57, the latter with its
//! printed sign corrected).
//!
//! ```text
//! Couette (upper wall at U from t = 0)
//!   u(y, t) = U [ y/L + Σ_{n≥1} (2/(nπ)) (−1)ⁿ sin(nπy/L) exp(−n²π²νt/L²) ]
//! Poiseuille (body force F per unit mass from t = 0)
//!   u(y, t) = (F/(2ν)) y (L − y) − Σ_{n odd} (4FL²/(ν π³ n³)) sin(nπy/L) exp(−n²π²νt/L²)
//! ```
//!
//! The thesis prints the Poiseuille series with the opposite overall sign (its steady state
//! flows against the force); the sign here gives u → F y(L − y)/(2ν) > 0.

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A start-up flow with a series solution.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StartupFlow {
    /// Plane Couette flow started by the upper wall.
    Couette,
    /// Plane Poiseuille flow started by a body force.
    Poiseuille,
}

/// The series' terms are summed until exp(−n²π²νt/L²) < e^(−50) (and at least this many).
const MIN_TERMS: u32 = 2000;

fn series(y: f64, t: f64, l: f64, nu: f64, odd_only: bool, coeff: impl Fn(f64) -> f64) -> f64 {
    let decay = PI * PI * nu * t / (l * l);
    let mut sum = 0.0;
    let mut n = 1u32;
    loop {
        let nf = f64::from(n);
        let e = -nf * nf * decay;
        if n > MIN_TERMS && e < -50.0 {
            break;
        }
        if !odd_only || n % 2 == 1 {
            sum += coeff(nf) * (nf * PI * y / l).sin() * e.exp();
        }
        n += 1;
        if n > 10_000_000 {
            break;
        }
    }
    sum
}

/// Start-up Couette velocity u(y, t) (module documentation).
pub fn couette(y: f64, t: f64, l: f64, wall_velocity: f64, nu: f64) -> f64 {
    if t <= 0.0 {
        return 0.0;
    }
    let s = series(y, t, l, nu, false, |n| {
        let sign = if (n as u64).is_multiple_of(2) {
            1.0
        } else {
            -1.0
        };
        2.0 / (n * PI) * sign
    });
    wall_velocity * (y / l + s)
}

/// Start-up Poiseuille velocity u(y, t) (module documentation).
pub fn poiseuille(y: f64, t: f64, l: f64, force: f64, nu: f64) -> f64 {
    let steady = force / (2.0 * nu) * y * (l - y);
    if t <= 0.0 {
        return 0.0;
    }
    steady
        - series(y, t, l, nu, true, |n| {
            4.0 * force * l * l / (nu * PI.powi(3) * n * n * n)
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    const YS: [f64; 5] = [0.1, 0.25, 0.5, 0.75, 0.9];

    /// Spec `sph-maxwell.md` §3 T1: Re = 1 (ν = 1), U = L = 1, to the table's 4 decimals.
    #[test]
    fn couette_reproduces_the_spec_table() {
        let table = [
            (0.01, [0.0000, 0.0000, 0.0004, 0.0771, 0.4795]),
            (0.05, [0.0039, 0.0176, 0.1138, 0.4292, 0.7518]),
            (0.1, [0.0303, 0.0883, 0.2628, 0.5761, 0.8230]),
            (0.2, [0.0727, 0.1876, 0.4116, 0.6873, 0.8726]),
            (0.3, [0.0898, 0.2267, 0.4670, 0.7267, 0.8898]),
        ];
        for (t, row) in table {
            for (y, want) in YS.iter().zip(row) {
                let got = couette(*y, t, 1.0, 1.0, 1.0);
                assert!((got - want).abs() <= 5e-5, "t {t} y {y}: {got} vs {want}");
            }
        }
    }

    /// Spec §3 T2: Re = 8 (ν = 1/8, F = 1), to the table's 4 decimals, and the steady state.
    #[test]
    fn poiseuille_reproduces_the_corrected_spec_table() {
        let table = [
            (0.05, [0.0405, 0.0497, 0.0500, 0.0497, 0.0405]),
            (0.1, [0.0675, 0.0963, 0.1000, 0.0963, 0.0675]),
            (0.2, [0.1074, 0.1769, 0.1977, 0.1769, 0.1074]),
            (0.3, [0.1386, 0.2450, 0.2886, 0.2450, 0.1386]),
            (0.4, [0.1649, 0.3042, 0.3704, 0.3042, 0.1649]),
            (1e3, [0.36, 0.75, 1.00, 0.75, 0.36]),
        ];
        for (t, row) in table {
            for (y, want) in YS.iter().zip(row) {
                let got = poiseuille(*y, t, 1.0, 1.0, 0.125);
                assert!((got - want).abs() <= 5e-5, "t {t} y {y}: {got} vs {want}");
            }
        }
    }
}
