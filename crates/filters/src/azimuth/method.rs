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
            Method::Particle(n) | Method::Marginalized(n) => {
                super::particle::check_count("number of particles", n)
            }
            Method::Grid(n) => super::particle::check_count("number of grid cells", n),
        }
    }

    /// Runs the study of this method on `scenario`: every run with the scenario's prior
    /// (`r ~ N(0, σ₀² I)`, A uniform), scored by [`AzimuthScorer`].
    ///
    /// # Errors
    /// As [`Study::run`]; an invalid method size is an [`ExperimentError::Method`] (its source
    /// the [`Method::validate`] error) before any run.
    pub fn study(
        self,
        scenario: &AzimuthScenario,
        study: &Study,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Summary, ExperimentError> {
        self.validate().map_err(|source| ExperimentError::Method {
            label: self.label(),
            source,
        })?;
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

/// What [`particles_to_match`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct ParticleSearch {
    /// The exact filter's final azimuth RMSE (deg), the target.
    pub exact_rmse: f64,
    /// Every particle count tried, with its final azimuth RMSE (deg; +∞ when no run reported one)
    /// and its number of failed runs, in the order tried.
    pub tried: Vec<(u64, f64, u64)>,
    /// The smallest count found whose RMSE is within the tolerance, `None` if `high` is not.
    pub count: Option<u64>,
}

/// The smallest particle count in `[low, high]` at which the bootstrap particle filter's final
/// azimuth RMSE on `scenario` is at most `(1 + tolerance)` times the exact filter's over the same
/// runs, with no failed run (the exact posterior is optimal, so a particle filter approaches its
/// RMSE from above), to
/// the relative `resolution`, by doubling then bisection
/// ([`smallest_passing`](liebayes_experiments::search::smallest_passing)): about
/// `log₂(high/low) + log₂(1/resolution) + 2` studies of `study`'s runs.
///
/// # Errors
/// [`ExperimentError::OutOfRange`] for a tolerance outside (0, 10] (NaN included), for
/// `low`/`high`/`resolution` outside the search's ranges or a `high` above
/// [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS), and when the scenario leaves the azimuth
/// unobservable (no target); the studies' errors otherwise.
pub fn particles_to_match(
    scenario: &AzimuthScenario,
    study: &Study,
    tolerance: f64,
    (low, high): (u64, u64),
    resolution: f64,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<ParticleSearch, ExperimentError> {
    if !(tolerance > 0.0 && tolerance <= 10.0) {
        return Err(ExperimentError::OutOfRange {
            what: "RMSE tolerance",
            value: tolerance.to_string(),
            range: "(0, 10]",
        });
    }
    let limit = u64::try_from(liebayes_operators::MAX_ELEMENTS).unwrap_or(u64::MAX);
    if high > limit {
        return Err(ExperimentError::OutOfRange {
            what: "largest particle count",
            value: high.to_string(),
            range: "at most 2^30",
        });
    }
    let exact = Method::Exact.study(scenario, study, progress)?;
    let exact_rmse = final_azimuth_rmse(&exact).ok_or(ExperimentError::OutOfRange {
        what: "scenario",
        value: scenario.motion().name().to_owned(),
        range: "a scenario where the azimuth is observable (circle, line)",
    })?;
    let mut tried = Vec::new();
    let count = liebayes_experiments::search::smallest_passing(low, high, resolution, |n| {
        // n ≤ high ≤ 2^30: it fits a usize.
        let particles = usize::try_from(n).unwrap_or(usize::MAX);
        let summary = Method::Particle(particles).study(scenario, study, progress)?;
        let rmse = final_azimuth_rmse(&summary).unwrap_or(f64::INFINITY);
        tried.push((n, rmse, summary.failure_count()));
        Ok::<_, ExperimentError>(
            summary.failure_count() == 0 && rmse <= exact_rmse * (1.0 + tolerance),
        )
    })?;
    Ok(ParticleSearch {
        exact_rmse,
        tried,
        count,
    })
}
