//! The extended Kalman filter on any [`Manifold`], in error-state form.
//!
//! With the density `x = μ ⊞ δ`, `δ ~ N(0, P)` ([`ManifoldGaussian`]):
//!
//! * **propagate**: `μ′ = f(μ, u)`, `P′ = F P Fᵀ + Q`, F the right Jacobian of the motion (and the
//!   cross-covariance `Cov(δ, δ′) = P Fᵀ` for the [smoother](crate::smoother));
//! * **condition**: `ν = z ⊟ h(μ)`, `S = H P Hᵀ + R`, `K = P Hᵀ S⁻¹`, `μ⁺ = μ ⊞ K ν`, and the
//!   Joseph form `P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ`; log evidence `ln N(ν; 0, S)` (the linearised
//!   model's, an approximation of `ln p(z)`); the report is the [`Innovation`] (ν, S, K, NIS).
//!   When R is below the rounding of `H P Hᵀ` and S or P⁺ loses positive definiteness to it, the
//!   update is made once more with `R + 64 M ε max(max |Sᵢᵢ|, |H|²_F max |Pᵢⱼ|) I` (information
//!   finer than the arithmetic holds is dropped; the posterior is slightly wider than the exact
//!   one). A prediction whose covariance rounding leaves singular (a prior far finer than a
//!   singular Q) is made once more with `Q + 64 D ε max |P′ᵢᵢ| I`, the same way.
//!
//! P⁺ is left in the tangent space at μ rather than transported to μ⁺ (the first-order "reset"
//! `J(Kν) P⁺ J(Kν)ᵀ`, [`Manifold::j_retract_tangent`], is omitted): on Rⁿ and SO(2) the two coincide;
//! elsewhere P⁺, linearised at the prior mean, is no better a description of the errors about μ⁺
//! than about μ when the correction is large, and transporting it made a world-frame attitude
//! filter from a 30° prior over-confident (average NEES 98 for 3 expected). The
//! [iterated EKF](crate::iterated), linearised at its own estimate, transports.

use crate::error::all_finite;
use crate::kalman::joseph;
use crate::models::{MeasurementModel, ProcessModel};
use crate::numerics::{
    Produced, above_rounding, checked_gaussian, checked_gaussian_above_rounding, model_noise,
    rounding_scale,
};
use crate::smoother::{GaussianTransition, Prediction};
use crate::{Condition, Conditioned, Innovation, OperatorError, Propagate};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use nalgebra::{SMatrix, SVector};

/// A model to be used by linearisation: `density.propagate(&Ekf(process), &u)`,
/// `density.condition(&Ekf(measurement), &z)`, or with a model kept elsewhere,
/// `density.propagate(&Ekf(&process), &u)`. M, the measurement dimension, is inferred from z (and is
/// 0, unused, for a process).
///
/// # Example
/// ```
/// use liebayes_operators::densities::ManifoldGaussian;
/// use liebayes_operators::manifolds::{Manifold, Rn};
/// use liebayes_operators::{Condition, Ekf, MeasurementFn};
/// use nalgebra::{Matrix1, Vector1};
///
/// // A range z = x² + n, linearised at the mean 2: H = 4.
/// let range = MeasurementFn::new(|x: &Rn<f64, 1>| Vector1::new(x.coords()[0].powi(2)), |_| {
///     Matrix1::new(1.0)
/// });
/// let prior = ManifoldGaussian::new(Rn::new(Vector1::new(2.0)).unwrap(), Matrix1::new(0.5)).unwrap();
/// let step = prior.condition(&Ekf(&range), &Vector1::new(5.0)).unwrap();
/// // Kalman gain K = P H / (H P H + R) = 2/9; the mean moves by K (z − 4), P by (1 − K H).
/// assert!((step.posterior.mean().coords()[0] - (2.0 + 2.0 / 9.0)).abs() < 1e-6);
/// assert!((step.posterior.covariance()[0] - 0.5 / 9.0).abs() < 1e-6);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ekf<Model, const M: usize = 0>(pub Model);

impl<X, P, const D: usize> GaussianTransition<X, D> for Ekf<P>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D>,
{
    type Input = P::Input;

    /// `μ′ = f(μ, u)`, `P′ = F P Fᵀ + Q`, cross-covariance `P Fᵀ`, noise Q.
    fn predict_with_cross(
        &self,
        prior: &ManifoldGaussian<X, D>,
        input: &P::Input,
    ) -> Result<Prediction<X, D>, OperatorError> {
        let mean = prior.mean();
        let noise = model_noise("process noise Q", self.0.noise(mean, input))?;
        let (propagated, cross) = self.0.propagate_covariance(mean, input, prior.covariance());
        let (density, floor) = checked_gaussian_above_rounding(
            &self.0.transition(mean, input),
            &(propagated + noise),
            Produced {
                mean: "the predicted mean f(mu, u) of the process model",
                covariance: "predicted covariance F P F^T + Q (check the process noise Q and the \
                             Jacobian F)",
            },
        )?;
        let noise = noise + SMatrix::<f64, D, D>::identity() * floor;
        // A model's own `propagate_covariance` may return a cross-covariance the predicted one
        // does not reveal; a smoother's record must hold a finite one.
        all_finite("cross-covariance P F^T of the process model", cross.iter())?;
        Ok(Prediction {
            density,
            cross_covariance: cross,
            noise,
        })
    }
}

impl<X, P, const D: usize> Propagate<Ekf<P>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D>,
{
    type Input = P::Input;

    fn propagate(&self, model: &Ekf<P>, input: &P::Input) -> Result<Self, OperatorError> {
        model.predict_with_cross(self, input).map(|p| p.density)
    }
}

impl<X, H, const D: usize, const M: usize> Condition<Ekf<H, M>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    type Measurement = SVector<f64, M>;
    type Report = Innovation<D, M>;

    fn condition(
        &self,
        model: &Ekf<H, M>,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<Self, Innovation<D, M>>, OperatorError> {
        crate::error::all_finite("measurement z", z.iter())?;
        let (mean, p) = (self.mean(), self.covariance());
        let h = model.0.jacobian(mean);
        let r = model_noise("measurement noise R", model.0.noise(mean))?;
        let pht = p * h.transpose();
        let residual = model.0.residual(z, &model.0.predict(mean));
        above_rounding::<_, M>(
            || rounding_scale(&h, p, &r),
            |floor| {
                let r = r + SMatrix::<f64, M, M>::identity() * floor;
                let (report, log_evidence) =
                    Innovation::new(residual, &(h * pht + r), &pht, model.0.dof())?;
                let posterior = checked_gaussian(
                    mean.retract(&report.correction()),
                    &joseph(self.cholesky_factor(), report.gain(), &h, &r),
                    Produced {
                        mean: "the posterior mean mu ⊞ K nu",
                        covariance: "posterior covariance (Joseph form; check the measurement noise R \
                                 and the Jacobian H)",
                    },
                )?;
                Ok(Conditioned {
                    posterior,
                    log_evidence,
                    report,
                })
            },
        )
    }
}
