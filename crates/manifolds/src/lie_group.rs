//! The [`LieGroup`] and [`GroupAction`] traits, with the Jacobians every group derives from its
//! adjoint and its right Jacobian.
//!
//! Convention (see the crate docs): a Jacobian `J_out_in` is defined by
//! `out(in ⊞ δ) = out(in) ⊞ (J_out_in δ + O(|δ|²))` with the type's own ⊞ ([`Manifold::retract`]);
//! for tangent-valued or point-valued outputs ⊞ is plain addition. The groups of the crate perturb on
//! the right, `x ⊞ δ = x · exp(δ)`, and the provided Jacobians are the formulas for that retraction;
//! [`Left`](crate::Left) perturbs on the left and overrides all of them.

use crate::manifold::{Jacobian, Manifold, Tangent};
use nalgebra::SVector;
use std::fmt::Debug;

/// A Lie group of dimension `D`.
///
/// Implementors provide the group operations, `exp`/`log`, `hat`/`vee`, the adjoint and the right
/// Jacobian (with its inverse); the Jacobians of compose, inverse, exp, log, retract and local follow
/// from those and are provided.
///
/// **The Jacobians follow the type's retraction.** Every `j_<out>_<in>` is the matrix J with
/// `out(in ⊞ δ) = out(in) ⊞ (J δ + O(|δ|²))`, where ⊞ is [`Manifold::retract`] of this type, on the
/// input and on the output alike. The intrinsic maps (`right_jacobian`, `left_jacobian`, their
/// inverses, `adjoint`) do not depend on it. The provided implementations are the formulas for the
/// right retraction `x ⊞ δ = x · exp(δ)` that every group of the crate uses (body-frame errors); a type
/// with another retraction must override all of them, as [`Left`](crate::Left) does for world-frame
/// errors `x ⊞ δ = exp(δ) · x`. There are no `retract_left`/`local_left` methods: wrapping the group in
/// `Left` is the one way to perturb on the left, and it keeps every generic operator working.
///
/// # Example
/// ```
/// use liebayes_manifolds::{LieGroup, Manifold, So3};
/// use nalgebra::Vector3;
/// let x = So3::exp(&Vector3::new(0.1, 0.2, 0.3));
/// let y = So3::exp(&Vector3::new(-0.4, 0.0, 0.5));
/// // Group laws and the right perturbation x ⊞ v = x · exp(v).
/// assert!(x.compose(&x.inverse()).distance(&So3::identity()) < 1e-15);
/// let v = x.local(&y);
/// assert!(x.compose(&So3::exp(&v)).distance(&y) < 1e-15);
/// ```
pub trait LieGroup<const D: usize>: Manifold<D> {
    /// The Lie algebra in the group's own representation (a skew matrix for SO(2)/SO(3), a pure
    /// quaternion for SU(2), a vector for Rⁿ).
    type Algebra: Clone + Debug;

    /// The identity element.
    fn identity() -> Self;

    /// The group product `self · other`.
    #[must_use]
    fn compose(&self, other: &Self) -> Self;

    /// The inverse element.
    #[must_use]
    fn inverse(&self) -> Self;

    /// The exponential map from tangent coordinates.
    fn exp(v: &Tangent<Self::Scalar, D>) -> Self;

    /// The logarithm on the principal branch (the inverse of `exp` inside the injectivity radius).
    fn log(&self) -> Tangent<Self::Scalar, D>;

    /// Tangent coordinates to a Lie-algebra element.
    fn hat(v: &Tangent<Self::Scalar, D>) -> Self::Algebra;

    /// Lie-algebra element to tangent coordinates (the inverse of [`hat`](Self::hat)).
    fn vee(a: &Self::Algebra) -> Tangent<Self::Scalar, D>;

    /// `g a g⁻¹` computed in the group's representation (matrix or quaternion products), independently
    /// of [`adjoint`](Self::adjoint): the law `adjoint() v == vee(conjugate_algebra(hat(v)))` checks one
    /// against the other.
    fn conjugate_algebra(&self, a: &Self::Algebra) -> Self::Algebra;

    /// The adjoint matrix `Ad(g)`, with `g · exp(v) · g⁻¹ = exp(Ad(g) v)`.
    fn adjoint(&self) -> Jacobian<Self::Scalar, D, D>;

    /// Right Jacobian `Jr(v)`: `exp(v + δ) = exp(v) · exp(Jr(v) δ + O(|δ|²))`.
    fn right_jacobian(v: &Tangent<Self::Scalar, D>) -> Jacobian<Self::Scalar, D, D>;

    /// Inverse of the right Jacobian: `log(exp(v) · exp(δ)) = v + Jr⁻¹(v) δ + O(|δ|²)` inside the
    /// injectivity radius.
    fn right_jacobian_inverse(v: &Tangent<Self::Scalar, D>) -> Jacobian<Self::Scalar, D, D>;

    /// Left Jacobian `Jl(v) = Jr(-v)`: `exp(v + δ) = exp(Jl(v) δ + O(|δ|²)) · exp(v)`.
    fn left_jacobian(v: &Tangent<Self::Scalar, D>) -> Jacobian<Self::Scalar, D, D> {
        Self::right_jacobian(&-v)
    }

    /// Inverse of the left Jacobian, `Jl⁻¹(v) = Jr⁻¹(-v)`.
    fn left_jacobian_inverse(v: &Tangent<Self::Scalar, D>) -> Jacobian<Self::Scalar, D, D> {
        Self::right_jacobian_inverse(&-v)
    }

    /// `J_compose_self`: Jacobian of `self · other` with respect to `self`; `Ad(other⁻¹)` for the right
    /// retraction.
    fn j_compose_self(&self, other: &Self) -> Jacobian<Self::Scalar, D, D> {
        other.inverse().adjoint()
    }

    /// `J_compose_other`: Jacobian of `self · other` with respect to `other`; the identity for the
    /// right retraction.
    fn j_compose_other(&self, _other: &Self) -> Jacobian<Self::Scalar, D, D> {
        Jacobian::identity()
    }

    /// `J_inverse_self`: Jacobian of `self⁻¹` with respect to `self`; `-Ad(self)` for the right
    /// retraction.
    fn j_inverse_self(&self) -> Jacobian<Self::Scalar, D, D> {
        -self.adjoint()
    }

    /// `J_exp_tangent`: Jacobian of `exp(v)` with respect to `v`; `Jr(v)` for the right retraction.
    fn j_exp_tangent(v: &Tangent<Self::Scalar, D>) -> Jacobian<Self::Scalar, D, D> {
        Self::right_jacobian(v)
    }

    /// `J_log_self`: Jacobian of `log(self)` with respect to `self`; `Jr⁻¹(log(self))` for the right
    /// retraction.
    fn j_log_self(&self) -> Jacobian<Self::Scalar, D, D> {
        Self::right_jacobian_inverse(&self.log())
    }

    /// `J_retract_self`: Jacobian of `self ⊞ v` with respect to `self`; `Ad(exp(v))⁻¹ = Ad(exp(-v))`
    /// for the right retraction.
    fn j_retract_self(&self, v: &Tangent<Self::Scalar, D>) -> Jacobian<Self::Scalar, D, D> {
        Self::exp(&-v).adjoint()
    }

    /// `J_local_self`: Jacobian of `other ⊟ self` with respect to `self`; `-Jl⁻¹(other ⊟ self)` for the
    /// right retraction.
    fn j_local_self(&self, other: &Self) -> Jacobian<Self::Scalar, D, D> {
        -Self::left_jacobian_inverse(&self.local(other))
    }

    /// `J_local_other`: Jacobian of `other ⊟ self` with respect to `other`; `Jr⁻¹(other ⊟ self)` for
    /// the right retraction.
    fn j_local_other(&self, other: &Self) -> Jacobian<Self::Scalar, D, D> {
        Self::right_jacobian_inverse(&self.local(other))
    }
}

/// The action of a group of dimension `D` on points of `R^P` (rotation of vectors, translation).
///
/// # Example
/// ```
/// use liebayes_manifolds::{GroupAction, So3};
/// use nalgebra::Vector3;
/// let r = So3::from_axis_angle(&Vector3::z(), std::f64::consts::FRAC_PI_2).unwrap();
/// // A quarter turn about z takes x to y; the Jacobian in the point is the rotation matrix.
/// assert!((r.act(&Vector3::x()) - Vector3::y()).norm() < 1e-15);
/// assert!((r.j_act_point(&Vector3::x()) - r.to_matrix()).norm() < 1e-15);
/// ```
pub trait GroupAction<const D: usize, const P: usize>: LieGroup<D> {
    /// The transformed point `g · p`.
    fn act(&self, p: &SVector<Self::Scalar, P>) -> SVector<Self::Scalar, P>;

    /// `J_act_self`: Jacobian of `g · p` with respect to `g`, perturbed by the type's retraction.
    fn j_act_self(&self, p: &SVector<Self::Scalar, P>) -> Jacobian<Self::Scalar, P, D>;

    /// `J_act_point`: Jacobian of `g · p` with respect to `p`.
    fn j_act_point(&self, p: &SVector<Self::Scalar, P>) -> Jacobian<Self::Scalar, P, P>;
}

/// Implements [`Manifold`] for a group through `retract = compose(exp)` and `local = log(inverse · other)`,
/// with `is_finite` the given test of the stored coordinates.
macro_rules! impl_manifold_for_group {
    ($ty:ident, $dim:literal, |$x:ident| $finite:expr) => {
        impl<T: $crate::real::Real> $crate::manifold::Manifold<$dim> for $ty<T> {
            type Scalar = T;

            #[inline]
            fn retract(&self, v: &$crate::manifold::Tangent<T, $dim>) -> Self {
                self.compose(&<Self as $crate::lie_group::LieGroup<$dim>>::exp(v))
            }

            #[inline]
            fn local(&self, other: &Self) -> $crate::manifold::Tangent<T, $dim> {
                self.inverse().compose(other).log()
            }

            #[inline]
            fn is_finite(&self) -> bool {
                let $x = self;
                $finite
            }

            /// `Jr(v)`: `x exp(v + δ) = x exp(v) exp(Jr(v) δ)`.
            #[inline]
            fn j_retract_tangent(
                &self,
                v: &$crate::manifold::Tangent<T, $dim>,
            ) -> $crate::manifold::Jacobian<T, $dim, $dim> {
                <Self as $crate::lie_group::LieGroup<$dim>>::right_jacobian(v)
            }
        }
    };
}
pub(crate) use impl_manifold_for_group;
