//! Green–Kubo shear viscosity from the equilibrium autocorrelation of the pressure tensor.
//!
//! For an isotropic fluid at rest, with P̃ = ½(P + Pᵀ) − (tr P/D) I the symmetric traceless
//! part of the instantaneous pressure tensor (kinetic + conservative + dissipative + random),
//!
//! ```text
//! ⟨P̃_αβ(0) P̃_γδ(t)⟩ = (k_BT/V) G(t) (δ_αγ δ_βδ + δ_αδ δ_βγ − (2/D) δ_αβ δ_γδ),
//! η = ∫₀^∞ G(t) dt = V/(k_BT) ∫₀^∞ C(t) dt,   C(t) = Σ_αβ ⟨P̃_αβ(0) P̃_αβ(t)⟩ / ((D − 1)(D + 2))
//! ```
//!
//! (the contraction of the isotropic tensor gives D² + D − 2; Daivis & Evans, J. Chem. Phys. 100,
//! 541 (1994), use the same average of the five independent components in 3D, two in 2D).
//!
//! **The random force** of DPD contributes a δ-correlated stress: its virial at a step has a
//! variance ∝ σ²/Δt and is uncorrelated with later steps, so its whole share of the integral
//! sits at lag 0. Sampled every step with the random numbers the step used, the trapezoid
//! rule's ½ C(0) Δt gives exactly (V/k_BT) ½ Δt Var(P_R) = (1/V) Σ_pairs γ w_D (x y/r)² — the
//! dissipative viscosity η_D the same pairs give under shear (σ² = 2γk_BT). Sampling every k > 1
//! steps would weigh it k times, and leaving the random stress out loses it: both are wrong, so
//! the correlation is fed every step. The cross terms between the random kick of one step and
//! the velocities of the next are O(Δt).
//!
//! The run after equilibration is cut into `diagnostics.blocks` consecutive blocks, each with its
//! own multiple-tau correlator ([`crate::correlator`], 16 lags per level, pairs averaged); the
//! estimate is the mean of the blocks' integrals up to `diagnostics.green_kubo_time`, the error
//! bar their spread (products straddling a block boundary are not counted: unbiased, and a
//! negligible loss when the blocks are much longer than the integration time).

use crate::correlator::{MultipleTauCorrelator, trapezoid_integral};
use crate::diagnostics::Estimate;

/// The channels fed to the correlator: the D² components of the symmetric traceless part of the
/// D × D (row-major) tensor `p`.
pub fn traceless_symmetric(p: &[f64], dimension: usize) -> Vec<f64> {
    let d = dimension;
    let trace = (0..d).map(|a| p[a * d + a]).sum::<f64>() / d as f64;
    let mut out = vec![0.0; d * d];
    for a in 0..d {
        for b in 0..d {
            out[a * d + b] = 0.5 * (p[a * d + b] + p[b * d + a]) - if a == b { trace } else { 0.0 };
        }
    }
    out
}

/// Empty correlators, one per block, reaching lags of `tau_max` at step `dt`.
pub fn block_correlators(
    blocks: usize,
    tau_max: f64,
    dt: f64,
    dimension: usize,
) -> Vec<MultipleTauCorrelator> {
    vec![MultipleTauCorrelator::reaching(tau_max / dt, dimension * dimension); blocks]
}

/// The block that the sample of `step` belongs to, for samples after `equilibration` up to
/// `steps`.
pub fn block_of(step: u64, equilibration: u64, steps: u64, blocks: usize) -> usize {
    let span = steps.saturating_sub(equilibration).max(1);
    let k = step.saturating_sub(equilibration + 1);
    ((k as u128 * blocks as u128 / span as u128) as usize).min(blocks - 1)
}

/// What the correlators give: η with its standard error over the blocks, and the block-mean
/// G(t) = V C(t)/k_BT with its running integral, as (t, G, ∫₀ᵗ G) rows.
pub struct GreenKuboEstimate {
    /// η ± standard error (samples: the blocks).
    pub viscosity: Estimate,
    /// (t, G(t), η(t) = ∫₀ᵗ G).
    pub table: Vec<(f64, f64, f64)>,
}

/// η = V/(k_BT) ∫₀^τ_max C dt from the blocks' correlators (those with products).
pub fn estimate(
    blocks: &[MultipleTauCorrelator],
    dt: f64,
    volume: f64,
    kt: f64,
    tau_max: f64,
    dimension: usize,
) -> GreenKuboEstimate {
    let norm = volume / (kt * ((dimension - 1) * (dimension + 2)) as f64);
    let curves: Vec<Vec<(f64, f64)>> = blocks
        .iter()
        .map(|c| {
            c.correlation()
                .into_iter()
                .map(|(lag, v)| (lag * dt, norm * v))
                .collect::<Vec<_>>()
        })
        .filter(|c: &Vec<(f64, f64)>| c.last().is_some_and(|&(t, _)| t >= tau_max))
        .collect();
    let integrals: Vec<f64> = curves
        .iter()
        .map(|c| trapezoid_integral(c, tau_max))
        .collect();
    let n = integrals.len();
    let mean = integrals.iter().sum::<f64>() / n.max(1) as f64;
    let var = integrals.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n.max(2) - 1) as f64;
    let viscosity = Estimate {
        mean: if n == 0 { f64::NAN } else { mean },
        stderr: if n < 2 {
            f64::NAN
        } else {
            (var / n as f64).sqrt()
        },
        samples: n,
    };
    // The block-mean curve on the lags every block has (a block may be a sample short).
    let mut table = Vec::new();
    if let Some(first) = curves.first() {
        let common = curves.iter().map(Vec::len).min().unwrap_or(0);
        let mut running = 0.0;
        for (i, &(t, _)) in first[..common].iter().enumerate() {
            let g = curves.iter().map(|c| c[i].1).sum::<f64>() / n as f64;
            if let Some(&(t0, g0, _)) = table.last() {
                running += 0.5 * (g0 + g) * (t - t0);
            }
            table.push((t, g, running));
        }
    }
    GreenKuboEstimate { viscosity, table }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_channels_are_the_symmetric_traceless_part() {
        let p = [0.0, 1.0, 0.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let c = traceless_symmetric(&p, 3);
        assert_eq!((c[1], c[3]), (2.0, 2.0));
        let q = [2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let c = traceless_symmetric(&q, 3);
        assert_eq!((c[0], c[4], c[8]), (1.0, -1.0, 0.0));
        let r = [1.0, 5.0, -1.0, 3.0];
        assert_eq!(traceless_symmetric(&r, 2), [-1.0, 2.0, 2.0, 1.0]);
    }

    #[test]
    fn blocks_split_the_sampled_steps_evenly() {
        let b: Vec<usize> = (11..=30).map(|s| block_of(s, 10, 30, 4)).collect();
        assert_eq!(b, [[0; 5], [1; 5], [2; 5], [3; 5]].concat());
    }
}
