//! Bad input never panics, hangs, aborts or silently yields NaN. The experiment layer's public
//! entries that take numbers and shapes from users (exact sums, running statistics, metric series,
//! summaries built run by run, run scores, quantiles, shards, studies, the recorder) are fed NaN,
//! ±∞, ±MAX, subnormals, zeros, huge indices and malformed scores, each call on its own thread; it
//! must return an error or a finite result, and a summary must be exactly as it was after an
//! error. The fixed cases at the end are the regressions of reported failures
//! (`LIEBAYES_FUZZ_CASES` runs the properties long).

use liebayes_densities::Gaussian;
use liebayes_experiments::{
    ExactSum, ExperimentError, MAX_EPOCHS, MAX_RUNS, Metric, MetricSeries, Recursive, Reduction,
    RunScores, RunningStats, Shard, Step, Study, StudyLabel, Summary, quantiles, record,
};
use liebayes_operators::OperatorError;
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_reference::fuzz::{self, size, value};
use nalgebra::{Matrix1, Vector1};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// The metrics a fuzzed run's scores declare: names drawn from a few, so that some repeat.
fn metric(name: u8, per_run: bool) -> Metric {
    const NAMES: [&str; 3] = ["error", "nees", "bias"];
    let m = Metric::new(NAMES[usize::from(name) % 3], Reduction::RootMeanSquare, "m");
    if per_run { m.per_run() } else { m }
}

/// Running statistics of any values: the count and the non-finite count partition them, and the
/// mean, smallest and largest of the finite values are finite and ordered, the root mean square
/// finite and between the magnitudes (the mean square and the variance may overflow to +∞, as
/// documented, never to NaN).
fn check_stats(values: &[f64], stats: &RunningStats) -> Result<(), TestCaseError> {
    let finite = values.iter().filter(|v| v.is_finite()).count() as u64;
    prop_assert_eq!(stats.count(), finite);
    prop_assert_eq!(stats.non_finite(), values.len() as u64 - finite);
    if finite == 0 {
        prop_assert!(stats.mean().is_none() && stats.min().is_none());
        return Ok(());
    }
    let (mean, min, max) = (
        stats.mean().unwrap(),
        stats.min().unwrap(),
        stats.max().unwrap(),
    );
    prop_assert!(
        mean.is_finite() && min <= mean && mean <= max,
        "{mean} {min} {max}"
    );
    let square = stats.mean_square().unwrap();
    prop_assert!(square >= 0.0, "mean square {square}");
    // The root mean square is finite, between the smallest and the largest magnitude.
    let rms = stats.root_mean_square().unwrap();
    let (low, high) = if min <= 0.0 && 0.0 <= max {
        (0.0, min.abs().max(max.abs()))
    } else {
        (min.abs().min(max.abs()), min.abs().max(max.abs()))
    };
    // Below: to the rounding of the mean of the squares, but where the squares underflow.
    prop_assert!(
        rms <= high && (rms >= low * (1.0 - 4.0 * f64::EPSILON) || low < 1e-150),
        "rms {rms} outside [{low}, {high}]"
    );
    if let Some(variance) = stats.variance() {
        prop_assert!(variance >= 0.0, "variance {variance}");
    }
    Ok(())
}

#[test]
fn statistics_and_sums() {
    fuzz::run(
        "RunningStats",
        proptest::collection::vec(value(), 0..12),
        |values| {
            fuzz::case("RunningStats", move || -> Result<(), TestCaseError> {
                let mut stats = RunningStats::new();
                let mut sum = ExactSum::new();
                for &v in &values {
                    stats.add(v);
                    sum.add(v);
                }
                check_stats(&values, &stats)?;
                // What it writes, its reader takes back.
                let text = serde_json::to_string(&stats).unwrap();
                let back: RunningStats = serde_json::from_str(&text)
                    .map_err(|e| TestCaseError::fail(format!("{e}: {text}")))?;
                prop_assert_eq!(&back, &stats);
                // Split in two and merged: the same statistics, bit for bit.
                let (a, b) = values.split_at(values.len() / 2);
                let (mut left, mut right) = (RunningStats::new(), RunningStats::new());
                for &v in a {
                    left.add(v);
                }
                for &v in b {
                    right.add(v);
                }
                left.merge(&right).unwrap();
                prop_assert_eq!(&left, &stats);
                // The exact sum is NaN only when a NaN or both infinities were added.
                let total = sum.value();
                let nan_in = values.iter().any(|v| v.is_nan())
                    || (values.contains(&f64::INFINITY) && values.contains(&f64::NEG_INFINITY));
                prop_assert_eq!(total.is_nan(), nan_in);
                let q = quantiles(&values, &[0.0, 0.25, 0.5, 1.0]);
                prop_assert_eq!(q.len(), 4);
                prop_assert!(q.iter().all(|x| x.is_finite()) || finite_count(&values) == 0);
                Ok(())
            });
        },
    );
    fuzz::summary("RunningStats");
}

fn finite_count(values: &[f64]) -> usize {
    values.iter().filter(|v| v.is_finite()).count()
}

#[test]
fn metric_series_and_shards() {
    fuzz::run(
        "MetricSeries",
        (
            size(MAX_EPOCHS),
            value(),
            any::<u64>(),
            any::<u64>(),
            any::<u64>(),
        ),
        |(k, v, index, count, runs)| {
            fuzz::case("MetricSeries", move || -> Result<(), TestCaseError> {
                let mut series = MetricSeries::default();
                let added = fuzz::counted(series.add(k, v)).is_some();
                // Only the next epoch (0 here) is accepted, and the storage holds what was added.
                prop_assert_eq!(added, k == 0);
                prop_assert_eq!(series.epochs().len(), usize::from(added));
                if let Some(shard) = fuzz::counted(Shard::new(index, count)) {
                    let range = shard.runs(runs);
                    prop_assert!(range.start <= range.end && range.end <= runs);
                }
                let study = fuzz::counted(Study::new("fuzzed", runs, index, Shard::WHOLE));
                prop_assert_eq!(study.is_some(), (1..=MAX_RUNS).contains(&runs));
                Ok(())
            });
        },
    );
    fuzz::summary("MetricSeries");
}

#[test]
fn summaries_built_run_by_run() {
    fuzz::run(
        "Summary::add_run",
        (
            proptest::collection::vec((any::<u8>(), any::<bool>()), 0..4),
            proptest::collection::vec(value(), 0..5),
            proptest::collection::vec(value(), 0..12),
            value(),
            0..6_u64,
            size(MAX_EPOCHS),
        ),
        |(metrics, times, values, seconds, run, k)| {
            fuzz::case("Summary::add_run", move || -> Result<(), TestCaseError> {
                let scores = RunScores {
                    metrics: metrics.iter().map(|&(n, p)| metric(n, p)).collect(),
                    times,
                    values,
                    seconds_per_step: seconds,
                };
                // Looking up any epoch, however large, is an answer or None.
                if let Some(x) = scores.get("error", k) {
                    prop_assert!(k < scores.epochs());
                    let _ = x;
                }
                let label = StudyLabel {
                    name: "fuzzed".into(),
                    seed: 1,
                    runs: 4,
                };
                let mut summary = Summary::new(label, 0..4).unwrap();
                for attempt in 0..3 {
                    let before = summary.clone();
                    if fuzz::counted(summary.add_run(run, &scores)).is_none() {
                        prop_assert_eq!(&summary, &before, "attempt {}", attempt);
                    }
                }
                // What was built is what a file may hold: it reads back equal.
                let text = serde_json::to_string(&summary).unwrap();
                let back: Summary = serde_json::from_str(&text)
                    .map_err(|e| TestCaseError::fail(format!("{e}: {text}")))?;
                prop_assert_eq!(&back, &summary);
                Ok(())
            });
        },
    );
    fuzz::summary("Summary::add_run");
}

/// Scores whose values do not match their epochs and metrics (public fields, filled by hand):
/// an error naming the run, and the summary unchanged (it indexed past the values and panicked
/// half-way through recording).
#[test]
fn ragged_scores_are_refused_and_change_nothing() {
    let label = StudyLabel {
        name: "ragged".into(),
        seed: 0,
        runs: 3,
    };
    let mut summary = Summary::new(label, 0..3).unwrap();
    let good = RunScores {
        metrics: vec![
            Metric::new("error", Reduction::RootMeanSquare, "m").per_run(),
            Metric::new("nees", Reduction::ChiSquare { dof: 2 }, ""),
        ],
        times: vec![0.0, 1.0],
        values: vec![1.0, 2.0, 3.0, 4.0],
        seconds_per_step: 1e-6,
    };
    summary.add_run(0, &good).unwrap();
    let before = summary.clone();
    let mut short = good.clone();
    short.values.pop();
    let mut repeated = good.clone();
    repeated.metrics[1].name = "error";
    let mut backwards = good.clone();
    backwards.times = vec![1.0, 0.0];
    for bad in [short, repeated, backwards] {
        let error = summary.add_run(1, &bad).unwrap_err();
        assert!(matches!(error, ExperimentError::Incompatible(_)), "{error}");
        assert!(error.to_string().contains("run 1"), "{error}");
        assert_eq!(summary, before);
    }
    // Runs outside the summary's ranges, and more runs than it covers, are refused.
    assert!(matches!(
        summary.add_run(3, &good),
        Err(ExperimentError::OutOfRange { .. })
    ));
    summary.add_run(1, &good).unwrap();
    summary.add_failure("diverged").unwrap();
    assert!(matches!(
        summary.add_run(2, &good),
        Err(ExperimentError::Incompatible(_))
    ));
    // An epoch index past every bound is None, not an overflow.
    assert_eq!(good.get("error", usize::MAX), None);
    assert_eq!(good.get("error", 2), None);
    assert_eq!(good.get("nees", 1), Some(4.0));
}

/// The mean of values near the largest f64: their sum overflows, their mean does not.
#[test]
fn the_mean_of_huge_values_is_finite() {
    let mut stats = RunningStats::new();
    for v in [f64::MAX, f64::MAX, 0.5 * f64::MAX] {
        stats.add(v);
    }
    let expected = (f64::MAX / 3.0) * 2.5;
    assert!((stats.mean().unwrap() - expected).abs() <= 2.0 * f64::EPSILON * expected);
    assert_eq!(stats.variance(), Some(f64::INFINITY));
    let mut negative = RunningStats::new();
    negative.add(-f64::MAX);
    negative.add(-f64::MAX);
    assert_eq!(negative.mean(), Some(-f64::MAX));
}

/// A run's root mean square of values whose squares overflow, and its mean of values whose sum
/// does: finite (they were NaN), and they survive a file with the infinities of the trace.
#[test]
fn per_run_values_of_huge_errors_are_finite() {
    let label = StudyLabel {
        name: "huge".into(),
        seed: 0,
        runs: 1,
    };
    let mut summary = Summary::new(label, 0..1).unwrap();
    let scores = RunScores {
        metrics: vec![
            Metric::new("error", Reduction::RootMeanSquare, "m").per_run(),
            Metric::new("bias", Reduction::Mean, "m").per_run(),
        ],
        times: vec![0.0, 1.0, 2.0],
        values: vec![
            3e200,
            f64::MAX,
            4e200,
            f64::MAX,
            f64::NEG_INFINITY,
            f64::NAN,
        ],
        seconds_per_step: 1e-6,
    };
    summary.add_run(0, &scores).unwrap();
    let rms = summary.run_values("error").unwrap().values()[0].1;
    assert!(
        (rms - 5e200 / 2f64.sqrt()).abs() <= 4.0 * f64::EPSILON * rms,
        "{rms:e}"
    );
    assert_eq!(summary.run_values("bias").unwrap().values()[0].1, f64::MAX);
    let text = serde_json::to_string(&summary).unwrap();
    assert!(text.contains("\"-inf\""), "{text}");
    let back: Summary = serde_json::from_str(&text).unwrap();
    assert_eq!(back, summary);
    assert!(serde_json::from_str::<Summary>(&text.replace("\"-inf\"", "\"minus\"")).is_err());
}

/// A recording of an endless iterator of steps: the reservation is bounded (it asked for
/// `usize::MAX` steps' capacity and panicked before the first step), and a step that fails ends
/// it with the filter's error.
#[test]
fn an_endless_recording_reserves_a_bounded_capacity() {
    let prior = Gaussian::new(Vector1::new(0.0), Matrix1::new(1.0)).unwrap();
    let process = LinearProcess::new(Matrix1::new(1.0), Matrix1::new(0.0)).unwrap();
    let measurement = LinearMeasurement::new(Matrix1::new(1.0), Matrix1::new(1.0)).unwrap();
    let mut filter = Recursive::new(prior, process, measurement);
    let steps = std::iter::repeat(Step {
        time: 1.0,
        input: Vector1::new(0.0),
        truth: 0.0,
        measurement: Some(Vector1::new(f64::NAN)),
    });
    let failure = record(&mut filter, steps).unwrap_err();
    assert_eq!(failure.step, 0);
    assert!(matches!(failure.error, OperatorError::NonFinite { .. }));
}

/// Statistics of values under 2⁻⁵¹¹ (three of 2.96e-159, a run's time in a fuzzed summary) were
/// refused by their own reader: the squares are subnormal, rounded to a multiple of 2⁻¹⁰⁷⁴, and
/// the root mean square came out 1.3e-7 above the largest value, past the 4ε the reader allowed.
/// The reader now allows for that rounding; every value from 1e-170 to 1e-150 reads back.
#[test]
fn statistics_of_values_with_subnormal_squares_read_back() {
    let mut values = vec![2.959_180_311_277_383e-159; 3];
    values.extend((0..200).map(|k| 10f64.powf(-170.0 + 0.1 * f64::from(k))));
    for x in values {
        for count in [1, 3, 7] {
            let mut stats = RunningStats::new();
            for _ in 0..count {
                stats.add(x);
            }
            let text = serde_json::to_string(&stats).unwrap();
            let back: RunningStats = serde_json::from_str(&text)
                .unwrap_or_else(|e| panic!("{count} values of {x:e}: {e}"));
            assert_eq!(back, stats);
        }
    }
    // A crafted sum of squares well beyond the rounding is still refused.
    let mut stats = RunningStats::new();
    stats.add(1e-160);
    let mut doubled = stats.clone();
    doubled.add(1e-160);
    let text = serde_json::to_string(&stats).unwrap();
    let crafted = serde_json::to_value(&doubled).unwrap()["sum_of_squares"].clone();
    let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
    value["sum_of_squares"] = crafted;
    assert!(serde_json::from_value::<RunningStats>(value).is_err());
}

/// Statistics read back with a count as large as u64 holds: adding to them leaves the values
/// beyond out and merging them is refused (it overflowed, a panic), and the figures stay finite.
/// (Zeros, so that the sums are those of that many values, as the reader checks.)
#[test]
fn counts_read_from_a_file_do_not_overflow() {
    let mut stats = RunningStats::new();
    stats.add(0.0);
    let text = serde_json::to_string(&stats)
        .unwrap()
        .replace("\"count\":1", &format!("\"count\":{}", u64::MAX));
    let mut huge: RunningStats = serde_json::from_str(&text).unwrap();
    assert_eq!(huge.count(), u64::MAX);
    huge.add(3.0);
    huge.add(f64::NAN);
    let copy = huge.clone();
    assert!(huge.merge(&copy).is_err());
    assert_eq!(huge, copy);
    assert_eq!(huge.count(), u64::MAX);
    assert!(huge.mean().unwrap().is_finite());
}

/// Rates of nothing: an empty recording's steps per second is 0 (it was 0/0, NaN), and a run
/// whose time is not positive (public fields) is too short to time, +∞.
#[test]
fn rates_of_empty_or_untimed_recordings_are_not_nan() {
    let empty: liebayes_experiments::Recording<(), f64> = liebayes_experiments::Recording {
        steps: Vec::new(),
        smoothed: Vec::new(),
        seconds: 0.0,
    };
    assert_eq!(empty.steps_per_second(), 0.0);
    let untimed = liebayes_experiments::Recording {
        steps: vec![liebayes_experiments::Recorded {
            time: 0.0,
            truth: (),
            estimate: 1.0,
            update: None,
        }],
        smoothed: Vec::new(),
        seconds: f64::NAN,
    };
    assert_eq!(untimed.steps_per_second(), f64::INFINITY);
}

/// A summary file whose per-run values hold an infinity is refused: a run's value is finite or
/// NaN (written null).
#[test]
fn per_run_values_read_back_are_finite_or_nan() {
    let label = StudyLabel {
        name: "file".into(),
        seed: 0,
        runs: 1,
    };
    let mut summary = Summary::new(label, 0..1).unwrap();
    let scores = RunScores {
        metrics: vec![Metric::new("error", Reduction::Mean, "m").per_run()],
        times: vec![0.0],
        values: vec![2.5],
        seconds_per_step: 1e-6,
    };
    summary.add_run(0, &scores).unwrap();
    let text = serde_json::to_string(&summary).unwrap();
    assert!(text.contains("\"values\":[2.5]"), "{text}");
    let bad = text.replace("\"values\":[2.5]", "\"values\":[\"inf\"]");
    let error = serde_json::from_str::<Summary>(&bad).unwrap_err();
    assert!(error.to_string().contains("per-run values"), "{error}");
}
