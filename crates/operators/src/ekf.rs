//! The extended Kalman filter on any [`Manifold`], in error-state form.
//!
//! With the density `x = μ ⊞ δ`, `δ ~ N(0, P)` ([`ManifoldGaussian`]):
//!
//! * **propagate**: `μ′ = f(μ, u)`, `P′ = F P Fᵀ + Q`, F the right Jacobian of the motion;
//! * **condition**: `ν = z ⊟ h(μ)`, `S = H P Hᵀ + R`, `K = P Hᵀ S⁻¹`, `μ⁺ = μ ⊞ K ν`, and the
//!   Joseph form `P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ`; log evidence `ln N(ν; 0, S)` (the linearised
//!   model's, an approximation of `ln p(z)`).
//!
//! P⁺ is left in the tangent space at μ rather than transported to μ⁺ (the first-order "reset"
//! `J_r(Kν) P⁺ J_r(Kν)ᵀ` is omitted); on Rⁿ and SO(2) the two coincide.

use crate::kalman::joseph;
use crate::manifold_gaussian::{
    GaussianUpdate, ManifoldGaussian, MeasurementModel, ProcessModel, checked_covariance,
};
use crate::{Condition, Conditioned, OperatorError, Propagate};
use liebayes_manifolds::Manifold;
use nalgebra::SVector;

/// A model to be used by linearisation: `density.propagate(&Ekf(process), &u)`,
/// `density.condition(&Ekf(measurement), &z)`. M, the measurement dimension, is inferred from z (and is
/// 0, unused, for a process).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ekf<Model, const M: usize = 0>(pub Model);

impl<X, P, const D: usize> Propagate<Ekf<P>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D>,
{
    type Input = P::Input;

    fn propagate(&self, model: &Ekf<P>, input: &P::Input) -> Result<Self, OperatorError> {
        let f = model.0.jacobian(self.mean(), input);
        let q = model.0.noise(self.mean(), input);
        let mean = model.0.transition(self.mean(), input);
        Ok(ManifoldGaussian::from_checked(
            mean,
            checked_covariance(f * self.covariance() * f.transpose() + q)?,
        ))
    }
}

impl<X, H, const D: usize, const M: usize> Condition<Ekf<H, M>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    type Measurement = SVector<f64, M>;

    fn condition(
        &self,
        model: &Ekf<H, M>,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<Self>, OperatorError> {
        crate::error::all_finite("measurement z", z.iter())?;
        let (mean, p) = (self.mean(), self.covariance());
        let h = model.0.jacobian(mean);
        let r = model.0.noise(mean);
        let innovation = model.0.residual(z, &model.0.predict(mean));
        let update = GaussianUpdate::new(
            &innovation,
            &(h * p * h.transpose() + r),
            &(p * h.transpose()),
        )?;
        let covariance = checked_covariance(joseph(p, &update.gain, &h, &r))?;
        Ok(Conditioned {
            posterior: ManifoldGaussian::from_checked(mean.retract(&update.correction), covariance),
            log_evidence: update.log_evidence,
        })
    }
}
