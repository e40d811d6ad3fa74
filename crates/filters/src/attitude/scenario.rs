//! The attitude filters' scenarios on the experiment layer: [`ImuScenario`], simulated IMU runs,
//! and [`LogScenario`], a recorded log replayed as it is. In both, every sample is a step whose
//! input is its gyroscope and accelerometer reading ([`ImuSample`]) and whose measurement is its
//! magnetometer reading, where it has one.

use super::data::{DataError, ImuLog};
use super::estimate::ImuSample;
use super::simulate::{SimulationSettings, check_settings, simulate};
use crate::error::FilterError;
use liebayes_experiments::{ExperimentError, Scenario, Step};
use nalgebra::{UnitQuaternion, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Simulated IMU runs ([`simulate`] with `settings`, one seed drawn per run from the run's
/// simulation stream): the truth is each sample's orientation; every `magnetometer_every`-th
/// sample (from the first) carries the magnetometer reading as the measurement, and is a scored
/// epoch. The run's log is simulated whole before it is replayed (its memory is the log's).
#[derive(Clone, Debug, PartialEq)]
pub struct ImuScenario {
    settings: SimulationSettings,
    magnetometer_every: usize,
}

impl ImuScenario {
    /// The scenario of `settings`, with a magnetometer reading every `magnetometer_every` samples.
    ///
    /// # Errors
    /// [`FilterError::Setting`] for settings [`simulate`] refuses or `magnetometer_every` = 0.
    pub fn new(
        settings: SimulationSettings,
        magnetometer_every: usize,
    ) -> Result<Self, FilterError> {
        check_settings(&settings)?;
        if magnetometer_every == 0 {
            return Err(FilterError::Setting {
                origin: "ImuScenario::new",
                setting: "magnetometer_every",
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

/// A recorded [`ImuLog`] as a scenario: every run replays the same samples. The truth of a sample
/// is its reference orientation where the log has one and the sample counts (the movement mask;
/// every sample without a mask), `None` otherwise (scored as NaN, left out of every statistic). The
/// measurement is the sample's magnetometer reading as the log has it (a magnetometer slower than
/// the gyroscope repeats its last reading; each filter knows what to do with a repeat); a 6D log
/// has none.
#[derive(Clone, Debug, PartialEq)]
pub struct LogScenario {
    log: ImuLog,
    epochs: usize,
}

impl LogScenario {
    /// The scenario of `log`.
    ///
    /// # Errors
    /// [`DataError::NothingToScore`] for an empty log.
    pub fn new(log: ImuLog) -> Result<Self, DataError> {
        if log.is_empty() {
            return Err(DataError::NothingToScore {
                origin: "LogScenario::new".to_owned(),
                message: "the log is empty".to_owned(),
            });
        }
        let epochs = if log.magnetometer().is_some() {
            log.len()
        } else {
            0
        };
        Ok(Self { log, epochs })
    }

    /// The log.
    pub fn log(&self) -> &ImuLog {
        &self.log
    }

    /// The steps of the log, in order.
    pub fn steps(&self) -> LogSteps<'_> {
        LogSteps {
            log: &self.log,
            next: 0,
        }
    }
}

/// The steps of a [`LogScenario`].
#[derive(Clone, Debug)]
pub struct LogSteps<'s> {
    log: &'s ImuLog,
    next: usize,
}

impl Iterator for LogSteps<'_> {
    type Item = Step<Option<UnitQuaternion<f64>>, ImuSample, Vector3<f64>>;

    fn next(&mut self) -> Option<Self::Item> {
        let k = self.next;
        let log = self.log;
        let gyro = *log.gyroscope().get(k)?;
        self.next += 1;
        let counts = log.movement().is_none_or(|m| m[k]);
        let truth = log.reference().and_then(|r| r[k]).filter(|_| counts);
        Some(Step {
            time: k as f64 * log.interval(),
            input: ImuSample {
                gyro,
                acc: log.accelerometer()[k],
            },
            truth,
            measurement: log.magnetometer().map(|m| m[k]),
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.log.len() - self.next;
        (left, Some(left))
    }
}

impl Scenario for LogScenario {
    type Truth = Option<UnitQuaternion<f64>>;
    type Input = ImuSample;
    type Measurement = Vector3<f64>;
    type Steps<'s> = LogSteps<'s>;

    fn epochs(&self) -> usize {
        self.epochs
    }

    fn simulate<'s>(&'s self, _rng: &'s mut ChaCha8Rng) -> Result<LogSteps<'s>, ExperimentError> {
        Ok(self.steps())
    }
}
