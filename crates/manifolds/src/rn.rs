//! [`Rn`]: the vector space Rⁿ as a manifold and an additive Lie group.

use crate::error::{ManifoldError, check_finite};
use crate::lie_group::{GroupAction, LieGroup};
use crate::manifold::{Jacobian, Manifold, Tangent};
use crate::pose::saturated;
use crate::real::Real;
use nalgebra::SVector;

/// A point of Rⁿ, the additive group: compose is `+`, exp and log are the identity map, and every
/// Jacobian is `±I`. It acts on Rⁿ by translation. Having it behind the same traits lets generic
/// filters treat positions, velocities and biases like any other state.
///
/// # Example
/// ```
/// use liebayes_manifolds::{LieGroup, Manifold, Rn};
/// use nalgebra::Vector2;
/// let x = Rn::new(Vector2::new(1.0, 2.0))?;
/// let y = x.retract(&Vector2::new(0.5, -1.0));
/// assert_eq!(y.coords(), &Vector2::new(1.5, 1.0));
/// assert_eq!(x.compose(&x.inverse()), Rn::identity());
/// # Ok::<(), liebayes_manifolds::ManifoldError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rn<T: Real, const N: usize> {
    v: SVector<T, N>,
}

impl<T: Real, const N: usize> Rn<T, N> {
    /// The point with coordinates `v`, checked for finiteness.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`].
    pub fn new(v: SVector<T, N>) -> Result<Self, ManifoldError> {
        check_finite("vector", v.iter())?;
        Ok(Self { v })
    }

    /// The point from a slice of exactly `N` finite numbers.
    ///
    /// # Errors
    /// [`ManifoldError::WrongLength`] or [`ManifoldError::NonFinite`].
    pub fn from_slice(values: &[T]) -> Result<Self, ManifoldError> {
        if values.len() != N {
            return Err(ManifoldError::WrongLength {
                what: "vector",
                expected: N,
                got: values.len(),
            });
        }
        Self::new(SVector::from_column_slice(values))
    }

    /// The point with coordinates `v`, unchecked (hot paths).
    #[inline]
    pub const fn new_unchecked(v: SVector<T, N>) -> Self {
        Self { v }
    }

    /// The coordinates.
    #[inline]
    pub const fn coords(&self) -> &SVector<T, N> {
        &self.v
    }
}

impl<T: Real, const N: usize> Manifold<N> for Rn<T, N> {
    type Scalar = T;

    /// `x + v`, saturated at the largest finite value where the sum overflows (like the poses'
    /// translations).
    #[inline]
    fn retract(&self, v: &Tangent<T, N>) -> Self {
        Self::new_unchecked(saturated(self.v + v))
    }

    /// `y − x`, saturated at the largest finite value where the difference overflows.
    #[inline]
    fn local(&self, other: &Self) -> Tangent<T, N> {
        saturated(other.v - self.v)
    }

    #[inline]
    fn is_finite(&self) -> bool {
        self.v.iter().all(nalgebra::ComplexField::is_finite)
    }

    /// `I`: the retraction is `x + v`.
    #[inline]
    fn j_retract_tangent(&self, _: &Tangent<T, N>) -> crate::manifold::Jacobian<T, N, N> {
        crate::manifold::Jacobian::identity()
    }
}

impl<T: Real, const N: usize> LieGroup<N> for Rn<T, N> {
    /// The algebra of Rⁿ is Rⁿ itself.
    type Algebra = SVector<T, N>;

    #[inline]
    fn identity() -> Self {
        Self::new_unchecked(SVector::zeros())
    }

    /// `x + y`, saturated at the largest finite value where the sum overflows.
    #[inline]
    fn compose(&self, other: &Self) -> Self {
        Self::new_unchecked(saturated(self.v + other.v))
    }

    #[inline]
    fn inverse(&self) -> Self {
        Self::new_unchecked(-self.v)
    }

    #[inline]
    fn exp(v: &Tangent<T, N>) -> Self {
        Self::new_unchecked(*v)
    }

    #[inline]
    fn log(&self) -> Tangent<T, N> {
        self.v
    }

    #[inline]
    fn hat(v: &Tangent<T, N>) -> SVector<T, N> {
        *v
    }

    #[inline]
    fn vee(a: &SVector<T, N>) -> Tangent<T, N> {
        *a
    }

    /// Abelian: `g a g⁻¹ = a`.
    fn conjugate_algebra(&self, a: &SVector<T, N>) -> SVector<T, N> {
        *a
    }

    #[inline]
    fn adjoint(&self) -> Jacobian<T, N, N> {
        Jacobian::identity()
    }

    #[inline]
    fn right_jacobian(_v: &Tangent<T, N>) -> Jacobian<T, N, N> {
        Jacobian::identity()
    }

    #[inline]
    fn right_jacobian_inverse(_v: &Tangent<T, N>) -> Jacobian<T, N, N> {
        Jacobian::identity()
    }
}

impl<T: Real, const N: usize> GroupAction<N, N> for Rn<T, N> {
    /// Translation `p + x`, saturating at the largest finite value.
    #[inline]
    fn act(&self, p: &SVector<T, N>) -> SVector<T, N> {
        saturated(p + self.v)
    }

    #[inline]
    fn j_act_self(&self, _p: &SVector<T, N>) -> Jacobian<T, N, N> {
        Jacobian::identity()
    }

    #[inline]
    fn j_act_point(&self, _p: &SVector<T, N>) -> Jacobian<T, N, N> {
        Jacobian::identity()
    }
}

crate::approx_impls::impl_approx_by_field!(Rn<T, N>, [T: Real, const N: usize], v);

impl<T: Real, const N: usize> From<Rn<T, N>> for SVector<T, N> {
    #[inline]
    fn from(x: Rn<T, N>) -> Self {
        x.v
    }
}
