//! Test helpers: the reference vectors (from the shared test-support crate) and an independent
//! quadrature.
#![allow(dead_code)] // each test binary uses a different subset of these helpers

#[allow(unused_imports)] // each test binary uses a different subset
pub use liebayes_reference::{Value, fuzz, numbers, reference, relative_error};

pub mod quadrature;
