//! # mesorheo
//!
//! An MPI domain-decomposed particle solver for polymeric and viscoelastic flows.
//!
//! Architecture (see `docs/architecture.md`). Module map, from the top down:
//!
//! - [`driver`] sets a case up (fresh, or restarted from a checkpoint with the fallback to
//!   older ones) and hands it to the one step loop of [`scene`], which runs every scene — the
//!   particle scene ([`scene::ParticleScene`]) and the homogeneous-flow scene ([`flow_scene`]) —
//!   with the same schedule of samples, snapshots, checkpoints and clean stops.
//! - [`sim::Simulation`] owns one rank's particle state and steps it: the integrator
//!   ([`integrators`]), migration and halo exchange ([`domain`], over a [`comm::Comm`]),
//!   neighbour lists ([`neighbour`]), and the models' pair passes with the ghost-field
//!   refreshes between them.
//! - [`models`]: every particle model implements [`models::ParticleModel`] (the guide to adding
//!   one is [`models::interface`]); every fluid model, registered once in
//!   [`config::registry`], owns its validation, time-step limits, `check` report, observables,
//!   blow-up detectors and build ([`models::FluidModel`]); pair passes gather ([`models::gather`]) or, for DPD, scatter
//!   ([`models::pair_loop`]) into exact sums ([`fixed_sum`]). Models: DPD, SPH with walls
//!   ([`models::sph`], its kernels in [`models::sph::kernels`]), dumbbell ensembles, and the
//!   engine's test model. [`species`] gives walls their boundary particles; [`analytic`] holds
//!   the series solutions the start-up references compare with.
//! - [`facade`]: the entry points of [`sim::Simulation`] and of the homogeneous-flow ensembles
//!   that other crates (tests, benchmarks, examples) call, compiled once here for D = 2 and 3
//!   (release builds do not share generic code between crates: each test binary used to
//!   compile the whole engine again).
//! - [`config`] parses and validates case files (it knows the models' parameter types; no model
//!   imports it: models see a case through [`models::fluid_model::CaseView`]); [`diagnostics`]
//!   and [`summary`] average and report; [`output`] writes checkpoints and snapshots;
//!   [`check`] says what a case costs and whether its time step is safe, [`capacity`] whether
//!   it fits a rank count and a node.
//!
//! Dependencies run one way (no cycle among top-level modules; `tools/module_graph.py
//! --check` in `./run test`): config → models → engine (domain, halo, neighbour, sums,
//! particles) ← sim/scene/driver ← commands.
//!
//! Physics never sees MPI; the same code runs on one rank talking to itself, on P in-process
//! ranks, and under `mpirun`.

// Index loops over the D components of `[f64; D]` arrays read like the equations they implement
// (and compile to the same code as iterator chains).
#![allow(clippy::needless_range_loop)]

pub mod analytic;
pub mod capacity;
pub mod check;
pub mod comm;
pub mod config;
pub mod correlator;
pub mod counting_sort;
pub mod diagnostics;
pub mod domain;
pub mod dpd_parameters;
pub mod driver;
pub mod error;
pub mod estimate;
pub mod facade;
pub mod fixed_sum;
pub mod flow_scene;
pub mod geometry;
pub mod green_kubo;
pub mod integrators;
pub mod key_doc;
pub mod models;
pub mod neighbour;
pub mod observable;
pub mod observables_csv;
#[cfg(feature = "hdf5")]
pub mod output;
pub mod particles;
pub mod rigid_bodies;
pub mod rng;
pub mod scene;
pub mod sim;
pub mod simd;
pub mod spans;
pub mod species;
pub mod stability_map;
pub mod study;
pub mod summary;
pub mod tcaf_fit;
pub mod transverse_current;
pub mod workers;
