//! The error type of the densities crate.

use liebayes_manifolds::ManifoldError;
use liebayes_manifolds::Readable;

/// Why parameters or arguments do not define a density or a value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DensityError {
    /// A parameter is NaN or infinite.
    #[error("{what} is {}: it must be a finite number", Readable(*.value))]
    NonFinite {
        /// The parameter.
        what: &'static str,
        /// The value given.
        value: f64,
    },
    /// A parameter lies outside the range where the density or function is defined.
    #[error("{what} is {}, outside its range {range}", Readable(*.value))]
    OutOfRange {
        /// The parameter.
        what: &'static str,
        /// The value given.
        value: f64,
        /// The valid range, in words.
        range: &'static str,
    },
    /// A point or parameter on a manifold was invalid.
    #[error(transparent)]
    Manifold(#[from] ManifoldError),
}

/// Checks that `value` is finite.
pub(crate) fn finite(what: &'static str, value: f64) -> Result<f64, DensityError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(DensityError::NonFinite { what, value })
    }
}
