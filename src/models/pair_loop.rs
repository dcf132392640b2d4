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

use crate::error::Error;
use crate::error::{Quantity, UNSTABLE, Unstable};
use crate::fixed_sum::{FixedSum, Split};
use crate::neighbour::{NEAR_AT_BUILD, NeighbourList, PairBand};
use crate::particles::Particles;
use crate::simd::Isa;
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

/// Pairs evaluated together by [`PairKernel::eval_block`].
pub const BATCH: usize = 64;

/// The inputs of a block of pairs, one array per component.
#[derive(Clone, Debug)]
pub struct PairBlock<const D: usize> {
    /// r_ij = r_i − r_j.
    pub r: [[f64; BATCH]; D],
    /// v_ij = v_i − v_j.
    pub v: [[f64; BATCH]; D],
    /// Global ids (i, j).
    pub ids: [(u64, u64); BATCH],
    /// Number of pairs in the block.
    pub len: usize,
}

impl<const D: usize> Default for PairBlock<D> {
    fn default() -> Self {
        Self {
            r: [[0.0; BATCH]; D],
            v: [[0.0; BATCH]; D],
            ids: [(0, 0); BATCH],
            len: 0,
        }
    }
}

/// The outputs of [`PairKernel::eval_block`]: [`PairTerms`] as arrays, and whether the kernel
/// accepted each pair.
#[derive(Clone, Debug)]
pub struct BlockTerms<const D: usize> {
    /// Unit vectors e_ij.
    pub e: [[f64; BATCH]; D],
    /// Distances.
    pub r: [f64; BATCH],
    /// Force magnitudes [conservative, dissipative, random].
    pub parts: [[f64; BATCH]; 3],
    /// Pair within the interaction range.
    pub valid: [bool; BATCH],
}

impl<const D: usize> Default for BlockTerms<D> {
    fn default() -> Self {
        Self {
            e: [[0.0; BATCH]; D],
            r: [0.0; BATCH],
            parts: [[0.0; BATCH]; 3],
            valid: [false; BATCH],
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

    /// Evaluates a block of pairs at once (structure of arrays, so that a kernel can be written
    /// for the vector units): `out` gets, for every pair k < `block.len`, exactly what
    /// [`Self::eval_keyed`] returns for it (`valid[k]` false where that is `None`).
    #[inline(always)]
    fn eval_block(&self, block: &PairBlock<D>, step_key: u64, out: &mut BlockTerms<D>) {
        for k in 0..block.len {
            let r: [f64; D] = std::array::from_fn(|d| block.r[d][k]);
            let v: [f64; D] = std::array::from_fn(|d| block.v[d][k]);
            match self.eval_keyed(&r, &v, block.ids[k], step_key) {
                Some(t) => {
                    out.valid[k] = true;
                    for d in 0..D {
                        out.e[d][k] = t.e[d];
                    }
                    out.r[k] = t.r;
                    for (p, &x) in t.parts.iter().enumerate() {
                        out.parts[p][k] = x;
                    }
                }
                None => out.valid[k] = false,
            }
        }
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

/// Which components of the virial a force evaluation accumulates (each costs an exact sum per
/// pair, so a run asks only for what its observables need).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VirialScope {
    /// No virial.
    Off,
    /// The diagonal components only (pressure, normal stress differences); the others are 0.
    Diagonal,
    /// Every component.
    Full,
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
    buffers: Vec<PairBand<[FixedSum; D]>>,
}

/// One thread's share of the pair loop.
struct ChunkInput<'a, const D: usize, K> {
    kernel: &'a K,
    particles: &'a Particles<D>,
    /// Listed pairs, j with its [`NEAR_AT_BUILD`] bit.
    pairs: &'a [[u32; 2]],
    /// The positions are those of the list's build: its marks tell the pairs within the
    /// cutoff.
    at_build_positions: bool,
    step_key: u64,
    virial: VirialScope,
}

/// [`evaluate_chunk`] compiled for AVX2 (4 doubles per vector instruction, no FMA: the same
/// IEEE operations, so the same bits as the portable build).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn evaluate_chunk_avx2<const D: usize, K: PairKernel<D>>(
    chunk: &ChunkInput<D, K>,
    acc: &mut PairBand<[FixedSum; D]>,
) -> (ChunkVirial, Option<BadPair>) {
    evaluate_chunk(chunk, acc)
}

/// Evaluates a chunk of pairs into the thread's accumulators `window` (sized to the band of
/// owned particles the chunk touches); returns the chunk's virial and the first pair whose
/// force was not finite.
#[inline(always)]
fn evaluate_chunk<const D: usize, K: PairKernel<D>>(
    chunk: &ChunkInput<D, K>,
    window: &mut PairBand<[FixedSum; D]>,
) -> (ChunkVirial, Option<BadPair>) {
    let ChunkInput {
        kernel,
        particles,
        pairs,
        at_build_positions,
        step_key,
        virial: scope,
    } = *chunk;
    let n_owned = particles.n_owned;
    let (pos, vel, gid) = (&particles.pos, &particles.vel, &particles.gid);
    let rc2 = kernel.cutoff() * kernel.cutoff();
    let (lo, acc) = window.reset(pairs, n_owned, 1, [FixedSum::ZERO; D]);
    let mut virial = [FixedSum::ZERO; 27];
    let mut bad: Option<BadPair> = None;
    let mut near = [[0u32; 2]; BLOCK];
    let mut inputs = PairBlock::<D>::default();
    let mut terms = BlockTerms::<D>::default();
    let mut splits = [[Split::ZERO; BATCH]; D];
    for block in pairs.chunks(BLOCK) {
        let n_near = if at_build_positions {
            // The build marked the pairs within the cutoff at these very positions, by the
            // same r² formula as `near_pairs`: no distances to compute.
            let mut n_near = 0;
            for &[i, j] in block {
                near[n_near] = [i, j & !NEAR_AT_BUILD];
                n_near += (j >> 31) as usize;
            }
            n_near
        } else {
            near_pairs(pos, block, rc2, &mut near)
        };
        for batch in near[..n_near].chunks(BATCH) {
            inputs.len = batch.len();
            for (k, &[i, j]) in batch.iter().enumerate() {
                let (i, j) = (i as usize, j as usize);
                for d in 0..D {
                    inputs.r[d][k] = pos[i][d] - pos[j][d];
                    inputs.v[d][k] = vel[i][d] - vel[j][d];
                }
                inputs.ids[k] = (gid[i], gid[j]);
            }
            kernel.eval_block(&inputs, step_key, &mut terms);
            // The force on i along every axis, split once into fixed-point words.
            let mut total = [0.0; BATCH];
            for (k, f) in total.iter_mut().enumerate().take(batch.len()) {
                *f = terms.parts[0][k] + terms.parts[1][k] + terms.parts[2][k];
            }
            for d in 0..D {
                for k in 0..batch.len() {
                    splits[d][k] = Split::of(total[k] * terms.e[d][k]);
                }
            }
            for (k, &[i, j]) in batch.iter().enumerate() {
                if !terms.valid[k] {
                    continue;
                }
                let (i, j) = (i as usize, j as usize);
                let f = total[k];
                if !FixedSum::representable(f) {
                    // NaN, infinite or absurd: the run has blown up; report, do not
                    // accumulate.
                    bad.get_or_insert((gid[i], gid[j], f));
                    continue;
                }
                let owned_j = j < n_owned;
                for d in 0..D {
                    // Split once; the j end subtracts the same words (symmetric rounding).
                    let fd = splits[d][k];
                    acc[i - lo][d].add_split(fd);
                    if owned_j {
                        acc[j - lo][d].sub_split(fd);
                    }
                }
            }
            if scope != VirialScope::Off {
                let diagonal = scope == VirialScope::Diagonal;
                let (sums, bad) = (&mut virial, &mut bad);
                add_block_virial(batch, n_owned, gid, diagonal, &terms, &total, sums, bad);
            }
        }
    }
    (virial, bad)
}

/// Adds the virial r_ij ⊗ F_ij per part of a batch of evaluated pairs to `virial`, in passes
/// over the batch that the compiler vectorises: the weights s_p = w f_p (w = r, or r/2 for an
/// owned–ghost pair, whose other half is added on the other side), then for every part and
/// component a ≤ b (r ⊗ F ∝ e ⊗ e is symmetric: the upper triangle, mirrored by the caller)
/// the terms (s_p e_a) e_b summed exactly ([`FixedSum::sum_of`]): the same value as adding the
/// terms pair by pair; with `diagonal` only a = b. A pair that is not valid, or whose force or
/// weights cannot be accumulated, adds nothing (the latter is reported in `bad`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn add_block_virial<const D: usize>(
    batch: &[[u32; 2]],
    n_owned: usize,
    gid: &[u64],
    diagonal: bool,
    terms: &BlockTerms<D>,
    total: &[f64; BATCH],
    virial: &mut ChunkVirial,
    bad: &mut Option<BadPair>,
) {
    let n = batch.len();
    let mut weight = [[0.0; BATCH]; 3];
    let mut keep = [false; BATCH];
    for (k, &[i, j]) in batch.iter().enumerate() {
        let w = if (j as usize) < n_owned {
            terms.r[k]
        } else {
            0.5 * terms.r[k]
        };
        let mut representable = true;
        for p in 0..3 {
            weight[p][k] = w * terms.parts[p][k];
            representable &= FixedSum::representable(weight[p][k]);
        }
        // A force that is not representable was reported by the force scatter.
        let accumulated = terms.valid[k] && FixedSum::representable(total[k]);
        keep[k] = accumulated && representable;
        if accumulated && !representable {
            let (i, j) = (i as usize, j as usize);
            bad.get_or_insert((gid[i], gid[j], w * total[k]));
        }
    }
    let mut terms_ab = [0.0; BATCH];
    for (p, weight) in weight.iter().enumerate() {
        for a in 0..D {
            let last = if diagonal { a } else { D - 1 };
            for b in a..=last {
                for k in 0..n {
                    let x = weight[k] * terms.e[a][k] * terms.e[b][k];
                    terms_ab[k] = if keep[k] { x } else { 0.0 };
                }
                let sum = &mut virial[p * 9 + a * 3 + b];
                sum.merge(&FixedSum::sum_of(&terms_ab[..n]));
                sum.normalize();
            }
        }
    }
}

/// The distance pre-pass of [`evaluate_chunk`]: writes the pairs of `block` the kernel may
/// accept (r² below the cutoff², by the kernel's own formula; also zero and NaN, which it
/// rejects itself) to the front of `near`, without their [`NEAR_AT_BUILD`] marks, and returns
/// their number. Branch-free, so the listed pairs beyond the cutoff cost no mispredicted
/// branch.
#[inline(always)]
fn near_pairs<const D: usize>(
    pos: &[[f64; D]],
    block: &[[u32; 2]],
    rc2: f64,
    near: &mut [[u32; 2]],
) -> usize {
    let mut n_near = 0;
    for &[i, j] in block {
        let j = j & !NEAR_AT_BUILD;
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
    n_near
}

/// Evaluates all listed pairs and adds the force on every owned particle to `force`;
/// returns the virial components `virial` asks for (else `None`), or an error if a pair force
/// is not finite (a blown-up run).
/// `isa` (normally [`Isa::current`]) picks the compiled version; every one gives the same bits.
#[allow(clippy::too_many_arguments)]
pub fn compute_forces<const D: usize, K: PairKernel<D>>(
    isa: Isa,
    kernel: &K,
    particles: &Particles<D>,
    list: &NeighbourList<D>,
    step: u64,
    workspace: &mut PairWorkspace<D>,
    force: &mut [[f64; D]],
    virial: VirialScope,
) -> Result<Option<Virial>, Error> {
    let n_owned = particles.n_owned;
    let chunks = rayon::current_num_threads().max(1);
    let at_build_positions = list.at_build_positions;
    workspace.buffers.resize_with(chunks, PairBand::default);
    let step_key = kernel.step_key(step);
    let avx2 = isa.has_avx2();
    let results: Vec<(ChunkVirial, Option<BadPair>)> = workspace
        .buffers
        .par_iter_mut()
        .zip(list.pair_chunks(chunks))
        .map(|(acc, pairs)| {
            let chunk = ChunkInput {
                kernel,
                particles,
                pairs,
                at_build_positions,
                step_key,
                virial,
            };
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: an `Isa` has AVX2 only when the CPU reports it (`Isa::avx2`), the one
                // requirement of this target-feature function.
                return unsafe { evaluate_chunk_avx2(&chunk, acc) };
            }
            evaluate_chunk(&chunk, acc)
        })
        .collect();
    if let Some(&(a, b, f)) = results.iter().find_map(|(_, bad)| bad.as_ref()) {
        return Err(Unstable::new(
            Quantity::PairForce,
            Some(a),
            step,
            format!(
                "pair force {f:e} between particles {a} and {b} at step {step} is not finite \
                 or exceeds {:e}: {UNSTABLE} (time step too large, or particles overlapping)",
                FixedSum::MAX_TERM
            ),
        )
        .into());
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
                    if let Some(a) = b.get(i, 1) {
                        s.merge(&a[0][d]);
                    }
                }
                // Added (the engine zeroes the forces before the first model): 0 + x = x
                // bitwise, since a fixed-point value is never −0.
                f[d] += s.value();
            }
        });
    Ok((virial != VirialScope::Off).then(|| {
        let mut total = [FixedSum::ZERO; 27];
        for v in virials {
            for (t, x) in total.iter_mut().zip(v) {
                let mut x = *x;
                x.normalize();
                t.merge(&x);
            }
        }
        // One representation of each value, whatever the split into chunks.
        total.iter_mut().for_each(FixedSum::normalize);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::dpd::{Dpd, DpdCfg, Noise};
    use crate::rng::{Purpose, StreamKey};

    /// A random fluid in a 6³ (or 6²) box at ρ ≈ 3 with ghost copies of the particles within
    /// 1.5 of the x = 0 face shifted by +6 (so owned–ghost pairs occur).
    fn fluid<const D: usize>() -> Particles<D> {
        let key = StreamKey::new(11, Purpose::Test, D as u8);
        let n = 3 * 6usize.pow(D as u32);
        let mut p = Particles::<D>::default();
        for i in 0..n as u32 {
            let pos = std::array::from_fn(|d| 6.0 * key.uniform2(0, i, d as u32).0);
            let vel = std::array::from_fn(|d| key.gaussian2(1, i, d as u32).0);
            p.push_owned(u64::from(i), pos, vel);
        }
        for i in 0..n {
            if p.pos[i][0] < 1.5 {
                let mut pos = p.pos[i];
                pos[0] += 6.0;
                let (gid, vel) = (p.gid[i], p.vel[i]);
                p.push_ghost(gid, pos, vel, 0);
            }
        }
        p
    }

    fn same_bits_on_every_isa<const D: usize>(weight_exponent: f64, noise: Noise) {
        let Some(avx2) = Isa::avx2_for_test("pair_loop::same_bits_on_every_isa") else {
            return;
        };
        let p = fluid::<D>();
        let cfg = DpdCfg {
            a: 25.0,
            gamma: 4.5,
            kt: 1.0,
            cutoff: 1.0,
            weight_exponent,
            noise,

            conservative_exponent: 1.0,
            physical: None,
            body_force: Vec::new(),
            body_force_profile: crate::models::dpd::BodyForceProfile::Uniform,
            colloids: None,
            soft_start_sweeps: None,
        };
        let dpd = Dpd::new(&cfg, 0.04, 5);
        let run = |isa: Isa| {
            let mut list = NeighbourList::build_on(isa, &p, 1.5, 1.0);
            let forces = |list: &NeighbourList<D>| {
                let mut force = vec![[0.0; D]; p.n_owned];
                let mut ws = PairWorkspace::default();
                let scope = VirialScope::Full;
                let virial = compute_forces(isa, &dpd, &p, list, 3, &mut ws, &mut force, scope)
                    .expect("finite forces")
                    .expect("virial asked for");
                (force, virial)
            };
            // With the build's marks (no distances) and without them (the pre-pass): the
            // same bits.
            let (force, virial) = forces(&list);
            list.at_build_positions = false;
            assert_eq!((force.clone(), virial.clone()), forces(&list));
            // The marks are exactly the pairs the distance pre-pass keeps.
            let marked: Vec<[u32; 2]> = (list.flagged_pairs().iter())
                .filter(|p| p[1] >= NEAR_AT_BUILD)
                .map(|&[i, j]| [i, j & !NEAR_AT_BUILD])
                .collect();
            let mut kept = vec![[0; 2]; list.len()];
            let n_kept = near_pairs(&p.pos, list.flagged_pairs(), 1.0, &mut kept);
            assert!(marked == kept[..n_kept], "marks differ from the pre-pass");
            assert!(marked.len() * 5 > list.len());
            (list.flagged_pairs().to_vec(), force, virial)
        };
        let (pairs_a, force_a, virial_a) = run(avx2);
        let (pairs_p, force_p, virial_p) = run(Isa::PORTABLE);
        assert!(pairs_a.len() > 10 * p.n_owned, "{} pairs", pairs_a.len());
        assert_eq!(pairs_a, pairs_p);
        for (a, b) in force_a.iter().zip(&force_p) {
            for d in 0..D {
                assert_eq!(a[d].to_bits(), b[d].to_bits());
            }
        }
        assert!(force_a.iter().any(|f| f[0] != 0.0));
        assert_eq!(virial_a, virial_p);
    }

    #[test]
    fn avx2_and_portable_builds_give_the_same_list_forces_and_virial() {
        same_bits_on_every_isa::<3>(2.0, Noise::Gaussian);
        same_bits_on_every_isa::<2>(2.0, Noise::Gaussian);
        same_bits_on_every_isa::<3>(0.5, Noise::Uniform);
    }
}
