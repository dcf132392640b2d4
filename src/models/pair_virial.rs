//! The momentum flux's pair sum shared by the models whose pair forces are not the generic
//! pair loop's (SPH: `crate::models::sph::momentum_flux`; the GENERIC polymer fluid:
//! `crate::models::generic_polymer`'s `momentum_flux`): Σ_pairs F_ij ⊗ ℓ_ij per part over the
//! half list, component a·D + b = Σ F^a ℓ^b, F_ij the force on i from j and ℓ_ij its lever.
//!
//! Every pair adds ½ of its term twice: an owned–ghost pair once on each of its two ranks (the
//! same bits on both when the model's pair terms are exactly antisymmetric), an owned–owned
//! pair twice on its rank. Each term is accumulated exactly ([`FixedSum`], which rounds a term
//! once to its resolution), so round(½t) + round(½t) is the same integer on any decomposition,
//! where round(t) once would not be, and the sum is the same on any rank and thread count.

use crate::fixed_sum::FixedSum;
use crate::models::gather::PairError;
use crate::models::pair_loop::Virial;
use crate::neighbour::{NEAR_AT_BUILD, NeighbourList};
use crate::particles::Particles;
use rayon::prelude::*;

/// Pairs between renormalisations of the accumulators.
const NORMALIZE_EVERY: usize = 1024;

/// The pair's force on i split into three parts, and its lever; `None` for a pair that
/// exchanges nothing.
pub(crate) type FluxTerms<const D: usize> = Option<([[f64; D]; 3], [f64; D])>;

/// Σ_pairs F_ij ⊗ ℓ_ij per part over the half list `list` (pairs closer than `cutoff`, not
/// coincident), an owned–ghost pair at half weight; `terms(i, j, x_ij, r)` gives the pair's
/// parts and lever (x_ij = x_i − x_j). Exact, and the same on any number of threads and ranks.
pub(crate) fn half_list_virial<const D: usize, T>(
    p: &Particles<D>,
    list: &NeighbourList<D>,
    cutoff: f64,
    terms: T,
) -> Result<Virial, PairError>
where
    T: Fn(usize, usize, &[f64; D], f64) -> FluxTerms<D> + Sync,
{
    let n_owned = p.n_owned;
    let rc2 = cutoff * cutoff;
    let chunks = rayon::current_num_threads().max(1);
    let results: Vec<Result<Vec<FixedSum>, PairError>> = list
        .pair_chunks(chunks)
        .map(|pairs| {
            let mut sums = vec![FixedSum::ZERO; 3 * D * D];
            for (n, &[i, j]) in pairs.iter().enumerate() {
                let (i, j) = (i as usize, (j & !NEAR_AT_BUILD) as usize);
                let x: [f64; D] = std::array::from_fn(|d| p.pos[i][d] - p.pos[j][d]);
                let r2: f64 = x.iter().map(|v| v * v).sum();
                if r2 >= rc2 || r2 == 0.0 {
                    continue;
                }
                let Some((parts, lever)) = terms(i, j, &x, r2.sqrt()) else {
                    continue;
                };
                let copies = if j < n_owned { 2 } else { 1 };
                for (k, part) in parts.iter().enumerate() {
                    for a in 0..D {
                        for b in 0..D {
                            let term = 0.5 * part[a] * lever[b];
                            if !FixedSum::representable(term) {
                                return Err(PairError {
                                    gid_i: p.gid[i],
                                    gid_j: p.gid[j],
                                    quantity: k * D * D + a * D + b,
                                    value: term,
                                    max_term: FixedSum::MAX_TERM,
                                });
                            }
                            for _ in 0..copies {
                                sums[k * D * D + a * D + b].add(term);
                            }
                        }
                    }
                }
                if n % NORMALIZE_EVERY == NORMALIZE_EVERY - 1 {
                    sums.iter_mut().for_each(FixedSum::normalize);
                }
            }
            sums.iter_mut().for_each(FixedSum::normalize);
            Ok(sums)
        })
        .collect();
    let mut total = vec![FixedSum::ZERO; 3 * D * D];
    for chunk in results {
        for (t, x) in total.iter_mut().zip(chunk?) {
            t.merge(&x);
            t.normalize();
        }
    }
    Ok(std::array::from_fn(|k| {
        total[k * D * D..(k + 1) * D * D].to_vec()
    }))
}
