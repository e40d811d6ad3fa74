//! Scenarios, trajectories and the one replay loop: a scenario simulates a trajectory from a seeded
//! generator, and [`replay`] runs a filter through it, scoring each measurement epoch.

use crate::filter::RecursiveFilter;
use crate::score::Scorer;
use crate::{ExperimentError, MAX_EPOCHS};
use liebayes_operators::OperatorError;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

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

/// A simulated run: its steps in order.
pub type Trajectory<T, U, Z> = Vec<Step<T, U, Z>>;

/// The trajectory type of a scenario.
pub type TrajectoryOf<S> =
    Trajectory<<S as Scenario>::Truth, <S as Scenario>::Input, <S as Scenario>::Measurement>;

/// What an application simulates: trajectories of true states, inputs and measurements.
pub trait Scenario: Sync {
    /// The true state.
    type Truth;
    /// The process input.
    type Input;
    /// A measurement.
    type Measurement;

    /// The number of measurement epochs of every trajectory (the length of the per-epoch series).
    fn epochs(&self) -> usize;

    /// Simulates one run from `rng` (the run's own stream).
    ///
    /// # Errors
    /// When the scenario's settings cannot be simulated (the message says which).
    fn simulate(&self, rng: &mut ChaCha8Rng) -> Result<TrajectoryOf<Self>, ExperimentError>;
}

/// A run's scores: per measurement epoch, the scorer's metrics then the log evidence and the NIS
/// (NaN where the filter has none); and the filter's time.
#[derive(Clone, Debug, PartialEq)]
pub struct RunScores {
    /// The metric names, the scorer's followed by `log_evidence` and `nis`.
    pub names: Vec<&'static str>,
    /// `values[k * names.len() + j]`: metric j at measurement epoch k.
    pub values: Vec<f64>,
    /// The NIS degrees of freedom of the updates (0 where the filter reports none).
    pub nis_dof: usize,
    /// Filter time per step (s), scoring and simulation excluded.
    pub seconds_per_step: f64,
}

impl RunScores {
    /// The number of measurement epochs scored.
    pub fn epochs(&self) -> usize {
        self.values.len() / self.names.len().max(1)
    }

    /// Metric `name` at epoch k.
    pub fn get(&self, name: &str, k: usize) -> Option<f64> {
        let j = self.names.iter().position(|n| *n == name)?;
        self.values.get(k * self.names.len() + j).copied()
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

/// Runs `filter` through `trajectory`: at each step a predict with its input, then, where there is a
/// measurement, an update and the scores of the estimate against the truth. The scores are kept
/// only if every step succeeds; the first failure stops the run and is returned.
///
/// # Errors
/// [`RunFailure`] at the first step, update or estimate that fails.
pub fn replay<F, T, Sc>(
    filter: &mut F,
    trajectory: &[Step<T, F::Input, F::Measurement>],
    scorer: &Sc,
) -> Result<RunScores, RunFailure>
where
    F: RecursiveFilter,
    F::Input: Sized,
    F::Measurement: Sized,
    Sc: Scorer<T, F::Estimate> + ?Sized,
{
    let mut names: Vec<&'static str> = scorer.names().to_vec();
    names.extend(["log_evidence", "nis"]);
    let width = names.len();
    let epochs = trajectory
        .iter()
        .filter(|s| s.measurement.is_some())
        .count()
        .min(MAX_EPOCHS);
    let mut values = Vec::with_capacity(epochs * width);
    let mut nis_dof = 0;
    let mut filtering = std::time::Duration::ZERO;
    for (index, step) in trajectory.iter().enumerate() {
        let fail = |error| RunFailure {
            step: index,
            time: step.time,
            error,
        };
        let clock = Instant::now();
        filter.predict(&step.input).map_err(fail)?;
        let Some(z) = &step.measurement else {
            filtering += clock.elapsed();
            continue;
        };
        let update = filter.update(z).map_err(fail)?;
        filtering += clock.elapsed();
        if values.len() >= epochs * width {
            continue;
        }
        let estimate = filter.estimate().map_err(fail)?;
        let start = values.len();
        values.resize(start + width, f64::NAN);
        scorer.score(
            &step.truth,
            &estimate,
            &mut values[start..start + width - 2],
        );
        values[start + width - 2] = update.log_evidence;
        if let Some(nis) = update.nis {
            values[start + width - 1] = nis.value;
            nis_dof = nis.dof;
        }
    }
    Ok(RunScores {
        names,
        values,
        nis_dof,
        seconds_per_step: filtering.as_secs_f64() / trajectory.len().max(1) as f64,
    })
}
