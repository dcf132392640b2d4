//! Domain decomposition: slabs along one axis, halo (ghost) exchange and migration.
//!
//! Each rank owns the slab `[lo, hi)` of one axis and the whole box along the others, so a
//! Lees–Edwards image never changes which rank a ghost goes to (docs/architecture.md). The halo is
//! built in a fixed order — first the slab axis through the communicator (a serial run talks to
//! itself), then local images along the remaining periodic axes, gradient axis before flow axis —
//! so every rank count produces each ghost by the same arithmetic.

mod by_id;
mod halo;
mod migrate;
mod slab;

pub use by_id::{id_block, redistribute, sort_by_id};
pub use halo::HaloPlan;
pub use migrate::{migrate, send_leavers, wrap_owned};
pub use slab::Slab;

/// Message tags.
pub(crate) mod tags {
    pub const HALO_UP: u32 = 1;
    pub const HALO_DOWN: u32 = 2;
    pub const MIGRATE_UP: u32 = 3;
    pub const MIGRATE_DOWN: u32 = 4;
    pub const REDISTRIBUTE: u32 = 5;
    pub const HALO_FIELDS_UP: u32 = 6;
    pub const HALO_FIELDS_DOWN: u32 = 7;
}
