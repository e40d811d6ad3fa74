//! The error type of the operators crate.

use liebayes_densities::DensityError;
use liebayes_manifolds::ManifoldError;
use liebayes_manifolds::Readable;

/// The largest number of elements any container of the crate holds: particles, grid cells,
/// resampled draws, recorded smoother steps, and the degrees of freedom of an average-NEES band.
/// 2³⁰ = 1 073 741 824; a size above it is refused with [`OperatorError::TooLarge`] before anything
/// is allocated, and a size below it whose buffers cannot be allocated is refused the same way (the
/// allocation is tried, never assumed).
pub const MAX_ELEMENTS: usize = 1 << 30;

/// Why a propagation or a conditioning step could not be carried out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OperatorError {
    /// A model parameter or an input is NaN or infinite.
    #[error("{what} is {}: it must be a finite number", Readable(*.value))]
    NonFinite {
        /// The parameter or input.
        what: &'static str,
        /// The value given.
        value: f64,
    },
    /// A model parameter lies outside its range.
    #[error("{what} is {}, outside its range {range}", Readable(*.value))]
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
    #[error("not closed: {what} (measure of the violation: {})", Readable(*.value))]
    NotClosed {
        /// Why, and what to use instead.
        what: &'static str,
        /// How far the model is from the closed case (relative).
        value: f64,
    },
    /// The resulting density is not valid (for example a covariance that lost positive definiteness).
    #[error("the resulting density is invalid: {0}")]
    Density(#[from] DensityError),
    /// A model returned a point with a NaN or infinite coordinate (checked with
    /// [`Manifold::is_finite`](liebayes_manifolds::Manifold::is_finite)); the step is refused.
    #[error(
        "{what} is not finite (a coordinate is NaN or infinite): check the model for an overflow \
         or a division by zero"
    )]
    NonFinitePoint {
        /// Which point, and which model produced it.
        what: &'static str,
    },
    /// A size is above [`MAX_ELEMENTS`], or its buffers cannot be allocated.
    #[error(
        "{what} is {value}: the largest accepted is {max}, and the memory for it must be available; \
         use a smaller size"
    )]
    TooLarge {
        /// The size.
        what: &'static str,
        /// The value given.
        value: usize,
        /// The largest accepted.
        max: usize,
    },
    /// A model's state was in use by another step: a process that steps a container through the
    /// model it is itself part of (re-entrantly).
    #[error("{what} is already in use by a step: give the inner step its own model")]
    InUse {
        /// What was in use.
        what: &'static str,
    },
    /// A filter asked for an estimate or an update before it has what it starts from (an attitude
    /// filter before its first sample).
    #[error("{what} is not initialised yet: it needs {needs}")]
    NotReady {
        /// The filter.
        what: &'static str,
        /// What initialises it.
        needs: &'static str,
    },
    /// A one-pass linearised update (EKF or UKF) whose correction went beyond the reach of its
    /// linearisation: the reading the model predicts at the updated mean missed the linear
    /// prediction by `statistic` (squared, in the posterior's own standard deviations of the
    /// reading), above [`LINEARISATION_LIMIT`](crate::ekf::LINEARISATION_LIMIT). The state is kept
    /// as it was.
    #[error(
        "the one-pass update's linearisation failed: {}; condition with the iterated EKF or \
         UKF (IteratedEkf, IteratedUkf), which relinearise at their estimate",
        Miss(*.statistic)
    )]
    Linearisation {
        /// The miss q of [`LINEARISATION_LIMIT`](crate::ekf::LINEARISATION_LIMIT); infinite when
        /// the model is not finite at the updated mean.
        statistic: f64,
    },
    /// A computation on the manifold failed, with what the step was computing: a weighted mean that
    /// did not converge (sigma points or particles spread over more than half the injectivity radius)
    /// or whose weights are degenerate.
    #[error("{what}: {source}")]
    Manifold {
        /// What the step was computing.
        what: &'static str,
        /// The manifold layer's error.
        source: ManifoldError,
    },
}

/// How far a one-pass update's posterior missed its own reading, as [`OperatorError::Linearisation`]
/// words it.
struct Miss(f64);

impl std::fmt::Display for Miss {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_finite() {
            write!(
                f,
                "at the updated mean the reading's residual is {} squared standard deviations off \
                 what the linearised model predicted (at most {} is kept)",
                Readable(self.0),
                Readable(crate::ekf::LINEARISATION_LIMIT)
            )
        } else {
            f.write_str(
                "the measurement model is not finite at the updated mean (the correction left its \
                 domain)",
            )
        }
    }
}

/// Checks a size against [`MAX_ELEMENTS`].
pub(crate) fn check_size(what: &'static str, value: usize) -> Result<(), OperatorError> {
    if value > MAX_ELEMENTS {
        return Err(OperatorError::TooLarge {
            what,
            value,
            max: MAX_ELEMENTS,
        });
    }
    Ok(())
}

/// Makes room for `additional` more elements in `buffer`, refusing sizes above [`MAX_ELEMENTS`] and
/// allocations that fail (instead of aborting).
pub(crate) fn reserve<T>(
    buffer: &mut Vec<T>,
    what: &'static str,
    additional: usize,
) -> Result<(), OperatorError> {
    let too_large = OperatorError::TooLarge {
        what,
        value: buffer.len().saturating_add(additional),
        max: MAX_ELEMENTS,
    };
    if buffer.len().saturating_add(additional) > MAX_ELEMENTS {
        return Err(too_large);
    }
    buffer.try_reserve(additional).map_err(|_| too_large)
}

/// An empty vector with room for `capacity` elements, as [`reserve`].
pub(crate) fn with_capacity<T>(
    what: &'static str,
    capacity: usize,
) -> Result<Vec<T>, OperatorError> {
    let mut buffer = Vec::new();
    reserve(&mut buffer, what, capacity)?;
    Ok(buffer)
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
