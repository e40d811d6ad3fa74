//! The summary of a study: per-epoch statistics of named metrics over runs, the failures by reason,
//! and the run ranges it covers. Summaries of disjoint run ranges merge exactly, so shards of a
//! study run on different machines combine to the summary of one run over all of them, bit for bit.

use crate::{ExperimentError, RunningStats};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::ops::Range;

/// The most epochs a metric series holds: a study's length is checked against it before anything
/// is allocated.
pub const MAX_EPOCHS: usize = 1 << 24;

/// The most distinct failure reasons kept; further reasons are counted under one entry.
pub const MAX_FAILURE_REASONS: usize = 64;

/// Where failures beyond [`MAX_FAILURE_REASONS`] distinct reasons are counted.
const OTHER_REASONS: &str = "other reasons";

/// The statistics over runs of one metric at each epoch.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricSeries {
    epochs: Vec<RunningStats>,
}

impl MetricSeries {
    /// Adds one run's value at epoch k.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] for k at or beyond [`MAX_EPOCHS`].
    pub fn add(&mut self, k: usize, value: f64) -> Result<(), ExperimentError> {
        if k >= MAX_EPOCHS {
            return Err(ExperimentError::OutOfRange {
                what: "epoch index",
                value: k.to_string(),
                range: "[0, 2^24)",
            });
        }
        if self.epochs.len() <= k {
            self.epochs.resize_with(k + 1, RunningStats::new);
        }
        self.epochs[k].add(value);
        Ok(())
    }

    /// Adds the runs of another series.
    pub fn merge(&mut self, other: &MetricSeries) {
        if self.epochs.len() < other.epochs.len() {
            self.epochs
                .resize_with(other.epochs.len(), RunningStats::new);
        }
        for (a, b) in self.epochs.iter_mut().zip(&other.epochs) {
            a.merge(b);
        }
    }

    /// The statistics at each epoch.
    pub fn epochs(&self) -> &[RunningStats] {
        &self.epochs
    }

    /// All epochs pooled: the statistics of every value of every run.
    pub fn pooled(&self) -> RunningStats {
        let mut all = RunningStats::new();
        for e in &self.epochs {
            all.merge(e);
        }
        all
    }
}

/// The summary of a study over some run ranges: per-epoch series and per-run scalars (a final error,
/// a time per step) by metric name, and the failed runs counted by reason.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Summary {
    /// Disjoint, sorted, with adjacent ranges joined.
    runs: Vec<Range<u64>>,
    series: BTreeMap<String, MetricSeries>,
    scalars: BTreeMap<String, RunningStats>,
    failures: BTreeMap<String, u64>,
}

impl Summary {
    /// The empty summary of the runs `runs` (nothing recorded yet).
    pub fn new(runs: Range<u64>) -> Self {
        Self {
            runs: if runs.is_empty() {
                Vec::new()
            } else {
                vec![runs]
            },
            ..Self::default()
        }
    }

    /// The run ranges covered, disjoint and sorted.
    pub fn runs(&self) -> &[Range<u64>] {
        &self.runs
    }

    /// The number of runs covered.
    pub fn run_count(&self) -> u64 {
        self.runs.iter().map(|r| r.end - r.start).sum()
    }

    /// Records a run's value of a per-epoch metric.
    ///
    /// # Errors
    /// As [`MetricSeries::add`].
    pub fn add_epoch(&mut self, metric: &str, k: usize, value: f64) -> Result<(), ExperimentError> {
        self.series
            .entry(metric.to_owned())
            .or_default()
            .add(k, value)
    }

    /// Records a run's value of a per-run metric.
    pub fn add_scalar(&mut self, metric: &str, value: f64) {
        self.scalars
            .entry(metric.to_owned())
            .or_default()
            .add(value);
    }

    /// Records a failed run and why (the error's message); beyond [`MAX_FAILURE_REASONS`] distinct
    /// reasons, under "other reasons".
    pub fn add_failure(&mut self, reason: &str) {
        self.count_failures(reason, 1);
    }

    fn count_failures(&mut self, reason: &str, count: u64) {
        let key = if self.failures.contains_key(reason) || self.failures.len() < MAX_FAILURE_REASONS
        {
            reason
        } else {
            OTHER_REASONS
        };
        *self.failures.entry(key.to_owned()).or_default() += count;
    }

    /// The per-epoch series of a metric.
    pub fn series(&self, metric: &str) -> Option<&MetricSeries> {
        self.series.get(metric)
    }

    /// Every per-epoch series, by name.
    pub fn all_series(&self) -> &BTreeMap<String, MetricSeries> {
        &self.series
    }

    /// The per-run statistics of a metric.
    pub fn scalar(&self, metric: &str) -> Option<&RunningStats> {
        self.scalars.get(metric)
    }

    /// Every per-run metric, by name.
    pub fn scalars(&self) -> &BTreeMap<String, RunningStats> {
        &self.scalars
    }

    /// Failed runs by reason.
    pub fn failures(&self) -> &BTreeMap<String, u64> {
        &self.failures
    }

    /// Adds the summary of other runs; the result is the same in any order of merging.
    ///
    /// # Errors
    /// [`ExperimentError::Incompatible`] when the two cover a run in common (the same shard merged
    /// twice); `self` is then unchanged.
    pub fn merge(&mut self, other: &Summary) -> Result<(), ExperimentError> {
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
        self.runs = joined;
        for (name, series) in &other.series {
            self.series.entry(name.clone()).or_default().merge(series);
        }
        for (name, stats) in &other.scalars {
            self.scalars.entry(name.clone()).or_default().merge(stats);
        }
        for (reason, &count) in &other.failures {
            self.count_failures(reason, count);
        }
        Ok(())
    }
}
