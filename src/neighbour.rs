//! Neighbour search: a cell list over owned + ghost particles and a Verlet pair list with a skin.
//!
//! The list holds every pair within r_list = r_c + skin that has at least one owned end, once,
//! as `[i, j]` with i owned. Cells are at least r_list wide; each cell is paired with itself and
//! its forward half of the 3^D stencil, so every pair is examined exactly once. An owned–ghost
//! pair is also listed on the rank (or for the image) that owns the other end, which applies
//! the force only to its own particle. The order of the list does not matter for the result:
//! forces are accumulated exactly ([`crate::fixed_sum`]).
//!
//! Rebuild criterion (checked by the caller): 2 max|Δx| + |Δs| > skin, where Δs is the drift of
//! the Lees–Edwards offset since the build: no pair outside r_list at build time can have come
//! within r_c.

use crate::particles::Particles;
use rayon::prelude::*;

/// The Verlet pair list of this rank.
#[derive(Clone, Debug, Default)]
pub struct NeighbourList<const D: usize> {
    /// Pairs `[i, j]`, i owned, j owned or ghost.
    pub pairs: Vec<[u32; 2]>,
    /// Owned positions at build time (for the displacement criterion).
    pub build_pos: Vec<[f64; D]>,
    /// List radius r_c + skin.
    pub radius: f64,
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

/// A uniform grid of cells over a bounding box, with particles sorted by cell.
pub struct CellGrid<const D: usize> {
    lo: [f64; D],
    inv_cell: [f64; D],
    /// Cells per axis.
    pub ncell: [usize; D],
    /// `start[c]..start[c+1]` indexes `sorted` for cell c.
    pub start: Vec<usize>,
    /// Particle indices sorted by cell.
    pub sorted: Vec<u32>,
}

impl<const D: usize> CellGrid<D> {
    /// Bins `pos` into cells at least `width` wide.
    pub fn new(pos: &[[f64; D]], width: f64) -> Self {
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
        let total: usize = ncell.iter().product();
        let mut grid = CellGrid {
            lo,
            inv_cell,
            ncell,
            start: vec![0; total + 1],
            sorted: vec![0; pos.len()],
        };
        let cells: Vec<u32> = pos
            .iter()
            .map(|p| grid.flat(&grid.coords(p)) as u32)
            .collect();
        for &c in &cells {
            grid.start[c as usize + 1] += 1;
        }
        for c in 0..total {
            grid.start[c + 1] += grid.start[c];
        }
        let mut fill = grid.start.clone();
        for (i, &c) in cells.iter().enumerate() {
            grid.sorted[fill[c as usize]] = i as u32;
            fill[c as usize] += 1;
        }
        grid
    }

    /// Cell coordinates of a point (clamped to the grid).
    #[inline(always)]
    pub fn coords(&self, p: &[f64; D]) -> [usize; D] {
        let mut c = [0usize; D];
        for d in 0..D {
            c[d] =
                (((p[d] - self.lo[d]) * self.inv_cell[d]).max(0.0) as usize).min(self.ncell[d] - 1);
        }
        c
    }

    /// Cell coordinates of a flat index.
    #[inline(always)]
    pub fn unflat(&self, mut f: usize) -> [usize; D] {
        let mut c = [0usize; D];
        for d in 0..D {
            c[d] = f % self.ncell[d];
            f /= self.ncell[d];
        }
        c
    }

    /// Flat index of cell coordinates (x fastest).
    #[inline(always)]
    pub fn flat(&self, c: &[usize; D]) -> usize {
        let mut f = 0;
        for d in (0..D).rev() {
            f = f * self.ncell[d] + c[d];
        }
        f
    }

    /// Forward half of the 3^D neighbour offsets (the first non-zero component, from the last
    /// axis down, is +1).
    fn forward_stencil() -> Vec<[isize; D]> {
        let mut out = Vec::new();
        for s in 0..3usize.pow(D as u32) {
            let mut o = [0isize; D];
            let mut rem = s;
            for x in o.iter_mut() {
                *x = (rem % 3) as isize - 1;
                rem /= 3;
            }
            if let Some(&last) = o.iter().rev().find(|&&x| x != 0)
                && last > 0
            {
                out.push(o);
            }
        }
        out
    }
}

impl<const D: usize> NeighbourList<D> {
    /// Builds the pair list over owned + ghost particles.
    pub fn build(particles: &Particles<D>, radius: f64) -> Self {
        let n_owned = particles.n_owned as u32;
        let pos = &particles.pos;
        let grid = CellGrid::new(pos, radius);
        let stencil = CellGrid::<D>::forward_stencil();
        // Positions in cell order, so the inner loop streams through memory.
        let sorted_pos: Vec<[f64; D]> = grid.sorted.iter().map(|&j| pos[j as usize]).collect();
        let r2 = radius * radius;
        let total_cells = grid.start.len() - 1;
        let owned_end: Vec<usize> = (0..total_cells)
            .map(|c| {
                let (a, b) = (grid.start[c], grid.start[c + 1]);
                a + grid.sorted[a..b].partition_point(|&j| j < n_owned)
            })
            .collect();
        const CHUNK: usize = 64;
        let chunks: Vec<Vec<[u32; 2]>> = (0..total_cells.div_ceil(CHUNK))
            .into_par_iter()
            .map(|chunk| {
                let mut pairs: Vec<[u32; 2]> = Vec::new();
                let mut scratch: Vec<[u32; 2]> = Vec::new();
                let cells = chunk * CHUNK..((chunk + 1) * CHUNK).min(total_cells);
                for c in cells {
                    let (a, b) = (grid.start[c], grid.start[c + 1]);
                    if a == b {
                        continue;
                    }
                    let coords = grid.unflat(c);
                    // Within a cell the owned particles come first (the counting sort is
                    // stable and owned indices are the smallest), so ghost–ghost candidates —
                    // never listed — are skipped wholesale.
                    let a_ghost = owned_end[c];
                    // Own cell: each unordered pair once.
                    for ia in a..a_ghost {
                        let pi = &sorted_pos[ia];
                        let i = grid.sorted[ia];
                        candidates(
                            pi,
                            i,
                            &grid.sorted[ia + 1..b],
                            &sorted_pos[ia + 1..b],
                            r2,
                            n_owned,
                            &mut scratch,
                        );
                    }
                    // Forward neighbour cells.
                    'stencil: for o in &stencil {
                        let mut nc = [0usize; D];
                        for d in 0..D {
                            let x = coords[d] as isize + o[d];
                            if x < 0 || x >= grid.ncell[d] as isize {
                                continue 'stencil;
                            }
                            nc[d] = x as usize;
                        }
                        let f = grid.flat(&nc);
                        let (fa, fb) = (grid.start[f], grid.start[f + 1]);
                        let f_ghost = owned_end[f];
                        if fa == fb || (a == a_ghost && fa == f_ghost) {
                            continue;
                        }
                        for ia in a..b {
                            let i = grid.sorted[ia];
                            // Owned i meets everything, a ghost i only the owned of cell f.
                            let end = if ia < a_ghost { fb } else { f_ghost };
                            candidates(
                                &sorted_pos[ia],
                                i,
                                &grid.sorted[fa..end],
                                &sorted_pos[fa..end],
                                r2,
                                n_owned,
                                &mut scratch,
                            );
                        }
                    }
                    pairs.append(&mut scratch);
                }
                pairs
            })
            .collect();
        let total: usize = chunks.iter().map(Vec::len).sum();
        let mut pairs = Vec::with_capacity(total);
        for c in chunks {
            pairs.extend_from_slice(&c);
        }
        NeighbourList {
            pairs,
            build_pos: pos[..n_owned as usize].to_vec(),
            radius,
        }
    }

    /// Largest displacement of an owned particle since the build (local to this rank).
    pub fn max_displacement(&self, particles: &Particles<D>) -> f64 {
        let m2 = particles.pos[..particles.n_owned]
            .par_iter()
            .zip(self.build_pos.par_iter())
            .with_min_len(4096)
            .map(|(p, q)| dist2(p, q))
            .reduce(|| 0.0, f64::max);
        m2.sqrt()
    }

    /// Number of listed pairs.
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// Whether no pair is listed.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }
}

/// Appends the pairs of particle `i` (at `pi`) with candidates `js` (at `pjs`) within √r2 that
/// have an owned end, owned end first. Branch-free in the distance test.
#[inline(always)]
fn candidates<const D: usize>(
    pi: &[f64; D],
    i: u32,
    js: &[u32],
    pjs: &[[f64; D]],
    r2: f64,
    n_owned: u32,
    out: &mut Vec<[u32; 2]>,
) {
    let i_owned = i < n_owned;
    let mut len = out.len();
    out.resize(len + js.len(), [0, 0]);
    for (&j, pj) in js.iter().zip(pjs) {
        let j_owned = j < n_owned;
        out[len] = if i_owned { [i, j] } else { [j, i] };
        let hit = (dist2(pi, pj) < r2) & (i_owned | j_owned);
        len += usize::from(hit);
    }
    out.truncate(len);
}

/// A spatial order of the owned particles (by cell of a grid `width` wide) for cache locality.
pub fn spatial_order<const D: usize>(pos: &[[f64; D]], width: f64) -> Vec<u32> {
    CellGrid::new(pos, width).sorted
}
