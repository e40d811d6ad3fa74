//! # liebayes-experiments
//!
//! The experiment layer: what simulating, replaying, scoring and studying filters share, whatever
//! the application. It is being built; today it holds the statistics a study keeps:
//!
//! * [`ExactSum`]: the exact sum of f64 values, rounded once when read, so that partial sums of a
//!   study split into shards merge to the same bits as one run over all of it;
//! * [`RunningStats`]: count, exact sums of values and squares, extremes and the count of
//!   non-finite values of a stream, merged exactly: a metric's summary over any number of runs in
//!   constant memory.
//!
//! Nothing here depends on a particular filter or state space.

mod exact_sum;
mod statistics;

pub use exact_sum::ExactSum;
pub use statistics::RunningStats;
