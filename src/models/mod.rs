//! Physical models. Each file opens with its equations as implemented and their source.

pub mod dpd;
pub mod dumbbells;
pub mod homogeneous_flow;
pub mod pair_loop;
