//! The summary of a study: per-epoch statistics of named metrics over runs, the per-run values of
//! the metrics that ask for them, the failures by reason, and the run ranges it covers. Summaries of disjoint run ranges merge exactly, so shards of a
//! study run on different machines combine to the summary of one run over all of them, bit for bit.

use crate::file_value::file_values;
use crate::replay::RunScores;
use crate::run_values::{MAX_KEPT_RUNS, RunValues, run_value};
use crate::score::Reduction;
use crate::study::MAX_STUDY_EPOCHS;
use crate::{ExperimentError, RunningStats};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::ops::Range;

/// The most epochs a replay scores (it scores the first this many epochs of a run and filters on
/// after them), and the most a recording keeps. A summary holds fewer: at most
/// [`MAX_STUDY_EPOCHS`] = 2¹⁴ per series and trace, so a scenario whose settings are valid up to
/// this limit (a replay's, a recording's) is refused by a study beyond 2¹⁴ epochs, before any run
/// ([`Study::run`](crate::Study::run)).
pub const MAX_EPOCHS: usize = 1 << 24;

/// The most distinct failure reasons kept: the first in byte order (alphabetically, for ASCII), the
/// others counted under one entry, "other reasons". Which reasons are kept depends only on the set
/// of reasons, not on the order the runs failed in or the summaries were merged in, so a study
/// sharded or run in parallel gives the same summary, bit for bit.
pub const MAX_FAILURE_REASONS: usize = 64;

/// The most metrics a summary holds (a study scores a dozen or so). A run, a merge or a file that
/// would take a summary beyond it is refused: a crafted shard of 10 000 metrics made a merge take
/// minutes, and its trace, epochs by metrics, could ask for gigabytes.
pub const MAX_METRICS: usize = 256;

/// Where failures beyond [`MAX_FAILURE_REASONS`] distinct reasons are counted.
const OTHER_REASONS: &str = "other reasons";

/// The statistics over runs of one metric at each epoch: at most [`MAX_STUDY_EPOCHS`] = 2¹⁴
/// epochs, however it is built. Read from a file (on its own or in a summary), a series of more
/// epochs is refused at the first epoch beyond the limit, before the rest is read.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricSeries {
    #[serde(deserialize_with = "read_epochs")]
    epochs: Vec<RunningStats>,
}

/// A series' epochs as a file holds them: at most [`MAX_STUDY_EPOCHS`].
fn read_epochs<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<RunningStats>, D::Error> {
    crate::bounded::vec(
        d,
        MAX_STUDY_EPOCHS,
        "a metric series' epochs (MAX_STUDY_EPOCHS = 2^14 = 16384 at most)",
    )
}

/// A trace's values as a file holds them: at most [`MAX_STUDY_EPOCHS`] × [`MAX_METRICS`].
fn read_trace_values<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    let values: Vec<crate::file_value::FileValue> = crate::bounded::vec(
        d,
        MAX_STUDY_EPOCHS * MAX_METRICS,
        "a trace's values (2^14 epochs of MAX_METRICS = 256 metrics at most)",
    )?;
    Ok(values.into_iter().map(|v| v.0).collect())
}

/// A summary's metrics as a file holds them: at most [`MAX_METRICS`].
fn read_metrics<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<SummaryMetric>, D::Error> {
    crate::bounded::vec(
        d,
        MAX_METRICS,
        "a summary's metrics (MAX_METRICS = 256 at most)",
    )
}

/// A trace's epoch times as a file holds them: at most [`MAX_STUDY_EPOCHS`].
fn read_times<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    crate::bounded::vec(
        d,
        MAX_STUDY_EPOCHS,
        "a trace's times (MAX_STUDY_EPOCHS = 2^14 = 16384 epochs at most)",
    )
}

impl MetricSeries {
    /// Adds one run's value at epoch k: an epoch already held, or the next one. A run's epochs
    /// are added in order, so the series holds exactly the epochs added, and its memory is
    /// proportional to them.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] for k beyond the next epoch (k greater than the number of
    /// epochs held), or at or beyond [`MAX_STUDY_EPOCHS`] (each epoch's statistics take about
    /// 2 KB); nothing is added then.
    pub fn add(&mut self, k: usize, value: f64) -> Result<(), ExperimentError> {
        let next = self.epochs.len();
        if k > next || k >= MAX_STUDY_EPOCHS {
            return Err(ExperimentError::OutOfRange {
                what: "epoch index",
                value: k.to_string(),
                range: "[0, epochs held] and below 2^14 (epochs are added in order)",
            });
        }
        if k == next {
            self.epochs.push(RunningStats::new());
        }
        self.epochs[k].add(value);
        Ok(())
    }

    /// Adds the runs of another series, epoch by epoch as [`RunningStats::merge`].
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] when an epoch's merged statistics would hold more than
    /// `u64::MAX` values (two series of a [`Summary`] of disjoint runs never do, their counts being
    /// bounded by their runs); `self` is then unchanged.
    pub fn merge(&mut self, other: &MetricSeries) -> Result<(), ExperimentError> {
        let mut merged = self.epochs.clone();
        if merged.len() < other.epochs.len() {
            merged.resize_with(other.epochs.len(), RunningStats::new);
        }
        for (a, b) in merged.iter_mut().zip(&other.epochs) {
            a.merge(b)?;
        }
        self.epochs = merged;
        Ok(())
    }

    /// The statistics at each epoch.
    pub fn epochs(&self) -> &[RunningStats] {
        &self.epochs
    }

    /// All epochs pooled: the statistics of every value of every run.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] when the epochs hold more than `u64::MAX` values in all
    /// ([`RunningStats::merge`]), which only a series read from a file can reach.
    pub fn pooled(&self) -> Result<RunningStats, ExperimentError> {
        let mut all = RunningStats::new();
        for e in &self.epochs {
            all.merge(e)?;
        }
        Ok(all)
    }
}

/// A metric of a summary: its name, how it is summarised over runs, its unit, its statistics at
/// each epoch and, for a metric recorded [`per_run`](crate::Metric::per_run), each run's value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SummaryMetric {
    /// The metric's name.
    pub name: String,
    /// How it is summarised over runs.
    pub reduction: Reduction,
    /// Its unit.
    pub unit: String,
    /// Its statistics over runs at each epoch.
    pub series: MetricSeries,
    /// Each run's value (the runs with index below [`MAX_KEPT_RUNS`]) for a metric recorded per
    /// run; `None` for a metric that is not.
    pub per_run: Option<RunValues>,
}

/// One run's scores kept whole (the study's first run, for plots of a single run): the epoch times
/// and, per epoch, the value of every metric in the summary's order. Two traces are equal when
/// their numbers are equal bit for bit (so a NaN, a value the estimate did not have, equals itself).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Trace {
    /// The run's index.
    pub run: u64,
    /// The time of each epoch (s): at most [`MAX_STUDY_EPOCHS`] (a file holding more is refused
    /// at the first beyond).
    #[serde(deserialize_with = "read_times")]
    pub times: Vec<f64>,
    /// `values[k * metrics + j]`: metric j of the summary at epoch k (NaN where it has none;
    /// in a file `null`, and the infinities `"inf"` and `"-inf"`). A file holding more than
    /// [`MAX_STUDY_EPOCHS`] × [`MAX_METRICS`] is refused at the first value beyond.
    #[serde(
        serialize_with = "file_values::serialize",
        deserialize_with = "read_trace_values"
    )]
    pub values: Vec<f64>,
}

/// Values laid out `epochs` by `from_width` (`values[k * from_width + j]`) moved to a layout
/// `epochs` by `width`: column `from` to column `to` for each pair of `moves`, NaN (a value not
/// recorded) in every other column. How a trace is built from a run's scores, and kept one value per
/// epoch and metric, under the right names, when metrics are added or another trace is merged in.
fn columns_moved(
    values: &[f64],
    epochs: usize,
    from_width: usize,
    moves: &[(usize, usize)],
    width: usize,
) -> Vec<f64> {
    let mut moved = vec![f64::NAN; epochs * width];
    for k in 0..epochs {
        for &(from, to) in moves {
            moved[k * width + to] = values[k * from_width + from];
        }
    }
    moved
}

impl PartialEq for Trace {
    fn eq(&self, other: &Self) -> bool {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        self.run == other.run
            && bits(&self.times) == bits(&other.times)
            && bits(&self.values) == bits(&other.values)
    }
}

/// Which study a summary belongs to: summaries merge only when these agree.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyLabel {
    /// The filter and scenario, as the application names them (`"exact, circle"`).
    pub name: String,
    /// The study's seed.
    pub seed: u64,
    /// The study's number of runs (all shards).
    pub runs: u64,
}

/// The summary of a study over some run ranges: per-epoch statistics of every metric (in the
/// scorer's order) and of the epoch times, each run's value of the metrics recorded per run, the
/// failed runs counted by reason, the first run's scores, and the filter's time per step.
///
/// Everything but the timing is determined by the study's seed and runs: two summaries of the same
/// runs are equal bit for bit, however they were sharded. The timing is measured, so it differs
/// from one execution to the next; it is kept apart for that reason.
///
/// Read from a file, a summary is checked whole, so that what merges and what is reported can be
/// trusted: run ranges sorted, disjoint and inside the study; metric names distinct; at every epoch
/// no more values than runs covered; counts that agree across fields (no more times at an epoch
/// than successful runs, no more values of a metric there than times); per-run values of covered
/// runs only; a trace of run 0 with each epoch once, in increasing time; each [`RunningStats`]
/// consistent. The error names the field at fault.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "SummaryFields")]
pub struct Summary {
    label: StudyLabel,
    /// Disjoint, sorted, with adjacent ranges joined.
    runs: Vec<Range<u64>>,
    metrics: Vec<SummaryMetric>,
    times: MetricSeries,
    failures: BTreeMap<String, u64>,
    trace: Option<Trace>,
    timing: RunningStats,
}

/// The serialized form of [`Summary`], checked when converted.
#[derive(Deserialize)]
#[serde(rename = "Summary", deny_unknown_fields)]
struct SummaryFields {
    label: StudyLabel,
    runs: Vec<Range<u64>>,
    #[serde(deserialize_with = "read_metrics")]
    metrics: Vec<SummaryMetric>,
    times: MetricSeries,
    #[serde(deserialize_with = "read_failures")]
    failures: BTreeMap<String, u64>,
    trace: Option<Trace>,
    timing: RunningStats,
}

/// A summary's failures as a file holds them: at most [`MAX_FAILURE_REASONS`] reasons and "other
/// reasons" (refused at the first beyond, before the rest takes memory).
fn read_failures<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<BTreeMap<String, u64>, D::Error> {
    crate::bounded::map(
        d,
        MAX_FAILURE_REASONS + 1,
        "failures (MAX_FAILURE_REASONS = 64 reasons and \"other reasons\" at most)",
    )
}

impl TryFrom<SummaryFields> for Summary {
    type Error = String;

    fn try_from(f: SummaryFields) -> Result<Self, String> {
        let summary = Self {
            label: f.label,
            runs: f.runs,
            metrics: f.metrics,
            times: f.times,
            failures: f.failures,
            trace: f.trace,
            timing: f.timing,
        };
        summary.check()?;
        Ok(summary)
    }
}

/// The shape of one run's scores: one value per epoch and metric, distinct metric names, finite
/// and strictly increasing epoch times (what a summary's trace must hold).
fn check_scores(run: u64, scores: &RunScores) -> Result<(), ExperimentError> {
    let (epochs, width) = (scores.epochs(), scores.metrics.len());
    if epochs.checked_mul(width) != Some(scores.values.len()) {
        return Err(ExperimentError::Incompatible(format!(
            "run {run}: the scores hold {} values, not one per epoch ({epochs}) and metric ({width})",
            scores.values.len()
        )));
    }
    let mut names = HashSet::with_capacity(width);
    if let Some(m) = scores.metrics.iter().find(|m| !names.insert(m.name)) {
        return Err(ExperimentError::Incompatible(format!(
            "run {run}: metric {:?} appears twice in the scores",
            m.name
        )));
    }
    if scores.times.iter().any(|t| !t.is_finite()) || scores.times.windows(2).any(|w| w[0] >= w[1])
    {
        return Err(ExperimentError::Incompatible(format!(
            "run {run}: epoch times must be finite and strictly increasing"
        )));
    }
    Ok(())
}

impl Summary {
    /// Checks what every summary built by [`add_run`](Self::add_run), [`add_failure`](Self::add_failure)
    /// and [`merge`](Self::merge) satisfies, so that a summary read from a file can be trusted:
    /// - run ranges non-empty, sorted, disjoint and not adjacent (joined), inside `0..label.runs`;
    /// - metric names distinct; at most [`MAX_STUDY_EPOCHS`] epochs per series;
    /// - at every epoch of every series, and for the timing together with the failures, no more
    ///   values (finite and not) than runs covered; at most [`MAX_FAILURE_REASONS`] reasons besides
    ///   "other reasons";
    /// - per-run values only for covered runs;
    /// - counts that agree across fields ([`check_counts`](Self::check_counts)): times finite, no
    ///   more at an epoch than at the one before nor, at the first, than successful runs (timed);
    ///   no more epochs in a metric's series than in the times, no more values of a metric at an
    ///   epoch than times there, no more per-run values than successful runs;
    /// - a trace of run 0, covered, with finite, strictly increasing epoch times (each epoch once),
    ///   no more epochs than the times, and one value per epoch and metric.
    ///
    /// (Each [`RunningStats`] is checked on its own when read.)
    ///
    /// # Errors
    /// A message naming the field at fault and what it holds.
    fn check(&self) -> Result<(), String> {
        let mut end = 0;
        for (i, r) in self.runs.iter().enumerate() {
            if r.start >= r.end || (i > 0 && r.start <= end) || r.end > self.label.runs {
                return Err(format!(
                    "runs: range {}..{} is empty, unsorted, overlapping or adjacent to the one \
                     before, or outside the study's 0..{}",
                    r.start, r.end, self.label.runs
                ));
            }
            end = r.end;
        }
        let runs = self.run_count();
        let within = |what: &str, stats: &RunningStats, others: u64| {
            let values = stats.count().checked_add(stats.non_finite());
            match values.and_then(|v| v.checked_add(others)) {
                Some(v) if v <= runs => Ok(()),
                _ => Err(format!(
                    "{what}: count {} and non_finite {} (with {others} failed runs) exceed the \
                     {runs} runs covered",
                    stats.count(),
                    stats.non_finite()
                )),
            }
        };
        let series = |what: &str, s: &MetricSeries| {
            if s.epochs.len() > MAX_STUDY_EPOCHS {
                return Err(format!(
                    "{what}: {} epochs, more than {MAX_STUDY_EPOCHS}",
                    s.epochs.len()
                ));
            }
            s.epochs
                .iter()
                .enumerate()
                .try_for_each(|(k, e)| within(&format!("{what}, epoch {k}"), e, 0))
        };
        if self.metrics.len() > MAX_METRICS {
            return Err(format!(
                "metrics: {}, more than MAX_METRICS = {MAX_METRICS}",
                self.metrics.len()
            ));
        }
        let mut names = HashSet::with_capacity(self.metrics.len());
        for m in &self.metrics {
            if !names.insert(m.name.as_str()) {
                return Err(format!("metrics: {:?} appears twice", m.name));
            }
            series(&format!("metric {:?}", m.name), &m.series)?;
            let stray = m
                .per_run
                .as_ref()
                .and_then(|values| values.values().iter().find(|v| !self.covers(v.0)));
            if let Some((run, _)) = stray {
                return Err(format!(
                    "metric {:?}, per_run: run {run} is not among the runs covered",
                    m.name
                ));
            }
        }
        series("times", &self.times)?;
        let reasons = self.failures.len() - usize::from(self.failures.contains_key(OTHER_REASONS));
        if reasons > MAX_FAILURE_REASONS {
            return Err(format!(
                "failures: {reasons} reasons besides \"{OTHER_REASONS}\", more than the \
                 {MAX_FAILURE_REASONS} kept"
            ));
        }
        let failed = self
            .failures
            .values()
            .try_fold(0_u64, |total, &n| total.checked_add(n))
            .filter(|&n| n <= runs)
            .ok_or_else(|| format!("failures: more failed runs than the {runs} runs covered"))?;
        within("timing", &self.timing, failed)?;
        self.check_counts()?;
        if let Some(trace) = &self.trace {
            self.check_trace(trace)?;
        }
        Ok(())
    }

    /// The part of [`check`](Self::check) that relates the counts of different fields, as every
    /// summary built by recording runs has them: a successful run is timed once and adds its time
    /// at each of its epochs (from the first) and at most one value per metric there, a failed run
    /// adds nothing but its reason. So the times are finite, their counts do not increase with the
    /// epoch and the first is at most the runs timed; each metric has no more epochs than the
    /// times, no more values at an epoch than times there, and no more per-run values than runs
    /// timed. (The timing and the failures together are bounded by the runs covered, checked
    /// before.)
    fn check_counts(&self) -> Result<(), String> {
        // Checked before: the timing's counts and the failures sum within u64.
        let timed = self.timing.count() + self.timing.non_finite();
        let times = &self.times.epochs;
        let mut before = timed;
        for (k, t) in times.iter().enumerate() {
            if t.non_finite() > 0 {
                return Err(format!(
                    "times, epoch {k}: non_finite is {}, but epoch times are finite",
                    t.non_finite()
                ));
            }
            if t.count() > before {
                return Err(if k == 0 {
                    format!(
                        "times, epoch 0: count {} is more than the {timed} successful runs \
                         (timing: count plus non_finite; a failed run has no times)",
                        t.count()
                    )
                } else {
                    format!(
                        "times, epoch {k}: count {} is more than the {before} of epoch {} (a \
                         run has its epochs from the first)",
                        t.count(),
                        k - 1
                    )
                });
            }
            before = t.count();
        }
        for m in &self.metrics {
            let epochs = &m.series.epochs;
            if epochs.len() > times.len() {
                return Err(format!(
                    "metric {:?}: its series has {} epochs, more than the {} of times",
                    m.name,
                    epochs.len(),
                    times.len()
                ));
            }
            for (k, (e, t)) in epochs.iter().zip(times).enumerate() {
                // Each within the runs covered, checked before: the sum fits u64.
                if e.count() + e.non_finite() > t.count() {
                    return Err(format!(
                        "metric {:?}, epoch {k}: count {} and non_finite {} are more values \
                         than the {} runs that times holds at that epoch",
                        m.name,
                        e.count(),
                        e.non_finite(),
                        t.count()
                    ));
                }
            }
            if let Some(values) = &m.per_run {
                if values.values().len() as u64 > timed {
                    return Err(format!(
                        "metric {:?}, per_run: {} run values, more than the {timed} successful \
                         runs (timing: count plus non_finite)",
                        m.name,
                        values.values().len()
                    ));
                }
            }
        }
        if let Some(trace) = &self.trace {
            if trace.times.len() > times.len() {
                return Err(format!(
                    "trace: {} epochs, more than the {} of times",
                    trace.times.len(),
                    times.len()
                ));
            }
        }
        Ok(())
    }

    /// The trace's part of [`check`](Self::check).
    fn check_trace(&self, trace: &Trace) -> Result<(), String> {
        if trace.run != 0 || !self.covers(0) {
            return Err(format!(
                "trace: run {} is not run 0 of the runs covered",
                trace.run
            ));
        }
        if trace.times.len() > MAX_STUDY_EPOCHS {
            return Err(format!(
                "trace: {} epochs, more than {MAX_STUDY_EPOCHS}",
                trace.times.len()
            ));
        }
        if trace.times.iter().any(|t| !t.is_finite())
            || trace.times.windows(2).any(|w| w[0] >= w[1])
        {
            return Err(
                "trace: epoch times must be finite and strictly increasing (each epoch once)"
                    .to_owned(),
            );
        }
        if trace.times.len().checked_mul(self.metrics.len()) != Some(trace.values.len()) {
            return Err(format!(
                "trace: {} values for {} epochs of {} metrics",
                trace.values.len(),
                trace.times.len(),
                self.metrics.len()
            ));
        }
        Ok(())
    }

    /// The empty summary of the runs `runs` of the study `label` (nothing recorded yet); an empty
    /// range covers no run.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] for a non-empty range that is not inside the study's runs
    /// `0..label.runs` (a summary of it would be refused by its reader).
    pub fn new(label: StudyLabel, runs: Range<u64>) -> Result<Self, ExperimentError> {
        if !runs.is_empty() && runs.end > label.runs {
            return Err(ExperimentError::OutOfRange {
                what: "run range of the summary",
                value: format!("{}..{} (of {} runs)", runs.start, runs.end, label.runs),
                range: "inside the study's runs 0..label.runs",
            });
        }
        Ok(Self {
            label,
            runs: if runs.is_empty() {
                Vec::new()
            } else {
                vec![runs]
            },
            ..Self::default()
        })
    }

    /// Whether run `run` is covered: a binary search of the sorted, disjoint run ranges.
    fn covers(&self, run: u64) -> bool {
        let i = self.runs.partition_point(|r| r.end <= run);
        self.runs.get(i).is_some_and(|r| r.contains(&run))
    }

    /// The study this summary belongs to.
    pub fn label(&self) -> &StudyLabel {
        &self.label
    }

    /// The run ranges covered, disjoint and sorted.
    pub fn runs(&self) -> &[Range<u64>] {
        &self.runs
    }

    /// The number of runs covered.
    pub fn run_count(&self) -> u64 {
        self.runs.iter().map(|r| r.end - r.start).sum()
    }

    /// Records one run's scores: per epoch its time and the value of every metric (a NIS column
    /// of a filter that reports none, degrees of freedom 0, is left out); for a metric recorded
    /// [`per_run`](crate::Metric::per_run), and a run index below [`MAX_KEPT_RUNS`], the run's value
    /// (its root mean square or mean over the run's finite values, see [`RunValues`]). The first
    /// run of the study (run 0) is also kept whole as the [`trace`](Self::trace).
    ///
    /// A metric first recorded by a later run than run 0 has NaN (not recorded) in the trace.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] for more than [`MAX_STUDY_EPOCHS`] epochs (each epoch's
    /// statistics take about 2 KB per metric) or a run outside the summary's run ranges,
    /// [`ExperimentError::Incompatible`] when the scores are malformed (not
    /// one value per epoch and metric, a metric name twice, epoch times that are not finite and
    /// strictly increasing), when the summary already holds as many runs as it covers, when a
    /// metric's summary rule, unit or per-run flag differs from the one already recorded under its
    /// name, or when the run's per-run values are already recorded. Nothing is recorded then.
    pub fn add_run(&mut self, run: u64, scores: &RunScores) -> Result<(), ExperimentError> {
        let epochs = scores.epochs();
        if epochs > MAX_STUDY_EPOCHS {
            return Err(ExperimentError::OutOfRange {
                what: "number of epochs",
                value: epochs.to_string(),
                range: "[0, 2^14]",
            });
        }
        if !self.covers(run) {
            return Err(ExperimentError::OutOfRange {
                what: "run index",
                value: run.to_string(),
                range: "the summary's run ranges",
            });
        }
        check_scores(run, scores)?;
        self.check_room(&format!("run {run}"))?;
        let kept: Vec<usize> = (0..scores.metrics.len())
            .filter(|&j| scores.metrics[j].reduction != Reduction::ChiSquare { dof: 0 })
            .collect();
        let slots = self.slots(kept.iter().map(|&j| {
            let m = &scores.metrics[j];
            (m.name, m.reduction, m.unit, m.per_run)
        }))?;
        for (&j, slot) in kept.iter().zip(&slots) {
            let m = &scores.metrics[j];
            let recorded = slot
                .and_then(|i| self.metrics[i].per_run.as_ref())
                .is_some_and(|values| values.contains(run));
            if recorded {
                return Err(ExperimentError::Incompatible(format!(
                    "run {run} of metric {} is already recorded",
                    m.name
                )));
            }
        }
        // Checked: nothing below can fail, so the run is recorded whole or not at all.
        let before = self.metrics.len();
        let mut columns = Vec::with_capacity(scores.metrics.len());
        for (j, slot) in kept.into_iter().zip(slots) {
            let m = &scores.metrics[j];
            let index = slot.unwrap_or_else(|| {
                self.metrics.push(SummaryMetric {
                    name: m.name.to_owned(),
                    reduction: m.reduction,
                    unit: m.unit.to_owned(),
                    series: MetricSeries::default(),
                    per_run: m.per_run.then(RunValues::new),
                });
                self.metrics.len() - 1
            });
            columns.push((j, index));
        }
        let width = scores.metrics.len();
        for &(j, index) in &columns {
            let column = (0..epochs).map(|k| scores.values[k * width + j]);
            let metric = &mut self.metrics[index];
            for (k, x) in column.clone().enumerate() {
                metric.series.add(k, x)?;
            }
            if let Some(values) = &mut metric.per_run {
                if run < MAX_KEPT_RUNS {
                    values.insert(run, run_value(metric.reduction, column));
                }
            }
        }
        for (k, &t) in scores.times.iter().enumerate() {
            self.times.add(k, t)?;
        }
        self.widen_trace(before);
        if run == 0 {
            self.trace = Some(Trace {
                run,
                times: scores.times.clone(),
                values: columns_moved(&scores.values, epochs, width, &columns, self.metrics.len()),
            });
        }
        self.timing.add(scores.seconds_per_step);
        Ok(())
    }

    /// Keeps the trace one value per epoch and metric after metrics were added behind the first
    /// `before`: NaN (not recorded) under the new ones.
    fn widen_trace(&mut self, before: usize) {
        let width = self.metrics.len();
        if width == before {
            return;
        }
        if let Some(trace) = &mut self.trace {
            let kept: Vec<(usize, usize)> = (0..before).map(|j| (j, j)).collect();
            trace.values = columns_moved(&trace.values, trace.times.len(), before, &kept, width);
        }
    }

    /// Refuses one more run (`what`, for the message) when the summary already holds a run, a
    /// successful one (timed) or a failure, for every run it covers: the rule its reader checks.
    fn check_room(&self, what: &str) -> Result<(), ExperimentError> {
        let recorded = self
            .timing
            .count()
            .saturating_add(self.timing.non_finite())
            .saturating_add(self.failure_count());
        if recorded >= self.run_count() {
            return Err(ExperimentError::Incompatible(format!(
                "{what}: the summary already holds {recorded} runs, all the {} it covers",
                self.run_count()
            )));
        }
        Ok(())
    }

    /// The index of metric `name`, if recorded.
    fn find(&self, name: &str) -> Option<usize> {
        self.metrics.iter().position(|m| m.name == name)
    }

    /// Where each of `metrics` (name, rule, unit, per-run flag) is recorded (`None`: not yet),
    /// checking that its rule, unit and per-run flag agree with the recorded ones and that the new
    /// ones fit within [`MAX_METRICS`]. The names are looked up in a hash of those held, so the
    /// work is linear in both lists.
    fn slots<'m>(
        &self,
        metrics: impl Iterator<Item = (&'m str, Reduction, &'m str, bool)>,
    ) -> Result<Vec<Option<usize>>, ExperimentError> {
        let held: HashMap<&str, usize> = self
            .metrics
            .iter()
            .enumerate()
            .map(|(i, m)| (m.name.as_str(), i))
            .collect();
        let slots = metrics
            .map(|(name, reduction, unit, per_run)| {
                let Some(&index) = held.get(name) else {
                    return Ok(None);
                };
                let m = &self.metrics[index];
                if m.reduction != reduction || m.unit != unit {
                    return Err(ExperimentError::Incompatible(format!(
                        "metric {name} is summarised as {:?} in {} here and as {reduction:?} in \
                         {unit} there",
                        m.reduction, m.unit
                    )));
                }
                if m.per_run.is_some() != per_run {
                    let kept = |yes: bool| if yes { "kept" } else { "not kept" };
                    return Err(ExperimentError::Incompatible(format!(
                        "metric {name} has its per-run values {} here and {} there",
                        kept(m.per_run.is_some()),
                        kept(per_run)
                    )));
                }
                Ok(Some(index))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let added = slots.iter().filter(|slot| slot.is_none()).count();
        if self.metrics.len() + added > MAX_METRICS {
            return Err(ExperimentError::OutOfRange {
                what: "number of metrics of a summary",
                value: (self.metrics.len() + added).to_string(),
                range: "at most MAX_METRICS = 256",
            });
        }
        Ok(slots)
    }

    /// Records a failed run and why (the error's message); beyond [`MAX_FAILURE_REASONS`] distinct
    /// reasons, only the first in byte order are kept and the others counted under "other
    /// reasons" (see [`MAX_FAILURE_REASONS`]).
    ///
    /// # Errors
    /// [`ExperimentError::Incompatible`] when the summary already holds a run (successful or
    /// failed) for every run it covers, as [`add_run`](Self::add_run); nothing is recorded then.
    pub fn add_failure(&mut self, reason: &str) -> Result<(), ExperimentError> {
        self.check_room("a failed run")?;
        self.count_failures(reason, 1);
        Ok(())
    }

    /// Adds `count` failures under `reason`, saturating (the counts of a summary its reader
    /// accepts are bounded by its runs), then keeps the first [`MAX_FAILURE_REASONS`] reasons in
    /// byte order and counts the failures of the others under "other reasons". A reason among the
    /// first of all a study's reasons is among the first of every part that holds it, so it is
    /// never folded: the result does not depend on the order of the failures or of the merges.
    fn count_failures(&mut self, reason: &str, count: u64) {
        let total = self.failures.entry(reason.to_owned()).or_default();
        *total = total.saturating_add(count);
        loop {
            let reasons =
                self.failures.len() - usize::from(self.failures.contains_key(OTHER_REASONS));
            if reasons <= MAX_FAILURE_REASONS {
                return;
            }
            let Some(last) = self
                .failures
                .keys()
                .rev()
                .find(|k| *k != OTHER_REASONS)
                .cloned()
            else {
                return;
            };
            let folded = self.failures.remove(&last).unwrap_or_default();
            let other = self.failures.entry(OTHER_REASONS.to_owned()).or_default();
            *other = other.saturating_add(folded);
        }
    }

    /// The metrics, in the order the scorer gave them.
    pub fn metrics(&self) -> &[SummaryMetric] {
        &self.metrics
    }

    /// The per-epoch series of a metric.
    pub fn series(&self, metric: &str) -> Option<&MetricSeries> {
        self.find(metric).map(|i| &self.metrics[i].series)
    }

    /// Each run's value of a metric recorded [`per_run`](crate::Metric::per_run) (`None` for a metric
    /// not recorded, or not per run).
    pub fn run_values(&self, metric: &str) -> Option<&RunValues> {
        self.find(metric)
            .and_then(|i| self.metrics[i].per_run.as_ref())
    }

    /// The epoch times (their statistics over runs: equal in every run for a fixed schedule).
    pub fn times(&self) -> &MetricSeries {
        &self.times
    }

    /// The first run's scores (run 0 of the study), if this summary covers it and it succeeded.
    pub fn trace(&self) -> Option<&Trace> {
        self.trace.as_ref()
    }

    /// The filter time per step (s) over the successful runs: measured, so not reproducible.
    pub fn timing(&self) -> &RunningStats {
        &self.timing
    }

    /// Failed runs by reason.
    pub fn failures(&self) -> &BTreeMap<String, u64> {
        &self.failures
    }

    /// The number of failed runs (saturating at `u64::MAX`, which no summary its reader accepts
    /// reaches).
    pub fn failure_count(&self) -> u64 {
        self.failures
            .values()
            .fold(0, |total, &n| total.saturating_add(n))
    }

    /// Adds the summary of other runs of the same study; the result is the same in any order of
    /// merging. An empty summary (`Summary::default()`) takes the label of the first one merged.
    /// Metrics are matched by name: the trace, this summary's or the other's, is laid out in this
    /// summary's metric order, with NaN (not recorded) under a metric the run 0 did not have.
    ///
    /// # Errors
    /// [`ExperimentError::Incompatible`] when the two belong to different studies (label, seed or
    /// run count), cover a run in common (the same shard merged twice), or summarise a metric
    /// differently (its rule, unit or per-run flag); [`ExperimentError::OutOfRange`] when a
    /// statistic would hold more than `u64::MAX` values; `self` is then unchanged.
    pub fn merge(&mut self, other: &Summary) -> Result<(), ExperimentError> {
        let blank = |s: &Summary| s.runs.is_empty() && s.label == StudyLabel::default();
        if self.label != other.label && !blank(self) && !blank(other) {
            return Err(ExperimentError::Incompatible(format!(
                "they are of different studies ({:?} and {:?})",
                self.label, other.label
            )));
        }
        let label = if blank(self) {
            other.label.clone()
        } else {
            self.label.clone()
        };
        let mut runs: Vec<Range<u64>> = self.runs.iter().chain(&other.runs).cloned().collect();
        runs.sort_by_key(|r| r.start);
        let mut joined: Vec<Range<u64>> = Vec::with_capacity(runs.len());
        for r in runs {
            match joined.last_mut() {
                Some(last) if r.start < last.end => {
                    return Err(ExperimentError::Incompatible(format!(
                        "runs {}..{} are in both (was a shard merged twice?)",
                        r.start,
                        r.end.min(last.end)
                    )));
                }
                Some(last) if r.start == last.end => last.end = r.end,
                _ => joined.push(r),
            }
        }
        // The per-run values united and the statistics merged first (a run in both, or more than
        // u64::MAX values at an epoch, is refused), so that nothing below fails.
        let slots = self.slots(other.metrics.iter().map(|m| {
            (
                m.name.as_str(),
                m.reduction,
                m.unit.as_str(),
                m.per_run.is_some(),
            )
        }))?;
        let mut united = Vec::new();
        for (m, &slot) in other.metrics.iter().zip(&slots) {
            if let (Some(i), Some(theirs)) = (slot, &m.per_run) {
                if let Some(ours) = &self.metrics[i].per_run {
                    united.push((i, ours.united(theirs)?));
                }
            }
        }
        let mut series = Vec::new();
        for (m, &slot) in other.metrics.iter().zip(&slots) {
            if let Some(i) = slot {
                let mut merged = self.metrics[i].series.clone();
                merged.merge(&m.series)?;
                series.push((i, merged));
            }
        }
        let mut times = self.times.clone();
        times.merge(&other.times)?;
        let mut timing = self.timing.clone();
        timing.merge(&other.timing)?;
        self.label = label;
        self.runs = joined;
        for (i, values) in united {
            self.metrics[i].per_run = Some(values);
        }
        for (i, merged) in series {
            self.metrics[i].series = merged;
        }
        let before = self.metrics.len();
        // Where each of the other's metrics lands here, for its trace.
        let mut columns = Vec::with_capacity(other.metrics.len());
        for ((j, m), slot) in other.metrics.iter().enumerate().zip(slots) {
            let i = if let Some(i) = slot {
                i
            } else {
                self.metrics.push(m.clone());
                self.metrics.len() - 1
            };
            columns.push((j, i));
        }
        self.times = times;
        for (reason, &count) in &other.failures {
            self.count_failures(reason, count);
        }
        self.widen_trace(before);
        if let (None, Some(theirs)) = (&self.trace, &other.trace) {
            let epochs = theirs.times.len();
            self.trace = Some(Trace {
                run: theirs.run,
                times: theirs.times.clone(),
                values: columns_moved(
                    &theirs.values,
                    epochs,
                    other.metrics.len(),
                    &columns,
                    self.metrics.len(),
                ),
            });
        }
        self.timing = timing;
        Ok(())
    }
}
