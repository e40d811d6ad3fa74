//! The error type of the operators crate.

use liebayes_densities::DensityError;

/// Why a propagation or a conditioning step could not be carried out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OperatorError {
    /// A model parameter or an input is NaN or infinite.
    #[error("{what} is {value}: it must be a finite number")]
    NonFinite {
        /// The parameter or input.
        what: &'static str,
        /// The value given.
        value: f64,
    },
    /// A model parameter lies outside its range.
    #[error("{what} is {value}, outside its range {range}")]
    OutOfRange {
        /// The parameter.
        what: &'static str,
        /// The value given.
        value: f64,
        /// The valid range, in words.
        range: &'static str,
    },
    /// A covariance is not symmetric positive definite (given so, or after an update that lost it).
    #[error("{what} is not symmetric positive definite")]
    NotPositiveDefinite {
        /// The matrix, and what to check.
        what: &'static str,
    },
    /// An exact closed-form step was asked of a model under which the family is not closed.
    #[error("not closed: {what} (measure of the violation: {value})")]
    NotClosed {
        /// Why, and what to use instead.
        what: &'static str,
        /// How far the model is from the closed case (relative).
        value: f64,
    },
    /// The resulting density is not valid (for example a covariance that lost positive definiteness).
    #[error("the resulting density is invalid: {0}")]
    Density(#[from] DensityError),
}

/// Checks that every value is finite.
pub(crate) fn all_finite<'a>(
    what: &'static str,
    values: impl IntoIterator<Item = &'a f64>,
) -> Result<(), OperatorError> {
    match values.into_iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(OperatorError::NonFinite { what, value }),
        None => Ok(()),
    }
}
