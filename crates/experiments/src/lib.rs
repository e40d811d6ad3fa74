//! # liebayes-experiments
//!
//! The experiment layer: what simulating, replaying, scoring and studying filters share, whatever
//! the application. An application adds its scenario, its filters and, where the state's manifold
//! is not enough, its scoring; the layer does the rest.
//!
//! * [`RecursiveFilter`]: the one interface a study drives (predict with an input, update with a
//!   measurement returning its log evidence and NIS, an estimate with its uncertainty).
//!   [`Recursive`] gives it to any density that steps through the operators' `Propagate` and
//!   `Condition` (the Kalman filters on a manifold, the linear Kalman filter).
//! * [`Smoothed`]: a smoother (the operators' RTS and fixed-lag smoothers) as a
//!   `RecursiveFilter` whose forward pass is scored like any filter's and whose [`Smoothing`]
//!   releases each step's smoothed estimate, scored by the same scorer under the names
//!   `smoothed_<metric>` into the same run scores and summary ([`smoothing`]).
//! * [`Method`]: one filter a study compares: its label, its settings checked before any run,
//!   and the filter of each run built from the run's filter stream; [`Study::run_method`] runs it.
//! * [`Paired`]: two filters on the same data, to compare an approximation with a reference at
//!   every epoch.
//! * [`Scenario`] simulates a [`Trajectory`] of [`Step`]s from a run's generator; [`replay()`] is the
//!   one loop that runs a filter through it and scores each measurement epoch, stopping at the first
//!   failure with where and why; [`record()`] is the same loop keeping every step's estimate (a
//!   recorded log scored whole, a run plotted or written out).
//! * [`Scorer`]: named metrics of an estimate against the truth; [`ManifoldScorer`] scores a
//!   Gaussian on any manifold through `local` (squared error, NEES).
//! * [`Study`]: runs of a scenario and a filter, each from its own stream [`run_rngs`], over one
//!   [`Shard`] of the runs, in parallel with the `rayon` feature, into a [`Summary`] (per-epoch
//!   [`MetricSeries`], per-run statistics, failures by reason, timing) that merges exactly: shards
//!   run on different machines combine to one study's figures, bit for bit.
//! * [`Table`]: the rows one report compares, checked, merged exactly from shards, with the runs
//!   it misses, its columns, each metric's [`Figure`] by its [`Reduction`], and the run-by-run
//!   [`RunComparison`] of its rows: what a renderer shows, computed here.
//! * [`RunValues`]: each run's value of a metric marked [`Metric::per_run`] (its RMSE over the run,
//!   say), kept for the first [`MAX_KEPT_RUNS`] runs, with their [`quantiles`] and their
//!   [`relative_differences`] from a reference filter's values on the same runs.
//! * [`search::smallest_passing`]: the smallest size (a particle count) at which a filter meets a
//!   target, by doubling then bisection, in a bounded number of studies.
//! * [`ExactSum`] and [`RunningStats`]: the exact, mergeable statistics beneath, in constant memory
//!   whatever the number of runs.
//! * `testing` (feature `proptest`): the filter law suite, `filter_laws!`, which any
//!   `RecursiveFilter` runs in one line: steps all or nothing on extreme inputs, NEES and NIS in
//!   two-sided χ² bands, a mis-specified measurement noise caught.

//!
//! # Input contract
//!
//! A study's settings are checked before any run: at most [`MAX_RUNS`] = 2⁴⁰ runs, at most
//! [`MAX_STUDY_EPOCHS`] epochs, a shard `K/N` with 1 ≤ K ≤ N; a metric series and a summary's trace
//! hold at most [`MAX_STUDY_EPOCHS`] = 2¹⁴ epochs, added in order, so their memory is that of the
//! epochs added, and a run with more measurement epochs than its scenario declares is refused. A
//! scenario's settings may be valid up to [`MAX_EPOCHS`] = 2²⁴ epochs (what a replay scores and a
//! recording keeps); a study refuses more than 2¹⁴ before any run, naming both. A filter's failed
//! step ends its run with a [`RunFailure`] (where and why), counted by reason, and a non-finite
//! metric value is counted apart, never averaged into a figure; means and root mean squares of
//! finite values are finite however large the values (an overflowing sum is scaled). Statistics
//! hold at most `u64::MAX` values: [`RunningStats::merge`] refuses a merge beyond, never
//! saturating a count, and [`ExactSum::merge`] refuses a total of 2¹¹⁰² or more in magnitude.
//! [`Summary::new`] refuses runs outside its study, and [`Summary::add_run`] checks a run's scores before recording
//! any of them (one value per epoch and metric, distinct metric names, finite increasing times, a
//! run inside the summary's ranges, no more runs or failures than it covers), so what it builds is
//! what its reader accepts. A [`Summary`] or a [`Table`] read from a file is checked whole before
//! it is used (sums finite and bounded by the extremes, counts consistent, within each statistic
//! and across fields: no more values of a metric at an epoch than times there, no more times than
//! successful runs; min ≤ max, run ranges sorted and disjoint; a table with at least one row, each
//! of a study of at least one run, see [`Table::validate`]), and refused with the field that is
//! wrong; a sequence longer than its field allows (a series' epochs, a trace's times, an exact
//! sum's limbs, per-run values) is refused at its first element beyond, before the rest takes
//! memory, and a [`MetricSeries`] is checked so when read on its own too. Failure reasons beyond
//! [`MAX_FAILURE_REASONS`] are folded canonically (the first in byte order kept), so merges in any
//! order agree bit for bit. A value is written as a number, `null` (NaN) or `"inf"`/`"-inf"`, so
//! that it reads back bit for bit. The recorder keeps at most [`MAX_EPOCHS`] steps.
#![cfg_attr(docsrs, feature(doc_cfg))]

mod bounded;
mod error;
mod exact_sum;
mod file_value;
pub mod filter;
mod method;
mod paired;
pub mod record;
pub mod replay;
mod run_values;
pub mod score;
pub mod search;
mod shard;
pub mod smoothing;
mod statistics;
pub mod study;
mod summary;
pub mod table;
#[cfg(feature = "proptest")]
#[cfg_attr(docsrs, doc(cfg(feature = "proptest")))]
pub mod testing;

pub use error::ExperimentError;
pub use exact_sum::ExactSum;
pub use filter::{AsIs, Estimator, Nis, Recursive, RecursiveFilter, StepReport, Update};
pub use method::Method;
pub use paired::{Paired, PairedEstimate};
pub use record::{Recorded, Recording, record};
pub use replay::{RunFailure, RunScores, Scenario, Step, StepOf, Trajectory, replay};
pub use run_values::{MAX_KEPT_RUNS, RunValues, quantiles, relative_differences};
pub use score::{Figure, ManifoldScorer, Metric, Reduction, Scorer};
pub use shard::{Shard, run_rngs};
pub use smoothing::{Smoothed, Smoother, Smoothing};
pub use statistics::RunningStats;
pub use study::{MAX_RUNS, MAX_STUDY_EPOCHS, Study};
pub use summary::{
    MAX_EPOCHS, MAX_FAILURE_REASONS, MAX_METRICS, MetricSeries, StudyLabel, Summary, SummaryMetric,
    Trace,
};
pub use table::{Column, FigureKind, MissingRuns, RunComparison, Table};
