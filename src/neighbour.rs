//! Neighbour search: a cell list over owned + ghost particles and Verlet lists with a skin.
//!
//! Each owned particle gets a *full* list of partners within r_list = r_c + skin, sorted by global
//! id, so any per-particle sum over neighbours runs in an order that depends neither on cells,
//! ranks nor threads (DESIGN.md, determinism rule 2). On top of the full lists the builder
//! numbers the distinct pairs — owned–owned pairs once (from the smaller id), owned–ghost pairs
//! on each rank that holds the owned end — so pair terms are evaluated once and then gathered
//! per particle in canonical order.
//!
//! Rebuild criterion (checked by the caller): 2 max|Δx| + |Δs| > skin, where Δs is the change of
//! the Lees–Edwards offset since the build: no pair outside r_list at build time can then have
//! come within r_c.

use crate::particles::Particles;
use rayon::prelude::*;

/// Verlet lists for the owned particles.
#[derive(Clone, Debug, Default)]
pub struct NeighbourList<const D: usize> {
    /// `offsets[i]..offsets[i+1]` indexes particle i's entries.
    pub offsets: Vec<usize>,
    /// Local index (owned or ghost) of each neighbour, sorted by global id per particle.
    pub entries: Vec<u32>,
    /// Distinct pair each entry belongs to.
    pub pair_of_entry: Vec<u32>,
    /// Distinct pairs `[i, j]` (i owned; the pair's terms are stored as seen from i).
    pub pairs: Vec<[u32; 2]>,
    /// Owned positions at build time (for the displacement criterion).
    pub build_pos: Vec<[f64; D]>,
    /// List radius r_c + skin.
    pub radius: f64,
}

#[inline]
fn dist2<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    let mut s = 0.0;
    for d in 0..D {
        let x = a[d] - b[d];
        s += x * x;
    }
    s
}

impl<const D: usize> NeighbourList<D> {
    /// Builds the lists of all owned particles over owned + ghost particles.
    pub fn build(particles: &Particles<D>, radius: f64) -> Self {
        let n_all = particles.len();
        let n_owned = particles.n_owned;
        let pos = &particles.pos;
        // Cell grid over the bounding box of everything held.
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
        for d in 0..D {
            if n_all > 0 {
                let extent = hi[d] - lo[d];
                ncell[d] = ((extent / radius).floor() as usize).clamp(1, 1 << 20);
                inv_cell[d] = ncell[d] as f64 / extent.max(f64::MIN_POSITIVE);
            }
        }
        let total_cells: usize = ncell.iter().product();
        let cell_of = |p: &[f64; D]| -> [usize; D] {
            let mut c = [0usize; D];
            for d in 0..D {
                c[d] = (((p[d] - lo[d]) * inv_cell[d]) as usize).min(ncell[d] - 1);
            }
            c
        };
        let flat = |c: &[usize; D]| -> usize {
            let mut f = 0;
            for d in (0..D).rev() {
                f = f * ncell[d] + c[d];
            }
            f
        };
        let mut cell_start = vec![0usize; total_cells + 1];
        let cells: Vec<usize> = pos.iter().map(|p| flat(&cell_of(p))).collect();
        for &c in &cells {
            cell_start[c + 1] += 1;
        }
        for c in 0..total_cells {
            cell_start[c + 1] += cell_start[c];
        }
        let mut fill = cell_start.clone();
        let mut sorted = vec![0u32; n_all];
        for (i, &c) in cells.iter().enumerate() {
            sorted[fill[c]] = i as u32;
            fill[c] += 1;
        }
        let r2 = radius * radius;
        let gid = &particles.gid;
        let lists: Vec<Vec<u32>> = (0..n_owned)
            .into_par_iter()
            .map(|i| {
                let ci = cell_of(&pos[i]);
                let mut found: Vec<(u64, u32)> = Vec::with_capacity(64);
                let mut offset = [0usize; D];
                let stencil = 3usize.pow(D as u32);
                for s in 0..stencil {
                    let mut rem = s;
                    let mut ok = true;
                    for d in 0..D {
                        let delta = (rem % 3) as isize - 1;
                        rem /= 3;
                        let c = ci[d] as isize + delta;
                        if c < 0 || c >= ncell[d] as isize {
                            ok = false;
                            break;
                        }
                        offset[d] = c as usize;
                    }
                    // No wrapping (ghosts are already imaged), so the 3^D offsets are distinct cells.
                    if !ok {
                        continue;
                    }
                    let c = flat(&offset);
                    for &j in &sorted[cell_start[c]..cell_start[c + 1]] {
                        let ju = j as usize;
                        if ju != i && dist2(&pos[i], &pos[ju]) < r2 {
                            found.push((gid[ju], j));
                        }
                    }
                }
                found.sort_unstable();
                found.into_iter().map(|(_, j)| j).collect()
            })
            .collect();
        let mut offsets = Vec::with_capacity(n_owned + 1);
        offsets.push(0);
        for l in &lists {
            offsets.push(offsets.last().copied().unwrap_or(0) + l.len());
        }
        let entries: Vec<u32> = lists.into_iter().flatten().collect();
        // Number the distinct pairs: the owned end with the smaller id (or the only owned end).
        let owns_pair = |i: usize, j: usize| j >= n_owned || gid[j] > gid[i];
        let mut pair_of_entry = vec![u32::MAX; entries.len()];
        let mut pairs = Vec::with_capacity(entries.len() / 2 + 1);
        for i in 0..n_owned {
            for e in offsets[i]..offsets[i + 1] {
                let j = entries[e] as usize;
                if owns_pair(i, j) {
                    pair_of_entry[e] = pairs.len() as u32;
                    pairs.push([i as u32, j as u32]);
                }
            }
        }
        let first_pass = pair_of_entry.clone();
        pair_of_entry
            .par_iter_mut()
            .enumerate()
            .filter(|(_, p)| **p == u32::MAX)
            .for_each(|(e, p)| {
                let i = offsets.partition_point(|&o| o <= e) - 1;
                let j = entries[e] as usize;
                let row = &entries[offsets[j]..offsets[j + 1]];
                let k = row
                    .binary_search_by_key(&gid[i], |&m| gid[m as usize])
                    .expect("neighbour relation is symmetric");
                *p = first_pass[offsets[j] + k];
            });
        NeighbourList {
            offsets,
            entries,
            pair_of_entry,
            pairs,
            build_pos: pos[..n_owned].to_vec(),
            radius,
        }
    }

    /// Largest displacement of an owned particle since the build (local to this rank).
    pub fn max_displacement(&self, particles: &Particles<D>) -> f64 {
        let m2 = particles.pos[..particles.n_owned]
            .par_iter()
            .zip(self.build_pos.par_iter())
            .map(|(p, q)| dist2(p, q))
            .reduce(|| 0.0, f64::max);
        m2.sqrt()
    }

    /// Neighbours of owned particle `i`.
    pub fn neighbours(&self, i: usize) -> &[u32] {
        &self.entries[self.offsets[i]..self.offsets[i + 1]]
    }
}
