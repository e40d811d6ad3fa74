//! Per-run values of a metric: each run's reduction of the metric over its epochs, kept by run
//! index, with their quantiles and their percentage differences from a reference filter's values
//! on the same runs.

use crate::ExactSum;
use crate::ExperimentError;
use crate::file_value::FileValue;
use crate::score::Reduction;
use serde::{Deserialize, Serialize};

/// The run indices below which a summary keeps per-run values: runs `0..65 536`.
///
/// The cap bounds a summary's memory (16 bytes per kept run and per-run metric, 1 MiB at most per
/// metric) whatever the number of runs. Quantiles are exact up to that many runs; beyond, since
/// the runs of a study are independent and identically distributed, the first 65 536 are a fair
/// sample of all of them, and the same sample however the study is sharded.
pub const MAX_KEPT_RUNS: u64 = 1 << 16;

/// One metric's value in each of the runs a summary keeps (those with index below
/// [`MAX_KEPT_RUNS`]), sorted by run index. A run's value is its metric reduced over the run's
/// epochs with a finite value: the root mean square `√(Σ xₖ² / n)` for
/// [`Reduction::RootMeanSquare`], the mean `Σ xₖ / n` otherwise, each sum exact and rounded once;
/// NaN when the run had no finite value. So every value is finite or NaN.
///
/// Two are equal when their run indices and values are equal bit for bit (a NaN equals itself).
/// In a file, NaN is written `null` and read back as NaN.
#[derive(Clone, Debug, Default)]
pub struct RunValues {
    /// (run index, value), strictly increasing in the run index.
    values: Vec<(u64, f64)>,
}

impl PartialEq for RunValues {
    fn eq(&self, other: &Self) -> bool {
        self.values.len() == other.values.len()
            && self
                .values
                .iter()
                .zip(&other.values)
                .all(|(a, b)| a.0 == b.0 && a.1.to_bits() == b.1.to_bits())
    }
}

impl RunValues {
    /// No run yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The (run index, value) pairs, sorted by run index.
    pub fn values(&self) -> &[(u64, f64)] {
        &self.values
    }

    /// The number of runs kept.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Whether no run is kept.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The quantiles of the finite values at each probability; see [`quantiles`].
    pub fn quantiles(&self, probabilities: &[f64]) -> Vec<f64> {
        let values: Vec<f64> = self.values.iter().map(|v| v.1).collect();
        quantiles(&values, probabilities)
    }

    /// Whether run `run` has a value here.
    pub(crate) fn contains(&self, run: u64) -> bool {
        self.values.binary_search_by_key(&run, |v| v.0).is_ok()
    }

    /// Keeps `value` for run `run` (the caller has checked that `run` is below
    /// [`MAX_KEPT_RUNS`] and not yet kept).
    pub(crate) fn insert(&mut self, run: u64, value: f64) {
        let at = self.values.partition_point(|v| v.0 < run);
        self.values.insert(at, (run, value));
    }

    /// The union of the runs of `self` and `other`, which must have no run in common.
    ///
    /// # Errors
    /// [`ExperimentError::Incompatible`] naming the first run that both hold.
    pub(crate) fn united(&self, other: &RunValues) -> Result<RunValues, ExperimentError> {
        let (a, b) = (&self.values, &other.values);
        let mut values = Vec::with_capacity(a.len() + b.len());
        let (mut i, mut j) = (0, 0);
        while i < a.len() && j < b.len() {
            if a[i].0 == b[j].0 {
                return Err(ExperimentError::Incompatible(format!(
                    "run {} has a per-run value in both (was a shard merged twice?)",
                    a[i].0
                )));
            }
            if a[i].0 < b[j].0 {
                values.push(a[i]);
                i += 1;
            } else {
                values.push(b[j]);
                j += 1;
            }
        }
        values.extend_from_slice(&a[i..]);
        values.extend_from_slice(&b[j..]);
        Ok(RunValues { values })
    }
}

/// One run's value of a metric from its values at the run's epochs (see [`RunValues`]): over the
/// finite values, `√(Σ x² / n)` for [`Reduction::RootMeanSquare`] and `Σ x / n` otherwise, each
/// sum exact and rounded once; NaN without a finite value. Both lie within the values' range, so
/// they are finite: where the squares overflow (values beyond about 1e154), the root mean square
/// is taken of the values scaled by 2⁻⁶⁰⁰ (exactly) and scaled back.
pub(crate) fn run_value(reduction: Reduction, values: impl Iterator<Item = f64>) -> f64 {
    const DOWN: f64 = 2.409_919_865_102_884e-181; // 2⁻⁶⁰⁰, exactly
    const UP: f64 = 4.149_515_568_880_993e180; // 2⁶⁰⁰, exactly
    let square = reduction == Reduction::RootMeanSquare;
    let (mut sum, mut scaled) = (ExactSum::new(), ExactSum::new());
    let mut count = 0_u64;
    for x in values.filter(|x| x.is_finite()) {
        if square {
            sum.add(x * x);
            scaled.add((x * DOWN) * (x * DOWN));
        } else {
            sum.add(x);
        }
        count += 1;
    }
    if count == 0 {
        return f64::NAN;
    }
    if !square {
        return sum.mean(count);
    }
    let mean_square = sum.mean(count);
    if mean_square.is_finite() {
        mean_square.sqrt()
    } else {
        scaled.mean(count).sqrt() * UP
    }
}

/// The quantiles of the finite values of `values`, one per probability p, by linear interpolation
/// between order statistics (type 7 of Hyndman and Fan, the default of R and NumPy): with the n
/// finite values sorted `x₍₀₎ ≤ … ≤ x₍ₙ₋₁₎` and `h = (n − 1) p`,
/// `q(p) = x₍⌊h⌋₎ + (h − ⌊h⌋) (x₍⌊h⌋+1₎ − x₍⌊h⌋₎)`; so q(0) is the smallest value and q(1) the
/// largest. NaN for a probability outside [0, 1] (or NaN), and for every probability when no value
/// is finite.
///
/// # Example
/// ```
/// use liebayes_experiments::quantiles;
/// let q = quantiles(&[4.0, 1.0, f64::NAN, 3.0, 2.0], &[0.0, 0.5, 1.0, 0.25]);
/// // NaN is left out; the median of 1..4 lies half-way between 2 and 3.
/// assert_eq!(q, vec![1.0, 2.5, 4.0, 1.75]);
/// ```
pub fn quantiles(values: &[f64], probabilities: &[f64]) -> Vec<f64> {
    let mut sorted: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    sorted.sort_unstable_by(f64::total_cmp);
    probabilities
        .iter()
        .map(|&p| quantile_of_sorted(&sorted, p))
        .collect()
}

/// The type-7 quantile at `p` of finite values sorted ascending (see [`quantiles`]).
fn quantile_of_sorted(sorted: &[f64], p: f64) -> f64 {
    let Some(&last) = sorted.last() else {
        return f64::NAN;
    };
    if !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    let h = (sorted.len() - 1) as f64 * p;
    let floor = h.floor();
    // h ≤ n − 1 < 2⁵³, so the conversion is exact.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let k = floor as usize;
    let fraction = h - floor;
    if fraction == 0.0 || k + 1 >= sorted.len() {
        return sorted.get(k).copied().unwrap_or(last);
    }
    let (low, high) = (sorted[k], sorted[k + 1]);
    let step = high - low;
    if step.is_finite() {
        low + fraction * step
    } else {
        // The difference of values of opposite signs near the largest f64 overflows.
        (1.0 - fraction) * low + fraction * high
    }
}

/// The percentage differences of `other`'s run values from `reference`'s on the same runs:
/// `100 (v − v_ref) / v_ref`, that is `100 (v / v_ref − 1)`, for every run index present in both
/// with finite values and a nonzero reference value, in run order (a difference that overflows is
/// left out). Negative where `other` is below the reference (a smaller error).
pub fn relative_differences(reference: &RunValues, other: &RunValues) -> Vec<f64> {
    let (a, b) = (&reference.values, &other.values);
    let mut out = Vec::with_capacity(a.len().min(b.len()));
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].0.cmp(&b[j].0) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                let (r, v) = (a[i].1, b[j].1);
                let d = 100.0 * ((v - r) / r);
                if r.is_finite() && v.is_finite() && r != 0.0 && d.is_finite() {
                    out.push(d);
                }
                i += 1;
                j += 1;
            }
        }
    }
    out
}

/// The serialized form of [`RunValues`]: the run indices and, beside them, the values (`null` for
/// NaN, `"inf"` and `"-inf"` for the infinities).
#[derive(Serialize, Deserialize)]
#[serde(rename = "RunValues", deny_unknown_fields)]
struct RunValuesFields {
    #[serde(deserialize_with = "read_runs")]
    runs: Vec<u64>,
    #[serde(deserialize_with = "read_values")]
    values: Vec<FileValue>,
}

/// The most run values a file holds: one per kept run.
const MAX_READ: usize = 1 << 16;
const _: () = assert!(MAX_READ as u64 == MAX_KEPT_RUNS);

/// At most [`MAX_KEPT_RUNS`] run indices.
fn read_runs<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<u64>, D::Error> {
    crate::bounded::vec(
        d,
        MAX_READ,
        "per-run values' runs (MAX_KEPT_RUNS = 65536 at most)",
    )
}

/// At most [`MAX_KEPT_RUNS`] values.
fn read_values<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<FileValue>, D::Error> {
    crate::bounded::vec(
        d,
        MAX_READ,
        "per-run values (MAX_KEPT_RUNS = 65536 at most)",
    )
}

impl Serialize for RunValues {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        RunValuesFields {
            runs: self.values.iter().map(|v| v.0).collect(),
            values: self.values.iter().map(|v| FileValue(v.1)).collect(),
        }
        .serialize(serializer)
    }
}

impl<'de> Deserialize<'de> for RunValues {
    /// Reads run values back: as many values as run indices, the indices strictly increasing and
    /// below [`MAX_KEPT_RUNS`], every value finite or NaN.
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        let fields = RunValuesFields::deserialize(deserializer)?;
        if fields.runs.len() != fields.values.len() {
            return Err(D::Error::custom(format!(
                "per-run values: {} run indices but {} values",
                fields.runs.len(),
                fields.values.len()
            )));
        }
        if let Some(v) = fields.values.iter().find(|v| v.0.is_infinite()) {
            return Err(D::Error::custom(format!(
                "per-run values: {} is not a run's value (each is finite, or null for none)",
                v.0
            )));
        }
        if fields.runs.windows(2).any(|w| w[0] >= w[1])
            || fields.runs.last().is_some_and(|&r| r >= MAX_KEPT_RUNS)
        {
            return Err(D::Error::custom(
                "per-run values: run indices must be strictly increasing and below 65536",
            ));
        }
        Ok(Self {
            values: fields
                .runs
                .into_iter()
                .zip(fields.values)
                .map(|(r, v)| (r, v.0))
                .collect(),
        })
    }
}
