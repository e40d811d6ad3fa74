//! The filters a study compares, by name, and the study of one of them on a scenario.

use super::estimate::AzimuthScorer;
use super::scenario::AzimuthScenario;
use super::{
    AzimuthDensity, AzimuthExact, PositionMeasurement, VelocityProcess, ekf, grid_filter,
    marginalized_filter, particle_filter, ukf,
};
use liebayes_experiments::{ExperimentError, Recursive, Study, Summary};
use liebayes_operators::OperatorError;
use nalgebra::Vector2;
use rand_chacha::ChaCha8Rng;

/// The filters of azimuth alignment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The exact seven-number filter ([`AzimuthDensity`]).
    Exact,
    /// The EKF on `[r, A]`.
    Ekf,
    /// The UKF on `[r, A]`.
    Ukf,
    /// The bootstrap particle filter with this many particles.
    Particle(usize),
    /// The grid filter (a Kalman filter at each of this many azimuths).
    Grid(usize),
    /// The marginalized particle filter with this many azimuth particles.
    Marginalized(usize),
}

impl Method {
    /// A short label: `exact`, `EKF`, `UKF`, `PF 1000`, `grid 360`, `MPF 360`.
    pub fn label(self) -> String {
        match self {
            Method::Exact => "exact".into(),
            Method::Ekf => "EKF".into(),
            Method::Ukf => "UKF".into(),
            Method::Particle(n) => format!("PF {n}"),
            Method::Grid(n) => format!("grid {n}"),
            Method::Marginalized(n) => format!("MPF {n}"),
        }
    }

    /// Checks the method's size (particles, cells) before any study allocates it.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for zero, [`OperatorError::TooLarge`] above
    /// [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS).
    pub fn validate(self) -> Result<(), OperatorError> {
        match self {
            Method::Exact | Method::Ekf | Method::Ukf => Ok(()),
            Method::Particle(n) | Method::Grid(n) | Method::Marginalized(n) => {
                super::particle::check_count(n)
            }
        }
    }

    /// Runs the study of this method on `scenario`: every run with the scenario's prior
    /// (`r ~ N(0, σ₀² I)`, A uniform), scored by [`AzimuthScorer`].
    ///
    /// # Errors
    /// As [`Study::run`]; an invalid method size is an [`ExperimentError::OutOfRange`] before any
    /// run.
    pub fn study(
        self,
        scenario: &AzimuthScenario,
        study: &Study,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Summary, ExperimentError> {
        self.validate()
            .map_err(|e| ExperimentError::Scenario(e.to_string()))?;
        let config = scenario.config();
        let (r0, s0) = (Vector2::zeros(), config.sigma0);
        let settings = || -> Result<(VelocityProcess, PositionMeasurement), OperatorError> {
            Ok((
                VelocityProcess::new(config.q)?,
                PositionMeasurement::new(config.sigma_m)?,
            ))
        };
        let (process, measurement) =
            settings().map_err(|e| ExperimentError::Scenario(e.to_string()))?;
        let scorer = AzimuthScorer;
        match self {
            Method::Exact => study.run(
                scenario,
                &|_: &mut ChaCha8Rng| exact(process, measurement, r0, s0),
                &scorer,
                progress,
            ),
            Method::Ekf => study.run(
                scenario,
                &|_: &mut ChaCha8Rng| ekf(process, measurement, r0, s0),
                &scorer,
                progress,
            ),
            Method::Ukf => study.run(
                scenario,
                &|_: &mut ChaCha8Rng| ukf(process, measurement, r0, s0),
                &scorer,
                progress,
            ),
            Method::Particle(n) => study.run(
                scenario,
                &|rng: &mut ChaCha8Rng| {
                    particle_filter(n, process, measurement, r0, s0, rng.clone())
                },
                &scorer,
                progress,
            ),
            Method::Grid(n) => study.run(
                scenario,
                &|_: &mut ChaCha8Rng| grid_filter(n, process, measurement, r0, s0),
                &scorer,
                progress,
            ),
            Method::Marginalized(n) => study.run(
                scenario,
                &|rng: &mut ChaCha8Rng| {
                    marginalized_filter(n, process, measurement, r0, s0, rng.clone())
                },
                &scorer,
                progress,
            ),
        }
    }
}

/// The exact filter from the prior `r ~ N(r₀, σ₀² I)`, A uniform.
///
/// # Errors
/// As [`AzimuthDensity::new`].
pub fn exact(
    process: VelocityProcess,
    measurement: PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
) -> Result<AzimuthExact, OperatorError> {
    Ok(Recursive::with_estimator(
        AzimuthDensity::new(r0, sigma0)?,
        process,
        measurement,
        super::AzimuthMoments,
    ))
}
