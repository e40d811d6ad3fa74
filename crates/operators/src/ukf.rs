//! The unscented Kalman filter on any [`Manifold`]: sigma points by retraction, means on the manifold.
//!
//! With `x = μ ⊞ δ`, `δ ~ N(0, P)` and the lower Cholesky factor L of P, the 2D + 1 sigma points are
//! `χ₀ = μ`, `χ±ᵢ = μ ⊞ (±γ Lᵢ)` with `γ = √(D + λ)`, `λ = α² (D + κ) − D`, and the weights
//! `w₀ᵐ = λ/(D + λ)`, `w₀ᶜ = w₀ᵐ + 1 − α² + β`, `wᵢ = 1/(2(D + λ))` (Wan and van der Merwe's scaled
//! unscented transform).
//!
//! * **propagate**: `Yᵢ = f(χᵢ, u)`; the mean m is the weighted mean *on the manifold*, the fixed point
//!   of `m ← m ⊞ Σ wᵢᵐ (Yᵢ ⊟ m)` (Gauss-Newton, never an average of coordinates, so sigma points on both
//!   sides of ±π average correctly); `P′ = Σ wᵢᶜ (Yᵢ ⊟ m)(Yᵢ ⊟ m)ᵀ + Q`.
//! * **condition**: `Zᵢ = h(χᵢ)`, ẑ the fixed point of `ẑ ← ẑ + Σ wᵢᵐ (Zᵢ ⊟ ẑ)` (with the model's residual,
//!   which may wrap), `S = Σ wᵢᶜ rᵢ rᵢᵀ + R`, `C = Σ wᵢᶜ dᵢ rᵢᵀ` with dᵢ the sigma offsets,
//!   `K = C S⁻¹`, `μ⁺ = μ ⊞ K (z ⊟ ẑ)`, `P⁺ = P − K S Kᵀ`; log evidence `ln N(z ⊟ ẑ; 0, S)`.
//!
//! Exact for linear models on Rⁿ (it then equals the Kalman filter). Nothing is allocated: the sigma
//! points live in arrays of size D.

use crate::manifold_gaussian::{
    GaussianUpdate, ManifoldGaussian, MeasurementModel, ProcessModel, checked_covariance,
};
use crate::{Condition, Conditioned, OperatorError, Propagate};
use liebayes_manifolds::Manifold;
use nalgebra::{Cholesky, SMatrix, SVector};

/// Iterations of the manifold mean before giving up; convergence to 1e-12 takes 2 to 5 in practice.
const MEAN_ITERATIONS: usize = 50;
/// The mean is converged when its step is below this (in tangent units).
const MEAN_TOLERANCE: f64 = 1e-12;

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

/// The sigma offsets `γ Lⱼ` (the −γ Lⱼ side is their negation).
fn sigma_offsets<const D: usize>(
    covariance: &SMatrix<f64, D, D>,
    gamma: f64,
) -> Result<[SVector<f64, D>; D], OperatorError> {
    let l = Cholesky::new(*covariance)
        .ok_or(OperatorError::NotPositiveDefinite {
            what: "tangent covariance P",
        })?
        .l()
        * gamma;
    Ok(std::array::from_fn(|j| l.column(j).into_owned()))
}

/// The weighted mean of `centre` (weight w₀) and `plus`/`minus` (weight w each) on the manifold, by
/// Gauss-Newton from `centre`.
fn manifold_mean<X: Manifold<D, Scalar = f64>, const D: usize, const K: usize>(
    centre: &X,
    plus: &[X; K],
    minus: &[X; K],
    w0: f64,
    w: f64,
) -> X {
    let mut mean = centre.clone();
    for _ in 0..MEAN_ITERATIONS {
        let step = mean.local(centre) * w0
            + plus
                .iter()
                .chain(minus)
                .map(|y| mean.local(y) * w)
                .sum::<SVector<f64, D>>();
        mean = mean.retract(&step);
        if step.norm() < MEAN_TOLERANCE {
            break;
        }
    }
    mean
}

impl<X, P, const D: usize> Propagate<Ukf<P>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D>,
{
    type Input = P::Input;

    fn propagate(&self, ukf: &Ukf<P>, input: &P::Input) -> Result<Self, OperatorError> {
        let (gamma, w0m, w0c, w) = ukf.weights(D);
        let offsets = sigma_offsets(self.covariance(), gamma)?;
        let mu = self.mean();
        let centre = ukf.model.transition(mu, input);
        let plus = offsets.map(|d| ukf.model.transition(&mu.retract(&d), input));
        let minus = offsets.map(|d| ukf.model.transition(&mu.retract(&-d), input));
        let mean = manifold_mean(&centre, &plus, &minus, w0m, w);
        let outer = |y: &X| {
            let e = mean.local(y);
            e * e.transpose()
        };
        let covariance = outer(&centre) * w0c
            + plus
                .iter()
                .chain(&minus)
                .map(|y| outer(y) * w)
                .sum::<SMatrix<f64, D, D>>()
            + ukf.model.noise(mu, input);
        Ok(ManifoldGaussian::from_checked(
            mean,
            checked_covariance(covariance)?,
        ))
    }
}

impl<X, H, const D: usize, const M: usize> Condition<Ukf<H, M>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    type Measurement = SVector<f64, M>;

    fn condition(
        &self,
        ukf: &Ukf<H, M>,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<Self>, OperatorError> {
        crate::error::all_finite("measurement z", z.iter())?;
        let (gamma, w0m, w0c, w) = ukf.weights(D);
        let offsets = sigma_offsets(self.covariance(), gamma)?;
        let (mu, h) = (self.mean(), &ukf.model);
        let centre = h.predict(mu);
        let plus = offsets.map(|d| h.predict(&mu.retract(&d)));
        let minus = offsets.map(|d| h.predict(&mu.retract(&-d)));
        // ẑ by the same fixed point as the state mean, with the model's residual.
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
        let innovation = h.residual(z, &predicted);
        let update = GaussianUpdate::new(&innovation, &s, &cross)?;
        let covariance =
            checked_covariance(self.covariance() - update.gain * s * update.gain.transpose())?;
        Ok(Conditioned {
            posterior: ManifoldGaussian::from_checked(mu.retract(&update.correction), covariance),
            log_evidence: update.log_evidence,
        })
    }
}
