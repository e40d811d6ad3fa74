//! [`Su2`]: unit quaternions, the double cover of SO(3).

use crate::error::{ManifoldError, check_finite, check_unit, normalized};
use crate::lie_group::{GroupAction, LieGroup, impl_manifold_for_group};
use crate::manifold::{Jacobian, Tangent};
use crate::real::Real;
use crate::rotation_vector;
use crate::so3::So3;
use approx::{AbsDiffEq, RelativeEq};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// A unit quaternion, an element of SU(2) ≅ S³, the double cover of SO(3).
///
/// Hamilton convention, scalar first in all I/O: `q = (w, x, y, z)`, acting on R³ by `v ↦ q v q*`.
/// Unlike [`So3`], q and −q are different points here (equality compares coefficients), which is what
/// antipodally symmetric densities such as the Bingham distribution live on; [`to_so3`](Self::to_so3)
/// is the covering map.
///
/// Tangent coordinates are the same rotation vectors as for [`So3`]: `exp(v) = (cos(θ/2), sin(θ/2) v/θ)`.
/// `log` returns the vector with |v| = 2 atan2(|xyz|, w) in [0, 2π] (so `w < 0` gives angles above π);
/// exp is injective for |v| < 2π and singular at 2π, where every axis reaches −1.
#[derive(Clone, Copy, Debug)]
pub struct Su2<T: Real> {
    q: UnitQuaternion<T>,
}

/// Construction.
impl<T: Real> Su2<T> {
    /// The unit quaternion `(w, x, y, z)`, checked for finiteness and unit norm.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::NotUnit`].
    pub fn from_quaternion_wxyz(w: T, x: T, y: T, z: T) -> Result<Self, ManifoldError> {
        Self::from_quaternion(Quaternion::new(w, x, y, z))
    }

    /// A unit quaternion, checked for finiteness and unit norm.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::NotUnit`].
    pub fn from_quaternion(q: Quaternion<T>) -> Result<Self, ManifoldError> {
        check_unit("quaternion", &q.coords, "from_quaternion_normalizing")?;
        Ok(Self::from_quaternion_unchecked(q))
    }

    /// `q / |q|`: the renormalisation helper.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::ZeroVector`].
    pub fn from_quaternion_normalizing(q: Quaternion<T>) -> Result<Self, ManifoldError> {
        let unit = normalized("quaternion", &q.coords)?;
        Ok(Self::from_quaternion_unchecked(Quaternion::from(unit)))
    }

    /// Wraps a quaternion without any check: the caller guarantees unit norm (hot paths).
    #[inline]
    pub fn from_quaternion_unchecked(q: Quaternion<T>) -> Self {
        Self::from_unit_quaternion(UnitQuaternion::new_unchecked(q))
    }

    /// Wraps a nalgebra unit quaternion (no cost).
    #[inline]
    pub const fn from_unit_quaternion(q: UnitQuaternion<T>) -> Self {
        Self { q }
    }

    /// `exp(v)` of a rotation vector, checked for finiteness.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`].
    pub fn from_rotation_vector(v: &Vector3<T>) -> Result<Self, ManifoldError> {
        check_finite("rotation vector", v.iter())?;
        Ok(Self::exp(v))
    }

    /// The same element with its quaternion renormalised.
    #[must_use]
    pub fn renormalized(&self) -> Self {
        Self::from_quaternion_unchecked(self.q.into_inner().normalize())
    }
}

/// Conversion and access.
impl<T: Real> Su2<T> {
    /// The unit quaternion.
    #[inline]
    pub const fn as_unit_quaternion(&self) -> &UnitQuaternion<T> {
        &self.q
    }

    /// The coefficients, scalar first: `[w, x, y, z]`.
    #[inline]
    pub fn to_quaternion_wxyz(&self) -> [T; 4] {
        [self.q.w, self.q.i, self.q.j, self.q.k]
    }

    /// The covering map SU(2) → SO(3): the rotation `v ↦ q v q*` (q and −q map to the same rotation).
    #[inline]
    pub const fn to_so3(&self) -> So3<T> {
        So3::from_unit_quaternion(self.q)
    }

    /// The antipodal point −q (the other lift of the same rotation).
    #[inline]
    #[must_use]
    pub fn antipode(&self) -> Self {
        Self::from_quaternion_unchecked(-self.q.into_inner())
    }

    /// The rotation matrix of `v ↦ q v q*`.
    #[inline]
    pub fn to_rotation_matrix(&self) -> Matrix3<T> {
        self.q.to_rotation_matrix().into_inner()
    }
}

impl<T: Real> LieGroup<3> for Su2<T> {
    /// Pure quaternions: `hat(v) = (0, v/2)`, so that the quaternion exponential of `hat(v)` is `exp(v)`.
    type Algebra = Quaternion<T>;

    #[inline]
    fn identity() -> Self {
        Self::from_unit_quaternion(UnitQuaternion::identity())
    }

    #[inline]
    fn compose(&self, other: &Self) -> Self {
        Self::from_unit_quaternion(self.q * other.q)
    }

    #[inline]
    fn inverse(&self) -> Self {
        Self::from_unit_quaternion(self.q.inverse())
    }

    /// `exp(v) = (cos(θ/2), sin(θ/2) v/θ)`, θ = |v|, with the Taylor series below the series angle.
    #[inline]
    fn exp(v: &Tangent<T, 3>) -> Self {
        Self::from_unit_quaternion(rotation_vector::exp(v))
    }

    /// `v = 2 atan2(|xyz|, w) xyz/|xyz|`, |v| in [0, 2π]; at q = −1 exactly, `(2π, 0, 0)`.
    #[inline]
    fn log(&self) -> Tangent<T, 3> {
        rotation_vector::log(self.q.quaternion())
    }

    #[inline]
    fn hat(v: &Tangent<T, 3>) -> Quaternion<T> {
        let half = T::lit(0.5);
        Quaternion::new(T::zero(), v.x * half, v.y * half, v.z * half)
    }

    #[inline]
    fn vee(a: &Quaternion<T>) -> Tangent<T, 3> {
        a.imag() * T::lit(2.0)
    }

    /// `q a q*` by quaternion products.
    fn conjugate_algebra(&self, a: &Quaternion<T>) -> Quaternion<T> {
        self.q.quaternion() * a * self.q.conjugate().quaternion()
    }

    /// `Ad(q) = R(q)`, the rotation matrix.
    #[inline]
    fn adjoint(&self) -> Jacobian<T, 3, 3> {
        self.to_rotation_matrix()
    }

    /// Same as SO(3): `Jr(v) = I − ((1 − cos θ)/θ²) hat(v) + ((θ − sin θ)/θ³) hat(v)²`.
    #[inline]
    fn right_jacobian(v: &Tangent<T, 3>) -> Jacobian<T, 3, 3> {
        rotation_vector::right_jacobian(v)
    }

    /// Same as SO(3); singular at θ = 2π, where SU(2)'s exp folds onto −1.
    #[inline]
    fn right_jacobian_inverse(v: &Tangent<T, 3>) -> Jacobian<T, 3, 3> {
        rotation_vector::right_jacobian_inverse(v)
    }

    /// `Ad(other⁻¹) = R(other)ᵀ`.
    #[inline]
    fn j_compose_self(&self, other: &Self) -> Jacobian<T, 3, 3> {
        other.to_rotation_matrix().transpose()
    }
}

impl_manifold_for_group!(Su2, 3);

impl<T: Real> GroupAction<3, 3> for Su2<T> {
    /// `q v q*`.
    #[inline]
    fn act(&self, p: &Vector3<T>) -> Vector3<T> {
        self.q * p
    }

    /// `−R hat(p)`.
    #[inline]
    fn j_act_self(&self, p: &Vector3<T>) -> Jacobian<T, 3, 3> {
        -(self.to_rotation_matrix() * rotation_vector::hat(p))
    }

    /// `R`.
    #[inline]
    fn j_act_point(&self, _p: &Vector3<T>) -> Jacobian<T, 3, 3> {
        self.to_rotation_matrix()
    }
}

/// Equal when the coefficients are equal: q and −q differ on SU(2).
impl<T: Real> PartialEq for Su2<T> {
    fn eq(&self, other: &Self) -> bool {
        self.q.coords == other.q.coords
    }
}

impl<T: Real> AbsDiffEq for Su2<T> {
    type Epsilon = T;
    fn default_epsilon() -> T {
        T::default_epsilon()
    }
    fn abs_diff_eq(&self, other: &Self, epsilon: T) -> bool {
        self.q.coords.abs_diff_eq(&other.q.coords, epsilon)
    }
}

impl<T: Real> RelativeEq for Su2<T> {
    fn default_max_relative() -> T {
        T::default_max_relative()
    }
    fn relative_eq(&self, other: &Self, epsilon: T, max_relative: T) -> bool {
        self.q
            .coords
            .relative_eq(&other.q.coords, epsilon, max_relative)
    }
}

impl<T: Real> From<UnitQuaternion<T>> for Su2<T> {
    #[inline]
    fn from(q: UnitQuaternion<T>) -> Self {
        Self::from_unit_quaternion(q)
    }
}

impl<T: Real> From<Su2<T>> for UnitQuaternion<T> {
    #[inline]
    fn from(q: Su2<T>) -> Self {
        q.q
    }
}
