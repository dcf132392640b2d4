//! Neighbour search: a cell list over owned + ghost particles and a Verlet pair list with a skin.
//!
//! The list holds every pair within r_list = r_c + skin that has at least one owned end, once,
//! as `[i, j]` with i owned. Cells are at least r_list / 2 wide; an owned particle is paired with
//! the owned particles of the forward half of the 5^D stencil and with the ghosts of the whole
//! stencil, so every pair is examined exactly once and ghost–ghost pairs never. An owned–ghost
//! pair is also listed on the rank (or for the image) that owns the other end, which applies
//! the force only to its own particle. The order of the list does not matter for the result:
//! forces are accumulated exactly ([`crate::fixed_sum`]).
//!
//! Each listed pair also records whether it lay within the interaction cutoff r_c at the build
//! positions ([`NEAR_AT_BUILD`], a bit of j): the force evaluation right after a build keeps
//! those pairs without computing their distances again (the same r² by the same operations, so
//! the same pairs as its own distance filter would keep).
//!
//! Rebuild criterion (checked by the caller): 2 max|Δx| + |Δs| > skin, where Δs is the drift of
//! the Lees–Edwards offset since the build: no pair outside r_list at build time can have come
//! within r_c.

use crate::counting_sort;
use crate::particles::Particles;
use crate::simd::Isa;
use rayon::prelude::*;

/// The bit of j in a listed pair `[i, j]` that says the pair lay within the cutoff at the
/// build positions; the particle index is `j & !NEAR_AT_BUILD`.
pub const NEAR_AT_BUILD: u32 = 1 << 31;

/// The Verlet pair list of this rank.
#[derive(Clone, Debug, Default)]
pub struct NeighbourList<const D: usize> {
    /// Pairs `[i, j]`, i owned, j owned or ghost, j carrying the [`NEAR_AT_BUILD`] bit.
    pub(crate) flagged: Vec<[u32; 2]>,
    /// Owned positions at build time (for the displacement criterion).
    pub build_pos: Vec<[f64; D]>,
    /// List radius r_c + skin.
    pub radius: f64,
    /// Whether the positions are still those of the build, so that the [`NEAR_AT_BUILD`] bits
    /// tell the pairs within the cutoff. Set by the build; whoever moves the particles clears
    /// it.
    pub at_build_positions: bool,
}

#[inline(always)]
fn dist2<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    let mut s = 0.0;
    for d in 0..D {
        let x = a[d] - b[d];
        s += x * x;
    }
    s
}

/// The cell geometry over a bounding box: origin, cells per axis and inverse cell widths.
struct GridGeometry<const D: usize> {
    lo: [f64; D],
    inv_cell: [f64; D],
    ncell: [usize; D],
}

/// Padding entries after the binned arrays: one vector of the AVX2 row scan less one.
const PAD: usize = LANES - 1;
/// Candidates per step of the AVX2 row scan (four doubles).
const LANES: usize = 4;

/// One set of particles binned into the cells of a [`GridGeometry`].
struct Binned<const D: usize> {
    /// `start[c]..start[c+1]` indexes `sorted` and `pos` for cell c.
    start: Vec<usize>,
    /// Particle indices sorted by cell (stable within a cell), then [`PAD`] entries 0.
    sorted: Vec<u32>,
    /// Positions in the order of `sorted`, one array per axis, then [`PAD`] NaNs.
    pos: [Vec<f64>; D],
}

impl<const D: usize> GridGeometry<D> {
    /// Cells at least `width` wide over the bounding box of `pos`.
    fn new(pos: &[[f64; D]], width: f64) -> Self {
        let mut lo = [f64::INFINITY; D];
        let mut hi = [f64::NEG_INFINITY; D];
        for p in pos {
            for d in 0..D {
                lo[d] = lo[d].min(p[d]);
                hi[d] = hi[d].max(p[d]);
            }
        }
        let mut ncell = [1usize; D];
        let mut inv_cell = [0.0; D];
        // Dilute systems: widen the cells until there are at most ~2 per particle, so memory
        // follows the particle count, not the volume.
        let cap = (2 * pos.len()).max(64) as f64;
        let mut width = width;
        loop {
            for d in 0..D {
                if !pos.is_empty() {
                    let extent = (hi[d] - lo[d]).max(f64::MIN_POSITIVE);
                    ncell[d] = ((extent / width).floor() as usize).clamp(1, 1 << 16);
                    inv_cell[d] = ncell[d] as f64 / extent;
                } else {
                    lo[d] = 0.0;
                }
            }
            if ncell.iter().map(|&c| c as f64).product::<f64>() <= cap {
                break;
            }
            width *= 1.25;
        }
        GridGeometry {
            lo,
            inv_cell,
            ncell,
        }
    }

    /// Number of cells.
    fn total(&self) -> usize {
        self.ncell.iter().product()
    }

    /// Cell coordinates of a point (clamped to the grid).
    #[inline(always)]
    fn coords(&self, p: &[f64; D]) -> [usize; D] {
        let mut c = [0usize; D];
        for d in 0..D {
            c[d] =
                (((p[d] - self.lo[d]) * self.inv_cell[d]).max(0.0) as usize).min(self.ncell[d] - 1);
        }
        c
    }

    /// Cell coordinates of a flat index.
    #[inline(always)]
    fn unflat(&self, mut f: usize) -> [usize; D] {
        let mut c = [0usize; D];
        for d in 0..D {
            c[d] = f % self.ncell[d];
            f /= self.ncell[d];
        }
        c
    }

    /// Flat index of cell coordinates (x fastest).
    #[inline(always)]
    fn flat(&self, c: &[usize; D]) -> usize {
        let mut f = 0;
        for d in (0..D).rev() {
            f = f * self.ncell[d] + c[d];
        }
        f
    }

    /// Flat cell index of every point.
    fn cells(&self, pos: &[[f64; D]]) -> Vec<u32> {
        pos.par_iter()
            .with_min_len(4096)
            .map(|p| self.flat(&self.coords(p)) as u32)
            .collect()
    }

    /// The indices of `pos` sorted by cell (a stable counting sort on the rank's threads:
    /// the same order on any number of them).
    fn order(&self, pos: &[[f64; D]]) -> Vec<u32> {
        counting_sort::sort_indices(&self.cells(pos), self.total()).1
    }

    /// Counting sort of `pos` (indices offset by `first`) into the cells: the stable order,
    /// then the indices and positions gathered in it, all on the rank's threads.
    fn bin(&self, pos: &[[f64; D]], first: u32) -> Binned<D> {
        let (start, order) = counting_sort::sort_indices(&self.cells(pos), self.total());
        let n = pos.len();
        // PAD entries past the end (index 0, position NaN: never within any radius), so the
        // vectorised row scan may read whole vectors at the end of the arrays.
        let mut sorted = vec![0u32; n + PAD];
        sorted[..n]
            .par_iter_mut()
            .zip(order.par_iter())
            .with_min_len(4096)
            .for_each(|(s, &o)| *s = first + o);
        let spos: [Vec<f64>; D] = std::array::from_fn(|d| {
            let mut v = vec![f64::NAN; n + PAD];
            v[..n]
                .par_iter_mut()
                .zip(order.par_iter())
                .with_min_len(4096)
                .for_each(|(x, &o)| *x = pos[o as usize][d]);
            v
        });
        Binned {
            start,
            sorted,
            pos: spos,
        }
    }
}

impl<const D: usize> NeighbourList<D> {
    /// Builds the pair list over owned + ghost particles.
    ///
    /// Cells are at least r_list / 2 wide, so a pair within r_list lies at most two cells apart
    /// along every axis. Owned and ghost particles are binned into two separate cell lists on
    /// one grid. With x the fastest cell axis, the cells x − 2 … x + 2 of one row of the
    /// stencil are contiguous in each list, so every (cell, row) pair is one slice of sorted
    /// positions. An owned particle meets the owned particles of the forward half of the
    /// 5^D stencil (rows whose last non-zero offset is positive, plus the later particles of
    /// its own row) and the ghosts of the whole stencil; ghost–ghost pairs are never examined.
    ///
    /// The pairs within `cutoff` (≤ `radius`) are marked [`NEAR_AT_BUILD`].
    pub fn build(particles: &Particles<D>, radius: f64, cutoff: f64) -> Self {
        Self::build_on(Isa::current(), particles, radius, cutoff)
    }

    /// [`Self::build`] with the instruction set given: the same list on every one.
    pub fn build_on(isa: Isa, particles: &Particles<D>, radius: f64, cutoff: f64) -> Self {
        let n_owned = particles.n_owned;
        let pos = &particles.pos;
        assert!(
            cutoff <= radius,
            "cutoff {cutoff} beyond the list radius {radius}"
        );
        assert!(
            pos.len() < NEAR_AT_BUILD as usize,
            "{} particles (owned and ghosts) on one rank: at most 2^31 − 1 are supported",
            pos.len()
        );
        // A hair wider than r_list / 2, so that rounding in the binning can never put a pair
        // within r_list three cells apart.
        let geom = GridGeometry::new(pos, 0.5 * radius * (1.0 + 1e-9));
        let owned = geom.bin(&pos[..n_owned], 0);
        let ghosts = geom.bin(&pos[n_owned..], n_owned as u32);
        let r2 = radius * radius;
        // Row offsets over the axes 1..D, each in −2..=2.
        let mut rows: Vec<([isize; D], bool)> = Vec::new();
        for s in 0..5usize.pow(D as u32 - 1) {
            let mut o = [0isize; D];
            let mut rem = s;
            for x in o.iter_mut().skip(1) {
                *x = (rem % 5) as isize - 2;
                rem /= 5;
            }
            let forward = o.iter().rev().find(|&&x| x != 0).is_some_and(|&x| x > 0);
            rows.push((o, forward));
        }
        let total_cells = geom.total();
        let scan = Scan {
            geom: &geom,
            owned: &owned,
            ghosts: &ghosts,
            rows: &rows,
            r2,
            near2: cutoff * cutoff,
        };
        let avx2 = isa.has_avx2();
        const CHUNK: usize = 256;
        let chunks: Vec<Vec<[u32; 2]>> = (0..total_cells.div_ceil(CHUNK))
            .into_par_iter()
            .map(|chunk| {
                let cells = chunk * CHUNK..((chunk + 1) * CHUNK).min(total_cells);
                #[cfg(target_arch = "x86_64")]
                if avx2 {
                    // SAFETY: an `Isa` has AVX2 only when the CPU reports it (`Isa::avx2`),
                    // the one requirement of this target-feature function.
                    return unsafe { scan_cells_avx2(&scan, cells) };
                }
                scan_cells::<D, false>(&scan, cells)
            })
            .collect();
        // Concatenated in chunk order, the copies in parallel.
        let total: usize = chunks.iter().map(Vec::len).sum();
        let mut pairs = vec![[0u32; 2]; total];
        let mut rest = &mut pairs[..];
        let mut parts = Vec::with_capacity(chunks.len());
        for c in &chunks {
            let (head, tail) = rest.split_at_mut(c.len());
            parts.push(head);
            rest = tail;
        }
        parts
            .into_par_iter()
            .zip(chunks.par_iter())
            .for_each(|(dst, src)| dst.copy_from_slice(src));
        NeighbourList {
            flagged: pairs,
            build_pos: pos[..n_owned].to_vec(),
            radius,
            at_build_positions: true,
        }
    }

    /// The pairs `[i, j]`, i owned, j owned or ghost.
    pub fn pairs(&self) -> impl ExactSizeIterator<Item = [u32; 2]> + '_ {
        self.flagged.iter().map(|&[i, j]| [i, j & !NEAR_AT_BUILD])
    }

    /// The pairs with their [`NEAR_AT_BUILD`] bits.
    pub fn flagged_pairs(&self) -> &[[u32; 2]] {
        &self.flagged
    }

    /// The flagged pairs cut into `chunks` contiguous runs, padded with empty ones so that a
    /// zip with `chunks` per-thread accumulators covers every pair (the scatter loops).
    pub fn pair_chunks(
        &self,
        chunks: usize,
    ) -> impl rayon::iter::IndexedParallelIterator<Item = &[[u32; 2]]> + '_ {
        use rayon::prelude::*;
        let per_chunk = self.flagged.len().div_ceil(chunks.max(1)).max(1);
        self.flagged
            .par_chunks(per_chunk)
            .chain(rayon::iter::repeat_n(&[][..], chunks))
    }

    /// Largest displacement of an owned particle since the build (local to this rank).
    pub fn max_displacement(&self, particles: &Particles<D>) -> f64 {
        self.largest_displacement(particles).0
    }

    /// The largest displacement of an owned particle since the build and its index: a
    /// position that is not finite counts as an infinite displacement (`f64::max` alone would
    /// drop a NaN and let a blown-up particle through). Ties go to the lower index, so the
    /// answer does not depend on the threads.
    pub fn largest_displacement(&self, particles: &Particles<D>) -> (f64, usize) {
        let (m2, i) = particles.pos[..particles.n_owned]
            .par_iter()
            .zip(self.build_pos.par_iter())
            .enumerate()
            .with_min_len(4096)
            .map(|(i, (p, q))| {
                let d = dist2(p, q);
                (if d.is_nan() { f64::INFINITY } else { d }, i)
            })
            .reduce(|| (0.0, usize::MAX), larger_then_lower_index);
        (m2.sqrt(), i)
    }

    /// Number of listed pairs.
    pub fn len(&self) -> usize {
        self.flagged.len()
    }

    /// Whether no pair is listed.
    pub fn is_empty(&self) -> bool {
        self.flagged.is_empty()
    }
}

/// One thread's accumulators over the band of owned particles its chunk of listed pairs
/// touches: particle `lo + k`'s `width` entries at `acc[k · width ..]`. The list runs in cell
/// order over spatially ordered particles, so a chunk touches a band of the owned particles
/// (its own and their neighbours up to two cell layers on), and a scatter loop clears and
/// merges its band rather than every owned particle: with T threads, O(n) in all instead of
/// O(T n). Ghost ends are never accumulated.
#[derive(Clone, Debug)]
pub struct PairBand<T> {
    lo: usize,
    acc: Vec<T>,
}

impl<T> Default for PairBand<T> {
    fn default() -> Self {
        Self {
            lo: 0,
            acc: Vec::new(),
        }
    }
}

impl<T: Copy> PairBand<T> {
    /// Sizes the band to the owned particles (`< n_owned`) of `pairs` (j with its
    /// [`NEAR_AT_BUILD`] bit), `width` entries of `zero` each, and returns its first particle
    /// and the accumulators (empty when no pair).
    pub fn reset(
        &mut self,
        pairs: &[[u32; 2]],
        n_owned: usize,
        width: usize,
        zero: T,
    ) -> (usize, &mut [T]) {
        let (mut lo, mut hi) = (usize::MAX, 0);
        for &[i, j] in pairs {
            let (i, j) = (i as usize, (j & !NEAR_AT_BUILD) as usize);
            lo = lo.min(i);
            hi = hi.max(i + 1);
            if j < n_owned {
                lo = lo.min(j);
                hi = hi.max(j + 1);
            }
        }
        let lo = lo.min(hi);
        self.lo = lo;
        self.acc.clear();
        self.acc.resize((hi - lo) * width, zero);
        (lo, &mut self.acc)
    }

    /// The `width` entries of particle `i`, if in the band.
    #[inline]
    pub fn get(&self, i: usize, width: usize) -> Option<&[T]> {
        // i below the band wraps to a huge k, which every checked step below turns into None.
        let k = i.wrapping_sub(self.lo);
        self.acc
            .get(k.checked_mul(width)?..k.checked_add(1)?.checked_mul(width)?)
    }
}

/// The reduction of a (value, index) maximum that does not depend on how rayon splits the work:
/// the larger value, and among equal values the lower index.
pub fn larger_then_lower_index(a: (f64, usize), b: (f64, usize)) -> (f64, usize) {
    if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
        b
    } else {
        a
    }
}

/// What the scan of the cells needs: the grid, the two binned lists, the stencil rows, r_list²
/// and r_c².
struct Scan<'a, const D: usize> {
    geom: &'a GridGeometry<D>,
    owned: &'a Binned<D>,
    ghosts: &'a Binned<D>,
    /// Row offsets over the axes 1..D and whether the row is in the forward half.
    rows: &'a [([isize; D], bool)],
    r2: f64,
    near2: f64,
}

/// [`scan_cells`] compiled for AVX2 (no FMA: the same operations, so the same list).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn scan_cells_avx2<const D: usize>(scan: &Scan<D>, cells: std::ops::Range<usize>) -> Vec<[u32; 2]> {
    scan_cells::<D, true>(scan, cells)
}

/// The pairs whose owned end lies in one of `cells` (see [`NeighbourList::build`]). With `AVX2`
/// the rows are scanned by [`candidates_avx2`]: the same list, in the same order. Only
/// [`scan_cells_avx2`] instantiates `AVX2 = true`.
#[inline(always)]
fn scan_cells<const D: usize, const AVX2: bool>(
    scan: &Scan<D>,
    cells: std::ops::Range<usize>,
) -> Vec<[u32; 2]> {
    let Scan {
        geom,
        owned,
        ghosts,
        rows,
        r2,
        near2,
    } = *scan;
    let nx = geom.ncell[0];
    let mut pairs: Vec<[u32; 2]> = Vec::new();
    // Slices (begin, end) of the owned and of the ghost list to scan.
    let mut o_rows: Vec<(usize, usize)> = Vec::with_capacity(rows.len());
    let mut g_rows: Vec<(usize, usize)> = Vec::with_capacity(rows.len());
    for c in cells {
        let (a, b) = (owned.start[c], owned.start[c + 1]);
        if a == b {
            continue;
        }
        let coords = geom.unflat(c);
        let mut lo = coords;
        let mut hi = coords;
        lo[0] = coords[0].saturating_sub(2);
        hi[0] = (coords[0] + 2).min(nx - 1);
        o_rows.clear();
        g_rows.clear();
        let own_end = owned.start[geom.flat(&hi) + 1];
        'rows: for (o, forward) in rows {
            for d in 1..D {
                let x = coords[d] as isize + o[d];
                if x < 0 || x >= geom.ncell[d] as isize {
                    continue 'rows;
                }
                lo[d] = x as usize;
                hi[d] = x as usize;
            }
            let (f0, f1) = (geom.flat(&lo), geom.flat(&hi) + 1);
            if *forward && owned.start[f0] < owned.start[f1] {
                o_rows.push((owned.start[f0], owned.start[f1]));
            }
            if ghosts.start[f0] < ghosts.start[f1] {
                g_rows.push((ghosts.start[f0], ghosts.start[f1]));
            }
        }
        // Candidates in the other rows, the same for every particle of the cell.
        let in_rows: usize = o_rows.iter().chain(&g_rows).map(|r| r.1 - r.0).sum();
        for ia in a..b {
            let i = owned.sorted[ia];
            let pi: [f64; D] = std::array::from_fn(|d| owned.pos[d][ia]);
            let pi = &pi;
            let count = (own_end - ia - 1) + in_rows;
            let mut len = pairs.len();
            // Room for every candidate, and for the whole last vector of the AVX2 scan.
            pairs.resize(len + count + LANES, [0, 0]);
            let out = &mut pairs[..];
            let rows = std::iter::once((owned, ia + 1, own_end))
                .chain(o_rows.iter().map(|&(s, e)| (owned, s, e)))
                .chain(g_rows.iter().map(|&(s, e)| (ghosts, s, e)));
            for (list, s, e) in rows {
                #[cfg(target_arch = "x86_64")]
                if AVX2 {
                    // SAFETY: `AVX2` is true only in `scan_cells_avx2`, which runs only when
                    // the CPU has AVX2 (the one requirement of `candidates_avx2`).
                    len = unsafe { candidates_avx2(pi, i, list, s..e, [r2, near2], out, len) };
                    continue;
                }
                len = candidates(pi, i, list, s..e, [r2, near2], out, len);
            }
            pairs.truncate(len);
        }
    }
    pairs
}

/// Writes the pairs `[i, j]` of particle `i` (at `pi`) with the particles `range` of `cells`
/// within √r2 into `out[len..]`, marked [`NEAR_AT_BUILD`] when within √near2, and returns the
/// new length. Branch-free in the distance tests; `out` must have room for every candidate.
#[inline(always)]
fn candidates<const D: usize>(
    pi: &[f64; D],
    i: u32,
    cells: &Binned<D>,
    range: std::ops::Range<usize>,
    [r2, near2]: [f64; 2],
    out: &mut [[u32; 2]],
    mut len: usize,
) -> usize {
    let js = &cells.sorted[range.clone()];
    let xs: [&[f64]; D] = std::array::from_fn(|d| &cells.pos[d][range.clone()]);
    for (k, &j) in js.iter().enumerate() {
        // dist2 of pi and pj, the same operations in the same order.
        let mut d2 = 0.0;
        for d in 0..D {
            let x = pi[d] - xs[d][k];
            d2 += x * x;
        }
        out[len] = [i, j | (u32::from(d2 < near2) << 31)];
        len += usize::from(d2 < r2);
    }
    len
}

/// For every 4-bit mask m, the 32-bit lane indices that move the 64-bit lanes set in m (in
/// order) to the front of a vector: the compress of [`candidates_avx2`].
#[cfg(target_arch = "x86_64")]
const COMPRESS: [[i32; 8]; 16] = {
    let mut table = [[0i32; 8]; 16];
    let mut m = 0;
    while m < 16 {
        let mut next = 0;
        let mut lane: i32 = 0;
        while lane < 4 {
            if m & (1 << lane) != 0 {
                table[m][2 * next] = 2 * lane;
                table[m][2 * next + 1] = 2 * lane + 1;
                next += 1;
            }
            lane += 1;
        }
        m += 1;
    }
    table
};

/// [`candidates`] four candidates at a time with AVX2: the same distances (the same IEEE
/// operations in the same order, no FMA), the same pairs and marks in the same order. The pairs within
/// range are packed to the front of a vector by a lane permutation ([`COMPRESS`]) and the whole
/// vector is stored at `out[len..]`; only the packed ones count. Reads up to 3 entries past
/// `e` (the [`PAD`] of the binned arrays guarantees they exist; they are masked out).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn candidates_avx2<const D: usize>(
    pi: &[f64; D],
    i: u32,
    cells: &Binned<D>,
    range: std::ops::Range<usize>,
    [r2, near2]: [f64; 2],
    out: &mut [[u32; 2]],
    len0: usize,
) -> usize {
    use std::arch::x86_64::*;
    let (s, e) = (range.start, range.end);
    let n = e - s;
    let mut len = len0;
    // The bounds every raw access below relies on.
    assert!(e + PAD <= cells.sorted.len() && len0 + n.next_multiple_of(LANES) <= out.len());
    for d in 0..D {
        assert!(cells.pos[d].len() == cells.sorted.len());
    }
    let limit = _mm256_set1_pd(r2);
    let near_limit = _mm256_set1_pd(near2);
    // NEAR_AT_BUILD in the j half of a pair.
    let near_bit = _mm256_set1_epi64x(i64::from(NEAR_AT_BUILD) << 32);
    let centre: [__m256d; D] = std::array::from_fn(|d| _mm256_set1_pd(pi[d]));
    let owner = _mm256_set1_epi64x(i64::from(i));
    let lane = _mm256_setr_epi64x(0, 1, 2, 3);
    let mut k = 0;
    while k < n {
        // SAFETY (all raw accesses of this loop): k < n, so s + k + 3 < e + PAD ≤ the length
        // of every binned array; at most k of this row's candidates were kept so far, so with
        // len₀ the length at the row's start, len + 4 ≤ len₀ + k + 4 ≤ len₀ +
        // n.next_multiple_of(4) ≤ out.len() (both bounds asserted above).
        let mut d2 = _mm256_setzero_pd();
        for d in 0..D {
            let xj = unsafe { _mm256_loadu_pd(cells.pos[d].as_ptr().add(s + k)) };
            let x = _mm256_sub_pd(centre[d], xj);
            d2 = _mm256_add_pd(d2, _mm256_mul_pd(x, x));
        }
        // d2 < r2 (false for NaN, as in the scalar test), in the row only.
        let inside = _mm256_cmp_pd::<_CMP_LT_OQ>(d2, limit);
        let in_row = _mm256_cmpgt_epi64(_mm256_set1_epi64x((n - k) as i64), lane);
        let mask = _mm256_movemask_pd(_mm256_and_pd(inside, _mm256_castsi256_pd(in_row))) as usize;
        let js = unsafe { _mm_loadu_si128(cells.sorted.as_ptr().add(s + k).cast()) };
        // [i, j] as one little-endian u64: i in the low half, j in the high half, with its
        // NEAR_AT_BUILD bit where d2 < near2.
        let near = _mm256_castpd_si256(_mm256_cmp_pd::<_CMP_LT_OQ>(d2, near_limit));
        let pairs = _mm256_or_si256(_mm256_slli_epi64::<32>(_mm256_cvtepu32_epi64(js)), owner);
        let pairs = _mm256_or_si256(pairs, _mm256_and_si256(near, near_bit));
        let order = unsafe { _mm256_loadu_si256(COMPRESS[mask].as_ptr().cast()) };
        let packed = _mm256_permutevar8x32_epi32(pairs, order);
        unsafe { _mm256_storeu_si256(out.as_mut_ptr().add(len).cast(), packed) };
        len += mask.count_ones() as usize;
        k += LANES;
    }
    len
}

/// A spatial order of the owned particles (by cell of a grid `width` wide) for cache locality.
pub fn spatial_order<const D: usize>(pos: &[[f64; D]], width: f64) -> Vec<u32> {
    GridGeometry::new(pos, width).order(pos)
}

/// `total` particles scattered uniformly (xorshift64 from `seed`) over a box of `lengths`,
/// the first `owned` of them owned and the rest ghosts, ids 0, 1, …: the tests' crowd.
#[cfg(test)]
pub(crate) fn scattered_particles<const D: usize>(
    owned: u64,
    total: u64,
    lengths: [f64; D],
    seed: u64,
) -> Particles<D> {
    let mut p = Particles::<D>::default();
    let mut x = seed;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    for g in 0..total {
        let pos: [f64; D] = std::array::from_fn(|d| lengths[d] * next());
        if g < owned {
            p.push_owned(g, pos, [0.0; D]);
        } else {
            p.push_ghost(g, pos, [0.0; D], 0);
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 60 000 scattered particles (50 000 owned): the list, the spatial order and the binned
    /// cells are the same on 1, 2, 3 and 8 threads (the counting sorts split into chunks
    /// there), and the order is the stable sort by cell.
    #[test]
    fn lists_and_orders_are_the_same_on_any_number_of_threads() {
        let p = scattered_particles(50_000, 60_000, [20.0, 30.0, 10.0], 0x9E37_79B9_7F4A_7C15);
        let mut first = None;
        for threads in [1, 2, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            let (list, order) = pool.install(|| {
                (
                    NeighbourList::build(&p, 1.0, 0.8),
                    spatial_order(&p.pos, 0.75),
                )
            });
            let got = (list.flagged_pairs().to_vec(), order);
            let want = first.get_or_insert_with(|| got.clone());
            assert!(got == *want, "{threads} threads");
        }
        // The order is stable by cell: within a cell, ascending indices.
        let (_, order) = first.expect("built");
        let geom = GridGeometry::new(&p.pos, 0.75);
        let cells = geom.cells(&p.pos);
        for w in order.windows(2) {
            let (a, b) = (w[0] as usize, w[1] as usize);
            assert!(cells[a] < cells[b] || (cells[a] == cells[b] && a < b));
        }
    }
}
