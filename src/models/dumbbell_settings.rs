//! The settings of a dumbbell ensemble, shared by the homogeneous-flow scene (`[polymer]`) and
//! the CONNFFESSIT fluid (`[fluid.polymer]`): spring law, stochastic scheme, storage precision,
//! and their validation.

use crate::models::bddfs::QGrid;
use crate::models::dumbbells::{Scheme, Spring};
use crate::spans::{CaseError, Segment, SpanIndex};
use serde::{Deserialize, Serialize};

fn k(s: &str) -> Segment {
    Segment::Key(s.to_owned())
}

/// Spring laws.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SpringKind {
    /// F = H Q.
    Hookean,
    /// F = H Q / (1 − Q²/Q₀²).
    Fene,
}

/// Stochastic schemes.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SchemeKind {
    /// Euler–Maruyama (weak order 1).
    EulerMaruyama,
    /// Stochastic Heun / SRK2 (weak order 2).
    Heun,
    /// Öttinger's semi-implicit predictor–corrector (FENE stays inside √b).
    SemiImplicit,
}

/// Whose Wiener increments the ensembles of a CONNFFESSIT fluid draw (`fluid.polymer.noise`).
///
/// - `Independent`: particle g draws its initial connectors and the increments of step n from
///   the streams (seed, g) and (seed, g, n): M·N_d independent dumbbells. The stress of
///   neighbouring particles then differs by independent noise of relative size N_d^(−1/2),
///   whose divergence pushes the particles off their ordered arrangement; the disorder feeds
///   the velocity gradient and the pair forces, and the measured η and N₁ acquire a bias of
///   order 1/N_d that grows with Wi (docs/validation.md, "The coupled shear's bias").
/// - `ConfigurationFields`: every particle draws from the streams of particle 0, so dumbbell k
///   of every particle starts from the same connector and receives the same increments: the
///   k-th dumbbells form a Brownian configuration field Q_k(r, t), smooth in space (Hulsen, van
///   Heel & van den Brule, J. Non-Newtonian Fluid Mech. 70 (1997) 79). The stress is
///   still the Kramers stress of N_d dumbbells at each particle, with the same expectation,
///   but its noise is the same at neighbouring particles and so drives no relative motion:
///   in homogeneous flow every particle carries the homogeneous-flow ensemble of particle 0
///   exactly. The price: the mean stress averages N_d independent dumbbells, not M·N_d.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum EnsembleNoise {
    /// Every particle its own streams (the default).
    #[default]
    Independent,
    /// One set of streams shared by every particle (Brownian configuration fields).
    ConfigurationFields,
}

impl EnsembleNoise {
    /// The particle id whose streams particle `gid` draws from.
    #[inline]
    pub fn stream_owner(self, gid: u64) -> u64 {
        match self {
            Self::Independent => gid,
            Self::ConfigurationFields => 0,
        }
    }
}

/// Storage precision of the connector vectors (`polymer.precision`): the particle store's own.
pub use crate::particles::Precision;

/// The spring law of the keys `spring` and `b` (b validated to exist for FENE).
pub fn spring_law(spring: SpringKind, b: Option<f64>) -> Spring {
    match spring {
        SpringKind::Hookean => Spring::Hookean,
        SpringKind::Fene => Spring::Fene {
            b: b.unwrap_or(f64::NAN),
        },
    }
}

/// The scheme of the key `scheme`, with its default: Heun for Hookean, semi-implicit for FENE.
pub fn scheme_or_default(scheme: Option<SchemeKind>, spring: SpringKind) -> Scheme {
    match (scheme, spring) {
        (Some(SchemeKind::EulerMaruyama), _) => Scheme::EulerMaruyama,
        (Some(SchemeKind::Heun), _) => Scheme::Heun,
        (Some(SchemeKind::SemiImplicit), _) | (None, SpringKind::Fene) => Scheme::SemiImplicit,
        (None, SpringKind::Hookean) => Scheme::Heun,
    }
}

/// Largest N_d (6.7·10⁷): one particle's ensemble is one contiguous buffer; larger ensembles
/// are better spread over more particles.
pub const MAX_PER_PARTICLE: usize = 1 << 26;

/// Checks of a dumbbell ensemble's keys under the table `table` (`[polymer]` of a homogeneous
/// flow, `[fluid.polymer]` of a CONNFFESSIT fluid): N_d, the spring and its b, the scheme.
pub fn validate_ensemble(
    table: &[Segment],
    per_particle: usize,
    spring: SpringKind,
    b: Option<f64>,
    scheme: Option<SchemeKind>,
    ix: &SpanIndex,
) -> Result<(), CaseError> {
    let pk = |key: &str| {
        let mut path = table.to_vec();
        path.push(k(key));
        path
    };
    if per_particle == 0 || per_particle > MAX_PER_PARTICLE {
        return Err(ix.error(
            &pk("per_particle"),
            format!(
                "found {}; must be between 1 and {MAX_PER_PARTICLE} (10²–10⁴ is typical)",
                per_particle
            ),
        ));
    }
    match (spring, b) {
        (SpringKind::Fene, None) => {
            return Err(ix.error(
                &pk("b"),
                "missing: a FENE spring needs its extensibility b = H Q₀²/k_BT (> 2; 10–100 \
                 typical)",
            ));
        }
        (SpringKind::Fene, Some(b)) if !(b.is_finite() && b > 2.0) => {
            return Err(ix.error(
                &pk("b"),
                format!("found {b}; must be > 2 (typically 10–100)"),
            ));
        }
        (SpringKind::Hookean, Some(_)) => {
            return Err(ix.error(
                &pk("b"),
                "a Hookean spring has no extensibility; remove b or use spring = \"fene\"",
            ));
        }
        _ => {}
    }
    if spring == SpringKind::Fene && !matches!(scheme, None | Some(SchemeKind::SemiImplicit)) {
        return Err(ix.error(
            &pk("scheme"),
            format!(
                "found \"{}\": an explicit scheme can stretch a FENE dumbbell beyond √b; use \
                 \"semi_implicit\" (or leave scheme out)",
                match scheme {
                    Some(SchemeKind::EulerMaruyama) => "euler_maruyama",
                    _ => "heun",
                }
            ),
        ));
    }
    Ok(())
}

/// Checks of a BDDFS histogram grid `grid` under the table `table` (`[polymer]` of a
/// homogeneous flow, `[fluid.polymer]` of a CONNFFESSIT fluid), `given` saying whether `cells`
/// and `q_max` were given: `cells` is required, `q_max` is required for Hookean springs (the
/// grid clips their unbounded connectors) and defaults to √b for FENE, and the grid must work
/// ([`QGrid::check`]).
#[allow(clippy::too_many_arguments)]
pub fn validate_histogram_grid(
    table: &[Segment],
    grid: &QGrid,
    given: (bool, bool),
    spring: SpringKind,
    law: Spring,
    dim: usize,
    ix: &SpanIndex,
) -> Result<(), CaseError> {
    let pk = |key: &str| {
        let mut path = table.to_vec();
        path.push(k(key));
        path
    };
    let (cells_given, q_max_given) = given;
    if !cells_given {
        return Err(ix.error(
            &pk("cells"),
            "missing: BDDFS needs the cells per axis n_c of its histogram grid (≥ 2; `check` \
             suggests one for the time step)",
        ));
    }
    if spring == SpringKind::Hookean && !q_max_given {
        return Err(ix.error(
            &pk("q_max"),
            "missing: a Hookean connector is unbounded, so BDDFS needs the grid's half-edge \
             Q_max (> 0, in units of √(k_BT/H); connectors beyond it are clipped into the \
             boundary cells and counted — e.g. 6 + 3 Wi keeps them rare)",
        ));
    }
    if let Err(e) = grid.check(dim, law) {
        let key = if e.starts_with("n_c") {
            "cells"
        } else {
            "q_max"
        };
        return Err(ix.error(&pk(key), e));
    }
    Ok(())
}
