//! The error type of the crate, and the checks that produce it.

use crate::real::Real;
use nalgebra::{SMatrix, SVector};

/// A number as the library's messages show it: plainly from 1e-4 to 1e6 in magnitude (and 0),
/// in scientific notation outside (so that 1e200 reads `1e200`, not 201 digits). Every crate's error
/// messages format their values with it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Readable(pub f64);

impl std::fmt::Display for Readable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        if v == 0.0 || !v.is_finite() || (1e-4..1e6).contains(&v.abs()) {
            write!(f, "{v}")
        } else {
            write!(f, "{v:e}")
        }
    }
}

/// Why raw numbers do not describe a point of a manifold.
///
/// Every message says what is wrong and by how much, and what to do about it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ManifoldError {
    /// A component is NaN or infinite.
    #[error("{what} has a non-finite component ({}): every component must be a finite number", Readable(*.value))]
    NonFinite {
        /// What was being constructed.
        what: &'static str,
        /// The offending component.
        value: f64,
    },
    /// A vector that must have unit norm does not.
    #[error(
        "{what} must have unit norm, but its norm is {norm} (|norm - 1| = {deviation:e} exceeds the \
         tolerance {tolerance:e}); normalise it first or use {hint}"
    )]
    NotUnit {
        /// What was being constructed.
        what: &'static str,
        /// The norm found.
        norm: f64,
        /// `abs(norm - 1)`.
        deviation: f64,
        /// The accepted deviation.
        tolerance: f64,
        /// The constructor that normalises.
        hint: &'static str,
    },
    /// A vector is too short to define a direction.
    #[error(
        "{what} has norm {norm:e}, below {minimum:e}: it is too close to zero to define a direction"
    )]
    ZeroVector {
        /// What was being constructed.
        what: &'static str,
        /// The norm found.
        norm: f64,
        /// The smallest accepted norm.
        minimum: f64,
    },
    /// A matrix that must be orthonormal is not.
    #[error(
        "the rotation matrix is not orthonormal: the largest entry of |R^T R - I| is {deviation:e}, \
         above the tolerance {tolerance:e}; use from_matrix_orthonormalized to project it onto the \
         nearest rotation"
    )]
    NotOrthonormal {
        /// The largest absolute entry of `R^T R - I`.
        deviation: f64,
        /// The accepted deviation.
        tolerance: f64,
    },
    /// A matrix is orthonormal but a reflection, or (when orthonormalising) rank-deficient.
    #[error(
        "the matrix has determinant {det}, not +1: it is a reflection or degenerate, not a rotation"
    )]
    NotProperRotation {
        /// The determinant found.
        det: f64,
    },
    /// A homogeneous matrix whose last rows are not those of the identity (`[0, …, 0, 1]` for a
    /// rigid motion, `[0, 0, 0, 1, 0]` and `[0, 0, 0, 0, 1]` for an extended pose).
    #[error(
        "the bottom rows of a homogeneous matrix must be those of the identity ([0, ..., 0, 1] for a \
         rigid motion [[R, t], [0, 1]], [0, 0, 0, 1, 0] and [0, 0, 0, 0, 1] for an extended pose \
         [[R, v, p], [0, 1, 0], [0, 0, 1]]), but they deviate by {deviation:e}, above the tolerance \
         {tolerance:e}: the matrix is not an element of the group; pass the matrix in that form or \
         build the element from its parts with from_parts"
    )]
    NotHomogeneous {
        /// The largest absolute deviation of the bottom rows from those of the identity.
        deviation: f64,
        /// The accepted deviation.
        tolerance: f64,
    },
    /// A slice had the wrong number of components.
    #[error("{what} needs {expected} components, got {got}")]
    WrongLength {
        /// What was being constructed.
        what: &'static str,
        /// The number of components needed.
        expected: usize,
        /// The number given.
        got: usize,
    },
    /// The Jacobi sweeps behind an orthonormalisation stopped at their bound.
    #[error(
        "the SVD of the matrix did not converge in {sweeps} Jacobi sweeps, so it has no nearest \
         rotation to report; check the matrix for entries that are not meant to be there"
    )]
    PolarNotConverged {
        /// The bound that was reached.
        sweeps: usize,
    },
    /// A setting is outside its valid range.
    #[error("{what} is {}, outside its valid range {range}", Readable(*.value))]
    OutOfRange {
        /// The setting.
        what: &'static str,
        /// The value given.
        value: f64,
        /// The valid range.
        range: &'static str,
    },
    /// A computation over samples was given none.
    #[error("{what} needs at least one sample, got none")]
    EmptyInput {
        /// What was being computed.
        what: &'static str,
    },
    /// A weight is NaN or infinite.
    #[error(
        "weight {index} is {value}: every weight must be a finite number (negative weights are \
         allowed, as long as the weights have a non-zero sum)"
    )]
    NonFiniteWeight {
        /// The position of the weight in the samples.
        index: usize,
        /// The weight.
        value: f64,
    },
    /// The weights cannot be normalised: their sum is not finite or is zero up to rounding.
    #[error(
        "the weights sum to {sum:e} (their absolute values to {absolute_sum:e}): the sum must be \
         finite and larger in magnitude than its rounding error, n eps sum|w_i| (n weights, eps the \
         scalar's machine epsilon), so that the weights can be normalised"
    )]
    DegenerateWeights {
        /// The sum of the weights.
        sum: f64,
        /// The sum of their absolute values.
        absolute_sum: f64,
    },
    /// The Gauss-Newton iteration of a weighted mean did not reach its tolerance.
    #[error(
        "the weighted mean did not converge in {iterations} iterations: the last step has \
         tangent norm {last_step:e}, above the tolerance {tolerance:e}. The mean is unique when the \
         samples, with positive weights, lie in a ball of radius below half the injectivity radius; \
         otherwise start nearer the samples or allow more iterations"
    )]
    MeanNotConverged {
        /// The iterations done (the bound of the settings).
        iterations: usize,
        /// The tangent norm of the last step (infinite or NaN if the step overflowed).
        last_step: f64,
        /// The tolerance of the settings.
        tolerance: f64,
    },
}

/// Checks that every value is finite.
pub(crate) fn check_finite<'a, T: Real>(
    what: &'static str,
    values: impl IntoIterator<Item = &'a T>,
) -> Result<(), ManifoldError> {
    match values.into_iter().find(|v| !v.is_finite()) {
        Some(v) => Err(ManifoldError::NonFinite {
            what,
            value: v.to_f64(),
        }),
        None => Ok(()),
    }
}

/// Checks that a finite vector has unit norm within [`Thresholds::UNIT_NORM_TOLERANCE`](crate::constants::Thresholds).
pub(crate) fn check_unit<T: Real, const N: usize>(
    what: &'static str,
    v: &SVector<T, N>,
    hint: &'static str,
) -> Result<(), ManifoldError> {
    check_finite(what, v.iter())?;
    let norm = v.norm();
    let deviation = (norm - T::one()).abs();
    if deviation > T::UNIT_NORM_TOLERANCE {
        return Err(ManifoldError::NotUnit {
            what,
            norm: norm.to_f64(),
            deviation: deviation.to_f64(),
            tolerance: T::UNIT_NORM_TOLERANCE.to_f64(),
            hint,
        });
    }
    Ok(())
}

/// [`check_unit`], then the value to store: `v` itself when it is unit to rounding
/// ([`unit_to_rounding`]), else `v / |v|`.
pub(crate) fn checked_unit<T: Real, const N: usize>(
    what: &'static str,
    v: &SVector<T, N>,
    hint: &'static str,
) -> Result<SVector<T, N>, ManifoldError> {
    check_unit(what, v, hint)?;
    Ok(unit_to_rounding(v))
}

/// `v` when `abs(|v|² − 1)` is at most
/// [`UNIT_ROUNDING_TOLERANCE`](crate::constants::Thresholds::UNIT_ROUNDING_TOLERANCE) (unit to
/// rounding), else `v / |v|`. Idempotent: `v / |v|` is unit to rounding, so a value normalised once
/// is kept bit for bit. For a vector near unit length (no scaling needed for its norm).
pub(crate) fn unit_to_rounding<T: Real, const N: usize>(v: &SVector<T, N>) -> SVector<T, N> {
    if (v.norm_squared() - T::one()).abs() <= T::UNIT_ROUNDING_TOLERANCE {
        *v
    } else {
        v / v.norm()
    }
}

/// Returns `v / |v|` for a finite vector at least [`Thresholds::MIN_DIRECTION_NORM`](crate::constants::Thresholds) long.
pub(crate) fn normalized<T: Real, const N: usize>(
    what: &'static str,
    v: &SVector<T, N>,
) -> Result<SVector<T, N>, ManifoldError> {
    check_finite(what, v.iter())?;
    // Scale first so that neither tiny nor huge components under- or overflow in the norm.
    let scale = v.amax();
    let too_short = |norm: T| ManifoldError::ZeroVector {
        what,
        norm: norm.to_f64(),
        minimum: T::MIN_DIRECTION_NORM.to_f64(),
    };
    if scale == T::zero() {
        return Err(too_short(T::zero()));
    }
    let scaled = v / scale;
    let scaled_norm = scaled.norm();
    let norm = scale * scaled_norm;
    if norm < T::MIN_DIRECTION_NORM {
        return Err(too_short(norm));
    }
    Ok(scaled / scaled_norm)
}

/// Checks that a square matrix is a rotation: finite, orthonormal and with determinant `det` = +1.
pub(crate) fn check_rotation_matrix<T: Real, const N: usize>(
    m: &SMatrix<T, N, N>,
    det: T,
) -> Result<(), ManifoldError> {
    check_finite("rotation matrix", m.iter())?;
    let deviation = (m.transpose() * m - SMatrix::<T, N, N>::identity()).amax();
    if deviation > T::ORTHONORMAL_TOLERANCE {
        return Err(ManifoldError::NotOrthonormal {
            deviation: deviation.to_f64(),
            tolerance: T::ORTHONORMAL_TOLERANCE.to_f64(),
        });
    }
    if (det - T::one()).abs() > T::ORTHONORMAL_TOLERANCE {
        return Err(ManifoldError::NotProperRotation { det: det.to_f64() });
    }
    Ok(())
}
