//! [`Left`]: any Lie group with world-frame (left) perturbations.

use crate::lie_group::{GroupAction, LieGroup};
use crate::manifold::{Jacobian, Manifold, Tangent};
use crate::real::Real;
use crate::{Rn, Se2, Se3, Se23, So2, So3, Su2};
use approx::{AbsDiffEq, RelativeEq};
use nalgebra::SVector;

/// The Lie group `G` with its perturbations on the left, in the world frame:
/// `x ⊞ v = exp(v) · x` and `y ⊟ x = log(y · x⁻¹)`.
///
/// The groups of this crate perturb on the right (`x ⊞ v = x · exp(v)`, an error in the body frame).
/// Wrapping a group in `Left` changes only that: the group operations, `exp`, `log`, `hat`, `vee`, the
/// adjoint and the right and left Jacobians are intrinsic and delegate to `G`, while every Jacobian
/// that depends on the retraction (`j_compose_*`, `j_inverse_self`, `j_exp_tangent`, `j_log_self`,
/// `j_retract_*`, `j_local_*`, `j_act_self`) is the left-convention form: `J_out_in` with
/// `out(exp(δ) · in) = exp(J_out_in δ + O(|δ|²)) · out(in)`.
///
/// | Jacobian | `Left<G>` | `G` (right) |
/// |---|---|---|
/// | `j_compose_self(a, b)` | `I` | `Ad(b⁻¹)` |
/// | `j_compose_other(a, b)` | `Ad(a)` | `I` |
/// | `j_inverse_self(a)` | `−Ad(a⁻¹)` | `−Ad(a)` |
/// | `j_exp_tangent(v)` | `Jl(v)` | `Jr(v)` |
/// | `j_log_self(x)` | `Jl⁻¹(log x)` | `Jr⁻¹(log x)` |
/// | `j_retract_self(x, v)` | `Ad(exp v)` | `Ad(exp(−v))` |
/// | `j_retract_tangent(x, v)` | `Jl(v)` | `Jr(v)` |
/// | `j_local_self(x, y)` | `−Jr⁻¹(y ⊟ x)` | `−Jl⁻¹(y ⊟ x)` |
/// | `j_local_other(x, y)` | `Jl⁻¹(y ⊟ x)` | `Jr⁻¹(y ⊟ x)` |
/// | `j_act_self(x, p)` | `J_act_self^G(x, p) Ad(x⁻¹)` | `J_act_self^G(x, p)` |
///
/// Every generic operator written against [`Manifold`] or [`LieGroup`] (EKF, UKF, particle filters,
/// [`weighted_mean`](crate::weighted_mean)) therefore runs with either convention unchanged. Which one
/// to choose is a modelling question: see "Choosing the error convention" in the project's
/// conventions. A covariance moves between the two by the adjoint, `Σ_left = Ad(x) Σ_right Ad(x)ᵀ`.
///
/// There is deliberately no `retract_left` on [`LieGroup`]: `Left` is the one way to perturb on the
/// left, and its methods are the left versions of all the others.
///
/// # Example
/// ```
/// use liebayes_manifolds::{Left, LieGroup, Manifold, So3};
/// use nalgebra::Vector3;
///
/// let x = So3::<f64>::exp(&Vector3::new(0.3, -0.2, 1.0));
/// let d = Vector3::new(0.0, 0.0, 1e-3); // a small yaw, about the world z axis
/// let y = Left::new(x).retract(&d);
/// assert!(y.inner().distance(&So3::exp(&d).compose(&x)) < 1e-15);
/// assert!((Left::new(x).local(&y) - d).norm() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Left<G>(G);

impl<G> Left<G> {
    /// Wraps a group element (no cost).
    #[inline]
    pub const fn new(g: G) -> Self {
        Self(g)
    }

    /// The wrapped element.
    #[inline]
    pub const fn inner(&self) -> &G {
        &self.0
    }

    /// Unwraps the element (no cost).
    #[inline]
    pub fn into_inner(self) -> G {
        self.0
    }
}

impl<G> From<G> for Left<G> {
    #[inline]
    fn from(g: G) -> Self {
        Self(g)
    }
}

/// Implements `From<Left<G>> for G` for a group of the crate (a blanket impl is not allowed by the
/// orphan rules).
macro_rules! impl_from_left {
    ($ty:ty, [$($generics:tt)*]) => {
        impl<$($generics)*> From<Left<$ty>> for $ty {
            #[inline]
            fn from(x: Left<$ty>) -> Self {
                x.0
            }
        }
    };
}
impl_from_left!(So2<T>, [T: Real]);
impl_from_left!(So3<T>, [T: Real]);
impl_from_left!(Su2<T>, [T: Real]);
impl_from_left!(Rn<T, N>, [T: Real, const N: usize]);
impl_from_left!(Se2<T>, [T: Real]);
impl_from_left!(Se3<T>, [T: Real]);
impl_from_left!(Se23<T>, [T: Real]);

impl<G: LieGroup<D>, const D: usize> Manifold<D> for Left<G> {
    type Scalar = G::Scalar;

    /// `exp(v) · x`.
    #[inline]
    fn retract(&self, v: &Tangent<G::Scalar, D>) -> Self {
        Self(G::exp(v).compose(&self.0))
    }

    /// `log(y · x⁻¹)`.
    #[inline]
    fn local(&self, other: &Self) -> Tangent<G::Scalar, D> {
        other.0.compose(&self.0.inverse()).log()
    }

    #[inline]
    fn is_finite(&self) -> bool {
        self.0.is_finite()
    }

    /// `Jl(v)`: `exp(v + δ) x = exp(Jl(v) δ) · exp(v) x`.
    #[inline]
    fn j_retract_tangent(&self, v: &Tangent<G::Scalar, D>) -> Jacobian<G::Scalar, D, D> {
        G::left_jacobian(v)
    }
}

impl<G: LieGroup<D>, const D: usize> LieGroup<D> for Left<G> {
    type Algebra = G::Algebra;

    #[inline]
    fn identity() -> Self {
        Self(G::identity())
    }

    #[inline]
    fn compose(&self, other: &Self) -> Self {
        Self(self.0.compose(&other.0))
    }

    #[inline]
    fn inverse(&self) -> Self {
        Self(self.0.inverse())
    }

    #[inline]
    fn exp(v: &Tangent<G::Scalar, D>) -> Self {
        Self(G::exp(v))
    }

    #[inline]
    fn log(&self) -> Tangent<G::Scalar, D> {
        self.0.log()
    }

    #[inline]
    fn hat(v: &Tangent<G::Scalar, D>) -> G::Algebra {
        G::hat(v)
    }

    #[inline]
    fn vee(a: &G::Algebra) -> Tangent<G::Scalar, D> {
        G::vee(a)
    }

    #[inline]
    fn conjugate_algebra(&self, a: &G::Algebra) -> G::Algebra {
        self.0.conjugate_algebra(a)
    }

    #[inline]
    fn adjoint(&self) -> Jacobian<G::Scalar, D, D> {
        self.0.adjoint()
    }

    #[inline]
    fn right_jacobian(v: &Tangent<G::Scalar, D>) -> Jacobian<G::Scalar, D, D> {
        G::right_jacobian(v)
    }

    #[inline]
    fn right_jacobian_inverse(v: &Tangent<G::Scalar, D>) -> Jacobian<G::Scalar, D, D> {
        G::right_jacobian_inverse(v)
    }

    #[inline]
    fn left_jacobian(v: &Tangent<G::Scalar, D>) -> Jacobian<G::Scalar, D, D> {
        G::left_jacobian(v)
    }

    #[inline]
    fn left_jacobian_inverse(v: &Tangent<G::Scalar, D>) -> Jacobian<G::Scalar, D, D> {
        G::left_jacobian_inverse(v)
    }

    /// `I`: `exp(δ) a · b = exp(δ) · (a b)`.
    #[inline]
    fn j_compose_self(&self, _other: &Self) -> Jacobian<G::Scalar, D, D> {
        Jacobian::identity()
    }

    /// `Ad(a)`: `a · exp(δ) b = exp(Ad(a) δ) · (a b)`.
    #[inline]
    fn j_compose_other(&self, _other: &Self) -> Jacobian<G::Scalar, D, D> {
        self.0.adjoint()
    }

    /// `−Ad(a⁻¹)`: `(exp(δ) a)⁻¹ = a⁻¹ exp(−δ) = exp(−Ad(a⁻¹) δ) · a⁻¹`.
    #[inline]
    fn j_inverse_self(&self) -> Jacobian<G::Scalar, D, D> {
        -self.0.inverse().adjoint()
    }

    /// `Jl(v)`: `exp(v + δ) = exp(Jl(v) δ) · exp(v)`.
    #[inline]
    fn j_exp_tangent(v: &Tangent<G::Scalar, D>) -> Jacobian<G::Scalar, D, D> {
        G::left_jacobian(v)
    }

    /// `Jl⁻¹(log x)`: `log(exp(δ) exp(u)) = u + Jl⁻¹(u) δ`.
    #[inline]
    fn j_log_self(&self) -> Jacobian<G::Scalar, D, D> {
        G::left_jacobian_inverse(&self.0.log())
    }

    /// `Ad(exp v)`: `exp(v) exp(δ) x = exp(Ad(exp v) δ) · exp(v) x`.
    #[inline]
    fn j_retract_self(&self, v: &Tangent<G::Scalar, D>) -> Jacobian<G::Scalar, D, D> {
        G::exp(v).adjoint()
    }

    /// `−Jr⁻¹(y ⊟ x)`: with `u = log(y x⁻¹)`, `log(y (exp(δ) x)⁻¹) = log(exp(u) exp(−δ)) = u − Jr⁻¹(u) δ`.
    #[inline]
    fn j_local_self(&self, other: &Self) -> Jacobian<G::Scalar, D, D> {
        -G::right_jacobian_inverse(&self.local(other))
    }

    /// `Jl⁻¹(y ⊟ x)`: `log(exp(δ) y x⁻¹) = log(exp(δ) exp(u)) = u + Jl⁻¹(u) δ`.
    #[inline]
    fn j_local_other(&self, other: &Self) -> Jacobian<G::Scalar, D, D> {
        G::left_jacobian_inverse(&self.local(other))
    }
}

impl<G: GroupAction<D, P>, const D: usize, const P: usize> GroupAction<D, P> for Left<G> {
    #[inline]
    fn act(&self, p: &SVector<G::Scalar, P>) -> SVector<G::Scalar, P> {
        self.0.act(p)
    }

    /// `J_act_self^G(x, p) Ad(x⁻¹)`, since `exp(δ) x = x exp(Ad(x⁻¹) δ)`; for rotations `−hat(R p)`.
    /// Saturating at the largest finite value, like the group's own.
    #[inline]
    fn j_act_self(&self, p: &SVector<G::Scalar, P>) -> Jacobian<G::Scalar, P, D> {
        crate::pose::mul_saturating(&self.0.j_act_self(p), &self.0.inverse().adjoint())
    }

    #[inline]
    fn j_act_point(&self, p: &SVector<G::Scalar, P>) -> Jacobian<G::Scalar, P, P> {
        self.0.j_act_point(p)
    }
}

/// Compares the wrapped elements.
impl<G: AbsDiffEq> AbsDiffEq for Left<G> {
    type Epsilon = G::Epsilon;
    fn default_epsilon() -> G::Epsilon {
        G::default_epsilon()
    }
    fn abs_diff_eq(&self, other: &Self, epsilon: G::Epsilon) -> bool {
        self.0.abs_diff_eq(&other.0, epsilon)
    }
    /// The negation of `abs_diff_eq`.
    fn abs_diff_ne(&self, other: &Self, epsilon: G::Epsilon) -> bool {
        !self.abs_diff_eq(other, epsilon)
    }
}

/// Compares the wrapped elements.
impl<G: RelativeEq> RelativeEq for Left<G> {
    fn default_max_relative() -> G::Epsilon {
        G::default_max_relative()
    }
    fn relative_eq(&self, other: &Self, epsilon: G::Epsilon, max_relative: G::Epsilon) -> bool {
        self.0.relative_eq(&other.0, epsilon, max_relative)
    }
    /// The negation of `relative_eq`.
    fn relative_ne(&self, other: &Self, epsilon: G::Epsilon, max_relative: G::Epsilon) -> bool {
        !self.relative_eq(other, epsilon, max_relative)
    }
}
