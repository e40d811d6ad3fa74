//! Running statistics that merge exactly: what a study keeps per metric instead of every run's values,
//! so its memory does not grow with the number of runs and its shards combine bit for bit.

use crate::{ExactSum, ExperimentError};

/// The count, exact sum and exact sum of squares of a stream of values, with their extremes and the
/// number of non-finite values (kept apart, so that one diverged run is reported, not averaged in).
///
/// The squares of values beyond 2⁵¹¹ ≈ 6.7e153 (whose squares f64 cannot hold past 1.3e154) are
/// summed apart, scaled exactly by 2⁻¹⁰²⁴, so that the root mean square is finite for every finite
/// value up to `f64::MAX`.
///
/// Merging is exact and commutative: statistics of shards merged in any order equal the statistics
/// of the whole stream, bit for bit. A stream holds at most `u64::MAX` values, finite and not: a
/// merge beyond is refused ([`merge`](Self::merge)), never saturated. The mean `Σx / n` and
/// the variance `(Σx² − (Σx)²/n) / (n − 1)` are computed from the exact sums, each rounded once,
/// then combined in f64: the variance keeps a relative accuracy of about `ε · mean² / variance`,
/// which loses digits only for values whose spread is below 1e-8 of their size.
///
/// Read from a file, the statistics are checked: no non-finite value in the sums (only finite
/// values, and squares that f64 holds, are summed), the count and the non-finite count summing
/// within u64, extremes present exactly when the count is positive, finite, with min ≤ max, sums of
/// squares non-negative, the large squares' sum zero unless an extreme lies beyond 2⁵¹¹, the
/// sums of no values zero, and the sums bounded by the extremes as every stream's are: the mean
/// within [min, max] and the root mean square at most the largest magnitude, both up to a relative
/// rounding of 4ε (and the root mean square up to the rounding of squares below f64's normal
/// range, of values under 2⁻⁵¹¹: `√(largest² + 2⁻¹⁰⁷⁴)`). (A file without the large squares'
/// sum, from an earlier version, reads it as zero.)
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "RunningStatsFields")]
pub struct RunningStats {
    count: u64,
    non_finite: u64,
    sum: ExactSum,
    /// `Σ x²` over the values of magnitude up to [`LARGE`].
    sum_of_squares: ExactSum,
    /// `Σ (x 2⁻⁵¹²)²` over the values beyond [`LARGE`].
    sum_of_large_squares: ExactSum,
    min: Option<f64>,
    max: Option<f64>,
}

/// Values of magnitude above 2⁵¹¹ have their squares summed scaled by 2⁻¹⁰²⁴ (at most
/// `MAX² 2⁻¹⁰²⁴ < MAX`); the squares of the others are at most 2¹⁰²² and exact where f64's are.
const LARGE: f64 = 6.703_903_964_971_299e153;

/// 2⁻⁵¹², by which the large values are scaled before they are squared.
const HALF_SCALE: f64 = 7.458_340_731_200_207e-155;

/// 2⁵¹², which undoes [`HALF_SCALE`]; a scaled square is multiplied back by it twice (2¹⁰²⁴ is
/// not an f64), overflowing to +∞ exactly when the square exceeds f64's range.
const UNSCALE: f64 = 1.340_780_792_994_259_7e154;

/// The relative rounding allowed when a file's mean and root mean square are checked against its
/// extremes (each is rounded once or twice from the exact sums).
const BOUND_SLACK: f64 = 4.0 * f64::EPSILON;

/// 2⁻⁵³⁷, the square root of 2⁻¹⁰⁷⁴: the rounding of a square below f64's normal range, as a root
/// mean square to add (in quadrature) to the largest magnitude when a file's sums are checked.
const SUBNORMAL_SQUARE_ROUNDING: f64 = 2.222_758_749_485_077_5e-162;

/// The smaller of two finite values in f64's total order, where −0 < +0: `f64::min` may return
/// either zero, so the minimum of a stream holding both would depend on the order of its values
/// and a merge of shards would not be exact.
fn least(a: f64, b: f64) -> f64 {
    if b.total_cmp(&a).is_lt() { b } else { a }
}

/// The larger of two finite values in f64's total order, where −0 < +0 (see [`least`]).
fn greatest(a: f64, b: f64) -> f64 {
    if b.total_cmp(&a).is_gt() { b } else { a }
}

impl RunningStats {
    /// No values yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one value; a NaN or infinite value is only counted, in
    /// [`non_finite`](Self::non_finite).
    ///
    /// A stream holds at most `u64::MAX` values, finite and not (what its reader accepts): to
    /// statistics already holding that many (only statistics read from a file can), the value is
    /// not added, so that the count stays that of the values summed and the mean stays within
    /// [min, max].
    pub fn add(&mut self, x: f64) {
        let room = self
            .count
            .checked_add(self.non_finite)
            .is_some_and(|n| n < u64::MAX);
        if !room {
            return;
        }
        if !x.is_finite() {
            self.non_finite += 1;
            return;
        }
        self.count += 1;
        self.sum.add(x);
        if x.abs() > LARGE {
            let scaled = x * HALF_SCALE;
            self.sum_of_large_squares.add(scaled * scaled);
        } else {
            self.sum_of_squares.add(x * x);
        }
        self.min = Some(self.min.map_or(x, |m| least(m, x)));
        self.max = Some(self.max.map_or(x, |m| greatest(m, x)));
    }

    /// Adds the values of another stream (another shard of runs), exactly: merging in any order
    /// gives the same statistics, bit for bit.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] when the merged stream would hold more than `u64::MAX`
    /// values, finite and not (the counts would overflow, and a saturated count would make the
    /// mean wrong or infinite); `self` is then unchanged.
    pub fn merge(&mut self, other: &RunningStats) -> Result<(), ExperimentError> {
        let values = |s: &RunningStats| u128::from(s.count) + u128::from(s.non_finite);
        let total = values(self) + values(other);
        if total > u128::from(u64::MAX) {
            return Err(ExperimentError::OutOfRange {
                what: "number of values (count plus non_finite) of merged statistics",
                value: total.to_string(),
                range: "[0, 2^64 - 1] (merge fewer streams)",
            });
        }
        let mut sum = self.sum.clone();
        sum.merge(&other.sum)?;
        let mut sum_of_squares = self.sum_of_squares.clone();
        sum_of_squares.merge(&other.sum_of_squares)?;
        let mut sum_of_large_squares = self.sum_of_large_squares.clone();
        sum_of_large_squares.merge(&other.sum_of_large_squares)?;
        // Checked above: the counts and their sum fit u64, and nothing below fails.
        self.count += other.count;
        self.non_finite += other.non_finite;
        self.sum = sum;
        self.sum_of_squares = sum_of_squares;
        self.sum_of_large_squares = sum_of_large_squares;
        self.min = match (self.min, other.min) {
            (Some(a), Some(b)) => Some(least(a, b)),
            (a, b) => a.or(b),
        };
        self.max = match (self.max, other.max) {
            (Some(a), Some(b)) => Some(greatest(a, b)),
            (a, b) => a.or(b),
        };
        Ok(())
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

    /// The mean square `Σx² / n`, `None` without finite values; +∞ only where it exceeds f64's
    /// range (a mean square beyond 1.8e308, values beyond about 1.3e154).
    pub fn mean_square(&self) -> Option<f64> {
        (self.count > 0).then(|| match self.scaled_mean_square() {
            Some(scaled) => scaled * UNSCALE * UNSCALE,
            None => self.sum_of_squares.mean(self.count),
        })
    }

    /// The root mean square `√(Σx²/n)`, `None` without finite values; finite for any finite values
    /// (it lies between the smallest and the largest magnitude).
    pub fn root_mean_square(&self) -> Option<f64> {
        let largest = self.min?.abs().max(self.max?.abs());
        // Rounding cannot lift it past the largest value, which bounds it.
        Some(self.unbounded_root_mean_square().min(largest))
    }

    /// `√(Σx²/n)` as the sums give it (for n > 0), before it is bounded by the largest value:
    /// what a file's sums are checked by.
    fn unbounded_root_mean_square(&self) -> f64 {
        match self.scaled_mean_square() {
            Some(scaled) => scaled.sqrt() * UNSCALE,
            None => self.sum_of_squares.mean(self.count).sqrt(),
        }
    }

    /// The sample variance `(Σx² − n x̄²) / (n − 1)`, clamped at 0 against rounding (+∞ where it
    /// exceeds f64's range, for values beyond about 1.3e154); `None` for fewer than two finite
    /// values.
    pub fn variance(&self) -> Option<f64> {
        if self.count < 2 {
            return None;
        }
        let factor = self.count as f64 / (self.count as f64 - 1.0);
        let mean = self.sum.mean(self.count);
        Some(if let Some(scaled) = self.scaled_mean_square() {
            let scaled_mean = mean * HALF_SCALE;
            ((scaled - scaled_mean * scaled_mean) * factor).max(0.0) * UNSCALE * UNSCALE
        } else {
            let mean_square = self.sum_of_squares.mean(self.count);
            ((mean_square - mean * mean) * factor).max(0.0)
        })
    }

    /// `Σx² 2⁻¹⁰²⁴ / n` when a value lies beyond [`LARGE`] (`None` otherwise): the large squares'
    /// mean (each at least 2⁻², so the sum is finite at that scale) plus the others' scaled down.
    fn scaled_mean_square(&self) -> Option<f64> {
        if self.sum_of_large_squares == ExactSum::new() {
            return None;
        }
        let large = self.sum_of_large_squares.mean(self.count);
        let rest = self.sum_of_squares.mean(self.count) * (HALF_SCALE * HALF_SCALE);
        Some(large + rest)
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
    #[serde(default)]
    sum_of_large_squares: ExactSum,
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
        if f.sum_of_squares.has_non_finite() || f.sum_of_large_squares.has_non_finite() {
            return Err(
                "statistics: a sum of squares is flagged NaN or infinite, but only squares f64 \
                 holds are summed"
                    .to_owned(),
            );
        }
        let largest = f.min.unwrap_or(0.0).abs().max(f.max.unwrap_or(0.0).abs());
        if f.sum_of_large_squares != ExactSum::new() && largest <= LARGE {
            return Err(format!(
                "statistics: sum_of_large_squares is not zero, but no extreme lies beyond \
                 {LARGE:e} (min {:?}, max {:?})",
                f.min, f.max
            ));
        }
        if f.count.checked_add(f.non_finite).is_none() {
            return Err(format!(
                "statistics: count {} plus non_finite {} overflows",
                f.count, f.non_finite
            ));
        }
        match (f.count, f.min, f.max) {
            (0, None, None) => {
                if f.sum != ExactSum::new()
                    || f.sum_of_squares != ExactSum::new()
                    || f.sum_of_large_squares != ExactSum::new()
                {
                    return Err("statistics: count is 0 but the sums are not".to_owned());
                }
            }
            (1.., Some(min), Some(max)) => {
                if !(min.is_finite() && max.is_finite() && min <= max) {
                    return Err(format!(
                        "statistics: min {min} and max {max} must be finite with min <= max"
                    ));
                }
                if f.sum_of_squares.value() < 0.0 || f.sum_of_large_squares.value() < 0.0 {
                    return Err("statistics: a sum of squares is negative".to_owned());
                }
            }
            (count, min, max) => {
                return Err(format!(
                    "statistics: count {count} with min {min:?} and max {max:?} (extremes are \
                     present exactly when the count is positive)"
                ));
            }
        }
        let stats = Self {
            count: f.count,
            non_finite: f.non_finite,
            sum: f.sum,
            sum_of_squares: f.sum_of_squares,
            sum_of_large_squares: f.sum_of_large_squares,
            min: f.min,
            max: f.max,
        };
        stats.check_bounds()?;
        Ok(stats)
    }
}

impl RunningStats {
    /// The reader's check that the sums are those of values within the extremes: the mean in
    /// [min, max] and the root mean square at most the largest magnitude, up to a relative
    /// [`BOUND_SLACK`] (so a crafted sum cannot make the mean infinite or outside the extremes).
    fn check_bounds(&self) -> Result<(), String> {
        let (Some(min), Some(max), Some(mean)) = (self.min, self.max, self.mean()) else {
            return Ok(());
        };
        let largest = min.abs().max(max.abs());
        let slack = BOUND_SLACK * largest;
        if !(mean.is_finite() && min - slack <= mean && mean <= max + slack) {
            return Err(format!(
                "statistics: sum gives the mean {mean}, outside [min, max] = [{min}, {max}]"
            ));
        }
        // A square below f64's normal range (of a value under 2⁻⁵¹¹) is rounded to a multiple of
        // 2⁻¹⁰⁷⁴, by up to 2⁻¹⁰⁷⁵: the mean square may exceed the largest square by that much.
        let rms = self.unbounded_root_mean_square();
        if !(rms.is_finite() && rms <= (largest + slack).hypot(SUBNORMAL_SQUARE_ROUNDING)) {
            return Err(format!(
                "statistics: sum_of_squares and sum_of_large_squares give the root mean square \
                 {rms}, above the largest magnitude {largest} of min and max"
            ));
        }
        Ok(())
    }
}
