//! Every numerical threshold of the crate, in one place.
//!
//! Each threshold is an associated constant of [`Thresholds`], implemented for `f64` and `f32`, so
//! that generic code picks the value fitting its scalar type. The values and the reasoning behind them:
//!
//! | constant | f64 | f32 | meaning |
//! |---|---|---|---|
//! | [`SERIES_ANGLE`](Thresholds::SERIES_ANGLE) | 1e-2 | 1e-1 | below this rotation angle, the Jacobian coefficients use their Taylor series |
//! | [`EXP_SERIES_ANGLE`](Thresholds::EXP_SERIES_ANGLE) | 0.2 | 0.2 | below this rotation angle, the rotation exp takes cos(θ/2) and sin(θ/2)/(θ/2) from their Taylor series (to the h⁸ term, h = θ/2) instead of calling `sin_cos` |
//! | [`SINE_DEFECT_SERIES_ANGLE`](Thresholds::SINE_DEFECT_SERIES_ANGLE) | 1 | 1 | below this angle the SE(2)/SE(3) coupling coefficients take θ − sin θ from its Taylor series (nine terms) instead of the difference, which loses eps θ / (θ − sin θ) relative (12 eps at 1, 6e4 eps at 1e-2) |
//! | [`LARGE_COORDINATE`](Thresholds::LARGE_COORDINATE) | 1e300 | 1e34 | translations with a component above this are scaled down before the products of exp, log and the pose Jacobians, and the results saturate at the largest finite value (no overflow into NaN) |
//! | [`UNIT_NORM_TOLERANCE`](Thresholds::UNIT_NORM_TOLERANCE) | 1e-9 | 1e-5 | a quaternion, unit complex number or unit vector is accepted when abs(norm - 1) is at most this |
//! | [`UNIT_ROUNDING_TOLERANCE`](Thresholds::UNIT_ROUNDING_TOLERANCE) | 32 eps = 7.1e-15 | 32 eps = 3.8e-6 | an accepted quaternion, unit complex number or unit vector is stored as given when abs(norm² - 1) is at most this (unit to rounding), and as v / abs(v) otherwise |
//! | [`ORTHONORMAL_TOLERANCE`](Thresholds::ORTHONORMAL_TOLERANCE) | 1e-9 | 1e-5 | a rotation matrix is accepted when every entry of R^T R - I, and det R - 1, is at most this in absolute value |
//! | [`MIN_DIRECTION_NORM`](Thresholds::MIN_DIRECTION_NORM) | 1e-150 | 1e-18 | the normalising constructors refuse vectors shorter than this: their direction is noise |
//! | [`MEAN_TOLERANCE`](Thresholds::MEAN_TOLERANCE) | 1e-10 | 1e-5 | default convergence tolerance of [`weighted_mean`](crate::weighted_mean): the tangent norm of the last Gauss-Newton step |
//! | [`MEAN_MAX_ITERATIONS`] | 50 | 50 | default iteration bound of [`weighted_mean`](crate::weighted_mean) |
//! | [`MEAN_ITERATION_LIMIT`] | 10 000 | 10 000 | the largest iteration bound [`MeanSettings::new`](crate::MeanSettings::new) accepts |
//! | [`POLAR_MAX_SWEEPS`] | 100 | 100 | bound on the Jacobi sweeps of [`So3::from_matrix_orthonormalized`](crate::So3::from_matrix_orthonormalized) |
//!
//! Why the series thresholds are safe: the series are kept to the theta^4 term, so their truncation
//! error is below theta^6 / 5040 relative (for the worst coefficient), that is below 2e-16 at 1e-2 in
//! f64 and below 2e-10 at 1e-1 in f32. Above the threshold the closed forms lose at most
//! eps / theta^2 relative in the coefficients of hat(v)^2, which multiply a matrix of size theta^2, so
//! the Jacobians keep an absolute error of a few eps.
//!
//! Why the exp threshold: the rotation exp keeps five terms of each series in h² (h = θ/2 below
//! 0.1), so the first omitted term is below h^10 / 10! = 2.8e-17 (cosine) and h^10 / 11! (the sine
//! quotient), under half an ulp of their values near 1 in f64. The threshold is wide on purpose: a
//! strapdown integrator's per-sample turn (|ω| Δt, below 0.2 up to 57 rad/s at 285 Hz) stays on the
//! series branch, so the branch is predicted and no `sin_cos` call is made.
//!
//! Why the mean tolerance: 1e-10 in f64 is far below any angle a filter resolves, and 1e-5 in f32
//! (about 80 eps) is reached by the compact groups with room to spare. The mean converges linearly
//! near its fixed point, with a rate that shrinks with the spread of the samples (one step is exact on
//! R^n), so the remaining error after a step below the tolerance is a fraction of it. Where rounding
//! keeps the steps above the tolerance (coordinates far from the origin of R^n, eps |x| > 1e-10),
//! the iteration ends when the step stalls (see [`weighted_mean`](crate::weighted_mean)).
//!
//! Why the sweep bound: cyclic Jacobi converges quadratically once the columns are nearly orthogonal,
//! and a 3x3 matrix takes 3 to 6 sweeps. A singular matrix takes longer: a column in the span of
//! another loses a factor eps per sweep until it underflows, at most about 2 * 1074 / 52 = 41 sweeps
//! in f64 (and 2 * 149 / 23 = 13 in f32); the bound of 100 leaves room for both and only keeps the
//! loop finite.

/// The numerical thresholds of the crate for one scalar type (see the [module docs](self)).
pub trait Thresholds: Sized {
    /// Rotation angle below which the Jacobian coefficients switch to their Taylor series.
    const SERIES_ANGLE: Self;
    /// Rotation angle below which the rotation exp takes its half-angle cosine and sine quotient
    /// from their Taylor series (five terms each) rather than from `sin_cos`.
    const EXP_SERIES_ANGLE: Self;
    /// Rotation angle below which the coupling coefficients of SE(2) and SE(3) take θ − sin θ from its
    /// Taylor series rather than the difference.
    ///
    /// The difference `θ − sin θ` of two rounded numbers of size θ has an absolute error of about
    /// `eps θ`, that is `eps θ / (θ − sin θ) ≈ 6 eps / θ²` relative: 12 eps at 1, but 6e4 eps at 1e-2.
    /// The pose Jacobians multiply `(θ − sin θ)/θ²` by the translation, so the difference alone would
    /// cost `eps |ρ| / θ` absolute just above [`SERIES_ANGLE`](Self::SERIES_ANGLE). Nine terms of the
    /// series reach 1e-19 relative at 1 (the first omitted term is θ¹⁸/21!).
    const SINE_DEFECT_SERIES_ANGLE: Self;
    /// Largest translation component that the products of the pose formulas (exp, log, Jr, Jr⁻¹ of
    /// SE(2) and SE(3)) take directly.
    ///
    /// Their coefficient matrices have entries below 30 in size and at most about ten terms per entry,
    /// so below this bound no product overflows (3e302 in f64, 3e36 in f32). Above it the translation
    /// is divided by its largest component first and the result, scaled back, saturates at the largest
    /// finite value: finite input never produces NaN.
    const LARGE_COORDINATE: Self;
    /// Largest accepted `abs(norm - 1)` for quaternions, unit complex numbers and unit vectors.
    const UNIT_NORM_TOLERANCE: Self;
    /// Largest `abs(norm² - 1)` of a value that the checked constructors store as given; a value
    /// accepted with a larger deviation (up to [`UNIT_NORM_TOLERANCE`](Self::UNIT_NORM_TOLERANCE))
    /// is stored as `v / |v|`.
    ///
    /// 32 eps lies above the rounding of `v / |v|` itself (at most about 11 eps in `norm²` for four
    /// components), so normalising is idempotent: a stored value is read back unchanged, and the
    /// serde round trip stays exact. Below it the deviation is rounding, which products of unit
    /// values keep at n eps after n steps; above it a deviation of 1e-9 kept as given would grow
    /// geometrically under composition (30 squarings of a quaternion of norm 1 + 9e-10 gave norm
    /// 2.6).
    const UNIT_ROUNDING_TOLERANCE: Self;
    /// Largest accepted entry of `R^T R - I` and of `det R - 1` for rotation matrices.
    const ORTHONORMAL_TOLERANCE: Self;
    /// Smallest norm the normalising constructors accept.
    const MIN_DIRECTION_NORM: Self;
    /// Default convergence tolerance of the weighted mean (tangent norm of the last step).
    const MEAN_TOLERANCE: Self;
}

/// Default iteration bound of the weighted mean.
pub const MEAN_MAX_ITERATIONS: usize = 50;

/// The largest iteration bound of the weighted mean a caller may set: Gauss-Newton converges
/// quadratically near the mean, so a bound beyond this only lets a diverging run spin.
pub const MEAN_ITERATION_LIMIT: usize = 10_000;

/// Bound on the Jacobi sweeps behind [`So3::from_matrix_orthonormalized`](crate::So3::from_matrix_orthonormalized).
pub const POLAR_MAX_SWEEPS: usize = 100;

impl Thresholds for f64 {
    const SERIES_ANGLE: f64 = 1e-2;
    const EXP_SERIES_ANGLE: f64 = 0.2;
    const SINE_DEFECT_SERIES_ANGLE: f64 = 1.0;
    const LARGE_COORDINATE: f64 = 1e300;
    const UNIT_NORM_TOLERANCE: f64 = 1e-9;
    const UNIT_ROUNDING_TOLERANCE: f64 = 32.0 * f64::EPSILON;
    const ORTHONORMAL_TOLERANCE: f64 = 1e-9;
    const MIN_DIRECTION_NORM: f64 = 1e-150;
    const MEAN_TOLERANCE: f64 = 1e-10;
}

impl Thresholds for f32 {
    const SERIES_ANGLE: f32 = 1e-1;
    const EXP_SERIES_ANGLE: f32 = 0.2;
    const SINE_DEFECT_SERIES_ANGLE: f32 = 1.0;
    const LARGE_COORDINATE: f32 = 1e34;
    const UNIT_NORM_TOLERANCE: f32 = 1e-5;
    const UNIT_ROUNDING_TOLERANCE: f32 = 32.0 * f32::EPSILON;
    const ORTHONORMAL_TOLERANCE: f32 = 1e-5;
    const MIN_DIRECTION_NORM: f32 = 1e-18;
    const MEAN_TOLERANCE: f32 = 1e-5;
}
