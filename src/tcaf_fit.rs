//! Wavenumber-dependent viscosity from the transverse-current autocorrelation function (TCAF).
//!
//! For a fluid of mass density ρ, the transverse current at wavenumber k decays, once
//! normalised, as C(t) = C⊥(k,t)/C⊥(k,0). Two models are fitted to it (Hess et al. 2002;
//! Nguyen 2021):
//!
//! ```text
//! Newtonian:  C(t) = exp(−η_k k² t/ρ)
//! Maxwell:    C(t) = e^{−x} [cosh(Ω x) + sinh(Ω x)/Ω],   x = t/(2τ_k),
//!             Ω = √(1 − 4 τ_k η_k k²/ρ)
//! ```
//!
//! the Maxwell one being the response of a fluid with the memory kernel G(t) = (η/τ) e^{−t/τ};
//! it solves C'' + C'/τ + (η k²/(ρ τ)) C = 0 with C(0) = 1, C'(0) = 0, and tends to the
//! Newtonian one as τ → 0. Both satisfy the model-free relation
//!
//! ```text
//! ∫₀^∞ C(t) dt = ρ/(η_k k²)
//! ```
//!
//! (the Laplace transform at s = 0), which [`integral_viscosity`] uses directly. The η_k of
//! several wavenumbers are extrapolated to the macroscopic viscosity with
//! [`extrapolate_to_zero_wavenumber`] (η_k = η₀ + a k²).
//!
//! The fits use the leading stretch of the (t, C) points whose values stay above a cutoff (the
//! tail, dominated by noise, carries no information on η_k) and least squares in C itself.

/// Result of fitting a model to a normalised TCAF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcafFit {
    /// The wavenumber-dependent viscosity η_k.
    pub viscosity: f64,
    /// The Maxwell relaxation time τ_k (0 for the Newtonian fit).
    pub relaxation_time: f64,
    /// Number of (t, C) points in the fit (the leading stretch above the cutoff).
    pub points_used: usize,
    /// Root-mean-square residual of the fit, √(Σ (C_model − C)²/n).
    pub residual_rms: f64,
}

/// Newtonian TCAF at time `t` (even in t):
///
/// ```text
/// C(t) = exp(−η k² |t|/ρ)
/// ```
pub fn newtonian_tcaf(t: f64, eta: f64, k: f64, rho: f64) -> f64 {
    (-eta * k * k * t.abs() / rho).exp()
}

/// Maxwell (linear viscoelastic) TCAF at time `t` (even in t):
///
/// ```text
/// C(t) = e^{−x} [cosh(Ω x) + sinh(Ω x)/Ω],   x = |t|/(2τ),   Ω = √(1 − 4 τ η k²/ρ)
/// ```
///
/// For 4τηk²/ρ > 1, Ω = i|Ω| and the bracket is cos(|Ω| x) + sin(|Ω| x)/|Ω|; at Ω = 0 it is
/// 1 + x. The sinh/sin terms are evaluated as x·sinh(z)/z with a series for small z, so Ω → 0
/// is continuous and never divides by zero; for large Ω x the two exponentials are kept apart
/// (e^{−(1∓Ω)x}, with 1 − Ω = a/(1 + Ω)) so nothing overflows and τ → 0 reaches the Newtonian
/// limit accurately. `tau == 0` gives the Newtonian TCAF; a negative or NaN `tau` gives NaN.
pub fn maxwell_tcaf(t: f64, eta: f64, tau: f64, k: f64, rho: f64) -> f64 {
    if tau == 0.0 {
        return newtonian_tcaf(t, eta, k, rho);
    }
    if tau.is_nan() || tau < 0.0 {
        return f64::NAN;
    }
    let x = t.abs() / (2.0 * tau);
    let a = 4.0 * tau * eta * k * k / rho;
    let d = 1.0 - a;
    if d >= 0.0 {
        let omega = d.sqrt();
        let z = omega * x;
        if z < 1.0 {
            (-x).exp() * (z.cosh() + x * sinhc(z))
        } else {
            // e^{−x} cosh(Ωx) + e^{−x} sinh(Ωx)/Ω with the exponentials combined.
            let one_minus_omega = a / (1.0 + omega);
            let slow = (-one_minus_omega * x).exp();
            let fast = (-(1.0 + omega) * x).exp();
            0.5 * ((1.0 + 1.0 / omega) * slow - (one_minus_omega / omega) * fast)
        }
    } else {
        let w = (-d).sqrt();
        let z = w * x;
        (-x).exp() * (z.cos() + x * sinc(z))
    }
}

/// sinh(z)/z, with its series for small |z|.
fn sinhc(z: f64) -> f64 {
    if z.abs() < 1e-4 {
        1.0 + z * z / 6.0
    } else {
        z.sinh() / z
    }
}

/// sin(z)/z, with its series for small |z|.
fn sinc(z: f64) -> f64 {
    if z.abs() < 1e-4 {
        1.0 - z * z / 6.0
    } else {
        z.sin() / z
    }
}

/// The leading stretch of `points` with finite t and C > `cutoff`, split into times and values:
/// it stops at the first point with C ≤ cutoff (or a non-finite t or C).
fn leading_points(points: &[(f64, f64)], cutoff: f64) -> (Vec<f64>, Vec<f64>) {
    points
        .iter()
        .take_while(|&&(t, c)| t.is_finite() && c.is_finite() && c > cutoff)
        .copied()
        .unzip()
}

/// Σ (exp(−b t_i) − y_i)².
fn exponential_cost(ts: &[f64], ys: &[f64], b: f64) -> f64 {
    ts.iter()
        .zip(ys)
        .map(|(&t, &y)| {
            let r = (-b * t).exp() - y;
            r * r
        })
        .sum()
}

/// Least-squares fit of C(t) = exp(−η k² t/ρ) to the normalised TCAF `points` (t, C(t)/C(0)),
/// sorted by t:
///
/// ```text
/// minimise S(η) = Σᵢ (exp(−η k² tᵢ/ρ) − Cᵢ)²   over the leading points with Cᵢ > cutoff
/// ```
///
/// The decay rate b = η k²/ρ starts from the log-linear fit through the origin,
/// b₀ = −Σ tᵢ ln Cᵢ / Σ tᵢ², and is refined by Gauss–Newton steps in ln b (so it stays positive)
/// with step halving whenever S does not decrease. The relaxation time of the result is 0.
/// Returns `None` with fewer than 3 usable points, all of them at t = 0, or a non-finite or
/// non-positive η.
pub fn fit_newtonian(points: &[(f64, f64)], k: f64, rho: f64, cutoff: f64) -> Option<TcafFit> {
    let (ts, ys) = leading_points(points, cutoff);
    let n = ts.len();
    if n < 3 {
        return None;
    }
    let (num, den) = ts
        .iter()
        .zip(&ys)
        .filter(|&(_, &y)| y > 0.0)
        .fold((0.0, 0.0), |(num, den), (&t, &y)| {
            (num - t * y.ln(), den + t * t)
        });
    let sum_t2: f64 = ts.iter().map(|t| t * t).sum();
    if sum_t2 <= 0.0 {
        return None;
    }
    let t_last = ts[n - 1];
    let mut b = if den > 0.0 && num / den > 0.0 && (num / den).is_finite() {
        num / den
    } else if t_last > 0.0 {
        1.0 / t_last
    } else {
        return None;
    };
    let mut cost = exponential_cost(&ts, &ys, b);
    for _ in 0..200 {
        // Gauss–Newton in u = ln b: ∂r/∂u = −b t e^{−bt}.
        let (jr, jj) = ts.iter().zip(&ys).fold((0.0, 0.0), |(jr, jj), (&t, &y)| {
            let e = (-b * t).exp();
            let j = -b * t * e;
            (jr + j * (e - y), jj + j * j)
        });
        if jj <= 0.0 || !jj.is_finite() {
            break;
        }
        let delta = -jr / jj;
        if !delta.is_finite() {
            return None;
        }
        let mut step = delta;
        let mut accepted = false;
        while step.abs() > 1e-16 {
            let trial = b * step.exp();
            let trial_cost = exponential_cost(&ts, &ys, trial);
            if trial_cost < cost {
                b = trial;
                cost = trial_cost;
                accepted = true;
                break;
            }
            step *= 0.5;
        }
        if !accepted || delta.abs() < 1e-13 {
            break;
        }
    }
    let viscosity = b * rho / (k * k);
    if !(viscosity.is_finite() && viscosity > 0.0) {
        return None;
    }
    Some(TcafFit {
        viscosity,
        relaxation_time: 0.0,
        points_used: n,
        residual_rms: (cost / n as f64).sqrt(),
    })
}

/// Σ (C_Maxwell(tᵢ; e^{p₀}, e^{p₁}) − yᵢ)².
fn maxwell_cost(ts: &[f64], ys: &[f64], p: [f64; 2], k: f64, rho: f64) -> f64 {
    let (eta, tau) = (p[0].exp(), p[1].exp());
    ts.iter()
        .zip(ys)
        .map(|(&t, &y)| {
            let r = maxwell_tcaf(t, eta, tau, k, rho) - y;
            r * r
        })
        .sum()
}

/// Bounds on ln η and ln τ in the Levenberg–Marquardt iterations (keeps e^p finite).
const LOG_BOUND: f64 = 700.0;

/// Levenberg–Marquardt for the Maxwell model in p = (ln η, ln τ) from `p` with a
/// central-difference Jacobian; returns the final parameters and cost.
fn maxwell_levenberg_marquardt(
    ts: &[f64],
    ys: &[f64],
    mut p: [f64; 2],
    k: f64,
    rho: f64,
) -> Option<([f64; 2], f64)> {
    const H: f64 = 1e-6;
    let model = |t: f64, q: [f64; 2]| maxwell_tcaf(t, q[0].exp(), q[1].exp(), k, rho);
    let mut cost = maxwell_cost(ts, ys, p, k, rho);
    if !cost.is_finite() {
        return None;
    }
    let mut lambda = 1e-3;
    for _ in 0..200 {
        if cost == 0.0 {
            break;
        }
        // Normal equations A = JᵀJ, g = Jᵀr.
        let mut a = [[0.0; 2]; 2];
        let mut g = [0.0; 2];
        for (&t, &y) in ts.iter().zip(ys) {
            let r = model(t, p) - y;
            let mut j = [0.0; 2];
            for (m, jm) in j.iter_mut().enumerate() {
                let mut plus = p;
                let mut minus = p;
                plus[m] += H;
                minus[m] -= H;
                *jm = (model(t, plus) - model(t, minus)) / (2.0 * H);
            }
            for m in 0..2 {
                g[m] += j[m] * r;
                for l in 0..2 {
                    a[m][l] += j[m] * j[l];
                }
            }
        }
        if !(a[0][0].is_finite() && a[1][1].is_finite() && a[0][1].is_finite()) {
            return None;
        }
        let mut converged = false;
        let mut accepted = false;
        while lambda < 1e20 {
            let d0 = a[0][0] * (1.0 + lambda) + lambda * 1e-30;
            let d1 = a[1][1] * (1.0 + lambda) + lambda * 1e-30;
            let det = d0 * d1 - a[0][1] * a[1][0];
            if !(det.is_finite() && det > 0.0) {
                lambda *= 10.0;
                continue;
            }
            let delta = [
                (-g[0] * d1 + g[1] * a[0][1]) / det,
                (-g[1] * d0 + g[0] * a[1][0]) / det,
            ];
            let trial = [
                (p[0] + delta[0]).clamp(-LOG_BOUND, LOG_BOUND),
                (p[1] + delta[1]).clamp(-LOG_BOUND, LOG_BOUND),
            ];
            let trial_cost = maxwell_cost(ts, ys, trial, k, rho);
            let small = delta[0].abs().max(delta[1].abs()) < 1e-12;
            if trial_cost.is_finite() && trial_cost < cost {
                p = trial;
                cost = trial_cost;
                lambda = (lambda / 10.0).max(1e-15);
                accepted = true;
                converged = small;
                break;
            }
            if small {
                // The step is below the tolerance and gains nothing: at the minimum.
                converged = true;
                break;
            }
            lambda *= 10.0;
        }
        if converged || !accepted {
            break;
        }
    }
    Some((p, cost))
}

/// Least-squares fit of the Maxwell TCAF to the normalised TCAF `points` (t, C(t)/C(0)),
/// sorted by t:
///
/// ```text
/// minimise S(η, τ) = Σᵢ (C_Maxwell(tᵢ; η, τ) − Cᵢ)²   over the leading points with Cᵢ > cutoff,
/// C_Maxwell(t) = e^{−t/(2τ)} [cosh(Ω t/(2τ)) + sinh(Ω t/(2τ))/Ω],   Ω = √(1 − 4τηk²/ρ)
/// ```
///
/// Levenberg–Marquardt in (ln η, ln τ), so both stay positive, with a central-difference
/// Jacobian, started from the Newtonian fit η_N with τ₀ ∈ {0.01, 0.1, 1} × ρ/(η_N k²); the start
/// with the smallest final S is kept. Each run stops when the relative parameter change falls
/// below 1e-12, when no step decreases S, or after 200 iterations. Returns `None` with fewer
/// than 4 usable points, when the Newtonian start fails, or for a non-finite result.
pub fn fit_maxwell(points: &[(f64, f64)], k: f64, rho: f64, cutoff: f64) -> Option<TcafFit> {
    let (ts, ys) = leading_points(points, cutoff);
    let n = ts.len();
    if n < 4 {
        return None;
    }
    let start = fit_newtonian(points, k, rho, cutoff)?;
    let eta0 = start.viscosity;
    let time_scale = rho / (eta0 * k * k);
    let (p, cost) = [0.01, 0.1, 1.0]
        .into_iter()
        .filter_map(|factor| {
            let p0 = [eta0.ln(), (factor * time_scale).ln()];
            if p0[0].is_finite() && p0[1].is_finite() {
                maxwell_levenberg_marquardt(&ts, &ys, p0, k, rho)
            } else {
                None
            }
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let (viscosity, relaxation_time) = (p[0].exp(), p[1].exp());
    let residual_rms = (cost / n as f64).sqrt();
    if !(viscosity.is_finite()
        && viscosity > 0.0
        && relaxation_time.is_finite()
        && relaxation_time > 0.0
        && residual_rms.is_finite())
    {
        return None;
    }
    Some(TcafFit {
        viscosity,
        relaxation_time,
        points_used: n,
        residual_rms,
    })
}

/// Extrapolation of η_k to k → 0 by the least-squares fit
///
/// ```text
/// η_k = η₀ + a k²,   minimising Σᵢ wᵢ (η_kᵢ − η₀ − a kᵢ²)²
/// ```
///
/// with wᵢ = 1/σᵢ² when `sigma` has one entry per point, all positive and finite, and wᵢ = 1
/// otherwise. Returns (η₀, a, standard error of η₀). Weighted, the σᵢ are the points' standard
/// errors and the error is √((N⁻¹)₀₀) of the normal matrix N = Σ wᵢ (1, kᵢ²)ᵀ(1, kᵢ²);
/// unweighted, it is √(s² (N⁻¹)₀₀) with s² = Σ rᵢ²/(n − 2), NaN for exactly 2 points. Returns
/// `None` for fewer than 2 points, lengths of `k` and `eta` that differ, non-finite input, or
/// a degenerate design (all k² equal).
pub fn extrapolate_to_zero_wavenumber(
    k: &[f64],
    eta: &[f64],
    sigma: &[f64],
) -> Option<(f64, f64, f64)> {
    let n = k.len();
    if n < 2 || eta.len() != n {
        return None;
    }
    if k.iter().chain(eta).any(|v| !v.is_finite()) {
        return None;
    }
    let weighted = sigma.len() == n && sigma.iter().all(|s| s.is_finite() && *s > 0.0);
    let weight = |i: usize| {
        if weighted {
            1.0 / (sigma[i] * sigma[i])
        } else {
            1.0
        }
    };
    let x: Vec<f64> = k.iter().map(|k| k * k).collect();
    if x.iter().all(|&xi| xi == x[0]) {
        return None;
    }
    // Centred sums: x̄ = Σwx/Σw, Sxx = Σw(x − x̄)², Sxy = Σw(x − x̄)(η − η̄).
    let sw: f64 = (0..n).map(weight).sum();
    let x_mean = (0..n).map(|i| weight(i) * x[i]).sum::<f64>() / sw;
    let y_mean = (0..n).map(|i| weight(i) * eta[i]).sum::<f64>() / sw;
    let sxx: f64 = (0..n).map(|i| weight(i) * (x[i] - x_mean).powi(2)).sum();
    let scale: f64 = (0..n).map(|i| weight(i) * x[i] * x[i]).sum();
    if !(sxx.is_finite() && sxx > 1e-20 * scale) {
        return None;
    }
    let sxy: f64 = (0..n)
        .map(|i| weight(i) * (x[i] - x_mean) * (eta[i] - y_mean))
        .sum();
    let slope = sxy / sxx;
    let eta0 = y_mean - slope * x_mean;
    // (N⁻¹)₀₀ = 1/Σw + x̄²/Sxx.
    let n_inv_00 = 1.0 / sw + x_mean * x_mean / sxx;
    let error = if weighted {
        n_inv_00.sqrt()
    } else if n > 2 {
        let rss: f64 = (0..n).map(|i| (eta[i] - eta0 - slope * x[i]).powi(2)).sum();
        (rss / (n - 2) as f64 * n_inv_00).sqrt()
    } else {
        f64::NAN
    };
    if !(eta0.is_finite() && slope.is_finite()) {
        return None;
    }
    Some((eta0, slope, error))
}

/// Model-free viscosity from the integral of the normalised TCAF `points` (t, C(t)/C(0)):
///
/// ```text
/// η_k = ρ / (k² ∫ C(t) dt)
/// ```
///
/// with the trapezoid rule over all the points (any spacing). NaN when k² ∫ C dt is not
/// positive and finite (including fewer than 2 points).
pub fn integral_viscosity(points: &[(f64, f64)], k: f64, rho: f64) -> f64 {
    let integral: f64 = points
        .windows(2)
        .map(|w| 0.5 * (w[1].0 - w[0].0) * (w[1].1 + w[0].1))
        .sum();
    let denominator = k * k * integral;
    if denominator.is_finite() && denominator > 0.0 {
        rho / denominator
    } else {
        f64::NAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const RHO: f64 = 4.0;
    const ETAS: [f64; 4] = [28.9, 28.3, 26.8, 25.0];
    const TAU: f64 = 0.05;

    fn wavenumber(j: usize) -> f64 {
        2.0 * PI * j as f64 / 15.0
    }

    fn relative(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    /// Integrates C'' + C'/τ + (η k²/(ρ τ)) C = 0, C(0) = 1, C'(0) = 0 with RK4 to `t_end`.
    fn maxwell_ode(t_end: f64, eta: f64, tau: f64, k: f64, rho: f64) -> f64 {
        let steps = (t_end / 2e-5).ceil() as usize;
        let h = t_end / steps as f64;
        let omega2 = eta * k * k / (rho * tau);
        let f = |c: f64, v: f64| (v, -v / tau - omega2 * c);
        let (mut c, mut v) = (1.0, 0.0);
        for _ in 0..steps {
            let k1 = f(c, v);
            let k2 = f(c + 0.5 * h * k1.0, v + 0.5 * h * k1.1);
            let k3 = f(c + 0.5 * h * k2.0, v + 0.5 * h * k2.1);
            let k4 = f(c + h * k3.0, v + h * k3.1);
            c += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
            v += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
        }
        c
    }

    /// Multiple-tau lags: 0, Δ, …, 15Δ, then 8 lags per level with the spacing doubling.
    fn multiple_tau_grid(delta: f64, levels: usize) -> Vec<f64> {
        let mut t: Vec<f64> = (0..16).map(|i| i as f64 * delta).collect();
        let mut spacing = delta;
        for _ in 0..levels {
            spacing *= 2.0;
            for _ in 0..8 {
                let last = t[t.len() - 1];
                t.push(last + spacing);
            }
        }
        t
    }

    /// Deterministic approximately Gaussian noise (sum of 12 xorshift uniforms − 6).
    struct Noise(u64);

    impl Noise {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }

        fn gaussian(&mut self) -> f64 {
            (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
        }
    }

    #[test]
    fn maxwell_starts_at_one_with_zero_slope() {
        let k = 0.4189;
        for tau in [0.05, 2.0, RHO / (4.0 * 29.0 * k * k)] {
            assert_eq!(maxwell_tcaf(0.0, 29.0, tau, k, RHO), 1.0);
            let h = 1e-6;
            let slope = (maxwell_tcaf(h, 29.0, tau, k, RHO) - 1.0) / h;
            assert!(slope.abs() < 1e-4, "tau {tau}: slope {slope}");
        }
        // The Newtonian TCAF, by contrast, starts with slope −ηk²/ρ.
        let slope = (newtonian_tcaf(1e-6, 29.0, k, RHO) - 1.0) / 1e-6;
        assert!(relative(slope, -29.0 * k * k / RHO) < 1e-5);
    }

    #[test]
    fn maxwell_solves_its_ode() {
        let (k, eta) = (0.4189, 29.0);
        let critical = RHO / (4.0 * eta * k * k);
        // Real Ω, imaginary Ω, Ω = 0 and just either side of it.
        for tau in [
            0.05,
            2.0,
            critical,
            critical * (1.0 + 1e-13),
            critical * (1.0 - 1e-13),
            critical * (1.0 + 1e-9),
        ] {
            for t in [0.01, 0.1, 0.5, 1.3, 3.0] {
                let exact = maxwell_tcaf(t, eta, tau, k, RHO);
                let ode = maxwell_ode(t, eta, tau, k, RHO);
                assert!(
                    (exact - ode).abs() < 1e-9,
                    "tau {tau} t {t}: {exact} vs ODE {ode}"
                );
            }
        }
    }

    #[test]
    fn maxwell_at_critical_damping_is_continuous() {
        // Exactly Ω = 0 (4τηk²/ρ = 1 in exact arithmetic): C = e^{−x}(1 + x).
        for t in [0.0, 0.5, 2.0, 50.0, 2000.0] {
            let x = t / 2.0;
            let c = maxwell_tcaf(t, 1.0, 1.0, 1.0, 4.0);
            assert!((c - (-x).exp() * (1.0 + x)).abs() <= 1e-15 * (-x).exp() * (1.0 + x));
        }
        // Ω² = ±1e-14 (|Ω| = 1e-7), where the corrections are O(Ω² x²).
        let (k, eta) = (0.4189, 29.0);
        let critical = RHO / (4.0 * eta * k * k);
        for t in [0.1, 1.0, 10.0] {
            for factor in [1.0, 1.0 + 1e-14, 1.0 - 1e-14] {
                let tau = critical * factor;
                let x = t / (2.0 * tau);
                let limit = (-x).exp() * (1.0 + x);
                let c = maxwell_tcaf(t, eta, tau, k, RHO);
                assert!((c - limit).abs() <= 1e-10 * limit, "{c} vs {limit}");
            }
        }
    }

    #[test]
    fn maxwell_tends_to_newtonian() {
        let (k, eta) = (0.4189, 29.0);
        for t in [0.0, 0.01, 0.1, 1.0, 5.0] {
            let maxwell = maxwell_tcaf(t, eta, 1e-9, k, RHO);
            let newtonian = newtonian_tcaf(t, eta, k, RHO);
            assert!(
                (maxwell - newtonian).abs() < 1e-7,
                "{maxwell} vs {newtonian}"
            );
        }
        assert!(
            (maxwell_tcaf(0.5, eta, 0.05, k, RHO) - newtonian_tcaf(0.5, eta, k, RHO)).abs() > 1e-3
        );
        assert_eq!(
            maxwell_tcaf(0.5, eta, 0.0, k, RHO),
            newtonian_tcaf(0.5, eta, k, RHO)
        );
        assert!(maxwell_tcaf(0.5, eta, -1.0, k, RHO).is_nan());
    }

    #[test]
    fn integrals_give_the_viscosity() {
        let (k, eta) = (0.4189, 29.0);
        let expected = RHO / (eta * k * k);
        let trapezoid = |f: &dyn Fn(f64) -> f64, t_end: f64, steps: usize| {
            let h = t_end / steps as f64;
            let inner: f64 = (1..steps).map(|i| f(i as f64 * h)).sum();
            h * (inner + 0.5 * (f(0.0) + f(t_end)))
        };
        let newtonian = trapezoid(&|t| newtonian_tcaf(t, eta, k, RHO), 40.0, 400_000);
        assert!(
            relative(newtonian, expected) < 1e-6,
            "{newtonian} vs {expected}"
        );
        for (tau, t_end) in [(0.05, 40.0), (2.0, 200.0)] {
            let maxwell = trapezoid(&|t| maxwell_tcaf(t, eta, tau, k, RHO), t_end, 400_000);
            assert!(
                relative(maxwell, expected) < 1e-6,
                "tau {tau}: {maxwell} vs {expected}"
            );
        }
    }

    #[test]
    fn newtonian_fit_recovers_exact_data() {
        let grid = multiple_tau_grid(0.002, 10);
        for (j, &eta) in ETAS.iter().enumerate() {
            let k = wavenumber(j + 1);
            let points: Vec<(f64, f64)> = grid
                .iter()
                .map(|&t| (t, newtonian_tcaf(t, eta, k, RHO)))
                .collect();
            let fit = fit_newtonian(&points, k, RHO, 0.05).expect("fit");
            assert!(relative(fit.viscosity, eta) < 1e-8, "{fit:?} vs {eta}");
            assert_eq!(fit.relaxation_time, 0.0);
            assert!(fit.residual_rms < 1e-10);
            let expected_n = points.iter().take_while(|p| p.1 > 0.05).count();
            assert_eq!(fit.points_used, expected_n);
            assert!(expected_n < points.len());
        }
    }

    #[test]
    fn maxwell_fit_recovers_exact_data() {
        let grid = multiple_tau_grid(0.002, 10);
        for (j, &eta) in ETAS.iter().enumerate() {
            let k = wavenumber(j + 1);
            let points: Vec<(f64, f64)> = grid
                .iter()
                .map(|&t| (t, maxwell_tcaf(t, eta, TAU, k, RHO)))
                .collect();
            let fit = fit_maxwell(&points, k, RHO, 0.05).expect("fit");
            assert!(
                relative(fit.viscosity, eta) < 1e-8,
                "j {j}: {fit:?} vs {eta}"
            );
            assert!(relative(fit.relaxation_time, TAU) < 1e-8, "j {j}: {fit:?}");
            assert!(fit.residual_rms < 1e-10);
        }
    }

    #[test]
    fn fits_tolerate_noise() {
        let grid = multiple_tau_grid(0.002, 10);
        let mut noise = Noise(0x9E37_79B9_7F4A_7C15);
        for (j, &eta) in ETAS.iter().enumerate() {
            let k = wavenumber(j + 1);
            let newtonian: Vec<(f64, f64)> = grid
                .iter()
                .map(|&t| (t, newtonian_tcaf(t, eta, k, RHO) + 1e-3 * noise.gaussian()))
                .collect();
            let fit = fit_newtonian(&newtonian, k, RHO, 0.05).expect("Newtonian fit");
            assert!(relative(fit.viscosity, eta) < 0.02, "j {j}: {fit:?}");
            assert!(fit.residual_rms > 1e-4 && fit.residual_rms < 1e-2);
            let maxwell: Vec<(f64, f64)> = grid
                .iter()
                .map(|&t| {
                    (
                        t,
                        maxwell_tcaf(t, eta, TAU, k, RHO) + 1e-3 * noise.gaussian(),
                    )
                })
                .collect();
            let fit = fit_maxwell(&maxwell, k, RHO, 0.05).expect("Maxwell fit");
            assert!(relative(fit.viscosity, eta) < 0.02, "j {j}: {fit:?}");
        }
    }

    #[test]
    fn fits_need_enough_points() {
        let k = wavenumber(1);
        let points: Vec<(f64, f64)> = [0.0, 0.1, 0.2, 10.0, 10.1]
            .iter()
            .map(|&t| (t, maxwell_tcaf(t, 28.9, TAU, k, RHO)))
            .collect();
        // Three points above the cutoff, then one below it: later points are ignored.
        assert!(fit_maxwell(&points, k, RHO, 0.05).is_none());
        let fit = fit_newtonian(&points, k, RHO, 0.05).expect("three points suffice");
        assert_eq!(fit.points_used, 3);
        assert!(fit_newtonian(&points[..2], k, RHO, 0.05).is_none());
        let bad = [(0.0, 1.0), (0.1, f64::NAN), (0.2, 0.9), (0.3, 0.8)];
        assert!(fit_newtonian(&bad, k, RHO, 0.05).is_none());
        assert!(fit_newtonian(&[(0.0, 1.0); 5], k, RHO, 0.05).is_none());
        let four: Vec<(f64, f64)> = [0.0, 0.1, 0.2, 0.3]
            .iter()
            .map(|&t| (t, maxwell_tcaf(t, 28.9, TAU, k, RHO)))
            .collect();
        assert!(fit_maxwell(&four, k, RHO, 0.05).is_some());
    }

    #[test]
    fn extrapolation_of_exact_quadratic_data() {
        let (eta0, a) = (30.0, -2.5);
        let k: Vec<f64> = (1..=4).map(wavenumber).collect();
        let eta: Vec<f64> = k.iter().map(|k| eta0 + a * k * k).collect();
        for sigma in [vec![], vec![0.1, 0.2, 0.3, 0.4]] {
            let (e, s, error) = extrapolate_to_zero_wavenumber(&k, &eta, &sigma).expect("fit");
            assert!((e - eta0).abs() < 1e-12 * eta0);
            assert!((s - a).abs() < 1e-12 * a.abs());
            if sigma.is_empty() {
                assert!(error.abs() < 1e-12, "{error}");
            } else {
                assert!(error > 0.0);
            }
        }
    }

    #[test]
    fn extrapolation_errors_match_a_hand_computation() {
        // x = k² = 1, 4, 9; η = 30, 27, 20.
        let k = [1.0, 2.0, 3.0];
        let eta = [30.0, 27.0, 20.0];
        // Unweighted: n = 3, Σx = 14, Σx² = 98, det = 3·98 − 14² = 98, Σy = 77, Σxy = 318:
        // η₀ = (98·77 − 14·318)/98 = 221/7, a = (3·318 − 14·77)/98 = −62/49.
        // Residuals η − η₀ − a x = (−15, 24, −9)/49, RSS = 882/2401 = 18/49, s² = RSS/(3 − 2),
        // var η₀ = s² Σx²/det = 18/49.
        let (e, a, error) = extrapolate_to_zero_wavenumber(&k, &eta, &[]).expect("fit");
        assert!((e - 221.0 / 7.0).abs() < 1e-12);
        assert!((a + 62.0 / 49.0).abs() < 1e-12);
        assert!((error - (18.0f64 / 49.0).sqrt()).abs() < 1e-12, "{error}");
        // Weighted, σ = (1, 1, 2), w = (1, 1, 1/4): Σw = 9/4, Σwx = 29/4, Σwx² = 149/4,
        // det = (9/4)(149/4) − (29/4)² = 125/4, var η₀ = Σwx²/det = 149/125;
        // Σwy = 62, Σwxy = 183: η₀ = (149/4·62 − 29/4·183)/(125/4) = 3931/125,
        // a = (9/4·183 − 29/4·62)/(125/4) = −151/125.
        let (e, a, error) =
            extrapolate_to_zero_wavenumber(&k, &eta, &[1.0, 1.0, 2.0]).expect("fit");
        assert!((e - 3931.0 / 125.0).abs() < 1e-12);
        assert!((a + 151.0 / 125.0).abs() < 1e-12);
        assert!((error - (149.0f64 / 125.0).sqrt()).abs() < 1e-12, "{error}");
        // A zero σ falls back to the unweighted fit.
        let (_, _, error) =
            extrapolate_to_zero_wavenumber(&k, &eta, &[1.0, 0.0, 2.0]).expect("fit");
        assert!((error - (18.0f64 / 49.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn extrapolation_degenerate_cases() {
        let (e, a, error) =
            extrapolate_to_zero_wavenumber(&[1.0, 2.0], &[29.0, 26.0], &[]).expect("fit");
        assert!((e - 30.0).abs() < 1e-12 && (a + 1.0).abs() < 1e-12);
        assert!(error.is_nan());
        assert!(extrapolate_to_zero_wavenumber(&[1.0], &[29.0], &[]).is_none());
        assert!(extrapolate_to_zero_wavenumber(&[0.4; 3], &[29.0, 28.0, 27.0], &[]).is_none());
        // ±k give the same k²: still degenerate.
        assert!(extrapolate_to_zero_wavenumber(&[0.4, -0.4], &[29.0, 28.0], &[]).is_none());
        assert!(extrapolate_to_zero_wavenumber(&[0.4, 0.8], &[29.0], &[]).is_none());
    }

    #[test]
    fn integral_viscosity_of_newtonian_data() {
        let (k, eta) = (wavenumber(1), 28.9);
        let mut points: Vec<(f64, f64)> = (0..200_000)
            .map(|i| {
                let t = i as f64 * 2e-4;
                (t, newtonian_tcaf(t, eta, k, RHO))
            })
            .collect();
        let found = integral_viscosity(&points, k, RHO);
        assert!(relative(found, eta) < 1e-4, "{found}");
        // Non-uniform spacing: a coarser tail.
        points.retain(|p| p.0 < 10.0 || ((p.0 / 2e-4).round() as usize).is_multiple_of(10));
        let found = integral_viscosity(&points, k, RHO);
        assert!(relative(found, eta) < 1e-4, "{found}");
        assert!(integral_viscosity(&points[..1], k, RHO).is_nan());
        assert!(integral_viscosity(&[(0.0, -1.0), (1.0, -1.0)], k, RHO).is_nan());
    }
}
