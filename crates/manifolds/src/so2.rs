//! [`So2`]: rotations of the plane.

use crate::error::{
    ManifoldError, check_finite, check_rotation_matrix, checked_unit, normalized, unit_to_rounding,
};
use crate::lie_group::{GroupAction, LieGroup, impl_manifold_for_group};
use crate::manifold::{Jacobian, Tangent};
use crate::pose::saturated;
use crate::real::Real;
use nalgebra::{Complex, Matrix1, Matrix2, Rotation2, UnitComplex, Vector1, Vector2};

/// `angle` wrapped to [−π, π): `angle − 2πk` for the integer k that puts it there (the azimuth
/// and bearing convention; [`So2::angle`] returns (−π, π] instead). Exact for |angle| < 3π (one
/// subtraction of 2π, rounded once), `rem_euclid` beyond; NaN for a non-finite angle.
///
/// # Example
/// ```
/// use liebayes_manifolds::wrap_angle;
/// use std::f64::consts::PI;
/// assert_eq!(wrap_angle(PI), -PI);
/// assert!((wrap_angle(7.0) - (7.0 - 2.0 * PI)).abs() < 1e-15);
/// assert_eq!(wrap_angle(-0.5), -0.5);
/// ```
pub fn wrap_angle(angle: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    // The common cases without a floating-point remainder (a hot path of particle filters).
    if (-PI..PI).contains(&angle) {
        return angle;
    }
    if (PI..3.0 * PI).contains(&angle) {
        return angle - TAU;
    }
    if (-3.0 * PI..-PI).contains(&angle) {
        return angle + TAU;
    }
    let r = (angle + PI).rem_euclid(TAU) - PI;
    // rem_euclid may round up to TAU for tiny negative inputs.
    if r >= PI { r - TAU } else { r }
}

/// A rotation of the plane, an element of SO(2), stored as a unit complex number `cos θ + i sin θ`.
///
/// Counter-clockwise for positive angles: `R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]]`. The tangent is
/// the angle (a 1-vector); `log` returns it in (−π, π]. `DIM` = 1; acts on points of R² by rotation.
///
/// # Example
/// ```
/// use liebayes_manifolds::{LieGroup, Manifold, So2};
/// let a = So2::from_angle(3.0_f64).unwrap();
/// let b = So2::from_angle(-3.0_f64).unwrap();
/// // The difference wraps across ±π: 2π − 6, not −6.
/// assert!((a.local(&b)[0] - (2.0 * std::f64::consts::PI - 6.0)).abs() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct So2<T: Real> {
    z: UnitComplex<T>,
}

/// Construction.
impl<T: Real> So2<T> {
    /// The rotation by `angle` radians, checked for finiteness.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`].
    pub fn from_angle(angle: T) -> Result<Self, ManifoldError> {
        check_finite("angle", [angle].iter())?;
        Ok(Self::from_angle_unchecked(angle))
    }

    /// The rotation by `angle` radians without the finiteness check (hot paths).
    #[inline]
    pub fn from_angle_unchecked(angle: T) -> Self {
        Self::from_unit_complex(UnitComplex::new(angle))
    }

    /// The rotation with the given cosine and sine, checked for finiteness and `cos² + sin² = 1`
    /// (`abs(|z| − 1)` at most
    /// [`UNIT_NORM_TOLERANCE`](crate::constants::Thresholds::UNIT_NORM_TOLERANCE), 1e-9 in f64);
    /// stored as given when unit to rounding (`abs(|z|² − 1)` at most
    /// [`UNIT_ROUNDING_TOLERANCE`](crate::constants::Thresholds::UNIT_ROUNDING_TOLERANCE), 32 eps),
    /// else as `z / |z|`.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::NotUnit`].
    pub fn from_cos_sin(cos: T, sin: T) -> Result<Self, ManifoldError> {
        let z = checked_unit(
            "(cos, sin) pair",
            &Vector2::new(cos, sin),
            "So2::from_vector_normalizing",
        )?;
        Ok(Self::from_cos_sin_unchecked(z.x, z.y))
    }

    /// The rotation with the given cosine and sine, unchecked (hot paths).
    #[inline]
    pub fn from_cos_sin_unchecked(cos: T, sin: T) -> Self {
        Self::from_unit_complex(UnitComplex::new_unchecked(Complex::new(cos, sin)))
    }

    /// The rotation taking the x axis to the direction `v / |v|` of `v`, of any finite length
    /// `|v| ≥` [`MIN_DIRECTION_NORM`](crate::constants::Thresholds::MIN_DIRECTION_NORM) (1e-150 in f64, 1e-18
    /// in f32; a shorter vector's direction is rounding noise): the renormalisation helper.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], or [`ManifoldError::ZeroVector`] for `|v|` below
    /// `MIN_DIRECTION_NORM` (zero included).
    pub fn from_vector_normalizing(v: &Vector2<T>) -> Result<Self, ManifoldError> {
        let u = normalized("direction vector", v)?;
        Ok(Self::from_cos_sin_unchecked(u.x, u.y))
    }

    /// The rotation of a 2×2 matrix, checked for finiteness, orthonormality and determinant +1 (to
    /// [`ORTHONORMAL_TOLERANCE`](crate::constants::Thresholds::ORTHONORMAL_TOLERANCE)); its first
    /// column `(cos, sin)` is stored normalised unless unit to rounding (as
    /// [`from_cos_sin`](Self::from_cos_sin)).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], [`ManifoldError::NotOrthonormal`] or
    /// [`ManifoldError::NotProperRotation`].
    pub fn from_matrix(m: &Matrix2<T>) -> Result<Self, ManifoldError> {
        check_rotation_matrix(m, m.determinant())?;
        let z = unit_to_rounding(&Vector2::new(m.m11, m.m21));
        Ok(Self::from_cos_sin_unchecked(z.x, z.y))
    }

    /// Wraps a nalgebra unit complex number as it is, without a check (no cost): nalgebra's unit
    /// types are unit by construction except when its own `new_unchecked`, or `new_normalize` of
    /// zero, made them NaN. [`So2::from_cos_sin`] checks its numbers.
    #[inline]
    pub const fn from_unit_complex(z: UnitComplex<T>) -> Self {
        Self { z }
    }

    /// The same rotation with `cos² + sin² = 1` restored.
    #[must_use]
    pub fn renormalized(&self) -> Self {
        Self::from_unit_complex(UnitComplex::new_normalize(self.z.into_inner()))
    }
}

/// Conversion and access.
impl<T: Real> So2<T> {
    /// The angle in (−π, π].
    #[inline]
    pub fn angle(&self) -> T {
        let angle = self.z.im.atan2(self.z.re);
        // A half turn stored with sine −0 (or a sine of order −1e-300) gives atan2 = −π, outside the
        // principal branch: it is the half turn π.
        if angle == -T::pi() { T::pi() } else { angle }
    }

    /// `cos θ`.
    #[inline]
    pub fn cos(&self) -> T {
        self.z.re
    }

    /// `sin θ`.
    #[inline]
    pub fn sin(&self) -> T {
        self.z.im
    }

    /// The stored unit complex number.
    #[inline]
    pub const fn as_unit_complex(&self) -> &UnitComplex<T> {
        &self.z
    }

    /// The rotation matrix `[[cos θ, −sin θ], [sin θ, cos θ]]`.
    #[inline]
    pub fn to_matrix(&self) -> Matrix2<T> {
        self.z.to_rotation_matrix().into_inner()
    }
}

impl<T: Real> LieGroup<1> for So2<T> {
    /// Skew 2×2 matrices `[[0, −θ], [θ, 0]]`.
    type Algebra = Matrix2<T>;

    #[inline]
    fn identity() -> Self {
        Self::from_unit_complex(UnitComplex::identity())
    }

    #[inline]
    fn compose(&self, other: &Self) -> Self {
        Self::from_unit_complex(self.z * other.z)
    }

    #[inline]
    fn inverse(&self) -> Self {
        Self::from_unit_complex(self.z.inverse())
    }

    /// `exp(θ) = cos θ + i sin θ`.
    #[inline]
    fn exp(v: &Tangent<T, 1>) -> Self {
        Self::from_angle_unchecked(v[0])
    }

    /// `atan2(sin θ, cos θ)` in (−π, π].
    #[inline]
    fn log(&self) -> Tangent<T, 1> {
        Vector1::new(self.angle())
    }

    #[inline]
    fn hat(v: &Tangent<T, 1>) -> Matrix2<T> {
        Matrix2::new(T::zero(), -v[0], v[0], T::zero())
    }

    #[inline]
    fn vee(a: &Matrix2<T>) -> Tangent<T, 1> {
        Vector1::new(crate::rotation_vector::half_difference(a.m21, a.m12))
    }

    /// `R a Rᵀ`, saturating at the largest finite value (`a` near overflow).
    fn conjugate_algebra(&self, a: &Matrix2<T>) -> Matrix2<T> {
        let r = self.to_matrix();
        crate::pose::conjugate_saturating(&r, a, &r.transpose())
    }

    /// SO(2) is abelian: `Ad = 1`.
    #[inline]
    fn adjoint(&self) -> Jacobian<T, 1, 1> {
        Matrix1::identity()
    }

    /// `Jr = 1`.
    #[inline]
    fn right_jacobian(_v: &Tangent<T, 1>) -> Jacobian<T, 1, 1> {
        Matrix1::identity()
    }

    /// `Jr⁻¹ = 1`.
    #[inline]
    fn right_jacobian_inverse(_v: &Tangent<T, 1>) -> Jacobian<T, 1, 1> {
        Matrix1::identity()
    }
}

impl_manifold_for_group!(So2, 1, |x| x.z.re.is_finite() && x.z.im.is_finite());

impl<T: Real> GroupAction<1, 2> for So2<T> {
    /// `R p`, saturating at the largest finite value where the turned point lies beyond it.
    #[inline]
    fn act(&self, p: &Vector2<T>) -> Vector2<T> {
        saturated(self.z * p)
    }

    /// `R [−p_y, p_x]ᵀ`, saturating like `act`.
    #[inline]
    fn j_act_self(&self, p: &Vector2<T>) -> Jacobian<T, 2, 1> {
        saturated(self.z * Vector2::new(-p.y, p.x))
    }

    /// `R`.
    #[inline]
    fn j_act_point(&self, _p: &Vector2<T>) -> Jacobian<T, 2, 2> {
        self.to_matrix()
    }
}

impl<T: Real> PartialEq for So2<T> {
    fn eq(&self, other: &Self) -> bool {
        self.z == other.z
    }
}

crate::approx_impls::impl_approx_by_field!(So2<T>, [T: Real], z);

/// Unchecked, as [`from_unit_complex`](So2::from_unit_complex).
impl<T: Real> From<UnitComplex<T>> for So2<T> {
    #[inline]
    fn from(z: UnitComplex<T>) -> Self {
        Self::from_unit_complex(z)
    }
}

impl<T: Real> From<So2<T>> for UnitComplex<T> {
    #[inline]
    fn from(r: So2<T>) -> Self {
        r.z
    }
}

/// The rotation of a nalgebra `Rotation2`, unchecked like
/// [`from_unit_complex`](So2::from_unit_complex): its first column is taken as `(cos, sin)`, and
/// nalgebra's rotations are rotations by construction except when its own
/// `Rotation2::from_matrix_unchecked` made them of any matrix. [`So2::from_matrix`] checks its
/// matrix.
impl<T: Real> From<Rotation2<T>> for So2<T> {
    #[inline]
    fn from(r: Rotation2<T>) -> Self {
        Self::from_unit_complex(UnitComplex::from_rotation_matrix(&r))
    }
}

impl<T: Real> From<So2<T>> for Rotation2<T> {
    #[inline]
    fn from(r: So2<T>) -> Self {
        r.z.to_rotation_matrix()
    }
}
