//! Wavenumber-dependent shear viscosity η(k) from the transverse-current autocorrelation
//! function (TCAF) of a fluid at rest, and its k → 0 limit η₀ (Nguyen 2021 ch. 4;
//! docs/theory/dpd_physical_parameters.md §6).
//!
//! ```text
//! J(k, t)  = Σ_j v_j(t) exp(i k·r_j(t))                         (sum over the fluid particles)
//! C⊥(k, t) = (k²/N) ⟨Re[J⊥(k, 0)* J⊥(k, t)]⟩,   C⊥(k, 0) = k² k_BT/m   (equipartition)
//! ```
//!
//! The wavevectors are k_j = (2πj/L) ê_a, j = 1 … `diagnostics.transverse_current_modes`, along
//! every axis a of a cubic (square) box, and J⊥ is each velocity component b ≠ a: D(D − 1)
//! (axis, component) pairs per k, each with its real and imaginary part, are the channels of one
//! multiple-tau correlator per mode and block ([`crate::correlator`]), so the pairs are
//! averaged. J is summed exactly over the ranks ([`FixedSum`]), and the phases e^{ijθ} come from
//! repeated multiplication of e^{iθ}, θ = 2πx_a/L, so every rank count gives the same bits.
//!
//! Each mode's normalised C⊥(k, t)/C⊥(k, 0) is fitted, over the leading lags where it exceeds
//! [`FIT_CUTOFF`], with the Maxwell (linear viscoelastic) model of Hess (2002) in
//! [`crate::tcaf_fit::maxwell_tcaf`], giving η_k and τ_k; η₀ and the curvature a come from
//! η_k = η₀ + a k² over the [`EXTRAPOLATION_MODES`] smallest k (Palmer 1994). The blocks of the
//! run after equilibration (`diagnostics.blocks`) are the data sets: the estimates are those of
//! the block-mean correlation and their error bars are jackknife errors (each block left out in
//! turn), which keeps the nonlinear fits on well-averaged curves.

use crate::correlator::MultipleTauCorrelator;
use crate::diagnostics::Estimate;
use crate::fixed_sum::FixedSum;
use crate::tcaf_fit::{extrapolate_to_zero_wavenumber, fit_maxwell, maxwell_tcaf};

/// The fits use the leading lags where C⊥(k, t)/C⊥(k, 0) exceeds this
/// (docs/theory/dpd_physical_parameters.md §6.3).
pub const FIT_CUTOFF: f64 = 0.05;
/// η₀ is extrapolated from at most this many of the smallest wavenumbers
/// (docs/theory/dpd_physical_parameters.md §6.3).
pub const EXTRAPOLATION_MODES: usize = 4;

/// Correlator channels per mode: (axis a, component b ≠ a) pairs × (real, imaginary).
pub fn channels(dimension: usize) -> usize {
    2 * dimension * (dimension - 1)
}

/// Empty correlators for `blocks` blocks × `modes` modes (index `block · modes + mode`),
/// reaching lags of `tau_max` with samples `sample_interval` apart in time.
pub fn block_correlators(
    blocks: usize,
    modes: usize,
    tau_max: f64,
    sample_interval: f64,
    dimension: usize,
) -> Vec<MultipleTauCorrelator> {
    let one = MultipleTauCorrelator::reaching(tau_max / sample_interval, channels(dimension));
    vec![one; blocks * modes]
}

/// Adds one particle's share of the transverse currents to `sums` (length
/// `modes · channels(D)`, row `mode · channels + 2·pair + {0: Re, 1: Im}`), for a box of edge
/// `length`.
pub fn add_particle<const D: usize>(
    sums: &mut [FixedSum],
    pos: &[f64; D],
    vel: &[f64; D],
    length: f64,
    modes: usize,
) {
    let c = channels(D);
    let mut pair = 0;
    for a in 0..D {
        let theta = std::f64::consts::TAU * pos[a] / length;
        let (s1, c1) = theta.sin_cos();
        let (mut re, mut im) = (1.0, 0.0);
        for mode in 0..modes {
            // e^{i(j+1)θ} = e^{ijθ} e^{iθ}
            (re, im) = (re * c1 - im * s1, re * s1 + im * c1);
            let row = mode * c + 2 * pair;
            let mut p = 0;
            for (b, &v) in vel.iter().enumerate() {
                if b == a {
                    continue;
                }
                sums[row + 2 * p].add(v * re);
                sums[row + 2 * p + 1].add(v * im);
                p += 1;
            }
        }
        pair += D - 1;
    }
}

/// One mode's estimate.
#[derive(Clone, Debug)]
pub struct ModeEstimate {
    /// The wavenumber k_j = 2πj/L.
    pub wavenumber: f64,
    /// η_k ± jackknife error.
    pub viscosity: Estimate,
    /// τ_k ± jackknife error.
    pub relaxation_time: Estimate,
    /// The measured C⊥(k, 0) ± jackknife error.
    pub initial: Estimate,
    /// C⊥(k, 0) by equipartition, k² k_BT ⟨1/m⟩.
    pub initial_expected: f64,
    /// (t, C⊥(k, t)/C⊥(k, 0), the fitted Maxwell curve) of the block-mean correlation.
    pub curve: Vec<(f64, f64, f64)>,
}

/// The modes and their k → 0 extrapolation.
#[derive(Clone, Debug)]
pub struct TransverseCurrentEstimate {
    pub modes: Vec<ModeEstimate>,
    /// η₀ ± jackknife error.
    pub viscosity: Estimate,
    /// The curvature a of η_k = η₀ + a k².
    pub curvature: f64,
}

/// What the fluid is, for the normalisations.
pub struct FluidState {
    /// Fluid particles N.
    pub particles: f64,
    /// Mass density ρ.
    pub mass_density: f64,
    /// k_BT/m.
    pub kt_over_mass: f64,
    /// Box edge L.
    pub length: f64,
}

/// η_k per mode and η₀ from the correlators of [`block_correlators`] (`modes` per block),
/// with samples `sample_interval` apart in time.
pub fn estimate(
    correlators: &[MultipleTauCorrelator],
    modes: usize,
    sample_interval: f64,
    fluid: &FluidState,
    dimension: usize,
) -> TransverseCurrentEstimate {
    // Blocks with samples (a run stopped early leaves its last blocks empty).
    let filled: Vec<usize> = (0..correlators.len() / modes.max(1))
        .filter(|&b| {
            (0..modes).all(|m| {
                correlators[b * modes + m]
                    .correlation()
                    .first()
                    .is_some_and(|p| p.1 > 0.0)
            })
        })
        .collect();
    let blocks = filled.len();
    let pairs = (dimension * (dimension - 1)) as f64;
    let wavenumbers: Vec<f64> = (1..=modes)
        .map(|j| std::f64::consts::TAU * j as f64 / fluid.length)
        .collect();
    // C⊥(k, t) of each block and mode on the lags every block of the mode has.
    let curves: Vec<Vec<Vec<(f64, f64)>>> = (0..modes)
        .map(|m| {
            let k2 = wavenumbers[m] * wavenumbers[m];
            let per_block: Vec<Vec<(f64, f64)>> = (0..blocks)
                .map(|b| {
                    correlators[filled[b] * modes + m]
                        .correlation()
                        .into_iter()
                        .map(|(lag, v)| (lag * sample_interval, k2 * v / (pairs * fluid.particles)))
                        .collect()
                })
                .collect();
            let common = per_block.iter().map(Vec::len).min().unwrap_or(0);
            per_block
                .into_iter()
                .map(|mut c| {
                    c.truncate(common);
                    c
                })
                .collect()
        })
        .collect();
    // The mean over a subset of blocks (all but `left_out`), normalised by its own C(0).
    let mean_curve = |m: usize, left_out: Option<usize>| -> (f64, Vec<(f64, f64)>) {
        let used: Vec<&Vec<(f64, f64)>> = (curves[m].iter().enumerate())
            .filter(|(b, _)| Some(*b) != left_out)
            .map(|(_, c)| c)
            .collect();
        let n = used.len() as f64;
        let len = used.first().map_or(0, |c| c.len());
        let mean: Vec<(f64, f64)> = (0..len)
            .map(|i| (used[0][i].0, used.iter().map(|c| c[i].1).sum::<f64>() / n))
            .collect();
        let c0 = mean.first().map_or(f64::NAN, |p| p.1);
        (c0, mean.into_iter().map(|(t, c)| (t, c / c0)).collect())
    };
    let rho = fluid.mass_density;
    // (η_k, τ_k, C⊥(k, 0)) of a subset of blocks.
    let fit = |m: usize, left_out: Option<usize>| -> (f64, f64, f64) {
        let (c0, points) = mean_curve(m, left_out);
        fit_maxwell(&points, wavenumbers[m], rho, FIT_CUTOFF)
            .map_or((f64::NAN, f64::NAN, c0), |f| {
                (f.viscosity, f.relaxation_time, c0)
            })
    };
    let extrapolation_modes = modes.min(EXTRAPOLATION_MODES);
    let extrapolate = |etas: &[f64]| -> (f64, f64) {
        let n = extrapolation_modes;
        extrapolate_to_zero_wavenumber(&wavenumbers[..n], &etas[..n], &vec![f64::NAN; n])
            .map_or((f64::NAN, f64::NAN), |(eta0, a, _)| (eta0, a))
    };
    // The whole-run fits, then the jackknife replicas.
    let full: Vec<(f64, f64, f64)> = (0..modes).map(|m| fit(m, None)).collect();
    let full_etas: Vec<f64> = full.iter().map(|f| f.0).collect();
    let (eta0, curvature) = extrapolate(&full_etas);
    let replicas: Vec<Vec<(f64, f64, f64)>> = if blocks >= 2 {
        (0..blocks)
            .map(|b| (0..modes).map(|m| fit(m, Some(b))).collect())
            .collect()
    } else {
        Vec::new()
    };
    let jackknife = |values: &[f64], full: f64| -> Estimate {
        let n = values.len();
        let stderr = if n < 2 {
            f64::NAN
        } else {
            let mean = values.iter().sum::<f64>() / n as f64;
            let ss = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
            (ss * (n - 1) as f64 / n as f64).sqrt()
        };
        Estimate {
            mean: full,
            stderr,
            samples: blocks,
        }
    };
    let modes_out: Vec<ModeEstimate> = (0..modes)
        .map(|m| {
            let (_, points) = mean_curve(m, None);
            let (eta, tau, c0) = full[m];
            let k = wavenumbers[m];
            let curve = points
                .iter()
                .map(|&(t, c)| (t, c, maxwell_tcaf(t, eta, tau, k, rho)))
                .collect();
            let etas: Vec<f64> = replicas.iter().map(|r| r[m].0).collect();
            let taus: Vec<f64> = replicas.iter().map(|r| r[m].1).collect();
            let c0s: Vec<f64> = replicas.iter().map(|r| r[m].2).collect();
            ModeEstimate {
                wavenumber: k,
                viscosity: jackknife(&etas, eta),
                relaxation_time: jackknife(&taus, tau),
                initial: jackknife(&c0s, c0),
                initial_expected: k * k * fluid.kt_over_mass,
                curve,
            }
        })
        .collect();
    let eta0s: Vec<f64> = replicas
        .iter()
        .map(|r| extrapolate(&r.iter().map(|f| f.0).collect::<Vec<_>>()).0)
        .collect();
    TransverseCurrentEstimate {
        modes: modes_out,
        viscosity: jackknife(&eta0s, eta0),
        curvature,
    }
}

pub use crate::config::observables::transverse_current_mode as mode_observable;

#[cfg(test)]
mod tests {
    use super::*;

    /// The currents of one particle equal the direct exponentials, channel by channel.
    #[test]
    fn currents_match_direct_exponentials() {
        let (modes, length) = (5, 7.5);
        let pos = [1.3, 6.9, 0.2];
        let vel = [0.4, -1.1, 2.5];
        let mut sums = vec![FixedSum::ZERO; modes * channels(3)];
        add_particle(&mut sums, &pos, &vel, length, modes);
        let c = channels(3);
        for m in 0..modes {
            let k = std::f64::consts::TAU * (m + 1) as f64 / length;
            let mut pair = 0;
            for a in 0..3 {
                for b in (0..3).filter(|&b| b != a) {
                    let (s, co) = (k * pos[a]).sin_cos();
                    let re = sums[m * c + 2 * pair].value();
                    let im = sums[m * c + 2 * pair + 1].value();
                    assert!((re - vel[b] * co).abs() < 1e-13, "mode {m} pair {a}{b}");
                    assert!((im - vel[b] * s).abs() < 1e-13, "mode {m} pair {a}{b}");
                    pair += 1;
                }
            }
        }
    }

    /// A known correlation: the channel pair (Re, Im) = A(cos ωt, sin ωt) has
    /// ⟨Re J(0) Re J(τ) + Im J(0) Im J(τ)⟩ = A² cos ωτ, so C⊥/C⊥(0) = cos ωτ and
    /// C⊥(k, 0) = k² A²/N exactly.
    #[test]
    fn the_normalisation_follows_the_definition() {
        let dimension = 2;
        let (blocks, modes) = (2, 1);
        let mut cs = block_correlators(blocks, modes, 1.0, 0.01, dimension);
        for (b, c) in cs.iter_mut().enumerate() {
            for s in 0..400 {
                let phase = 0.3 * s as f64 + b as f64;
                // 4 channels: two pairs, each (Re, Im) = (cos, sin) of amplitude 2.
                let x = [
                    2.0 * phase.cos(),
                    2.0 * phase.sin(),
                    2.0 * phase.cos(),
                    2.0 * phase.sin(),
                ];
                c.add(&x);
            }
        }
        let fluid = FluidState {
            particles: 10.0,
            mass_density: 1.0,
            kt_over_mass: 1.0,
            length: std::f64::consts::TAU,
        };
        let e = estimate(&cs, modes, 0.01, &fluid, dimension);
        // k = 1; per pair ⟨Re² + Im²⟩ = 4; C⊥(0) = k² · 4 / N.
        assert!((e.modes[0].initial.mean - 0.4).abs() < 1e-12);
        assert!((e.modes[0].curve[1].1 - 0.3f64.cos()).abs() < 1e-12);
    }
}
