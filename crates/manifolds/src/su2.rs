//! [`Su2`]: unit quaternions, the double cover of SO(3).

use crate::error::{ManifoldError, check_finite, checked_unit, normalized};
use crate::lie_group::{LieGroup, impl_manifold_for_group};
use crate::manifold::Tangent;
use crate::real::Real;
use crate::rotation_vector;
use crate::so3::So3;
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
///
/// # Example
/// ```
/// use liebayes_manifolds::{LieGroup, Manifold, So3, Su2};
/// use nalgebra::Vector3;
/// let v = Vector3::new(0.3, -0.2, 0.9);
/// let q = Su2::exp(&v);
/// // The covering map sends exp on SU(2) to exp on SO(3), and −q to the same rotation.
/// assert!(q.to_so3().distance(&So3::exp(&v)) < 1e-15);
/// assert!(q.antipode().to_so3().distance(&So3::exp(&v)) < 1e-15);
/// assert!((q.log() - v).norm() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Su2<T: Real> {
    q: UnitQuaternion<T>,
}

/// Construction.
impl<T: Real> Su2<T> {
    /// The unit quaternion `(w, x, y, z)`, checked for finiteness and unit norm (as
    /// [`from_quaternion`](Self::from_quaternion)).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::NotUnit`].
    pub fn from_quaternion_wxyz(w: T, x: T, y: T, z: T) -> Result<Self, ManifoldError> {
        Self::from_quaternion(Quaternion::new(w, x, y, z))
    }

    /// A unit quaternion, checked for finiteness and unit norm: `abs(|q| − 1)` at most
    /// [`UNIT_NORM_TOLERANCE`](crate::constants::Thresholds::UNIT_NORM_TOLERANCE) (1e-9 in f64).
    /// It is stored as given when it is unit to rounding (`abs(|q|² − 1)` at most
    /// [`UNIT_ROUNDING_TOLERANCE`](crate::constants::Thresholds::UNIT_ROUNDING_TOLERANCE), 32 eps),
    /// else as `q / |q|`: products of stored elements then keep unit norm to rounding.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::NotUnit`].
    pub fn from_quaternion(q: Quaternion<T>) -> Result<Self, ManifoldError> {
        let unit = checked_unit("quaternion", &q.coords, "from_quaternion_normalizing")?;
        Ok(Self::from_quaternion_unchecked(Quaternion::from(unit)))
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

    /// Wraps a nalgebra unit quaternion as it is, without a check (no cost): nalgebra's unit types
    /// are unit by construction except when its own `new_unchecked`, or normalising zero, made
    /// them NaN. [`Su2::from_quaternion`] checks its quaternion.
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

    rotation_vector::quaternion_group_methods!();

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

    /// `2 (x, y, z)`, saturating at the largest finite value (entries beyond half of it).
    #[inline]
    fn vee(a: &Quaternion<T>) -> Tangent<T, 3> {
        crate::pose::saturated(a.imag() * T::lit(2.0))
    }

    /// `q a q* = (w, R(q) (x, y, z))`: the vector part rotated, saturating at the largest finite
    /// value (two quaternion products overflow into NaN for entries near it).
    fn conjugate_algebra(&self, a: &Quaternion<T>) -> Quaternion<T> {
        Quaternion::from_parts(a.w, rotation_vector::rotate(&self.q, &a.imag()))
    }
}

impl_manifold_for_group!(Su2, 3, |x| x
    .q
    .coords
    .iter()
    .all(nalgebra::ComplexField::is_finite));

rotation_vector::impl_rotation_action!(Su2);

/// Equal when the coefficients are equal: q and −q differ on SU(2).
impl<T: Real> PartialEq for Su2<T> {
    fn eq(&self, other: &Self) -> bool {
        self.q.coords == other.q.coords
    }
}

crate::approx_impls::impl_approx_by_field!(Su2<T>, [T: Real], q.coords);

/// Unchecked, as [`from_unit_quaternion`](Su2::from_unit_quaternion).
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
