//! The unscented Kalman filter on any [`Manifold`]: sigma points by retraction, means on the manifold.
//!
//! With `x = μ ⊞ δ`, `δ ~ N(0, P)` and the lower Cholesky factor L of P, the 2D + 1 sigma points are
//! `χ₀ = μ`, `χ±ᵢ = μ ⊞ (±γ Lᵢ)` with `γ = √(D + λ)`, `λ = α² (D + κ) − D`, and the weights
//! `w₀ᵐ = λ/(D + λ)`, `w₀ᶜ = w₀ᵐ + 1 − α² + β`, `wᵢ = 1/(2(D + λ))` (Wan and van der Merwe's scaled
//! unscented transform).
//!
//! * **propagate**: `Yᵢ = f(χᵢ, u)`; the mean m is the weighted mean *on the manifold*, the fixed point
//!   of `m ← m ⊞ Σ wᵢᵐ (Yᵢ ⊟ m)` (Gauss-Newton, never an average of coordinates, so sigma points on both
//!   sides of ±π average correctly); `P′ = Σ wᵢᶜ (Yᵢ ⊟ m)(Yᵢ ⊟ m)ᵀ + Q`; for the
//!   [smoother](crate::smoother), the cross-covariance `C = Σ wᵢᶜ dᵢ (Yᵢ ⊟ m)ᵀ` with dᵢ the sigma
//!   offsets.
//! * **condition**: `Zᵢ = h(χᵢ)`, ẑ the fixed point of `ẑ ← ẑ + Σ wᵢᵐ (Zᵢ ⊟ ẑ)` (with the model's residual,
//!   which may wrap), `S = Σ wᵢᶜ rᵢ rᵢᵀ + R`, `C = Σ wᵢᶜ dᵢ rᵢᵀ` with dᵢ the sigma offsets,
//!   `K = C S⁻¹`, `μ⁺ = μ ⊞ K (z ⊟ ẑ)`, `P⁺ = P − K S Kᵀ`; log evidence `ln N(z ⊟ ẑ; 0, S)`; the
//!   report is the [`Innovation`] (ν, S, K, NIS).
//!
//! Exact for linear models on Rⁿ (it then equals the Kalman filter). Nothing is allocated: the sigma
//! points live in arrays of size D.

use crate::models::{MeasurementModel, ProcessModel};
use crate::numerics::{MEAN_ITERATIONS, MEAN_TOLERANCE, checked_gaussian, manifold_mean};
use crate::smoother::{GaussianTransition, Prediction};
use crate::{Condition, Conditioned, Innovation, OperatorError, Propagate};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use nalgebra::{SMatrix, SVector};
use std::iter::once;

/// A model to be used through the unscented transform: `density.propagate(&Ukf::new(process), &u)`,
/// `density.condition(&Ukf::new(measurement), &z)`. M, the measurement dimension, is inferred from z
/// (and is 0, unused, for a process).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ukf<Model, const M: usize = 0> {
    model: Model,
    alpha: f64,
    beta: f64,
    kappa: f64,
}

impl<Model, const M: usize> Ukf<Model, M> {
    /// The model with α = 1, β = 2, κ = 0: sigma points at `±√D` standard deviations, no negative
    /// mean weight.
    pub fn new(model: Model) -> Self {
        Self {
            model,
            alpha: 1.0,
            beta: 2.0,
            kappa: 0.0,
        }
    }

    /// The scaling parameters α (spread, 0 < α ≤ 1 usually), β (2 is optimal for Gaussians) and κ.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] unless α > 0 and `α² (D + κ) > 0` for every D ≥ 1 (κ > −1), all
    /// finite.
    pub fn with_scaling(
        model: Model,
        alpha: f64,
        beta: f64,
        kappa: f64,
    ) -> Result<Self, OperatorError> {
        crate::error::all_finite(
            "unscented scaling (alpha, beta, kappa)",
            [alpha, beta, kappa].iter(),
        )?;
        if alpha <= 0.0 || kappa <= -1.0 {
            return Err(OperatorError::OutOfRange {
                what: "unscented scaling alpha (with kappa)",
                value: alpha,
                range: "alpha > 0 and kappa > -1",
            });
        }
        Ok(Self {
            model,
            alpha,
            beta,
            kappa,
        })
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// `(γ, w₀ᵐ, w₀ᶜ, wᵢ)` for dimension d.
    fn weights(&self, d: usize) -> (f64, f64, f64, f64) {
        let d = d as f64;
        let lambda = self.alpha * self.alpha * (d + self.kappa) - d;
        let w0 = lambda / (d + lambda);
        (
            (d + lambda).sqrt(),
            w0,
            w0 + 1.0 - self.alpha * self.alpha + self.beta,
            0.5 / (d + lambda),
        )
    }
}

/// The sigma offsets `γ Lⱼ` from the density's Cholesky factor (the −γ Lⱼ side is their negation).
fn sigma_offsets<X, const D: usize>(
    density: &ManifoldGaussian<X, D>,
    gamma: f64,
) -> [SVector<f64, D>; D]
where
    X: Manifold<D, Scalar = f64>,
{
    let l = density.cholesky_factor() * gamma;
    std::array::from_fn(|j| l.column(j).into_owned())
}

impl<X, P, const D: usize> GaussianTransition<X, D> for Ukf<P>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D>,
{
    type Input = P::Input;

    /// The unscented prediction (see the module docs), with the cross-covariance
    /// `C = Σ wᵢᶜ dᵢ (Yᵢ ⊟ m)ᵀ` of the sigma offsets dᵢ and the images' deviations.
    fn predict_with_cross(
        &self,
        prior: &ManifoldGaussian<X, D>,
        input: &P::Input,
    ) -> Result<Prediction<X, D>, OperatorError> {
        let (gamma, w0m, w0c, w) = self.weights(D);
        let offsets = sigma_offsets(prior, gamma);
        let mu = prior.mean();
        let centre = self.model.transition(mu, input);
        let plus = offsets.map(|d| self.model.transition(&mu.retract(&d), input));
        let minus = offsets.map(|d| self.model.transition(&mu.retract(&-d), input));
        let mean = manifold_mean(
            &centre,
            &once((w0m, &centre)).chain(plus.iter().chain(&minus).map(|y| (w, y))),
        );
        let e0 = mean.local(&centre);
        let mut covariance = e0 * e0.transpose() * w0c + self.model.noise(mu, input);
        let mut cross = SMatrix::<f64, D, D>::zeros();
        for (d, (yp, ym)) in offsets.iter().zip(plus.iter().zip(&minus)) {
            let (ep, em) = (mean.local(yp), mean.local(ym));
            covariance += (ep * ep.transpose() + em * em.transpose()) * w;
            cross += d * (ep - em).transpose() * w;
        }
        let density = checked_gaussian(
            mean,
            &covariance,
            "predicted covariance (sigma points plus Q; check the process noise Q)",
        )?;
        Ok(Prediction {
            density,
            cross_covariance: cross,
        })
    }
}

impl<X, P, const D: usize> Propagate<Ukf<P>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D>,
{
    type Input = P::Input;

    fn propagate(&self, ukf: &Ukf<P>, input: &P::Input) -> Result<Self, OperatorError> {
        ukf.predict_with_cross(self, input).map(|p| p.density)
    }
}

impl<X, H, const D: usize, const M: usize> Condition<Ukf<H, M>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    type Measurement = SVector<f64, M>;
    type Report = Innovation<D, M>;

    fn condition(
        &self,
        ukf: &Ukf<H, M>,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<Self, Innovation<D, M>>, OperatorError> {
        crate::error::all_finite("measurement z", z.iter())?;
        let (gamma, w0m, w0c, w) = ukf.weights(D);
        let offsets = sigma_offsets(self, gamma);
        let (mu, h) = (self.mean(), &ukf.model);
        let centre = h.predict(mu);
        let plus = offsets.map(|d| h.predict(&mu.retract(&d)));
        let minus = offsets.map(|d| h.predict(&mu.retract(&-d)));
        // ẑ by the same fixed point as the state mean (and its iteration limits), with the model's
        // residual in place of `local`.
        let mut predicted = centre;
        for _ in 0..MEAN_ITERATIONS {
            let step = h.residual(&centre, &predicted) * w0m
                + plus
                    .iter()
                    .chain(&minus)
                    .map(|y| h.residual(y, &predicted) * w)
                    .sum::<SVector<f64, M>>();
            predicted += step;
            if step.norm() < MEAN_TOLERANCE * (1.0 + predicted.norm()) {
                break;
            }
        }
        let r0 = h.residual(&centre, &predicted);
        let mut s = r0 * r0.transpose() * w0c + h.noise(mu);
        let mut cross = SMatrix::<f64, D, M>::zeros();
        for (d, (zp, zm)) in offsets.iter().zip(plus.iter().zip(&minus)) {
            let (rp, rm) = (h.residual(zp, &predicted), h.residual(zm, &predicted));
            s += (rp * rp.transpose() + rm * rm.transpose()) * w;
            cross += d * (rp - rm).transpose() * w;
        }
        let (report, log_evidence) = Innovation::new(h.residual(z, &predicted), &s, &cross)?;
        let gain = report.gain();
        let posterior = checked_gaussian(
            mu.retract(&report.correction()),
            &(self.covariance() - gain * report.covariance() * gain.transpose()),
            "posterior covariance P - K S K^T (it lost positive definiteness; check R)",
        )?;
        Ok(Conditioned {
            posterior,
            log_evidence,
            report,
        })
    }
}
