//! The EKF and UKF baselines: a Gaussian on the state `[r, A]` ∈ R² × SO(2) ([`PositionAzimuth`]),
//! stepped by the operators crate's manifold Kalman filters.

use super::PositionAzimuth;
use super::estimate::{AzimuthEstimate, AzimuthMoments};
use super::model::check_filter_settings;
use super::model::{PositionMeasurement, VelocityInput, VelocityProcess};
use liebayes_densities::ManifoldGaussian;
use liebayes_experiments::{Estimator, Recursive};
use liebayes_manifolds::{Rn, So2};
use liebayes_operators::{Ekf, MeasurementModel, OperatorError, ProcessModel, Ukf};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2};
use std::f64::consts::PI;

/// The EKF on `[r, A]`.
pub type AzimuthEkf = Recursive<
    ManifoldGaussian<PositionAzimuth, 3>,
    Ekf<VelocityProcess>,
    Ekf<PositionMeasurement, 2>,
    AzimuthMoments,
>;

/// The UKF on `[r, A]` (α = 0.1, β = 2, κ = 0; see [`ukf`]).
pub type AzimuthUkf = Recursive<
    ManifoldGaussian<PositionAzimuth, 3>,
    Ukf<VelocityProcess>,
    Ukf<PositionMeasurement, 2>,
    AzimuthMoments,
>;

/// The state with position r and azimuth A (r finite: the callers pass validated or finite values).
pub(super) fn state(r: Vector2<f64>, azimuth: So2<f64>) -> PositionAzimuth {
    PositionAzimuth::new(Rn::new_unchecked(r), azimuth)
}

/// `r′ = r + v dt + w`, `A′ = A`, as a manifold process model (F = I, `Q = diag(q² dt, q² dt, 0)`).
impl ProcessModel<PositionAzimuth, 3> for VelocityProcess {
    type Input = VelocityInput;

    fn transition(&self, x: &PositionAzimuth, input: &VelocityInput) -> PositionAzimuth {
        state(x.first().coords() + input.velocity * input.dt, *x.second())
    }

    fn noise(&self, _: &PositionAzimuth, input: &VelocityInput) -> Matrix3<f64> {
        let q = self.noise_density() * input.dt;
        Matrix3::new(q, 0.0, 0.0, 0.0, q, 0.0, 0.0, 0.0, 0.0)
    }

    fn jacobian(&self, _: &PositionAzimuth, _: &VelocityInput) -> Matrix3<f64> {
        Matrix3::identity()
    }
}

/// `z = R(A) r + n`, with `H = [R(A), R(A) r^×]` (∂R(A)/∂A = R(A) J, J r = r^×).
impl MeasurementModel<PositionAzimuth, 3, 2> for PositionMeasurement {
    fn predict(&self, x: &PositionAzimuth) -> Vector2<f64> {
        x.second().to_matrix() * x.first().coords()
    }

    fn noise(&self, _: &PositionAzimuth) -> Matrix2<f64> {
        Matrix2::identity() * self.variance()
    }

    fn jacobian(&self, x: &PositionAzimuth) -> Matrix2x3<f64> {
        let rotation = x.second().to_matrix();
        let r = x.first().coords();
        let mut h = Matrix2x3::zeros();
        h.fixed_view_mut::<2, 2>(0, 0).copy_from(&rotation);
        h.set_column(2, &(rotation * Vector2::new(-r.y, r.x)));
        h
    }
}

/// The prior `r ~ N(r₀, σ₀² I)`, `A ~ N(0, π²/3)` (the variance of the uniform azimuth), after the
/// settings check every azimuth filter shares.
///
/// # Errors
/// As [`ekf`].
fn prior(
    process: VelocityProcess,
    measurement: &PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
) -> Result<ManifoldGaussian<PositionAzimuth, 3>, OperatorError> {
    let s2 = check_filter_settings(process, measurement, r0, sigma0)?;
    Ok(ManifoldGaussian::new(
        state(r0, So2::from_angle_unchecked(0.0)),
        Matrix3::new(s2, 0.0, 0.0, 0.0, s2, 0.0, 0.0, 0.0, PI * PI / 3.0),
    )?)
}

/// The EKF from the prior `r ~ N(r₀, σ₀² I)`, `A ~ N(0, π²/3)`.
///
/// # Errors
/// The settings check every azimuth filter shares, before anything is built:
/// [`OperatorError::NonFinite`] for a non-finite r₀; [`OperatorError::OutOfRange`] for a component
/// of r₀ beyond ±[`PRIOR_POSITION_LIMIT`](super::PRIOR_POSITION_LIMIT) = ±1e100, σ₀ or the
/// measurement's σ_m outside [`SETTING_SIGMA_RANGE`](super::SETTING_SIGMA_RANGE) = [1e-49, 1e49],
/// or the process's q above 1e49.
///
/// # Example
/// ```
/// use liebayes_experiments::RecursiveFilter;
/// use liebayes_filters::azimuth::{PositionMeasurement, VelocityInput, VelocityProcess, ekf};
/// use nalgebra::Vector2;
/// let process = VelocityProcess::new(0.1).unwrap();
/// let sensor = PositionMeasurement::new(1.0).unwrap();
/// let mut filter = ekf(process, sensor, Vector2::new(5.0, 0.0), 1.0).unwrap();
/// // One second at 1 m/s along the platform's x axis moves the position estimate by 1 m.
/// filter.predict(&VelocityInput { velocity: Vector2::new(1.0, 0.0), dt: 1.0 }).unwrap();
/// let estimate = filter.estimate().unwrap();
/// assert!((estimate.mean_r - Vector2::new(6.0, 0.0)).norm() < 1e-12);
/// // Its variance grows by q² dt = 0.01 per axis.
/// assert!((estimate.cov_r[(0, 0)] - 1.01).abs() < 1e-12);
/// ```
pub fn ekf(
    process: VelocityProcess,
    measurement: PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
) -> Result<AzimuthEkf, OperatorError> {
    Ok(Recursive::with_estimator(
        prior(process, &measurement, r0, sigma0)?,
        Ekf(process),
        Ekf(measurement),
        AzimuthMoments,
    ))
}

/// The UKF from the same prior as [`ekf`], with α = 0.1 (β = 2, κ = 0). With the default α = 1 the
/// sigma points of the prior `σ_A = π/√3` sit at `A ± √3 σ_A = A ± π`, the same rotation, so the
/// measurement sigma points carry no information on A and it is never corrected. α = 0.1 puts them
/// at ±18°; of the values measured (docs/filters/azimuth.md) it is the best over the three
/// scenarios, and wider spreads (α = 0.5) leave early errors that the constant azimuth never sheds.
///
/// # Errors
/// As [`ekf`].
///
/// # Example
/// ```
/// use liebayes_experiments::RecursiveFilter;
/// use liebayes_filters::azimuth::{PositionMeasurement, VelocityProcess, ukf};
/// use nalgebra::Vector2;
/// let filter = ukf(VelocityProcess::new(0.1).unwrap(), PositionMeasurement::new(1.0).unwrap(),
///     Vector2::new(5.0, 0.0), 2.0).unwrap();
/// // Before any step the estimate is the prior: r₀, σ₀² I, the azimuth at 0.
/// let estimate = filter.estimate().unwrap();
/// assert_eq!(estimate.mean_r, Vector2::new(5.0, 0.0));
/// assert!((estimate.cov_r[(1, 1)] - 4.0).abs() < 1e-12);
/// ```
pub fn ukf(
    process: VelocityProcess,
    measurement: PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
) -> Result<AzimuthUkf, OperatorError> {
    Ok(Recursive::with_estimator(
        prior(process, &measurement, r0, sigma0)?,
        Ukf::with_scaling(process, 0.1, 2.0, 0.0)?,
        Ukf::with_scaling(measurement, 0.1, 2.0, 0.0)?,
        AzimuthMoments,
    ))
}

/// A wrapped normal for A: `ρ = exp(−P_AA / 2)`, circular variance P_AA.
impl Estimator<ManifoldGaussian<PositionAzimuth, 3>> for AzimuthMoments {
    type Estimate = AzimuthEstimate;

    fn estimate(
        &self,
        density: &ManifoldGaussian<PositionAzimuth, 3>,
    ) -> Result<AzimuthEstimate, OperatorError> {
        let (p, mean) = (density.covariance(), density.mean());
        AzimuthEstimate {
            azimuth: Some(*mean.second()),
            rho: (-0.5 * p[(2, 2)]).exp(),
            circular_variance: p[(2, 2)],
            mean_r: *mean.first().coords(),
            cov_r: p.fixed_view::<2, 2>(0, 0).into_owned(),
        }
        .checked()
    }
}
