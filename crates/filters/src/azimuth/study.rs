//! Monte Carlo study of the exact filter over one scenario: seeded, reproducible, a few ms per 100 runs.

use super::scenario::{Config, Scenario, simulate};
use super::{
    AzimuthDensity, ParticleBaseline, PositionMeasurement, VelocityInput, VelocityProcess,
};
use liebayes_operators::OperatorError;
use liebayes_operators::evaluation::{angle_difference, average_nees_band, nees};
use nalgebra::Vector2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// The exact filter's figures over many runs, at the final measurement epoch.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The scenario.
    pub scenario: Scenario,
    /// Number of runs.
    pub runs: usize,
    /// RMS of the final azimuth error (rad) over the runs where the azimuth is observable (κ > 0).
    pub azimuth_rmse: Option<f64>,
    /// Mean of the reported σ_A (rad) over the same runs.
    pub mean_sigma_a: Option<f64>,
    /// Average NEES of the final position estimate (2 for a consistent filter).
    pub average_nees: f64,
    /// Its 95 % band for this number of runs.
    pub nees_band: (f64, f64),
    /// Fraction of runs whose final azimuth error exceeds 10°, among runs where it is observable.
    pub divergence_rate: Option<f64>,
    /// Wall-clock filter time per simulation step (ns): a propagation every step and an update at every
    /// measurement, simulation excluded.
    pub ns_per_step: f64,
}

/// Runs the exact filter on `runs` simulations of `scenario` (run i seeded with `seed + i`).
///
/// # Errors
/// [`OperatorError`] for an invalid configuration (non-positive noise levels).
pub fn study(
    scenario: Scenario,
    config: &Config,
    runs: usize,
    seed: u64,
) -> Result<Summary, OperatorError> {
    let process = VelocityProcess::new(config.q)?;
    let measurement = PositionMeasurement::new(config.sigma_m)?;
    let (mut nees_sum, mut squared_error, mut sigma_sum, mut observable, mut diverged) =
        (0.0, 0.0, 0.0, 0usize, 0usize);
    let mut filter_seconds = 0.0;
    let mut steps = 0usize;
    for run in 0..runs {
        let sim = simulate(
            scenario,
            config,
            &mut ChaCha8Rng::seed_from_u64(seed + run as u64),
        );
        let mut filter = AzimuthDensity::new(Vector2::zeros(), config.sigma0)?;
        let mut last = None;
        let start = Instant::now();
        for (k, v) in sim.velocities.iter().enumerate() {
            if let Some(z) = sim.measurements[k] {
                filter.update(&measurement, &z)?;
                last = Some((filter, sim.positions[k]));
            }
            filter.predict(
                &process,
                &VelocityInput {
                    velocity: *v,
                    dt: config.dt,
                },
            )?;
        }
        filter_seconds += start.elapsed().as_secs_f64();
        steps += sim.velocities.len();
        let Some((density, truth)) = last else {
            continue;
        };
        let estimates = density.estimates();
        nees_sum += nees(&(truth - estimates.mean_r), &estimates.cov_r).unwrap_or(f64::INFINITY);
        if let (Some(mode), Some(sigma_a)) = (estimates.mode, estimates.sigma_a) {
            let error = angle_difference(mode, sim.true_azimuth);
            squared_error += error * error;
            sigma_sum += sigma_a;
            observable += 1;
            diverged += usize::from(error.abs() > 10f64.to_radians());
        }
    }
    let per_observable = |x: f64| (observable > 0).then(|| x / observable as f64);
    Ok(Summary {
        scenario,
        runs,
        azimuth_rmse: per_observable(squared_error).map(f64::sqrt),
        mean_sigma_a: per_observable(sigma_sum),
        average_nees: nees_sum / runs.max(1) as f64,
        nees_band: average_nees_band(2, runs.max(1)),
        divergence_rate: per_observable(diverged as f64),
        ns_per_step: filter_seconds * 1e9 / steps.max(1) as f64,
    })
}

/// A baseline's figures over many runs, at the final measurement epoch.
#[derive(Clone, Debug, PartialEq)]
pub struct BaselineSummary {
    /// Number of runs.
    pub runs: usize,
    /// RMS of the final azimuth error (rad).
    pub azimuth_rmse: f64,
    /// Fraction of runs whose final azimuth error exceeds 10°.
    pub divergence_rate: f64,
    /// Wall-clock filter time per simulation step (ns), simulation excluded.
    pub ns_per_step: f64,
}

/// The bootstrap particle filter with `particles` particles on the same simulations as [`study`]
/// (run i seeded with `seed + i`; the filter's own randomness seeded apart from it).
///
/// # Errors
/// [`OperatorError`] for an invalid configuration, or when the particles cannot explain a measurement.
pub fn particle_study(
    scenario: Scenario,
    config: &Config,
    runs: usize,
    seed: u64,
    particles: usize,
) -> Result<BaselineSummary, OperatorError> {
    let process = VelocityProcess::new(config.q)?;
    let measurement = PositionMeasurement::new(config.sigma_m)?;
    let (mut squared_error, mut diverged, mut seconds, mut steps) = (0.0, 0usize, 0.0, 0usize);
    for run in 0..runs {
        let sim = simulate(
            scenario,
            config,
            &mut ChaCha8Rng::seed_from_u64(seed + run as u64),
        );
        let mut rng = ChaCha8Rng::seed_from_u64(!(seed + run as u64));
        let start = Instant::now();
        let mut filter =
            ParticleBaseline::new(particles, Vector2::zeros(), config.sigma0, &mut rng)?;
        let mut last = 0.0;
        for (k, v) in sim.velocities.iter().enumerate() {
            if let Some(z) = sim.measurements[k] {
                filter.update(&measurement, &z, &mut rng)?;
                last = filter.azimuth_mean();
            }
            filter.predict(
                &process,
                &VelocityInput {
                    velocity: *v,
                    dt: config.dt,
                },
                &mut rng,
            )?;
        }
        seconds += start.elapsed().as_secs_f64();
        steps += sim.velocities.len();
        let error = angle_difference(last, sim.true_azimuth);
        squared_error += error * error;
        diverged += usize::from(error.abs() > 10f64.to_radians());
    }
    let runs_f = runs.max(1) as f64;
    Ok(BaselineSummary {
        runs,
        azimuth_rmse: (squared_error / runs_f).sqrt(),
        divergence_rate: diverged as f64 / runs_f,
        ns_per_step: seconds * 1e9 / steps.max(1) as f64,
    })
}
