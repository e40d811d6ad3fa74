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
        merged.merge(&stats(&values[..k]));
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
