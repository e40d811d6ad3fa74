//! The filters a study compares, by name, and the study of one of them on a scenario.

use super::estimate::AzimuthScorer;
use super::scenario::AzimuthScenario;
use super::{
    AzimuthDensity, AzimuthEstimate, AzimuthExact, PositionMeasurement, VelocityInput,
    VelocityProcess, ekf, grid_filter, marginalized_filter, particle_filter, ukf,
};
use liebayes_experiments::search::{SearchSettings, SizeSearch, smallest_to_match};
use liebayes_experiments::{ExperimentError, Recursive, RecursiveFilter, Study, Summary};
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
            Method::Particle(n) | Method::Marginalized(n) => {
                crate::error::check_count("number of particles", n)
            }
            Method::Grid(n) => crate::error::check_count("number of grid cells", n),
        }
    }

    /// This method with `scenario`'s settings (its process noise, measurement noise and prior):
    /// what a study builds each run's filter from.
    ///
    /// # Errors
    /// A process or measurement noise out of range ([`VelocityProcess::new`],
    /// [`PositionMeasurement::new`]).
    pub fn on(self, scenario: &AzimuthScenario) -> Result<OnScenario, OperatorError> {
        let config = scenario.config();
        Ok(OnScenario {
            method: self,
            process: VelocityProcess::new(config.q)?,
            measurement: PositionMeasurement::new(config.sigma_m)?,
            sigma0: config.sigma0,
        })
    }

    /// Runs the study of this method on `scenario`: every run with the scenario's prior
    /// (`r ~ N(0, σ₀² I)`, A uniform), scored by [`AzimuthScorer`].
    ///
    /// # Errors
    /// As [`Study::run_method`]; an invalid method size is an [`ExperimentError::Method`] (its
    /// source the [`Method::validate`] error) before any run, a scenario setting out of range an
    /// [`ExperimentError::Scenario`].
    pub fn study(
        self,
        scenario: &AzimuthScenario,
        study: &Study,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Summary, ExperimentError> {
        let method = self
            .on(scenario)
            .map_err(|e| ExperimentError::Scenario(e.to_string()))?;
        study.run_method(scenario, &method, &AzimuthScorer, progress)
    }
}

/// Any filter of azimuth alignment: each reports an [`AzimuthEstimate`].
pub type AzimuthFilter = Box<
    dyn RecursiveFilter<
            Input = VelocityInput,
            Measurement = Vector2<f64>,
            Estimate = AzimuthEstimate,
        > + Send,
>;

/// A [`Method`] with the models it runs with: the velocity process, the position measurement and
/// the prior's position standard deviation σ₀ (the prior `r ~ N(0, σ₀² I)`, A uniform). What a
/// study builds each run's filter from ([`Study::run_method`]); a filter assuming other noise than
/// the scenario's (a mis-specified model) is one with other `process` or `measurement`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OnScenario {
    /// The method.
    pub method: Method,
    /// The process model it assumes.
    pub process: VelocityProcess,
    /// The measurement model it assumes.
    pub measurement: PositionMeasurement,
    /// The prior position standard deviation σ₀ (m).
    pub sigma0: f64,
}

impl liebayes_experiments::Method for OnScenario {
    type Filter = AzimuthFilter;

    fn label(&self) -> String {
        self.method.label()
    }

    /// The method's own settings, and the models' and σ₀ as every azimuth filter checks them
    /// (a mis-specified model of settings no filter can run is refused before any run).
    fn validate(&self) -> Result<(), OperatorError> {
        self.method.validate()?;
        super::model::check_filter_settings(
            self.process,
            &self.measurement,
            Vector2::zeros(),
            self.sigma0,
        )
        .map(|_| ())
    }

    /// The method's filter; the sampling filters draw their particles from `rng`'s copy.
    fn build(&self, rng: &mut ChaCha8Rng) -> Result<AzimuthFilter, OperatorError> {
        let Self {
            method,
            process,
            measurement,
            sigma0,
        } = *self;
        let r0 = Vector2::zeros();
        Ok(match method {
            Method::Exact => Box::new(exact(process, measurement, r0, sigma0)?),
            Method::Ekf => Box::new(ekf(process, measurement, r0, sigma0)?),
            Method::Ukf => Box::new(ukf(process, measurement, r0, sigma0)?),
            Method::Particle(n) => Box::new(particle_filter(
                n,
                process,
                measurement,
                r0,
                sigma0,
                rng.clone(),
            )?),
            Method::Grid(n) => Box::new(grid_filter(n, process, measurement, r0, sigma0)?),
            Method::Marginalized(n) => Box::new(marginalized_filter(
                n,
                process,
                measurement,
                r0,
                sigma0,
                rng.clone(),
            )?),
        })
    }
}

/// The exact filter from the prior `r ~ N(r₀, σ₀² I)`, A uniform.
///
/// The settings are checked as every azimuth filter's (as [`ekf`]), so that a setting one filter
/// accepts, all six can run: narrower than [`AzimuthDensity::new`]'s own range, which stays open to
/// a density built directly.
///
/// # Errors
/// As [`ekf`]: [`OperatorError::NonFinite`] for a non-finite r₀; [`OperatorError::OutOfRange`] for
/// a component of r₀ beyond ±1e100, σ₀ or the measurement's σ_m outside [1e-49, 1e49], or the
/// process's q above 1e49.
pub fn exact(
    process: VelocityProcess,
    measurement: PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
) -> Result<AzimuthExact, OperatorError> {
    super::model::check_filter_settings(process, &measurement, r0, sigma0)?;
    Ok(Recursive::with_estimator(
        AzimuthDensity::new(r0, sigma0)?,
        process,
        measurement,
        super::AzimuthMoments,
    ))
}

/// The root mean square of the final azimuth error (deg) over the runs of a study, `None` when no
/// run reported an azimuth (an unobservable scenario, or every run failed).
pub fn final_azimuth_rmse(summary: &Summary) -> Option<f64> {
    summary
        .series("azimuth_error")?
        .epochs()
        .last()?
        .mean_square()
        .map(f64::sqrt)
}

/// The smallest particle count in `settings`' range at which the bootstrap particle filter's
/// final azimuth RMSE ([`final_azimuth_rmse`]) on `scenario` is at most `(1 + tolerance)` times
/// the exact filter's over the same runs, with no failed run (the exact posterior is optimal, so a
/// particle filter approaches its RMSE from above), by
/// [`smallest_to_match`](liebayes_experiments::search::smallest_to_match): about
/// `log₂(high/low) + log₂(1/resolution) + 2` studies of `study`'s runs. The search's target is the
/// exact filter's RMSE (deg).
///
/// # Errors
/// [`ExperimentError::OutOfRange`] when the scenario leaves the azimuth unobservable (no target)
/// and, before any study, for settings outside the search's ranges
/// ([`SearchSettings::check`](liebayes_experiments::search::SearchSettings::check)); the studies'
/// errors otherwise.
pub fn particles_to_match(
    scenario: &AzimuthScenario,
    study: &Study,
    settings: SearchSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<SizeSearch, ExperimentError> {
    // Before the exact filter's study: bad settings cost no work.
    settings.check()?;
    let exact = Method::Exact.study(scenario, study, progress)?;
    let exact_rmse = final_azimuth_rmse(&exact).ok_or(ExperimentError::OutOfRange {
        what: "scenario",
        value: scenario.motion().name().to_owned(),
        range: "a scenario where the azimuth is observable (circle, line)",
    })?;
    smallest_to_match(
        exact_rmse,
        settings,
        |n| {
            // n ≤ high ≤ MAX_ELEMENTS: it fits a usize.
            let particles = usize::try_from(n).unwrap_or(usize::MAX);
            Method::Particle(particles).study(scenario, study, progress)
        },
        final_azimuth_rmse,
    )
}
