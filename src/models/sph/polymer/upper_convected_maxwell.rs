//! The upper-convected Maxwell fluid (Oldroyd-B with a solvent viscosity `fluid.viscosity`;
//! Bird, Armstrong & Hassager 1987, vol. 1 §7.3):
//!
//! ```text
//! dτ/dt = Gτ + τGᵀ + (2η_p/λ) D − τ/λ,   D = ½ (G + Gᵀ)
//! ```
//!
//! It has a non-zero trace: in steady shear τ_xx = 2η_pλγ̇², τ_yy = τ_zz = 0, so
//! η = η_s + η_p, Ψ₁ = 2η_pλ, Ψ₂ = 0. It uses the full rate of strain D (= D̄ for an
//! incompressible flow; the weakly compressible tr G is O(M²)).

use super::{Law, LawParams, PolymerCfg, packed_index, unpack};

/// `model = "upper_convected_maxwell"`.
pub struct UpperConvectedMaxwell;

impl Law for UpperConvectedMaxwell {
    fn oldroyd_b(_cfg: &PolymerCfg) -> bool {
        true
    }

    #[inline]
    fn rate<const D: usize>(p: &LawParams, tau: &[f64], g: &[[f64; D]; D], rate: &mut [f64]) {
        let t = unpack::<D>(tau);
        let inv_lambda = 1.0 / p.relaxation_time;
        let modulus = p.viscosity * inv_lambda; // G = η_p/λ
        for a in 0..D {
            for b in a..D {
                let strain = 0.5 * (g[a][b] + g[b][a]);
                let mut r = 2.0 * modulus * strain;
                r -= t[a][b] * inv_lambda;
                // (Gτ + τGᵀ)^{ab} = Σ_c G^{ac} τ^{cb} + τ^{ac} G^{bc}.
                for c in 0..D {
                    r += g[a][c] * t[c][b] + t[a][c] * g[b][c];
                }
                rate[packed_index::<D>(a, b)] = r;
            }
        }
    }

    /// τ_xx = 2η_pλγ̇².
    fn steady_shear_tension(cfg: &PolymerCfg, shear_rate: f64, _dimension: usize) -> f64 {
        2.0 * cfg.viscosity * cfg.relaxation_time * shear_rate * shear_rate
    }
}
