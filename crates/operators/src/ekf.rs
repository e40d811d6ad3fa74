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
//! * **check**: the update is kept only if the linearisation held over its correction: the reading
//!   predicted at μ⁺ may miss the linear prediction `h(μ) + H K ν` by at most
//!   [`LINEARISATION_LIMIT`] in the posterior's own squared standard deviations; beyond, the
//!   correction went where H no longer describes h (a reading far finer than a prior that a curved
//!   model spreads), the posterior would claim a precision it does not have, and the update is
//!   refused ([`OperatorError::Linearisation`]) for the [iterated EKF](crate::iterated) to take.
//!   One more evaluation of h.
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
    Produced, above_rounding, checked_gaussian, checked_gaussian_above_rounding, is_diagonal,
    model_noise, rounding_scale, symmetric_part,
};
use crate::smoother::{GaussianTransition, Prediction};
use crate::{Condition, Conditioned, Innovation, OperatorError, Propagate};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use nalgebra::{Cholesky, SMatrix, SVector};

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
        let predicted = model.0.predict(mean);
        let residual = model.0.residual(z, &predicted);
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
                let step = Conditioned {
                    posterior,
                    log_evidence,
                    report,
                };
                let line = Line {
                    intercept: &predicted,
                    slope: &h,
                    noise: &r,
                };
                check_linearisation(&model.0, z, &line, &step, || (SMatrix::zeros(), 0.0))?;
                Ok(step)
            },
        )
    }
}

/// The largest linearisation miss an EKF or UKF update is kept with: the reading predicted at the
/// updated mean μ⁺ misses the linear prediction `h(μ) + H K ν` (the UKF's `ẑ + Ĥ K ν`) by d, and
/// `q = dᵀ (H P⁺ Hᵀ + R + ρ² I)⁻¹ d` (ρ the rounding of the reading; the UKF adds what Ĥ leaves
/// unexplained to R) must be at most 1e8, a miss of 10⁴ of the posterior's own standard
/// deviations. A linear model misses by rounding only; the main job's EKF updates stay below
/// 1.6e2, its UKF updates below 1.2e2.
pub const LINEARISATION_LIMIT: f64 = 1e8;

/// The line `z ≈ c + A (x ⊟ μ)` an update was made with and the noise it added: for the EKF,
/// c = h(μ), A = H; for the UKF the statistical linearisation, c = ẑ, A = Ĥ.
pub(crate) struct Line<'a, const D: usize, const M: usize> {
    /// c.
    pub(crate) intercept: &'a SVector<f64, M>,
    /// A.
    pub(crate) slope: &'a SMatrix<f64, M, D>,
    /// R, as the update used it.
    pub(crate) noise: &'a SMatrix<f64, M, M>,
}

/// Checks that a linearisation held over the update's correction δ: the [`Line`] predicts the
/// reading at the updated mean μ⁺ = μ ⊞ δ as `c + A δ`; the miss is `d = h(μ⁺) ⊟ (c + A δ)` (⊟ the
/// model's residual, so that a reading on a circle misses on the circle), measured as
/// `q = dᵀ (A P⁺ Aᵀ + R + Ω + ρ² I)⁻¹ d` in the posterior's own uncertainty about the reading, and
/// ρ what rounding alone can miss by: 64 M ε times the largest of |z|, |c|, |h(μ⁺)| and |A δ|, plus
/// the rounding of the line itself. `beyond` gives Ω (what the line leaves unexplained, zero for a
/// Jacobian) and the line's rounding; it is called only when the bound by R alone cannot keep the
/// update. One more evaluation of h.
///
/// # Errors
/// [`OperatorError::Linearisation`] when q is above [`LINEARISATION_LIMIT`] (or not a number).
pub(crate) fn check_linearisation<X, H, const D: usize, const M: usize>(
    model: &H,
    z: &SVector<f64, M>,
    line: &Line<'_, D, M>,
    step: &Conditioned<ManifoldGaussian<X, D>, Innovation<D, M>>,
    beyond: impl FnOnce() -> (SMatrix<f64, M, M>, f64),
) -> Result<(), OperatorError>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    let (predicted, h, r) = (line.intercept, line.slope, line.noise);
    let updated = model.predict(step.posterior.mean());
    let linear = h * step.report.correction();
    // On the reading's own manifold: a residual carried across the cut of a circle by the
    // correction is not a miss of 2π.
    let miss = model.residual(&updated, &(predicted + linear));
    if miss.iter().all(|&x| x == 0.0) {
        return Ok(());
    }
    if !miss.iter().all(|x| x.is_finite()) {
        // The model is not finite at the updated mean: the correction left its domain.
        return Err(OperatorError::Linearisation {
            statistic: f64::INFINITY,
        });
    }
    let size = [z.amax(), predicted.amax(), updated.amax(), linear.amax()]
        .into_iter()
        .fold(0.0, f64::max);
    let rounding = 64.0 * M as f64 * f64::EPSILON * size;
    let floor = (rounding * rounding).max(f64::MIN_POSITIVE);
    // The weight is at least `R + ρ² I`: for a diagonal R, `Σ dᵢ² / (Rᵢᵢ + ρ²)` bounds q from
    // above, and a bound within the limit keeps the update without factoring the weight.
    if is_diagonal(r) {
        let bound: f64 = miss
            .iter()
            .zip(r.diagonal().iter())
            .map(|(d, v)| d * d / (v + floor))
            .sum();
        if bound <= LINEARISATION_LIMIT {
            return Ok(());
        }
    }
    let (unexplained, line_rounding) = beyond();
    let rounding = rounding + line_rounding;
    let floor = (rounding * rounding).max(f64::MIN_POSITIVE);
    // `H P⁺ Hᵀ` as the Gram matrix of `H L`, positive semi-definite whatever the rounding.
    let spread = h * step.posterior.cholesky_factor();
    let weight = spread * spread.transpose()
        + symmetric_part(r)
        + unexplained
        + SMatrix::<f64, M, M>::identity() * floor;
    let statistic = match Cholesky::new(weight) {
        Some(factor) => factor
            .l()
            .solve_lower_triangular_unchecked(&miss)
            .norm_squared(),
        // Positive definite in exact arithmetic: a factorisation lost to rounding falls back on
        // the diagonal, which is positive.
        None => miss
            .iter()
            .zip(weight.diagonal().iter())
            .map(|(d, w)| d * d / w)
            .sum(),
    };
    if statistic <= LINEARISATION_LIMIT {
        Ok(())
    } else {
        Err(OperatorError::Linearisation { statistic })
    }
}
