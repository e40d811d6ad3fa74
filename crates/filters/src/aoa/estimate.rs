//! [`PositionEstimate`]: what every angle-of-arrival filter reports, and [`PositionScorer`], its
//! metrics against the true position.

use super::model::Position;
use liebayes_densities::ManifoldGaussian;
use liebayes_experiments::{Estimator, Metric, Reduction, Scorer};
use liebayes_operators::OperatorError;
use liebayes_operators::evaluation::nees;
use liebayes_operators::particle::ParticleSet;
use nalgebra::{Matrix3, Vector3};

/// A position estimate: the posterior mean and covariance (world axes, m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionEstimate {
    /// `E θ`.
    pub mean: Vector3<f64>,
    /// `Cov θ`.
    pub covariance: Matrix3<f64>,
}

/// The estimator of every angle-of-arrival filter: the Gaussian's mean and covariance, or a
/// particle set's weighted ones (before any resampling).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PositionMoments;

impl Estimator<ManifoldGaussian<Position, 3>> for PositionMoments {
    type Estimate = PositionEstimate;

    fn estimate(
        &self,
        density: &ManifoldGaussian<Position, 3>,
    ) -> Result<PositionEstimate, OperatorError> {
        Ok(PositionEstimate {
            mean: *density.mean().coords(),
            covariance: *density.covariance(),
        })
    }
}

impl Estimator<ParticleSet<Position>> for PositionMoments {
    type Estimate = PositionEstimate;

    /// # Errors
    /// [`OperatorError::NonFinite`] when the moments overflow.
    fn estimate(&self, set: &ParticleSet<Position>) -> Result<PositionEstimate, OperatorError> {
        let mean = set.expectation(|x| *x.coords());
        let covariance = set.expectation(|x| {
            let d = x.coords() - mean;
            d * d.transpose()
        });
        match mean
            .iter()
            .chain(covariance.iter())
            .find(|v| !v.is_finite())
        {
            Some(&value) => Err(OperatorError::NonFinite {
                what: "particle position moments (the particles are too far apart)",
                value,
            }),
            None => Ok(PositionEstimate { mean, covariance }),
        }
    }
}

/// The metrics of a position estimate against the true position, `e = E θ − θ`:
///
/// | metric | summarised as | |
/// |---|---|---|
/// | `position_error` | RMS (m), kept per run | `|e|`; a run's value is its RMSE over the track |
/// | `x_error`, `x_sigma`, … `z_sigma` | RMS (m) | `e` and `√diag Cov θ` |
/// | `nees_position` | χ²(3) mean | `eᵀ (Cov θ)⁻¹ e` |
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PositionScorer;

impl Scorer<Position, PositionEstimate> for PositionScorer {
    fn metrics(&self) -> Vec<Metric> {
        vec![
            Metric::new("position_error", Reduction::RootMeanSquare, "m").per_run(),
            Metric::new("x_error", Reduction::RootMeanSquare, "m"),
            Metric::new("x_sigma", Reduction::RootMeanSquare, "m"),
            Metric::new("y_error", Reduction::RootMeanSquare, "m"),
            Metric::new("y_sigma", Reduction::RootMeanSquare, "m"),
            Metric::new("z_error", Reduction::RootMeanSquare, "m"),
            Metric::new("z_sigma", Reduction::RootMeanSquare, "m"),
            Metric::new("nees_position", Reduction::ChiSquare { dof: 3 }, ""),
        ]
    }

    fn score(&self, truth: &Position, estimate: &PositionEstimate, values: &mut [f64]) {
        let e = estimate.mean - truth.coords();
        let sigma = estimate.covariance.diagonal().map(|v| v.max(0.0).sqrt());
        values.copy_from_slice(&[
            e.norm(),
            e.x,
            sigma.x,
            e.y,
            sigma.y,
            e.z,
            sigma.z,
            nees(&e, &estimate.covariance).unwrap_or(f64::INFINITY),
        ]);
    }
}
