//! Monte Carlo study of any azimuth filter over one scenario: seeded, reproducible whatever the number of
//! threads (run i simulates with seed `seed + i` and draws the filter's own randomness from `!(seed + i)`),
//! parallel over the runs.

use super::baselines::{
    AzimuthFilter, Estimate, GaussianBaseline, Linearisation, MarginalizedBaseline,
    ParticleBaseline,
};
use super::scenario::{Config, Scenario, simulate};
use super::{AzimuthDensity, GridReference, PositionMeasurement, VelocityInput, VelocityProcess};
use liebayes_manifolds::So2;
use liebayes_operators::OperatorError;
use liebayes_operators::evaluation::{
    MeanEstimate, MonteCarlo, Series, average_nees_band, circular_consistency, estimation_error,
    nees,
};
use nalgebra::Vector2;
use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::{Duration, Instant};

/// A final azimuth error above this counts as a divergence (10°).
pub const DIVERGENCE_THRESHOLD: f64 = 10.0 * std::f64::consts::PI / 180.0;

/// The filters a study can run.
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

    /// The filter with the scenario's prior (`r ~ N(0, σ₀² I)`, A uniform).
    ///
    /// # Errors
    /// [`OperatorError`] for an invalid σ₀, or a particle or cell count that is zero or above
    /// [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS).
    pub fn build(
        self,
        config: &Config,
        rng: &mut dyn RngCore,
    ) -> Result<Box<dyn AzimuthFilter>, OperatorError> {
        let (r0, s0) = (Vector2::zeros(), config.sigma0);
        Ok(match self {
            Method::Exact => Box::new(AzimuthDensity::new(r0, s0)?),
            Method::Ekf => Box::new(GaussianBaseline::new(Linearisation::Extended, r0, s0)?),
            Method::Ukf => Box::new(GaussianBaseline::new(Linearisation::Unscented, r0, s0)?),
            Method::Particle(n) => Box::new(ParticleBaseline::new(n, r0, s0, rng)?),
            Method::Grid(n) => Box::new(GridReference::new(n, r0, s0)?),
            Method::Marginalized(n) => Box::new(MarginalizedBaseline::new(n, r0, s0, rng)?),
        })
    }
}

/// One measurement epoch of one run: the estimate against the truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epoch {
    /// Time (s).
    pub t: f64,
    /// Estimated minus true azimuth, wrapped (rad); `None` when the filter holds A uniform.
    pub azimuth_error: Option<f64>,
    /// The filter's σ_A (rad); `None` when it holds A uniform.
    pub sigma_a: Option<f64>,
    /// The filter's mean resultant length ρ.
    pub rho: f64,
    /// `E r − r` (m).
    pub position_error: Vector2<f64>,
    /// The filter's standard deviations of r (m), `√diag(Cov r)`.
    pub position_sigma: Vector2<f64>,
    /// NEES of r, `None` when Cov r is not positive definite.
    pub nees: Option<f64>,
}

/// One run: every measurement epoch, the filter time, and whether a step failed.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// The true azimuth (rad).
    pub true_azimuth: f64,
    /// The estimate after each update.
    pub epochs: Vec<Epoch>,
    /// Wall-clock filter time (s), simulation excluded.
    pub seconds: f64,
    /// Propagation steps run.
    pub steps: usize,
    /// The error that stopped the filter, if one did (the run then counts as diverged).
    pub failure: Option<OperatorError>,
}

/// Runs `method` on one simulation of `scenario` (simulation seeded with `seed`, filter randomness
/// with `!seed`).
///
/// # Errors
/// [`OperatorError`] for an invalid configuration (a failure of the filter mid-run is recorded in
/// [`Run::failure`] instead).
pub fn run_once(
    method: Method,
    scenario: Scenario,
    config: &Config,
    seed: u64,
) -> Result<Run, OperatorError> {
    let process = VelocityProcess::new(config.q)?;
    let measurement = PositionMeasurement::new(config.sigma_m)?;
    let sim = simulate(scenario, config, &mut ChaCha8Rng::seed_from_u64(seed))?;
    let mut rng = ChaCha8Rng::seed_from_u64(!seed);
    let mut filter = method.build(config, &mut rng)?;
    let mut epochs = Vec::with_capacity(sim.measurements.iter().flatten().count());
    let mut failure = None;
    let mut steps = 0;
    // The clock runs over the whole loop; the estimates and their record (not part of a filter step)
    // are timed apart and subtracted.
    let mut estimating = Duration::ZERO;
    let start = Instant::now();
    for (k, v) in sim.velocities.iter().enumerate() {
        let step = (|| {
            if let Some(z) = sim.measurements[k] {
                filter.update(&measurement, &z, &mut rng)?;
                let clock = Instant::now();
                epochs.push(epoch(
                    k as f64 * config.dt,
                    &filter.estimate()?,
                    sim.true_azimuth,
                    &sim.positions[k],
                ));
                estimating += clock.elapsed();
            }
            let input = VelocityInput {
                velocity: *v,
                dt: config.dt,
            };
            filter.predict(&process, &input, &mut rng)
        })();
        steps += 1;
        if let Err(e) = step {
            failure = Some(e);
            break;
        }
    }
    let seconds = start.elapsed().saturating_sub(estimating).as_secs_f64();
    Ok(Run {
        true_azimuth: sim.true_azimuth,
        epochs,
        seconds,
        steps,
        failure,
    })
}

/// The epoch's errors, through the manifolds: `estimate ⊟ truth` on SO(2) for the azimuth (wrapped to
/// (−π, π]) and on R² for the position.
fn epoch(t: f64, estimate: &Estimate, true_azimuth: f64, position: &Vector2<f64>) -> Epoch {
    let truth = So2::from_angle_unchecked(true_azimuth);
    let error = estimate.mean_r - position;
    Epoch {
        t,
        azimuth_error: estimate
            .azimuth
            .map(|a| estimation_error(&truth, &So2::from_angle_unchecked(a))[0]),
        sigma_a: estimate.sigma_a(),
        rho: estimate.rho,
        position_error: error,
        position_sigma: estimate.cov_r.diagonal().map(|v| v.max(0.0).sqrt()),
        nees: nees(&error, &estimate.cov_r).ok(),
    }
}

/// A method's figures over many runs of one scenario.
#[derive(Clone, Debug)]
pub struct Summary {
    /// The method.
    pub method: Method,
    /// The scenario.
    pub scenario: Scenario,
    /// The first run (seed `seed`), kept whole for plots.
    pub first_run: Run,
    /// Number of runs.
    pub runs: usize,
    /// Runs in which a step failed.
    pub failures: usize,
    /// RMS of the final azimuth error (rad) over the runs that report an azimuth.
    pub azimuth_rmse: Option<f64>,
    /// Mean of the reported final σ_A (rad) over the same runs.
    pub mean_sigma_a: Option<f64>,
    /// Average NEES of the final position estimate (2 for a consistent filter); infinite when a run's
    /// covariance was not positive definite or a run failed.
    pub average_nees: f64,
    /// Its 95 % band for this number of runs.
    pub nees_band: (f64, f64),
    /// The circular consistency statistic of the final azimuth (mean 1 for a consistent filter), with
    /// its band from the sample variance.
    pub circular: MeanEstimate,
    /// Fraction of runs whose final azimuth error exceeds 10° or that failed, among the runs that report
    /// an azimuth or failed; `None` when none did (azimuth unobservable).
    pub divergence_rate: Option<f64>,
    /// Wall-clock filter time per propagation step (ns): a propagation every step and an update at every
    /// measurement.
    pub ns_per_step: f64,
    /// Per measurement epoch over the runs: mean squared azimuth error (rad²).
    pub azimuth_mse: Series,
    /// Per epoch: mean reported σ_A² (rad²), to compare with the mean squared error.
    pub mean_sigma_a2: Series,
    /// Per epoch: mean squared position error |E r − r|² (m²).
    pub position_mse: Series,
    /// Per epoch: mean reported tr Cov r (m²).
    pub mean_position_variance: Series,
}

/// Runs `method` on `runs` simulations of `scenario` in parallel (run i seeded with `seed + i`) and
/// summarises the final epoch and the errors over time.
///
/// # Errors
/// [`OperatorError`] for an invalid configuration, `runs == 0` or runs above
/// [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS), or per-epoch sums that overflow.
pub fn study(
    method: Method,
    scenario: Scenario,
    config: &Config,
    runs: usize,
    seed: u64,
) -> Result<Summary, OperatorError> {
    if runs == 0 {
        return Err(OperatorError::OutOfRange {
            what: "number of Monte Carlo runs",
            value: 0.0,
            range: "at least 1",
        });
    }
    let label = format!("{} {}", method.label(), scenario.name());
    config.validate()?;
    let results = MonteCarlo::new(label).run(runs, |i| {
        run_once(method, scenario, config, seed.wrapping_add(i as u64))
    })?;
    let results = results.into_iter().collect::<Result<Vec<Run>, _>>()?;
    let first_run = results.first().cloned().ok_or(OperatorError::OutOfRange {
        what: "number of Monte Carlo runs",
        value: 0.0,
        range: "at least 1",
    })?;
    let mut summary = Summary {
        method,
        scenario,
        first_run,
        runs,
        failures: 0,
        azimuth_rmse: None,
        mean_sigma_a: None,
        average_nees: 0.0,
        nees_band: average_nees_band(2, runs)?,
        circular: MeanEstimate::default(),
        divergence_rate: None,
        ns_per_step: 0.0,
        azimuth_mse: Series::default(),
        mean_sigma_a2: Series::default(),
        position_mse: Series::default(),
        mean_position_variance: Series::default(),
    };
    let (mut squared, mut sigma, mut reported, mut diverged) = (0.0, 0.0, 0usize, 0usize);
    let (mut nees_sum, mut seconds, mut steps) = (0.0, 0.0, 0usize);
    for run in &results {
        seconds += run.seconds;
        steps += run.steps;
        for (k, e) in run.epochs.iter().enumerate() {
            if let (Some(error), Some(s)) = (e.azimuth_error, e.sigma_a) {
                summary.azimuth_mse.add(k, error * error)?;
                summary.mean_sigma_a2.add(k, s * s)?;
            }
            summary
                .position_mse
                .add(k, e.position_error.norm_squared())?;
            summary
                .mean_position_variance
                .add(k, e.position_sigma.norm_squared())?;
        }
        let last = run.epochs.last();
        if run.failure.is_some() || last.is_none() {
            summary.failures += 1;
            diverged += 1;
            nees_sum = f64::INFINITY;
            continue;
        }
        let Some(last) = last else { continue };
        nees_sum += last.nees.unwrap_or(f64::INFINITY);
        if let (Some(error), Some(s)) = (last.azimuth_error, last.sigma_a) {
            squared += error * error;
            sigma += s;
            reported += 1;
            diverged += usize::from(error.abs() > DIVERGENCE_THRESHOLD);
            if let Some(c) = circular_consistency(error, last.rho) {
                summary.circular.add(c)?;
            }
        }
    }
    let per = |x: f64| (reported > 0).then(|| x / reported as f64);
    summary.azimuth_rmse = per(squared).map(f64::sqrt);
    summary.mean_sigma_a = per(sigma);
    summary.average_nees = nees_sum / runs as f64;
    summary.divergence_rate = (reported + summary.failures > 0)
        .then(|| diverged as f64 / (reported + summary.failures) as f64);
    summary.ns_per_step = seconds * 1e9 / steps.max(1) as f64;
    Ok(summary)
}
