//! The attitude filters on the experiment layer: a simulated IMU as a [`Scenario`]
//! ([`ImuScenario`]: gyroscope and accelerometer samples drive the process, magnetometer readings
//! are the measurements), the production filter as a
//! [`RecursiveFilter`](liebayes_experiments::RecursiveFilter) (implemented on [`AttitudeEkf`]),
//! and [`AttitudeScorer`]: BROAD's errors and the NEES of the heading, the tilt and the whole
//! attitude error against their χ² bands. A [`Study`](liebayes_experiments::Study) of these runs
//! many independent simulated runs in constant memory.
//!
//! [`AttitudeEkf`]: super::AttitudeEkf

use super::data::{DataError, ImuLog};
use super::metric::sample_errors;
use super::simulate::{SimulationSettings, check_settings, simulate};
use super::track::AttitudeTrack;
use liebayes_experiments::{ExperimentError, Metric, Reduction, Scenario, Scorer, Step};
use nalgebra::{Matrix2, Matrix3, UnitQuaternion, Vector2, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// One sample's gyroscope (rad/s) and accelerometer (m/s²) readings: the process input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// Gyroscope (rad/s, IMU frame).
    pub gyro: Vector3<f64>,
    /// Accelerometer (m/s², IMU frame).
    pub acc: Vector3<f64>,
}

/// An attitude filter's estimate: the orientation (IMU frame w.r.t. ENU) and the covariance of
/// its world-frame error `δθ`, `R_true = exp([δθ]ₓ) R̂` (rad²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttitudeEstimate {
    /// The orientation.
    pub orientation: UnitQuaternion<f64>,
    /// The world-frame error covariance (rad²).
    pub covariance: Matrix3<f64>,
}

/// Simulated IMU runs ([`simulate`] with `settings`, one seed drawn per run from the run's
/// simulation stream): every sample is a step whose input is its gyroscope and accelerometer
/// reading and whose truth is its orientation; every `magnetometer_every`-th sample (from the
/// first) carries the magnetometer reading as the measurement, and is a scored epoch. The run's
/// log is simulated whole before it is replayed (its memory is the log's).
#[derive(Clone, Debug, PartialEq)]
pub struct ImuScenario {
    settings: SimulationSettings,
    magnetometer_every: usize,
}

impl ImuScenario {
    /// The scenario of `settings`, with a magnetometer reading every `magnetometer_every` samples.
    ///
    /// # Errors
    /// [`DataError::BadValue`] for settings [`simulate`] refuses or `magnetometer_every` = 0.
    pub fn new(settings: SimulationSettings, magnetometer_every: usize) -> Result<Self, DataError> {
        check_settings(&settings)?;
        if magnetometer_every == 0 {
            return Err(DataError::BadValue {
                origin: "ImuScenario::new".to_owned(),
                variable: "magnetometer_every".to_owned(),
                row: 0,
                value: "0".to_owned(),
                expected: "at least 1 sample between magnetometer readings",
            });
        }
        Ok(Self {
            settings,
            magnetometer_every,
        })
    }

    /// The simulation settings.
    pub fn settings(&self) -> &SimulationSettings {
        &self.settings
    }
}

/// The steps of one simulated run of an [`ImuScenario`].
#[derive(Clone, Debug)]
pub struct ImuSteps {
    log: ImuLog,
    next: usize,
    magnetometer_every: usize,
}

impl Iterator for ImuSteps {
    type Item = Step<UnitQuaternion<f64>, ImuSample, Vector3<f64>>;

    fn next(&mut self) -> Option<Self::Item> {
        let k = self.next;
        let truth = (*self.log.reference()?.get(k)?)?;
        self.next += 1;
        let measurement = (k % self.magnetometer_every == 0)
            .then(|| self.log.magnetometer().map(|m| m[k]))
            .flatten();
        Some(Step {
            time: k as f64 * self.log.interval(),
            input: ImuSample {
                gyro: self.log.gyroscope()[k],
                acc: self.log.accelerometer()[k],
            },
            truth,
            measurement,
        })
    }
}

impl Scenario for ImuScenario {
    type Truth = UnitQuaternion<f64>;
    type Input = ImuSample;
    type Measurement = Vector3<f64>;
    type Steps<'s> = ImuSteps;

    fn epochs(&self) -> usize {
        self.settings.samples.div_ceil(self.magnetometer_every)
    }

    fn simulate<'s>(&'s self, rng: &'s mut ChaCha8Rng) -> Result<ImuSteps, ExperimentError> {
        let log = simulate(&self.settings, rng.random())
            .map_err(|e| ExperimentError::Scenario(e.to_string()))?;
        Ok(ImuSteps {
            log,
            next: 0,
            magnetometer_every: self.magnetometer_every,
        })
    }
}

/// Scores an [`AttitudeEstimate`] against the true orientation: BROAD's heading, inclination
/// (`tilt_error`) and total errors (deg, [`sample_errors`], root mean square over runs) beside the
/// reported σ (`heading_sigma` `√P_zz`, `tilt_sigma` `√(P_xx + P_yy)`, deg), and with the
/// world-frame error `δθ = log(R_true R̂ᵀ)` the NEES of its vertical component `δθ_z² / P_zz`
/// (χ²(1)), of its horizontal part `δθ_xyᵀ P_xy⁻¹ δθ_xy` (χ²(2)) and of the whole `δθᵀ P⁻¹ δθ`
/// (χ²(3)); NaN where the covariance block is not positive definite.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AttitudeScorer;

impl Scorer<UnitQuaternion<f64>, AttitudeEstimate> for AttitudeScorer {
    fn metrics(&self) -> Vec<Metric> {
        vec![
            Metric::new("heading_error", Reduction::RootMeanSquare, "deg").per_run(),
            Metric::new("heading_sigma", Reduction::RootMeanSquare, "deg"),
            Metric::new("tilt_error", Reduction::RootMeanSquare, "deg").per_run(),
            Metric::new("tilt_sigma", Reduction::RootMeanSquare, "deg"),
            Metric::new("total_error", Reduction::RootMeanSquare, "deg").per_run(),
            Metric::new("heading_nees", Reduction::ChiSquare { dof: 1 }, ""),
            Metric::new("tilt_nees", Reduction::ChiSquare { dof: 2 }, ""),
            Metric::new("nees", Reduction::ChiSquare { dof: 3 }, ""),
        ]
    }

    fn score(&self, truth: &UnitQuaternion<f64>, estimate: &AttitudeEstimate, values: &mut [f64]) {
        let e = sample_errors(&estimate.orientation, truth);
        let p = &estimate.covariance;
        let (heading_sigma, tilt_sigma) = AttitudeTrack::sigmas_of_world_covariance(p);
        values[0] = e.heading.to_degrees();
        values[1] = heading_sigma.to_degrees();
        values[2] = e.inclination.to_degrees();
        values[3] = tilt_sigma.to_degrees();
        values[4] = e.total.to_degrees();
        let d = (truth * estimate.orientation.inverse()).scaled_axis();
        values[5] = if p[(2, 2)] > 0.0 {
            d.z * d.z / p[(2, 2)]
        } else {
            f64::NAN
        };
        let tilt: Matrix2<f64> = p.fixed_view::<2, 2>(0, 0).into_owned();
        values[6] = tilt.cholesky().map_or(f64::NAN, |c| {
            let h = Vector2::new(d.x, d.y);
            h.dot(&c.solve(&h))
        });
        values[7] = p.cholesky().map_or(f64::NAN, |c| d.dot(&c.solve(&d)));
    }
}
