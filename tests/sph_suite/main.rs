//! The SPH, MSPH and CONNFFESSIT flow tests in one test binary (`cargo test --release --test
//! sph_suite`; one module per former file). One crate instantiates the engine's generic code
//! once instead of once per file: the test build is the larger part of `./run test`.

#[path = "../common/mod.rs"]
mod common;

mod bddfs_connffessit;
mod connffessit;
mod msph_channel;
mod sph_channel;
mod sph_inclusion;
mod sph_lammps;
mod sph_maxwell;
