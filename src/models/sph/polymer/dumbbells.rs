//! `model = "dumbbells"` (CONNFFESSIT): the stress is the Kramers stress G(⟨QF(Q)⟩ − I),
//! G = η_p/λ, of the Brownian dumbbells each fluid particle carries
//! ([`crate::models::dumbbell_ensemble`], a companion model the SPH fluid builds), not a
//! function of τ and G: this law has no rate.

use super::{Law, LawParams, PolymerCfg};
use crate::models::dumbbell_settings::SpringKind;

/// `model = "dumbbells"`.
pub struct Dumbbells;

impl Law for Dumbbells {
    const ENSEMBLE: bool = true;
    const KEYS: &'static [&'static str] = &[
        "per_particle",
        "spring",
        "b",
        "scheme",
        "precision",
        "noise",
    ];

    fn validate(cfg: &PolymerCfg) -> Result<(), (&'static str, String)> {
        if cfg.per_particle.is_none() {
            return Err((
                "model",
                "model = \"dumbbells\" needs per_particle = N_d, the dumbbells each fluid \
                 particle carries (10²–10⁴ typical)"
                    .to_string(),
            ));
        }
        Ok(())
    }

    fn rate<const D: usize>(_: &LawParams, _: &[f64], _: &[[f64; D]; D], _: &mut [f64]) {
        unreachable!("dumbbell ensembles have no constitutive rate (`ConstitutiveLaw::of`)")
    }

    /// Hookean dumbbells are the stochastic Oldroyd-B fluid (FENE ones are not).
    fn oldroyd_b(cfg: &PolymerCfg) -> bool {
        cfg.spring.unwrap_or(SpringKind::Hookean) == SpringKind::Hookean
    }

    /// FENE dumbbells: b/(b + D + 2) (Bird et al. 1987 vol. 2 §13.5); Hookean: 1.
    fn zero_shear_factor(cfg: &PolymerCfg, dimension: usize) -> Option<(f64, &'static str)> {
        match cfg.spring_law() {
            crate::models::dumbbells::Spring::Fene { b } => {
                Some((b / (b + dimension as f64 + 2.0), "b/(b + D + 2)"))
            }
            _ => None,
        }
    }

    /// 2η_pλγ̇² (Hookean; FENE less).
    fn steady_shear_tension(cfg: &PolymerCfg, shear_rate: f64, _dimension: usize) -> f64 {
        2.0 * cfg.viscosity * cfg.relaxation_time * shear_rate * shear_rate
    }
}
