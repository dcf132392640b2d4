//! Ensembles of Brownian dumbbells carried by particles (CONNFFESSIT): the particle's velocity
//! gradient deforms its N_d connector vectors Q and their Kramers stress is its polymer stress.
//!
//! Sources: Murashima & Taniguchi (docs/theory/msph_dumbbells.md §1.5, eqs. 17–19) and Ellero ch. 5
//! (docs/theory/polymer_particle_and_bddfs.md §2.1, §4.1); Öttinger, *Stochastic Processes in
//! Polymeric Fluids* (1996) §4.3 for FENE and the semi-implicit scheme.
//!
//! Dimensional form (spring force F_s(Q), friction ζ, κ_αβ = ∂v_α/∂x_β, so dQ_x = κ_xy Q_y dt
//! in the shear flow v_x = κ_xy y — the transpose would be the lower-convected physics):
//!
//! ```text
//! dQ = (κ·Q − (2/ζ) F_s(Q)) dt + √(4 k_BT/ζ) dW,   F_s = H Q (Hookean), H Q / (1 − Q²/Q₀²) (FENE)
//! ```
//!
//! Implemented non-dimensional form (Q in units of √(k_BT/H), λ = ζ/(4H), b = H Q₀²/k_BT):
//!
//! ```text
//! dQ = (κ·Q − F(Q)/(2λ)) dt + √(1/λ) dW,     F(Q) = Q  or  Q / (1 − Q²/b)
//! τ  = G (⟨Q F(Q)⟩ − I),                    G = n k_BT          (Kramers; η_p = G λ for Hookean)
//! ```
//!
//! Schemes, with ξ ~ N(0, I) drawn once per dumbbell and step, A(Q) = κ·Q − F(Q)/(2λ), κ frozen
//! during the step:
//! - Euler–Maruyama: Q' = Q + A(Q) Δt + √(Δt/λ) ξ (weak order 1);
//! - stochastic Heun, the second-order stochastic Runge–Kutta the paper uses (Brańka & Heyes,
//!   PRE 58 (1998) 2611; for additive noise the same ξ in both stages,
//!   docs/theory/msph_dumbbells.md §1.5):
//!   Q̃ = Q + A(Q) Δt + √(Δt/λ) ξ,  Q' = Q + ½ (A(Q) + A(Q̃)) Δt + √(Δt/λ) ξ (weak order 2);
//! - semi-implicit predictor–corrector (Öttinger §4.3.2), for FENE: predictor Q̃ as above,
//!   corrector Q' + (Δt/4λ) F(Q') = Q + [½ κ·(Q + Q̃) − F(Q)/(4λ)] Δt + √(Δt/λ) ξ =: R. F(Q')
//!   is parallel to Q', so Q' = l R/|R| with l the unique root in [0, √b) of
//!   l³ − |R| l² − b (1 + Δt/4λ) l + b |R| = 0: |Q'| < √b at every step, whatever Δt.
//!
//! FENE with the explicit schemes can leave the ball |Q| < √b; they are refused for FENE
//! ([`DumbbellParams::check`]).
//!
//! Random numbers: one [`NormalStream`] per (seed, particle id, step) — a counter-based key
//! (keyed SplitMix64) seeding a fast sequential generator (xoshiro256++ + ziggurat) for the
//! particle's N_d × D normals — so results do not depend on the rank or thread that advances
//! the particle.

use crate::rng::{NormalStream, Purpose};

/// Spring law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Spring {
    /// F(Q) = Q.
    Hookean,
    /// F(Q) = Q / (1 − Q²/b), |Q| < √b.
    Fene {
        /// Maximum extensibility b = H Q₀² / k_BT.
        b: f64,
    },
}

impl Spring {
    /// F(Q)/Q as a function of Q².
    #[inline(always)]
    pub fn factor(self, q2: f64) -> f64 {
        match self {
            Spring::Hookean => 1.0,
            Spring::Fene { b } => 1.0 / (1.0 - q2 / b),
        }
    }

    /// ⟨Q²⟩ at equilibrium in `dim` dimensions: D (Hookean), D b / (b + D + 2) (FENE).
    pub fn equilibrium_q2(self, dim: usize) -> f64 {
        let d = dim as f64;
        match self {
            Spring::Hookean => d,
            Spring::Fene { b } => d * b / (b + d + 2.0),
        }
    }
}

/// Stochastic integration scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    /// Euler–Maruyama (weak order 1).
    EulerMaruyama,
    /// Stochastic Heun / SRK2 of Brańka & Heyes (weak order 2 for additive noise).
    Heun,
    /// Öttinger's semi-implicit predictor–corrector (keeps FENE dumbbells inside √b).
    SemiImplicit,
}

/// Parameters of an ensemble.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DumbbellParams {
    /// Spring law.
    pub spring: Spring,
    /// Scheme.
    pub scheme: Scheme,
    /// Relaxation time λ = ζ / (4H).
    pub lambda: f64,
    /// Time step.
    pub dt: f64,
}

impl DumbbellParams {
    /// Refuses combinations that cannot work, with the reason.
    pub fn check(&self) -> Result<(), String> {
        if !(self.lambda > 0.0 && self.lambda.is_finite()) {
            return Err(format!("relaxation time λ = {}; must be > 0", self.lambda));
        }
        if !(self.dt > 0.0 && self.dt.is_finite()) {
            return Err(format!("time step {}; must be > 0", self.dt));
        }
        if let Spring::Fene { b } = self.spring {
            if !(b > 2.0 && b.is_finite()) {
                return Err(format!(
                    "FENE b = {b}; must be > 2 (b is H Q₀²/k_BT, typically 10–100)"
                ));
            }
            if self.scheme != Scheme::SemiImplicit {
                return Err(format!(
                    "{:?} can stretch a FENE dumbbell beyond √b; use the semi-implicit scheme",
                    self.scheme
                ));
            }
        }
        Ok(())
    }
}

/// A(Q) = κ·Q − F(Q)/(2λ) with `factor(Q²)` = F(Q)/Q and `half_inv_lambda` = 1/(2λ).
#[inline(always)]
fn drift<const D: usize>(
    q: &[f64; D],
    kappa: &[[f64; D]; D],
    factor: impl Fn(f64) -> f64,
    half_inv_lambda: f64,
) -> [f64; D] {
    let q2: f64 = q.iter().map(|x| x * x).sum();
    let f = factor(q2) * half_inv_lambda;
    let mut a = [0.0; D];
    for al in 0..D {
        let mut s = 0.0;
        for be in 0..D {
            s += kappa[al][be] * q[be];
        }
        a[al] = s - f * q[al];
    }
    a
}

/// Root l ∈ [0, √b) of l (1 + ε / (1 − l²/b)) = r (monotone in l): Newton's method safeguarded
/// by bisection.
fn fene_length(r: f64, b: f64, eps: f64) -> f64 {
    let g = |l: f64| l * l * l - r * l * l - b * (1.0 + eps) * l + b * r;
    let dg = |l: f64| 3.0 * l * l - 2.0 * r * l - b * (1.0 + eps);
    // g(0) = b r ≥ 0 > g(√b) = −ε b^{3/2}; g is decreasing on the bracket's root.
    let (mut lo, mut hi) = (0.0, b.sqrt());
    let mut l = (r / (1.0 + eps)).min(0.5 * hi);
    for _ in 0..200 {
        let v = g(l);
        if v == 0.0 {
            break;
        }
        if v > 0.0 {
            lo = l;
        } else {
            hi = l;
        }
        let d = dg(l);
        let newton = l - v / d;
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        let converged = (next - l).abs() <= 4.0 * f64::EPSILON * l.max(1e-300);
        l = next;
        if converged || hi - lo <= 4.0 * f64::EPSILON * hi {
            break;
        }
    }
    l.min(b.sqrt() * (1.0 - f64::EPSILON))
}

/// The first dumbbell of the ensemble `q` that is outside the spring's domain, as
/// (index, |Q|²): a connector that is not finite or has |Q|² ≥ `limit` (b for FENE; for
/// Hookean springs the runaway bound of the flow,
/// [`Flow::hookean_runaway_q2`](crate::models::homogeneous_flow::Flow::hookean_runaway_q2)).
/// The semi-implicit FENE step keeps |Q| < √b in exact arithmetic; this detector catches what
/// rounding (single-precision storage) or an explicit scheme beyond its stability limit does.
pub fn outside_domain<const D: usize, T: Copy + Into<f64>>(
    q: &[T],
    limit: f64,
) -> Option<(usize, f64)> {
    q.chunks_exact(D).enumerate().find_map(|(k, c)| {
        let q2: f64 = c
            .iter()
            .map(|&x| {
                let x: f64 = x.into();
                x * x
            })
            .sum();
        (q2.is_nan() || q2 >= limit).then_some((k, q2))
    })
}

/// Advances the ensemble `q` (N_d × D numbers, connector after connector) by one step under
/// the velocity gradient `kappa`, drawing its noise from `noise` (D normals per dumbbell, in
/// connector order).
///
/// The scheme and spring are dispatched once per call, not per dumbbell, no heap allocation;
/// Hookean Euler–Maruyama uses its matrix form Q' = M Q + √(Δt/λ) ξ with M = I + Δt (κ − I/2λ)
/// and draws inline, the other schemes through a small stack buffer.
pub fn step_ensemble<const D: usize>(
    q: &mut [f64],
    kappa: &[[f64; D]; D],
    p: &DumbbellParams,
    noise: &mut NormalStream,
) {
    let amp = (p.dt / p.lambda).sqrt();
    let dt = p.dt;
    let hl = 0.5 / p.lambda;
    match (p.scheme, p.spring) {
        (Scheme::EulerMaruyama, Spring::Hookean) => {
            let mut m = *kappa;
            for (al, row) in m.iter_mut().enumerate() {
                for v in row.iter_mut() {
                    *v *= dt;
                }
                row[al] += 1.0 - dt * hl;
            }
            for_each_dumbbell::<D>(q, noise, amp, |x, xi| {
                let mut y = *xi;
                for al in 0..D {
                    for be in 0..D {
                        y[al] += m[al][be] * x[be];
                    }
                }
                y
            });
        }
        (Scheme::EulerMaruyama, spring) => {
            for_each_dumbbell_buffered::<D>(q, noise, amp, |x, xi| {
                let a0 = drift(x, kappa, |q2| spring.factor(q2), hl);
                let mut y = [0.0; D];
                for d in 0..D {
                    y[d] = x[d] + a0[d] * dt + xi[d];
                }
                y
            });
        }
        (Scheme::Heun, Spring::Hookean) => heun(q, kappa, dt, hl, amp, noise, |_| 1.0),
        (Scheme::Heun, spring) => heun(q, kappa, dt, hl, amp, noise, |q2| spring.factor(q2)),
        (Scheme::SemiImplicit, Spring::Hookean) => {
            let scale = 1.0 / (1.0 + dt * 0.5 * hl);
            semi_implicit(q, kappa, dt, hl, amp, noise, |_| 1.0, |_| scale);
        }
        (Scheme::SemiImplicit, Spring::Fene { b }) => {
            let eps = dt * 0.5 * hl;
            let spring = p.spring;
            semi_implicit(
                q,
                kappa,
                dt,
                hl,
                amp,
                noise,
                |q2| spring.factor(q2),
                |r: &[f64; D]| {
                    let rn = r.iter().map(|v| v * v).sum::<f64>().sqrt();
                    if rn == 0.0 {
                        0.0
                    } else {
                        fene_length(rn, b, eps) / rn
                    }
                },
            );
        }
    }
}

/// Applies `update(Q, √(Δt/λ) ξ) → Q'` to every connector, drawing its D normals first
/// (inline: the generator keeps its state in registers through the loop, its rare path takes
/// no state). Best for a small `update` (Hookean Euler–Maruyama).
#[inline(always)]
fn for_each_dumbbell<const D: usize>(
    q: &mut [f64],
    noise: &mut NormalStream,
    amp: f64,
    update: impl Fn(&[f64; D], &[f64; D]) -> [f64; D],
) {
    // A local copy whose address never escapes: its four words stay in registers (drawing
    // through `noise` itself stored them back to memory after every normal).
    let mut g = noise.clone();
    for c in q.chunks_exact_mut(D) {
        let mut x = [0.0; D];
        x.copy_from_slice(c);
        let mut xi = [0.0; D];
        for v in xi.iter_mut() {
            *v = amp * g.normal();
        }
        c.copy_from_slice(&update(&x, &xi));
    }
    *noise = g;
}

/// As [`for_each_dumbbell`] — the same numbers in the same order — but the normals of up to
/// 128 three-dimensional dumbbells go into a stack buffer first: for a larger `update` (Heun,
/// semi-implicit) generator and arithmetic then do not compete for registers (measured ~1.2×
/// faster for Heun in 3D than drawing inline).
#[inline(always)]
fn for_each_dumbbell_buffered<const D: usize>(
    q: &mut [f64],
    noise: &mut NormalStream,
    amp: f64,
    update: impl Fn(&[f64; D], &[f64; D]) -> [f64; D],
) {
    let mut buf = [0.0f64; 384];
    let per_chunk = (buf.len() / D) * D;
    for chunk in q.chunks_mut(per_chunk) {
        let normals = &mut buf[..chunk.len()];
        noise.fill_normals(normals);
        for (c, g) in chunk.chunks_exact_mut(D).zip(normals.chunks_exact(D)) {
            let mut x = [0.0; D];
            x.copy_from_slice(c);
            let mut xi = [0.0; D];
            for d in 0..D {
                xi[d] = amp * g[d];
            }
            c.copy_from_slice(&update(&x, &xi));
        }
    }
}

/// Stochastic Heun: Q̃ = Q + A(Q) Δt + ξ', Q' = Q + ½ (A(Q) + A(Q̃)) Δt + ξ' (ξ' = √(Δt/λ) ξ).
#[inline(always)]
fn heun<const D: usize>(
    q: &mut [f64],
    kappa: &[[f64; D]; D],
    dt: f64,
    hl: f64,
    amp: f64,
    noise: &mut NormalStream,
    factor: impl Fn(f64) -> f64 + Copy,
) {
    for_each_dumbbell_buffered::<D>(q, noise, amp, |x, xi| {
        let a0 = drift(x, kappa, factor, hl);
        let mut pred = [0.0; D];
        for d in 0..D {
            pred[d] = x[d] + a0[d] * dt + xi[d];
        }
        let a1 = drift(&pred, kappa, factor, hl);
        let mut y = [0.0; D];
        for d in 0..D {
            y[d] = x[d] + 0.5 * (a0[d] + a1[d]) * dt + xi[d];
        }
        y
    });
}

/// Öttinger's predictor–corrector: Q̃ as Euler, R = Q + [½ κ·(Q + Q̃) − F(Q)/(4λ)] Δt + ξ',
/// Q' = R · `scale(R)` (1/(1 + Δt/4λ) for Hookean, l/|R| from the cubic for FENE).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn semi_implicit<const D: usize>(
    q: &mut [f64],
    kappa: &[[f64; D]; D],
    dt: f64,
    hl: f64,
    amp: f64,
    noise: &mut NormalStream,
    factor: impl Fn(f64) -> f64 + Copy,
    scale: impl Fn(&[f64; D]) -> f64,
) {
    for_each_dumbbell_buffered::<D>(q, noise, amp, |x, xi| {
        let a0 = drift(x, kappa, factor, hl);
        let mut pred = [0.0; D];
        for d in 0..D {
            pred[d] = x[d] + a0[d] * dt + xi[d];
        }
        let q2: f64 = x.iter().map(|v| v * v).sum();
        let fq = factor(q2) * 0.5 * hl;
        let mut r = [0.0; D];
        for al in 0..D {
            let mut s = 0.0;
            for be in 0..D {
                s += kappa[al][be] * (x[be] + pred[be]);
            }
            r[al] = x[al] + (0.5 * s - fq * x[al]) * dt + xi[al];
        }
        let sc = scale(&r);
        let mut y = [0.0; D];
        for d in 0..D {
            y[d] = r[d] * sc;
        }
        y
    });
}

/// ⟨Q F(Q)⟩ − I over the ensemble, flattened D × D (τ / G).
pub fn kramers_stress<const D: usize>(q: &[f64], spring: Spring) -> [f64; 9] {
    let mut s = [0.0; 9];
    let n = q.len() / D;
    for c in q.chunks_exact(D) {
        let q2: f64 = c.iter().map(|v| v * v).sum();
        let f = spring.factor(q2);
        for a in 0..D {
            for b in 0..D {
                s[a * D + b] += c[a] * c[b] * f;
            }
        }
    }
    for a in 0..D {
        for b in 0..D {
            s[a * D + b] /= n.max(1) as f64;
        }
        s[a * D + a] -= 1.0;
    }
    s
}

/// Draws `q` (N_d × D numbers) from the equilibrium distribution: N(0, I) for Hookean; for FENE,
/// ψ ∝ (1 − Q²/b)^{b/2} by rejection from N(0, I) (acceptance (1 − Q²/b)^{b/2} e^{Q²/2} ≤ 1,
/// since ln(1 − x) ≤ −x).
pub fn sample_equilibrium<const D: usize>(q: &mut [f64], spring: Spring, rng: &mut NormalStream) {
    for c in q.chunks_exact_mut(D) {
        loop {
            for v in c.iter_mut() {
                *v = rng.normal();
            }
            let q2: f64 = c.iter().map(|v| v * v).sum();
            match spring {
                Spring::Hookean => break,
                Spring::Fene { b } => {
                    if q2 < b {
                        let accept = (0.5 * b * (1.0 - q2 / b).ln() + 0.5 * q2).exp();
                        if rng.uniform() < accept {
                            break;
                        }
                    }
                }
            }
        }
    }
}

/// The noise stream of particle `gid` at `step`, for the `stage`-th update of its ensemble
/// within that step. The engine advances every ensemble once per step, with stage 0 (the key
/// of every run so far: the stage is the stream's second id word, 0 before it existed); a
/// multi-stage coupling that advances an ensemble again within a step must use stage 1, 2, …,
/// so no two updates reuse the same noise.
#[inline]
pub fn noise_stream(seed: u64, gid: u64, step: u64, stage: u8) -> NormalStream {
    NormalStream::new(seed, Purpose::DumbbellNoise, step, gid, u64::from(stage))
}

/// The stream of particle `gid`'s initial state.
#[inline]
pub fn init_stream(seed: u64, gid: u64) -> NormalStream {
    NormalStream::new(seed, Purpose::DumbbellInit, 0, gid, 0)
}

/// Discrete-time second moment c = ⟨QQ⟩ of a *Hookean* ensemble after `steps` steps of a
/// linear scheme from c₀ = I, propagated exactly: Q' = M Q + N ξ ⇒ c' = M c Mᵀ + (Δt/λ) N Nᵀ,
/// with K = κ − I/(2λ): Euler M = I + ΔtK, N = I; Heun M = I + ΔtK + ½Δt²K², N = I + ½ΔtK;
/// semi-implicit M = [I + ½Δt κ (2I + ΔtK) − Δt/(4λ)I]/(1 + Δt/4λ), N = (I + ½Δt κ)/(1 + Δt/4λ).
/// This is the oracle the statistical tests compare with (it isolates sampling error from
/// time-step error), and the time-step error itself is its distance to the continuous solution.
pub fn hookean_discrete_moment<const D: usize>(
    kappa: &[[f64; D]; D],
    p: &DumbbellParams,
    steps: u64,
) -> [[f64; D]; D] {
    let dt = p.dt;
    let mut k = *kappa;
    for d in 0..D {
        k[d][d] -= 0.5 / p.lambda;
    }
    let id = {
        let mut m = [[0.0; D]; D];
        for d in 0..D {
            m[d][d] = 1.0;
        }
        m
    };
    let mul = |a: &[[f64; D]; D], b: &[[f64; D]; D]| {
        let mut m = [[0.0; D]; D];
        for i in 0..D {
            for j in 0..D {
                for l in 0..D {
                    m[i][j] += a[i][l] * b[l][j];
                }
            }
        }
        m
    };
    let add = |a: &[[f64; D]; D], b: &[[f64; D]; D], s: f64| {
        let mut m = *a;
        for i in 0..D {
            for j in 0..D {
                m[i][j] += s * b[i][j];
            }
        }
        m
    };
    let (m, n) = match p.scheme {
        Scheme::EulerMaruyama => (add(&id, &k, dt), id),
        Scheme::Heun => (
            add(&add(&id, &k, dt), &mul(&k, &k), 0.5 * dt * dt),
            add(&id, &k, 0.5 * dt),
        ),
        Scheme::SemiImplicit => {
            let e = dt / (4.0 * p.lambda);
            let two_plus = add(&add(&id, &id, 1.0), &k, dt); // 2I + ΔtK
            let m = add(&add(&id, &mul(kappa, &two_plus), 0.5 * dt), &id, -e);
            let n = add(&id, kappa, 0.5 * dt);
            let s = 1.0 / (1.0 + e);
            let sc = |a: [[f64; D]; D]| {
                let mut o = a;
                o.iter_mut().flatten().for_each(|x| *x *= s);
                o
            };
            (sc(m), sc(n))
        }
    };
    let transpose = |a: &[[f64; D]; D]| {
        let mut t = [[0.0; D]; D];
        for i in 0..D {
            for j in 0..D {
                t[i][j] = a[j][i];
            }
        }
        t
    };
    let noise = {
        let nn = mul(&n, &transpose(&n));
        let mut o = nn;
        o.iter_mut().flatten().for_each(|x| *x *= dt / p.lambda);
        o
    };
    let mt = transpose(&m);
    let mut c = id;
    for _ in 0..steps {
        c = add(&mul(&mul(&m, &c), &mt), &noise, 1.0);
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stage 0 is the key every checkpoint and digest so far was made with; another stage of
    /// the same particle and step draws other numbers.
    #[test]
    fn stage_zero_keeps_the_key_and_other_stages_draw_other_noise() {
        let mut a = [0.0; 64];
        let mut b = [0.0; 64];
        noise_stream(3, 17, 40, 0).fill_normals(&mut a);
        NormalStream::new(3, Purpose::DumbbellNoise, 40, 17, 0).fill_normals(&mut b);
        assert_eq!(a, b);
        noise_stream(3, 17, 40, 1).fill_normals(&mut b);
        let same = a.iter().zip(&b).filter(|(x, y)| x == y).count();
        assert_eq!(same, 0);
    }

    #[test]
    fn fene_length_solves_the_corrector_inside_the_ball() {
        for &(r, b, eps) in &[
            (0.5, 10.0, 0.01),
            (3.0, 10.0, 0.001),
            (100.0, 50.0, 0.1),
            (1e-9, 10.0, 0.5),
        ] {
            let l = fene_length(r, b, eps);
            assert!(l >= 0.0 && l < b.sqrt(), "{l}");
            let back = l * (1.0 + eps / (1.0 - l * l / b));
            assert!((back - r).abs() < 1e-9 * r.max(1.0), "r {r}: {back}");
        }
    }

    #[test]
    fn semi_implicit_hookean_matches_its_discrete_moment_form() {
        // One step from a fixed Q with zero noise reproduces M Q of the oracle.
        let kappa = [[0.0, 1.3], [0.0, 0.0]];
        let p = DumbbellParams {
            spring: Spring::Hookean,
            scheme: Scheme::SemiImplicit,
            lambda: 1.0,
            dt: 0.1,
        };
        let e = p.dt / 4.0;
        let (q0, q1) = (0.7, -0.4);
        // By hand: Q̃ = Q + ΔtKQ, R = Q + [½κ(Q + Q̃) − Q/4λ]Δt, Q' = R/(1+e).
        let k = [[-0.5, 1.3], [0.0, -0.5]];
        let pred = [
            q0 + p.dt * (k[0][0] * q0 + k[0][1] * q1),
            q1 + p.dt * (k[1][1] * q1),
        ];
        let r0 = q0 + (0.5 * 1.3 * (q1 + pred[1]) - 0.25 * q0) * p.dt;
        let r1 = q1 - 0.25 * q1 * p.dt;
        let want = [r0 / (1.0 + e), r1 / (1.0 + e)];
        // Through the generic path with a stream whose noise we cancel by using dt/λ → amp 0
        // is impossible; instead compare the drift part via two runs with identical noise.
        let mut a = [q0, q1];
        let mut z = [0.0, 0.0];
        let mut s1 = NormalStream::new(1, Purpose::Test, 0, 0, 0);
        let mut s2 = NormalStream::new(1, Purpose::Test, 0, 0, 0);
        step_ensemble::<2>(&mut a, &kappa, &p, &mut s1);
        step_ensemble::<2>(&mut z, &kappa, &p, &mut s2);
        // Linear scheme: Q'(Q) − Q'(0) = M Q.
        let got = [a[0] - z[0], a[1] - z[1]];
        assert!(
            (got[0] - want[0]).abs() < 1e-14 && (got[1] - want[1]).abs() < 1e-14,
            "{got:?} vs {want:?}"
        );
    }
}
