//! The BROAD evaluation as a library function: every method on every recorded log, scored by
//! [`AttitudeScorer`] over the samples that count, per log and pooled ([`evaluate`]). The binary's
//! table, the ablation example and the tests all come from it.

use super::estimate::{AttitudeEstimate, AttitudeScorer};
use super::method::Method;
use super::metric::TrialErrors;
use super::scenario::LogScenario;
use crate::error::FilterError;
use liebayes_experiments::record::rate;
use liebayes_experiments::{ExperimentError, Recorded, Recording, RunningStats, Scorer, record};
use nalgebra::UnitQuaternion;

/// A recorded log's run: the estimate after every sample, with its truth where it counts.
pub type LogRecording = Recording<Option<UnitQuaternion<f64>>, AttitudeEstimate>;

/// One method's scores over one log (or pooled over several): the statistics of each metric of
/// [`AttitudeScorer`] over the samples that count, and the filter's time.
#[derive(Clone, Debug, PartialEq)]
pub struct LogScore {
    /// One per metric of [`AttitudeScorer`], in its order.
    stats: Vec<RunningStats>,
    /// Samples filtered.
    pub samples: u64,
    /// Filter time (s).
    pub seconds: f64,
}

/// Each step of a recording with the method's estimate of it: the smoothed estimate of an offline
/// method (one that released them, [`Method::EkfOffline`]), the filter's own otherwise.
pub fn estimates(
    recording: &LogRecording,
) -> impl Iterator<
    Item = (
        &Recorded<Option<UnitQuaternion<f64>>, AttitudeEstimate>,
        &AttitudeEstimate,
    ),
> {
    let smoothed = !recording.smoothed.is_empty();
    recording.steps.iter().enumerate().map(move |(k, step)| {
        let estimate = if smoothed {
            recording.smoothed.get(k).unwrap_or(&step.estimate)
        } else {
            &step.estimate
        };
        (step, estimate)
    })
}

impl LogScore {
    /// The scores of a recording, of the method's estimates ([`estimates`]).
    pub fn of(recording: &LogRecording) -> Self {
        let metrics =
            Scorer::<Option<UnitQuaternion<f64>>, AttitudeEstimate>::metrics(&AttitudeScorer);
        let mut stats = vec![RunningStats::new(); metrics.len()];
        let mut values = vec![0.0; metrics.len()];
        for (step, estimate) in estimates(recording) {
            if step.truth.is_none() {
                continue;
            }
            AttitudeScorer.score(&step.truth, estimate, &mut values);
            for (s, v) in stats.iter_mut().zip(&values) {
                s.add(*v);
            }
        }
        Self {
            stats,
            samples: recording.len() as u64,
            seconds: recording.seconds,
        }
    }

    /// The statistics of metric `name` of [`AttitudeScorer`] over the scored samples.
    pub fn stats(&self, name: &str) -> Option<&RunningStats> {
        self.stats.get(AttitudeScorer::index(name)?)
    }

    /// BROAD's score: the RMSE (deg) of the total, heading and inclination errors over the scored
    /// samples; `None` when no sample was scored.
    pub fn errors(&self) -> Option<TrialErrors> {
        let rmse = |name| self.stats(name)?.mean_square().map(f64::sqrt);
        Some(TrialErrors {
            total: rmse("total_error")?,
            heading: rmse("heading_error")?,
            inclination: rmse("tilt_error")?,
            samples: usize::try_from(self.stats("total_error")?.count()).unwrap_or(usize::MAX),
        })
    }

    /// The mean NEES of the heading (χ²(1): a consistent filter's mean is 1), the tilt (χ²(2):
    /// mean 2) and the whole attitude error (χ²(3): mean 3) over the scored samples; `None` for a
    /// filter without a covariance.
    pub fn nees(&self) -> Option<[f64; 3]> {
        let mean = |name| self.stats(name)?.mean();
        Some([mean("heading_nees")?, mean("tilt_nees")?, mean("nees")?])
    }

    /// Samples per second of filter time: 0 without samples, `+∞` for a run too short to time
    /// (a time that is not positive; the fields are public).
    pub fn throughput(&self) -> f64 {
        rate(self.samples as f64, self.seconds)
    }

    /// Adds another log's scores (pooling: statistics merged exactly, samples and time summed).
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] when a statistic would hold more than `u64::MAX` values
    /// ([`RunningStats::merge`]); `self` is then unchanged.
    pub fn merge(&mut self, other: &LogScore) -> Result<(), ExperimentError> {
        let mut stats = self.stats.clone();
        for (s, o) in stats.iter_mut().zip(&other.stats) {
            s.merge(o)?;
        }
        self.stats = stats;
        self.samples = self.samples.saturating_add(other.samples);
        self.seconds += other.seconds;
        Ok(())
    }
}

/// Runs `method` over the log of `scenario` from its first sample (causally, one parameter set),
/// keeping every estimate.
///
/// # Errors
/// The method's settings ([`Method::build`]); [`FilterError::Step`] naming `name` and the sample
/// where a step failed.
pub fn run_log(
    name: &str,
    scenario: &LogScenario,
    method: &Method,
) -> Result<LogRecording, FilterError> {
    let mut filter = method.build(scenario.log().rate())?;
    record(&mut filter, scenario.steps()).map_err(|f| FilterError::step(name, f))
}

/// Every method on every log: `scores[trial][method]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// The logs' names, in order.
    pub trials: Vec<String>,
    /// The methods' labels, in order.
    pub methods: Vec<String>,
    /// `scores[i][j]`: method j on log i.
    pub scores: Vec<Vec<LogScore>>,
}

impl Evaluation {
    /// BROAD's mean over the logs of each log's RMSE (total, heading, inclination; deg) for method
    /// `j`, `None` when a log had no scored sample.
    pub fn mean_errors(&self, j: usize) -> Option<[f64; 3]> {
        let mut sums = [0.0; 3];
        for row in &self.scores {
            let e = row.get(j)?.errors()?;
            sums[0] += e.total;
            sums[1] += e.heading;
            sums[2] += e.inclination;
        }
        if self.scores.is_empty() {
            return None;
        }
        let n = self.scores.len() as f64;
        Some(sums.map(|s| s / n))
    }

    /// Leave-one-log-out cross-validation of a choice among the methods (settings of a filter,
    /// say): for each log, the method whose mean total RMSE over the *other* logs is lowest, and
    /// its score on the held-out log. `None` with fewer than two logs, no method, or a log with a
    /// missing score (a row of `scores` shorter or longer than `methods`, or a log without a scored
    /// sample), or scores too many to pool (more than `u64::MAX` values, [`LogScore::merge`]).
    pub fn leave_one_out(&self) -> Option<CrossValidation> {
        let logs = self.scores.len();
        let width = self.methods.len();
        if logs < 2 || width == 0 || self.scores.iter().any(|row| row.len() != width) {
            return None;
        }
        let mut totals = vec![vec![0.0; self.methods.len()]; logs];
        for (row, scores) in totals.iter_mut().zip(&self.scores) {
            for (t, score) in row.iter_mut().zip(scores) {
                *t = score.errors()?.total;
            }
        }
        let column: Vec<f64> = (0..self.methods.len())
            .map(|j| totals.iter().map(|row| row[j]).sum())
            .collect();
        let mut chosen = Vec::with_capacity(logs);
        let mut sums = [0.0; 3];
        let mut pooled: Option<LogScore> = None;
        for (row, scores) in totals.iter().zip(&self.scores) {
            let others = |j: usize| column[j] - row[j];
            let best = (0..self.methods.len()).min_by(|&a, &b| others(a).total_cmp(&others(b)))?;
            let score = &scores[best];
            let e = score.errors()?;
            for (sum, x) in sums.iter_mut().zip([e.total, e.heading, e.inclination]) {
                *sum += x / logs as f64;
            }
            match &mut pooled {
                Some(p) => p.merge(score).ok()?,
                None => pooled = Some(score.clone()),
            }
            chosen.push(best);
        }
        Some(CrossValidation {
            chosen,
            mean_errors: sums,
            pooled: pooled?,
        })
    }

    /// Method `j`'s scores pooled over every log (its pooled NEES and total throughput); `None`
    /// without logs, past the last method, or for scores too many to pool ([`LogScore::merge`]).
    pub fn pooled(&self, j: usize) -> Option<LogScore> {
        let mut rows = self.scores.iter();
        let mut pooled = rows.next()?.get(j)?.clone();
        for row in rows {
            pooled.merge(row.get(j)?).ok()?;
        }
        Some(pooled)
    }
}

/// The result of [`Evaluation::leave_one_out`].
#[derive(Clone, Debug, PartialEq)]
pub struct CrossValidation {
    /// For each log, the index of the method chosen on the other logs.
    pub chosen: Vec<usize>,
    /// BROAD's mean over the logs of each held-out RMSE (total, heading, inclination; deg): the
    /// cross-validated figure.
    pub mean_errors: [f64; 3],
    /// The held-out scores pooled over the logs (their NEES).
    pub pooled: LogScore,
}

/// Runs every method on every `(name, log)` ([`run_log`]), scores each run ([`LogScore`]) and
/// hands each recording to `inspect` (to write its estimates or plot it;
/// `|_, _, _| Ok::<_, FilterError>(())` to keep nothing), so that no run is held longer than its
/// scoring. `inspect`'s error type is the caller's: any that a [`FilterError`] converts into.
///
/// # Errors
/// The first run's or `inspect`'s error.
pub fn evaluate<E: From<FilterError>>(
    logs: &[(String, LogScenario)],
    methods: &[Method],
    inspect: &mut dyn FnMut(&str, &Method, &LogRecording) -> Result<(), E>,
) -> Result<Evaluation, E> {
    for method in methods {
        method.validate()?;
    }
    let mut scores = Vec::with_capacity(logs.len());
    for (name, scenario) in logs {
        let mut row = Vec::with_capacity(methods.len());
        for method in methods {
            let recording = run_log(name, scenario, method)?;
            row.push(LogScore::of(&recording));
            inspect(name, method, &recording)?;
        }
        scores.push(row);
    }
    Ok(Evaluation {
        trials: logs.iter().map(|(name, _)| name.clone()).collect(),
        methods: methods.iter().map(Method::label).collect(),
        scores,
    })
}
