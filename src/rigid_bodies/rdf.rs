//! The colloid–solvent radial distribution function and the exclusion radius read from it
//! (`colloid_solvent_rdf`; Nguyen 2021 Eq. 2.8–2.9, L468–474 and L877; spec §4).
//!
//! ```text
//! g(r_b) = ⟨s_b⟩ / (N_B n_S V_b),   n_S = N_S / V,
//! V_b = (4π/3)(r_{b+1}³ − r_b³) (3D),  π(r_{b+1}² − r_b²) (2D),   r_b = b Δr
//! ```
//!
//! s_b is the number of (solvent particle, body) pairs whose minimum-image distance (with the
//! Lees–Edwards shift) lies in [r_b, r_{b+1}), summed over the N_B bodies; the solvent is every
//! fluid particle that is no body's constituent, N_S of them. The thesis writes the shell as
//! 4πr²Δr (2πrΔr in 2D); the exact shell volume is used here, so an ideal gas gives g = 1 in every
//! bin, the innermost included (4πr²Δr at the bin centre is 25 % low in the first 3D bin).
//!
//! The distance is taken to each body's *cloud centre*, the mean position of its constituents
//! (minimum image about the body's centre R), not to R: a fixed body under drag has its cloud
//! F/(n_cp H) downstream of its sites, and about R the fluid would seem closer on the upstream
//! side by that much (docs/validation.md "Cylinder array"; `tools/validate.py`'s
//! `exclusion_radius` does the same). For a free body the two agree (its constituents' mean
//! offset from R starts and stays at zero: [`super::RigidBodies::start_with_constituent_velocities`]).
//!
//! **Exclusion radius** (the thesis's "exclusion size", the r at which g < 0.01, L877; spec §4):
//! the outer edge r_{b+1} of the last bin b with g < 0.01 — the same reading as
//! `tools/validate.py`, so that a lone visitor deep inside (one count in a small inner shell
//! already reads g ≈ 0.02) does not end the excluded region, and a bin of the rising flank that
//! dips under 0.01 by chance does extend it. Its resolution is the bin width; its error bar is the
//! spread of the same reading of each block's mean g(r) ([`exclusion_estimate`]).
//!
//! Every count is an exact fixed-point sum over the ranks' owned particles, and the cloud centres
//! are exact sums too, so g(r) is bitwise the same on any rank and thread count.

use crate::estimate::Estimate;

/// g below this is "excluded" (Nguyen 2021 L877).
pub const EXCLUSION_THRESHOLD: f64 = 0.01;

/// The number of bins of width `width` in [0, `range`]: ⌊range/width⌋ (a range within 10⁻⁹
/// of a whole number of bins keeps its last bin).
pub fn bin_count(range: f64, width: f64) -> usize {
    (range / width * (1.0 + 1e-9)).floor() as usize
}

/// Volume of the shell r0 ≤ r < r1 in `dimension` dimensions (an area in 2D).
pub fn shell_volume(dimension: usize, r0: f64, r1: f64) -> f64 {
    use std::f64::consts::PI;
    if dimension == 3 {
        4.0 / 3.0 * PI * (r1.powi(3) - r0.powi(3))
    } else {
        PI * (r1 * r1 - r0 * r0)
    }
}

/// g(r) of one sample from its pair counts: counts_b / (bodies · n_S · V_b).
pub fn normalise(
    counts: &[f64],
    width: f64,
    dimension: usize,
    bodies: f64,
    density: f64,
) -> Vec<f64> {
    counts
        .iter()
        .enumerate()
        .map(|(b, &s)| {
            let shell = shell_volume(dimension, b as f64 * width, (b + 1) as f64 * width);
            s / (bodies * density * shell)
        })
        .collect()
}

/// The exclusion radius of `g` (module documentation): the outer edge of the last bin with
/// g < [`EXCLUSION_THRESHOLD`]; 0 when no bin is below it (the solvent reaches the centre); NaN
/// when g is empty or holds a NaN.
pub fn exclusion_radius(g: &[f64], width: f64) -> f64 {
    if g.is_empty() || g.iter().any(|x| x.is_nan()) {
        return f64::NAN;
    }
    g.iter()
        .rposition(|&x| x < EXCLUSION_THRESHOLD)
        .map_or(0.0, |b| (b + 1) as f64 * width)
}

/// The exclusion radius of the time-averaged g(r) (`series[b]`: bin b's samples), with the
/// block error: the series cut into `blocks` equal blocks as [`crate::estimate::block_average`]
/// does, the radius read from each block's mean g(r), and the standard error s_B/√n_B of those.
pub fn exclusion_estimate(series: &[&[f64]], blocks: usize, width: f64) -> Estimate {
    let n = series.first().map_or(0, |s| s.len());
    if n == 0 || series.iter().any(|s| s.len() != n) {
        return Estimate {
            mean: f64::NAN,
            stderr: f64::NAN,
            samples: 0,
        };
    }
    let radius_over = |r: std::ops::Range<usize>| {
        let len = r.len() as f64;
        let mean_g: Vec<f64> = series
            .iter()
            .map(|s| s[r.clone()].iter().sum::<f64>() / len)
            .collect();
        exclusion_radius(&mean_g, width)
    };
    crate::estimate::block_estimate(n, blocks, radius_over)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform points about a centre (an ideal gas) give g = 1 in every bin, the innermost
    /// included, in 2D and 3D: the shells' volumes sum to the ball's, and each bin's count is
    /// its share of it.
    #[test]
    fn an_ideal_gas_has_g_one_in_every_bin() {
        let key = crate::rng::StreamKey::new(11, crate::rng::Purpose::Test, 5);
        for dimension in [2usize, 3] {
            let (side, width, bins) = (4.0, 0.25, 8);
            let n = 400_000u32;
            let mut counts = vec![0.0; bins];
            for i in 0..n {
                let (u0, u1) = key.uniform2(u64::from(i), dimension as u32, 0);
                let (u2, _) = key.uniform2(u64::from(i), dimension as u32, 1);
                let x = [u0 - 0.5, u1 - 0.5, u2 - 0.5].map(|u| u * side);
                let r = x[..dimension].iter().map(|c| c * c).sum::<f64>().sqrt();
                let b = (r / width).floor() as usize;
                if b < bins {
                    counts[b] += 1.0;
                }
            }
            let density = f64::from(n) / side.powi(dimension as i32);
            let g = normalise(&counts, width, dimension, 1.0, density);
            for (b, (gb, s)) in g.iter().zip(&counts).enumerate() {
                // Poisson: σ_g = g/√s; 5σ.
                assert!(
                    (gb - 1.0).abs() < 5.0 / s.sqrt(),
                    "{dimension}D bin {b}: g = {gb} ({s} counts)"
                );
            }
        }
    }

    #[test]
    fn the_exclusion_radius_is_the_outer_edge_of_the_last_bin_below_one_percent() {
        let g = [0.0, 0.0, 0.02, 0.0, 0.005, 0.3, 0.9, 1.1, 0.008];
        // The far bin (0.008 at bin 8) would count too: the range is the caller's to keep near.
        assert_eq!(exclusion_radius(&g[..8], 0.1), 0.5);
        assert_eq!(exclusion_radius(&g, 0.1), 0.9);
        assert_eq!(exclusion_radius(&[0.5, 1.0], 0.1), 0.0);
        assert!(exclusion_radius(&[], 0.1).is_nan());
        assert!(exclusion_radius(&[0.0, f64::NAN], 0.1).is_nan());
    }

    #[test]
    fn the_exclusion_estimate_reads_each_block() {
        // Two bins, 4 samples, 2 blocks: block 1 has the rising bin 1 below 0.01, block 2 not.
        let inner = [0.0, 0.0, 0.0, 0.0];
        let rising = [0.0, 0.01, 0.5, 0.7];
        let e = exclusion_estimate(&[&inner, &rising], 2, 0.1);
        // Whole mean of bin 1: 0.3025 → radius 0.1; blocks: 0.005 → 0.2, 0.6 → 0.1.
        assert_eq!(e.mean, 0.1);
        assert_eq!(e.samples, 4);
        assert!((e.stderr - 0.05).abs() < 1e-12, "{e:?}");
    }
}
