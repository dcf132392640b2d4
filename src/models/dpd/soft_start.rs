//! The soft start of a DPD fluid placed at random: a few sweeps of overlap removal before the
//! run proper (`fluid.soft_start_sweeps`, docs/theory/dpd_soft_start.md).
//!
//! Uniformly random positions put clusters into the box that no fluid at a > 0 holds: the
//! particle with the largest Σ_j w_D carries 2–3.6× the mean, and at strong friction the local
//! friction rate γ Σ_j w_D / m there decides the explicit friction's instability within the
//! first 4–21 steps (docs/validation.md, "Stability maps against `check`"). The soft start
//! removes them by steepest descent on the shape of the conservative pair potential
//! (unit amplitude, the case's exponent s̄ and cutoff r_c):
//!
//! ```text
//! F_i   = Σ_j (1 − r_ij/r_c)^s̄ e_ij                       (r_ij < r_c, e_ij = (x_i − x_j)/r_ij)
//! k     = 2 s̄ N_c / (D r_c),   N_c = n V_D(r_c)            the cage stiffness per unit a (= 2mω_E²/a)
//! Δx_i  = κ F_i / k,  |Δx_i| ≤ δ r_c,   κ = 1/2, δ = 1/10
//! ```
//!
//! repeated for `sweeps` sweeps (default [`DEFAULT_SWEEPS`]). The step κ/k keeps the descent
//! stable on the stiffest pair mode of the cage (curvature ≤ k, so κ/k · k = 1/2 < 2) and makes
//! the trajectory independent of a (it applies at a = 0 as well: the ideal gas's equilibrium
//! is the random placement, but the relaxed start makes its limit the lattice start's, which
//! the fitted maps measure). The cap δ r_c bounds the first sweeps, where overlapping clusters
//! push hard. Measured (`python3 tools/soft_start_reference.py --trace 3 8 1536 1`, the 3D
//! ρ = 3 box of `cases/dpd_equilibrium_3d.toml`, 2026-11-27): the largest Σ_j w_D / mean falls
//! from 2.84 to 1.86, 1.59, 1.43, 1.38 after 5, 10, 20, 30 sweeps (2D ρ = 4: 2.70 to 1.27
//! after 30).
//!
//! Velocities are not touched (Maxwellian at k_BT, as without the soft start); the sweeps are
//! no time steps (the step count and time start at 0 afterwards).
//!
//! Determinism: every rank relaxes the whole system's positions in global-id order, serially,
//! before it keeps its own (see [`crate::sim::initial_particles`]), so the result does not
//! depend on the rank or thread count; a restart reads the relaxed state from its checkpoint
//! and never relaxes again.

use crate::geometry::{Boundary, ball_volume};

/// Sweeps of overlap removal of a random start when the case does not say
/// (`fluid.soft_start_sweeps`).
pub const DEFAULT_SWEEPS: u32 = 30;

/// The most sweeps a case may ask for (validation refuses more).
pub const MAX_SWEEPS: u32 = 10_000;

/// Descent step in units of 1/k (module doc).
const STEP: f64 = 0.5;

/// Largest displacement of one sweep, in units of r_c.
const DISPLACEMENT_CAP: f64 = 0.1;

/// Relaxes `positions` (all particles of a random start, in a box of `lengths` with
/// `boundaries`) by `sweeps` sweeps of capped steepest descent on the pair potential shape
/// (1 − r/r_c)^{s̄+1} (module doc). Serial and in id order: the same on every rank.
pub fn relax_random_start<const D: usize>(
    positions: &mut [[f64; D]],
    lengths: &[f64],
    boundaries: &[Boundary],
    cutoff: f64,
    conservative_exponent: f64,
    sweeps: u32,
) {
    let n = positions.len();
    if n < 2 || sweeps == 0 || cutoff.is_nan() || cutoff <= 0.0 {
        return;
    }
    let volume: f64 = lengths.iter().take(D).product();
    let neighbours = n as f64 / volume * ball_volume(D, cutoff);
    let stiffness = 2.0 * conservative_exponent * neighbours / (D as f64 * cutoff);
    if stiffness.is_nan() || stiffness <= 0.0 {
        return;
    }
    let mobility = STEP / stiffness;
    let cap = DISPLACEMENT_CAP * cutoff;
    let periodic: Vec<bool> = (0..D)
        .map(|d| boundaries[d] == Boundary::Periodic)
        .collect();
    let grid = CellGrid::<D>::new(lengths, cutoff);
    let mut forces = vec![[0.0; D]; n];
    for _ in 0..sweeps {
        let cells = grid.bin(positions);
        for (i, f) in forces.iter_mut().enumerate() {
            *f = [0.0; D];
            let xi = positions[i];
            grid.for_each_neighbour_cell(grid.cell_of(&xi), &periodic, |c| {
                for &j in &cells[c] {
                    if j == i {
                        continue;
                    }
                    let mut e = [0.0; D];
                    let mut r2 = 0.0;
                    for d in 0..D {
                        let mut dx = xi[d] - positions[j][d];
                        if periodic[d] {
                            dx -= lengths[d] * (dx / lengths[d]).round();
                        }
                        e[d] = dx;
                        r2 += dx * dx;
                    }
                    if r2 >= cutoff * cutoff || r2 == 0.0 {
                        continue;
                    }
                    let r = r2.sqrt();
                    let w = (1.0 - r / cutoff).powf(conservative_exponent) / r;
                    for d in 0..D {
                        f[d] += w * e[d];
                    }
                }
            });
        }
        for (x, f) in positions.iter_mut().zip(&forces) {
            let mut step = [0.0; D];
            let mut len2 = 0.0;
            for d in 0..D {
                step[d] = mobility * f[d];
                len2 += step[d] * step[d];
            }
            let scale = if len2 > cap * cap {
                cap / len2.sqrt()
            } else {
                1.0
            };
            for d in 0..D {
                let mut y = x[d] + scale * step[d];
                if periodic[d] {
                    y = y.rem_euclid(lengths[d]);
                    // rem_euclid may round a tiny negative to L itself.
                    if y >= lengths[d] {
                        y = 0.0;
                    }
                } else {
                    y = y.clamp(0.0, lengths[d] * (1.0 - f64::EPSILON));
                }
                x[d] = y;
            }
        }
    }
}

/// Cells at least r_c wide covering the box, for the serial pair search of the soft start.
struct CellGrid<const D: usize> {
    counts: [usize; D],
    widths: [f64; D],
}

impl<const D: usize> CellGrid<D> {
    fn new(lengths: &[f64], cutoff: f64) -> Self {
        let mut counts = [1; D];
        let mut widths = [0.0; D];
        for d in 0..D {
            counts[d] = ((lengths[d] / cutoff).floor() as usize).clamp(1, 1 << 16);
            widths[d] = lengths[d] / counts[d] as f64;
        }
        Self { counts, widths }
    }

    fn cell_of(&self, x: &[f64; D]) -> [usize; D] {
        let mut c = [0; D];
        for d in 0..D {
            c[d] = ((x[d] / self.widths[d]).floor().max(0.0) as usize).min(self.counts[d] - 1);
        }
        c
    }

    fn index(&self, c: &[usize; D]) -> usize {
        let mut k = 0;
        for d in (0..D).rev() {
            k = k * self.counts[d] + c[d];
        }
        k
    }

    /// The particles of each cell, in id order.
    fn bin(&self, positions: &[[f64; D]]) -> Vec<Vec<usize>> {
        let total: usize = self.counts.iter().product();
        let mut cells = vec![Vec::new(); total];
        for (i, x) in positions.iter().enumerate() {
            cells[self.index(&self.cell_of(x))].push(i);
        }
        cells
    }

    /// Calls `visit` once for each distinct cell within one cell of `home` (periodic images
    /// folded, so a box of one or two cells along an axis visits each cell once).
    fn for_each_neighbour_cell(
        &self,
        home: [usize; D],
        periodic: &[bool],
        mut visit: impl FnMut(usize),
    ) {
        let mut along: Vec<Vec<usize>> = Vec::with_capacity(D);
        for d in 0..D {
            let n = self.counts[d] as i64;
            let mut v: Vec<usize> = Vec::with_capacity(3);
            for off in -1i64..=1 {
                let c = home[d] as i64 + off;
                let c = if periodic[d] {
                    c.rem_euclid(n)
                } else if (0..n).contains(&c) {
                    c
                } else {
                    continue;
                };
                if !v.contains(&(c as usize)) {
                    v.push(c as usize);
                }
            }
            along.push(v);
        }
        let mut pick = [0usize; D];
        loop {
            let mut c = [0usize; D];
            for d in 0..D {
                c[d] = along[d][pick[d]];
            }
            visit(self.index(&c));
            let mut d = 0;
            loop {
                if d == D {
                    return;
                }
                pick[d] += 1;
                if pick[d] < along[d].len() {
                    break;
                }
                pick[d] = 0;
                d += 1;
            }
        }
    }
}

/// Largest Σ_j (1 − r_ij/r_c)^{2s} of a particle over its mean (the densest cluster's share of
/// the friction), by direct search: what the soft start lowers (tests and `tools/`).
pub fn largest_friction_weight_ratio<const D: usize>(
    positions: &[[f64; D]],
    lengths: &[f64],
    cutoff: f64,
    weight_exponent: f64,
) -> f64 {
    let n = positions.len();
    let mut sums = vec![0.0; n];
    for i in 0..n {
        for j in i + 1..n {
            let mut r2 = 0.0;
            for d in 0..D {
                let mut dx = positions[i][d] - positions[j][d];
                dx -= lengths[d] * (dx / lengths[d]).round();
                r2 += dx * dx;
            }
            if r2 < cutoff * cutoff {
                let w = (1.0 - r2.sqrt() / cutoff).powf(weight_exponent);
                sums[i] += w;
                sums[j] += w;
            }
        }
    }
    let mean = sums.iter().sum::<f64>() / n as f64;
    sums.iter().cloned().fold(0.0, f64::max) / mean
}
