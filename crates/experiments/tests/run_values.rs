//! Per-run values: each run's reduction of a metric against a brute-force recomputation from its
//! scores, the cap on the runs kept, their file form, their quantiles against a sort, their
//! percentage differences on a hand example, and the per-run flag as part of a metric's identity.

// The brute force indexes a sorted vector at ⌊(n − 1) p⌋ for p in [0, 1].
#![allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]

use liebayes_experiments::{
    ExperimentError, MAX_KEPT_RUNS, Metric, Reduction, RunScores, RunValues, StudyLabel, Summary,
    quantiles, relative_differences, run_rngs,
};
use proptest::prelude::*;
use rand::Rng;

fn label(runs: u64) -> StudyLabel {
    StudyLabel {
        name: "stand-in".into(),
        seed: 3,
        runs,
    }
}

/// The metrics of the stand-in: an RMS error and a mean kept per run, a rate not kept.
fn metrics() -> Vec<Metric> {
    vec![
        Metric::new("error", Reduction::RootMeanSquare, "m").per_run(),
        Metric::new("bias", Reduction::Mean, "m").per_run(),
        Metric::new("diverged", Reduction::Rate, ""),
    ]
}

/// A run of `epochs` epochs drawn from run `run`'s stream: values over six decades, a fifth of
/// them NaN or infinite (left out of the run's value).
fn scores(run: u64, epochs: usize) -> RunScores {
    let mut rng = run_rngs(9, run).0;
    let mut values = Vec::with_capacity(3 * epochs);
    for _ in 0..epochs {
        for _ in 0..2 {
            let x = match rng.random_range(0..10) {
                0 => f64::NAN,
                1 => f64::INFINITY,
                _ => rng.random_range(-1.0..1.0) * 10f64.powi(rng.random_range(-3..3)),
            };
            values.push(x);
        }
        values.push(f64::from(u8::from(rng.random_bool(0.1))));
    }
    RunScores {
        metrics: metrics(),
        times: (0..epochs).map(|k| k as f64).collect(),
        values,
        seconds_per_step: 1e-6,
    }
}

/// The run's value of metric column j by brute force: the finite values summed in f64.
fn brute_force(scores: &RunScores, j: usize, square: bool) -> f64 {
    let finite: Vec<f64> = (0..scores.epochs())
        .map(|k| scores.values[k * 3 + j])
        .filter(|x| x.is_finite())
        .collect();
    let n = finite.len() as f64;
    if square {
        (finite.iter().map(|x| x * x).sum::<f64>() / n).sqrt()
    } else {
        finite.iter().sum::<f64>() / n
    }
}

#[test]
fn run_values_equal_a_brute_force_recomputation() {
    let mut summary = Summary::new(label(40), 0..40).unwrap();
    // Runs recorded out of order are kept in run order.
    let order: Vec<u64> = (0..40).map(|i| (i * 17) % 40).collect();
    for &run in &order {
        summary.add_run(run, &scores(run, 30)).unwrap();
    }
    for (j, name, square) in [(0, "error", true), (1, "bias", false)] {
        let values = summary.run_values(name).unwrap();
        assert_eq!(values.len(), 40);
        for (i, &(run, v)) in values.values().iter().enumerate() {
            assert_eq!(run, i as u64);
            let expected = brute_force(&scores(run, 30), j, square);
            assert!(
                (v - expected).abs() <= 1e-13 * expected.abs(),
                "{name}, run {run}: {v} against {expected}"
            );
        }
    }
    assert!(summary.run_values("diverged").is_none());
    assert!(summary.run_values("absent").is_none());
    // A run without a finite value has the value NaN; exact small values give exact results.
    let mut lone = Summary::new(label(2), 0..2).unwrap();
    let nan_run = RunScores {
        values: vec![f64::NAN, f64::NAN, 0.0, f64::INFINITY, f64::NAN, 0.0],
        ..scores(0, 2)
    };
    lone.add_run(0, &nan_run).unwrap();
    let exact = RunScores {
        values: vec![3.0, 1.0, 0.0, 4.0, f64::NAN, 0.0],
        ..scores(1, 2)
    };
    lone.add_run(1, &exact).unwrap();
    let error = lone.run_values("error").unwrap().values();
    assert!(error[0].1.is_nan());
    // √((9 + 16) / 2) and the mean of the one finite value.
    assert_eq!(error[1], (1, (12.5_f64).sqrt()));
    assert_eq!(lone.run_values("bias").unwrap().values()[1], (1, 1.0));
    // An RMS whose squares overflow is still the RMS (scaled): every run value is finite or NaN.
    let mut overflow = Summary::new(label(1), 0..1).unwrap();
    let huge = RunScores {
        values: vec![1e200, 1e300, 0.0, -1e200, 1e300, 0.0],
        ..scores(0, 2)
    };
    overflow.add_run(0, &huge).unwrap();
    assert_eq!(overflow.run_values("error").unwrap().values()[0].1, 1e200);
    assert_eq!(overflow.run_values("bias").unwrap().values()[0].1, 1e300);
}

#[test]
fn only_runs_below_the_cap_are_kept() {
    let start = MAX_KEPT_RUNS - 3;
    let mut summary = Summary::new(label(MAX_KEPT_RUNS + 3), start..MAX_KEPT_RUNS + 3).unwrap();
    for run in start..MAX_KEPT_RUNS + 3 {
        summary.add_run(run, &scores(run, 4)).unwrap();
    }
    let kept: Vec<u64> = summary
        .run_values("error")
        .unwrap()
        .values()
        .iter()
        .map(|v| v.0)
        .collect();
    assert_eq!(kept, [start, start + 1, start + 2]);
    // The runs beyond the cap are still in the per-epoch statistics.
    assert_eq!(
        summary.series("diverged").unwrap().epochs()[0].count(),
        6,
        "every run counted per epoch"
    );
    // Merged with the runs below, the union is what one summary of all of them keeps.
    let mut below = Summary::new(label(MAX_KEPT_RUNS + 3), start - 5..start).unwrap();
    for run in start - 5..start {
        below.add_run(run, &scores(run, 4)).unwrap();
    }
    below.merge(&summary).unwrap();
    assert_eq!(below.run_values("bias").unwrap().len(), 8);
}

#[test]
fn a_run_recorded_twice_is_refused_and_changes_nothing() {
    let mut summary = Summary::new(label(10), 0..5).unwrap();
    summary.add_run(2, &scores(2, 5)).unwrap();
    let before = summary.clone();
    let error = summary.add_run(2, &scores(2, 5)).unwrap_err();
    assert!(error.to_string().contains("run 2"), "{error}");
    assert_eq!(summary, before);
    // A summary of other runs refuses the run (so two summaries cannot both hold its value).
    let mut other = Summary::new(label(10), 5..10).unwrap();
    let empty = other.clone();
    let error = other.add_run(2, &scores(2, 5)).unwrap_err();
    assert!(
        matches!(error, ExperimentError::OutOfRange { .. }),
        "{error}"
    );
    assert_eq!(other, empty);
}

#[test]
fn the_per_run_flag_is_part_of_a_metrics_identity() {
    let mut summary = Summary::new(label(4), 0..4).unwrap();
    summary.add_run(0, &scores(0, 3)).unwrap();
    let before = summary.clone();
    let mut plain = scores(1, 3);
    plain.metrics[0].per_run = false;
    let error = summary.add_run(1, &plain).unwrap_err();
    assert!(matches!(error, ExperimentError::Incompatible(_)), "{error}");
    assert!(error.to_string().contains("per-run"), "{error}");
    assert_eq!(summary, before);
    // The same in a merge, both ways round.
    let mut other = Summary::new(label(4), 1..4).unwrap();
    other.add_run(1, &plain).unwrap();
    assert!(matches!(
        summary.merge(&other),
        Err(ExperimentError::Incompatible(_))
    ));
    assert_eq!(summary, before);
    let other_before = other.clone();
    assert!(other.merge(&summary).is_err());
    assert_eq!(other, other_before);
}

#[test]
fn run_values_survive_their_file() {
    let all_nan = RunScores {
        values: vec![f64::NAN; 3],
        ..scores(0, 1)
    };
    let mut summary = Summary::new(label(4), 0..3).unwrap();
    for run in 0..3 {
        // JSON has no infinity: the first run's trace would read one back as NaN.
        let mut finite = scores(run, 6);
        for x in &mut finite.values {
            *x = if x.is_infinite() { f64::NAN } else { *x };
        }
        summary.add_run(run, &finite).unwrap();
    }
    let mut lone = Summary::new(label(4), 3..4).unwrap();
    lone.add_run(3, &all_nan).unwrap();
    summary.merge(&lone).unwrap();
    let text = serde_json::to_string(&summary).unwrap();
    assert!(text.contains(r#""runs":[0,1,2,3],"values":["#), "{text}");
    let back: Summary = serde_json::from_str(&text).unwrap();
    assert_eq!(back, summary);
    assert!(back.run_values("error").unwrap().values()[3].1.is_nan());
    assert_eq!(serde_json::to_string(&back).unwrap(), text);
    for bad in [
        r#"{"runs": [0, 1], "values": [1.0]}"#,
        r#"{"runs": [1, 0], "values": [1.0, 2.0]}"#,
        r#"{"runs": [3, 3], "values": [1.0, 2.0]}"#,
        r#"{"runs": [65536], "values": [1.0]}"#,
        r#"{"runs": [0], "values": [1.0], "extra": 0}"#,
    ] {
        assert!(serde_json::from_str::<RunValues>(bad).is_err(), "{bad}");
    }
    let good: RunValues =
        serde_json::from_str(r#"{"runs": [0, 7], "values": [null, 2.5]}"#).unwrap();
    assert!(good.values()[0].1.is_nan());
    assert_eq!(good.values()[1], (7, 2.5));
}

#[test]
fn relative_differences_on_a_hand_example() {
    let values = |pairs: &str| -> RunValues {
        let (runs, values): (Vec<u64>, Vec<Option<f64>>) = serde_json::from_str(pairs).unwrap();
        serde_json::from_value(serde_json::json!({ "runs": runs, "values": values })).unwrap()
    };
    // Runs 0 and 1 in both; run 2 has no reference value, run 3 a zero one, run 4 is only in the
    // other, run 5 has no value in the other, run 6 only in the reference.
    let reference = values("[[0, 1, 2, 3, 5, 6], [2.0, 4.0, null, 0.0, 1.0, 8.0]]");
    let other = values("[[0, 1, 2, 3, 4, 5], [3.0, 1.0, 1.0, 1.0, 7.0, null]]");
    assert_eq!(relative_differences(&reference, &other), [50.0, -75.0]);
    assert_eq!(relative_differences(&reference, &reference), [0.0; 4]);
    assert!(relative_differences(&RunValues::new(), &other).is_empty());
    // A difference that overflows is left out.
    let tiny = values("[[0], [1e-300]]");
    let huge = values("[[0], [1e300]]");
    assert!(relative_differences(&tiny, &huge).is_empty());
}

#[test]
fn quantiles_on_hand_examples_and_bad_probabilities() {
    let values = [4.0, f64::NAN, 1.0, 3.0, f64::INFINITY, 2.0];
    // The finite values 1, 2, 3, 4: h = 3 p.
    let q = quantiles(&values, &[0.0, 0.25, 0.5, 0.75, 1.0, 1.0 / 3.0]);
    assert_eq!(q[..5], [1.0, 1.75, 2.5, 3.25, 4.0]);
    assert!((q[5] - 2.0).abs() < 1e-15);
    for p in [-0.1, 1.1, f64::NAN, f64::INFINITY] {
        assert!(quantiles(&values, &[p])[0].is_nan(), "{p}");
    }
    assert!(quantiles(&[f64::NAN], &[0.5])[0].is_nan());
    assert!(quantiles(&[], &[0.0, 1.0]).iter().all(|q| q.is_nan()));
    assert_eq!(quantiles(&[7.0], &[0.0, 0.3, 1.0]), [7.0; 3]);
    // Values of opposite signs near the largest f64: no overflow.
    assert_eq!(quantiles(&[-f64::MAX, f64::MAX], &[0.5]), [0.0]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Against a brute-force sort: the quantile at p lies between the order statistics around
    /// position (n − 1) p, at the linear interpolation of the two; the extremes are the min and
    /// max; quantiles rise with p.
    #[test]
    fn quantiles_match_a_sort(
        values in prop::collection::vec(prop_oneof![
            8 => -1e6..1e6_f64,
            1 => Just(f64::NAN),
            // Small integers, for ties.
            2 => (-3..3_i32).prop_map(f64::from),
        ], 1..200),
        mut probabilities in prop::collection::vec(0.0..=1.0_f64, 1..20),
    ) {
        probabilities.sort_by(f64::total_cmp);
        let mut sorted: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        sorted.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let q = quantiles(&values, &probabilities);
        prop_assert_eq!(q.len(), probabilities.len());
        if sorted.is_empty() {
            prop_assert!(q.iter().all(|x| x.is_nan()));
            return Ok(());
        }
        let n = sorted.len();
        for (&p, &x) in probabilities.iter().zip(&q) {
            let position = (n - 1) as f64 * p;
            let below = sorted[position.floor() as usize];
            let above = sorted[(position.ceil() as usize).min(n - 1)];
            let expected = below + (position - position.floor()) * (above - below);
            prop_assert!(below <= x && x <= above, "{} not in [{}, {}]", x, below, above);
            prop_assert!((x - expected).abs() <= 1e-9 * (1.0 + expected.abs()), "{} vs {}", x, expected);
        }
        prop_assert!(q.windows(2).all(|w| w[0] <= w[1]));
        let ends = quantiles(&values, &[0.0, 1.0]);
        prop_assert_eq!(ends, vec![sorted[0], sorted[n - 1]]);
    }
}
