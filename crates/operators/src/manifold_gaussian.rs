//! [`ManifoldGaussian`]: the error-state Gaussian of the EKF and UKF, and the two model traits they
//! linearise or sample.
//!
//! A point `μ` of a manifold and a covariance `P` in its tangent space stand for `x = μ ⊞ δ`,
//! `δ ~ N(0, P)`. The filters never add or average points: every difference is `local` (y ⊟ x) and every
//! correction `retract` (x ⊞ δ), so angles need no wrapping by hand.

use crate::OperatorError;
use crate::error::all_finite;
use liebayes_manifolds::Manifold;
use nalgebra::{Cholesky, SMatrix, SVector};
use std::f64::consts::PI;

/// `x = μ ⊞ δ`, `δ ~ N(0, P)`: a mean on the manifold and a covariance in the tangent space at the mean.
#[derive(Clone, Debug, PartialEq)]
pub struct ManifoldGaussian<X, const D: usize> {
    mean: X,
    covariance: SMatrix<f64, D, D>,
}

impl<X: Manifold<D, Scalar = f64>, const D: usize> ManifoldGaussian<X, D> {
    /// The Gaussian with mean μ and tangent covariance P (symmetric positive definite).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite P, [`OperatorError::NotPositiveDefinite`] when P is
    /// not symmetric positive definite.
    pub fn new(mean: X, covariance: SMatrix<f64, D, D>) -> Result<Self, OperatorError> {
        all_finite("tangent covariance P", covariance.iter())?;
        let symmetric = (covariance + covariance.transpose()) * 0.5;
        if (covariance - symmetric).amax() > 1e-9 * covariance.amax()
            || Cholesky::new(symmetric).is_none()
        {
            return Err(OperatorError::NotPositiveDefinite {
                what: "tangent covariance P",
            });
        }
        Ok(Self {
            mean,
            covariance: symmetric,
        })
    }

    /// From a covariance that [`checked_covariance`] has just symmetrised and factored.
    pub(crate) fn from_checked(mean: X, covariance: SMatrix<f64, D, D>) -> Self {
        Self { mean, covariance }
    }

    /// μ.
    pub fn mean(&self) -> &X {
        &self.mean
    }

    /// P, in the tangent space at μ.
    pub fn covariance(&self) -> &SMatrix<f64, D, D> {
        &self.covariance
    }
}

/// A process `x′ = f(x, u) ⊞ w`, `w ~ N(0, Q)` with w in the tangent space at f(x, u).
pub trait ProcessModel<X: Manifold<D, Scalar = f64>, const D: usize> {
    /// What drives the process (a velocity and a time step, …).
    type Input;

    /// The noise-free motion f(x, u).
    fn transition(&self, x: &X, input: &Self::Input) -> X;

    /// Q, the covariance of w in the tangent space at f(x, u).
    fn noise(&self, x: &X, input: &Self::Input) -> SMatrix<f64, D, D>;

    /// `F = ∂ [f(x ⊞ δ, u) ⊟ f(x, u)] / ∂δ` at δ = 0 (a right Jacobian). The default is a central
    /// difference with step 1e-6 in each tangent direction: its error is about 1e-10 times the size of
    /// f's coordinates (rounding) plus 1e-12 times f's third derivative (truncation). Override it with
    /// the analytic form for accuracy far from the origin and for speed on a hot path.
    fn jacobian(&self, x: &X, input: &Self::Input) -> SMatrix<f64, D, D> {
        let centre = self.transition(x, input);
        numeric_jacobian(x, |y| centre.local(&self.transition(y, input)))
    }
}

/// A measurement `z = h(x) + n`, `n ~ N(0, R)`, with z in R^M and an innovation `z ⊟ ẑ` that may wrap
/// (an angle measured as one coordinate, say).
pub trait MeasurementModel<X: Manifold<D, Scalar = f64>, const D: usize, const M: usize> {
    /// The predicted measurement h(x).
    fn predict(&self, x: &X) -> SVector<f64, M>;

    /// R.
    fn noise(&self, x: &X) -> SMatrix<f64, M, M>;

    /// z ⊟ ẑ: `z − ẑ` unless a coordinate lives on a circle, where the override wraps it.
    fn residual(&self, z: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M> {
        z - predicted
    }

    /// `H = ∂ [h(x ⊞ δ) ⊟ h(x)] / ∂δ` at δ = 0. Default: central differences, as
    /// [`ProcessModel::jacobian`].
    fn jacobian(&self, x: &X) -> SMatrix<f64, M, D> {
        let centre = self.predict(x);
        numeric_jacobian(x, |y| self.residual(&self.predict(y), &centre))
    }
}

/// `∂ g(x ⊞ δ) / ∂δ` at 0 by central differences with step 1e-6 (g(x) is assumed to be 0).
fn numeric_jacobian<X: Manifold<D, Scalar = f64>, const D: usize, const K: usize>(
    x: &X,
    g: impl Fn(&X) -> SVector<f64, K>,
) -> SMatrix<f64, K, D> {
    const STEP: f64 = 1e-6;
    SMatrix::<f64, K, D>::from_columns(&std::array::from_fn::<_, D, _>(|j| {
        let mut e = SVector::<f64, D>::zeros();
        e[j] = STEP;
        (g(&x.retract(&e)) - g(&x.retract(&-e))) / (2.0 * STEP)
    }))
}

/// The Gaussian conditioning step shared by the EKF and the UKF, from the innovation ν, its covariance
/// S and the cross-covariance C = Cov(δ, z): `K = C S⁻¹`, `μ⁺ = μ ⊞ K ν`, `P⁺ = P − K S Kᵀ`, and the
/// log evidence `ln N(ν; 0, S)`. (The EKF passes C = P Hᵀ and uses the Joseph form itself.)
pub(crate) struct GaussianUpdate<const D: usize, const M: usize> {
    /// K.
    pub gain: SMatrix<f64, D, M>,
    /// K ν.
    pub correction: SVector<f64, D>,
    /// `ln N(ν; 0, S)`.
    pub log_evidence: f64,
}

impl<const D: usize, const M: usize> GaussianUpdate<D, M> {
    pub(crate) fn new(
        innovation: &SVector<f64, M>,
        innovation_covariance: &SMatrix<f64, M, M>,
        cross_covariance: &SMatrix<f64, D, M>,
    ) -> Result<Self, OperatorError> {
        let s = (innovation_covariance + innovation_covariance.transpose()) * 0.5;
        let factor = Cholesky::new(s).ok_or(OperatorError::NotPositiveDefinite {
            what: "innovation covariance S (make the measurement noise R positive definite)",
        })?;
        let gain = factor.solve(&cross_covariance.transpose()).transpose();
        let log_det = 2.0 * factor.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
        let log_evidence = -0.5
            * (innovation.dot(&factor.solve(innovation)) + log_det + M as f64 * (2.0 * PI).ln());
        Ok(Self {
            correction: gain * innovation,
            gain,
            log_evidence,
        })
    }
}

/// Symmetrises P and checks that it is finite and positive definite (one Cholesky factorisation), after
/// a propagation or an update.
pub(crate) fn checked_covariance<const D: usize>(
    p: SMatrix<f64, D, D>,
) -> Result<SMatrix<f64, D, D>, OperatorError> {
    let p = (p + p.transpose()) * 0.5;
    if p.iter().all(|v| v.is_finite()) && Cholesky::new(p).is_some() {
        Ok(p)
    } else {
        Err(OperatorError::NotPositiveDefinite {
            what: "posterior covariance (the update lost positive definiteness; check R and the model)",
        })
    }
}
