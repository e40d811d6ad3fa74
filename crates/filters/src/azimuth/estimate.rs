//! [`AzimuthEstimate`]: what every azimuth filter reports, and [`AzimuthScorer`], its metrics
//! against the truth.

use super::PositionAzimuth;
use liebayes_experiments::{Metric, Reduction, Scorer};
use liebayes_manifolds::{Manifold, So2};
use liebayes_operators::OperatorError;
use liebayes_operators::evaluation::{circular_consistency, nees};
use nalgebra::{Matrix2, Vector2};

/// A final azimuth error above this counts as a divergence (10°).
pub const DIVERGENCE_THRESHOLD: f64 = 10.0 * std::f64::consts::PI / 180.0;

/// The estimate of every azimuth filter: the azimuth's circular mean and spread, and the position's
/// mean and covariance (platform axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AzimuthEstimate {
    /// The circular mean of A, `None` when the filter holds A uniform (ρ = 0).
    pub azimuth: Option<So2<f64>>,
    /// The mean resultant length `ρ = |E e^(iA)|` in [0, 1].
    pub rho: f64,
    /// The circular variance `σ_A² = −2 ln ρ` (the variance of a wrapped normal with this ρ),
    /// computed by each filter where it is accurate (the exact filter from κ, without the
    /// cancellation of ln ρ near ρ = 1); +∞ at ρ = 0.
    pub circular_variance: f64,
    /// `E r`.
    pub mean_r: Vector2<f64>,
    /// `Cov r`.
    pub cov_r: Matrix2<f64>,
}

/// The estimators of the azimuth filters: the [`AzimuthEstimate`] of each filter's density (the
/// exact density, the Gaussian on `[r, A]`, the particle sets and the grid).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AzimuthMoments;

impl AzimuthEstimate {
    /// The circular standard deviation `σ_A = √(−2 ln ρ)`; `None` at ρ = 0 (and for a circular
    /// variance, a public field, that is negative or NaN).
    pub fn sigma_a(&self) -> Option<f64> {
        let v = self.circular_variance;
        (v.is_finite() && v >= 0.0).then(|| v.sqrt())
    }

    /// From the first trigonometric moment `E (cos A, sin A)` of a particle set or a grid.
    pub(super) fn from_moment(
        moment: Vector2<f64>,
        mean_r: Vector2<f64>,
        cov_r: Matrix2<f64>,
    ) -> Self {
        let rho = moment.x.hypot(moment.y).min(1.0);
        Self {
            azimuth: (rho > 0.0).then(|| So2::from_angle_unchecked(moment.y.atan2(moment.x))),
            rho,
            circular_variance: if rho > 0.0 {
                -2.0 * rho.ln()
            } else {
                f64::INFINITY
            },
            mean_r,
            cov_r,
        }
    }

    /// The estimate if its moments are finite.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] otherwise (moments that overflow: positions beyond about 1e154).
    pub(super) fn checked(self) -> Result<Self, OperatorError> {
        match self
            .mean_r
            .iter()
            .chain(self.cov_r.iter())
            .chain(std::iter::once(&self.rho))
            .find(|v| !v.is_finite())
        {
            Some(&value) => Err(OperatorError::NonFinite {
                what: "azimuth filter estimate (E r or Cov r overflow: the positions are too \
                       large for their second moments)",
                value,
            }),
            None => Ok(self),
        }
    }
}

/// `(cos A, sin A)`.
pub(super) fn azimuth_moment(a: &So2<f64>) -> Vector2<f64> {
    Vector2::new(a.cos(), a.sin())
}

/// The metrics of an azimuth filter against the true `[r, A]`, through the manifolds: the azimuth
/// error is `Â ⊟ A` on SO(2) (estimate minus truth, wrapped to (−π, π]), the position error
/// `E r − r` on R².
///
/// | metric | summarised as | |
/// |---|---|---|
/// | `azimuth_error`, `azimuth_sigma` | RMS (deg) | NaN while A is uniform |
/// | `x_error`, `x_sigma`, `y_error`, `y_sigma` | RMS (m) | `E r − r` and `√diag Cov r` |
/// | `nees_position` | χ²(2) mean | `(E r − r)ᵀ (Cov r)⁻¹ (E r − r)` |
/// | `circular_consistency` | mean, 1 when consistent | `(1 − cos e) / (1 − ρ)` |
/// | `diverged` | rate | `|e| > 10°` |
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AzimuthScorer;

impl Scorer<PositionAzimuth, AzimuthEstimate> for AzimuthScorer {
    fn metrics(&self) -> Vec<Metric> {
        vec![
            Metric::new("azimuth_error", Reduction::RootMeanSquare, "deg"),
            Metric::new("azimuth_sigma", Reduction::RootMeanSquare, "deg"),
            Metric::new("x_error", Reduction::RootMeanSquare, "m"),
            Metric::new("x_sigma", Reduction::RootMeanSquare, "m"),
            Metric::new("y_error", Reduction::RootMeanSquare, "m"),
            Metric::new("y_sigma", Reduction::RootMeanSquare, "m"),
            Metric::new("nees_position", Reduction::ChiSquare { dof: 2 }, ""),
            Metric::new("circular_consistency", Reduction::Mean, ""),
            Metric::new("diverged", Reduction::Rate, ""),
        ]
    }

    fn score(&self, truth: &PositionAzimuth, estimate: &AzimuthEstimate, values: &mut [f64]) {
        let error = estimate.azimuth.map(|a| truth.second().local(&a)[0]);
        let position = estimate.mean_r - truth.first().coords();
        let sigma = estimate.cov_r.diagonal().map(|v| v.max(0.0).sqrt());
        values.copy_from_slice(&[
            error.map_or(f64::NAN, f64::to_degrees),
            estimate.sigma_a().map_or(f64::NAN, f64::to_degrees),
            position.x,
            sigma.x,
            position.y,
            sigma.y,
            nees(&position, &estimate.cov_r).unwrap_or(f64::INFINITY),
            error
                .and_then(|e| circular_consistency(e, estimate.rho))
                .unwrap_or(f64::NAN),
            error.map_or(f64::NAN, |e| {
                f64::from(u8::from(e.abs() > DIVERGENCE_THRESHOLD))
            }),
        ]);
    }
}
