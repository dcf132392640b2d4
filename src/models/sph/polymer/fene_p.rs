//! The FENE-P fluid: the Peterlin closure of FENE dumbbells (Bird, Dotson & Johnson,
//! J. Non-Newtonian Fluid Mech. 7, 213 (1980); Bird et al. 1987 vol. 2 §13.5), in the
//! normalisation where the conformation c = ⟨QQ⟩H/k_BT relaxes towards I:
//!
//! ```text
//! dc/dt = G c + c Gᵀ − (Z c − I)/λ,     Z = 1/(1 − tr c/b),     τ = G_p (Z c − I),  G_p = η_p/λ
//! ```
//!
//! with G^{ab} = ∂v^a/∂x^b. The particle carries τ, not c (the measurement and the momentum
//! equation read the stress), so the law is advanced in τ. Inverting τ = G_p(Zc − I) with
//! Z = 1/(1 − tr c/b) gives Z explicitly, Z = 1 + (D + tr τ/G_p)/b, and c = (τ/G_p + I)/Z;
//! differentiating τ = G_p Z c, with Ż = Z² tr ċ / b (from the trace of the same relation),
//!
//! ```text
//! ċ = G c + c Gᵀ − τ/(G_p λ)
//! dτ/dt = G_p Z ċ + G_p Z² (tr ċ / b) c
//! ```
//!
//! As b → ∞, Z → 1 and this is the upper-convected Maxwell law. At rest c = b/(b + D) I, so the
//! zero-shear polymer viscosity is η_p b/(b + D). In steady simple shear v_x = γ̇y at
//! Wi = λγ̇: c_yy = c_zz = 1/Z, c_xy = Wi/Z², c_xx = (1 + 2Wi²/Z²)/Z, hence
//!
//! ```text
//! b Z³ − (b + D) Z² − 2 Wi² = 0   (one root Z > (b + D)/b)
//! η_p(γ̇) = η_p / Z,   N₁ = 2 η_p λ γ̇² / Z²,   N₂ = 0
//! ```
//!
//! (`tests` check the τ-form against this closed form, whose root they take by Cardano's
//! formula.) `b` (`[fluid.polymer] b`) must exceed 0; FENE dumbbells need b > 2 and 10–100 is
//! typical.

use super::{Law, LawParams, PolymerCfg, packed_index, unpack};

/// `model = "fene_p"`.
pub struct FeneP;

impl Law for FeneP {
    const KEYS: &'static [&'static str] = &["b"];

    #[inline]
    fn rate<const D: usize>(p: &LawParams, tau: &[f64], g: &[[f64; D]; D], rate: &mut [f64]) {
        let t = unpack::<D>(tau);
        let modulus = p.viscosity / p.relaxation_time; // G_p = η_p/λ
        let trace_tau = (0..D).map(|a| t[a][a]).sum::<f64>();
        let z = 1.0 + (D as f64 + trace_tau / modulus) / p.b;
        let c: [[f64; D]; D] = std::array::from_fn(|a| {
            std::array::from_fn(|b| (t[a][b] / modulus + if a == b { 1.0 } else { 0.0 }) / z)
        });
        let c_rate: [[f64; D]; D] = std::array::from_fn(|a| {
            std::array::from_fn(|b| {
                let mut r = -t[a][b] / (modulus * p.relaxation_time);
                for k in 0..D {
                    r += g[a][k] * c[k][b] + c[a][k] * g[b][k];
                }
                r
            })
        });
        let trace_rate = (0..D).map(|a| c_rate[a][a]).sum::<f64>();
        for a in 0..D {
            for b in a..D {
                rate[packed_index::<D>(a, b)] = modulus * z * c_rate[a][b]
                    + modulus * z * z * (trace_rate / p.b) * c[a][b];
            }
        }
    }

    fn validate(cfg: &PolymerCfg) -> Result<(), (&'static str, String)> {
        match cfg.b {
            None => Err((
                "b",
                "missing: model = \"fene_p\" needs the maximum extensibility b = H Q₀²/k_BT \
                 (> 0; 10–100 typical)"
                    .to_string(),
            )),
            Some(b) if !(b.is_finite() && b > 0.0) => {
                Err(("b", format!("found {b}; must be > 0 (10–100 typical)")))
            }
            Some(_) => Ok(()),
        }
    }

    /// b/(b + D): the conformation at rest is b/(b + D) I.
    fn zero_shear_factor(cfg: &PolymerCfg, dimension: usize) -> Option<(f64, &'static str)> {
        let b = cfg.b.unwrap_or(f64::NAN);
        Some((b / (b + dimension as f64), "b/(b + D)"))
    }

    /// N₁ = 2η_pλγ̇²/Z² (τ_yy = 0), with Z the root of the steady-shear cubic (module doc).
    fn steady_shear_tension(cfg: &PolymerCfg, shear_rate: f64, dimension: usize) -> f64 {
        let b = cfg.b.unwrap_or(f64::NAN);
        let wi = cfg.relaxation_time * shear_rate;
        let z = steady_shear_spring_factor(b, dimension as f64, wi);
        2.0 * cfg.viscosity * cfg.relaxation_time * shear_rate * shear_rate / (z * z)
    }
}

/// The root Z > (b + D)/b of b Z³ − (b + D) Z² − 2 Wi² = 0, by Newton's method from above
/// (the cubic is convex there, so the iterates fall monotonically onto the root).
pub fn steady_shear_spring_factor(b: f64, dimension: f64, wi: f64) -> f64 {
    let f = |z: f64| b * z * z * z - (b + dimension) * z * z - 2.0 * wi * wi;
    let df = |z: f64| 3.0 * b * z * z - 2.0 * (b + dimension) * z;
    // An upper bound: at z₀ = (b + D)/b + (2Wi²/b)^{1/3} + 1, f > 0.
    let mut z = (b + dimension) / b + (2.0 * wi * wi / b).cbrt() + 1.0;
    for _ in 0..100 {
        let step = f(z) / df(z);
        z -= step;
        if step.abs() <= 1e-15 * z {
            break;
        }
    }
    z
}

#[cfg(test)]
mod tests {
    use super::super::tests::start_up_in as shear;
    use super::super::{ConstitutiveLaw, PolymerModel};
    use super::*;

    fn law(viscosity: f64, relaxation_time: f64, b: f64) -> ConstitutiveLaw {
        ConstitutiveLaw {
            model: PolymerModel::FeneP,
            params: LawParams {
                viscosity,
                relaxation_time,
                rotation: true,
                b,
            },
        }
    }

    /// The real root of b Z³ − (b + D) Z² − 2Wi² = 0 by Cardano's formula (the reference
    /// here is independent of the law's Newton iteration): with Z = y + (b + D)/(3b) the
    /// depressed cubic y³ + p y + q = 0 has p = −(b + D)²/(3b²),
    /// q = −2(b + D)³/(27b³) − 2Wi²/b, and its discriminant −(4p³ + 27q²) < 0 for Wi > 0,
    /// so one real root y = ∛(−q/2 + √Δ) + ∛(−q/2 − √Δ), Δ = q²/4 + p³/27.
    fn cardano(b: f64, d: f64, wi: f64) -> f64 {
        let s = (b + d) / b;
        let p = -s * s / 3.0;
        let q = -2.0 * s * s * s / 27.0 - 2.0 * wi * wi / b;
        let delta = q * q / 4.0 + p * p * p / 27.0;
        let y = (-q / 2.0 + delta.sqrt()).cbrt() + (-q / 2.0 - delta.sqrt()).cbrt();
        y + s / 3.0
    }

    /// Steady simple shear (t = 40λ) in 2D and 3D at Wi = 0.5, 2, 10 and b = 5, 50: the shear
    /// stress η_pγ̇/Z, N₁ = 2η_pλγ̇²/Z² and τ_yy = τ_zz = 0 of the closed form, to 10⁻⁸ (RK4
    /// with λ/Δt = 400 is converged far below that). Mutation that fails: Z = 1 + tr τ/(G b)
    /// without the D. (The steady state is where ċ = 0, whatever τ̇ makes of ċ: the start-up
    /// test below checks the Z² tr ċ/b term.)
    #[test]
    fn steady_shear_follows_the_closed_form() {
        let (eta, lambda) = (3.0, 0.5);
        for b in [5.0, 50.0] {
            for wi in [0.5, 2.0, 10.0] {
                let gamma = wi / lambda;
                let m = law(eta, lambda, b);
                let check = |tau: &[f64], d: f64, yy: usize, zz: Option<usize>| {
                    let z = cardano(b, d, wi);
                    assert!((z - steady_shear_spring_factor(b, d, wi)).abs() < 1e-12 * z);
                    let (xy, n1) = (eta * gamma / z, 2.0 * eta * lambda * gamma * gamma / (z * z));
                    let scale = xy.max(n1);
                    let msg = format!("b {b}, Wi {wi}, D {d}: τ {tau:?}, want xy {xy}, N₁ {n1}");
                    assert!((tau[1] - xy).abs() < 1e-8 * scale, "{msg}");
                    assert!((tau[0] - tau[yy] - n1).abs() < 1e-8 * scale, "{msg}");
                    assert!(tau[yy].abs() < 1e-8 * scale, "{msg}");
                    if let Some(zz) = zz {
                        assert!(tau[zz].abs() < 1e-8 * scale, "{msg}");
                    }
                };
                let steps = 16_000;
                check(&shear::<2>(&m, gamma, 40.0 * lambda, steps), 2.0, 2, None);
                check(&shear::<3>(&m, gamma, 40.0 * lambda, steps), 3.0, 3, Some(5));
            }
        }
    }

    /// Start-up of shear from rest (τ = 0, c = b/(b + D) I) at Wi = 2, b = 5, in 2D and 3D:
    /// τ(t) of the law, advanced in τ, against τ = G_p(Zc − I) of the textbook conformation
    /// equation dc/dt = Gc + cGᵀ − (Zc − I)/λ, Z = 1/(1 − tr c/b), advanced in c by its own
    /// RK4 here, at t = 0.3λ, λ and 3λ (the overshoot and its decay), to 10⁻⁸ of N₁. Mutation
    /// that fails: the Z² tr ċ/b term dropped (τ drifts from the conformation it encodes).
    #[test]
    fn start_up_is_the_conformation_equation() {
        fn conformation<const D: usize>(b: f64, lambda: f64, gamma: f64, t: f64) -> [[f64; D]; D] {
            let mut g = [[0.0; D]; D];
            g[0][1] = gamma;
            let rate = |c: &[[f64; D]; D]| -> [[f64; D]; D] {
                let tr: f64 = (0..D).map(|a| c[a][a]).sum();
                let z = 1.0 / (1.0 - tr / b);
                std::array::from_fn(|a| {
                    std::array::from_fn(|k| {
                        let mut r = -(z * c[a][k] - if a == k { 1.0 } else { 0.0 }) / lambda;
                        for m in 0..D {
                            r += g[a][m] * c[m][k] + c[a][m] * g[k][m];
                        }
                        r
                    })
                })
            };
            let step = |c: &[[f64; D]; D], a: f64, k: &[[f64; D]; D]| -> [[f64; D]; D] {
                std::array::from_fn(|i| std::array::from_fn(|j| c[i][j] + a * k[i][j]))
            };
            let mut c: [[f64; D]; D] = std::array::from_fn(|a| {
                std::array::from_fn(|k| if a == k { b / (b + D as f64) } else { 0.0 })
            });
            let n = 20_000;
            let dt = t / n as f64;
            for _ in 0..n {
                let k1 = rate(&c);
                let k2 = rate(&step(&c, 0.5 * dt, &k1));
                let k3 = rate(&step(&c, 0.5 * dt, &k2));
                let k4 = rate(&step(&c, dt, &k3));
                c = std::array::from_fn(|i| {
                    std::array::from_fn(|j| {
                        c[i][j] + dt / 6.0 * (k1[i][j] + 2.0 * k2[i][j] + 2.0 * k3[i][j] + k4[i][j])
                    })
                });
            }
            c
        }
        fn compare<const D: usize>(eta: f64, lambda: f64, b: f64, wi: f64) {
            let gamma = wi / lambda;
            let modulus = eta / lambda;
            let scale = 2.0 * eta * lambda * gamma * gamma;
            for t in [0.3 * lambda, lambda, 3.0 * lambda] {
                let tau = shear::<D>(&law(eta, lambda, b), gamma, t, 20_000);
                let c = conformation::<D>(b, lambda, gamma, t);
                let tr: f64 = (0..D).map(|a| c[a][a]).sum();
                let z = 1.0 / (1.0 - tr / b);
                for a in 0..D {
                    for k in a..D {
                        let want = modulus * (z * c[a][k] - if a == k { 1.0 } else { 0.0 });
                        let got = tau[packed_index::<D>(a, k)];
                        assert!(
                            (got - want).abs() < 1e-8 * scale,
                            "D {D}, t {t}, ({a},{k}): τ-form {got}, conformation {want}"
                        );
                    }
                }
            }
        }
        compare::<2>(3.0, 0.5, 5.0, 2.0);
        compare::<3>(3.0, 0.5, 5.0, 2.0);
    }

    /// As b → ∞ the rate is the upper-convected Maxwell rate, at an arbitrary state.
    #[test]
    fn infinite_extensibility_is_the_upper_convected_maxwell_fluid() {
        let tau = [0.7, -0.2, 0.1, 1.3, 0.4, -0.5];
        let g = [[0.1, 0.9, -0.3], [0.2, -0.4, 0.5], [0.6, 0.0, 0.3]];
        let (mut fene, mut ucm) = ([0.0; 6], [0.0; 6]);
        law(2.0, 0.8, 1e12).rate::<3>(&tau, &g, &mut fene);
        let upper = ConstitutiveLaw {
            model: PolymerModel::UpperConvectedMaxwell,
            ..law(2.0, 0.8, f64::NAN)
        };
        upper.rate::<3>(&tau, &g, &mut ucm);
        for c in 0..6 {
            assert!((fene[c] - ucm[c]).abs() < 1e-9, "{c}: {} vs {}", fene[c], ucm[c]);
        }
    }
}
