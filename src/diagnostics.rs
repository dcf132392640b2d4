//! Observables and their time averages with block-averaged standard errors.
//!
//! Pressure tensor (compressive positive), with the peculiar velocity V_i = v_i − u(y_i):
//!
//! ```text
//! P = (1/V) [ Σ_i m V_i ⊗ V_i + Σ_{pairs} r_ij ⊗ F_ij ],  F = F^C + F^D + F^R
//! p = tr P / D,   η = −⟨P_xy⟩ / γ̇,   N₁ = σ_xx − σ_yy = P_yy − P_xx,   N₂ = P_zz − P_yy
//! ```
//!
//! Under shear u(y) is the *measured* streaming velocity (profile-unbiased): the bin means along
//! y interpolated linearly between bin centres, periodic with the Lees–Edwards jump ±γ̇L_y, so
//! the profile inside a bin does not leak into P_xx or k_BT; without shear it is the mean
//! velocity of the whole system. The temperature is k_BT = Σ m |V|² / (D (N − n_bins)),
//! removing the D degrees of freedom of every bin mean.
//! The total momentum reported is the peculiar one, Σ m (v − γ̇ (y − L_y/2) x̂), which a
//! Lees–Edwards crossing leaves unchanged, so it is conserved to round-off with or without shear.
//!
//! Every sum (per-rank and over ranks) is exact fixed point ([`crate::fixed_sum::FixedSum`]), so
//! the observables are bitwise the same for any rank and thread count, like the state.

use crate::config::{Case, Observable};
use std::collections::BTreeMap;

/// Names of the D×D components in the upper triangle.
pub fn tensor_components(dimension: usize) -> Vec<(usize, usize, String)> {
    let names = ["x", "y", "z"];
    let mut out = Vec::new();
    for a in 0..dimension {
        for b in a..dimension {
            out.push((a, b, format!("{}{}", names[a], names[b])));
        }
    }
    out
}

/// Contributions of the stress tensor.
pub const STRESS_PARTS: [&str; 5] = ["total", "kinetic", "conservative", "dissipative", "random"];

/// Every scalar observable name the case produces (for references and the summary).
pub fn scalar_names(case: &Case) -> Vec<String> {
    let mut out = Vec::new();
    let dim = case.dimension;
    for o in &case.diagnostics.observables {
        match o {
            Observable::Stress => {
                for part in STRESS_PARTS {
                    for (_, _, c) in tensor_components(dim) {
                        out.push(format!("stress_{part}_{c}"));
                    }
                }
            }
            Observable::Momentum => {
                for c in ["x", "y", "z"].iter().take(dim) {
                    out.push(format!("momentum_{c}"));
                }
            }
            Observable::VelocityProfile => {}
            other => out.push(other.name().to_owned()),
        }
    }
    out
}

/// Mean, standard error and sample count of a time series.
#[derive(Clone, Copy, Debug, serde::Serialize, PartialEq)]
pub struct Estimate {
    /// Time average.
    pub mean: f64,
    /// Block-averaged standard error of the mean.
    pub stderr: f64,
    /// Number of samples.
    pub samples: usize,
}

/// Block average: the series is cut into `blocks` equal blocks (dropping the oldest remainder)
/// and the standard error is the spread of the block means, s_B / √n_B.
pub fn block_average(series: &[f64], blocks: usize) -> Estimate {
    let n = series.len();
    if n == 0 {
        return Estimate {
            mean: f64::NAN,
            stderr: f64::NAN,
            samples: 0,
        };
    }
    let mean = series.iter().sum::<f64>() / n as f64;
    let nb = blocks.min(n);
    let size = n / nb;
    if nb < 2 || size == 0 {
        return Estimate {
            mean,
            stderr: f64::NAN,
            samples: n,
        };
    }
    let start = n - nb * size;
    let means: Vec<f64> = series[start..]
        .chunks_exact(size)
        .map(|c| c.iter().sum::<f64>() / size as f64)
        .collect();
    let bm = means.iter().sum::<f64>() / nb as f64;
    let var = means.iter().map(|m| (m - bm) * (m - bm)).sum::<f64>() / (nb - 1) as f64;
    Estimate {
        mean,
        stderr: (var / nb as f64).sqrt(),
        samples: n,
    }
}

/// Time series collected during a run.
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Scalar observables by name.
    pub scalars: BTreeMap<String, Vec<f64>>,
    /// Binned u_x(y) per sample.
    pub profile: Vec<Vec<f64>>,
    /// Steps of the samples.
    pub steps: Vec<u64>,
}

impl Series {
    /// Records one value.
    pub fn push(&mut self, name: &str, value: f64) {
        self.scalars.entry(name.to_owned()).or_default().push(value);
    }

    /// Averages of every scalar.
    pub fn estimates(&self, blocks: usize) -> BTreeMap<String, Estimate> {
        self.scalars
            .iter()
            .map(|(k, v)| (k.clone(), block_average(v, blocks)))
            .collect()
    }

    /// Average profile per bin.
    pub fn profile_estimates(&self, blocks: usize) -> Vec<Estimate> {
        let bins = self.profile.first().map_or(0, Vec::len);
        (0..bins)
            .map(|b| {
                let s: Vec<f64> = self.profile.iter().map(|p| p[b]).collect();
                block_average(&s, blocks)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_average_of_independent_noise_matches_sigma_over_sqrt_n() {
        // Deterministic pseudo-noise with known variance 1/12 (uniform).
        let key = crate::rng::StreamKey::new(3, crate::rng::Purpose::Test, 2);
        let xs: Vec<f64> = (0..20_000u32).map(|i| key.uniform2(0, i, 0).0).collect();
        let e = block_average(&xs, 20);
        let expected = (1.0f64 / 12.0 / 20_000.0).sqrt();
        assert!((e.mean - 0.5).abs() < 5.0 * expected);
        // The block estimate of the error has ~1/√(2·19) ≈ 16 % relative spread.
        assert!(
            (e.stderr / expected - 1.0).abs() < 0.5,
            "{} vs {}",
            e.stderr,
            expected
        );
    }
}
