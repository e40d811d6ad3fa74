//! # liebayes-experiments
//!
//! The experiment layer: what simulating, replaying, scoring and studying filters share, whatever
//! the application. It is being built; today it holds the statistics a study keeps:
//!
//! * [`ExactSum`]: the exact sum of f64 values, rounded once when read, so that partial sums of a
//!   study split into shards merge to the same bits as one run over all of it;
//! * [`RunningStats`]: count, exact sums of values and squares, extremes and the count of
//!   non-finite values of a stream, merged exactly: a metric's summary over any number of runs in
//!   constant memory;
//! * [`Shard`] and [`run_rng`]: shard K of N runs a contiguous range of run indices, and each run
//!   draws from its own random stream, so the shards' runs are exactly the full study's;
//! * [`Summary`]: per-epoch [`MetricSeries`] and per-run statistics by metric name, failures by
//!   reason, and the run ranges covered; summaries of disjoint ranges merge exactly (serde, so a
//!   shard's summary can be written to a file and merged elsewhere).
//!
//! Nothing here depends on a particular filter or state space.

mod error;
mod exact_sum;
mod shard;
mod statistics;
mod summary;

pub use error::ExperimentError;
pub use exact_sum::ExactSum;
pub use shard::{Shard, run_rng};
pub use statistics::RunningStats;
pub use summary::{MAX_EPOCHS, MAX_FAILURE_REASONS, MetricSeries, Summary};
