//! The working MSPH wall of docs/theory/msph_dumbbells.md §5.1 (`[walls] treatment = "mirror"`).
//!
//! MSPH's moment systems see boundary particles as ordinary neighbours, so a boundary particle
//! must carry values that continue the fluid's fields across the wall plane. The paper's
//! literal reading (boundary particles at the wall velocity, forming their own MSPH gradients
//! and stresses from one-sided neighbourhoods) is ill-posed: the near-wall flow comes out
//! grossly wrong (docs/theory/msph_dumbbells.md §5.1, kept in a test). What works: for boundary
//! particle w of the wall whose plane is Y, its mirror point m_w = x_w reflected in Y
//! (inside the fluid), and a first-order moving-least-squares fit over the fluid particles f within
//! the support 2h of m_w,
//!
//! ```text
//! minimise Σ_f W(|x_f − m_w|) (g_f − c₀ − c·(x_f − m_w))²    (a (D + 1)-square solve)
//! velocity   v_w = 2U − ĉ₀[v]          (odd about the plane moving at U: no slip)
//! density    ρ_w = ĉ₀[ρ]               (even: no spurious wall-ward pressure gradient)
//! stress     σ_w = ĉ₀[σ] + ĉ[σ]·(x_w − m_w)   (linear extrapolation)
//! ```
//!
//! A boundary particle forms no derivative and carries no dumbbells of its own. Fits are
//! computed for owned boundary particles (their mirror neighbourhoods lie within the owned
//! slab and its halo, since the wall axis is never the decomposition axis) and reach the
//! ghosts through the next pass's field refresh. Each fit sums its fluid particles in the
//! order of their global ids, so it is the same bits on any decomposition.
//!
//! Where fewer than D + 1 fluid particles determine the fit (a depleted neighbourhood) the
//! weighted mean (Shepard) is used with zero slope, and with no fluid particle at all the
//! defaults (ρ₀, U, zero stress); both are counted.

use super::kernels::{Kernel, TruncatedGaussian};
use super::{FLUID, UPPER_WALL, is_wall};
use crate::particles::Particles;

/// The walls as the mirror fits see them.
#[derive(Clone, Copy, Debug)]
pub struct MirrorWalls<const D: usize> {
    /// The wall axis.
    pub axis: usize,
    /// Coordinates of the lower and upper wall planes.
    pub planes: [f64; 2],
    /// The depth of the boundary layers (boundary particles lie within it of their plane).
    pub thickness: f64,
}

/// One boundary particle's fit: the coefficients ĉ₀ and ĉ (D each) of every value, and the
/// offset x_w − m_w to extrapolate with.
pub struct Fit<'a, const D: usize> {
    /// Index of the boundary particle.
    pub particle: usize,
    /// The lower (0) or upper (1) wall.
    pub side: usize,
    /// ĉ₀ per value.
    pub value: &'a [f64],
    /// ĉ per value (D each).
    pub slope: &'a [f64],
    /// x_w − m_w.
    pub offset: [f64; D],
}

/// Fits of the owned boundary particles that could not be formed by least squares: those that
/// fell back to the weighted mean, and those with no fluid particle in reach.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FitFallbacks {
    /// Weighted mean, zero slope.
    pub shepard: u64,
    /// No fluid particle within 2h of the mirror point.
    pub empty: u64,
}

impl<const D: usize> MirrorWalls<D> {
    /// Fits `count` values per fluid particle (`values(f, out)` writes particle f's) at the
    /// mirror point of every owned boundary particle of either wall, and hands each fit to
    /// `emit` (fits without any fluid particle in reach are not emitted).
    pub fn fit(
        &self,
        kernel: &TruncatedGaussian,
        p: &Particles<D>,
        count: usize,
        values: impl Fn(usize, &mut [f64]),
        mut emit: impl FnMut(Fit<'_, D>),
    ) -> FitFallbacks {
        let support = kernel.support();
        let h = 0.5 * support;
        let reach = self.thickness + support;
        let n = D + 1;
        let mut fallbacks = FitFallbacks::default();
        // The fluid particles (owned and ghosts) near each wall, in the order of their ids.
        let mut near: [Vec<usize>; 2] = [Vec::new(), Vec::new()];
        for f in 0..p.len() {
            if p.species_of(f) != FLUID {
                continue;
            }
            let y = p.pos[f][self.axis];
            if y - self.planes[0] <= reach {
                near[0].push(f);
            }
            if self.planes[1] - y <= reach {
                near[1].push(f);
            }
        }
        for list in &mut near {
            list.sort_by_key(|&f| (p.gid[f], p.pos[f].map(f64::to_bits)));
        }
        let mut g = vec![0.0; count];
        let mut a = vec![0.0; n * n];
        let mut rhs = vec![0.0; n * count];
        let mut value = vec![0.0; count];
        let mut slope = vec![0.0; count * D];
        for w in 0..p.n_owned {
            let species = p.species_of(w);
            if !is_wall(species) {
                continue;
            }
            let side = usize::from(species == UPPER_WALL);
            let mut m = p.pos[w];
            m[self.axis] = 2.0 * self.planes[side] - m[self.axis];
            a.fill(0.0);
            rhs.fill(0.0);
            let (mut weight_sum, mut used) = (0.0, 0usize);
            for &f in &near[side] {
                let delta: [f64; D] = std::array::from_fn(|d| (p.pos[f][d] - m[d]) / h);
                let r = h * delta.iter().map(|x| x * x).sum::<f64>().sqrt();
                let wf = kernel.w(r);
                if wf <= 0.0 {
                    continue;
                }
                used += 1;
                weight_sum += wf;
                values(f, &mut g);
                let phi = |k: usize| if k == 0 { 1.0 } else { delta[k - 1] };
                for r in 0..n {
                    let wr = wf * phi(r);
                    for c in 0..n {
                        a[r * n + c] += wr * phi(c);
                    }
                    for (q, gq) in g.iter().enumerate() {
                        rhs[q * n + r] += wr * gq;
                    }
                }
            }
            if used == 0 {
                fallbacks.empty += 1;
                continue;
            }
            let solved = used > D && solve_in_place(&mut a, n, &mut rhs, count);
            if solved {
                for q in 0..count {
                    value[q] = rhs[q * n];
                    for d in 0..D {
                        slope[q * D + d] = rhs[q * n + 1 + d] / h;
                    }
                }
            } else {
                fallbacks.shepard += 1;
                // The first row of the normal equations before elimination is Σ W g: redo it.
                value.fill(0.0);
                for &f in &near[side] {
                    let r = (0..D)
                        .map(|d| (p.pos[f][d] - m[d]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    let wf = kernel.w(r);
                    if wf > 0.0 {
                        values(f, &mut g);
                        for (v, gq) in value.iter_mut().zip(&g) {
                            *v += wf * gq / weight_sum;
                        }
                    }
                }
                slope.fill(0.0);
            }
            emit(Fit {
                particle: w,
                side,
                value: &value,
                slope: &slope,
                offset: std::array::from_fn(|d| p.pos[w][d] - m[d]),
            });
        }
        fallbacks
    }
}

/// Solves the n × n system `a` (row-major) for `count` right-hand sides stored one after the
/// other in `b` (n each), by Gaussian elimination with partial pivoting; false (and garbage)
/// when a pivot falls below 10⁻¹⁰ of the largest entry.
fn solve_in_place(a: &mut [f64], n: usize, b: &mut [f64], count: usize) -> bool {
    let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for k in 0..n {
        let p = (k..n)
            .max_by(|&x, &y| a[x * n + k].abs().total_cmp(&a[y * n + k].abs()))
            .unwrap_or(k);
        let pivot = a[p * n + k];
        if pivot.is_nan() || pivot.abs() <= 1e-10 * scale {
            return false;
        }
        if p != k {
            for c in 0..n {
                a.swap(k * n + c, p * n + c);
            }
            for q in 0..count {
                b.swap(q * n + k, q * n + p);
            }
        }
        for r in k + 1..n {
            let f = a[r * n + k] / a[k * n + k];
            for c in k..n {
                a[r * n + c] -= f * a[k * n + c];
            }
            for q in 0..count {
                b[q * n + r] -= f * b[q * n + k];
            }
        }
    }
    for q in 0..count {
        for r in (0..n).rev() {
            let mut x = b[q * n + r];
            for c in r + 1..n {
                x -= a[r * n + c] * b[q * n + c];
            }
            b[q * n + r] = x / a[r * n + r];
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_solve_matches_a_known_system() {
        // [[2, 1], [1, 3]] x = [3, 5] → x = [0.8, 1.4]; second rhs [1, 0] → [0.6, −0.2].
        let mut a = vec![2.0, 1.0, 1.0, 3.0];
        let mut b = vec![3.0, 5.0, 1.0, 0.0];
        assert!(solve_in_place(&mut a, 2, &mut b, 2));
        for (got, want) in b.iter().zip([0.8, 1.4, 0.6, -0.2]) {
            assert!((got - want).abs() < 1e-14, "{b:?}");
        }
        let mut singular = vec![1.0, 2.0, 2.0, 4.0];
        let mut b = vec![1.0, 2.0];
        assert!(!solve_in_place(&mut singular, 2, &mut b, 1));
    }
}
