//! The scalar types the crate is generic over.

use crate::constants::Thresholds;
use nalgebra::{RealField, SVector};

/// A real scalar: `f64` or `f32`.
///
/// Everything in the crate is generic over `T: Real`. The trait adds to nalgebra's [`RealField`]
/// the crate's [`Thresholds`] and exact conversions from and to `f64` for constants and messages.
pub trait Real: RealField + Copy + Default + Thresholds {
    /// The scalar nearest to `x` (a constant written in f64).
    fn lit(x: f64) -> Self;
    /// The value as an `f64` (for error messages and reports).
    fn to_f64(self) -> f64;
    /// The largest finite value.
    fn max_finite() -> Self;
    /// The smallest positive normal value.
    fn min_positive() -> Self;
}

impl Real for f64 {
    #[inline]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn max_finite() -> Self {
        f64::MAX
    }
    #[inline]
    fn min_positive() -> Self {
        f64::MIN_POSITIVE
    }
}

impl Real for f32 {
    #[inline]
    #[allow(clippy::cast_possible_truncation)]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    #[inline]
    fn max_finite() -> Self {
        f32::MAX
    }
    #[inline]
    fn min_positive() -> Self {
        f32::MIN_POSITIVE
    }
}

/// Euclidean norm that neither underflows for tiny nor overflows for huge components (it is infinite
/// only when the norm itself exceeds the largest finite value, and NaN when a component is NaN).
/// One check on the fast path.
#[inline]
pub(crate) fn stable_norm<T: Real, const N: usize>(v: &SVector<T, N>) -> T {
    let n2 = v.norm_squared();
    if n2.is_finite() && n2 > T::MIN_DIRECTION_NORM * T::MIN_DIRECTION_NORM {
        n2.sqrt()
    } else if n2.to_f64().is_nan() {
        // A NaN component (nalgebra's `amax` below would skip it unless it came last).
        n2
    } else {
        let scale = v.amax();
        if scale == T::zero() {
            T::zero()
        } else {
            (v / scale).norm() * scale
        }
    }
}
