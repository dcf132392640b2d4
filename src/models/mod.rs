//! Physical models. Each file opens with its equations as implemented and their source.

pub mod bddfs;
pub mod dpd;
pub mod dumbbell_ensemble;
pub mod dumbbell_settings;
pub mod dumbbells;
pub mod fluid_model;
pub mod gather;
pub mod generic_polymer;
pub mod homogeneous_flow;
pub mod interface;
pub mod pair_loop;
pub mod pair_virial;
pub mod sph;
pub mod stress_profile;
pub mod summation_gas;

pub use fluid_model::{BuildModels, FluidModel};
pub use interface::{
    FieldKind, FieldSpec, ParticleModel, PassContext, PassOutput, PassSpec, StateBlowUp,
};
