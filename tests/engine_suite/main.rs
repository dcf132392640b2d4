//! The engine, DPD and dumbbell tests in one test binary (`cargo test --release --test
//! engine_suite`; one module per former file). One crate instantiates the engine's generic code
//! once instead of once per file: the test build is the larger part of `./run test`.

#[path = "../common/mod.rs"]
mod common;

mod bddfs;
mod colloids;
mod determinism;
mod dpd_physics;
mod dumbbell_particles;
mod dumbbell_rheology;
mod dumbbells;
mod flow_scenes;
mod generic_polymer;
mod model_layer;
mod neighbours;
mod restart;
mod species;
