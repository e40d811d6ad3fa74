#![doc = include_str!("../README.md")]
//!
//! ## Crates
//!
//! * [`manifolds`]: spaces and groups (SO(2), SO(3), SU(2), S², Rⁿ) with exact exp/log and right Jacobians.
//! * [`densities`]: probability densities on those spaces and their special functions.
//! * [`operators`]: propagate, condition, and filters as generic algorithms.
//! * [`filters`]: the applications.

pub use liebayes_densities as densities;
pub use liebayes_filters as filters;
pub use liebayes_manifolds as manifolds;
pub use liebayes_operators as operators;
