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

use std::collections::BTreeMap;

pub use crate::config::observables::{STRESS_PARTS, scalar_names, tensor_components};

pub use crate::estimate::{Estimate, block_average, block_estimate};

/// Integrated autocorrelation time of a series, in samples:
///
/// ```text
/// τ_int = ½ + Σ_{t=1}^{M} ρ(t),   ρ(t) = C(t) / C(0),   C(t) = ⟨(x_k − x̄)(x_{k+t} − x̄)⟩
/// ```
///
/// with Sokal's self-consistent window, the smallest M ≥ 5 τ_int(M) (A. Sokal, *Monte Carlo
/// methods in statistical mechanics*, 1996, §3). The variance of the mean of n samples is then
/// 2 τ_int C(0) / n: for white noise τ_int = ½, for an AR(1) series with coefficient ρ,
/// τ_int = ½ (1 + ρ)/(1 − ρ). The window is capped at min(n/4, 2000) samples; if it does not
/// close by then, the value returned is a lower bound (the series is too short to tell).
/// NaN for fewer than 8 samples or a constant series.
pub fn integrated_autocorrelation_time(series: &[f64]) -> f64 {
    let n = series.len();
    if n < 8 {
        return f64::NAN;
    }
    let mean = series.iter().sum::<f64>() / n as f64;
    let dev: Vec<f64> = series.iter().map(|x| x - mean).collect();
    let c0 = dev.iter().map(|x| x * x).sum::<f64>() / n as f64;
    if c0 <= 0.0 || !c0.is_finite() {
        return f64::NAN;
    }
    let cap = (n / 4).clamp(1, 2000);
    let mut tau = 0.5;
    for t in 1..=cap {
        let ct = dev[..n - t]
            .iter()
            .zip(&dev[t..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / n as f64;
        tau += ct / c0;
        if t as f64 >= 5.0 * tau {
            break;
        }
    }
    tau.max(0.5)
}

/// Blocks shorter than this many integrated autocorrelation times give block errors that are
/// too small: with blocks of L samples the variance of the block means is low by a fraction
/// of about 2 τ_int / L (the correlation across block boundaries is lost), so L ≥ 10 τ_int
/// keeps the standard error within ~10 % (Flyvbjerg & Petersen, J. Chem. Phys. 91, 461 (1989)).
pub const BLOCK_CORRELATION_TIMES: f64 = 10.0;

/// Warnings for the scalar series (except the conserved momentum) whose blocks, of
/// `len / blocks` samples, are shorter than [`BLOCK_CORRELATION_TIMES`] integrated
/// autocorrelation times. Each names the observable, τ_int, the block length, the error a τ_int
/// estimate gives, and what to change.
pub fn block_warnings(scalars: &BTreeMap<String, Vec<f64>>, blocks: usize) -> Vec<String> {
    let mut out = Vec::new();
    for (name, series) in scalars {
        // Total momentum is conserved: its series is round-off (~10⁻¹³), not a fluctuating
        // observable whose error bar means anything.
        if name.starts_with("momentum") {
            continue;
        }
        // The RDF's bins are read through the exclusion radius, whose error bar comes from its
        // own block values; a warning per bin would bury the others.
        if name.starts_with(crate::observable::COLLOID_SOLVENT_RDF_PREFIX) {
            continue;
        }
        let n = series.len();
        let nb = blocks.min(n);
        if nb < 2 {
            continue;
        }
        let block_len = (n / nb) as f64;
        let tau = integrated_autocorrelation_time(series);
        if !tau.is_finite() || block_len >= BLOCK_CORRELATION_TIMES * tau {
            continue;
        }
        let mean = series.iter().sum::<f64>() / n as f64;
        let var = series.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64;
        let tau_stderr = (2.0 * tau * var / n as f64).sqrt();
        let usable = ((n as f64 / (BLOCK_CORRELATION_TIMES * tau)).floor() as usize).max(1);
        let fix = if usable >= 2 {
            format!(
                "set `blocks = {usable}` (or fewer) under [diagnostics], or run longer (a larger \
                 run.steps)"
            )
        } else {
            "run longer (a larger run.steps): the averaging window is too short for even 2 \
             independent blocks"
                .to_owned()
        };
        out.push(format!(
            "{name}: its ± error bar is probably too small: the samples stay correlated over \
             about {tau:.1} samples, and each of the {nb} averaging blocks holds only \
             {block_len:.0}, fewer than the {:.0} ({BLOCK_CORRELATION_TIMES} × {tau:.1}) an \
             honest error bar needs; a corrected one is ± {tau_stderr:.2e}. To fix it, {fix}",
            BLOCK_CORRELATION_TIMES * tau
        ));
    }
    out
}

pub use crate::observable::DENSITY_PROFILE_PREFIX;
/// Prefix of the per-bin scalar series of the `shear_stress_profile` observable (bin index,
/// 4 digits); the summary gathers them into `shear_stress_profile`.
pub const SHEAR_STRESS_PROFILE_PREFIX: &str = "shear_stress_profile_";

/// Time series collected during a run.
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Scalar observables by name.
    pub scalars: BTreeMap<String, Vec<f64>>,
    /// Binned u_x(y) per sample.
    pub profile: Vec<Vec<f64>>,
    /// Steps of the samples.
    pub steps: Vec<u64>,
    /// The Green–Kubo correlators, one per block ([`crate::green_kubo`]); empty unless asked.
    pub green_kubo: Vec<crate::correlator::MultipleTauCorrelator>,
    /// The transverse-current correlators, blocks × modes ([`crate::transverse_current`]);
    /// empty unless asked.
    pub transverse_current: Vec<crate::correlator::MultipleTauCorrelator>,
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

    /// AR(1) series x_{k+1} = ρ x_k + √(1 − ρ²) ξ_k (unit variance), from the keyed stream.
    fn ar1(rho: f64, n: usize, seed: u64) -> Vec<f64> {
        let mut h = crate::rng::HashStream::from_prefix(seed, 1, 2);
        let mut x = h.normal();
        (0..n)
            .map(|_| {
                x = rho * x + (1.0 - rho * rho).sqrt() * h.normal();
                x
            })
            .collect()
    }

    #[test]
    fn autocorrelation_time_of_ar1_and_white_noise() {
        // τ_int = ½ (1 + ρ)/(1 − ρ) = 9.5 for ρ = 0.9; its estimate from n = 10⁵ samples has a
        // relative error of about √(2(2M + 1)/n) ≈ 6 % with M ≈ 5 τ (Sokal, Eq. 3.19).
        for seed in [1, 2, 3] {
            let tau = integrated_autocorrelation_time(&ar1(0.9, 100_000, seed));
            assert!((tau / 9.5 - 1.0).abs() < 0.2, "seed {seed}: τ_int = {tau}");
            let white = integrated_autocorrelation_time(&ar1(0.0, 100_000, seed));
            assert!(
                (white - 0.5).abs() < 0.1,
                "seed {seed}: white τ_int = {white}"
            );
        }
        assert!(integrated_autocorrelation_time(&[1.0; 100]).is_nan());
        assert!(integrated_autocorrelation_time(&[1.0, 2.0]).is_nan());
    }

    #[test]
    fn short_blocks_of_a_correlated_series_are_flagged() {
        let mut scalars = BTreeMap::new();
        scalars.insert("viscosity".to_owned(), ar1(0.9, 20_000, 7));
        scalars.insert("temperature".to_owned(), ar1(0.0, 20_000, 8));
        // 1000 blocks of 20 samples: too short for τ_int ≈ 9.5 (needs ≥ 95), and the block
        // error is indeed too small. Exact σ of the mean: √((1 + ρ)/(1 − ρ)/n) = 0.0308. Blocks
        // of L = 20 keep a fraction 1 − 2ρ(1 − ρ^L)/(L(1 − ρ)(1 + ρ)) = 0.58 of that variance,
        // so their error is ~0.76 σ (±2 % from 1000 blocks); 20 blocks are unbiased (±16 %).
        let w = block_warnings(&scalars, 1000);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with("viscosity:")
                && w[0].contains("set `blocks = ")
                && !w[0].contains("τ_int"),
            "{}",
            w[0]
        );
        let exact = (19.0f64 / 20_000.0).sqrt();
        let short = block_average(&scalars["viscosity"], 1000).stderr;
        let long = block_average(&scalars["viscosity"], 20).stderr;
        assert!(short < 0.85 * exact, "short blocks {short}, exact {exact}");
        assert!(
            (long / exact - 1.0).abs() < 0.5,
            "long blocks {long}, exact {exact}"
        );
        // 20 blocks of 1000 samples: fine for both.
        assert!(block_warnings(&scalars, 20).is_empty());
    }
}
