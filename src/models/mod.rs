//! Physical models. Each file opens with its equations as implemented and their source.

pub mod dpd;
pub mod pair_loop;
