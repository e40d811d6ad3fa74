//! [`So3`]: rotations of space.

use crate::error::{
    ManifoldError, check_finite, check_rotation_matrix, normalized, unit_to_rounding,
};
use crate::lie_group::{LieGroup, impl_manifold_for_group};
use crate::manifold::Tangent;
use crate::polar;
use crate::real::{Real, stable_norm};
use crate::rotation_vector;
use crate::su2::Su2;
use approx::{AbsDiffEq, RelativeEq};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// A rotation of space, an element of SO(3).
///
/// Stored as a unit quaternion (Hamilton, scalar first in all I/O, active: `R(q) v = q v q*`), which
/// keeps composition cheap and the logarithm accurate at and near π. The quaternions q and −q are the
/// same rotation: `==`, the `approx` comparisons and [`distance`](crate::Manifold::distance) treat them
/// as equal. Use [`Su2`] where the sign matters.
///
/// Invariant: the quaternion has unit norm to rounding (the checked constructors normalise what
/// they accept within
/// [`UNIT_NORM_TOLERANCE`](crate::constants::Thresholds::UNIT_NORM_TOLERANCE)); the `_unchecked`
/// and `From` conversions leave that to the caller.
///
/// Tangent coordinates are rotation vectors (axis times angle, radians); `log` returns angles in
/// [0, π]. `DIM` = 3; acts on points of R³ by rotation.
///
/// # Example
/// ```
/// use liebayes_manifolds::{LieGroup, Manifold, So3};
/// use nalgebra::Vector3;
/// let r = So3::<f64>::exp(&Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2));
/// let v = r.rotate(&Vector3::x());
/// assert!((v - Vector3::y()).norm() < 1e-15);
/// assert!((r.log() - Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2)).norm() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct So3<T: Real> {
    q: UnitQuaternion<T>,
}

/// Construction.
impl<T: Real> So3<T> {
    /// The rotation of a unit quaternion given scalar first, checked for finiteness and unit norm.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::NotUnit`].
    pub fn from_quaternion_wxyz(w: T, x: T, y: T, z: T) -> Result<Self, ManifoldError> {
        Self::from_quaternion(Quaternion::new(w, x, y, z))
    }

    /// The rotation of a unit quaternion, checked for finiteness and unit norm, and stored
    /// normalised unless unit to rounding (as [`Su2::from_quaternion`]).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::NotUnit`].
    pub fn from_quaternion(q: Quaternion<T>) -> Result<Self, ManifoldError> {
        Su2::from_quaternion(q).map(|q| q.to_so3())
    }

    /// The rotation of `q / |q|`: the renormalisation helper for quaternions read from files or
    /// accumulated by integration.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::ZeroVector`].
    pub fn from_quaternion_normalizing(q: Quaternion<T>) -> Result<Self, ManifoldError> {
        Su2::from_quaternion_normalizing(q).map(|q| q.to_so3())
    }

    /// Wraps a quaternion without any check: the caller guarantees unit norm (hot paths).
    #[inline]
    pub fn from_quaternion_unchecked(q: Quaternion<T>) -> Self {
        Self::from_unit_quaternion(UnitQuaternion::new_unchecked(q))
    }

    /// Wraps a nalgebra unit quaternion as it is, without a check (no cost): nalgebra's unit types
    /// are unit by construction except when its own `new_unchecked`, or normalising zero, made
    /// them NaN. [`So3::from_quaternion`] checks its quaternion.
    #[inline]
    pub const fn from_unit_quaternion(q: UnitQuaternion<T>) -> Self {
        Self { q }
    }

    /// The rotation of a matrix, checked for finiteness, orthonormality and determinant +1 (to
    /// [`ORTHONORMAL_TOLERANCE`](crate::constants::Thresholds::ORTHONORMAL_TOLERANCE)); its
    /// quaternion, which carries the matrix's deviation from orthonormality, is stored normalised
    /// unless unit to rounding (as [`Su2::from_quaternion`]).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], [`ManifoldError::NotOrthonormal`] or
    /// [`ManifoldError::NotProperRotation`].
    pub fn from_matrix(m: &Matrix3<T>) -> Result<Self, ManifoldError> {
        check_rotation_matrix(m, m.determinant())?;
        let q = Self::from_matrix_unchecked(m).q;
        Ok(Self::from_quaternion_unchecked(Quaternion::from(
            unit_to_rounding(&q.coords),
        )))
    }

    /// The rotation of a matrix the caller guarantees to be a rotation (hot paths).
    #[inline]
    pub fn from_matrix_unchecked(m: &Matrix3<T>) -> Self {
        Self::from_unit_quaternion(UnitQuaternion::from_rotation_matrix(
            &Rotation3::from_matrix_unchecked(*m),
        ))
    }

    /// The rotation nearest to `m` in the Frobenius norm (the polar factor `U Vᵀ` of the SVD
    /// `m = U S Vᵀ`): the renormalisation helper for matrices that drifted from orthonormality.
    ///
    /// Valid for entries of any finite size, side by side (1e-300 next to 1e300): the SVD is a
    /// one-sided Jacobi iteration that never squares an entry, and it resolves matrices whose columns
    /// (or rows) have very different sizes to their own relative accuracy, so `R D` and `D R` give R
    /// for any positive diagonal D. When the smallest singular value is below the rounding of the
    /// largest, its direction is fixed by orientation (Kabsch's determinant correction), so the result
    /// is always a rotation: the nearest rotation of a matrix within rounding of `m`.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`]; [`ManifoldError::NotProperRotation`] when `det m <= 0` (a
    /// reflection or a degenerate matrix has no nearest rotation worth the name);
    /// [`ManifoldError::PolarNotConverged`] if the Jacobi sweeps reach
    /// [`POLAR_MAX_SWEEPS`](crate::constants::POLAR_MAX_SWEEPS).
    pub fn from_matrix_orthonormalized(m: &Matrix3<T>) -> Result<Self, ManifoldError> {
        check_finite("matrix", m.iter())?;
        let r = polar::nearest_rotation(m)?;
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
        Ok(Self::from_quaternion_unchecked(q.into_inner().normalize()))
    }

    /// The rotation of a rotation vector (axis times angle), checked for finiteness.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`].
    pub fn from_rotation_vector(v: &Vector3<T>) -> Result<Self, ManifoldError> {
        Su2::from_rotation_vector(v).map(|q| q.to_so3())
    }

    /// The rotation by `angle` about `axis`, normalised: any finite length `|axis| ≥`
    /// [`MIN_DIRECTION_NORM`](crate::constants::Thresholds::MIN_DIRECTION_NORM) (1e-150 in f64, 1e-18 in
    /// f32; a shorter axis's direction is rounding noise).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], or [`ManifoldError::ZeroVector`] for `|axis|` below
    /// `MIN_DIRECTION_NORM` (zero included).
    pub fn from_axis_angle(axis: &Vector3<T>, angle: T) -> Result<Self, ManifoldError> {
        check_finite("angle", [angle].iter())?;
        let axis = normalized("rotation axis", axis)?;
        Ok(Self::exp(&(axis * angle)))
    }

    /// The same rotation with its quaternion renormalised (after long chains of products).
    #[must_use]
    pub fn renormalized(&self) -> Self {
        Self::from_quaternion_unchecked(self.q.into_inner().normalize())
    }
}

/// Conversion and access.
impl<T: Real> So3<T> {
    /// The stored unit quaternion (one of the two representing this rotation).
    #[inline]
    pub const fn as_unit_quaternion(&self) -> &UnitQuaternion<T> {
        &self.q
    }

    /// The quaternion coefficients, scalar first: `[w, x, y, z]`.
    #[inline]
    pub fn to_quaternion_wxyz(&self) -> [T; 4] {
        [self.q.w, self.q.i, self.q.j, self.q.k]
    }

    /// The rotation matrix.
    #[inline]
    pub fn to_matrix(&self) -> Matrix3<T> {
        self.q.to_rotation_matrix().into_inner()
    }

    /// The lift to SU(2) with non-negative scalar part (the other lift is its negative).
    #[inline]
    pub fn to_su2(&self) -> Su2<T> {
        let q = self.q.into_inner();
        Su2::from_unit_quaternion(UnitQuaternion::new_unchecked(if q.w < T::zero() {
            -q
        } else {
            q
        }))
    }

    /// The rotation angle in [0, π].
    #[inline]
    pub fn angle(&self) -> T {
        T::lit(2.0) * stable_norm(&self.q.imag()).atan2(self.q.w.abs())
    }

    /// Rotates a vector: `R v = q v q*`.
    #[inline]
    pub fn rotate(&self, v: &Vector3<T>) -> Vector3<T> {
        rotation_vector::rotate(&self.q, v)
    }
}

impl<T: Real> LieGroup<3> for So3<T> {
    type Algebra = Matrix3<T>;

    rotation_vector::quaternion_group_methods!();

    /// The rotation vector with angle in [0, π]: the quaternion is first taken with `w >= 0`, then
    /// `θ = 2 atan2(|xyz|, w)`. At angle π both ±axis are logarithms; the sign of the stored axis is
    /// kept.
    #[inline]
    fn log(&self) -> Tangent<T, 3> {
        let q = self.q.into_inner();
        if q.w < T::zero() {
            rotation_vector::log(&-q)
        } else {
            rotation_vector::log(&q)
        }
    }

    /// The skew-symmetric matrix `hat(v) w = v × w`.
    #[inline]
    fn hat(v: &Tangent<T, 3>) -> Matrix3<T> {
        rotation_vector::hat(v)
    }

    #[inline]
    fn vee(a: &Matrix3<T>) -> Tangent<T, 3> {
        rotation_vector::vee(a)
    }

    /// `R a Rᵀ`, saturating at the largest finite value (`a` near overflow).
    fn conjugate_algebra(&self, a: &Matrix3<T>) -> Matrix3<T> {
        let r = self.to_matrix();
        crate::pose::conjugate_saturating(&r, a, &r.transpose())
    }
}

impl_manifold_for_group!(So3, 3, |x| x
    .q
    .coords
    .iter()
    .all(nalgebra::ComplexField::is_finite));

rotation_vector::impl_rotation_action!(So3);

/// Equal when the quaternions are equal up to sign (q and −q are one rotation).
impl<T: Real> PartialEq for So3<T> {
    fn eq(&self, other: &Self) -> bool {
        self.q.coords == other.q.coords || self.q.coords == -other.q.coords
    }
}

impl<T: Real> AbsDiffEq for So3<T> {
    type Epsilon = T;
    fn default_epsilon() -> T {
        T::default_epsilon()
    }
    /// Compares quaternion coefficients up to sign.
    fn abs_diff_eq(&self, other: &Self, epsilon: T) -> bool {
        self.q.coords.abs_diff_eq(&other.q.coords, epsilon)
            || self.q.coords.abs_diff_eq(&-other.q.coords, epsilon)
    }
    /// The negation of `abs_diff_eq`.
    fn abs_diff_ne(&self, other: &Self, epsilon: T) -> bool {
        !self.abs_diff_eq(other, epsilon)
    }
}

impl<T: Real> RelativeEq for So3<T> {
    fn default_max_relative() -> T {
        T::default_max_relative()
    }
    /// Compares quaternion coefficients up to sign.
    fn relative_eq(&self, other: &Self, epsilon: T, max_relative: T) -> bool {
        self.q
            .coords
            .relative_eq(&other.q.coords, epsilon, max_relative)
            || self
                .q
                .coords
                .relative_eq(&-other.q.coords, epsilon, max_relative)
    }
    /// The negation of `relative_eq`.
    fn relative_ne(&self, other: &Self, epsilon: T, max_relative: T) -> bool {
        !self.relative_eq(other, epsilon, max_relative)
    }
}

/// Unchecked, as [`from_unit_quaternion`](So3::from_unit_quaternion).
impl<T: Real> From<UnitQuaternion<T>> for So3<T> {
    #[inline]
    fn from(q: UnitQuaternion<T>) -> Self {
        Self::from_unit_quaternion(q)
    }
}

impl<T: Real> From<So3<T>> for UnitQuaternion<T> {
    #[inline]
    fn from(r: So3<T>) -> Self {
        r.q
    }
}

/// The rotation of a nalgebra `Rotation3`, unchecked like
/// [`from_unit_quaternion`](So3::from_unit_quaternion): nalgebra's rotations are rotations by
/// construction except when its own `Rotation3::from_matrix_unchecked` made them of any matrix,
/// whose quaternion is then not unit. [`So3::from_matrix`] checks its matrix.
impl<T: Real> From<Rotation3<T>> for So3<T> {
    #[inline]
    fn from(r: Rotation3<T>) -> Self {
        Self::from_unit_quaternion(UnitQuaternion::from_rotation_matrix(&r))
    }
}

impl<T: Real> From<So3<T>> for Rotation3<T> {
    #[inline]
    fn from(r: So3<T>) -> Self {
        r.q.to_rotation_matrix()
    }
}

impl<T: Real> From<Su2<T>> for So3<T> {
    #[inline]
    fn from(q: Su2<T>) -> Self {
        q.to_so3()
    }
}
