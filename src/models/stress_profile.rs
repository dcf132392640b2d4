//! The binned shear stress τ_xy(y) of a pair fluid: the Irving–Kirkwood stress averaged over
//! slabs (bins) of the gradient axis (Irving & Kirkwood 1950; the slab form of Todd, Evans &
//! Daivis, Phys. Rev. E 52, 1627 (1995)).
//!
//! A pair force F_ij carries momentum along the straight segment from r_j to r_i; the share
//! of its virial r_ij ⊗ F_ij that belongs to a slab is the fraction of that segment inside it:
//!
//! ```text
//! V_b P_xy(b) = Σ_{i∈b} m V_x V_y + Σ_pairs r_y F_x ℓ_b / |r_y|       τ_xy(b) = −P_xy(b)
//! ```
//!
//! where ℓ_b is the length (along y) of the segment [y_j, y_i] inside slab b, V the velocity
//! about the local mean and V_b = V/bins. Over all slabs the fractions sum to 1, so the slab
//! stresses average to the box's pressure tensor. A pair with r_y = 0 has r_y F_x = 0 and adds
//! nothing. The slab average of the true stress field is what this estimates, without the
//! smoothing of the per-particle (½ r_ij ⊗ F_ij to each end) assignment, which would flatten
//! the kinks of a piecewise-linear profile.

use crate::fixed_sum::FixedSum;
use crate::models::pair_loop::PairKernel;
use crate::neighbour::{NEAR_AT_BUILD, NeighbourList};
use crate::particles::Particles;
use rayon::prelude::*;

/// Calls `share(bin, ℓ)` for every bin the segment from y_j = `y_i − r_y` to `y_i` crosses,
/// with the length ℓ of the segment inside it (bins of width `ly/bins` along a periodic axis
/// of length `ly`; the segment may cross the boundary).
pub fn segment_shares(y_i: f64, r_y: f64, ly: f64, bins: usize, mut share: impl FnMut(usize, f64)) {
    let (lo, hi) = if r_y >= 0.0 {
        (y_i - r_y, y_i)
    } else {
        (y_i, y_i - r_y)
    };
    // Nothing to share for r_y = 0 (or a NaN, which the force loop reports).
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return;
    }
    let width = ly / bins as f64;
    let first = (lo / width).floor() as i64;
    let last = (hi / width).floor() as i64;
    let nb = bins as i64;
    for k in first..=last {
        let a = lo.max(k as f64 * width);
        let b = hi.min((k + 1) as f64 * width);
        if b > a {
            share(k.rem_euclid(nb) as usize, b - a);
        }
    }
}

/// The pair part Σ_pairs r_y F_x ℓ_b/|r_y| of the slab virial, per bin, for the forces
/// `kernel` gives at `step` (the same terms as the force loop: same inputs, same keyed noise),
/// summed exactly. An owned–ghost pair adds half (its other rank adds the other half), so the
/// sum over ranks counts every pair once, for any decomposition and thread count.
pub fn pair_shear_virial<const D: usize, K: PairKernel<D>>(
    kernel: &K,
    particles: &Particles<D>,
    list: &NeighbourList<D>,
    step: u64,
    bins: usize,
    ly: f64,
) -> Vec<FixedSum> {
    let step_key = kernel.step_key(step);
    let n_owned = particles.n_owned;
    let (pos, vel, gid) = (&particles.pos, &particles.vel, &particles.gid);
    let chunks = rayon::current_num_threads().max(1);
    let partial: Vec<Vec<FixedSum>> = list
        .pair_chunks(chunks)
        .map(|pairs| {
            let mut sums = vec![FixedSum::ZERO; bins];
            for (n, &[i, j]) in pairs.iter().enumerate() {
                if n % 1024 == 1023 {
                    sums.iter_mut().for_each(FixedSum::normalize);
                }
                let (i, j) = (i as usize, (j & !NEAR_AT_BUILD) as usize);
                let r: [f64; D] = std::array::from_fn(|d| pos[i][d] - pos[j][d]);
                let v: [f64; D] = std::array::from_fn(|d| vel[i][d] - vel[j][d]);
                let Some(t) = kernel.eval_keyed(&r, &v, (gid[i], gid[j]), step_key) else {
                    continue;
                };
                let f_x = (t.parts[0] + t.parts[1] + t.parts[2]) * t.e[0];
                let weight = if j < n_owned { 1.0 } else { 0.5 };
                let r_y = r[1];
                // r_y F_x ℓ_b/|r_y| = F_x sign(r_y) ℓ_b.
                let signed = weight * f_x * r_y.signum();
                let y_i = pos[i][1].rem_euclid(ly);
                segment_shares(y_i, r_y, ly, bins, |b, len| {
                    let term = signed * len;
                    if FixedSum::representable(term) {
                        sums[b].add(term);
                    }
                });
            }
            sums
        })
        .collect();
    let mut total = vec![FixedSum::ZERO; bins];
    for p in partial {
        for (t, mut x) in total.iter_mut().zip(p) {
            x.normalize();
            t.merge(&x);
        }
    }
    total.iter_mut().for_each(FixedSum::normalize);
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shares of a segment sum to its length and land in the right bins, across the
    /// periodic boundary too.
    #[test]
    fn segment_shares_cover_the_segment() {
        let mut got = Vec::new();
        segment_shares(2.3, 0.9, 10.0, 10, |b, l| got.push((b, l)));
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].0, 1);
        assert!((got[0].1 - 0.6).abs() < 1e-12 && got[1].0 == 2 && (got[1].1 - 0.3).abs() < 1e-12);
        got.clear();
        // From y_j = 0.2 + 0.5 = 0.7 down to y_i = 0.2 (r_y < 0): one bin.
        segment_shares(0.2, -0.5, 10.0, 10, |b, l| got.push((b, l)));
        assert!(got.len() == 1 && got[0].0 == 0 && (got[0].1 - 0.5).abs() < 1e-12);
        got.clear();
        // Across y = 0: y_i = 0.3, y_j = −0.4 (the image of 9.6).
        segment_shares(0.3, 0.7, 10.0, 10, |b, l| got.push((b, l)));
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].0, 9);
        assert!((got[0].1 - 0.4).abs() < 1e-12 && got[1].0 == 0 && (got[1].1 - 0.3).abs() < 1e-12);
        got.clear();
        segment_shares(5.0, 0.0, 10.0, 10, |b, l| got.push((b, l)));
        assert!(got.is_empty());
    }
}
