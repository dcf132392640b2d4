//! # mesorheo
//!
//! An MPI domain-decomposed particle solver for polymeric and viscoelastic flows.
//!
//! Architecture (see `../shared/DESIGN.md`): a case file ([`config`]) describes a scene; the
//! [`sim::Simulation`] owns the state of one rank and steps it: migration and halo exchange
//! ([`domain`], over a [`comm::Comm`]), neighbour lists ([`neighbour`]), models
//! ([`models`]), integration, and diagnostics ([`diagnostics`]). Physics never sees MPI; the
//! same code runs on one rank talking to itself, on P in-process ranks, and under `mpirun`.

// Index loops over the D components of `[f64; D]` arrays read like the equations they implement
// (and compile to the same code as iterator chains).
#![allow(clippy::needless_range_loop)]

pub mod check;
pub mod comm;
pub mod config;
pub mod diagnostics;
pub mod domain;
pub mod driver;
pub mod fixed_sum;
pub mod flow_scene;
pub mod geometry;
pub mod integrators;
pub mod models;
pub mod neighbour;
#[cfg(feature = "hdf5")]
pub mod output;
pub mod particles;
pub mod rng;
pub mod scene;
pub mod sim;
pub mod simd;
pub mod stability;
pub mod summary;
pub mod workers;
