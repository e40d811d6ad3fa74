//! The [`Manifold`] trait: points, tangent vectors, and the two maps between them.

use crate::real::{Real, stable_norm};
use approx::AbsDiffEq;
use nalgebra::{SMatrix, SVector};
use std::fmt::Debug;

/// A tangent vector of a `D`-dimensional manifold, in the coordinates of the space's tangent basis.
pub type Tangent<T, const D: usize> = SVector<T, D>;

/// A Jacobian with `R` output and `C` input coordinates (`J_out_in`).
pub type Jacobian<T, const R: usize, const C: usize> = SMatrix<T, R, C>;

/// A smooth manifold of dimension `D` with a retraction and its local inverse.
///
/// * `retract(x, v)` is x ⊞ v: the point reached from `x` along the tangent vector `v`.
/// * `local(x, y)` is y ⊟ x: the tangent vector at `x` that leads to `y`.
///
/// Law: `x.local(&x.retract(&v)) == v` whenever `|v|` is below the space's injectivity radius
/// (π for SO(2), SO(3) and S², 2π for SU(2), unbounded for Rⁿ), and `x.retract(&x.local(&y)) == y`
/// wherever `local` is defined. On the Lie groups of this crate, `retract(x, v) = x · exp(v)`:
/// perturbations act on the right, in the tangent space at `x` (the body frame);
/// [`Left`](crate::Left) gives `exp(v) · x` (the world frame) and
/// [`ProductManifold`](crate::ProductManifold) acts factor by factor.
///
/// # Example
/// ```
/// use liebayes_manifolds::{Manifold, So2};
/// use nalgebra::Vector1;
/// let x = So2::from_angle(3.0_f64)?;
/// // ⊞ and ⊟ invert each other, across the ±π cut.
/// let y = x.retract(&Vector1::new(0.5));
/// assert!((x.local(&y)[0] - 0.5).abs() < 1e-15);
/// assert!((y.angle() - (3.5 - 2.0 * std::f64::consts::PI)).abs() < 1e-15);
/// # Ok::<(), liebayes_manifolds::ManifoldError>(())
/// ```
pub trait Manifold<const D: usize>: Clone + Debug + Sized {
    /// The scalar type of coordinates.
    type Scalar: Real;

    /// The dimension of the manifold (the length of a tangent vector).
    const DIM: usize = D;

    /// x ⊞ v: the point reached from `self` along the tangent vector `v`.
    #[must_use]
    fn retract(&self, v: &Tangent<Self::Scalar, D>) -> Self;

    /// y ⊟ x: the tangent vector at `self` that leads to `other`.
    fn local(&self, other: &Self) -> Tangent<Self::Scalar, D>;

    /// Whether every stored coordinate is finite. A point from a validated constructor always is;
    /// generic code checks it on the points that models and `*_unchecked` constructors return (a
    /// filter step refuses a state that is not, instead of carrying NaN on).
    fn is_finite(&self) -> bool;

    /// Geodesic distance: the norm of `self.local(other)` (computed without overflow or underflow).
    fn distance(&self, other: &Self) -> Self::Scalar {
        stable_norm(&self.local(other))
    }

    /// `J_retract_tangent`: the Jacobian of `self ⊞ v` with respect to v, seen from the point it
    /// reaches, `J(v) = ∂[(x ⊞ (v + ε)) ⊟ (x ⊞ v)]/∂ε` at ε = 0 (`J(0) = I`). It carries a step taken
    /// in the tangent space at x after v into the tangent space at `x ⊞ v`: a covariance of errors
    /// about x ⊞ v is `J P Jᵀ` for a P of errors about x offset by v (the covariance reset of an
    /// error-state filter), and the chain rule of a model evaluated at `x ⊞ v` and differentiated in
    /// v (an iterated update). Valid for `|v|` below the injectivity radius.
    ///
    /// Every space of the crate gives the closed form: `Jr(v)` for a group's right retraction,
    /// `Jl(v)` for [`Left`](crate::Left), `I` for Rⁿ, block-diagonal for products. The default, for
    /// a manifold that has no closed form (S², a user's space), is a central difference with step
    /// `h = ε^(1/3)` (ε the scalar's machine epsilon: 6e-6 in f64), accurate to about `ε^(2/3)`
    /// (4e-11 in f64) times the size of the retraction's third derivative.
    fn j_retract_tangent(&self, v: &Tangent<Self::Scalar, D>) -> Jacobian<Self::Scalar, D, D> {
        let step = nalgebra::ComplexField::cbrt(<Self::Scalar as AbsDiffEq>::default_epsilon());
        let reached = self.retract(v);
        Jacobian::from_fn(|i, j| {
            let mut e = *v;
            e[j] += step;
            let ahead = reached.local(&self.retract(&e))[i];
            e[j] = v[j] - step;
            let behind = reached.local(&self.retract(&e))[i];
            (ahead - behind) / (step + step)
        })
    }
}
