//! The grid filter and brute-force reference of azimuth alignment: a bank of exact Kalman filters
//! for r, one at each of n azimuths, on the operators crate's [`CircularGrid`].

use super::estimate::{AzimuthEstimate, AzimuthMoments};
use super::model::check_filter_settings;
use super::model::{PositionMeasurement, VelocityInput, VelocityProcess};
use liebayes_densities::Gaussian;
use liebayes_experiments::{Estimator, Recursive};
use liebayes_manifolds::So2;
use liebayes_operators::grid::CircularGrid;
use liebayes_operators::kalman::LinearMeasurement;
use liebayes_operators::particle::{Given, LabelModel};
use liebayes_operators::{OperatorError, Propagate};
use nalgebra::{Matrix2, Vector2};

/// The velocity process on the position alone, `r′ = r + v dt + w`, `w ~ N(0, q² dt I)`, exact for
/// a Gaussian: `m′ = m + v dt`, `P′ = P + q² dt I`. What each cell of the grid and each particle of
/// the marginalized filter propagates.
impl Propagate<VelocityProcess> for Gaussian<2> {
    type Input = VelocityInput;

    /// # Errors
    /// As [`VelocityInput::validate`], or the Gaussian's errors when the result overflows.
    fn propagate(
        &self,
        model: &VelocityProcess,
        input: &VelocityInput,
    ) -> Result<Self, OperatorError> {
        input.validate()?;
        Ok(Gaussian::new(
            self.mean() + input.velocity * input.dt,
            self.covariance() + Matrix2::identity() * (model.noise_density() * input.dt),
        )?)
    }
}

/// Given the azimuth A, r's Kalman filter is conditioned with `z = R(A) r + n`,
/// `n ~ N(0, σ_m² I)`: the measurement model of each cell of the grid and each particle of the
/// marginalized filter.
impl LabelModel<So2<f64>> for PositionMeasurement {
    type Model = LinearMeasurement<2, 2>;

    fn at(&self, azimuth: &So2<f64>) -> Result<LinearMeasurement<2, 2>, OperatorError> {
        LinearMeasurement::new(azimuth.to_matrix(), Matrix2::identity() * self.variance())
    }
}

/// The velocity process moves r the same way whatever the azimuth.
impl LabelModel<So2<f64>> for VelocityProcess {
    type Model = VelocityProcess;

    fn at(&self, _: &So2<f64>) -> Result<VelocityProcess, OperatorError> {
        Ok(*self)
    }
}

/// The azimuth posterior evaluated exactly at the n angles `Aⱼ = 2πj/n`: given A the model is
/// linear and Gaussian, so one Kalman filter per angle carries `p(r | Aⱼ, z₁..ₖ)` exactly, and the
/// grid's weights carry `p(Aⱼ | z₁..ₖ)` up to the trapezoid normalisation. Nothing here knows the
/// seven-number recursion, which is why it is a reference for it: the two must agree at every angle,
/// at every epoch.
///
/// With few cells it is also the *grid filter* baseline: moments over A are trapezoid sums,
/// exponentially accurate while the grid resolves the posterior (spacing well below σ_A) and a
/// point-mass approximation once it does not. Costs n Kalman steps per step.
pub type AzimuthGrid = Recursive<
    CircularGrid<Gaussian<2>>,
    Given<VelocityProcess>,
    Given<PositionMeasurement>,
    AzimuthMoments,
>;

/// The grid filter with n cells, each with the prior `N(r₀, σ₀² I)`, and the uniform azimuth prior.
///
/// # Errors
/// The settings check every azimuth filter shares (as [`ekf`](super::ekf): r₀ finite within
/// ±1e100, σ₀ and σ_m in [1e-49, 1e49], q at most 1e49), then [`OperatorError::OutOfRange`] for
/// n = 0 and [`OperatorError::TooLarge`] for n above
/// [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS); all before any cell is allocated.
///
/// # Example
/// ```
/// use liebayes_experiments::RecursiveFilter;
/// use liebayes_filters::azimuth::{PositionMeasurement, VelocityProcess, grid_filter};
/// use nalgebra::Vector2;
/// let process = VelocityProcess::new(0.1).unwrap();
/// let sensor = PositionMeasurement::new(0.1).unwrap();
/// let mut filter = grid_filter(360, process, sensor, Vector2::new(10.0, 0.0), 1.0).unwrap();
/// // A world position (−10, 0): half a turn, found to the grid's degree.
/// filter.update(&Vector2::new(-10.0, 0.0)).unwrap();
/// let azimuth = filter.estimate().unwrap().azimuth.unwrap();
/// assert!((azimuth.angle().abs() - std::f64::consts::PI).abs() < 2e-2);
/// ```
pub fn grid_filter(
    n: usize,
    process: VelocityProcess,
    measurement: PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
) -> Result<AzimuthGrid, OperatorError> {
    let variance = check_filter_settings(process, &measurement, r0, sigma0)?;
    let prior = Gaussian::new(r0, Matrix2::identity() * variance)?;
    Ok(Recursive::with_estimator(
        CircularGrid::uniform(n, prior)?,
        Given(process),
        Given(measurement),
        AzimuthMoments,
    ))
}

/// `ln p(Aⱼ, z₁..ₖ)` (a density in A) for every cell j of a grid whose updates have summed to the
/// log evidence `ln p(z₁..ₖ)`: `ln wⱼ + ln p(z₁..ₖ) − ln(2π/n)`; −∞ in a cell of zero weight.
///
/// # Errors
/// [`OperatorError::NonFinite`] for a log evidence that is not finite (every update that succeeds
/// reports a finite one): a NaN would make every cell NaN, −∞ every cell −∞, and +∞ every cell +∞
/// but those of zero weight, NaN (−∞ + ∞).
pub fn log_joint(
    grid: &CircularGrid<Gaussian<2>>,
    log_evidence: f64,
) -> Result<Vec<f64>, OperatorError> {
    if !log_evidence.is_finite() {
        return Err(OperatorError::NonFinite {
            what: "log evidence ln p(z_1..k) of the grid's updates",
            value: log_evidence,
        });
    }
    let cell = (2.0 * std::f64::consts::PI / grid.len() as f64).ln();
    Ok(grid
        .log_weights()
        .iter()
        .map(|l| l + log_evidence - cell)
        .collect())
}

/// `(E r, Cov r)` by the trapezoid rule over the grid (the mixture of the per-angle Gaussians) and
/// the first trigonometric moment.
impl Estimator<CircularGrid<Gaussian<2>>> for AzimuthMoments {
    type Estimate = AzimuthEstimate;

    fn estimate(&self, grid: &CircularGrid<Gaussian<2>>) -> Result<AzimuthEstimate, OperatorError> {
        let mean = grid.expectation(|_, f| *f.mean());
        let covariance = grid.expectation(|_, f| {
            let d = f.mean() - mean;
            f.covariance() + d * d.transpose()
        });
        AzimuthEstimate::from_moment(grid.first_moment(), mean, covariance).checked()
    }
}
