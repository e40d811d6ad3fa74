//! Small numerical pieces shared by the operators: log weights (particle set, grid), the weighted mean
//! on a manifold (UKF, particle set) and the validated Gaussian a filter step returns.

use crate::OperatorError;
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use nalgebra::{SMatrix, SVector};

/// Iterations of a weighted mean before giving up; convergence to 1e-12 takes 2 to 5 in practice.
pub(crate) const MEAN_ITERATIONS: usize = 50;
/// A weighted mean is converged when its step is below this (in tangent units; relative to `1 + |ẑ|`
/// for the UKF's measurement mean).
pub(crate) const MEAN_TOLERANCE: f64 = 1e-12;

/// The weighted mean on a manifold of points `yᵢ` with weights `wᵢ` summing to 1 (some may be
/// negative, as the UKF's centre weight): the fixed point of `m ← m ⊞ Σ wᵢ (yᵢ ⊟ m)`, by Gauss-Newton
/// from `start`, at most 50 iterations, stopping at a step below 1e-12. Never an average of
/// coordinates, so points on both sides of ±π average correctly. One function for the UKF and the
/// particle set (the manifolds crate's shared weighted mean will replace it).
pub(crate) fn manifold_mean<'a, X, const D: usize>(
    start: &X,
    points: &(impl Iterator<Item = (f64, &'a X)> + Clone),
) -> X
where
    X: Manifold<D, Scalar = f64> + 'a,
{
    let mut mean = start.clone();
    for _ in 0..MEAN_ITERATIONS {
        let step = points
            .clone()
            .map(|(w, y)| mean.local(y) * w)
            .sum::<SVector<f64, D>>();
        mean = mean.retract(&step);
        if step.norm() < MEAN_TOLERANCE {
            break;
        }
    }
    mean
}

/// The Gaussian a filter step returns: P symmetrised as `(P + Pᵀ)/2`, then validated; `what` names
/// the step's covariance and what to check when it is refused (non-finite, not positive definite, or
/// with an unrepresentable inverse).
pub(crate) fn checked_gaussian<X: Manifold<D, Scalar = f64>, const D: usize>(
    mean: X,
    covariance: &SMatrix<f64, D, D>,
    what: &'static str,
) -> Result<ManifoldGaussian<X, D>, OperatorError> {
    ManifoldGaussian::new(mean, (covariance + covariance.transpose()) * 0.5)
        .map_err(|_| OperatorError::NotPositiveDefinite { what })
}

/// `ln Σ exp(lᵢ)`, computed as `m + ln Σ exp(lᵢ − m)` with m the largest term so that nothing
/// overflows or underflows; −∞ for no terms or all terms −∞.
pub(crate) fn log_sum_exp(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let max = values.clone().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return max;
    }
    max + values.map(|l| (l - max).exp()).sum::<f64>().ln()
}

/// Normalised log weights (`Σ exp(lᵢ) = 1`) with a buffer of pending values, so that a Bayes step
/// computes every log-likelihood first and changes the weights only once all are valid: a failed step
/// leaves the weights as they were, and no step allocates.
#[derive(Clone, Debug)]
pub(crate) struct LogWeights {
    values: Vec<f64>,
    pending: Vec<f64>,
}

impl LogWeights {
    /// n equal weights.
    pub(crate) fn uniform(n: usize) -> Self {
        Self {
            values: vec![-(n as f64).ln(); n],
            pending: Vec::with_capacity(n),
        }
    }

    /// The normalised log weights.
    pub(crate) fn values(&self) -> &[f64] {
        &self.values
    }

    /// The pending buffer, to be filled with one value per weight before [`Self::add_pending`] or
    /// [`Self::replace_with_pending`] (also usable as scratch space in between).
    pub(crate) fn pending(&mut self) -> &mut Vec<f64> {
        &mut self.pending
    }

    /// The linear weights `wᵢ = exp(lᵢ)`, computed into the pending buffer (for resampling).
    pub(crate) fn linear(&mut self) -> &[f64] {
        self.pending.clear();
        self.pending.extend(self.values.iter().map(|l| l.exp()));
        &self.pending
    }

    /// Resets to n equal weights.
    pub(crate) fn reset_uniform(&mut self) {
        let n = self.values.len();
        self.values.fill(-(n as f64).ln());
    }

    /// Bayes: `lᵢ += pendingᵢ`, then normalisation. Returns `ln Σ wᵢ exp(pendingᵢ)` (the log evidence,
    /// the weights being normalised before the step).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] when a pending value is NaN or +∞, or when every updated weight is
    /// zero; the weights are then unchanged.
    pub(crate) fn add_pending(&mut self, what: &'static str) -> Result<f64, OperatorError> {
        check(what, &self.pending)?;
        for (p, l) in self.pending.iter_mut().zip(&self.values) {
            *p += l;
        }
        self.normalise_pending()
    }

    /// The pending values, normalised, become the weights.
    ///
    /// # Errors
    /// As [`Self::add_pending`].
    pub(crate) fn replace_with_pending(&mut self, what: &'static str) -> Result<(), OperatorError> {
        check(what, &self.pending)?;
        self.normalise_pending().map(|_| ())
    }

    /// Normalises the pending values into the weights; returns their log total.
    fn normalise_pending(&mut self) -> Result<f64, OperatorError> {
        let total = log_sum_exp(self.pending.iter().copied());
        if total == f64::NEG_INFINITY {
            return Err(OperatorError::NonFinite {
                what: "total weight (every weight would be zero)",
                value: total,
            });
        }
        for (l, p) in self.values.iter_mut().zip(&self.pending) {
            *l = p - total;
        }
        Ok(total)
    }
}

/// Refuses NaN and +∞ (−∞, a zero weight, is allowed).
fn check(what: &'static str, values: &[f64]) -> Result<(), OperatorError> {
    match values.iter().find(|v| v.is_nan() || **v == f64::INFINITY) {
        Some(&value) => Err(OperatorError::NonFinite { what, value }),
        None => Ok(()),
    }
}
