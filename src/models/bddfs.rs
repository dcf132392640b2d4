//! BDDFS — Brownian Dynamics with Distribution Function Storing (Ellero & Kröger; Ellero 2004
//! Sec. 5.3; docs/theory/polymer_particle_and_bddfs.md §2.2, §2.4): instead of its N_d connector
//! vectors a particle keeps only a histogram of them on a uniform Q-grid, and every step
//! regenerates N_d dumbbells from it, advances each by one Brownian step and histograms them
//! again. Memory per particle falls from N_d × D numbers to the occupied cells; the work per
//! dumbbell-step is that of plain Brownian dynamics plus a reconstruction and a sort.
//!
//! Grid (n_c cells per axis over [−Q_max, Q_max]^D, ΔQ = 2 Q_max / n_c): cell k = (k_1 … k_D),
//! k_a ∈ {0 … n_c − 1}, covers Π_a [−Q_max + k_a ΔQ, −Q_max + (k_a + 1) ΔQ); its flat index is
//! Σ_a k_a n_c^(D−1−a). A particle's histogram is sparse: the occupied cells in increasing index,
//! each with its count ψ_k (an integer, Σ_k ψ_k = N_d at every step), packed as one u64
//! (index << 32 | count).
//!
//! One step n → n + 1 of one particle (κ frozen at t_n, as for the dumbbells):
//!
//! ```text
//! (a) reconstruct   Q_m = −Q_max 1 + (k + u_m) ΔQ,   u_m ~ U(0, 1)^D
//!                   (the offset from the cell centre, (u_m − ½) ΔQ, is uniform on [−½, ½]^D ΔQ;
//!                    the thesis's "unit square" read as [0, 1]^D would shift every step by ΔQ/2)
//!                   FENE: redrawn while |Q_m|² ≥ b, i.e. uniform on the cell ∩ {|Q| < √b}
//! (b) advance       Q'_m = one step of `polymer.scheme` (super::dumbbells::step_ensemble), the
//!                   same springs, integrators and noise keys as plain Brownian dynamics
//! (c) measure       τ/G = (1/N_d) Σ_m Q'_m F(Q'_m) − I     (the same Kramers estimator,
//!                   evaluated on the advanced Q', as BD evaluates it after its update)
//! (d) histogram     ψ_k ← #{m : Q'_m ∈ cell k}; a connector outside the grid (only possible
//!                   for Hookean springs, or FENE with Q_max < √b) is counted in the nearest
//!                   boundary cell ("clipped", counted and reported)
//! ```
//!
//! Random numbers: the offsets u_m of particle g at step n come from their own stream
//! (seed, [`Purpose::BddfsReconstruction`], n, g), drawn for the dumbbells in histogram order
//! (cells by increasing index, a cell's dumbbells one after another, D uniforms each, redraws in
//! place); the Brownian noise from the dumbbells' stream (seed, g, n, stage 0). Both depend only
//! on the particle's histogram, so the result is bitwise the same on any rank and thread count.
//!
//! # The grid's artificial diffusion [derived]
//!
//! Let P be the projection of a density onto its cell averages (binning, then uniform
//! reconstruction): step (d) then (a). For one component Q_a and a cell with centre c_a, the
//! uniform density on the cell has ⟨Q_a⟩ = c_a and ⟨Q_a²⟩ = c_a² + ΔQ²/12, and P is self-adjoint,
//! so for any density ψ
//!
//! ```text
//! ⟨Q_a⟩_Pψ = ⟨c_a⟩_ψ ,      ⟨Q_a²⟩_Pψ = ⟨c_a²⟩_ψ + ΔQ²/12 .
//! ```
//!
//! For ψ smooth on the scale ΔQ (here ψ is a binned density convolved with the step's Gaussian
//! noise of width √(Δt/λ)), Sheppard's correction gives ⟨c_a⟩ = ⟨Q_a⟩ and
//! ⟨c_a²⟩ = ⟨Q_a²⟩ + ΔQ²/12 (Euler–Maclaurin; the remainder is spectral, ~e^(−2π²σ²/ΔQ²) for a
//! Gaussian of width σ). So every step adds, per component, the variance
//!
//! ```text
//! σ²_grid = ΔQ²/12 (binning) + ΔQ²/12 (reconstruction) = ΔQ²/6
//! ```
//!
//! without moving the mean: an artificial diffusion on top of the physical Brownian variance
//! σ²_phys = Δt/λ per component and step (the noise √(Δt/λ) ξ). (The thesis and the issue name
//! ΔQ²/12, the reconstruction alone; the binning doubles it — measured in
//! `tests/engine_suite/bddfs.rs`.) Their ratio
//!
//! ```text
//! r = σ²_grid / σ²_phys = λ ΔQ² / (6 Δt)
//! ```
//!
//! is the relative excess of the effective diffusion. For a Hookean dumbbell at rest with the
//! semi-implicit scheme (Q' = m Q + a ξ, m = (1 − ε)/(1 + ε), a² = (Δt/λ)/(1 + ε)², ε = Δt/4λ)
//! the stationary variance of the reconstructed Q is ṽ = (a² + σ²_grid)/(1 − m²) and that of the
//! measured Q' is ṽ − σ²_grid, i.e.
//!
//! ```text
//! ⟨Q_a²⟩ = 1 + σ²_grid (1 − ε)² / (4ε) ≈ 1 + r       (exact: [`hookean_rest_excess`])
//! ```
//!
//! The error grows like ΔQ²/Δt: refining Δt on a fixed grid makes it *worse*, and keeping it
//! below r_max needs ΔQ ≤ √(6 r_max Δt/λ), n_c ≥ 2 Q_max / ΔQ ∝ Δt^(−1/2)
//! ([`suggested_cells`]); `check` warns beyond [`ARTIFICIAL_DIFFUSION_WARNING`].

use super::dumbbells::{DumbbellParams, Spring, kramers_stress, noise_stream, step_ensemble};
use crate::rng::{NormalStream, Purpose};

/// The ratio r = λΔQ²/(6Δt) of grid to physical diffusion beyond which `check` warns (1 %: the
/// stationary Hookean ⟨Q²⟩ is then about 1 % too large).
pub const ARTIFICIAL_DIFFUSION_WARNING: f64 = 0.01;

/// Largest number of cells n_c^D of a grid (the cell index is stored in 32 bits).
pub const MAX_GRID_CELLS: u64 = u32::MAX as u64;

/// The uniform Q-grid of a histogram: `cells` = n_c per axis over [−`q_max`, `q_max`]^D.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QGrid {
    /// n_c, cells per axis (≥ 2).
    pub cells: usize,
    /// Q_max, half the edge of the grid (in units of √(k_BT/H)).
    pub q_max: f64,
}

impl QGrid {
    /// ΔQ = 2 Q_max / n_c.
    pub fn spacing(&self) -> f64 {
        2.0 * self.q_max / self.cells as f64
    }

    /// n_c^D, the number of cells (saturating).
    pub fn total_cells(&self, dim: usize) -> u64 {
        (0..dim).fold(1u64, |n, _| n.saturating_mul(self.cells as u64))
    }

    /// σ²_grid = ΔQ²/6: the variance per component the grid adds every step (module docs).
    pub fn artificial_variance_per_step(&self) -> f64 {
        let dq = self.spacing();
        dq * dq / 6.0
    }

    /// r = σ²_grid / σ²_phys = λ ΔQ² / (6 Δt): the grid's diffusion relative to the physical one.
    pub fn artificial_diffusion_ratio(&self, dt: f64, lambda: f64) -> f64 {
        self.artificial_variance_per_step() / (dt / lambda)
    }

    /// Refuses a grid that cannot work, with the reason: n_c ≥ 2, n_c^D cells indexable in 32
    /// bits, Q_max > 0 finite, and for FENE Q_max ≤ √b (a larger grid only holds empty cells
    /// beyond the spring's reach).
    pub fn check(&self, dim: usize, spring: Spring) -> Result<(), String> {
        if self.cells < 2 {
            return Err(format!(
                "n_c = {} cells per axis; must be ≥ 2 (100–1000 is typical)",
                self.cells
            ));
        }
        if self.total_cells(dim) > MAX_GRID_CELLS {
            return Err(format!(
                "n_c^D = {}^{dim} cells; at most {MAX_GRID_CELLS} (32-bit cell indices)",
                self.cells
            ));
        }
        if !(self.q_max > 0.0 && self.q_max.is_finite()) {
            return Err(format!("Q_max = {}; must be > 0", self.q_max));
        }
        if let Spring::Fene { b } = spring
            && self.q_max > b.sqrt()
        {
            return Err(format!(
                "Q_max = {} is beyond the FENE limit √b = {}; use Q_max ≤ √b (leave it out for √b)",
                self.q_max,
                b.sqrt()
            ));
        }
        Ok(())
    }
}

/// The exact stationary excess of ⟨Q_a²⟩ (units k_BT/H, per component) of Hookean BDDFS at rest
/// with the semi-implicit scheme: σ²_grid (1 − ε)²/(4ε), ε = Δt/(4λ) (module docs).
pub fn hookean_rest_excess(grid: &QGrid, dt: f64, lambda: f64) -> f64 {
    let eps = dt / (4.0 * lambda);
    grid.artificial_variance_per_step() * (1.0 - eps) * (1.0 - eps) / (4.0 * eps)
}

/// The n_c that keeps r = λΔQ²/(6Δt) ≤ `ratio`: ⌈2 Q_max / √(6 ratio Δt/λ)⌉.
pub fn suggested_cells(q_max: f64, dt: f64, lambda: f64, ratio: f64) -> usize {
    let dq = (6.0 * ratio * dt / lambda).sqrt();
    (2.0 * q_max / dq).ceil() as usize
}

/// The bound 8 × min(N_d, n_c^D) on the bytes of one particle's sparse histogram (8 per
/// occupied cell).
pub fn histogram_bytes_bound(grid: &QGrid, n_d: usize, dim: usize) -> f64 {
    8.0 * (n_d as f64).min(grid.total_cells(dim) as f64)
}

/// The `check` lines of a BDDFS scene: the grid, its artificial diffusion against the physical
/// one (a warning with the suggested n_c beyond [`ARTIFICIAL_DIFFUSION_WARNING`]), and the
/// memory per particle of BDDFS and of plain Brownian dynamics with the same N_d.
pub fn check_lines(grid: &QGrid, n_d: usize, dim: usize, dt: f64, lambda: f64) -> Vec<String> {
    let dq = grid.spacing();
    let r = grid.artificial_diffusion_ratio(dt, lambda);
    let cells = grid.total_cells(dim);
    let mut out = vec![
        format!(
            "BDDFS grid: n_c = {} cells per axis over [−{q:.4}, {q:.4}]^{dim} (n_c^D = {cells}), ΔQ = {dq:.3e}",
            grid.cells,
            q = grid.q_max,
        ),
        format!(
            "grid diffusion: ΔQ²/6 = {:.3e} per component and step (binning ΔQ²/12 + uniform \
             reconstruction ΔQ²/12) against the Brownian Δt/λ = {:.3e}: r = λΔQ²/(6Δt) = {:.2} % \
             (≈ the relative excess of ⟨Q²⟩; it grows as ΔQ²/Δt: a smaller Δt needs n_c ∝ Δt^(−1/2))",
            grid.artificial_variance_per_step(),
            dt / lambda,
            100.0 * r
        ),
    ];
    if r > ARTIFICIAL_DIFFUSION_WARNING {
        out.push(format!(
            "grid diffusion: r = {:.2} % exceeds {:.0} %: the stresses and ⟨Q²⟩ are biased upwards \
             by about that much; use polymer.cells ≥ {} (or a larger Δt) [warning]",
            100.0 * r,
            100.0 * ARTIFICIAL_DIFFUSION_WARNING,
            suggested_cells(grid.q_max, dt, lambda, ARTIFICIAL_DIFFUSION_WARNING)
        ));
    }
    let bd = n_d as f64 * dim as f64 * 8.0;
    let bddfs = histogram_bytes_bound(grid, n_d, dim);
    out.push(format!(
        "memory per particle: BD {} B (N_d × D × 8), BDDFS ≤ {} B (8 B per occupied cell, at most \
         min(N_d, n_c^D); the run reports the occupancy): ≥ {:.1}× less; plus a working buffer \
         of N_d × (8D + 4) = {} B per thread",
        bd,
        bddfs,
        bd / bddfs,
        n_d * (8 * dim + 4)
    ));
    out
}

/// The reconstruction stream of particle `gid` at `step`.
#[inline]
pub fn reconstruction_stream(seed: u64, gid: u64, step: u64) -> NormalStream {
    NormalStream::new(seed, Purpose::BddfsReconstruction, step, gid, 0)
}

/// Packs one occupied cell.
#[inline(always)]
fn pack(cell: u32, count: u32) -> u64 {
    (u64::from(cell) << 32) | u64::from(count)
}

/// The (cell, count) of a packed entry.
#[inline(always)]
pub fn unpack(entry: u64) -> (u32, u32) {
    ((entry >> 32) as u32, entry as u32)
}

/// Number of dumbbells in a histogram.
pub fn dumbbell_count(histogram: &[u64]) -> u64 {
    histogram.iter().map(|&e| u64::from(unpack(e).1)).sum()
}

/// The working buffers of one thread: the regenerated connectors and their cell indices.
#[derive(Clone, Debug, Default)]
pub struct Workspace {
    q: Vec<f64>,
    cells: Vec<u32>,
}

/// What one particle's step measured on its advanced connectors Q'.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepMoments {
    /// τ/G = ⟨Q' F(Q')⟩ − I, D × D row-major in the first D² entries.
    pub stress: [f64; 9],
    /// ⟨|Q'|²⟩.
    pub mean_q2: f64,
    /// max |Q'|².
    pub max_q2: f64,
    /// Connectors outside the grid, counted in a boundary cell.
    pub clipped: u64,
    /// FENE reconstructions that found no point of the cell inside the ball in 64 draws and
    /// took the cell's point nearest the origin.
    pub fallbacks: u64,
    /// The first advanced connector outside the spring's domain (index, |Q'|²), if any.
    pub outside: Option<(usize, f64)>,
}

impl StepMoments {
    /// The moments of explicit connectors `q` (N_d × D): the same estimator as a step's.
    pub fn of<const D: usize>(q: &[f64], spring: Spring) -> Self {
        let (sum, max) = q.chunks_exact(D).fold((0.0, 0.0f64), |(s, m), c| {
            let q2: f64 = c.iter().map(|v| v * v).sum();
            (s + q2, m.max(q2))
        });
        Self {
            stress: kramers_stress::<D>(q, spring),
            mean_q2: sum / (q.len() / D).max(1) as f64,
            max_q2: max,
            clipped: 0,
            fallbacks: 0,
            outside: None,
        }
    }

    /// Moments not known (after a restart, before the first step).
    pub fn unknown() -> Self {
        Self {
            stress: [f64::NAN; 9],
            mean_q2: f64::NAN,
            max_q2: f64::NAN,
            clipped: 0,
            fallbacks: 0,
            outside: None,
        }
    }
}

/// The flat cell index of `q` and whether it lay outside the grid (then the nearest boundary
/// cell's index).
#[inline(always)]
fn cell_of<const D: usize>(q: &[f64], grid: &QGrid, inv_dq: f64) -> (u32, bool) {
    let n = grid.cells as i64;
    let mut index = 0u64;
    let mut outside = false;
    for &x in q.iter().take(D) {
        outside |= x.abs() > grid.q_max || x.is_nan();
        // `as` saturates (and maps NaN to 0); the clamp keeps the index on the grid.
        let k = (((x + grid.q_max) * inv_dq).floor() as i64).clamp(0, n - 1);
        index = index * grid.cells as u64 + k as u64;
    }
    (index as u32, outside)
}

/// The histogram of connectors `q` (N_d × D) into `out` (cleared first), using `cells` as the
/// scratch of cell indices. Returns how many lay outside the grid (clipped into a boundary cell).
pub fn histogram_into<const D: usize>(
    q: &[f64],
    grid: &QGrid,
    cells: &mut Vec<u32>,
    out: &mut Vec<u64>,
) -> u64 {
    let inv_dq = 1.0 / grid.spacing();
    let mut clipped = 0;
    cells.clear();
    cells.extend(q.chunks_exact(D).map(|c| {
        let (k, outside) = cell_of::<D>(c, grid, inv_dq);
        clipped += u64::from(outside);
        k
    }));
    cells.sort_unstable();
    out.clear();
    let mut i = 0;
    while i < cells.len() {
        let k = cells[i];
        let mut j = i + 1;
        while j < cells.len() && cells[j] == k {
            j += 1;
        }
        out.push(pack(k, (j - i) as u32));
        i = j;
    }
    clipped
}

/// The histogram of connectors `q` (N_d × D), and how many were clipped.
pub fn histogram_of<const D: usize>(q: &[f64], grid: &QGrid) -> (Vec<u64>, u64) {
    let mut out = Vec::new();
    let clipped = histogram_into::<D>(q, grid, &mut Vec::new(), &mut out);
    (out, clipped)
}

/// Draws for the connectors of `histogram` their positions uniformly within their cells into
/// `q` (N_d × D, in histogram order), from `rng`; FENE: uniform on the cell ∩ {|Q|² < b}
/// (redraws; after 64 the cell's point nearest the origin, counted). Returns the fallbacks.
pub fn reconstruct<const D: usize>(
    histogram: &[u64],
    grid: &QGrid,
    spring: Spring,
    rng: &mut NormalStream,
    q: &mut Vec<f64>,
) -> u64 {
    let dq = grid.spacing();
    let n = grid.cells as u64;
    let limit = match spring {
        Spring::Fene { b } => b,
        Spring::Hookean => f64::INFINITY,
    };
    let mut fallbacks = 0;
    q.clear();
    for &entry in histogram {
        let (cell, count) = unpack(entry);
        // Lower corner of the cell, axis by axis (axis 0 is the slowest index).
        let mut lower = [0.0; D];
        let mut rest = u64::from(cell);
        for a in (0..D).rev() {
            lower[a] = -grid.q_max + (rest % n) as f64 * dq;
            rest /= n;
        }
        for _ in 0..count {
            let mut x = [0.0; D];
            let mut placed = false;
            for _ in 0..64 {
                for a in 0..D {
                    x[a] = lower[a] + rng.uniform() * dq;
                }
                let q2: f64 = x.iter().map(|v| v * v).sum();
                if q2 < limit {
                    placed = true;
                    break;
                }
            }
            if !placed {
                for a in 0..D {
                    x[a] = 0.0f64.clamp(lower[a], lower[a] + dq);
                }
                fallbacks += 1;
            }
            q.extend_from_slice(&x);
        }
    }
    fallbacks
}

/// One BDDFS step of particle `gid`'s `histogram` at `step` (module docs: reconstruct, advance
/// with `params` under `kappa`, measure, histogram again), with the buffers of `ws`. `limit`:
/// the |Q|² beyond which a connector has left its spring's domain (b for FENE; the flow's
/// runaway bound for Hookean springs).
#[allow(clippy::too_many_arguments)]
pub fn step_histogram<const D: usize>(
    histogram: &mut Vec<u64>,
    grid: &QGrid,
    kappa: &[[f64; D]; D],
    params: &DumbbellParams,
    limit: f64,
    seed: u64,
    gid: u64,
    step: u64,
    ws: &mut Workspace,
) -> StepMoments {
    let fallbacks = reconstruct::<D>(
        histogram,
        grid,
        params.spring,
        &mut reconstruction_stream(seed, gid, step),
        &mut ws.q,
    );
    step_ensemble::<D>(
        &mut ws.q,
        kappa,
        params,
        &mut noise_stream(seed, gid, step, 0),
    );
    let mut m = StepMoments::of::<D>(&ws.q, params.spring);
    m.outside = super::dumbbells::outside_domain::<D, f64>(&ws.q, limit);
    m.fallbacks = fallbacks;
    m.clipped = histogram_into::<D>(&ws.q, grid, &mut ws.cells, histogram);
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::dumbbells::Scheme;

    fn grid() -> QGrid {
        QGrid {
            cells: 10,
            q_max: 2.0,
        }
    }

    #[test]
    fn histogram_counts_every_connector_in_its_cell_and_clips_outside_ones() {
        // ΔQ = 0.4: (−1.9, 0.1) → (0, 5); (1.99, −0.01) → (9, 4); (3.0, 0) clipped to (9, 5).
        let q = [-1.9, 0.1, 1.99, -0.01, -1.85, 0.35, 3.0, 0.0];
        let (h, clipped) = histogram_of::<2>(&q, &grid());
        assert_eq!(clipped, 1);
        assert_eq!(h, vec![pack(5, 2), pack(94, 1), pack(95, 1)]);
        assert_eq!(dumbbell_count(&h), 4);
    }

    #[test]
    fn reconstruction_stays_in_the_cell_with_offsets_on_the_centred_cell() {
        // 20 000 dumbbells in cell (3, 7): each inside it, and their mean at the centre (an
        // offset on [0, 1] × ΔQ around the centre would put it ΔQ/2 off).
        let g = grid();
        let h = vec![pack(37, 20_000)];
        let mut q = Vec::new();
        let mut rng = reconstruction_stream(1, 2, 3);
        assert_eq!(
            reconstruct::<2>(&h, &g, Spring::Hookean, &mut rng, &mut q),
            0
        );
        let dq = g.spacing();
        let (lo0, lo1) = (-2.0 + 3.0 * dq, -2.0 + 7.0 * dq);
        let mut mean = [0.0; 2];
        for c in q.chunks_exact(2) {
            assert!(c[0] >= lo0 && c[0] < lo0 + dq && c[1] >= lo1 && c[1] < lo1 + dq);
            mean[0] += c[0] / 20_000.0;
            mean[1] += c[1] / 20_000.0;
        }
        // σ of the mean: ΔQ/√(12 · 20 000) = 8·10⁻⁴; 5σ = 0.004.
        assert!((mean[0] - (lo0 + dq / 2.0)).abs() < 0.004, "{mean:?}");
        assert!((mean[1] - (lo1 + dq / 2.0)).abs() < 0.004, "{mean:?}");
        let (back, _) = histogram_of::<2>(&q, &g);
        assert_eq!(back, h);
    }

    #[test]
    fn fene_reconstruction_stays_inside_the_ball() {
        // b = 4, Q_max = 2, ΔQ = 0.4: cells (0, 4), (1, 1) and (8, 8) straddle |Q| = 2 (their
        // nearest points lie inside, their farthest outside); a cell entirely outside the ball
        // holds no FENE connector.
        let g = grid();
        let spring = Spring::Fene { b: 4.0 };
        let h = vec![pack(4, 50), pack(11, 50), pack(88, 50)];
        let mut q = Vec::new();
        let fallbacks =
            reconstruct::<2>(&h, &g, spring, &mut reconstruction_stream(1, 0, 0), &mut q);
        assert_eq!(fallbacks, 0);
        for c in q.chunks_exact(2) {
            assert!(c[0] * c[0] + c[1] * c[1] < 4.0, "{c:?}");
        }
    }

    #[test]
    fn a_step_keeps_the_dumbbell_count_and_is_a_function_of_its_keys() {
        let g = QGrid {
            cells: 40,
            q_max: 50f64.sqrt(),
        };
        let p = DumbbellParams {
            spring: Spring::Fene { b: 50.0 },
            scheme: Scheme::SemiImplicit,
            lambda: 1.0,
            dt: 0.01,
        };
        let mut q0 = vec![0.0; 2 * 500];
        crate::models::dumbbells::sample_equilibrium::<2>(
            &mut q0,
            p.spring,
            &mut crate::models::dumbbells::init_stream(4, 9),
        );
        let (h0, _) = histogram_of::<2>(&q0, &g);
        let kappa = [[0.0, 5.0], [0.0, 0.0]];
        let mut a = h0.clone();
        let mut b = h0.clone();
        let ma = step_histogram::<2>(
            &mut a,
            &g,
            &kappa,
            &p,
            50.0,
            4,
            9,
            1,
            &mut Workspace::default(),
        );
        let mut dirty = Workspace::default();
        // A used workspace gives the same result.
        let mut c = h0.clone();
        step_histogram::<2>(&mut c, &g, &kappa, &p, 50.0, 4, 9, 7, &mut dirty);
        let mb = step_histogram::<2>(&mut b, &g, &kappa, &p, 50.0, 4, 9, 1, &mut dirty);
        assert_eq!(a, b);
        assert_eq!(ma, mb);
        assert_eq!(dumbbell_count(&a), 500);
        assert_ne!(a, c, "another step draws other numbers");
        assert!(ma.outside.is_none() && ma.clipped == 0);
    }

    #[test]
    fn suggested_cells_meet_the_ratio() {
        let (q_max, dt) = (50f64.sqrt(), 0.01);
        let n = suggested_cells(q_max, dt, 1.0, 0.01);
        let r = QGrid { cells: n, q_max }.artificial_diffusion_ratio(dt, 1.0);
        let r_less = QGrid {
            cells: n - 1,
            q_max,
        }
        .artificial_diffusion_ratio(dt, 1.0);
        assert!(r <= 0.01 && r_less > 0.01, "{n}: {r} {r_less}");
    }
}
