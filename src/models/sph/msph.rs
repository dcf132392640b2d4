//! Modified SPH (MSPH) derivatives: Zhang & Batra (2004) as used by Murashima & Taniguchi
//! (eqs. 3–9), docs/theory/msph_dumbbells.md §1.3: the per-particle moment system, its gather
//! pass ([`MomentKernel`]) and its solution ([`Local`]), used by the SPH model's velocity-
//! gradient and stress-divergence passes when `[fluid] derivatives = "msph"`.
//!
//! A second-order Taylor expansion of f about ξ = x_i, substituted into the kernel average and
//! its first and second derivatives, gives per particle the linear system (2D: 6 × 6; 3D:
//! 10 × 10, the symmetric second derivatives merged):
//!
//! ```text
//! M_rc(i) = Σ_{j ∈ N_i} ω_j ψ_r(R_ij) φ_c(R_ij),   b_r(i) = Σ_j ω_j ψ_r(R_ij) f_j,   M u = b
//! R_ij = x_j − x_i;  ψ = [W, ∂_αW, ∂_αα W, ∂_αβ W (α < β)] with ∂ = ∂/∂ξ acting on W only;
//! φ = [1, R_α, ½R_α², R_αR_β (α < β)];   u = [f̂_i, ∂_α f, ∂_αα f, ∂_αβ f]
//! ```
//!
//! N_i includes j = i and the neighbours at exactly r = 2h, where the truncated Gaussian has
//! W = 0 but ∂W ≠ 0 (the reference matrix of docs/theory/msph_dumbbells.md §1.3 counts them).
//! Quadratic fields are reproduced exactly for any positive weights ω_j used alike in M and b;
//! ω_j = m_j/ρ_j here. M is not symmetric: it is factored once per particle
//! (LU with partial pivoting) and reused for every field. Component order in 2D:
//! (1, x, y, xx, yy, xy); in 3D (1, x, y, z, xx, yy, zz, xy, xz, yz) —
//! docs/theory/msph_dumbbells.md §1.3 prints 2D as (…, xx, xy, yy); only the order differs.

use super::kernels::{Kernel, TruncatedGaussian};
use crate::error::UNSTABLE;
use crate::models::gather::FullList;
use crate::particles::Particles;
use rayon::prelude::*;

/// Unknowns per particle: 1 + D + D(D + 1)/2 (6 in 2D, 10 in 3D).
pub const fn unknowns(dimension: usize) -> usize {
    1 + dimension + dimension * (dimension + 1) / 2
}

/// The off-diagonal index pairs (α < β) in their order.
fn pairs<const D: usize>() -> impl Iterator<Item = (usize, usize)> {
    (0..D).flat_map(|a| (a + 1..D).map(move |b| (a, b)))
}

/// ψ_r(R): W and its first and second derivatives with respect to ξ = x_i, for R = x_j − x_i
/// with |R| ≤ 2h (zeros beyond). ∂W/∂ξ^α = (2K/h²) E R^α, ∂²W/∂ξ^α∂ξ^β = K E (4R^αR^β/h⁴ −
/// 2δ_αβ/h²), E = e^{−|R|²/h²} (docs/theory/msph_dumbbells.md §1.2).
pub fn rows<const D: usize>(g: &TruncatedGaussian, r: &[f64; D]) -> [f64; 10] {
    let mut out = [0.0; 10];
    let r2: f64 = r.iter().map(|x| x * x).sum();
    let h = g.support() / 2.0;
    if r2 > 4.0 * h * h {
        return out;
    }
    let (inv_h2, k) = (1.0 / (h * h), g.prefactor());
    let e = (-r2 * inv_h2).exp();
    // W = K (E − e⁻⁴) for r < 2h, 0 at r = 2h (one exponential for every row).
    out[0] = if r2 < 4.0 * h * h {
        k * (e - (-4.0f64).exp())
    } else {
        0.0
    };
    for a in 0..D {
        out[1 + a] = 2.0 * k * inv_h2 * e * r[a];
        out[1 + D + a] = k * e * (4.0 * r[a] * r[a] * inv_h2 * inv_h2 - 2.0 * inv_h2);
    }
    for (q, (a, b)) in pairs::<D>().enumerate() {
        out[1 + 2 * D + q] = k * e * 4.0 * r[a] * r[b] * inv_h2 * inv_h2;
    }
    out
}

/// φ_c(R): the Taylor monomials 1, R_α, ½R_α², R_αR_β (α < β).
pub fn columns<const D: usize>(r: &[f64; D]) -> [f64; 10] {
    let mut out = [0.0; 10];
    out[0] = 1.0;
    for a in 0..D {
        out[1 + a] = r[a];
        out[1 + D + a] = 0.5 * r[a] * r[a];
    }
    for (q, (a, b)) in pairs::<D>().enumerate() {
        out[1 + 2 * D + q] = r[a] * r[b];
    }
    out
}

/// The moment matrix M(i) of one particle, accumulated neighbour by neighbour.
#[derive(Clone, Debug)]
pub struct MomentSystem<const D: usize> {
    m: [[f64; 10]; 10],
}

impl<const D: usize> Default for MomentSystem<D> {
    fn default() -> Self {
        Self { m: [[0.0; 10]; 10] }
    }
}

/// A factored moment matrix: P M = L U, ready for any number of right-hand sides.
#[derive(Clone, Debug)]
pub struct Factored<const D: usize> {
    lu: [[f64; 10]; 10],
    pivot: [usize; 10],
}

impl<const D: usize> MomentSystem<D> {
    const N: usize = unknowns(D);

    /// Adds neighbour R = x_j − x_i (or j = i, R = 0) with weight ω_j.
    pub fn add(&mut self, g: &TruncatedGaussian, weight: f64, r: &[f64; D]) {
        let (psi, phi) = (rows(g, r), columns(r));
        for (row, p) in self.m.iter_mut().zip(&psi).take(Self::N) {
            for (x, f) in row.iter_mut().zip(&phi).take(Self::N) {
                *x += weight * p * f;
            }
        }
    }

    /// M_rc.
    pub fn entry(&self, r: usize, c: usize) -> f64 {
        self.m[r][c]
    }

    /// LU with partial pivoting; None when a pivot falls below 10⁻¹² of the largest entry
    /// (a neighbourhood that cannot determine the second derivatives).
    pub fn factor(&self) -> Option<Factored<D>> {
        let n = Self::N;
        let mut lu = self.m;
        let mut pivot = [0usize; 10];
        let scale = lu.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
        for k in 0..n {
            let p = (k..n).max_by(|&a, &b| lu[a][k].abs().total_cmp(&lu[b][k].abs()))?;
            let pivot_size = lu[p][k].abs();
            if pivot_size.is_nan() || pivot_size <= 1e-12 * scale {
                return None;
            }
            lu.swap(k, p);
            pivot[k] = p;
            for r in k + 1..n {
                let f = lu[r][k] / lu[k][k];
                lu[r][k] = f;
                for c in k + 1..n {
                    lu[r][c] -= f * lu[k][c];
                }
            }
        }
        Some(Factored { lu, pivot })
    }
}

impl<const D: usize> Factored<D> {
    /// The 1-norm condition number ‖M‖₁ ‖M⁻¹‖₁ of the factored `m` (M⁻¹ column by column).
    pub fn condition_1(&self, m: &MomentSystem<D>) -> f64 {
        let n = unknowns(D);
        let norm = |col: &dyn Fn(usize) -> f64| -> f64 { (0..n).map(|r| col(r).abs()).sum() };
        let mut m_norm = 0.0f64;
        let mut inv_norm = 0.0f64;
        for c in 0..n {
            m_norm = m_norm.max(norm(&|r| m.m[r][c]));
            let mut e = [0.0; 10];
            e[c] = 1.0;
            let x = self.solve(&e);
            inv_norm = inv_norm.max(norm(&|r| x[r]));
        }
        let cond = m_norm * inv_norm;
        if cond.is_nan() { f64::INFINITY } else { cond }
    }

    /// u with M u = b.
    pub fn solve(&self, b: &[f64; 10]) -> [f64; 10] {
        let n = unknowns(D);
        let mut x = *b;
        for k in 0..n {
            x.swap(k, self.pivot[k]);
        }
        for r in 0..n {
            for c in 0..r {
                x[r] -= self.lu[r][c] * x[c];
            }
        }
        for r in (0..n).rev() {
            for c in r + 1..n {
                x[r] -= self.lu[r][c] * x[c];
            }
            x[r] /= self.lu[r][r];
        }
        x
    }
}

/// Polynomial degree of unknown `c` (0 for f̂, 1 for the first derivatives, 2 beyond).
fn degree<const D: usize>(c: usize) -> i32 {
    match c {
        0 => 0,
        c if c <= D => 1,
        _ => 2,
    }
}

/// Largest 1-norm condition number of the h-scaled moment matrix S = D_r M D_c
/// (D_r = diag(h^deg), D_c = diag(h^−deg), entries O(1) whatever the units) with which the
/// second-order system is solved. The bulk of the paper's lattice has 5.3 (2-norm 3.63); a
/// wall's outermost row, seeing one side only, ~10²; beyond 10⁴ the second derivatives are
/// not determined by the neighbourhood and the first-order correction is used instead.
pub const MAX_CONDITION: f64 = 1e4;

/// How one particle's derivatives are formed from its right-hand sides.
// Nearly every particle holds the large variant (the factored system); boxing it would cost
// an allocation per particle per evaluation to save space on the rare fallbacks.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Local<const D: usize> {
    /// The full second-order system, h-scaled and factored: u = D_c S⁻¹ D_r b.
    Second { scaled: Factored<D>, h: f64 },
    /// The first-order correction (Randles & Libersky): ∇f = A⁻¹ (b_∂ − f_i c) with
    /// A_αβ = Σ_j ω_j ∂_αW R_β and c_α = Σ_j ω_j ∂_αW (rows ∂_α, columns R_β and 1 of M):
    /// exact for linear fields.
    First { inverse: [[f64; D]; D], c: [f64; D] },
    /// Nothing determinable (an isolated particle): zero derivatives.
    Undetermined,
}

impl<const D: usize> Local<D> {
    /// The derivative form of a particle whose moment matrix M has entries `m` (row-major,
    /// unknowns(D)² numbers, as [`MomentKernel`] sums them), for smoothing length `h`.
    pub fn new(m: &[f64], h: f64) -> Self {
        let n = unknowns(D);
        let mut scaled = MomentSystem::<D>::default();
        for r in 0..n {
            for c in 0..n {
                scaled.m[r][c] = m[r * n + c] * h.powi(degree::<D>(r) - degree::<D>(c));
            }
        }
        if let Some(f) = scaled.factor()
            && f.condition_1(&scaled) <= MAX_CONDITION
        {
            return Local::Second { scaled: f, h };
        }
        let a: [[f64; D]; D] =
            std::array::from_fn(|x| std::array::from_fn(|y| m[(1 + x) * n + 1 + y]));
        let (det, inverse) = super::determinant_and_inverse(&a);
        // det A ≈ 1 in a complete neighbourhood (A → I); a sparse one falls towards 0.
        if det.is_finite() && det > super::MIN_CORRECTION_DETERMINANT {
            let c = std::array::from_fn(|x| m[(1 + x) * n]);
            return Local::First { inverse, c };
        }
        Local::Undetermined
    }

    /// Whether the second-order system is used.
    pub fn is_second_order(&self) -> bool {
        matches!(self, Local::Second { .. })
    }

    /// ∂_α f (α < D) of the field whose right-hand side is `b` (unknowns(D) numbers) and whose
    /// value at the particle is `f_i`.
    pub fn gradient(&self, b: &[f64], f_i: f64) -> [f64; D] {
        match self {
            Local::Second { scaled, h } => {
                let n = unknowns(D);
                let mut rhs = [0.0; 10];
                for r in 0..n {
                    rhs[r] = b[r] * h.powi(degree::<D>(r));
                }
                let y = scaled.solve(&rhs);
                std::array::from_fn(|a| y[1 + a] / h)
            }
            Local::First { inverse, c } => {
                let rhs: [f64; D] = std::array::from_fn(|a| b[1 + a] - f_i * c[a]);
                std::array::from_fn(|a| (0..D).map(|x| inverse[a][x] * rhs[x]).sum())
            }
            Local::Undetermined => [0.0; D],
        }
    }
}

/// Gather pass of the moment systems: per active particle i, M_i (unknowns² sums, when
/// `matrix`) followed by the right-hand sides b_i of `fields` per-particle values (`values`,
/// `fields` numbers per particle, owned and ghosts alike), ω_j = m/ρ_j, the self term j = i
/// included, and neighbours at exactly r = 2h included.
///
/// The sums are plain floating-point sums taken in a fixed order — the self term, then the
/// neighbours by global id — so they are the same bits on any decomposition without the
/// exact (fixed-point) sums of the pair passes, which for the 48 (2D) to 130 (3D) quantities
/// per pair made the 2D channel's whole loop a third slower (62 s against 46 s).
pub struct MomentKernel<'a, const D: usize> {
    /// The kernel.
    pub kernel: TruncatedGaussian,
    /// Particle mass m.
    pub mass: f64,
    /// ρ of every particle.
    pub density: &'a [f64],
    /// The fields' values, `fields` per particle.
    pub values: &'a [f64],
    /// Number of fields.
    pub fields: usize,
    /// Whether M is summed too (the gradient pass) or only b (the divergence pass, which
    /// reuses the factors).
    pub matrix: bool,
    /// Only fluid particles form a system (otherwise every particle).
    pub fluid_only: bool,
}

/// A neighbour in summation order: its global id, its position's bits (two periodic images
/// of one particle differ there), its local index.
type Neighbour<const D: usize> = (u64, [u64; D], usize);

/// A moment-system sum that is not finite: the run has blown up.
#[derive(Clone, Debug, PartialEq)]
pub struct NotFinite {
    /// Global id of the particle.
    pub gid: u64,
}

impl std::fmt::Display for NotFinite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the MSPH moment sums of particle {} are not finite: {UNSTABLE} (time step \
             too large, particles overlapping)",
            self.gid
        )
    }
}

impl<const D: usize> MomentKernel<'_, D> {
    /// The width of a particle's row of sums.
    pub fn width(&self) -> usize {
        let n = unknowns(D);
        (if self.matrix { n * n } else { 0 }) + n * self.fields
    }

    /// Whether particle `i` forms a system.
    pub fn active(&self, p: &Particles<D>, i: usize) -> bool {
        !self.fluid_only || p.species_of(i) == super::FLUID
    }

    /// The sums of every owned particle into `out` ([`Self::width`] each; zeros for an
    /// inactive one), over the full list's neighbours within 2h(1 + 10⁻⁹) (those at exactly
    /// r = 2h count). Runs on the current rayon pool; the result does not depend on its
    /// thread count.
    pub fn gather(
        &self,
        p: &Particles<D>,
        full: &FullList,
        out: &mut Vec<f64>,
    ) -> Result<(), NotFinite> {
        let width = self.width();
        let n = p.n_owned;
        out.clear();
        out.resize(n * width, 0.0);
        let rc = self.kernel.support() * (1.0 + 1e-9);
        let rc2 = rc * rc;
        out.par_chunks_mut(width)
            .enumerate()
            .with_min_len(16)
            .try_for_each_init(
                || (Vec::new(), vec![0.0; width]),
                |(order, term): &mut (Vec<Neighbour<D>>, Vec<f64>), (i, sums)| {
                    if !self.active(p, i) {
                        return Ok(());
                    }
                    order.clear();
                    for &j in full.row(i) {
                        let j = j as usize;
                        let r2: f64 = (0..D).map(|d| (p.pos[j][d] - p.pos[i][d]).powi(2)).sum();
                        #[allow(clippy::neg_cmp_op_on_partial_ord)]
                        if !(r2 > rc2) {
                            order.push((p.gid[j], p.pos[j].map(f64::to_bits), j));
                        }
                    }
                    order.sort_unstable();
                    self.terms(&[0.0; D], i, sums);
                    for &(_, _, j) in order.iter() {
                        let r: [f64; D] = std::array::from_fn(|d| p.pos[j][d] - p.pos[i][d]);
                        self.terms(&r, j, term);
                        for (s, t) in sums.iter_mut().zip(term.iter()) {
                            *s += t;
                        }
                    }
                    if sums.iter().all(|x| x.is_finite()) {
                        Ok(())
                    } else {
                        Err(NotFinite { gid: p.gid[i] })
                    }
                },
            )
    }

    #[inline(always)]
    fn terms(&self, r: &[f64; D], j: usize, out: &mut [f64]) {
        let n = unknowns(D);
        let omega = self.mass / self.density[j];
        let psi = rows(&self.kernel, r);
        let mut k = 0;
        if self.matrix {
            let phi = columns(r);
            for p in psi.iter().take(n) {
                let wp = omega * p;
                for f in phi.iter().take(n) {
                    out[k] = wp * f;
                    k += 1;
                }
            }
        }
        for q in 0..self.fields {
            let f = omega * self.values[j * self.fields + q];
            for p in psi.iter().take(n) {
                out[k] = f * p;
                k += 1;
            }
        }
    }
}

/// ψ(R) weighted by ω and f: one neighbour's term of b.
pub fn add_rhs<const D: usize>(
    b: &mut [f64; 10],
    g: &TruncatedGaussian,
    weight: f64,
    r: &[f64; D],
    f: f64,
) {
    let psi = rows(g, r);
    for (x, p) in b.iter_mut().zip(&psi).take(unknowns(D)) {
        *x += weight * p * f;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, StreamKey};

    /// The bulk particle of the paper's square lattice (a = 1, h = 2, ω = 1/0.9995554).
    fn bulk(f: impl Fn(f64, f64) -> f64) -> (MomentSystem<2>, [f64; 10]) {
        let g = TruncatedGaussian::new(2.0, 2);
        let omega = 1.0 / 0.9995554;
        let (mut m, mut b) = (MomentSystem::<2>::default(), [0.0; 10]);
        for i in -5i32..=5 {
            for j in -5i32..=5 {
                let r = [f64::from(i), f64::from(j)];
                if r[0].hypot(r[1]) <= 4.0 {
                    m.add(&g, omega, &r);
                    add_rhs(&mut b, &g, omega, &r, f(r[0], r[1]));
                }
            }
        }
        (m, b)
    }

    /// The reference matrix of docs/theory/msph_dumbbells.md §1.3 (rows W, ∂x, ∂y, ∂xx, ∂xy, ∂yy
    /// against columns 1, Rx, Ry, ½Rx², RxRy, ½Ry²; here ordered 1, x, y, xx, yy, xy), to its 6
    /// decimals.
    #[test]
    fn bulk_matrix_is_the_specs() {
        let (m, _) = bulk(|_, _| 0.0);
        // (row, column, value) in this module's order: 0 = 1, 1 = x, 2 = y, 3 = xx, 4 = yy, 5 = xy.
        let want = [
            (0, 0, 1.0),
            (0, 3, 0.836448),
            (0, 4, 0.836448),
            (1, 1, 0.990543),
            (2, 2, 0.990543),
            (3, 0, -0.044055),
            (3, 3, 0.735177),
            (3, 4, -0.086297),
            (4, 0, -0.044055),
            (4, 3, -0.086297),
            (4, 4, 0.735177),
            (5, 5, 0.817950),
        ];
        for r in 0..6 {
            for c in 0..6 {
                let v = want
                    .iter()
                    .find(|(a, b, _)| (*a, *b) == (r, c))
                    .map_or(0.0, |x| x.2);
                assert!(
                    (m.entry(r, c) - v).abs() < 6e-7,
                    "M[{r}][{c}] = {}",
                    m.entry(r, c)
                );
            }
        }
    }

    /// Quadratics are reproduced exactly on a disordered neighbourhood with uneven weights, in
    /// 2D and 3D; a short sine comes out 7.9 % low
    /// (docs/theory/msph_dumbbells.md §1.3: −0.28583 against −0.31029).
    #[test]
    fn quadratics_are_exact_and_short_waves_are_damped() {
        let key = StreamKey::new(9, Purpose::Test, 1);
        let g2 = TruncatedGaussian::new(2.0, 2);
        let mut m = MomentSystem::<2>::default();
        let mut b = [0.0; 10];
        let f =
            |x: f64, y: f64| 0.3 + 1.5 * x - 0.7 * y + 0.2 * x * x - 0.45 * x * y + 0.05 * y * y;
        for s in 0..60u32 {
            let r = [
                8.0 * key.uniform2(0, s, 0).0 - 4.0,
                8.0 * key.uniform2(0, s, 1).0 - 4.0,
            ];
            let (r, w) = if s == 0 {
                ([0.0, 0.0], 1.0)
            } else {
                (r, 0.5 + key.uniform2(1, s, 0).0)
            };
            m.add(&g2, w, &r);
            add_rhs(&mut b, &g2, w, &r, f(r[0], r[1]));
        }
        let u = m.factor().expect("regular").solve(&b);
        let want = [0.3, 1.5, -0.7, 0.4, 0.1, -0.45];
        for (got, want) in u.iter().zip(want) {
            assert!((got - want).abs() < 1e-9, "{u:?}");
        }
        let g3 = TruncatedGaussian::new(1.0, 3);
        let mut m = MomentSystem::<3>::default();
        let mut b = [0.0; 10];
        let f3 = |r: &[f64; 3]| 1.0 + r[0] - 2.0 * r[2] + 0.5 * r[1] * r[1] + 0.3 * r[0] * r[2];
        for s in 0..200u32 {
            let r: [f64; 3] = std::array::from_fn(|d| 4.0 * key.uniform2(2, s, d as u32).0 - 2.0);
            m.add(&g3, 1.0, &r);
            add_rhs(&mut b, &g3, 1.0, &r, f3(&r));
        }
        let u = m.factor().expect("regular").solve(&b);
        let want = [1.0, 1.0, 0.0, -2.0, 0.0, 1.0, 0.0, 0.0, 0.3, 0.0];
        for (got, want) in u.iter().zip(want) {
            assert!((got - want).abs() < 1e-9, "{u:?}");
        }
        // sin(2πx/20) at a bulk point x₀ where the exact derivative is −0.31029.
        let k = 2.0 * std::f64::consts::PI / 20.0;
        let x0 = (-0.31029 / k).acos() / k;
        let (m, b) = bulk(|x, _| (k * (x + x0)).sin());
        let u = m.factor().expect("regular").solve(&b);
        assert!((u[1] - -0.28583).abs() < 5e-5, "∂x sin = {}", u[1]);
        // A neighbourhood of one point cannot fix the second derivatives.
        let mut lonely = MomentSystem::<2>::default();
        lonely.add(&g2, 1.0, &[0.0, 0.0]);
        assert!(lonely.factor().is_none());
    }

    /// The entries of M (row-major) of a neighbourhood, for [`Local::new`].
    fn entries(points: &[[f64; 2]], g: &TruncatedGaussian) -> (Vec<f64>, Vec<[f64; 10]>) {
        let mut m = MomentSystem::<2>::default();
        let mut psi = Vec::new();
        for r in points {
            m.add(g, 1.0, r);
            psi.push(rows(g, r));
        }
        let n = unknowns(2);
        let e = (0..n * n).map(|k| m.entry(k / n, k % n)).collect();
        (e, psi)
    }

    /// The condition monitor: the bulk lattice is solved to second order (h-scaled 1-norm
    /// condition ~5, far below 10⁴); two rows of neighbours cannot fix ∂yy f, so the system
    /// falls back to the first-order correction, which still differentiates a linear field
    /// exactly; a lone particle determines nothing. Fails if the h-scaling is dropped (the
    /// unscaled bulk matrix of h = 0.01 has a condition number of ~10⁸), or without the
    /// first-order fallback (the strip's system is singular: ½R_y² = (a/2) R_y on its points).
    #[test]
    fn condition_monitor_falls_back_to_first_order() {
        for h in [2.0, 0.01] {
            let g = TruncatedGaussian::new(h, 2);
            let a = h / 2.0;
            let lattice: Vec<[f64; 2]> = (-4i32..=4)
                .flat_map(|i| (-4i32..=4).map(move |j| [a * f64::from(i), a * f64::from(j)]))
                .filter(|r| r[0].hypot(r[1]) <= 2.0 * h)
                .collect();
            let (m, _) = entries(&lattice, &g);
            let local = Local::<2>::new(&m, h);
            assert!(local.is_second_order(), "bulk at h = {h}");
            let strip: Vec<[f64; 2]> = (-4i32..=4)
                .flat_map(|i| (0..2).map(move |j| [a * f64::from(i), a * f64::from(j)]))
                .collect();
            let (m, psi) = entries(&strip, &g);
            let local = Local::<2>::new(&m, h);
            assert!(matches!(local, Local::First { .. }), "two rows at h = {h}");
            // f = 2 + 3x − 5y: b from the same neighbours, f_i = 2 at R = 0.
            let mut b = [0.0; 10];
            for (r, p) in strip.iter().zip(&psi) {
                let f = 2.0 + 3.0 * r[0] - 5.0 * r[1];
                for (x, q) in b.iter_mut().zip(p) {
                    *x += q * f;
                }
            }
            let grad = local.gradient(&b, 2.0);
            assert!(
                (grad[0] - 3.0).abs() < 1e-9 && (grad[1] + 5.0).abs() < 1e-9,
                "{grad:?}"
            );
            let (m, _) = entries(&[[0.0, 0.0]], &g);
            assert!(matches!(Local::<2>::new(&m, h), Local::Undetermined));
        }
    }
}
