//! Property-testing support, behind the `proptest` feature: strategies for every space (uniform
//! elements and curated edge cases) and the generic law suite the crate tests itself with.
//!
//! A user checking their own code draws elements from [`strategies`]; a user adding a group implements
//! [`LawSubject`] for it and runs the functions of [`laws`] on it, exactly as `tests/laws.rs` does for
//! the built-in spaces.

pub mod laws;
pub mod strategies;

pub use laws::{LawSubject, Tolerance};
