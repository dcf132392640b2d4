//! Gather passes: every owned particle sums the contributions of its neighbours into its own
//! accumulators, over the full neighbour list, exactly.
//!
//! ```text
//! S_i^q = s_i^q + Σ_{j ∈ N(i)} c^q(i, j)          q = 0 … width − 1
//! ```
//!
//! with s_i the self term and c(i, j) the pair term of the [`GatherKernel`]. Each quantity q is
//! accumulated in fixed point under its own [`Scale`] ([`crate::fixed_sum`]), so the sum is
//! the same bits whatever the order of the neighbours, the number of threads or the
//! decomposition; a term out of its scale's range (or not finite) stops the pass with a
//! [`PairError`] naming the pair, and is never wrapped.
//!
//! Why gather, not scatter: a wide output (an MSPH moment matrix has 36 or 100 numbers) would
//! need per-thread buffers of n_owned × width to scatter into; gathering writes each owned
//! particle's sums once, from one thread. The price is that an owned–owned pair is evaluated
//! from both ends — which is also what makes the result independent of which end is owned: the
//! contribution to i is always c(i, j), computed on i's rank from i's copy and j's (ghost or
//! owned) copy.

use crate::counting_sort::{self, DisjointSlots};
use crate::fixed_sum::{FixedSum, LaneFactor, LaneSums, Scale, Split};
use crate::neighbour::{NEAR_AT_BUILD, NeighbourList, PairBand};
use crate::particles::Particles;
use crate::simd::Isa;
use rayon::prelude::*;

/// Every owned particle's neighbours (owned and ghosts) within the list radius, in compressed
/// rows: `neighbours[offsets[i]..offsets[i + 1]]`. Built from the half list at each rebuild.
#[derive(Clone, Debug, Default)]
pub struct FullList {
    offsets: Vec<usize>,
    neighbours: Vec<u32>,
    lanes: LaneRows,
}

/// Particles per group of [`LaneRows`]: one AVX-512 register of doubles.
pub const LANES: usize = 8;

/// The rows of a [`FullList`] in groups of [`LANES`] owned particles, interleaved so that a
/// loop can evaluate one neighbour of each of the group's particles at once (each vector lane
/// walks its own particle's row, in the row's order).
///
/// Group g holds particles g·LANES … g·LANES + LANES − 1 (the last group repeats the last owned
/// particle in its spare lanes). Its entries `group(g)[k · LANES + l]` are the k-th neighbour of
/// its particle l, for k below the longest row of the group; past the end of a shorter row the
/// entry is the particle itself, which is never its own neighbour, so a lane whose entry equals
/// its particle adds nothing.
#[derive(Clone, Debug, Default)]
pub struct LaneRows {
    starts: Vec<usize>,
    index: Vec<u32>,
    /// The largest index held (bounds every load through the rows).
    max_index: u32,
}

impl LaneRows {
    /// Interleaves the rows on the rank's threads: each group's length first (its longest
    /// row × [`LANES`]), the groups' starts by a prefix sum, then every group filled on its own.
    fn new(offsets: &[usize], neighbours: &[u32], n_owned: usize) -> Self {
        let groups = n_owned.div_ceil(LANES);
        let member = |g: usize, l: usize| (g * LANES + l).min(n_owned - 1);
        let row = |g: usize, l: usize| {
            let m = member(g, l);
            &neighbours[offsets[m]..offsets[m + 1]]
        };
        let longest: Vec<usize> = (0..groups)
            .into_par_iter()
            .with_min_len(1024)
            .map(|g| (0..LANES).map(|l| row(g, l).len()).max().unwrap_or(0))
            .collect();
        let mut starts = Vec::with_capacity(groups + 1);
        starts.push(0);
        for (g, &k) in longest.iter().enumerate() {
            starts.push(starts[g] + k * LANES);
        }
        let mut index = vec![0u32; starts[groups]];
        let mut parts = Vec::with_capacity(groups);
        let mut rest = &mut index[..];
        for &k in &longest {
            let (head, tail) = rest.split_at_mut(k * LANES);
            parts.push(head);
            rest = tail;
        }
        parts
            .into_par_iter()
            .enumerate()
            .with_min_len(1024)
            .for_each(|(g, out)| {
                for (k, entries) in out.chunks_exact_mut(LANES).enumerate() {
                    for (l, e) in entries.iter_mut().enumerate() {
                        *e = row(g, l).get(k).copied().unwrap_or(member(g, l) as u32);
                    }
                }
            });
        let max_index = index.par_iter().copied().max().unwrap_or(0);
        Self {
            starts,
            index,
            max_index,
        }
    }

    /// Number of groups.
    pub fn groups(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// The entries of group `g`, [`LANES`] per neighbour rank k.
    #[inline]
    pub fn group(&self, g: usize) -> &[u32] {
        &self.index[self.starts[g]..self.starts[g + 1]]
    }

    /// The largest particle index the rows hold (0 when empty).
    pub fn max_index(&self) -> usize {
        self.max_index as usize
    }
}

impl FullList {
    /// The full rows of the half list's `n_owned` owned particles: pair [i, j] puts j in row i
    /// and, when j is owned, i in row j.
    ///
    /// A stable counting sort of the half list's entries by row, on the rank's threads
    /// ([`crate::counting_sort`]): each row holds its neighbours in the half list's order,
    /// the same rows on any number of threads.
    pub fn from_half<const D: usize>(list: &NeighbourList<D>, n_owned: usize) -> Self {
        let pairs = list.flagged_pairs();
        let owned = n_owned as u32;
        let per = pairs
            .len()
            .div_ceil(counting_sort::chunk_count(pairs.len()))
            .max(1);
        let counts: Vec<Vec<u32>> = pairs
            .par_chunks(per)
            .map(|chunk| {
                let mut count = vec![0u32; n_owned];
                for &[i, j] in chunk {
                    let j = j & !NEAR_AT_BUILD;
                    count[i as usize] += 1;
                    if j < owned {
                        count[j as usize] += 1;
                    }
                }
                count
            })
            .collect();
        let (offsets, mut next) = counting_sort::bases(counts, n_owned);
        let mut neighbours = vec![0u32; offsets[n_owned]];
        let slots = DisjointSlots::new(&mut neighbours);
        pairs
            .par_chunks(per)
            .zip(next.par_iter_mut())
            .for_each(|(chunk, next)| {
                for &[i, j] in chunk {
                    let j = j & !NEAR_AT_BUILD;
                    let (i, ju) = (i as usize, j as usize);
                    // SAFETY (both writes): this chunk's entries of a row take the run of
                    // slots `counting_sort::bases` gave that (chunk, row), one slot each; no
                    // other chunk and no other row is given any of them.
                    unsafe { slots.write(next[i] as usize, j) };
                    next[i] += 1;
                    if j < owned {
                        unsafe { slots.write(next[ju] as usize, i as u32) };
                        next[ju] += 1;
                    }
                }
            });
        let lanes = LaneRows::new(&offsets, &neighbours, n_owned);
        Self {
            offsets,
            neighbours,
            lanes,
        }
    }

    /// The same rows, [`LANES`] particles side by side.
    pub fn lanes(&self) -> &LaneRows {
        &self.lanes
    }

    /// Neighbours of owned particle `i`.
    #[inline]
    pub fn row(&self, i: usize) -> &[u32] {
        &self.neighbours[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Number of rows (owned particles).
    pub fn rows(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

/// The per-pair arithmetic of a gather pass.
///
/// Contract: [`Self::pair`] must depend only on the two particles' data and r_ij (never on
/// whether j is owned or a ghost, nor on indices), so that every decomposition gives the same
/// terms. For momentum conservation a model's force terms should also be antisymmetric to the
/// last bit — c(j, i) = −c(i, j) — which [`pair_symmetry`] checks in its tests.
pub trait GatherKernel<const D: usize>: Sync {
    /// The scale of each accumulated quantity (its length is the pass's width).
    fn scales(&self) -> &[Scale];

    /// Pairs with |r_ij| ≥ cutoff contribute nothing (not evaluated).
    fn cutoff(&self) -> f64;

    /// Writes the contribution of neighbour `j` to particle `i` into `out` (all of it: `out`
    /// holds garbage on entry), with r_ij = r_i − r_j and r = |r_ij| < cutoff.
    fn pair(&self, p: &Particles<D>, i: usize, j: usize, r_ij: &[f64; D], r: f64, out: &mut [f64]);

    /// Whether particle `i`'s sums are wanted at all (default: yes). An inactive row is all
    /// zeros and costs nothing (the momentum pass of a boundary particle, which never moves).
    fn active(&self, p: &Particles<D>, i: usize) -> bool {
        let _ = (p, i);
        true
    }

    /// Writes particle `i`'s contribution to itself into `out` and returns true, or returns
    /// false when there is none (the default).
    fn self_term(&self, p: &Particles<D>, i: usize, out: &mut [f64]) -> bool {
        let _ = (p, i, out);
        false
    }
}

/// A term that could not be accumulated: the pass stops (on every rank) with this.
#[derive(Clone, Debug, PartialEq)]
pub struct PairError {
    /// Global id of the particle whose sum it was for.
    pub gid_i: u64,
    /// Global id of the neighbour (equal to `gid_i` for the self term).
    pub gid_j: u64,
    /// Index of the quantity.
    pub quantity: usize,
    /// The term.
    pub value: f64,
    /// The largest magnitude the quantity's scale accepts.
    pub max_term: f64,
}

impl std::fmt::Display for PairError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the term {:e} of quantity {} for the pair of particles {} and {} is not finite or \
             exceeds the range ±{:e} of its exact sum: {} (time step too large, particles \
             overlapping) or the model's scale is too small",
            self.value,
            self.quantity,
            self.gid_i,
            self.gid_j,
            self.max_term,
            crate::error::UNSTABLE
        )
    }
}

impl PairError {
    /// The blow-up this is, found at `step` by `context` (a model's pass).
    pub fn at_step(
        &self,
        quantity: crate::error::Quantity,
        step: u64,
        context: &str,
    ) -> crate::error::Unstable {
        crate::error::Unstable::new(
            quantity,
            Some(self.gid_i),
            step,
            format!("{self} ({context} at step {step})"),
        )
    }
}

impl std::error::Error for PairError {}

/// r_ij = x_i − x_j and r_ij for a pair within `rc2` = cutoff², or `None` beyond it. A NaN
/// distance counts as within, so that the kernel sees it and the sum reports it.
#[inline(always)]
fn separation_within<const D: usize>(
    xi: &[f64; D],
    xj: &[f64; D],
    rc2: f64,
) -> Option<([f64; D], f64)> {
    let mut r_ij = [0.0; D];
    let mut r2 = 0.0;
    for d in 0..D {
        r_ij[d] = xi[d] - xj[d];
        r2 += r_ij[d] * r_ij[d];
    }
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    (!(r2 >= rc2)).then(|| (r_ij, r2.sqrt()))
}

/// The fixed-point words of term `x` of quantity `q` for the pair (i, j), or the error that
/// names the pair.
#[inline(always)]
fn split_term<const D: usize>(
    scale: &Scale,
    p: &Particles<D>,
    (i, j): (usize, usize),
    q: usize,
    x: f64,
) -> Result<Split, PairError> {
    scale.split(x).ok_or_else(|| PairError {
        gid_i: p.gid[i],
        gid_j: p.gid[j],
        quantity: q,
        value: x,
        max_term: scale.max_term(),
    })
}

/// Terms per fixed-point accumulator between normalisations (the low word cannot wrap before
/// 2^12 worst-case terms).
const NORMALISE_EVERY: usize = 2048;

/// Runs a gather pass over the owned particles of `p`: `out` gets, for every owned particle i,
/// its `width` sums (each rounded once) at `out[i·width..(i+1)·width]`. Runs on the current
/// rayon pool; the result does not depend on its thread count.
pub fn gather<const D: usize, K: GatherKernel<D>>(
    kernel: &K,
    p: &Particles<D>,
    full: &FullList,
    out: &mut Vec<f64>,
) -> Result<(), PairError> {
    let scales = kernel.scales();
    let width = scales.len();
    let n = p.n_owned;
    assert_eq!(full.rows(), n, "the full list is not of these particles");
    out.clear();
    out.resize(n * width, 0.0);
    if width == 0 {
        return Ok(());
    }
    let rc2 = kernel.cutoff() * kernel.cutoff();
    out.par_chunks_mut(width)
        .enumerate()
        .with_min_len(64)
        .try_for_each_init(
            || (vec![FixedSum::ZERO; width], vec![0.0; width]),
            |(sums, term), (i, sums_out)| {
                if !kernel.active(p, i) {
                    sums_out.fill(0.0);
                    return Ok(());
                }
                sums.fill(FixedSum::ZERO);
                let add = |sums: &mut [FixedSum], term: &[f64], j: usize| {
                    for (q, (s, &x)) in sums.iter_mut().zip(term).enumerate() {
                        s.add_split(split_term(&scales[q], p, (i, j), q, x)?);
                    }
                    Ok(())
                };
                if kernel.self_term(p, i, term) {
                    add(sums, term, i)?;
                }
                for (k, &j) in full.row(i).iter().enumerate() {
                    let j = j as usize;
                    if let Some((r_ij, r)) = separation_within(&p.pos[i], &p.pos[j], rc2) {
                        kernel.pair(p, i, j, &r_ij, r, term);
                        add(sums, term, j)?;
                    }
                    if k % NORMALISE_EVERY == NORMALISE_EVERY - 1 {
                        sums.iter_mut().for_each(FixedSum::normalize);
                    }
                }
                for ((o, s), scale) in sums_out.iter_mut().zip(sums.iter()).zip(scales) {
                    *o = scale.value(s);
                }
                Ok(())
            },
        )
}

/// Most quantities [`gather_in_lanes`] accumulates (wider passes, MSPH's moments, use [`gather`]).
const MAX_LANE_WIDTH: usize = 32;

/// [`gather`] with [`LANES`] owned particles side by side along the rows of
/// [`FullList::lanes`]: each lane evaluates its pair terms with the same [`GatherKernel::pair`]
/// (one lane after another), and the terms of all lanes are split into their fixed-point words
/// and added at once ([`LaneFactor::add`], which the compiler vectorises), where [`gather`]
/// splits them one by one with a check each. The words are those of [`Scale::split`], so the
/// sums are the very bits of [`gather`] (a unit test compares them).
///
/// Returns false, leaving `out` meaningless, when it does not apply (a pass wider than
/// [`MAX_LANE_WIDTH`], a row too long to add without normalising, rows that are not these
/// particles') or when a term was not representable: the caller then runs [`gather`], which
/// names the term.
pub fn gather_in_lanes<const D: usize, K: GatherKernel<D>>(
    isa: Isa,
    kernel: &K,
    p: &Particles<D>,
    full: &FullList,
    out: &mut Vec<f64>,
) -> bool {
    let scales = kernel.scales();
    let width = scales.len();
    let n = p.n_owned;
    let rows = full.lanes();
    if width == 0
        || width > MAX_LANE_WIDTH
        || n == 0
        || full.rows() != n
        || rows.groups() != n.div_ceil(LANES)
        || rows.max_index() >= p.len()
        || (0..rows.groups()).any(|g| rows.group(g).len() / LANES >= NORMALISE_EVERY)
    {
        return false;
    }
    out.clear();
    out.resize(n * width, 0.0);
    let factors: Vec<LaneFactor> = scales.iter().map(Scale::lane_factor).collect();
    let rc2 = kernel.cutoff() * kernel.cutoff();
    let group = |g: usize, chunk: &mut [f64], scratch: &mut LaneScratch| -> bool {
        #[cfg(target_arch = "x86_64")]
        if isa.has_avx512() {
            // SAFETY: an `Isa` has AVX-512 only when the CPU reports every subset that
            // `lane_group_avx512` enables (`Isa::avx512`), the one requirement of a
            // target-feature function.
            return unsafe { lane_group_avx512(kernel, p, rows, &factors, rc2, g, chunk, scratch) };
        }
        #[cfg(target_arch = "x86_64")]
        if isa.has_avx2() {
            // SAFETY: as above, for the AVX2 subset (`Isa::avx2`).
            return unsafe { lane_group_avx2(kernel, p, rows, &factors, rc2, g, chunk, scratch) };
        }
        let _ = isa;
        lane_group(kernel, p, rows, &factors, rc2, g, chunk, scratch)
    };
    out.par_chunks_mut(LANES * width)
        .enumerate()
        .with_min_len(8)
        .map_init(
            || LaneScratch::new(width),
            |scratch, (g, chunk)| group(g, chunk, scratch),
        )
        .reduce(|| true, |a, b| a && b)
}

/// Per-thread scratch of [`gather_in_lanes`].
struct LaneScratch {
    sums: Vec<LaneSums<LANES>>,
    terms: Vec<[f64; LANES]>,
    term: Vec<f64>,
}

impl LaneScratch {
    fn new(width: usize) -> Self {
        Self {
            sums: vec![LaneSums::ZERO; width],
            terms: vec![[0.0; LANES]; width],
            term: vec![0.0; width],
        }
    }
}

/// One group of [`gather_in_lanes`]: its lanes' sums into `chunk` (lanes × width, the last
/// group's only as many lanes as it has particles); false if a term was not representable.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn lane_group<const D: usize, K: GatherKernel<D>>(
    kernel: &K,
    p: &Particles<D>,
    rows: &LaneRows,
    factors: &[LaneFactor],
    rc2: f64,
    g: usize,
    chunk: &mut [f64],
    scratch: &mut LaneScratch,
) -> bool {
    let n = p.n_owned;
    let width = factors.len();
    let LaneScratch { sums, terms, term } = scratch;
    sums.fill(LaneSums::ZERO);
    let own: [usize; LANES] = std::array::from_fn(|l| (g * LANES + l).min(n - 1));
    let active: [bool; LANES] = std::array::from_fn(|l| kernel.active(p, own[l]));
    // The self terms (zero where there is none).
    for l in 0..LANES {
        let has = active[l] && kernel.self_term(p, own[l], term);
        for q in 0..width {
            terms[q][l] = if has { term[q] } else { 0.0 };
        }
    }
    for (factor, (t, s)) in factors.iter().zip(terms.iter().zip(sums.iter_mut())) {
        factor.add(t, s);
    }
    for entries in rows.group(g).chunks_exact(LANES) {
        for l in 0..LANES {
            let (i, j) = (own[l], entries[l] as usize);
            let within = if active[l] && j != i {
                separation_within(&p.pos[i], &p.pos[j], rc2)
            } else {
                None
            };
            match within {
                Some((r_ij, r)) => {
                    kernel.pair(p, i, j, &r_ij, r, term);
                    for q in 0..width {
                        terms[q][l] = term[q];
                    }
                }
                None => {
                    for t in terms.iter_mut() {
                        t[l] = 0.0;
                    }
                }
            }
        }
        for (factor, (t, s)) in factors.iter().zip(terms.iter().zip(sums.iter_mut())) {
            factor.add(t, s);
        }
    }
    for (l, row) in chunk.chunks_exact_mut(width).enumerate() {
        for (q, o) in row.iter_mut().enumerate() {
            *o = if active[l] {
                kernel.scales()[q].value(&sums[q].lane(l))
            } else {
                0.0
            };
        }
    }
    sums.iter().all(LaneSums::representable)
}

/// [`lane_group`] compiled for AVX-512 (no FMA: the same IEEE operations, so the same bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
#[allow(clippy::too_many_arguments)]
fn lane_group_avx512<const D: usize, K: GatherKernel<D>>(
    kernel: &K,
    p: &Particles<D>,
    rows: &LaneRows,
    factors: &[LaneFactor],
    rc2: f64,
    g: usize,
    chunk: &mut [f64],
    scratch: &mut LaneScratch,
) -> bool {
    lane_group(kernel, p, rows, factors, rc2, g, chunk, scratch)
}

/// [`lane_group`] compiled for AVX2 (no FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
fn lane_group_avx2<const D: usize, K: GatherKernel<D>>(
    kernel: &K,
    p: &Particles<D>,
    rows: &LaneRows,
    factors: &[LaneFactor],
    rc2: f64,
    g: usize,
    chunk: &mut [f64],
    scratch: &mut LaneScratch,
) -> bool {
    lane_group(kernel, p, rows, factors, rc2, g, chunk, scratch)
}

/// A gather kernel whose every quantity has a parity under i ↔ j, c(j, i) = ±c(i, j) to the
/// last bit ([`pair_symmetry`] checks it): its sums can be *scattered* from the half list
/// ([`scatter`]), each pair evaluated once instead of once from each end.
pub trait SymmetricKernel<const D: usize>: GatherKernel<D> {
    /// The parity of each quantity (as long as [`GatherKernel::scales`]).
    fn parities(&self) -> &[Parity];

    /// The terms of a batch of pairs within the cutoff: `out[q][k]` = c^q(i_k, j_k) for
    /// k < `batch.len` and every quantity q, the very bits [`GatherKernel::pair`] gives. The
    /// default calls `pair` for each; a kernel overrides it with loops over the batch that the
    /// compiler vectorises (the same IEEE operations in the same order, so the same bits).
    #[inline(always)]
    fn pair_batch(&self, p: &Particles<D>, batch: &PairBatch<D>, out: &mut BatchTerms) {
        pair_by_pair(self, p, batch, out);
    }
}

/// [`SymmetricKernel::pair_batch`] by calls of [`GatherKernel::pair`], one per pair.
#[inline(always)]
pub fn pair_by_pair<const D: usize, K: GatherKernel<D> + ?Sized>(
    kernel: &K,
    p: &Particles<D>,
    batch: &PairBatch<D>,
    out: &mut BatchTerms,
) {
    let width = kernel.scales().len();
    let mut term = [0.0; MAX_SCATTER_WIDTH];
    for k in 0..batch.len {
        let x = std::array::from_fn(|d| batch.x[d][k]);
        let (i, j) = (batch.i[k] as usize, batch.j[k] as usize);
        kernel.pair(p, i, j, &x, batch.r[k], &mut term[..width]);
        for q in 0..width {
            out[q][k] = term[q];
        }
    }
}

/// Pairs per batch of [`SymmetricKernel::pair_batch`].
pub const BATCH: usize = 64;

/// The widest pass [`scatter`] takes (quantities per pair).
pub const MAX_SCATTER_WIDTH: usize = 8;

/// The terms of a batch, one array per quantity.
pub type BatchTerms = [[f64; BATCH]; MAX_SCATTER_WIDTH];

/// A batch of pairs within the cutoff, as structure of arrays.
#[derive(Clone, Debug)]
pub struct PairBatch<const D: usize> {
    /// The owned end of each pair.
    pub i: [u32; BATCH],
    /// The other end (owned or ghost).
    pub j: [u32; BATCH],
    /// r_ij = r_i − r_j, per component.
    pub x: [[f64; BATCH]; D],
    /// |r_ij|.
    pub r: [f64; BATCH],
    /// Number of pairs.
    pub len: usize,
}

impl<const D: usize> Default for PairBatch<D> {
    fn default() -> Self {
        Self {
            i: [0; BATCH],
            j: [0; BATCH],
            x: [[0.0; BATCH]; D],
            r: [0.0; BATCH],
            len: 0,
        }
    }
}

/// Per-thread accumulators of [`scatter`], kept between calls.
#[derive(Debug, Default)]
pub struct ScatterBuffers {
    buffers: Vec<PairBand<FixedSum>>,
}

/// One thread's share of [`scatter`].
struct ScatterChunk<'a, const D: usize, K> {
    kernel: &'a K,
    p: &'a Particles<D>,
    /// Listed pairs, j with its [`crate::neighbour::NEAR_AT_BUILD`] bit.
    pairs: &'a [[u32; 2]],
    rc2: f64,
}

/// [`scatter_chunk`] compiled for AVX2 (no FMA: the same IEEE operations, so the same bits as
/// the portable build).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn scatter_chunk_avx2<const D: usize, K: SymmetricKernel<D>>(
    chunk: &ScatterChunk<D, K>,
    band: &mut PairBand<FixedSum>,
) -> Result<(), PairError> {
    scatter_chunk(chunk, band)
}

/// Scatters a chunk of listed pairs into the thread's accumulators `band` (the band of owned
/// particles the chunk touches × width), in
/// batches: the separations of up to [`BATCH`] listed pairs, those within the cutoff (and with
/// an end whose sums are wanted) kept without a branch, their terms from
/// [`SymmetricKernel::pair_batch`], each quantity split into its fixed-point words in one loop,
/// then the words added to both ends.
#[inline(always)]
fn scatter_chunk<const D: usize, K: SymmetricKernel<D>>(
    chunk: &ScatterChunk<D, K>,
    band: &mut PairBand<FixedSum>,
) -> Result<(), PairError> {
    let ScatterChunk {
        kernel,
        p,
        pairs,
        rc2,
    } = *chunk;
    let scales = kernel.scales();
    let parities = kernel.parities();
    let width = scales.len();
    let n = p.n_owned;
    let (lo, acc) = band.reset(pairs, n, width, FixedSum::ZERO);
    let mut batch = PairBatch::<D>::default();
    let mut r2 = [0.0; BATCH];
    let mut terms: BatchTerms = [[0.0; BATCH]; MAX_SCATTER_WIDTH];
    let mut words = [[Split::ZERO; BATCH]; MAX_SCATTER_WIDTH];
    let pos = &p.pos;
    for block in pairs.chunks(BATCH) {
        let mut len = 0;
        for &[i, j] in block {
            let j = j & !crate::neighbour::NEAR_AT_BUILD;
            let (iu, ju) = (i as usize, j as usize);
            let mut s = 0.0;
            for d in 0..D {
                let x = pos[iu][d] - pos[ju][d];
                batch.x[d][len] = x;
                s += x * x;
            }
            batch.i[len] = i;
            batch.j[len] = j;
            r2[len] = s;
            let wanted = kernel.active(p, iu) || (ju < n && kernel.active(p, ju));
            // Not `s < rc2`: a NaN distance reaches the kernel, and its sum reports it.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            let keep = !(s >= rc2) && wanted;
            len += usize::from(keep);
        }
        batch.len = len;
        for k in 0..len {
            batch.r[k] = r2[k].sqrt();
        }
        kernel.pair_batch(p, &batch, &mut terms);
        for q in 0..width {
            if let Some(k) = scales[q].split_batch(&terms[q][..len], &mut words[q][..len]) {
                let (i, j) = (batch.i[k] as usize, batch.j[k] as usize);
                return Err(split_term(&scales[q], p, (i, j), q, terms[q][k])
                    .expect_err("split_batch found this term out of range"));
            }
        }
        for k in 0..len {
            let (i, j) = (batch.i[k] as usize, batch.j[k] as usize);
            let to_i = kernel.active(p, i);
            let to_j = j < n && kernel.active(p, j);
            for q in 0..width {
                let w = words[q][k];
                if to_i {
                    acc[(i - lo) * width + q].add_split(w);
                }
                if to_j {
                    match parities[q] {
                        Parity::Even => acc[(j - lo) * width + q].add_split(w),
                        Parity::Odd => acc[(j - lo) * width + q].sub_split(w),
                    }
                }
            }
        }
    }
    Ok(())
}

/// The same sums as [`gather`], bit for bit, from the half list: pair [i, j] adds c(i, j) to i
/// and, when j is owned, ±c(i, j) = c(j, i) to j, under the kernel's parity. Both ends add the
/// *same* fixed-point words (negated for an odd quantity: the rounding is symmetric), so each
/// particle's integer sum is exactly the one gather forms. Each thread scatters into its own
/// accumulators, merged exactly at the end. `isa` (normally [`Isa::current`]) picks the
/// compiled version of the pair loop; every one gives the same bits.
pub fn scatter_on<const D: usize, K: SymmetricKernel<D>>(
    isa: Isa,
    kernel: &K,
    p: &Particles<D>,
    list: &NeighbourList<D>,
    work: &mut ScatterBuffers,
    out: &mut Vec<f64>,
) -> Result<(), PairError> {
    let scales = kernel.scales();
    let width = scales.len();
    assert_eq!(kernel.parities().len(), width);
    assert!(
        width <= MAX_SCATTER_WIDTH,
        "a scatter pass of width {width}"
    );
    let n = p.n_owned;
    out.clear();
    out.resize(n * width, 0.0);
    if width == 0 {
        return Ok(());
    }
    let rc2 = kernel.cutoff() * kernel.cutoff();
    let chunks = rayon::current_num_threads().max(1);
    work.buffers.resize_with(chunks, PairBand::default);
    let avx2 = isa.has_avx2();
    let results: Vec<Result<(), PairError>> = work
        .buffers
        .par_iter_mut()
        .zip(list.pair_chunks(chunks))
        .map(|(acc, pairs)| {
            let chunk = ScatterChunk {
                kernel,
                p,
                pairs,
                rc2,
            };
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: an `Isa` has AVX2 only when the CPU reports it (`Isa::avx2`), the one
                // requirement of this target-feature function.
                return unsafe { scatter_chunk_avx2(&chunk, acc) };
            }
            scatter_chunk(&chunk, acc)
        })
        .collect();
    results.into_iter().collect::<Result<(), PairError>>()?;
    let buffers = &work.buffers;
    out.par_chunks_mut(width)
        .enumerate()
        .with_min_len(256)
        .try_for_each_init(
            || vec![0.0; width],
            |term, (i, sums_out)| {
                if !kernel.active(p, i) {
                    return Ok(());
                }
                let own = kernel.self_term(p, i, term);
                for q in 0..width {
                    let mut s = FixedSum::ZERO;
                    if own {
                        s.add_split(split_term(&scales[q], p, (i, i), q, term[q])?);
                    }
                    for b in buffers {
                        if let Some(sums) = b.get(i, width) {
                            let mut x = sums[q];
                            x.normalize();
                            s.merge(&x);
                        }
                    }
                    sums_out[q] = scales[q].value(&s);
                }
                Ok(())
            },
        )
}

/// [`scatter_on`] with the instruction set of this process.
pub fn scatter<const D: usize, K: SymmetricKernel<D>>(
    kernel: &K,
    p: &Particles<D>,
    list: &NeighbourList<D>,
    work: &mut ScatterBuffers,
    out: &mut Vec<f64>,
) -> Result<(), PairError> {
    scatter_on(Isa::current(), kernel, p, list, work, out)
}

/// How a pair quantity behaves when the two ends swap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parity {
    /// c(j, i) = c(i, j) (a density contribution).
    Even,
    /// c(j, i) = −c(i, j) (a pair force).
    Odd,
}

/// Whether `kernel` gives c(j, i) = ±c(i, j) to the last bit, per `parity`, for every listed
/// pair of `p` within the cutoff whose ends are both owned (the property that makes pair
/// forces conserve momentum exactly and an owned–ghost pair the same on both of its ranks).
/// Returns the first pair that breaks it, with the two terms.
pub fn pair_symmetry<const D: usize, K: GatherKernel<D>>(
    kernel: &K,
    p: &Particles<D>,
    list: &NeighbourList<D>,
    parity: &[Parity],
) -> Result<usize, String> {
    let width = kernel.scales().len();
    assert_eq!(parity.len(), width);
    let (mut a, mut b) = (vec![0.0; width], vec![0.0; width]);
    let mut checked = 0;
    for [i, j] in list.pairs() {
        let (i, j) = (i as usize, j as usize);
        if j >= p.n_owned {
            continue;
        }
        let mut r_ij = [0.0; D];
        let mut r_ji = [0.0; D];
        for d in 0..D {
            r_ij[d] = p.pos[i][d] - p.pos[j][d];
            r_ji[d] = p.pos[j][d] - p.pos[i][d];
        }
        let r = r_ij.iter().map(|x| x * x).sum::<f64>().sqrt();
        if r >= kernel.cutoff() {
            continue;
        }
        kernel.pair(p, i, j, &r_ij, r, &mut a);
        kernel.pair(p, j, i, &r_ji, r, &mut b);
        for q in 0..width {
            let want = match parity[q] {
                Parity::Even => a[q],
                Parity::Odd => -a[q],
            };
            if want.to_bits() != b[q].to_bits() {
                return Err(format!(
                    "quantity {q} of the pair ({}, {}): c(i, j) = {:e}, c(j, i) = {:e}",
                    p.gid[i], p.gid[j], a[q], b[q]
                ));
            }
        }
        checked += 1;
    }
    Ok(checked)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three particles in a row (ids 3, 4, 5) and a ghost image of the first (id 3 again).
    fn row() -> (Particles<2>, NeighbourList<2>) {
        let mut p = Particles::<2>::default();
        for (g, x) in [(3u64, 0.0), (4, 0.5), (5, 1.0)] {
            p.push_owned(g, [x, 0.0], [0.0; 2]);
        }
        p.push_ghost(3, [1.4, 0.0], [0.0; 2], 0);
        let list = NeighbourList::build(&p, 0.6, 0.6);
        (p, list)
    }

    #[test]
    fn full_rows_hold_every_pair_from_both_owned_ends() {
        let (p, list) = row();
        let full = FullList::from_half(&list, p.n_owned);
        let mut rows: Vec<Vec<u32>> = (0..3).map(|i| full.row(i).to_vec()).collect();
        rows.iter_mut().for_each(|r| r.sort());
        // 0–1 and 1–2 are owned pairs (both rows), 2–ghost(3) only in row 2.
        assert_eq!(rows, vec![vec![1], vec![0, 2], vec![1, 3]]);
    }

    /// The old serial construction of the rows: the reference of the threaded one.
    fn serial_rows(list: &NeighbourList<2>, n_owned: usize) -> (Vec<usize>, Vec<u32>) {
        let mut offsets = vec![0usize; n_owned + 1];
        for [i, j] in list.pairs() {
            offsets[i as usize + 1] += 1;
            if (j as usize) < n_owned {
                offsets[j as usize + 1] += 1;
            }
        }
        for k in 1..offsets.len() {
            offsets[k] += offsets[k - 1];
        }
        let mut fill = offsets.clone();
        let mut neighbours = vec![0u32; offsets[n_owned]];
        for [i, j] in list.pairs() {
            neighbours[fill[i as usize]] = j;
            fill[i as usize] += 1;
            if (j as usize) < n_owned {
                neighbours[fill[j as usize]] = i;
                fill[j as usize] += 1;
            }
        }
        (offsets, neighbours)
    }

    /// 40 000 scattered owned particles and 4 000 ghosts: more pairs than one chunk of the
    /// threaded sort, so 2, 3 and 8 threads cut the list into several. Every thread count gives
    /// the serial construction's rows, entry for entry, and the same lane rows.
    #[test]
    fn full_rows_are_the_serial_construction_on_any_number_of_threads() {
        let p = crate::neighbour::scattered_particles(
            40_000,
            44_000,
            [100.0, 40.0],
            0x2545_F491_4F6C_DD1D,
        );
        let list = NeighbourList::build(&p, 0.5, 0.4);
        let (offsets, neighbours) = serial_rows(&list, p.n_owned);
        assert!(
            list.len() > 4 * 16_384,
            "{} pairs: too few to split",
            list.len()
        );
        let mut lanes = None;
        for threads in [1, 2, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            let full = pool.install(|| FullList::from_half(&list, p.n_owned));
            assert_eq!(full.offsets, offsets, "{threads} threads");
            assert_eq!(full.neighbours, neighbours, "{threads} threads");
            let l = &full.lanes;
            let lanes = lanes.get_or_insert_with(|| l.clone());
            assert_eq!(
                (&l.starts, &l.index, l.max_index),
                (&lanes.starts, &lanes.index, lanes.max_index),
                "{threads} threads"
            );
        }
        // The lane rows hold the rows: group 0, lane 1 walks row 1, then repeats particle 1.
        let lanes = lanes.expect("built");
        let row1 = &neighbours[offsets[1]..offsets[2]];
        let walked: Vec<u32> = lanes
            .group(0)
            .iter()
            .skip(1)
            .step_by(LANES)
            .copied()
            .collect();
        assert_eq!(&walked[..row1.len()], row1);
        assert!(walked[row1.len()..].iter().all(|&e| e == 1));
    }

    /// Sums ids of the neighbours, and a term of 10⁹ for the pair (4, 5).
    struct Probe {
        scales: [Scale; 2],
    }

    impl GatherKernel<2> for Probe {
        fn scales(&self) -> &[Scale] {
            &self.scales
        }
        fn cutoff(&self) -> f64 {
            0.6
        }
        fn pair(
            &self,
            p: &Particles<2>,
            i: usize,
            j: usize,
            _: &[f64; 2],
            _: f64,
            out: &mut [f64],
        ) {
            out[0] = p.gid[j] as f64;
            out[1] = if p.gid[i] == 4 && p.gid[j] == 5 {
                1e9
            } else {
                0.0
            };
        }
        fn self_term(&self, p: &Particles<2>, i: usize, out: &mut [f64]) -> bool {
            out[0] = 100.0 * p.gid[i] as f64;
            out[1] = 0.0;
            true
        }
    }

    #[test]
    fn gathered_sums_include_the_self_term_and_a_term_beyond_its_scale_names_the_pair() {
        let (p, list) = row();
        let full = FullList::from_half(&list, p.n_owned);
        let mut out = Vec::new();
        let wide = Probe {
            scales: [Scale::covering(1e3), Scale::covering(1e10)],
        };
        gather(&wide, &p, &full, &mut out).expect("in range");
        assert_eq!(out, vec![304.0, 0.0, 408.0, 1e9, 507.0, 0.0]);
        let narrow = Probe {
            scales: [Scale::covering(1e3), Scale::covering(1e3)],
        };
        let err = gather(&narrow, &p, &full, &mut out).expect_err("1e9 is beyond 2048");
        assert_eq!((err.gid_i, err.gid_j, err.quantity), (4, 5, 1));
        assert!(err.to_string().contains("particles 4 and 5"), "{err}");
    }

    /// Terms of three magnitudes, a self term on some particles, some inactive.
    struct Mixed {
        scales: [Scale; 3],
    }

    impl GatherKernel<2> for Mixed {
        fn scales(&self) -> &[Scale] {
            &self.scales
        }
        fn cutoff(&self) -> f64 {
            0.3
        }
        fn pair(
            &self,
            p: &Particles<2>,
            i: usize,
            j: usize,
            x: &[f64; 2],
            r: f64,
            out: &mut [f64],
        ) {
            out[0] = x[0] * (1.0 + p.vel[j][0] - p.vel[i][1]);
            out[1] = 1e-4 * r * p.gid[j] as f64;
            out[2] = 1e5 * x[1] / r;
        }
        fn active(&self, p: &Particles<2>, i: usize) -> bool {
            !p.gid[i].is_multiple_of(7)
        }
        fn self_term(&self, p: &Particles<2>, i: usize, out: &mut [f64]) -> bool {
            out[0] = 0.1 * p.gid[i] as f64;
            out[1] = 0.0;
            out[2] = -1.0;
            p.gid[i].is_multiple_of(3)
        }
    }

    /// The lanes give the very bits of the gather on every instruction set, and hand a term
    /// beyond its scale back to the gather.
    #[test]
    fn lanes_gather_the_bits_of_the_gather() {
        let mut p = Particles::<2>::default();
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        // 203 particles (the last group is partial), clustered enough for long rows.
        for g in 0..203u64 {
            let (x, y, vx, vy) = (2.0 * next(), 2.0 * next(), next() - 0.5, next() - 0.5);
            p.push_owned(g, [x, y], [vx, vy]);
        }
        let list = NeighbourList::build(&p, 0.3, 0.3);
        let full = FullList::from_half(&list, p.n_owned);
        let kernel = Mixed {
            scales: [
                Scale::covering(10.0),
                Scale::covering(0.1),
                Scale::covering(1e6),
            ],
        };
        let mut expected = Vec::new();
        gather(&kernel, &p, &full, &mut expected).expect("in range");
        let mut isas = vec![Isa::PORTABLE];
        isas.extend(Isa::avx2());
        isas.extend(Isa::avx512());
        for isa in isas {
            let mut got = Vec::new();
            assert!(
                gather_in_lanes(isa, &kernel, &p, &full, &mut got),
                "{isa:?}"
            );
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&expected), "{isa:?}");
        }
        assert!(expected.iter().any(|&x| x != 0.0));
        let narrow = Mixed {
            scales: [
                Scale::covering(10.0),
                Scale::covering(0.1),
                Scale::covering(1e3),
            ],
        };
        assert!(!gather_in_lanes(
            Isa::current(),
            &narrow,
            &p,
            &full,
            &mut Vec::new()
        ));
        assert!(gather(&narrow, &p, &full, &mut Vec::new()).is_err());
    }
}
