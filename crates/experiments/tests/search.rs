//! The size search against known thresholds, with its number of evaluations bounded.

use liebayes_experiments::ExperimentError;
use liebayes_experiments::search::smallest_passing;
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn finds_the_threshold_to_the_resolution(
        threshold in 1..10_000_000_u64,
        low in 1..100_u64,
        resolution in 0.001..0.5_f64,
    ) {
        let high = 20_000_000;
        let (mut calls, mut outside) = (0, 0);
        let found = smallest_passing::<ExperimentError>(low, high, resolution, |n| {
            calls += 1;
            outside += u32::from(!(low..=high).contains(&n));
            Ok(n >= threshold)
        })
        .unwrap()
        .unwrap();
        prop_assert_eq!(outside, 0);
        prop_assert!(found >= threshold);
        prop_assert!(found == low.max(threshold) || (found - threshold) as f64 <= resolution * found as f64 + 1.0);
        let bound = ((high / low) as f64).log2() + (1.0 / resolution).log2() + 3.0;
        prop_assert!(f64::from(calls) <= bound, "{calls} calls, bound {bound}");
    }
}

#[test]
fn none_when_the_largest_size_fails_and_errors_for_bad_settings() {
    assert_eq!(
        smallest_passing::<ExperimentError>(1, 1000, 0.05, |_| Ok(false)).unwrap(),
        None
    );
    assert_eq!(
        smallest_passing::<ExperimentError>(8, 1000, 0.05, |_| Ok(true)).unwrap(),
        Some(8)
    );
    assert_eq!(
        smallest_passing::<ExperimentError>(1, u64::MAX, 0.05, |n| Ok(n == u64::MAX)).unwrap(),
        Some(u64::MAX)
    );
    for (low, high, resolution) in [
        (0, 10, 0.1),
        (11, 10, 0.1),
        (1, 10, 0.0),
        (1, 10, f64::NAN),
        (1, 10, 1.5),
    ] {
        let error =
            smallest_passing::<ExperimentError>(low, high, resolution, |_| Ok(true)).unwrap_err();
        assert!(error.to_string().contains("outside"), "{error}");
    }
    let error = smallest_passing(1, 100, 0.1, |n| {
        if n > 4 {
            Err(ExperimentError::Scenario("stop".into()))
        } else {
            Ok(false)
        }
    })
    .unwrap_err();
    assert_eq!(error, ExperimentError::Scenario("stop".into()));
}
