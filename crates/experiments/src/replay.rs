//! Scenarios, trajectories and the one replay loop: a scenario simulates a trajectory from a seeded
//! generator, and [`replay`] runs a filter through it, scoring each measurement epoch.

use crate::filter::RecursiveFilter;
use crate::score::{Metric, Reduction, Scorer};
use crate::smoothing::{Pending, Releases, smoothed_name};
use crate::{ExperimentError, MAX_EPOCHS};
use liebayes_operators::OperatorError;
use rand_chacha::ChaCha8Rng;
use std::time::{Duration, Instant};

/// The steps a replay draws from the scenario before running the filter through them: the
/// simulation is kept out of the filter's time without holding the whole run.
const REPLAY_CHUNK: usize = 256;

/// One step of a trajectory: the input that drives the process from the previous step, the true
/// state after it, and the measurement taken then, if one was.
#[derive(Clone, Debug, PartialEq)]
pub struct Step<T, U, Z> {
    /// Time (s) at the end of the step.
    pub time: f64,
    /// The process input over the step.
    pub input: U,
    /// The true state at `time`.
    pub truth: T,
    /// The measurement at `time`, if any.
    pub measurement: Option<Z>,
}

/// A simulated run recorded: its steps in order (a [`Scenario`] may also stream its steps).
pub type Trajectory<T, U, Z> = Vec<Step<T, U, Z>>;

/// The step type of a scenario.
pub type StepOf<S> =
    Step<<S as Scenario>::Truth, <S as Scenario>::Input, <S as Scenario>::Measurement>;

/// What an application simulates: trajectories of true states, inputs and measurements, streamed
/// step by step from the run's generator (so that a run of 10⁸ steps takes no memory).
pub trait Scenario: Sync {
    /// The true state.
    type Truth;
    /// The process input.
    type Input;
    /// A measurement.
    type Measurement;
    /// The steps of one run, in order.
    type Steps<'s>: Iterator<Item = StepOf<Self>>
    where
        Self: 's;

    /// The number of measurement epochs of every trajectory (the length of the per-epoch series),
    /// at most [`MAX_EPOCHS`].
    fn epochs(&self) -> usize;

    /// Starts one run, drawing from `rng` (the run's simulation stream).
    ///
    /// # Errors
    /// When the scenario's settings cannot be simulated (the message says which).
    fn simulate<'s>(&'s self, rng: &'s mut ChaCha8Rng) -> Result<Self::Steps<'s>, ExperimentError>;
}

/// A run's scores: per measurement epoch, its time, the scorer's metrics then the log evidence and
/// the NIS (NaN where the filter has none), then, for a smoother, the scorer's metrics of the
/// epoch's smoothed estimate under the names `smoothed_<metric>`; and the filter's time.
#[derive(Clone, Debug, PartialEq)]
pub struct RunScores {
    /// The metrics, the scorer's followed by `log_evidence` and `nis` (χ² with the
    /// measurement's dimension; dimension 0 when the filter reports no NIS), and for a smoother
    /// the scorer's again, prefixed `smoothed_`.
    pub metrics: Vec<Metric>,
    /// The time of each scored epoch (s).
    pub times: Vec<f64>,
    /// `values[k * metrics.len() + j]`: metric j at measurement epoch k.
    pub values: Vec<f64>,
    /// Filter time per step (s), scoring and simulation excluded.
    pub seconds_per_step: f64,
}

impl RunScores {
    /// The number of measurement epochs scored.
    pub fn epochs(&self) -> usize {
        self.times.len()
    }

    /// Metric `name` at epoch k (`None` for an unknown name or an epoch not scored).
    pub fn get(&self, name: &str, k: usize) -> Option<f64> {
        let j = self.metrics.iter().position(|m| m.name == name)?;
        if k >= self.epochs() {
            return None;
        }
        let index = k.checked_mul(self.metrics.len())?.checked_add(j)?;
        self.values.get(index).copied()
    }
}

/// Why a run stopped: the step, its time and the filter's error.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("step {step} (t = {time} s): {error}")]
pub struct RunFailure {
    /// The index of the step that failed.
    pub step: usize,
    /// Its time (s).
    pub time: f64,
    /// The filter's error.
    pub error: OperatorError,
}

/// Runs `filter` through the steps of a trajectory: at each step a predict with its input, then,
/// where there is a measurement, an update and the scores of the estimate against the truth. The
/// first [`MAX_EPOCHS`] epochs are scored (the filter runs on after them). The scores are kept only
/// if every step succeeds; the first failure stops the run and is returned.
///
/// A smoother (a filter with [`RecursiveFilter::smoothing`], such as
/// [`Smoothed`](crate::Smoothed)) is run the same way, and asked after every step, and once after
/// the last, for the smoothed estimates it has made final: each measurement epoch's is scored
/// against the epoch's truth by the same scorer, in the columns `smoothed_<metric>` (the truths
/// of the epochs waiting for theirs are held until then). The smoothing counts as filter time.
///
/// # Errors
/// [`RunFailure`] at the first step, update or estimate that fails.
///
/// # Example
/// ```
/// use liebayes_experiments::{Metric, Recursive, Reduction, Scorer, Step, replay};
/// use liebayes_operators::densities::Gaussian;
/// use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
/// use nalgebra::{Matrix1, Vector1};
///
/// /// The estimate's error, scored at each measurement epoch.
/// struct Error;
/// impl Scorer<f64, Gaussian<1>> for Error {
///     fn metrics(&self) -> Vec<Metric> {
///         vec![Metric::new("error", Reduction::RootMeanSquare, "")]
///     }
///     fn score(&self, truth: &f64, estimate: &Gaussian<1>, values: &mut [f64]) {
///         values[0] = estimate.mean()[0] - truth;
///     }
/// }
///
/// let process = LinearProcess::new(Matrix1::new(1.0), Matrix1::new(1.0)).unwrap();
/// let sensor = LinearMeasurement::new(Matrix1::new(1.0), Matrix1::new(1.0)).unwrap();
/// let prior = Gaussian::new(Vector1::new(0.0), Matrix1::new(1.0)).unwrap();
/// let mut filter = Recursive::new(prior, process, sensor);
/// let step = |time, z: Option<f64>| Step { time, input: Vector1::zeros(), truth: 0.0, measurement: z.map(Vector1::new) };
/// let steps = vec![step(1.0, Some(3.0)), step(2.0, None), step(3.0, Some(-1.0))];
/// let scores = replay(&mut filter, steps, &Error).unwrap();
/// // Two measurement epochs, each with the error, the log evidence and the NIS.
/// assert_eq!(scores.times, vec![1.0, 3.0]);
/// assert_eq!(scores.metrics.len(), 3);
/// // First epoch: predicted variance 2, gain 2/3, estimate 2.
/// assert!((scores.values[0] - 2.0).abs() < 1e-12);
/// ```
pub fn replay<F, T, Sc>(
    filter: &mut F,
    steps: impl IntoIterator<Item = Step<T, F::Input, F::Measurement>>,
    scorer: &Sc,
) -> Result<RunScores, RunFailure>
where
    F: RecursiveFilter,
    F::Input: Sized,
    F::Measurement: Sized,
    Sc: Scorer<T, F::Estimate> + ?Sized,
{
    let mut metrics = scorer.metrics();
    let scored = metrics.len();
    metrics.extend([
        Metric::new("log_evidence", Reduction::Mean, ""),
        Metric::new("nis", Reduction::ChiSquare { dof: 0 }, ""),
    ]);
    // A smoother's smoothed estimates are scored in the columns after these, when released.
    let smoothed_at = metrics.len();
    if filter.smoothing().is_some() {
        let names = metrics[..scored].iter().map(|m| Metric {
            name: smoothed_name(m.name),
            ..*m
        });
        metrics.extend(names.collect::<Vec<_>>());
    }
    let width = metrics.len();
    let smooths = width > smoothed_at;
    let (mut times, mut values) = (Vec::new(), Vec::new());
    let mut pending = Pending::new(width, smoothed_at);
    let mut releases = Releases::new();
    // The steps are drawn (simulated) a chunk at a time, untimed; the clock runs over the
    // filter's pass through each chunk, and the estimates and their scoring (not part of a filter
    // step, and only at measurement epochs) are timed apart and subtracted. So neither the
    // simulation nor a clock read per step is counted as the filter's time.
    let mut steps = steps.into_iter();
    let mut chunk = Vec::with_capacity(REPLAY_CHUNK);
    let (mut filtering, mut scoring) = (Duration::ZERO, Duration::ZERO);
    let mut count = 0usize;
    let mut last_time = f64::NAN;
    loop {
        chunk.clear();
        chunk.extend(steps.by_ref().take(REPLAY_CHUNK));
        if chunk.is_empty() {
            break;
        }
        let start = Instant::now();
        for step in chunk.drain(..) {
            let index = count;
            count += 1;
            last_time = step.time;
            let fail = |error| RunFailure {
                step: index,
                time: step.time,
                error,
            };
            filter.predict(&step.input).map_err(fail)?;
            if let Some(z) = &step.measurement {
                let update = filter.update(z).map_err(fail)?;
                if times.len() < MAX_EPOCHS {
                    let clock = Instant::now();
                    let estimate = filter.estimate().map_err(fail)?;
                    let at = values.len();
                    values.resize(at + width, f64::NAN);
                    scorer.score(&step.truth, &estimate, &mut values[at..at + scored]);
                    values[at + scored] = update.log_evidence;
                    if let Some(nis) = update.nis {
                        values[at + scored + 1] = nis.value;
                        metrics[scored + 1].reduction = Reduction::ChiSquare { dof: nis.dof };
                    }
                    if smooths {
                        pending.push(index, times.len(), step.truth);
                    }
                    times.push(step.time);
                    scoring += clock.elapsed();
                }
            }
            if smooths {
                releases
                    .poll(filter, false, |i, e| {
                        pending.score(scorer, &mut values, i, &e);
                    })
                    .map_err(fail)?;
            }
        }
        filtering += start.elapsed();
    }
    if smooths {
        let start = Instant::now();
        releases
            .poll(filter, true, |i, e| {
                pending.score(scorer, &mut values, i, &e);
            })
            .map_err(|error| RunFailure {
                step: count.saturating_sub(1),
                time: last_time,
                error,
            })?;
        filtering += start.elapsed();
    }
    let filtering = filtering.saturating_sub(scoring);
    Ok(RunScores {
        metrics,
        times,
        values,
        seconds_per_step: filtering.as_secs_f64() / count.max(1) as f64,
    })
}
