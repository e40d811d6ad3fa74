//! The size search against known thresholds, with its number of evaluations bounded.

use liebayes_experiments::search::smallest_passing;
use liebayes_experiments::search::{SearchSettings, smallest_to_match};
use liebayes_experiments::{ExperimentError, Metric, Reduction, RunScores, StudyLabel, Summary};
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

/// A study of one run whose score is `1/√n` (an error falling as a particle filter's does), with
/// a failed run below `fails_below`.
fn falling(n: u64, fails_below: u64) -> Result<Summary, ExperimentError> {
    let label = StudyLabel {
        name: format!("PF {n}"),
        seed: 0,
        runs: 1,
    };
    let mut s = Summary::new(label, 0..1)?;
    if n < fails_below {
        s.add_failure("diverged")?;
        return Ok(s);
    }
    let scores = RunScores {
        metrics: vec![Metric::new("error", Reduction::RootMeanSquare, "")],
        times: vec![1.0],
        values: vec![1.0 / (n as f64).sqrt()],
        seconds_per_step: 1e-6,
    };
    s.add_run(0, &scores)?;
    Ok(s)
}

fn rmse(s: &Summary) -> Option<f64> {
    s.series("error")?
        .epochs()
        .first()?
        .mean_square()
        .map(f64::sqrt)
}

#[test]
fn the_match_search_finds_the_count_and_keeps_what_it_tried() {
    let settings = SearchSettings {
        tolerance: 0.05,
        low: 100,
        high: 1_000_000,
        resolution: 0.01,
    };
    // 1/√n ≤ 0.0105 from n = 9071 on.
    let found = smallest_to_match(0.01, settings, |n| falling(n, 0), rmse).unwrap();
    let n = found.count.unwrap();
    assert!((9071..=9071 + 92).contains(&n), "{n}");
    assert_eq!(found.target, 0.01);
    let passing: Vec<u64> = found
        .tried
        .iter()
        .filter(|t| t.score <= 0.0105)
        .map(|t| t.count)
        .collect();
    assert!(passing.iter().all(|&c| c >= 9071) && passing.contains(&n));
    assert!(found.tried.iter().all(|t| t.seconds_per_step == 1e-6));
    // A count whose runs fail does not pass, however small its score.
    let found = smallest_to_match(0.01, settings, |n| falling(n, 50_000), rmse).unwrap();
    assert!(found.count.unwrap() >= 50_000);
    let failed = found.tried.iter().find(|t| t.failures > 0).unwrap();
    assert_eq!(failed.score, f64::INFINITY);
    // Never reached.
    let found = smallest_to_match(1e-9, settings, |n| falling(n, 0), rmse).unwrap();
    assert_eq!(found.count, None);
}

#[test]
fn a_study_without_a_score_never_matches_a_huge_target() {
    let settings = SearchSettings {
        tolerance: 1.0,
        low: 1,
        high: 8,
        resolution: 0.5,
    };
    // target * (1 + tolerance) overflows to +inf: a study without a score (+inf) must not pass.
    let found = smallest_to_match(f64::MAX, settings, |n| falling(n, 0), |_| None).unwrap();
    assert_eq!(found.count, None);
    assert!(found.tried.iter().all(|t| t.score == f64::INFINITY));
    // A finite score within the tolerance of such a target still passes.
    let found =
        smallest_to_match(f64::MAX, settings, |n| falling(n, 0), |_| Some(f64::MAX)).unwrap();
    assert_eq!(found.count, Some(1));
}

#[test]
fn the_match_search_refuses_bad_settings_before_any_study() {
    let good = SearchSettings {
        tolerance: 0.05,
        low: 100,
        high: 1000,
        resolution: 0.1,
    };
    let bad = [
        (f64::NAN, good),
        (0.0, good),
        (-1.0, good),
        (f64::INFINITY, good),
        (
            1.0,
            SearchSettings {
                tolerance: f64::NAN,
                ..good
            },
        ),
        (
            1.0,
            SearchSettings {
                tolerance: 0.0,
                ..good
            },
        ),
        (
            1.0,
            SearchSettings {
                tolerance: 11.0,
                ..good
            },
        ),
        (1.0, SearchSettings { low: 0, ..good }),
        (1.0, SearchSettings { low: 2000, ..good }),
        (
            1.0,
            SearchSettings {
                high: u64::MAX,
                ..good
            },
        ),
        (
            1.0,
            SearchSettings {
                resolution: 0.0,
                ..good
            },
        ),
    ];
    for (target, settings) in bad {
        let mut studies = 0;
        let result = smallest_to_match(
            target,
            settings,
            |n| {
                studies += 1;
                falling(n, 0)
            },
            rmse,
        );
        assert!(
            matches!(result, Err(ExperimentError::OutOfRange { .. })),
            "{target} {settings:?}: {result:?}"
        );
        assert_eq!(studies, 0);
    }
    // A study's error stops the search and is returned.
    let error = smallest_to_match(
        1.0,
        good,
        |_| Err(ExperimentError::Scenario("broken".into())),
        rmse,
    );
    assert_eq!(error, Err(ExperimentError::Scenario("broken".into())));
}
