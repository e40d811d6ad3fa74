//! Symmetric eigendecompositions with a bounded iteration: nalgebra's `SymmetricEigen::new`
//! iterates until it converges, without a limit.

use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DefaultAllocator, Dim, DimDiff, DimSub, OMatrix, SymmetricEigen, U1};

/// The most iterations an eigendecomposition takes (a 4 × 4 one converges in a few dozen).
const EIGEN_ITERATIONS: usize = 1000;

/// The eigendecomposition of a symmetric matrix (its lower triangle is read), `None` when it has
/// not converged within 1000 iterations or is not finite (nalgebra's can hold NaN for matrices
/// whose entries span more than the f64 range once scaled, such as 1e83 beside 1e-308).
pub(crate) fn bounded_eigen<D>(m: OMatrix<f64, D, D>) -> Option<SymmetricEigen<f64, D>>
where
    D: Dim + DimSub<U1>,
    DefaultAllocator: Allocator<D, D> + Allocator<D> + Allocator<DimDiff<D, U1>>,
{
    SymmetricEigen::try_new(m, f64::EPSILON, EIGEN_ITERATIONS).filter(|eigen| {
        eigen
            .eigenvalues
            .iter()
            .chain(eigen.eigenvectors.iter())
            .all(|v| v.is_finite())
    })
}

/// The smallest eigenvalue of a symmetric `n × n` matrix given by its column-major entries, for
/// an error message (a dynamic copy: error paths only); NaN when it cannot be computed.
pub(crate) fn smallest_eigenvalue(n: usize, entries: &[f64]) -> f64 {
    bounded_eigen(DMatrix::from_column_slice(n, n, entries))
        .map_or(f64::NAN, |e| e.eigenvalues.min())
}
