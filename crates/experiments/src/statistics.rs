//! Running statistics that merge exactly: what a study keeps per metric instead of every run's values,
//! so its memory does not grow with the number of runs and its shards combine bit for bit.

use crate::ExactSum;

/// The count, exact sum and exact sum of squares of a stream of values, with their extremes and the
/// number of non-finite values (kept apart, so that one diverged run is reported, not averaged in).
///
/// Merging is exact and commutative: statistics of shards merged in any order equal the statistics
/// of the whole stream, bit for bit. The mean `Σx / n` and the variance
/// `(Σx² − (Σx)²/n) / (n − 1)` are computed from the exact sums, each rounded once, then combined in
/// f64: the variance keeps a relative accuracy of about `ε · mean² / variance`, which loses digits
/// only for values whose spread is below 1e-8 of their size.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunningStats {
    count: u64,
    non_finite: u64,
    sum: ExactSum,
    sum_of_squares: ExactSum,
    min: Option<f64>,
    max: Option<f64>,
}

impl RunningStats {
    /// No values yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one value; a NaN or infinite value is only counted, in
    /// [`non_finite`](Self::non_finite).
    pub fn add(&mut self, x: f64) {
        if !x.is_finite() {
            self.non_finite += 1;
            return;
        }
        self.count += 1;
        self.sum.add(x);
        self.sum_of_squares.add(x * x);
        self.min = Some(self.min.map_or(x, |m| m.min(x)));
        self.max = Some(self.max.map_or(x, |m| m.max(x)));
    }

    /// Adds the values of another stream (another shard of runs).
    pub fn merge(&mut self, other: &RunningStats) {
        self.count += other.count;
        self.non_finite += other.non_finite;
        self.sum.merge(&other.sum);
        self.sum_of_squares.merge(&other.sum_of_squares);
        self.min = match (self.min, other.min) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        self.max = match (self.max, other.max) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
    }

    /// The number of finite values n.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The number of NaN or infinite values, left out of every other statistic.
    pub fn non_finite(&self) -> u64 {
        self.non_finite
    }

    /// `Σx` over the finite values, rounded once (±∞ if it overflows).
    pub fn sum(&self) -> f64 {
        self.sum.value()
    }

    /// The mean `Σx / n`, `None` without finite values.
    pub fn mean(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum.value() / self.count as f64)
    }

    /// The mean square `Σx² / n` (for a root-mean-square error, take its square root), `None`
    /// without finite values.
    pub fn mean_square(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum_of_squares.value() / self.count as f64)
    }

    /// The sample variance `(Σx² − n x̄²) / (n − 1)`, clamped at 0 against rounding (+∞ where the
    /// squares overflow, for values beyond about 1e154); `None` for fewer than two finite values.
    pub fn variance(&self) -> Option<f64> {
        if self.count < 2 {
            return None;
        }
        let n = self.count as f64;
        let mean = self.sum.value() / self.count as f64;
        let mean_square = self.sum_of_squares.value() / self.count as f64;
        if mean_square.is_infinite() {
            return Some(f64::INFINITY);
        }
        Some(((mean_square - mean * mean) * (n / (n - 1.0))).max(0.0))
    }

    /// The smallest finite value.
    pub fn min(&self) -> Option<f64> {
        self.min
    }

    /// The largest finite value.
    pub fn max(&self) -> Option<f64> {
        self.max
    }
}
