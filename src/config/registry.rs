//! The registry of fluid models: `[fluid] kind = "…"` → the model's parameter struct.
//!
//! **Adding a fluid model is one line here** (its variant, its parameter struct and its
//! `kind`), plus the model's own directory, whose parameter struct implements
//! [`FluidModel`] and [`BuildModels`] (see [`crate::models::fluid_model`]). The macro derives
//! from the list the `[fluid]` enum (serde, tagged by `kind`), the dispatch to the model
//! ([`FluidCfg::model`], [`FluidCfg::builder`]) and the list of kinds the case parser accepts;
//! nothing else in the generic layers names a model.

use crate::models::fluid_model::{BuildModels, FluidModel, KindTraits};
use serde::{Deserialize, Serialize};

macro_rules! fluid_registry {
    ($( $(#[$doc:meta])* $variant:ident($cfg:ty) = $kind:literal, )*) => {
        /// `[fluid]`, selected by `kind`: one variant per registered fluid model.
        #[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
        #[serde(tag = "kind")]
        pub enum FluidCfg {
            $( $(#[$doc])* #[serde(rename = $kind)] $variant($cfg), )*
        }

        impl FluidCfg {
            /// The model's own answers about itself.
            pub fn model(&self) -> &dyn FluidModel {
                match self {
                    $( FluidCfg::$variant(m) => m, )*
                }
            }

            /// Whether its kind carries boundary particles (`[walls]`, `[inclusions]`).
            pub fn carries_boundary_particles(&self) -> bool {
                match self {
                    $( FluidCfg::$variant(_) => <$cfg as KindTraits>::CARRIES_BOUNDARY_PARTICLES, )*
                }
            }

            /// What the model runs in D dimensions.
            pub fn builder<const D: usize>(&self) -> &dyn BuildModels<D> {
                match self {
                    $( FluidCfg::$variant(m) => m, )*
                }
            }
        }

        /// The registered kinds that carry boundary particles, as `kind = "a" | "b"` (for the
        /// errors about walls and inclusions).
        pub fn kinds_carrying_boundary_particles() -> String {
            let kinds: Vec<String> = [$( ($kind, <$cfg as KindTraits>::CARRIES_BOUNDARY_PARTICLES), )*]
                .iter()
                .filter(|(_, carries)| *carries)
                .map(|(kind, _)| format!("\"{kind}\""))
                .collect();
            format!("kind = {}", kinds.join(" | "))
        }

        /// Every registered kind's documented `[fluid]` keys, in the registry's order.
        pub fn fluid_keys() -> impl Iterator<Item = &'static crate::key_doc::KeyDoc> {
            std::iter::empty()
                $( .chain(<$cfg as KindTraits>::KEYS.iter()) )*
        }

        /// Every registered `kind` with the check of its table (for the case parser).
        pub(super) const FLUIDS: &[(&str, super::tagged::Check)] = &[
            $( ($kind, super::tagged::check::<$cfg>), )*
        ];
    };
}

fluid_registry! {
    /// Dissipative particle dynamics (Groot–Warren; from physical properties, Nguyen 2021).
    Dpd(crate::models::dpd::DpdCfg) = "dpd",
    /// The engine's two-pass test model: an isothermal SPH gas with summation density.
    SummationGas(crate::models::summation_gas::SummationGasCfg) = "summation_gas",
    /// Weakly compressible SPH: Newtonian, corotational Maxwell, Oldroyd-B, CONNFFESSIT
    /// dumbbells; walls and inclusions; MSPH derivatives.
    Sph(crate::models::sph::SphCfg) = "sph",
    /// The GENERIC (thermodynamically consistent) polymer fluid particle, Model B: SDPD with a
    /// conformation vector and thermal noise.
    GenericPolymer(crate::models::generic_polymer::GenericPolymerCfg) = "generic_polymer",
}
