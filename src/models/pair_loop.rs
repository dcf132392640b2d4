//! The one generic pair loop (HOOMD's evaluator idea): a small kernel evaluates a pair; the
//! loop evaluates every distinct pair once (in parallel, each into its own slot) and then
//! gathers the force on each owned particle over its neighbour list in global-id order:
//!
//! ```text
//! F_i = Σ_{j ∈ N(i), sorted by gid} ± (f_C + f_D + f_R)_ij e_ij
//! ```
//!
//! The sign is + when the pair was evaluated from i, − from j; the kernel is exactly
//! antisymmetric (e_ji = −e_ij bit for bit), so F_i is the same bits for every rank count and
//! thread count. Pair virials for the stress tensor come from the same stored terms.

use crate::neighbour::NeighbourList;
use crate::particles::Particles;
use rayon::prelude::*;

/// What a pair kernel returns for a pair seen from i: the unit vector e_ij, the distance and
/// the scalar parts of the force on i along e_ij (conservative, dissipative, random).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairTerms<const D: usize> {
    /// Unit vector from j to i.
    pub e: [f64; D],
    /// Distance |r_ij|.
    pub r: f64,
    /// Force magnitudes on i: [conservative, dissipative, random].
    pub parts: [f64; 3],
}

impl<const D: usize> Default for PairTerms<D> {
    fn default() -> Self {
        Self {
            e: [0.0; D],
            r: 0.0,
            parts: [0.0; 3],
        }
    }
}

/// A pairwise interaction.
pub trait PairKernel<const D: usize>: Sync {
    /// Interaction range.
    fn cutoff(&self) -> f64;
    /// Terms for the pair with r_ij = r_i − r_j and v_ij = v_i − v_j (zero beyond the cutoff).
    fn eval(&self, r_vec: &[f64; D], v_rel: &[f64; D], gids: (u64, u64), step: u64)
    -> PairTerms<D>;
}

/// Pair-vector r_i − r_j: the one formula for every pair on every rank.
#[inline(always)]
pub fn separation<const D: usize>(a: &[f64; D], b: &[f64; D]) -> [f64; D] {
    let mut r = [0.0; D];
    for d in 0..D {
        r[d] = a[d] - b[d];
    }
    r
}

/// Evaluates all pairs into `terms` and gathers the forces on owned particles into `force`.
pub fn compute_forces<const D: usize, K: PairKernel<D>>(
    kernel: &K,
    particles: &Particles<D>,
    list: &NeighbourList<D>,
    step: u64,
    terms: &mut Vec<PairTerms<D>>,
    force: &mut [[f64; D]],
) {
    terms.resize(list.pairs.len(), PairTerms::default());
    let (pos, vel, gid) = (&particles.pos, &particles.vel, &particles.gid);
    terms
        .par_iter_mut()
        .zip(list.pairs.par_iter())
        .with_min_len(1024)
        .for_each(|(t, &[i, j])| {
            let (i, j) = (i as usize, j as usize);
            *t = kernel.eval(
                &separation(&pos[i], &pos[j]),
                &separation(&vel[i], &vel[j]),
                (gid[i], gid[j]),
                step,
            );
        });
    let terms = &terms[..];
    force[..particles.n_owned]
        .par_iter_mut()
        .enumerate()
        .with_min_len(256)
        .for_each(|(i, f)| {
            let mut acc = [0.0; D];
            for e in list.offsets[i]..list.offsets[i + 1] {
                let p = list.pair_of_entry[e] as usize;
                let t = &terms[p];
                let mut s = t.parts[0] + t.parts[1] + t.parts[2];
                if list.pairs[p][0] as usize != i {
                    s = -s;
                }
                for d in 0..D {
                    acc[d] += s * t.e[d];
                }
            }
            *f = acc;
        });
}

/// Σ over this rank's pairs of r_ij ⊗ F_ij per force part (conservative, dissipative, random),
/// as flattened D×D matrices. An owned–ghost pair is also held by the rank (or image) owning
/// the other end, so it counts one half here.
pub fn pair_virial<const D: usize>(
    particles: &Particles<D>,
    list: &NeighbourList<D>,
    terms: &[PairTerms<D>],
) -> [Vec<f64>; 3] {
    const CHUNK: usize = 4096;
    let n_owned = particles.n_owned;
    let partial: Vec<[Vec<f64>; 3]> = list
        .pairs
        .par_chunks(CHUNK)
        .zip(terms.par_chunks(CHUNK))
        .map(|(pairs, terms)| {
            let mut w = [vec![0.0; D * D], vec![0.0; D * D], vec![0.0; D * D]];
            for (&[_, j], t) in pairs.iter().zip(terms) {
                let weight = if (j as usize) < n_owned { 1.0 } else { 0.5 };
                for (part, wp) in w.iter_mut().enumerate() {
                    let f = weight * t.r * t.parts[part];
                    for a in 0..D {
                        for b in 0..D {
                            wp[a * D + b] += f * t.e[a] * t.e[b];
                        }
                    }
                }
            }
            w
        })
        .collect();
    let mut total = [vec![0.0; D * D], vec![0.0; D * D], vec![0.0; D * D]];
    for w in partial {
        for (t, p) in total.iter_mut().zip(w) {
            for (x, y) in t.iter_mut().zip(p) {
                *x += y;
            }
        }
    }
    total
}
