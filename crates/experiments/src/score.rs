//! Scoring an estimate against the truth, through the manifold: named metrics written into a slice
//! (no allocation per epoch).

use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;

/// Named metrics of an estimate `E` against a true state `T`.
pub trait Scorer<T, E>: Sync {
    /// The metric names, in the order [`score`](Self::score) writes them.
    fn names(&self) -> &'static [&'static str];

    /// Writes one value per name into `values` (whose length is `names().len()`).
    fn score(&self, truth: &T, estimate: &E, values: &mut [f64]);
}

/// The scores of a Gaussian on a manifold against a true point x, through the manifold's `local`:
/// the error `e = x ⊟ μ` (the truth seen from the estimate, in the estimate's tangent space),
///
/// * `squared_error`: `|e|²`, whose mean over runs at an epoch is the squared RMSE;
/// * `nees`: `eᵀ P⁻¹ e`, χ² with D degrees of freedom for a consistent filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ManifoldScorer;

impl<X: Manifold<D, Scalar = f64>, const D: usize> Scorer<X, ManifoldGaussian<X, D>>
    for ManifoldScorer
{
    fn names(&self) -> &'static [&'static str] {
        &["squared_error", "nees"]
    }

    fn score(&self, truth: &X, estimate: &ManifoldGaussian<X, D>, values: &mut [f64]) {
        values[0] = estimate.mean().local(truth).norm_squared();
        values[1] = estimate.mahalanobis_squared(truth);
    }
}
