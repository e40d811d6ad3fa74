//! [`ProductManifold`]: the product of two manifolds (or two Lie groups), factor by factor.

use crate::lie_group::LieGroup;
use crate::manifold::{Jacobian, Manifold, Tangent};
use crate::real::Real;
use approx::{AbsDiffEq, RelativeEq};
use nalgebra::ComplexField;

/// The product `A × B` of a manifold `A` of dimension `DA` and a manifold `B` of dimension `DB`, a
/// manifold of dimension `D = DA + DB`.
///
/// Tangent vectors are blocks `[v_A; v_B]` (the `DA` coordinates of `A` first), and everything acts
/// factor by factor: `(a, b) ⊞ [v_A; v_B] = (a ⊞ v_A, b ⊞ v_B)`, `(a', b') ⊟ (a, b) = [a' ⊟ a; b' ⊟ b]`,
/// and the distance is `√(d_A² + d_B²)`. When both factors are Lie groups the product is a Lie group:
/// compose, inverse, exp and log per factor, the algebra the pair of the factors' algebras, and the
/// adjoint and every Jacobian block-diagonal with the factors' own blocks (so a factor keeps its
/// convention: `Left<So3<f64>> × Rn` has world-frame attitude errors). Both factors share the scalar.
///
/// Stable Rust cannot compute `DA + DB` in a type, so `D` is a parameter, checked at compile time:
/// a product with `D ≠ DA + DB` does not build. Products nest, `(A × B) × C`.
///
/// # Example
/// ```
/// use liebayes_manifolds::{LieGroup, Manifold, ProductManifold, Rn, So3};
/// use nalgebra::{SVector, Vector3};
///
/// /// Attitude and gyroscope bias, one state.
/// type AttitudeBias = ProductManifold<So3<f64>, Rn<f64, 3>, 3, 3, 6>;
///
/// let x = AttitudeBias::new(So3::exp(&Vector3::new(0.1, 0.2, 0.3)), Rn::new(Vector3::zeros())?);
/// let dx = AttitudeBias::join_tangent(&Vector3::new(0.0, 0.0, 1e-3), &Vector3::new(1e-4, 0.0, 0.0));
/// let y = x.retract(&dx);
/// let (d_attitude, d_bias) = AttitudeBias::split_tangent(&x.local(&y));
/// assert!((d_attitude - Vector3::new(0.0, 0.0, 1e-3)).norm() < 1e-15);
/// assert!((d_bias - Vector3::new(1e-4, 0.0, 0.0)).norm() < 1e-15);
/// assert_eq!(x.adjoint().fixed_view::<3, 3>(0, 3), nalgebra::Matrix3::zeros());
/// # Ok::<(), liebayes_manifolds::ManifoldError>(())
/// ```
///
/// A wrong `D` is a compile-time error:
/// ```compile_fail
/// use liebayes_manifolds::{LieGroup, ProductManifold, Rn, So3};
/// let _ = ProductManifold::<So3<f64>, Rn<f64, 3>, 3, 3, 5>::identity();
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProductManifold<A, B, const DA: usize, const DB: usize, const D: usize> {
    first: A,
    second: B,
}

/// The compile-time check of a product's dimensions.
struct Dimensions<const DA: usize, const DB: usize, const D: usize>;

impl<const DA: usize, const DB: usize, const D: usize> Dimensions<DA, DB, D> {
    /// Evaluated wherever a product of these dimensions is built or its tangents are split.
    const ADD_UP: () = assert!(
        D == DA + DB,
        "ProductManifold<A, B, DA, DB, D> needs D == DA + DB: its tangent stacks the DA coordinates \
         of A over the DB coordinates of B"
    );
}

/// Construction and access.
impl<A, B, const DA: usize, const DB: usize, const D: usize> ProductManifold<A, B, DA, DB, D> {
    /// The point `(first, second)`.
    #[inline]
    pub const fn new(first: A, second: B) -> Self {
        let () = Dimensions::<DA, DB, D>::ADD_UP;
        Self { first, second }
    }

    /// The first factor.
    #[inline]
    pub const fn first(&self) -> &A {
        &self.first
    }

    /// The second factor.
    #[inline]
    pub const fn second(&self) -> &B {
        &self.second
    }

    /// The first factor, mutable.
    #[inline]
    pub fn first_mut(&mut self) -> &mut A {
        &mut self.first
    }

    /// The second factor, mutable.
    #[inline]
    pub fn second_mut(&mut self) -> &mut B {
        &mut self.second
    }

    /// The two factors.
    #[inline]
    pub fn into_parts(self) -> (A, B) {
        (self.first, self.second)
    }
}

/// Tangent blocks.
impl<A, B, const DA: usize, const DB: usize, const D: usize> ProductManifold<A, B, DA, DB, D>
where
    A: Manifold<DA>,
    B: Manifold<DB, Scalar = A::Scalar>,
{
    /// The blocks `(v_A, v_B)` of a tangent `v = [v_A; v_B]`.
    #[inline]
    pub fn split_tangent(
        v: &Tangent<A::Scalar, D>,
    ) -> (Tangent<A::Scalar, DA>, Tangent<A::Scalar, DB>) {
        let () = Dimensions::<DA, DB, D>::ADD_UP;
        (
            Tangent::from_fn(|i, _| v[i]),
            Tangent::from_fn(|i, _| v[DA + i]),
        )
    }

    /// The tangent `[v_A; v_B]`.
    #[inline]
    pub fn join_tangent(
        first: &Tangent<A::Scalar, DA>,
        second: &Tangent<A::Scalar, DB>,
    ) -> Tangent<A::Scalar, D> {
        let () = Dimensions::<DA, DB, D>::ADD_UP;
        Tangent::from_fn(|i, _| if i < DA { first[i] } else { second[i - DA] })
    }

    /// The block-diagonal matrix `diag(first, second)`.
    #[inline]
    fn block_diagonal(
        first: &Jacobian<A::Scalar, DA, DA>,
        second: &Jacobian<A::Scalar, DB, DB>,
    ) -> Jacobian<A::Scalar, D, D> {
        let () = Dimensions::<DA, DB, D>::ADD_UP;
        let mut m = Jacobian::<A::Scalar, D, D>::zeros();
        m.fixed_view_mut::<DA, DA>(0, 0).copy_from(first);
        m.fixed_view_mut::<DB, DB>(DA, DA).copy_from(second);
        m
    }
}

impl<A, B, const DA: usize, const DB: usize, const D: usize> From<(A, B)>
    for ProductManifold<A, B, DA, DB, D>
{
    #[inline]
    fn from((first, second): (A, B)) -> Self {
        Self::new(first, second)
    }
}

impl<A, B, const DA: usize, const DB: usize, const D: usize> Manifold<D>
    for ProductManifold<A, B, DA, DB, D>
where
    A: Manifold<DA>,
    B: Manifold<DB, Scalar = A::Scalar>,
{
    type Scalar = A::Scalar;

    /// `(a ⊞ v_A, b ⊞ v_B)`.
    #[inline]
    fn retract(&self, v: &Tangent<A::Scalar, D>) -> Self {
        let (va, vb) = Self::split_tangent(v);
        Self::new(self.first.retract(&va), self.second.retract(&vb))
    }

    /// `[a' ⊟ a; b' ⊟ b]`.
    #[inline]
    fn local(&self, other: &Self) -> Tangent<A::Scalar, D> {
        Self::join_tangent(
            &self.first.local(&other.first),
            &self.second.local(&other.second),
        )
    }

    #[inline]
    fn is_finite(&self) -> bool {
        self.first.is_finite() && self.second.is_finite()
    }

    /// `diag(J_A(v_A), J_B(v_B))`.
    #[inline]
    fn j_retract_tangent(&self, v: &Tangent<A::Scalar, D>) -> Jacobian<A::Scalar, D, D> {
        let (va, vb) = Self::split_tangent(v);
        Self::block_diagonal(
            &self.first.j_retract_tangent(&va),
            &self.second.j_retract_tangent(&vb),
        )
    }

    /// `√(d_A² + d_B²)` with the factors' own distances (computed without overflow).
    fn distance(&self, other: &Self) -> A::Scalar {
        self.first
            .distance(&other.first)
            .hypot(self.second.distance(&other.second))
    }
}

impl<A, B, const DA: usize, const DB: usize, const D: usize> LieGroup<D>
    for ProductManifold<A, B, DA, DB, D>
where
    A: LieGroup<DA>,
    B: LieGroup<DB, Scalar = A::Scalar>,
{
    /// The pair of the factors' algebras.
    type Algebra = (A::Algebra, B::Algebra);

    #[inline]
    fn identity() -> Self {
        Self::new(A::identity(), B::identity())
    }

    #[inline]
    fn compose(&self, other: &Self) -> Self {
        Self::new(
            self.first.compose(&other.first),
            self.second.compose(&other.second),
        )
    }

    #[inline]
    fn inverse(&self) -> Self {
        Self::new(self.first.inverse(), self.second.inverse())
    }

    #[inline]
    fn exp(v: &Tangent<A::Scalar, D>) -> Self {
        let (va, vb) = Self::split_tangent(v);
        Self::new(A::exp(&va), B::exp(&vb))
    }

    #[inline]
    fn log(&self) -> Tangent<A::Scalar, D> {
        Self::join_tangent(&self.first.log(), &self.second.log())
    }

    #[inline]
    fn hat(v: &Tangent<A::Scalar, D>) -> Self::Algebra {
        let (va, vb) = Self::split_tangent(v);
        (A::hat(&va), B::hat(&vb))
    }

    #[inline]
    fn vee((a, b): &Self::Algebra) -> Tangent<A::Scalar, D> {
        Self::join_tangent(&A::vee(a), &B::vee(b))
    }

    #[inline]
    fn conjugate_algebra(&self, (a, b): &Self::Algebra) -> Self::Algebra {
        (
            self.first.conjugate_algebra(a),
            self.second.conjugate_algebra(b),
        )
    }

    #[inline]
    fn adjoint(&self) -> Jacobian<A::Scalar, D, D> {
        Self::block_diagonal(&self.first.adjoint(), &self.second.adjoint())
    }

    #[inline]
    fn right_jacobian(v: &Tangent<A::Scalar, D>) -> Jacobian<A::Scalar, D, D> {
        let (va, vb) = Self::split_tangent(v);
        Self::block_diagonal(&A::right_jacobian(&va), &B::right_jacobian(&vb))
    }

    #[inline]
    fn right_jacobian_inverse(v: &Tangent<A::Scalar, D>) -> Jacobian<A::Scalar, D, D> {
        let (va, vb) = Self::split_tangent(v);
        Self::block_diagonal(
            &A::right_jacobian_inverse(&va),
            &B::right_jacobian_inverse(&vb),
        )
    }

    #[inline]
    fn left_jacobian(v: &Tangent<A::Scalar, D>) -> Jacobian<A::Scalar, D, D> {
        let (va, vb) = Self::split_tangent(v);
        Self::block_diagonal(&A::left_jacobian(&va), &B::left_jacobian(&vb))
    }

    #[inline]
    fn left_jacobian_inverse(v: &Tangent<A::Scalar, D>) -> Jacobian<A::Scalar, D, D> {
        let (va, vb) = Self::split_tangent(v);
        Self::block_diagonal(
            &A::left_jacobian_inverse(&va),
            &B::left_jacobian_inverse(&vb),
        )
    }

    #[inline]
    fn j_compose_self(&self, other: &Self) -> Jacobian<A::Scalar, D, D> {
        Self::block_diagonal(
            &self.first.j_compose_self(&other.first),
            &self.second.j_compose_self(&other.second),
        )
    }

    #[inline]
    fn j_compose_other(&self, other: &Self) -> Jacobian<A::Scalar, D, D> {
        Self::block_diagonal(
            &self.first.j_compose_other(&other.first),
            &self.second.j_compose_other(&other.second),
        )
    }

    #[inline]
    fn j_inverse_self(&self) -> Jacobian<A::Scalar, D, D> {
        Self::block_diagonal(&self.first.j_inverse_self(), &self.second.j_inverse_self())
    }

    #[inline]
    fn j_exp_tangent(v: &Tangent<A::Scalar, D>) -> Jacobian<A::Scalar, D, D> {
        let (va, vb) = Self::split_tangent(v);
        Self::block_diagonal(&A::j_exp_tangent(&va), &B::j_exp_tangent(&vb))
    }

    #[inline]
    fn j_log_self(&self) -> Jacobian<A::Scalar, D, D> {
        Self::block_diagonal(&self.first.j_log_self(), &self.second.j_log_self())
    }

    #[inline]
    fn j_retract_self(&self, v: &Tangent<A::Scalar, D>) -> Jacobian<A::Scalar, D, D> {
        let (va, vb) = Self::split_tangent(v);
        Self::block_diagonal(
            &self.first.j_retract_self(&va),
            &self.second.j_retract_self(&vb),
        )
    }

    #[inline]
    fn j_local_self(&self, other: &Self) -> Jacobian<A::Scalar, D, D> {
        Self::block_diagonal(
            &self.first.j_local_self(&other.first),
            &self.second.j_local_self(&other.second),
        )
    }

    #[inline]
    fn j_local_other(&self, other: &Self) -> Jacobian<A::Scalar, D, D> {
        Self::block_diagonal(
            &self.first.j_local_other(&other.first),
            &self.second.j_local_other(&other.second),
        )
    }
}

/// Both factors compare within `epsilon`.
impl<A, B, T, const DA: usize, const DB: usize, const D: usize> AbsDiffEq
    for ProductManifold<A, B, DA, DB, D>
where
    A: AbsDiffEq<Epsilon = T>,
    B: AbsDiffEq<Epsilon = T>,
    T: Real,
{
    type Epsilon = T;
    fn default_epsilon() -> T {
        T::default_epsilon()
    }
    fn abs_diff_eq(&self, other: &Self, epsilon: T) -> bool {
        self.first.abs_diff_eq(&other.first, epsilon)
            && self.second.abs_diff_eq(&other.second, epsilon)
    }
}

/// Both factors compare within `epsilon` and `max_relative`.
impl<A, B, T, const DA: usize, const DB: usize, const D: usize> RelativeEq
    for ProductManifold<A, B, DA, DB, D>
where
    A: RelativeEq<Epsilon = T>,
    B: RelativeEq<Epsilon = T>,
    T: Real,
{
    fn default_max_relative() -> T {
        T::default_max_relative()
    }
    fn relative_eq(&self, other: &Self, epsilon: T, max_relative: T) -> bool {
        self.first.relative_eq(&other.first, epsilon, max_relative)
            && self
                .second
                .relative_eq(&other.second, epsilon, max_relative)
    }
}
