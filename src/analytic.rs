//! Analytic solutions the runs check themselves against: start-up flows in a channel of width
//! L between walls at y = 0 and y = L, fluid at rest at t = 0, kinematic viscosity ν = η/ρ₀
//! (docs/theory/sph_maxwell.md §3 T1–T2; Ellero 2004 Eqs. 2.54 and 2.57, the latter with its
//! printed sign corrected).
//!
//! ```text
//! Couette (upper wall at U from t = 0)
//!   u(y, t) = U [ y/L + Σ_{n≥1} (2/(nπ)) (−1)ⁿ sin(nπy/L) exp(−n²π²νt/L²) ]
//! Poiseuille (body force F per unit mass from t = 0)
//!   u(y, t) = (F/(2ν)) y (L − y) − Σ_{n odd} (4FL²/(ν π³ n³)) sin(nπy/L) exp(−n²π²νt/L²)
//! ```
//!
//! The thesis prints the Poiseuille series with the opposite overall sign (its steady state
//! flows against the force); the sign here gives u → F y(L − y)/(2ν) > 0.

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The mean over y ∈ [y0, y1] of the steady reverse ("double") Poiseuille flow of a periodic box
/// of height `ly` driven by +g for y ≥ L_y/2 and −g below (fluid of mass density `rho`,
/// viscosity `eta`):
///
/// ```text
/// u_x(y) = ρ g s (L_y/2 − |s|) / (2η),   s = y − L_y/2,   u_max = ρ g L_y² / (32 η) at s = ±L_y/4
/// ∫ s (L_y/2 − |s|) ds = L_y s²/4 − s²|s|/3
/// ```
///
/// (Backer, Lowe, Hoefsloot & Iedema, J. Chem. Phys. 122, 154503 (2005); Nguyen 2021 §3.4,
/// docs/theory/dpd_physical_parameters.md §7.)
pub fn double_poiseuille_mean(y0: f64, y1: f64, ly: f64, rho: f64, g: f64, eta: f64) -> f64 {
    let h = |y: f64| {
        let s = y - 0.5 * ly;
        0.25 * ly * s * s - s * s * s.abs() / 3.0
    };
    rho * g / (2.0 * eta) * (h(y1) - h(y0)) / (y1 - y0)
}

/// The mean over y ∈ [y0, y1] of the shear stress of the same flow, fixed by the momentum
/// balance ∂τ_xy/∂y = −ρ g_x(y) alone (no viscosity):
///
/// ```text
/// τ_xy(y) = ρ g (L_y/4 − |s|),   s = y − L_y/2,   τ_max = ρ g L_y/4 at s = 0 and s = ±L_y/2
/// ∫ |s| ds = s|s|/2
/// ```
///
/// (η du_x/dy of [`double_poiseuille_mean`]'s profile.)
pub fn double_poiseuille_stress_mean(y0: f64, y1: f64, ly: f64, rho: f64, g: f64) -> f64 {
    let h = |y: f64| {
        let s = y - 0.5 * ly;
        0.5 * s * s.abs()
    };
    rho * g * (0.25 * ly - (h(y1) - h(y0)) / (y1 - y0))
}

/// A start-up flow with a series solution.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum StartupFlow {
    /// Plane Couette flow started by the upper wall.
    Couette,
    /// Plane Poiseuille flow started by a body force.
    Poiseuille,
    /// Free relaxation of u_x = A sin(πy/L) between walls at rest, σ = 0 at t = 0, in the
    /// linearised Jeffreys (Maxwell + solvent) or Newtonian fluid ([`relaxation`]).
    ViscoelasticRelaxation,
}

/// The series' terms are summed until exp(−n²π²νt/L²) < e^(−50) (and at least this many).
const MIN_TERMS: u32 = 2000;

fn series(y: f64, t: f64, l: f64, nu: f64, odd_only: bool, coeff: impl Fn(f64) -> f64) -> f64 {
    let decay = PI * PI * nu * t / (l * l);
    let mut sum = 0.0;
    let mut n = 1u32;
    loop {
        let nf = f64::from(n);
        let e = -nf * nf * decay;
        if n > MIN_TERMS && e < -50.0 {
            break;
        }
        if !odd_only || n % 2 == 1 {
            sum += coeff(nf) * (nf * PI * y / l).sin() * e.exp();
        }
        n += 1;
        if n > 10_000_000 {
            break;
        }
    }
    sum
}

/// Start-up Couette velocity u(y, t) (module documentation).
pub fn couette(y: f64, t: f64, l: f64, wall_velocity: f64, nu: f64) -> f64 {
    if t <= 0.0 {
        return 0.0;
    }
    let s = series(y, t, l, nu, false, |n| {
        let sign = if (n as u64).is_multiple_of(2) {
            1.0
        } else {
            -1.0
        };
        2.0 / (n * PI) * sign
    });
    wall_velocity * (y / l + s)
}

/// Start-up Poiseuille velocity u(y, t) (module documentation).
pub fn poiseuille(y: f64, t: f64, l: f64, force: f64, nu: f64) -> f64 {
    let steady = force / (2.0 * nu) * y * (l - y);
    if t <= 0.0 {
        return 0.0;
    }
    steady
        - series(y, t, l, nu, true, |n| {
            4.0 * force * l * l / (nu * PI.powi(3) * n * n * n)
        })
}

/// An Oldroyd-B fluid: density ρ, solvent and polymer viscosities, relaxation time λ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OldroydB {
    /// ρ.
    pub density: f64,
    /// η_s.
    pub solvent_viscosity: f64,
    /// η_p.
    pub polymer_viscosity: f64,
    /// λ.
    pub relaxation_time: f64,
}

/// Start-up Poiseuille velocity u(y, t) of an Oldroyd-B fluid (solvent viscosity η_s, polymer
/// viscosity η_p, relaxation time λ; the upper-convected Maxwell fluid when η_s = 0) of
/// density ρ driven by the body force F per unit mass from rest, τ = 0 at t = 0
/// (docs/theory/msph_dumbbells.md §3 T2). In unidirectional flow τ_yy stays 0, so the shear stress
/// obeys a linear equation and each odd sine mode k_n = nπ/L decays independently:
///
/// ```text
/// u(y, t) = F y (L − y)/(2ν₀) − Σ_{n odd} a_n(t) sin(k_n y),   ν₀ = (η_s + η_p)/ρ, ν_s = η_s/ρ
/// λ a″ + (1 + λν_s k²) a′ + ν₀ k² a = 0,  a(0) = A_n = 4FL²/(ν₀ n³π³),  a′(0) = −ν₀ k² A_n
/// a_n = C₊ e^{s₊t} + C₋ e^{s₋t},  s_± = (−b ± √(b² − 4λν₀k²))/(2λ),  b = 1 + λν_s k²
/// C₊ = A_n (−ν₀k² − s₋)/(s₊ − s₋),  C₋ = A_n (s₊ + ν₀k²)/(s₊ − s₋)   (complex roots: real part)
/// ```
///
/// a′(0) follows from u_t(0⁺) = F with τ(0) = 0. The sum runs over 20 000 odd modes (the
/// λ = 1000 wave front needs ~2000). Hookean dumbbells obey it in the N_d → ∞ limit.
pub fn poiseuille_oldroyd_b(y: f64, t: f64, l: f64, force: f64, fluid: &OldroydB) -> f64 {
    if t <= 0.0 {
        return 0.0;
    }
    let nu0 = (fluid.solvent_viscosity + fluid.polymer_viscosity) / fluid.density;
    let steady = force / (2.0 * nu0) * y * (l - y);
    let mut sum = 0.0;
    for m in 0..20_000u32 {
        let n = f64::from(2 * m + 1);
        let k = n * PI / l;
        let a0 = 4.0 * force * l * l / (nu0 * n * n * n * PI.powi(3));
        sum += oldroyd_b_mode(t, k, a0, -nu0 * k * k * a0, fluid) * (k * y).sin();
    }
    steady - sum
}

/// Start-up Couette velocity u(y, t) of an Oldroyd-B fluid (as [`poiseuille_oldroyd_b`]) between
/// a wall at rest at y = 0 and one moving at U at y = L from t = 0, fluid at rest and τ = 0 at
/// t = 0. With u = Uy/L + Σ a_n sin(k_n y), τ_xy = η_p U/L + Σ b_n cos(k_n y), k_n = nπ/L, the
/// initial τ_xy − η_p U/L is uniform, so b_n(0) = 0 for n ≥ 1 and u_t(0⁺) = 0 inside:
///
/// ```text
/// λ a″ + (1 + λν_s k²) a′ + ν₀ k² a = 0,   a(0) = A_n = 2U(−1)ⁿ/(nπ),   a′(0) = −ν_s k² A_n
/// ```
///
/// In unidirectional flow τ_yy stays 0 for the upper-convected model, so this is exact for it;
/// the corotational model adds O(De²) through its normal stresses. As λ → 0 it becomes the
/// Newtonian [`couette`] with ν₀; without a polymer (η_p = 0) it is [`couette`] with ν_s. The sum
/// runs over 20 000 modes (t ≥ 0.01 with ν_s ≥ 10⁻² needs ~10³).
pub fn couette_oldroyd_b(y: f64, t: f64, l: f64, wall_velocity: f64, fluid: &OldroydB) -> f64 {
    if t <= 0.0 {
        return 0.0;
    }
    let nu_s = fluid.solvent_viscosity / fluid.density;
    let mut sum = 0.0;
    for m in 1..=20_000u32 {
        let n = f64::from(m);
        let k = n * PI / l;
        let sign = if m % 2 == 0 { 1.0 } else { -1.0 };
        let a0 = 2.0 * wall_velocity * sign / (n * PI);
        sum += oldroyd_b_mode(t, k, a0, -nu_s * k * k * a0, fluid) * (k * y).sin();
    }
    wall_velocity * y / l + sum
}

/// One sine mode k of unidirectional Oldroyd-B flow: the solution of
/// λ a″ + (1 + λν_s k²) a′ + ν₀ k² a = 0 with a(0) = a0, a′(0) = slope0 (the shear stress's
/// cosine mode eliminated):
///
/// ```text
/// a = C₊ e^{s₊t} + C₋ e^{s₋t},  s_± = (−b ± √(b² − 4λν₀k²))/(2λ),  b = 1 + λν_s k²
/// C₊ = (a′(0) − s₋a(0))/(s₊ − s₋),  C₋ = (s₊a(0) − a′(0))/(s₊ − s₋)   (complex roots: real part)
/// ```
fn oldroyd_b_mode(t: f64, k: f64, a0: f64, slope0: f64, fluid: &OldroydB) -> f64 {
    let nu0 = (fluid.solvent_viscosity + fluid.polymer_viscosity) / fluid.density;
    let nu_s = fluid.solvent_viscosity / fluid.density;
    let lambda = fluid.relaxation_time;
    let (b, c) = (1.0 + lambda * nu_s * k * k, nu0 * k * k);
    let disc = b * b - 4.0 * lambda * c;
    if disc > 0.0 {
        let root = disc.sqrt();
        let (sp, sm) = ((-b + root) / (2.0 * lambda), (-b - root) / (2.0 * lambda));
        let (cp, cm) = (
            (slope0 - sm * a0) / (sp - sm),
            (sp * a0 - slope0) / (sp - sm),
        );
        cp * (sp * t).exp() + cm * (sm * t).exp()
    } else if disc < 0.0 {
        // s_± = μ ± iω: a = e^{μt} (a(0) cos ωt + ((a′(0) − μa(0))/ω) sin ωt).
        let (mu, omega) = (-b / (2.0 * lambda), (-disc).sqrt() / (2.0 * lambda));
        (mu * t).exp() * (a0 * (omega * t).cos() + (slope0 - mu * a0) / omega * (omega * t).sin())
    } else {
        // The double root s = −b/(2λ): a = e^{st} (a(0) + (a′(0) − s a(0)) t).
        let s = -b / (2.0 * lambda);
        (s * t).exp() * (a0 + (slope0 - s * a0) * t)
    }
}

/// The amplitude a(t) of u_x = a(t) sin(ky), k = π/L, relaxing from a(0) = A with zero stress,
/// in the linearised Jeffreys fluid (no advection, no rotation terms: the linear corotational
/// variant, or any Maxwell model at small amplitude) of density ρ, solvent viscosity η_s, and
/// polymer viscosity η_p with relaxation time λ (docs/theory/sph_maxwell.md §3 T3, Ellero 2004
/// Eqs. 3.12–3.15). With τ_xy = b(t) cos(ky):
///
/// ```text
/// ρ ȧ = −η_s k² a − k b,    ḃ = (η_p k/λ) a − b/λ,    a(0) = A, b(0) = 0
/// a(t) = A e^{μt} [cosh(st) + (M₁₁ − μ) sinh(st)/s],  μ = tr M/2, s² = μ² − det M
/// ```
///
/// (cos/sin with ω = √(−s²) when s² < 0). With η_s = 0, ρ = 1, η_p = 1/Re, λ = De this is the
/// corrected initial-value solution (docs/theory/sph_maxwell.md §3 T3)
/// e^{−t/(2De)}[cos ωt + (β/ω) sin ωt]; the thesis's printed form e^{−βt} cos ωt does not satisfy
/// ∂_t u(y, 0) = 0. Without a polymer (η_p = 0) it is the viscous decay A e^{−νk²t}.
pub fn relaxation(
    t: f64,
    amplitude: f64,
    l: f64,
    density: f64,
    solvent_viscosity: f64,
    polymer: Option<(f64, f64)>,
) -> f64 {
    let k = PI / l;
    let m11 = -solvent_viscosity * k * k / density;
    let Some((eta_p, lambda)) = polymer else {
        return amplitude * (m11 * t).exp();
    };
    let (m12, m21, m22) = (-k / density, eta_p * k / lambda, -1.0 / lambda);
    let mu = 0.5 * (m11 + m22);
    let det = m11 * m22 - m12 * m21;
    let s2 = mu * mu - det;
    let c = m11 - mu;
    let shape = if s2 > 0.0 {
        let s = s2.sqrt();
        (s * t).cosh() + c * (s * t).sinh() / s
    } else if s2 < 0.0 {
        let w = (-s2).sqrt();
        (w * t).cos() + c * (w * t).sin() / w
    } else {
        1.0 + c * t
    };
    amplitude * (mu * t).exp() * shape
}

#[cfg(test)]
mod tests {
    use super::*;

    const YS: [f64; 5] = [0.1, 0.25, 0.5, 0.75, 0.9];

    /// docs/theory/sph_maxwell.md §3 T3 table, the initial-value (IVP) columns, to one unit of its
    /// 4th decimal: (a) Re = 1, De = 0.25; (b) Re = 2.5, De = 0.1. The thesis's printed form
    /// (cos ωt alone) fails it by up to 0.33.
    #[test]
    fn relaxation_reproduces_the_spec_table() {
        let table = [
            (0.1, 0.8320, 0.8592),
            (0.2, 0.4574, 0.5998),
            (0.3, 0.0623, 0.3595),
            (0.4, -0.2222, 0.1842),
            (0.5, -0.3429, 0.0753),
            (0.6, -0.3159, 0.0170),
            (0.8, -0.0571, -0.0159),
            (1.0, 0.1136, -0.0108),
        ];
        for (t, a, b) in table {
            let got_a = relaxation(t, 1.0, 1.0, 1.0, 0.0, Some((1.0, 0.25)));
            let got_b = relaxation(t, 1.0, 1.0, 1.0, 0.0, Some((1.0 / 2.5, 0.1)));
            // One unit of the table's last decimal: the table is rounded loosely ((b) at
            // t = 0.5 prints 0.0753 for 0.075249, which direct evaluation of the formula of
            // docs/theory/sph_maxwell.md §3 T3 confirms).
            assert!((got_a - a).abs() <= 1e-4, "(a) t {t}: {got_a} vs {a}");
            assert!((got_b - b).abs() <= 1e-4, "(b) t {t}: {got_b} vs {b}");
        }
        // Newtonian: e^{−π²νt}; overdamped Maxwell (4π²De < Re): the cosh branch, checked
        // against a fine explicit integration of the 2×2 system.
        let nu = 0.3;
        let want = (-PI * PI * nu * 0.7).exp();
        assert!((relaxation(0.7, 1.0, 1.0, 1.0, nu, None) - want).abs() < 1e-15);
        let (eta_s, eta_p, lambda) = (0.05, 2.0, 0.01);
        let (mut a, mut b, k) = (1.0f64, 0.0f64, PI);
        let steps = 1_000_000;
        let dt = 0.5 / steps as f64;
        for _ in 0..steps {
            let f = |a: f64, b: f64| {
                (
                    -eta_s * k * k * a - k * b,
                    eta_p * k / lambda * a - b / lambda,
                )
            };
            let (k1a, k1b) = f(a, b);
            let (k2a, k2b) = f(a + 0.5 * dt * k1a, b + 0.5 * dt * k1b);
            a += dt * k2a;
            b += dt * k2b;
        }
        let got = relaxation(0.5, 1.0, 1.0, 1.0, eta_s, Some((eta_p, lambda)));
        assert!((got - a).abs() < 1e-7, "overdamped {got} vs {a}");
    }

    /// docs/theory/msph_dumbbells.md §3 T1 and T2 (H = 24, F = 10⁻³, ρ = 1, η₀ = 1), to their
    /// printed 5 decimals: the Newtonian table (λ → 0), the UCM tables λ = 10 and 1000 (η_s = 0)
    /// and the Oldroyd-B table η_s = 0.1 (η_p = 0.9).
    #[test]
    fn oldroyd_b_poiseuille_reproduces_the_spec_tables() {
        let ys = [0.5, 1.5, 3.5, 6.5, 9.5, 12.0];
        let ucm: [(f64, f64, [f64; 6]); 6] = [
            (
                10.0,
                50.0,
                [0.00407, 0.01150, 0.02373, 0.03652, 0.04370, 0.04545],
            ),
            (
                10.0,
                100.0,
                [0.00528, 0.01511, 0.03189, 0.05011, 0.06039, 0.06305],
            ),
            (
                10.0,
                150.0,
                [0.00568, 0.01629, 0.03455, 0.05462, 0.06604, 0.06900],
            ),
            (
                1000.0,
                50.0,
                [0.01608, 0.04749, 0.05000, 0.05000, 0.05000, 0.05000],
            ),
            (
                1000.0,
                100.0,
                [0.01647, 0.04866, 0.10000, 0.10000, 0.10000, 0.10000],
            ),
            (
                1000.0,
                150.0,
                [0.01685, 0.04981, 0.11279, 0.15000, 0.15000, 0.15000],
            ),
        ];
        for (lambda, t, row) in ucm {
            for (y, want) in ys.iter().zip(row) {
                let got = poiseuille_oldroyd_b(
                    *y,
                    t,
                    24.0,
                    1e-3,
                    &OldroydB {
                        density: 1.0,
                        solvent_viscosity: 0.0,
                        polymer_viscosity: 1.0,
                        relaxation_time: lambda,
                    },
                );
                assert!(
                    (got - want).abs() <= 6e-6,
                    "λ {lambda} t {t} y {y}: {got} vs {want}"
                );
            }
        }
        let newtonian = [
            (50.0, [0.00381, 0.01072, 0.02192, 0.03316, 0.03900, 0.04045]),
            (
                150.0,
                [0.00550, 0.01577, 0.03336, 0.05260, 0.06349, 0.06631],
            ),
        ];
        for (t, row) in newtonian {
            for (y, want) in ys.iter().zip(row) {
                let series = poiseuille(*y, t, 24.0, 1e-3, 1.0);
                // λ → 0 with η_s + η_p = 1 is the Newtonian fluid.
                let limit = poiseuille_oldroyd_b(
                    *y,
                    t,
                    24.0,
                    1e-3,
                    &OldroydB {
                        density: 1.0,
                        solvent_viscosity: 0.5,
                        polymer_viscosity: 0.5,
                        relaxation_time: 1e-9,
                    },
                );
                assert!(
                    (series - want).abs() <= 6e-6,
                    "t {t} y {y}: {series} vs {want}"
                );
                // The Newtonian series stops after ~2000 terms, whose tail Σ 4FL²/(νπ³n³)
                // is ~10⁻⁸; this one sums 20 000 odd modes.
                assert!(
                    (limit - series).abs() <= 5e-8,
                    "t {t} y {y}: {limit} vs {series}"
                );
            }
        }
        let beta = [
            (10.0, 50.0, [0.00405, 0.02360, 0.03621, 0.04489]),
            (10.0, 150.0, [0.00566, 0.03444, 0.05443, 0.06875]),
            (1000.0, 100.0, [0.01327, 0.06935, 0.09232, 0.09954]),
            (1000.0, 150.0, [0.01494, 0.08636, 0.12611, 0.14590]),
        ];
        for (lambda, t, row) in beta {
            for (y, want) in [0.5, 3.5, 6.5, 12.0].iter().zip(row) {
                let got = poiseuille_oldroyd_b(
                    *y,
                    t,
                    24.0,
                    1e-3,
                    &OldroydB {
                        density: 1.0,
                        solvent_viscosity: 0.1,
                        polymer_viscosity: 0.9,
                        relaxation_time: lambda,
                    },
                );
                assert!(
                    (got - want).abs() <= 6e-6,
                    "β λ {lambda} t {t} y {y}: {got} vs {want}"
                );
            }
        }
    }

    /// docs/theory/sph_maxwell.md §3 T1: Re = 1 (ν = 1), U = L = 1, to the table's 4 decimals.
    #[test]
    fn couette_reproduces_the_spec_table() {
        let table = [
            (0.01, [0.0000, 0.0000, 0.0004, 0.0771, 0.4795]),
            (0.05, [0.0039, 0.0176, 0.1138, 0.4292, 0.7518]),
            (0.1, [0.0303, 0.0883, 0.2628, 0.5761, 0.8230]),
            (0.2, [0.0727, 0.1876, 0.4116, 0.6873, 0.8726]),
            (0.3, [0.0898, 0.2267, 0.4670, 0.7267, 0.8898]),
        ];
        for (t, row) in table {
            for (y, want) in YS.iter().zip(row) {
                let got = couette(*y, t, 1.0, 1.0, 1.0);
                assert!((got - want).abs() <= 5e-5, "t {t} y {y}: {got} vs {want}");
            }
        }
    }

    /// The Oldroyd-B start-up Couette series against an independent solver: the 1D system
    /// ρu_t = η_s u_yy + ∂_yτ, λτ_t = η_p u_y − τ (u(0) = 0, u(L) = U from t = 0; u = τ = 0 at
    /// t = 0) on a staggered grid of 400 cells, Heun in time (Δt = 10⁻⁵), for an elastic fluid
    /// (η_s = 0.1, η_p = 0.9, λ = 0.05: waves of speed 4.2 cross the gap): they agree to
    /// 5·10⁻⁶ of U (the grid's O(Δy²)); the bound is 10⁻⁴. Then its limits: without a polymer
    /// it is the Newtonian series with ν_s, and as λ → 0 the Newtonian series with ν₀ (the SPH
    /// Newtonian-limit test relies on both). Mutation: a′(0) = 0 instead of −ν_s k²a(0) fails
    /// the solver by 2.8 % of U.
    #[test]
    fn oldroyd_b_couette_matches_a_finite_difference_solution_and_its_limits() {
        let fluid = OldroydB {
            density: 1.0,
            solvent_viscosity: 0.1,
            polymer_viscosity: 0.9,
            relaxation_time: 0.05,
        };
        let (cells, dt) = (400usize, 1e-5);
        let dy = 1.0 / cells as f64;
        // u at the nodes 0..=cells, τ at the cell centres.
        let rates = |u: &[f64], tau: &[f64]| {
            let mut du = vec![0.0; cells + 1];
            for i in 1..cells {
                du[i] = (fluid.solvent_viscosity * (u[i + 1] - 2.0 * u[i] + u[i - 1]) / (dy * dy)
                    + (tau[i] - tau[i - 1]) / dy)
                    / fluid.density;
            }
            let dtau: Vec<f64> = (0..cells)
                .map(|i| {
                    (fluid.polymer_viscosity * (u[i + 1] - u[i]) / dy - tau[i])
                        / fluid.relaxation_time
                })
                .collect();
            (du, dtau)
        };
        let (mut u, mut tau) = (vec![0.0; cells + 1], vec![0.0; cells]);
        u[cells] = 1.0;
        let mut step = 0u32;
        for t_check in [0.1, 0.3] {
            while f64::from(step) * dt < t_check - 0.5 * dt {
                let (du1, dt1) = rates(&u, &tau);
                let u1: Vec<f64> = u.iter().zip(&du1).map(|(a, b)| a + dt * b).collect();
                let t1: Vec<f64> = tau.iter().zip(&dt1).map(|(a, b)| a + dt * b).collect();
                let (du2, dt2) = rates(&u1, &t1);
                for i in 0..=cells {
                    u[i] += 0.5 * dt * (du1[i] + du2[i]);
                }
                for i in 0..cells {
                    tau[i] += 0.5 * dt * (dt1[i] + dt2[i]);
                }
                step += 1;
            }
            for i in [50, 100, 200, 300, 350] {
                let y = i as f64 * dy;
                let series = couette_oldroyd_b(y, t_check, 1.0, 1.0, &fluid);
                assert!(
                    (series - u[i]).abs() < 1e-4,
                    "t {t_check} y {y}: series {series}, finite differences {}",
                    u[i]
                );
            }
        }
        let solvent_only = OldroydB {
            polymer_viscosity: 0.0,
            ..fluid
        };
        let fast = OldroydB {
            relaxation_time: 1e-6,
            ..fluid
        };
        for t in [0.05, 0.1, 0.3] {
            for y in YS {
                let newtonian_s = couette(y, t, 1.0, 1.0, 0.1);
                let got = couette_oldroyd_b(y, t, 1.0, 1.0, &solvent_only);
                assert!((got - newtonian_s).abs() < 1e-9, "η_p = 0, t {t} y {y}");
                let newtonian_0 = couette(y, t, 1.0, 1.0, 1.0);
                let got = couette_oldroyd_b(y, t, 1.0, 1.0, &fast);
                assert!(
                    (got - newtonian_0).abs() < 1e-4,
                    "λ → 0, t {t} y {y}: {got} vs {newtonian_0}"
                );
            }
        }
    }

    /// docs/theory/sph_maxwell.md §3 T2: Re = 8 (ν = 1/8, F = 1), to the table's 4 decimals, and
    /// the steady state.
    #[test]
    fn poiseuille_reproduces_the_corrected_spec_table() {
        let table = [
            (0.05, [0.0405, 0.0497, 0.0500, 0.0497, 0.0405]),
            (0.1, [0.0675, 0.0963, 0.1000, 0.0963, 0.0675]),
            (0.2, [0.1074, 0.1769, 0.1977, 0.1769, 0.1074]),
            (0.3, [0.1386, 0.2450, 0.2886, 0.2450, 0.1386]),
            (0.4, [0.1649, 0.3042, 0.3704, 0.3042, 0.1649]),
            (1e3, [0.36, 0.75, 1.00, 0.75, 0.36]),
        ];
        for (t, row) in table {
            for (y, want) in YS.iter().zip(row) {
                let got = poiseuille(*y, t, 1.0, 1.0, 0.125);
                assert!((got - want).abs() <= 5e-5, "t {t} y {y}: {got} vs {want}");
            }
        }
    }
}
