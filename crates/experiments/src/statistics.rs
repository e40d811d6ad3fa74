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
///
/// Read from a file, the statistics are checked: no non-finite value in the sum (only finite
/// values are summed) nor in the sum of squares but the +∞ of a square that overflows, the count
/// and the non-finite count summing within u64, extremes present exactly when the count is
/// positive, finite, with min ≤ max, and the sums of no values zero.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "RunningStatsFields")]
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
        // The counts saturate (a count read from a file may be as large as u64 holds).
        if !x.is_finite() {
            self.non_finite = self.non_finite.saturating_add(1);
            return;
        }
        self.count = self.count.saturating_add(1);
        self.sum.add(x);
        self.sum_of_squares.add(x * x);
        self.min = Some(self.min.map_or(x, |m| m.min(x)));
        self.max = Some(self.max.map_or(x, |m| m.max(x)));
    }

    /// Adds the values of another stream (another shard of runs).
    pub fn merge(&mut self, other: &RunningStats) {
        self.count = self.count.saturating_add(other.count);
        self.non_finite = self.non_finite.saturating_add(other.non_finite);
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

    /// The mean `Σx / n`, `None` without finite values; finite, as the values are (a sum that
    /// overflows is divided at a scale of 2⁻⁶⁴).
    pub fn mean(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum.mean(self.count))
    }

    /// The mean square `Σx² / n` (for a root-mean-square error, take its square root), `None`
    /// without finite values; +∞ where the squares overflow (values beyond about 1e154).
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
        let mean = self.sum.mean(self.count);
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

/// The serialized form of [`RunningStats`], checked when converted.
#[derive(serde::Deserialize)]
#[serde(rename = "RunningStats", deny_unknown_fields)]
struct RunningStatsFields {
    count: u64,
    non_finite: u64,
    sum: ExactSum,
    sum_of_squares: ExactSum,
    min: Option<f64>,
    max: Option<f64>,
}

impl TryFrom<RunningStatsFields> for RunningStats {
    type Error = String;

    fn try_from(f: RunningStatsFields) -> Result<Self, String> {
        if f.sum.has_non_finite() {
            return Err(
                "statistics: sum is flagged NaN or infinite, but only finite values are summed"
                    .to_owned(),
            );
        }
        // A square overflows to +inf exactly when a value's magnitude is beyond √MAX ≈ 1.3e154.
        let largest = f.min.unwrap_or(0.0).abs().max(f.max.unwrap_or(0.0).abs());
        let square_overflows = (largest * largest).is_infinite();
        if f.sum_of_squares.has_non_finite()
            && !(f.sum_of_squares.value() == f64::INFINITY && square_overflows)
        {
            return Err(
                "statistics: sum_of_squares is flagged NaN or infinite, but it is +inf only \
                 where a value's square overflows (min or max beyond 1.3e154)"
                    .to_owned(),
            );
        }
        if f.count.checked_add(f.non_finite).is_none() {
            return Err(format!(
                "statistics: count {} plus non_finite {} overflows",
                f.count, f.non_finite
            ));
        }
        match (f.count, f.min, f.max) {
            (0, None, None) => {
                if f.sum != ExactSum::new() || f.sum_of_squares != ExactSum::new() {
                    return Err("statistics: count is 0 but the sums are not".to_owned());
                }
            }
            (1.., Some(min), Some(max)) => {
                if !(min.is_finite() && max.is_finite() && min <= max) {
                    return Err(format!(
                        "statistics: min {min} and max {max} must be finite with min <= max"
                    ));
                }
                if f.sum_of_squares.value() < 0.0 {
                    return Err("statistics: sum_of_squares is negative".to_owned());
                }
            }
            (count, min, max) => {
                return Err(format!(
                    "statistics: count {count} with min {min:?} and max {max:?} (extremes are \
                     present exactly when the count is positive)"
                ));
            }
        }
        Ok(Self {
            count: f.count,
            non_finite: f.non_finite,
            sum: f.sum,
            sum_of_squares: f.sum_of_squares,
            min: f.min,
            max: f.max,
        })
    }
}
