//! The corotational (Jaumann) Maxwell fluid of Ellero 2004 ch. 3 (Eq. 3.7, ×2;
//! docs/theory/sph_maxwell.md §1.9), with the thesis's printed sign corrected, and its linear
//! variant ("SPH2", `rotation = false`):
//!
//! ```text
//! Ω = ½ (G − Gᵀ)   (vorticity, Ω^{ab} = ½(∂_b v^a − ∂_a v^b))
//! D = ½ (G + Gᵀ)   (rate of strain),   D̄ = D − (1/d) tr G · I   (its deviatoric part)
//!
//! corotational (Jaumann) Maxwell   dτ/dt = Ωτ − τΩ + (2η_p/λ) D̄ − τ/λ
//! linear ("SPH2")                  dτ/dt =            (2η_p/λ) D̄ − τ/λ
//! ```
//!
//! **Departure from the printed text.** The thesis's Eq. 3.4 and Eq. 3.6 combine the rotation
//! terms into σω + ωσ, an antisymmetric tensor for symmetric σ: with it steady shear gives
//! σ_xx = σ_yy = 0 and σ_xy = ηγ̇, no shear thinning and no normal stresses, which contradicts
//! the thesis's own Figs. 3.5–3.6. The Jaumann form above is what is implemented
//! (docs/theory/sph_maxwell.md §1.9 erratum); in simple shear v_x = γ̇y it gives
//! dτ_xx/dt = γ̇τ_xy − τ_xx/λ, dτ_yy/dt = −γ̇τ_xy − τ_yy/λ,
//! dτ_xy/dt = (γ̇/2)(τ_yy − τ_xx) + η_pγ̇/λ − τ_xy/λ.
//!
//! Both keep tr τ = 0 (tr(Ωτ − τΩ) = tr D̄ = 0); it is monitored, not enforced
//! (`polymer_stress_trace` observable).

use super::{Law, LawParams, PolymerCfg, packed_index, unpack};

/// `model = "corotational_maxwell"`.
pub struct CorotationalMaxwell;

impl Law for CorotationalMaxwell {
    const KEYS: &'static [&'static str] = &["rotation"];

    #[inline]
    fn rate<const D: usize>(p: &LawParams, tau: &[f64], g: &[[f64; D]; D], rate: &mut [f64]) {
        let t = unpack::<D>(tau);
        let inv_lambda = 1.0 / p.relaxation_time;
        let modulus = p.viscosity * inv_lambda; // G = η_p/λ
        let trace_over_d = (0..D).map(|a| g[a][a]).sum::<f64>() / D as f64;
        for a in 0..D {
            for b in a..D {
                let strain = 0.5 * (g[a][b] + g[b][a]);
                let deviatoric = if a == b {
                    strain - trace_over_d
                } else {
                    strain
                };
                let mut r = 2.0 * modulus * deviatoric;
                r -= t[a][b] * inv_lambda;
                if p.rotation {
                    // (Ωτ − τΩ)^{ab} = Σ_c Ω^{ac} τ^{cb} − τ^{ac} Ω^{cb}.
                    for c in 0..D {
                        let omega_ac = 0.5 * (g[a][c] - g[c][a]);
                        let omega_cb = 0.5 * (g[c][b] - g[b][c]);
                        r += omega_ac * t[c][b] - t[a][c] * omega_cb;
                    }
                }
                rate[packed_index::<D>(a, b)] = r;
            }
        }
    }

    /// τ_xx = η_p De γ̇/(1 + De²), De = λγ̇ (what the rotation terms give; the linear variant
    /// has none, and is quoted the same for the background-pressure advice).
    fn steady_shear_tension(cfg: &PolymerCfg, shear_rate: f64, _dimension: usize) -> f64 {
        let de = cfg.relaxation_time * shear_rate.abs();
        cfg.viscosity * de * shear_rate.abs() / (1.0 + de * de)
    }
}
