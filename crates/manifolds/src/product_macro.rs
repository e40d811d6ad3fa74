//! [`product_manifold!`](crate::product_manifold): a named product of any number of spaces, with its
//! dimension computed from the factors.
//!
//! Why a macro and not impls on tuples: the dimension of `(A, B, C)` is `DA + DB + DC`, and stable
//! Rust cannot compute a const generic argument from the generic parameters of an impl
//! (`impl<A, B> Manifold<{ DA + DB }> for (A, B)` needs the unstable `generic_const_exprs`). A tuple
//! impl would therefore make the user write every dimension again, as [`ProductManifold`] does. The
//! macro instead declares a concrete struct, whose dimension `DIM` is a constant expression over
//! concrete types (`<So3<f64> as Dimension>::DIM + …`), which stable Rust accepts as a const argument.
//! It also names the factors, so code reads `x.velocity()` rather than `x.first().second()`.
//!
//! [`ProductManifold`]: crate::ProductManifold

use crate::real::Real;
use nalgebra::{SMatrix, SVector};

/// Support for the code [`product_manifold!`](crate::product_manifold) generates in the user's
/// crate: not part of the API.
#[doc(hidden)]
pub mod __private {
    pub use approx;

    use super::{Real, SMatrix, SVector};

    /// The offsets of consecutive blocks of the given lengths: `[0, d₀, d₀ + d₁, …]`.
    #[must_use]
    pub const fn offsets<const N: usize>(dims: [usize; N]) -> [usize; N] {
        let mut out = [0; N];
        let mut i = 1;
        while i < N {
            out[i] = out[i - 1] + dims[i - 1];
            i += 1;
        }
        out
    }

    /// The `K` coordinates of `v` from `offset` on.
    #[inline]
    #[must_use]
    pub fn block<T: Real, const D: usize, const K: usize>(
        v: &SVector<T, D>,
        offset: usize,
    ) -> SVector<T, K> {
        v.fixed_rows::<K>(offset).into_owned()
    }

    /// Writes `b` on the diagonal of `m` at rows and columns `offset..offset + K`.
    #[inline]
    pub fn place<T: Real, const D: usize, const K: usize>(
        m: &mut SMatrix<T, D, D>,
        offset: usize,
        b: &SMatrix<T, K, K>,
    ) {
        m.fixed_view_mut::<K, K>(offset, offset).copy_from(b);
    }

    /// Zero.
    #[must_use]
    pub fn zero<T: Real>() -> T {
        T::zero()
    }

    /// The smallest of the values.
    #[must_use]
    pub fn fold_min<T: Real, const N: usize>(values: [T; N]) -> T {
        values
            .into_iter()
            .reduce(nalgebra::RealField::min)
            .unwrap_or_else(T::zero)
    }

    /// The largest of the values.
    #[must_use]
    pub fn fold_max<T: Real, const N: usize>(values: [T; N]) -> T {
        values
            .into_iter()
            .reduce(nalgebra::RealField::max)
            .unwrap_or_else(T::zero)
    }

    /// `√(a² + b²)` without overflow.
    #[inline]
    #[must_use]
    pub fn hypot<T: Real>(a: T, b: T) -> T {
        nalgebra::ComplexField::hypot(a, b)
    }
}

/// Declares a product of any number of named spaces: a struct with one field per factor that is a
/// [`Manifold`](crate::Manifold) of dimension the sum of the factors' dimensions, and a
/// [`LieGroup`](crate::LieGroup) when every factor is one. No dimension is written by hand.
///
/// ```
/// use liebayes_manifolds::{LieGroup, Manifold, Rn, So3, product_manifold};
/// use nalgebra::{SVector, Vector3};
///
/// product_manifold! {
///     /// The state of an inertial navigation filter.
///     pub struct NavState<f64> {
///         /// Body-to-world rotation.
///         pub attitude: So3<f64>,
///         /// Velocity in the world frame.
///         pub velocity: Rn<f64, 3>,
///         /// Position in the world frame.
///         pub position: Rn<f64, 3>,
///         /// Gyroscope and accelerometer biases.
///         pub bias: Rn<f64, 6>,
///     }
/// }
///
/// assert_eq!(NavState::DIM, 15);
/// assert_eq!(NavState::OFFSETS, [0, 3, 6, 9]);
/// let x = NavState::identity();
/// let dx = NavState::join_tangent(
///     &Vector3::new(0.0, 0.0, 1e-3),
///     &Vector3::new(0.1, 0.0, 0.0),
///     &Vector3::zeros(),
///     &SVector::<f64, 6>::zeros(),
/// );
/// let y = x.retract(&dx);
/// assert!((y.velocity().coords() - Vector3::new(0.1, 0.0, 0.0)).norm() < 1e-15);
/// let (d_attitude, _, _, d_bias) = NavState::split_tangent(&x.local(&y));
/// assert!((d_attitude - Vector3::new(0.0, 0.0, 1e-3)).norm() < 1e-15);
/// assert_eq!(d_bias, SVector::<f64, 6>::zeros());
/// // The covariance block of the biases: rows and columns OFFSETS[3]..OFFSETS[3] + DIMS[3].
/// let p = nalgebra::SMatrix::<f64, 15, 15>::identity();
/// let bias_block = p.fixed_view::<6, 6>(NavState::OFFSETS[3], NavState::OFFSETS[3]);
/// assert_eq!(bias_block.trace(), 6.0);
/// ```
///
/// # What it generates
/// For `struct Name<S> { a: A, b: B, … }` (attributes and visibilities as written; at least one
/// factor):
///
/// * the struct, deriving `Clone`, `Copy`, `Debug` and `PartialEq` (every space of this crate has
///   them; the factors must too);
/// * `Name::DIM` (the sum of the factors' [`Dimension::DIM`](crate::Dimension)), `Name::FACTORS`
///   (their number), `Name::DIMS` and `Name::OFFSETS` (each factor's dimension and the offset of its
///   block in a tangent, in declaration order), and an impl of [`Dimension`](crate::Dimension), so
///   products nest;
/// * `new(a, b, …)`, one accessor per factor with the field's name (`x.a()`), `into_parts()` and
///   `From<(A, B, …)>`;
/// * `split_tangent(&v) -> (v_a, v_b, …)` and `join_tangent(&v_a, &v_b, …)`: a tangent stacks the
///   factors' tangents in declaration order;
/// * [`Manifold`](crate::Manifold) factor by factor, as [`ProductManifold`](crate::ProductManifold):
///   `x ⊞ v = (a ⊞ v_a, b ⊞ v_b, …)`, `y ⊟ x = [a' ⊟ a; b' ⊟ b; …]`, distance `√(Σ dᵢ²)`;
/// * [`LieGroup`](crate::LieGroup), usable when every factor is a Lie group: group operations, exp
///   and log factor by factor, the algebra the tuple of the factors' algebras, and the adjoint and
///   every Jacobian block-diagonal with the factors' own blocks (so a [`Left`](crate::Left) factor
///   keeps its world-frame convention);
/// * `approx`'s `AbsDiffEq` and `RelativeEq`, usable when every factor has them (every space of this
///   crate does), comparing factor by factor;
/// * with this crate's `proptest` feature, the law suite's `LawSubject` (radius the smallest of the
///   factors', conditioning and scale the worst), so `testing::laws` runs on the product.
///
/// The type in angle brackets after the name is the scalar every factor shares (`f64` or `f32`),
/// checked at compile time; the struct itself is not generic. Declare one struct per scalar type: a
/// generic `struct Name<T>` would need its dimension as a const expression over `T`, which stable
/// Rust does not allow.
///
/// The `LieGroup` and `approx` impls carry their conditions as where-clauses, so a product with a
/// factor that is not a group (for instance [`S2`](crate::S2)) is still a manifold, and only using it
/// as a group fails to compile:
/// ```compile_fail,E0277
/// use liebayes_manifolds::{LieGroup, Rn, S2, product_manifold};
/// product_manifold! {
///     /// A direction and a bias: a manifold, not a group.
///     struct Pointing<f64> { direction: S2<f64>, bias: Rn<f64, 2> }
/// }
/// // A manifold: x.retract(&v) and x.local(&y) work. But S2<f64> is not a LieGroup:
/// let _ = <Pointing as LieGroup<4>>::identity();
/// ```
///
/// Factors of different scalar types do not build:
/// ```compile_fail,E0271
/// use liebayes_manifolds::{Rn, So3, product_manifold};
/// product_manifold! {
///     /// An f64 attitude with an f32 bias.
///     struct Mixed<f64> { attitude: So3<f64>, bias: Rn<f32, 3> }
/// }
/// ```
#[macro_export]
macro_rules! product_manifold {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident <$scalar:ty> {
            $(
                $(#[$field_meta:meta])*
                $field_vis:vis $field:ident : $ty:ty
            ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq)]
        $vis struct $name {
            $(
                $(#[$field_meta])*
                $field_vis $field: $ty,
            )+
        }

        impl $name {
            /// The dimension of the product: the sum of the factors' dimensions.
            pub const DIM: usize = 0 $(+ <$ty as $crate::Dimension>::DIM)+;

            /// The number of factors.
            pub const FACTORS: usize = [$(stringify!($field)),+].len();

            /// The dimension of each factor, in declaration order.
            pub const DIMS: [usize; $name::FACTORS] = [$(<$ty as $crate::Dimension>::DIM),+];

            /// The offset of each factor's block in a tangent vector, in declaration order: the
            /// block of factor `i` is `OFFSETS[i]..OFFSETS[i] + DIMS[i]`.
            pub const OFFSETS: [usize; $name::FACTORS] =
                $crate::__private::offsets($name::DIMS);

            /// The point with the given factors.
            #[inline]
            #[must_use]
            #[allow(clippy::too_many_arguments)]
            pub const fn new($($field: $ty),+) -> Self {
                Self { $($field),+ }
            }

            $(
                #[doc = concat!("The factor `", stringify!($field), "`.")]
                #[inline]
                #[must_use]
                pub const fn $field(&self) -> &$ty {
                    &self.$field
                }
            )+

            /// The factors, in declaration order.
            #[inline]
            #[must_use]
            pub fn into_parts(self) -> ($($ty,)+) {
                ($(self.$field,)+)
            }

            /// The blocks of a tangent vector, one per factor in declaration order.
            #[inline]
            #[must_use]
            pub fn split_tangent(
                v: &$crate::Tangent<$scalar, { $name::DIM }>,
            ) -> ($($crate::Tangent<
                $scalar,
                { <$ty as $crate::Dimension>::DIM },
            >,)+) {
                let [$($field),+] = $name::OFFSETS;
                ($($crate::__private::block(v, $field),)+)
            }

            /// The tangent vector stacking the factors' blocks, in declaration order.
            #[inline]
            #[must_use]
            #[allow(clippy::too_many_arguments)]
            pub fn join_tangent(
                $($field: &$crate::Tangent<
                    $scalar,
                    { <$ty as $crate::Dimension>::DIM },
                >),+
            ) -> $crate::Tangent<$scalar, { $name::DIM }> {
                $crate::Tangent::from_iterator(
                    ::core::iter::empty()$(.chain($field.iter().copied()))+,
                )
            }
        }

        impl ::core::convert::From<($($ty,)+)> for $name {
            #[inline]
            fn from(($($field,)+): ($($ty,)+)) -> Self {
                Self { $($field),+ }
            }
        }

        impl $crate::Dimension for $name {
            const DIM: usize = $name::DIM;
        }

        impl $crate::Manifold<{ $name::DIM }> for $name
        where
            $($ty: $crate::Manifold<
                { <$ty as $crate::Dimension>::DIM },
                Scalar = $scalar,
            >,)+
        {
            type Scalar = $scalar;

            /// Every factor retracted along its block.
            #[inline]
            fn retract(&self, v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> Self {
                let [$($field),+] = $name::OFFSETS;
                Self {
                    $($field: <$ty as $crate::Manifold<{ <$ty as $crate::Dimension>::DIM }>>::retract(
                        &self.$field,
                        &$crate::__private::block(v, $field),
                    ),)+
                }
            }

            /// The factors' `local`, stacked.
            #[inline]
            fn local(&self, other: &Self) -> $crate::Tangent<Self::Scalar, { $name::DIM }> {
                $name::join_tangent($(
                    &<$ty as $crate::Manifold<{ <$ty as $crate::Dimension>::DIM }>>::local(
                        &self.$field,
                        &other.$field,
                    )
                ),+)
            }

            #[inline]
            fn is_finite(&self) -> bool {
                true $(&& <$ty as $crate::Manifold<{ <$ty as $crate::Dimension>::DIM }>>::is_finite(
                    &self.$field,
                ))+
            }

            /// Block-diagonal: every factor's own.
            #[inline]
            fn j_retract_tangent(&self, v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::Manifold<{ <$ty as $crate::Dimension>::DIM }>>::j_retract_tangent(&self.$field, &$crate::__private::block(v, $field))),+)
            }

            /// `√(Σ dᵢ²)` with the factors' own distances (computed without overflow).
            fn distance(&self, other: &Self) -> Self::Scalar {
                let mut d = $crate::__private::zero::<Self::Scalar>();
                $(
                    d = $crate::__private::hypot(
                        d,
                        <$ty as $crate::Manifold<{ <$ty as $crate::Dimension>::DIM }>>::distance(
                            &self.$field,
                            &other.$field,
                        ),
                    );
                )+
                d
            }
        }

        $crate::__product_lie_group!($name, $scalar, $($field: $ty),+);
        $crate::__product_approx!($name, $scalar, $($field: $ty),+);
        $crate::__product_law_subject!($name, $scalar, $($field: $ty),+);
    };
}

/// The `LieGroup` impl of [`product_manifold!`](crate::product_manifold), under `for<'a>` bounds so
/// that it is checked where it is used (a product of manifolds that are not groups still builds).
#[doc(hidden)]
#[macro_export]
macro_rules! __product_lie_group {
    ($name:ident, $scalar:ty, $($field:ident : $ty:ty),+) => {
        impl $crate::LieGroup<{ $name::DIM }> for $name
        where
            $(for<'a> $ty: $crate::LieGroup<
                { <$ty as $crate::Dimension>::DIM },
                Scalar = $scalar,
            >,)+
        {
            /// The tuple of the factors' algebras.
            type Algebra = ($(<$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::Algebra,)+);

            #[inline]
            fn identity() -> Self {
                Self { $($field: <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::identity(),)+ }
            }

            #[inline]
            fn compose(&self, other: &Self) -> Self {
                Self { $($field: <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::compose(&self.$field, &other.$field),)+ }
            }

            #[inline]
            fn inverse(&self) -> Self {
                Self { $($field: <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::inverse(&self.$field),)+ }
            }

            #[inline]
            fn exp(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> Self {
                let [$($field),+] = $name::OFFSETS;
                Self { $($field: <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::exp(&$crate::__private::block(v, $field)),)+ }
            }

            #[inline]
            fn log(&self) -> $crate::Tangent<Self::Scalar, { $name::DIM }> {
                $name::join_tangent($(&<$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::log(&self.$field)),+)
            }

            #[inline]
            fn hat(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> Self::Algebra {
                let [$($field),+] = $name::OFFSETS;
                ($(<$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::hat(&$crate::__private::block(v, $field)),)+)
            }

            #[inline]
            fn vee(a: &Self::Algebra) -> $crate::Tangent<Self::Scalar, { $name::DIM }> {
                let ($($field,)+) = a;
                $name::join_tangent($(&<$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::vee($field)),+)
            }

            #[inline]
            fn conjugate_algebra(&self, a: &Self::Algebra) -> Self::Algebra {
                let ($($field,)+) = a;
                ($(<$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::conjugate_algebra(&self.$field, $field),)+)
            }

            #[inline]
            fn adjoint(&self) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::adjoint(&self.$field)),+)
            }

            #[inline]
            fn right_jacobian(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::right_jacobian(&$crate::__private::block(v, $field))),+)
            }

            #[inline]
            fn right_jacobian_inverse(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::right_jacobian_inverse(&$crate::__private::block(v, $field))),+)
            }

            #[inline]
            fn left_jacobian(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::left_jacobian(&$crate::__private::block(v, $field))),+)
            }

            #[inline]
            fn left_jacobian_inverse(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::left_jacobian_inverse(&$crate::__private::block(v, $field))),+)
            }

            #[inline]
            fn j_compose_self(&self, other: &Self) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::j_compose_self(&self.$field, &other.$field)),+)
            }

            #[inline]
            fn j_compose_other(&self, other: &Self) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::j_compose_other(&self.$field, &other.$field)),+)
            }

            #[inline]
            fn j_inverse_self(&self) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::j_inverse_self(&self.$field)),+)
            }

            #[inline]
            fn j_exp_tangent(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::j_exp_tangent(&$crate::__private::block(v, $field))),+)
            }

            #[inline]
            fn j_log_self(&self) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::j_log_self(&self.$field)),+)
            }

            #[inline]
            fn j_retract_self(&self, v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::j_retract_self(&self.$field, &$crate::__private::block(v, $field))),+)
            }

            #[inline]
            fn j_local_self(&self, other: &Self) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::j_local_self(&self.$field, &other.$field)),+)
            }

            #[inline]
            fn j_local_other(&self, other: &Self) -> $crate::Jacobian<Self::Scalar, { $name::DIM }, { $name::DIM }> {
                $crate::__product_diagonal!($name; $($field => <$ty as $crate::LieGroup<{ <$ty as $crate::Dimension>::DIM }>>::j_local_other(&self.$field, &other.$field)),+)
            }
        }
    };
}

/// The block-diagonal matrix of a product: for each factor, its block (an expression in which the
/// factor's name is bound to the offset of its block) placed at that offset.
#[doc(hidden)]
#[macro_export]
macro_rules! __product_diagonal {
    ($name:ident; $($offset:ident => $block:expr),+) => {{
        let mut m = $crate::Jacobian::zeros();
        let [$($offset),+] = $name::OFFSETS;
        $($crate::__private::place(&mut m, $offset, &$block);)+
        m
    }};
}

/// The `approx` impls of [`product_manifold!`](crate::product_manifold), under `for<'a>` bounds so
/// that they are checked where they are used.
#[doc(hidden)]
#[macro_export]
macro_rules! __product_approx {
    ($name:ident, $scalar:ty, $($field:ident : $ty:ty),+) => {
        /// Every factor compares within `epsilon`.
        impl $crate::__private::approx::AbsDiffEq for $name
        where
            $(for<'a> $ty: $crate::__private::approx::AbsDiffEq<
                Epsilon = $scalar,
            >,)+
        {
            type Epsilon = $scalar;

            fn default_epsilon() -> Self::Epsilon {
                <Self::Epsilon as $crate::__private::approx::AbsDiffEq>::default_epsilon()
            }

            fn abs_diff_eq(&self, other: &Self, epsilon: Self::Epsilon) -> bool {
                true $(&& $crate::__private::approx::AbsDiffEq::abs_diff_eq(
                    &self.$field,
                    &other.$field,
                    epsilon,
                ))+
            }

            /// The negation of `abs_diff_eq`.
            fn abs_diff_ne(&self, other: &Self, epsilon: Self::Epsilon) -> bool {
                !$crate::__private::approx::AbsDiffEq::abs_diff_eq(self, other, epsilon)
            }
        }

        /// Every factor compares within `epsilon` and `max_relative`.
        impl $crate::__private::approx::RelativeEq for $name
        where
            $(for<'a> $ty: $crate::__private::approx::RelativeEq<
                Epsilon = $scalar,
            >,)+
        {
            fn default_max_relative() -> Self::Epsilon {
                <Self::Epsilon as $crate::__private::approx::RelativeEq>::default_max_relative()
            }

            fn relative_eq(
                &self,
                other: &Self,
                epsilon: Self::Epsilon,
                max_relative: Self::Epsilon,
            ) -> bool {
                true $(&& $crate::__private::approx::RelativeEq::relative_eq(
                    &self.$field,
                    &other.$field,
                    epsilon,
                    max_relative,
                ))+
            }

            /// The negation of `relative_eq`.
            fn relative_ne(
                &self,
                other: &Self,
                epsilon: Self::Epsilon,
                max_relative: Self::Epsilon,
            ) -> bool {
                !$crate::__private::approx::RelativeEq::relative_eq(self, other, epsilon, max_relative)
            }
        }
    };
}

/// The law suite's `LawSubject` for [`product_manifold!`](crate::product_manifold) (this crate built
/// with `proptest`), under `for<'a>` bounds: a product is injective where every factor is (radius:
/// the smallest; ratio: the largest), has equivalent tangents block by block, is regular where every
/// factor is, and is as badly conditioned and as large as its worst factor.
#[cfg(feature = "proptest")]
#[doc(hidden)]
#[macro_export]
macro_rules! __product_law_subject {
    ($name:ident, $scalar:ty, $($field:ident : $ty:ty),+) => {
        impl $crate::testing::LawSubject<{ $name::DIM }> for $name
        where
            $(for<'a> $ty: $crate::testing::LawSubject<
                { <$ty as $crate::Dimension>::DIM },
                Scalar = $scalar,
            >,)+
        {
            fn injectivity_radius() -> Self::Scalar {
                let radii = [$(<$ty as $crate::testing::LawSubject<{ <$ty as $crate::Dimension>::DIM }>>::injectivity_radius()),+];
                $crate::__private::fold_min(radii)
            }

            fn equivalent_tangent_near(
                v: &$crate::Tangent<Self::Scalar, { $name::DIM }>,
                reference: &$crate::Tangent<Self::Scalar, { $name::DIM }>,
            ) -> $crate::Tangent<Self::Scalar, { $name::DIM }> {
                let [$($field),+] = $name::OFFSETS;
                $name::join_tangent($(
                    &<$ty as $crate::testing::LawSubject<{ <$ty as $crate::Dimension>::DIM }>>::equivalent_tangent_near(
                        &$crate::__private::block(v, $field),
                        &$crate::__private::block(reference, $field),
                    )
                ),+)
            }

            fn jacobian_is_regular(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> bool {
                let [$($field),+] = $name::OFFSETS;
                true $(&& <$ty as $crate::testing::LawSubject<{ <$ty as $crate::Dimension>::DIM }>>::jacobian_is_regular(
                    &$crate::__private::block(v, $field),
                ))+
            }

            fn log_condition(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> Self::Scalar {
                let [$($field),+] = $name::OFFSETS;
                $crate::__private::fold_max([$(
                    <$ty as $crate::testing::LawSubject<{ <$ty as $crate::Dimension>::DIM }>>::log_condition(
                        &$crate::__private::block(v, $field),
                    )
                ),+])
            }

            fn coordinate_scale(&self) -> Self::Scalar {
                $crate::__private::fold_max([$(
                    <$ty as $crate::testing::LawSubject<{ <$ty as $crate::Dimension>::DIM }>>::coordinate_scale(&self.$field)
                ),+])
            }

            fn injectivity_ratio(v: &$crate::Tangent<Self::Scalar, { $name::DIM }>) -> Self::Scalar {
                let [$($field),+] = $name::OFFSETS;
                $crate::__private::fold_max([$(
                    <$ty as $crate::testing::LawSubject<{ <$ty as $crate::Dimension>::DIM }>>::injectivity_ratio(
                        &$crate::__private::block(v, $field),
                    )
                ),+])
            }
        }
    };
}

/// Without the `proptest` feature there is no law suite to serve.
#[cfg(not(feature = "proptest"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __product_law_subject {
    ($($anything:tt)*) => {};
}
