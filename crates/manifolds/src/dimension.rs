//! [`Dimension`]: the dimension of a space as a constant of its type, without naming it.

use crate::{Left, ProductManifold, Real, Rn, S2, Se2, Se3, Se23, So2, So3, Su2};

/// The dimension of a space (the length of its tangent vectors) as an associated constant of the
/// type alone.
///
/// [`Manifold<D>`](crate::Manifold) carries its dimension as the parameter `D`, which a caller must
/// already know to name the trait. `Dimension` gives it from the type: `<So3<f64> as
/// Dimension>::DIM` is 3. The [`product_manifold!`](crate::product_manifold) macro adds the
/// dimensions of its factors this way, so no dimension is written by hand. Every space of the crate
/// implements it, and a product checks at compile time that each factor is a `Manifold<DIM>` of its
/// own `DIM`; a user type implements it with the `D` of its `Manifold` impl.
///
/// The name is shared with [`Manifold::DIM`](crate::Manifold::DIM) (the same number): with both
/// traits in scope write `<X as Dimension>::DIM`. The prelude does not import `Dimension`.
///
/// # Example
/// ```
/// use liebayes_manifolds::{Dimension, Left, Rn, Se23, So3};
/// assert_eq!(<So3<f64> as Dimension>::DIM, 3);
/// assert_eq!(<Left<Se23<f32>> as Dimension>::DIM, 9);
/// // In constant expressions too: a buffer of one tangent of R⁵ × SO(3).
/// let block = [0.0; <Rn<f64, 5> as Dimension>::DIM + <So3<f64> as Dimension>::DIM];
/// assert_eq!(block.len(), 8);
/// ```
pub trait Dimension {
    /// The dimension.
    const DIM: usize;
}

/// Implements [`Dimension`] for a space of the crate with a fixed dimension.
macro_rules! fixed_dimension {
    ($($ty:ident = $dim:literal),+ $(,)?) => {
        $(
            impl<T: Real> Dimension for $ty<T> {
                const DIM: usize = $dim;
            }
        )+
    };
}
fixed_dimension!(
    So2 = 1,
    So3 = 3,
    Su2 = 3,
    S2 = 2,
    Se2 = 3,
    Se3 = 6,
    Se23 = 9
);

impl<T: Real, const N: usize> Dimension for Rn<T, N> {
    const DIM: usize = N;
}

impl<G: Dimension> Dimension for Left<G> {
    const DIM: usize = G::DIM;
}

impl<A, B, const DA: usize, const DB: usize, const D: usize> Dimension
    for ProductManifold<A, B, DA, DB, D>
{
    const DIM: usize = D;
}

#[cfg(test)]
mod tests {
    //! `Dimension::DIM` is the `D` of every space's `Manifold<D>` impl.
    use super::*;
    use crate::Manifold;

    fn dimensions<M: Manifold<D> + Dimension, const D: usize>() -> (usize, usize) {
        (<M as Dimension>::DIM, D)
    }

    #[test]
    fn dimension_is_the_manifold_parameter() {
        for (dim, d) in [
            dimensions::<So2<f64>, 1>(),
            dimensions::<So3<f32>, 3>(),
            dimensions::<Su2<f64>, 3>(),
            dimensions::<S2<f64>, 2>(),
            dimensions::<Rn<f64, 7>, 7>(),
            dimensions::<Se2<f64>, 3>(),
            dimensions::<Se3<f64>, 6>(),
            dimensions::<Se23<f32>, 9>(),
            dimensions::<Left<Se23<f64>>, 9>(),
            dimensions::<ProductManifold<So3<f64>, Rn<f64, 2>, 3, 2, 5>, 5>(),
        ] {
            assert_eq!(dim, d);
        }
    }
}
