//! The one generic pair loop (HOOMD's evaluator idea): a small kernel evaluates a pair; the loop
//! runs over the half neighbour lists and scatters ±F_ij into exact fixed-point accumulators
//! ([`FixedSum`], one set per thread, merged at the end), so the force on each particle is the
//! same bits whatever the order of the pairs, the number of threads or the decomposition:
//!
//! ```text
//! F_i = Σ_j (f_C + f_D + f_R)_ij e_ij         (summed exactly, rounded once)
//! W   = Σ_pairs r_ij ⊗ F_ij  per part          (virial, also exact)
//! ```
//!
//! An owned–ghost pair adds to the owned end only (the other end's rank adds its own half) and
//! contributes ½ of its virial here.

use crate::fixed_sum::{FixedSum, Split};
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
    /// Terms for the pair with r_ij = r_i − r_j and v_ij = v_i − v_j, or `None` beyond the
    /// cutoff.
    fn eval(
        &self,
        r_vec: &[f64; D],
        v_rel: &[f64; D],
        gids: (u64, u64),
        step: u64,
    ) -> Option<PairTerms<D>>;

    /// What of `step` [`Self::eval_keyed`] needs, computed once per step (by default the step
    /// itself).
    fn step_key(&self, step: u64) -> u64 {
        step
    }

    /// [`Self::eval`] with the step given as [`Self::step_key`]: the same result.
    #[inline(always)]
    fn eval_keyed(
        &self,
        r_vec: &[f64; D],
        v_rel: &[f64; D],
        gids: (u64, u64),
        step_key: u64,
    ) -> Option<PairTerms<D>> {
        self.eval(r_vec, v_rel, gids, step_key)
    }
}

/// Pair vector r_i − r_j: the one formula for every pair on every rank.
#[inline(always)]
pub fn separation<const D: usize>(a: &[f64; D], b: &[f64; D]) -> [f64; D] {
    let mut r = [0.0; D];
    for d in 0..D {
        r[d] = a[d] - b[d];
    }
    r
}

/// Virial Σ r_ij ⊗ F_ij per part [conservative, dissipative, random], flattened D×D, as exact
/// accumulators (so the sum over ranks is exact too).
pub type Virial = [Vec<FixedSum>; 3];

/// One chunk's virial accumulators: 3 parts × a 3×3 tensor (the 2D case uses the top-left 2×2).
type ChunkVirial = [FixedSum; 27];
/// Pairs per block of the distance pre-pass.
const BLOCK: usize = 512;
/// A pair whose force could not be accumulated: (id, id, force).
type BadPair = (u64, u64, f64);

/// Reusable accumulators of the pair loop.
#[derive(Default)]
pub struct PairWorkspace<const D: usize> {
    buffers: Vec<Vec<[FixedSum; D]>>,
}

/// Evaluates all listed pairs and writes the force on every owned particle into `force`;
/// returns the virial when asked, or an error if a pair force is not finite (a blown-up run).
pub fn compute_forces<const D: usize, K: PairKernel<D>>(
    kernel: &K,
    particles: &Particles<D>,
    list: &NeighbourList<D>,
    step: u64,
    workspace: &mut PairWorkspace<D>,
    force: &mut [[f64; D]],
    want_virial: bool,
) -> Result<Option<Virial>, String> {
    let n_owned = particles.n_owned;
    let chunks = rayon::current_num_threads().max(1);
    let per_chunk = list.pairs.len().div_ceil(chunks).max(1);
    workspace.buffers.resize_with(chunks, Vec::new);
    let (pos, vel, gid) = (&particles.pos, &particles.vel, &particles.gid);
    let rc2 = kernel.cutoff() * kernel.cutoff();
    let step_key = kernel.step_key(step);
    let results: Vec<(ChunkVirial, Option<BadPair>)> = workspace
        .buffers
        .par_iter_mut()
        .zip(
            list.pairs
                .par_chunks(per_chunk)
                .chain(rayon::iter::repeat_n(&[][..], chunks)),
        )
        .map(|(acc, pairs)| {
            acc.clear();
            acc.resize(n_owned, [FixedSum::ZERO; D]);
            let mut virial = [FixedSum::ZERO; 27];
            let mut bad: Option<BadPair> = None;
            let mut evaluated = 0usize;
            let mut near = [[0u32; 2]; BLOCK];
            for block in pairs.chunks(BLOCK) {
                // Branch-free pre-pass: keep the pairs the kernel may accept (r² below the
                // cutoff², by the kernel's own formula; also zero and NaN, which it rejects
                // itself), so the listed pairs beyond the cutoff cost no mispredicted branch.
                let mut n_near = 0;
                for &[i, j] in block {
                    let r = separation(&pos[i as usize], &pos[j as usize]);
                    let mut r2 = 0.0;
                    for x in r {
                        r2 += x * x;
                    }
                    near[n_near] = [i, j];
                    // Not `r2 < rc2`: a NaN must reach the kernel, which reports it.
                    #[allow(clippy::neg_cmp_op_on_partial_ord)]
                    let keep = !(r2 >= rc2);
                    n_near += usize::from(keep);
                }
                for &[i, j] in &near[..n_near] {
                    evaluated += 1;
                    if want_virial && evaluated.is_multiple_of(2048) {
                        virial.iter_mut().for_each(FixedSum::normalize);
                    }
                    let (i, j) = (i as usize, j as usize);
                    let Some(t) = kernel.eval_keyed(
                        &separation(&pos[i], &pos[j]),
                        &separation(&vel[i], &vel[j]),
                        (gid[i], gid[j]),
                        step_key,
                    ) else {
                        continue;
                    };
                    let f = t.parts[0] + t.parts[1] + t.parts[2];
                    if !FixedSum::representable(f) {
                        // NaN, infinite or absurd: the run has blown up; report, do not accumulate.
                        bad.get_or_insert((gid[i], gid[j], f));
                        continue;
                    }
                    let owned_j = j < n_owned;
                    for d in 0..D {
                        // Split once; the j end subtracts the same words (symmetric rounding).
                        let fd = Split::of(f * t.e[d]);
                        acc[i][d].add_split(fd);
                        if owned_j {
                            acc[j][d].sub_split(fd);
                        }
                    }
                    if want_virial {
                        let w = if owned_j { t.r } else { 0.5 * t.r };
                        if !t.parts.iter().all(|&p| FixedSum::representable(w * p)) {
                            bad.get_or_insert((gid[i], gid[j], w * f));
                            continue;
                        }
                        // r ⊗ F ∝ e ⊗ e is symmetric: the upper triangle, mirrored below.
                        for (part, &p) in t.parts.iter().enumerate() {
                            let s = w * p;
                            for a in 0..D {
                                let sa = s * t.e[a];
                                for b in a..D {
                                    virial[part * 9 + a * 3 + b].add(sa * t.e[b]);
                                }
                            }
                        }
                    }
                }
            }
            (virial, bad)
        })
        .collect();
    if let Some(&(a, b, f)) = results.iter().find_map(|(_, bad)| bad.as_ref()) {
        return Err(format!(
            "pair force {f:e} between particles {a} and {b} at step {step} is not finite or \
             exceeds {:e}: the run is unstable (time step too large, or particles overlapping)",
            FixedSum::MAX_TERM
        ));
    }
    let virials: Vec<&ChunkVirial> = results.iter().map(|(v, _)| v).collect();
    let buffers = &workspace.buffers;
    force[..n_owned]
        .par_iter_mut()
        .enumerate()
        .with_min_len(1024)
        .for_each(|(i, f)| {
            for d in 0..D {
                let mut s = FixedSum::ZERO;
                for b in buffers {
                    s.merge(&b[i][d]);
                }
                f[d] = s.value();
            }
        });
    Ok(want_virial.then(|| {
        let mut total = [FixedSum::ZERO; 27];
        for v in virials {
            for (t, x) in total.iter_mut().zip(v) {
                let mut x = *x;
                x.normalize();
                t.merge(&x);
            }
        }
        let part = |p: usize| -> Vec<FixedSum> {
            let mut w = vec![FixedSum::ZERO; D * D];
            for a in 0..D {
                for b in 0..D {
                    w[a * D + b] = total[p * 9 + a.min(b) * 3 + a.max(b)];
                }
            }
            w
        };
        [part(0), part(1), part(2)]
    }))
}
