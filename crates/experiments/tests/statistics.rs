//! `RunningStats` against two-pass statistics of the stored values, and its exact merge.

use liebayes_experiments::RunningStats;
use proptest::prelude::*;

fn stats(values: &[f64]) -> RunningStats {
    let mut s = RunningStats::new();
    for &x in values {
        s.add(x);
    }
    s
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Mean and variance against the two-pass formulas on the stored values; the variance's
    /// tolerance is the documented cancellation bound `ε · (mean² + variance) / variance`.
    #[test]
    fn mean_and_variance_match_two_passes(
        values in prop::collection::vec(-1e6..1e6_f64, 2..300),
        offset in -1e3..1e3_f64,
    ) {
        let values: Vec<f64> = values.iter().map(|x| x + offset).collect();
        let s = stats(&values);
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let variance = values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        prop_assert_eq!(s.count(), values.len() as u64);
        prop_assert!((s.mean().unwrap() - mean).abs() <= 1e-9 * (1.0 + mean.abs()));
        let tolerance = 64.0 * f64::EPSILON * (mean * mean + variance) + 1e-300;
        prop_assert!((s.variance().unwrap() - variance).abs() <= tolerance,
            "{} vs {}", s.variance().unwrap(), variance);
        prop_assert_eq!(s.min(), values.iter().copied().reduce(f64::min));
        prop_assert_eq!(s.max(), values.iter().copied().reduce(f64::max));
    }

    #[test]
    fn shards_merge_to_the_same_statistics(
        values in prop::collection::vec(prop_oneof![any::<f64>(), -10.0..10.0_f64], 0..100),
        cut in any::<prop::sample::Index>(),
    ) {
        let k = cut.index(values.len() + 1);
        let whole = stats(&values);
        let mut merged = stats(&values[k..]);
        merged.merge(&stats(&values[..k])).unwrap();
        prop_assert_eq!(merged.count(), whole.count());
        prop_assert_eq!(merged.non_finite(), whole.non_finite());
        let bits = |x: Option<f64>| x.map(f64::to_bits);
        prop_assert_eq!(bits(merged.mean()), bits(whole.mean()));
        prop_assert_eq!(bits(merged.mean_square()), bits(whole.mean_square()));
        prop_assert_eq!(bits(merged.variance()), bits(whole.variance()));
        prop_assert_eq!(bits(merged.min()), bits(whole.min()));
        prop_assert_eq!(bits(merged.max()), bits(whole.max()));
    }
}

/// Found at `PROPTEST_RNG_SEED=24`: `f64::min` and `max` may return either zero, so a stream
/// holding −0 and +0 had extremes that depended on the order of its values, and merged shards
/// differed from the whole. The extremes now follow f64's total order, −0 < +0.
#[test]
fn signed_zeros_give_the_same_extremes_in_any_order() {
    let bits = |x: Option<f64>| x.map(f64::to_bits);
    for values in [[-0.0, 0.0, 0.0], [0.0, -0.0, 0.0], [0.0, 0.0, -0.0]] {
        let s = stats(&values);
        assert_eq!(bits(s.min()), bits(Some(-0.0)));
        assert_eq!(bits(s.max()), bits(Some(0.0)));
        for k in 0..=values.len() {
            let mut merged = stats(&values[k..]);
            merged.merge(&stats(&values[..k])).unwrap();
            assert_eq!(merged, s);
        }
    }
}

#[test]
fn non_finite_values_are_counted_apart() {
    let s = stats(&[1.0, f64::NAN, 3.0, f64::INFINITY]);
    assert_eq!((s.count(), s.non_finite()), (2, 2));
    assert_eq!(s.mean(), Some(2.0));
    assert_eq!(s.variance(), Some(2.0));
    assert_eq!(RunningStats::new().mean(), None);
    assert_eq!(stats(&[4.0]).variance(), None);
    assert_eq!(stats(&[1e200, -1e200]).variance(), Some(f64::INFINITY));
    assert_eq!(stats(&[1e200, -1e200]).mean(), Some(0.0));
}

/// Squares beyond f64's range (values beyond 1.3e154) are summed at a scale of 2⁻¹⁰²⁴: the root
/// mean square is exact to rounding up to `f64::MAX`, the mean square +∞ only where it exceeds
/// f64's range, and small values beside large ones still count.
#[test]
fn the_root_mean_square_holds_values_up_to_max() {
    assert_eq!(stats(&[1e200, -1e200]).root_mean_square(), Some(1e200));
    assert_eq!(stats(&[f64::MAX]).root_mean_square(), Some(f64::MAX));
    assert_eq!(
        stats(&[f64::MAX, -f64::MAX]).root_mean_square(),
        Some(f64::MAX)
    );
    assert_eq!(stats(&[1e200]).mean_square(), Some(f64::INFINITY));
    // √((3e153² + 4e153²)/2) with both below the scaled range, and with one in it: the same.
    let below = stats(&[3e153, 4e153]).root_mean_square().unwrap();
    let across = stats(&[3e153, 4e153 * 2.0]).root_mean_square().unwrap();
    let exact =
        |a: f64, b: f64| ((a / 1e153).powi(2) / 2.0 + (b / 1e153).powi(2) / 2.0).sqrt() * 1e153;
    assert!((below - exact(3e153, 4e153)).abs() <= 4.0 * f64::EPSILON * below);
    assert!((across - exact(3e153, 8e153)).abs() <= 4.0 * f64::EPSILON * across);
    // A mean square of 1e300 from one large and many small values: finite and exact to rounding.
    let mut values = vec![1e-3; 999];
    values.push(1e154);
    let s = stats(&values);
    let expected = (999.0 * 1e-6 + values[999].powi(2)) / 1000.0;
    assert!((s.mean_square().unwrap() - expected).abs() <= 4.0 * f64::EPSILON * expected);
    // The variance of two values 2e154 apart: 2e308, beyond f64's range; 1e154 apart: finite.
    assert_eq!(stats(&[1e154, -1e154]).variance(), Some(f64::INFINITY));
    let v = stats(&[5e153, -5e153]).variance().unwrap();
    assert!((v - 5e307).abs() <= 1e-14 * 5e307, "{v:e}");
}

/// `base` through a file with its field `field` taken from `donor`: the error, if refused.
fn read_with(
    base: &RunningStats,
    field: &str,
    donor: &RunningStats,
) -> Result<RunningStats, String> {
    let mut json = serde_json::to_value(base).unwrap();
    json[field] = serde_json::to_value(donor).unwrap()[field].clone();
    serde_json::from_value(json).map_err(|e| e.to_string())
}

#[test]
fn sums_beyond_the_extremes_are_refused_naming_the_field() {
    let base = stats(&[1.0, 2.0]);
    // A mean of 50 outside [1, 2].
    let error = read_with(&base, "sum", &stats(&[100.0])).unwrap_err();
    assert!(
        error.contains("sum") && error.contains("outside [min, max]"),
        "{error}"
    );
    // A sum beyond f64's range over two values: the mean would be +inf.
    let error = read_with(&base, "sum", &stats(&[f64::MAX; 4])).unwrap_err();
    assert!(error.contains("outside [min, max]"), "{error}");
    // A root mean square of 1e10 above the largest magnitude 2.
    let error = read_with(&base, "sum_of_squares", &stats(&[1e10])).unwrap_err();
    assert!(
        error.contains("sum_of_squares") && error.contains("root mean square"),
        "{error}"
    );
    // The statistics of real streams, huge values included, read back.
    for values in [
        &[1.0, 2.0][..],
        &[0.1; 3],
        &[f64::MAX, f64::MAX, -f64::MAX],
        &[1e300, 3e300, 7e300],
        &[-5e-324, 5e-324],
    ] {
        let s = stats(values);
        let back: RunningStats = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(back, s);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Whatever the values, the mean and root mean square the sums give pass the reader's bounds.
    #[test]
    fn the_statistics_of_any_stream_read_back(
        values in prop::collection::vec(prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO, 1..40),
    ) {
        let s = stats(&values);
        let back: RunningStats = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        prop_assert_eq!(back, s);
    }
}

/// `(2⁶⁴ − 1) · x`, exactly: `x` doubled 64 times, less `x`.
fn times_u64_max(x: f64) -> liebayes_experiments::ExactSum {
    let mut sum: liebayes_experiments::ExactSum = [x].into_iter().collect();
    for _ in 0..64 {
        let copy = sum.clone();
        sum.merge(&copy).unwrap();
    }
    sum.add(-x);
    sum
}

/// A stream of `u64::MAX` values, every one `f64::MAX`, as a file holds it (no process adds that
/// many): its reader accepts it, its mean is `f64::MAX`.
fn full_stream() -> RunningStats {
    let scaled = f64::MAX * 2f64.powi(-512);
    let json = serde_json::json!({
        "count": u64::MAX,
        "non_finite": 0,
        "sum": times_u64_max(f64::MAX),
        "sum_of_squares": liebayes_experiments::ExactSum::new(),
        "sum_of_large_squares": times_u64_max(scaled * scaled),
        "min": f64::MAX,
        "max": f64::MAX,
    });
    let stats: RunningStats = serde_json::from_value(json).unwrap();
    assert_eq!(stats.mean(), Some(f64::MAX));
    stats
}

/// Merging two streams whose counts sum beyond `u64::MAX` saturated the count while the
/// exact sums kept growing, so the mean became +∞ (and left [min, max] with more merges). The
/// merge is refused instead, with a typed error naming the counts, the statistics unchanged; a
/// merge up to `u64::MAX` values is exact.
#[test]
fn a_merge_beyond_u64_max_values_is_refused_not_saturated() {
    let full = full_stream();
    let mut tried = full.clone();
    let error = tried.merge(&full).unwrap_err();
    assert!(
        matches!(
            error,
            liebayes_experiments::ExperimentError::OutOfRange { .. }
        ),
        "{error}"
    );
    let message = error.to_string();
    assert!(
        message.contains("count plus non_finite") && message.contains("2^64 - 1"),
        "{message}"
    );
    assert_eq!(tried, full);
    // One non-finite value beyond a full count is refused as well.
    assert!(tried.merge(&stats(&[f64::NAN])).is_err());
    // Up to u64::MAX values in all, the merge is exact.
    let mut one_short: RunningStats = {
        let mut json = serde_json::to_value(&full).unwrap();
        json["count"] = (u64::MAX - 1).into();
        let mut sum = times_u64_max(f64::MAX);
        sum.add(-f64::MAX);
        json["sum"] = serde_json::to_value(&sum).unwrap();
        serde_json::from_value(json).unwrap()
    };
    one_short.merge(&stats(&[f64::MAX])).unwrap();
    assert_eq!(one_short.count(), u64::MAX);
    assert_eq!(one_short.mean(), Some(f64::MAX));
}

/// Values added to a stream already holding `u64::MAX`
/// values saturated the count and grew the sum, until the mean was +∞. They are left out, so the
/// statistics stay those of the values counted.
#[test]
fn values_beyond_u64_max_are_not_added() {
    let full = full_stream();
    let mut grown = full.clone();
    for _ in 0..10_000 {
        grown.add(f64::MAX);
    }
    grown.add(f64::NAN);
    assert_eq!(grown, full);
    assert_eq!(grown.mean(), Some(f64::MAX));
    let back: RunningStats = serde_json::from_str(&serde_json::to_string(&grown).unwrap()).unwrap();
    assert_eq!(back, full);
}
