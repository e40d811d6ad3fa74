//! Summaries of shards merge to the summary of one study over all runs, bit for bit (per-run values
//! included), in any order and through a file; overlapping shards are refused.

use liebayes_experiments::{
    ExperimentError, MAX_EPOCHS, MAX_METRICS, MAX_STUDY_EPOCHS, Metric, Reduction, RunScores,
    Shard, StudyLabel, Summary, run_rngs,
};
use rand::Rng;

fn label(seed: u64, runs: u64) -> StudyLabel {
    StudyLabel {
        name: "stand-in".into(),
        seed,
        runs,
    }
}

/// A run's scores with the given values of `error` and `nees` at each epoch, both kept per run.
fn scores(values: Vec<f64>) -> RunScores {
    RunScores {
        metrics: vec![
            Metric::new("error", Reduction::RootMeanSquare, "m").per_run(),
            Metric::new("nees", Reduction::ChiSquare { dof: 2 }, "").per_run(),
        ],
        times: (0..values.len() / 2).map(|k| k as f64).collect(),
        values,
        seconds_per_step: 1e-6,
    }
}

/// A stand-in study: run k draws its per-epoch errors and sometimes a failure from its own stream;
/// values span twelve decades, so a floating-point sum would depend on the order.
fn study(seed: u64, shard: Shard, runs: u64) -> Summary {
    let range = shard.runs(runs);
    let mut summary = Summary::new(label(seed, runs), range.clone()).unwrap();
    for run in range {
        let mut rng = run_rngs(seed, run).0;
        if rng.random_bool(0.05) {
            summary
                .add_failure(if rng.random_bool(0.5) {
                    "diverged"
                } else {
                    "not positive definite"
                })
                .unwrap();
            continue;
        }
        let mut values = Vec::new();
        for _ in 0..40 {
            let scale = 10f64.powi(rng.random_range(-6..6));
            values.push(rng.random_range(-1.0..1.0) * scale);
            values.push(rng.random::<f64>() * 6.0);
        }
        summary.add_run(run, &scores(values)).unwrap();
    }
    summary
}

#[test]
fn three_shards_merged_equal_one_study_bit_for_bit() {
    let whole = study(42, Shard::WHOLE, 1000);
    let shards: Vec<Summary> = (1..=3)
        .map(|k| study(42, Shard::new(k, 3).unwrap(), 1000))
        .collect();
    for order in [[0, 1, 2], [2, 0, 1], [1, 2, 0]] {
        let mut merged = Summary::default();
        for i in order {
            // Through a file: what `--shard` writes and `merge` reads.
            let text = serde_json::to_string(&shards[i]).unwrap();
            merged.merge(&serde_json::from_str(&text).unwrap()).unwrap();
        }
        assert_eq!(merged, whole);
        assert_eq!(
            serde_json::to_string(&merged).unwrap(),
            serde_json::to_string(&whole).unwrap()
        );
    }
    assert_eq!(whole.run_count(), 1000);
    assert_eq!(whole.runs(), std::slice::from_ref(&(0..1000)));
    let failures: u64 = whole.failures().values().sum();
    assert!((20..=80).contains(&failures), "{failures}");
    // Every successful run's values are kept, in run order, whatever the shard that ran it.
    for metric in ["error", "nees"] {
        let runs = whole.run_values(metric).unwrap().values();
        assert_eq!(runs.len() as u64, 1000 - failures);
        assert!(runs.windows(2).all(|w| w[0].0 < w[1].0));
    }
    let shard_sizes: usize = shards
        .iter()
        .map(|s| s.run_values("error").unwrap().len())
        .sum();
    assert_eq!(shard_sizes as u64, 1000 - failures);
    let nees = whole.series("nees").unwrap().pooled().unwrap();
    assert_eq!(nees.count(), 40 * (1000 - failures));
    // The mean of uniform [0, 6) values, to 4 standard errors.
    let error = (nees.mean().unwrap() - 3.0).abs();
    assert!(
        error < 4.0 * (3.0 / (nees.count() as f64)).sqrt(),
        "{error}"
    );
}

#[test]
fn a_shard_merged_twice_is_refused_and_changes_nothing() {
    let mut merged = study(1, Shard::new(1, 2).unwrap(), 100);
    let before = merged.clone();
    let error = merged
        .merge(&study(1, Shard::new(1, 2).unwrap(), 100))
        .unwrap_err();
    assert!(matches!(error, ExperimentError::Incompatible(_)), "{error}");
    assert!(error.to_string().contains("merged twice"), "{error}");
    assert_eq!(merged, before);
    merged
        .merge(&study(1, Shard::new(2, 2).unwrap(), 100))
        .unwrap();
    assert_eq!(merged, study(1, Shard::WHOLE, 100));
}

#[test]
fn epochs_beyond_the_limit_and_bad_files_are_errors() {
    let mut summary = Summary::new(label(0, 2), 0..2).unwrap();
    let mut series = liebayes_experiments::MetricSeries::default();
    assert!(series.add(MAX_EPOCHS, 1.0).is_err());
    assert!(series.add(usize::MAX, 1.0).is_err());
    assert!(series.epochs().is_empty());
    // A metric summarised one way cannot be merged with the same name summarised another way.
    summary.add_run(0, &scores(vec![1.0, 2.0])).unwrap();
    let mut other = scores(vec![1.0, 2.0]);
    other.metrics[1].reduction = Reduction::Mean;
    let before = summary.clone();
    assert!(matches!(
        summary.add_run(1, &other),
        Err(ExperimentError::Incompatible(_))
    ));
    assert_eq!(summary, before);
    // Summaries of different studies are not merged.
    let mut different = Summary::new(label(1, 1), 0..1).unwrap();
    assert!(different.merge(&summary).is_err());
    for bad in [
        r#"{"runs": [], "series": {}, "scalars": {}, "failures": {}, "timing": {"count": 0, "non_finite": 0, "sum": {"limbs": [], "nan": false, "positive_infinity": false, "negative_infinity": false}, "sum_of_squares": {"limbs": [], "nan": false, "positive_infinity": false, "negative_infinity": false}, "min": null, "max": null}, "extra": 1}"#,
        r#"{"runs": [], "series": {"e": {"epochs": [{"count": 1, "non_finite": 0, "sum": {"limbs": [1], "nan": false, "positive_infinity": false, "negative_infinity": false}, "sum_of_squares": {"limbs": [1], "nan": false, "positive_infinity": false, "negative_infinity": false}, "min": 1.0, "max": 1.0}]}}, "scalars": {}, "failures": {}}"#,
    ] {
        assert!(serde_json::from_str::<Summary>(bad).is_err(), "{bad}");
    }
}

#[test]
fn failure_reasons_are_bounded() {
    let mut summary = Summary::new(label(0, 1000), 0..1000).unwrap();
    for i in 0..1000 {
        summary.add_failure(&format!("reason {i}")).unwrap();
    }
    assert_eq!(summary.failures().len(), 65);
    assert_eq!(summary.failures()["other reasons"], 1000 - 64);
}

#[test]
fn a_trace_with_missing_values_survives_its_file() {
    let mut summary = Summary::new(label(0, 1), 0..1).unwrap();
    summary
        .add_run(0, &scores(vec![f64::NAN, 2.0, 1.5, f64::NAN]))
        .unwrap();
    let text = serde_json::to_string(&summary).unwrap();
    assert!(text.contains("null"), "{text}");
    let back: Summary = serde_json::from_str(&text).unwrap();
    assert_eq!(back, summary);
    assert!(back.trace().unwrap().values[0].is_nan());
}

#[test]
fn a_series_holds_only_the_epochs_added_in_order() {
    let mut series = liebayes_experiments::MetricSeries::default();
    // An index inside 0..2^24 but beyond the epochs held would have to allocate every epoch below it.
    let error = series.add(MAX_EPOCHS - 1, 1.0).unwrap_err();
    assert!(error.to_string().contains("added in order"), "{error}");
    assert!(series.epochs().is_empty());
    series.add(0, 1.0).unwrap();
    series.add(1, 2.0).unwrap();
    series.add(0, 3.0).unwrap();
    assert!(series.add(3, 1.0).is_err());
    assert_eq!(series.epochs().len(), 2);
    assert_eq!(series.epochs()[0].count(), 2);
    assert_eq!(series.epochs()[1].count(), 1);
}

/// A change to a summary's JSON.
type Edit = dyn Fn(&mut serde_json::Value);

/// `summary` through a file with `edit` applied to its JSON: the error, if it is refused.
fn read_edited(
    summary: &Summary,
    edit: impl Fn(&mut serde_json::Value),
) -> Result<Summary, String> {
    let mut json = serde_json::to_value(summary).unwrap();
    edit(&mut json);
    serde_json::from_str(&json.to_string()).map_err(|e| e.to_string())
}

#[test]
fn crafted_summaries_are_refused_naming_the_field() {
    let whole = study(3, Shard::WHOLE, 20);
    assert_eq!(read_edited(&whole, |_| {}).unwrap(), whole);
    let epoch = |j: &mut serde_json::Value| j["metrics"][0]["series"]["epochs"][0].take();
    let cases: [(&str, Box<Edit>); 10] = [
        (
            "flagged NaN",
            Box::new(|j| j["metrics"][0]["series"]["epochs"][0]["sum"]["nan"] = true.into()),
        ),
        (
            "exceed the 20 runs",
            Box::new(|j| {
                j["metrics"][1]["series"]["epochs"][3]["non_finite"] = (u64::MAX / 2).into();
            }),
        ),
        (
            "overflows",
            Box::new(|j| {
                j["times"]["epochs"][0]["count"] = u64::MAX.into();
                j["times"]["epochs"][0]["non_finite"] = 1.into();
            }),
        ),
        (
            "min <= max",
            Box::new(move |j| {
                let mut e = epoch(j);
                let (min, max) = (e["min"].clone(), e["max"].clone());
                e["min"] = max;
                e["max"] = min;
                j["metrics"][0]["series"]["epochs"][0] = e;
            }),
        ),
        (
            "strictly increasing",
            Box::new(|j| j["trace"]["times"][2] = j["trace"]["times"][1].clone()),
        ),
        (
            "appears twice",
            Box::new(|j| j["metrics"][1]["name"] = "error".into()),
        ),
        (
            "runs: range 0..30",
            Box::new(|j| j["runs"][0]["end"] = 30.into()),
        ),
        (
            "failures: more failed runs",
            Box::new(|j| j["failures"]["diverged"] = 21.into()),
        ),
        (
            "timing",
            Box::new(|j| j["timing"]["non_finite"] = 20.into()),
        ),
        (
            "sum_of_large_squares is not zero",
            Box::new(move |j| {
                let mut e = epoch(j);
                e["sum_of_large_squares"] = e["sum_of_squares"].clone();
                j["metrics"][0]["series"]["epochs"][0] = e;
            }),
        ),
    ];
    for (field, edit) in cases {
        let error = read_edited(&whole, edit).unwrap_err();
        assert!(error.contains(field), "{field}: {error}");
    }
}

/// One run's scores of the named metrics (each a root mean square, not per run), one epoch at
/// t = 0, with the given values.
fn named(metrics: &[&'static str], values: Vec<f64>) -> RunScores {
    RunScores {
        metrics: metrics
            .iter()
            .map(|&name| Metric::new(name, Reduction::RootMeanSquare, ""))
            .collect(),
        times: vec![0.0],
        values,
        seconds_per_step: 1e-6,
    }
}

/// The value of metric `name` in a summary's trace at epoch 0.
fn traced(summary: &Summary, name: &str) -> f64 {
    let j = summary
        .metrics()
        .iter()
        .position(|m| m.name == name)
        .unwrap();
    summary.trace().unwrap().values[j]
}

#[test]
fn a_metric_first_seen_after_run_0_widens_the_trace() {
    let mut summary = Summary::new(label(0, 2), 0..2).unwrap();
    summary.add_run(0, &named(&["error"], vec![1.0])).unwrap();
    summary
        .add_run(1, &named(&["error", "nis"], vec![2.0, 3.0]))
        .unwrap();
    let trace = summary.trace().unwrap();
    assert_eq!(trace.values.len(), 2);
    assert_eq!(traced(&summary, "error"), 1.0);
    assert!(traced(&summary, "nis").is_nan());
    let back: Summary = serde_json::from_str(&serde_json::to_string(&summary).unwrap()).unwrap();
    assert_eq!(back, summary);
}

#[test]
fn a_merge_puts_the_trace_values_under_their_names() {
    let mut first = Summary::new(label(0, 2), 0..1).unwrap();
    first
        .add_run(0, &named(&["error", "nees"], vec![1.0, 2.0]))
        .unwrap();
    let mut second = Summary::new(label(0, 2), 1..2).unwrap();
    second
        .add_run(1, &named(&["nees", "error", "extra"], vec![5.0, 6.0, 7.0]))
        .unwrap();
    // The other's trace, reordered and widened to this summary's metrics.
    let mut merged = second.clone();
    merged.merge(&first).unwrap();
    // This summary's trace, widened by the metric the other brings.
    let mut other_way = first.clone();
    other_way.merge(&second).unwrap();
    for summary in [&merged, &other_way] {
        assert_eq!(summary.trace().unwrap().values.len(), 3);
        assert_eq!(traced(summary, "error"), 1.0);
        assert_eq!(traced(summary, "nees"), 2.0);
        assert!(traced(summary, "extra").is_nan());
        let text = serde_json::to_string(summary).unwrap();
        assert_eq!(&serde_json::from_str::<Summary>(&text).unwrap(), summary);
    }
}

#[test]
fn a_failure_beyond_the_runs_covered_is_refused() {
    let mut summary = Summary::new(label(0, 2), 0..2).unwrap();
    summary.add_run(0, &named(&["error"], vec![1.0])).unwrap();
    summary.add_failure("diverged").unwrap();
    let before = summary.clone();
    let error = summary.add_failure("diverged").unwrap_err();
    assert!(matches!(error, ExperimentError::Incompatible(_)), "{error}");
    assert_eq!(summary, before);
    assert_eq!(summary.failure_count(), 1);
    let text = serde_json::to_string(&summary).unwrap();
    assert_eq!(serde_json::from_str::<Summary>(&text).unwrap(), summary);
}

#[test]
fn a_run_of_more_epochs_than_a_study_holds_is_refused() {
    let epochs = MAX_STUDY_EPOCHS + 1;
    let long = RunScores {
        metrics: vec![Metric::new("error", Reduction::RootMeanSquare, "")],
        times: (0..epochs).map(|k| k as f64).collect(),
        values: vec![1.0; epochs],
        seconds_per_step: 1e-6,
    };
    let mut summary = Summary::new(label(0, 1), 0..1).unwrap();
    let error = summary.add_run(0, &long).unwrap_err();
    assert!(
        matches!(
            error,
            ExperimentError::OutOfRange {
                what: "number of epochs",
                ..
            }
        ),
        "{error}"
    );
    assert_eq!(summary, Summary::new(label(0, 1), 0..1).unwrap());
    let mut series = liebayes_experiments::MetricSeries::default();
    for k in 0..MAX_STUDY_EPOCHS {
        series.add(k, 1.0).unwrap();
    }
    assert!(series.add(MAX_STUDY_EPOCHS, 1.0).is_err());
    // Nor does the reader take a longer series than add_run builds.
    summary.add_run(0, &named(&["error"], vec![1.0])).unwrap();
    let error = read_edited(&summary, |json| {
        let epochs = json["metrics"][0]["series"]["epochs"]
            .as_array_mut()
            .unwrap();
        let first = epochs[0].clone();
        epochs.resize(MAX_STUDY_EPOCHS + 1, first);
    })
    .unwrap_err();
    assert!(error.contains("more than the limit of 16384"), "{error}");
}

#[test]
fn a_summary_of_runs_outside_its_study_is_refused() {
    let error = Summary::new(label(0, 2), 1..3).unwrap_err();
    assert!(
        matches!(error, ExperimentError::OutOfRange { .. }) && error.to_string().contains("1..3"),
        "{error}"
    );
    assert!(Summary::new(label(0, 2), 0..2).is_ok());
    // An empty range covers nothing, wherever it starts.
    assert_eq!(Summary::new(label(0, 2), 5..5).unwrap().run_count(), 0);
}

/// A metric series read on its own (not inside a summary) took any number of epochs;
/// it is refused at the first epoch beyond 2^14, with the limit in the message.
#[test]
fn a_metric_series_read_on_its_own_holds_at_most_2_14_epochs() {
    let mut series = liebayes_experiments::MetricSeries::default();
    series.add(0, 1.0).unwrap();
    let mut json = serde_json::to_value(&series).unwrap();
    let epochs = json["epochs"].as_array_mut().unwrap();
    let first = epochs[0].clone();
    epochs.resize(MAX_STUDY_EPOCHS, first.clone());
    let full: liebayes_experiments::MetricSeries = serde_json::from_value(json.clone()).unwrap();
    assert_eq!(full.epochs().len(), MAX_STUDY_EPOCHS);
    json["epochs"].as_array_mut().unwrap().push(first);
    let error = serde_json::from_str::<liebayes_experiments::MetricSeries>(&json.to_string())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("metric series") && error.contains("more than the limit of 16384"),
        "{error}"
    );
}

/// The JSON of a summary of `runs` runs (0..runs of as many), every one successful with the
/// given number of epochs.
fn successful(runs: u64, epochs: usize) -> serde_json::Value {
    let mut summary = Summary::new(label(0, runs), 0..runs).unwrap();
    for run in 0..runs {
        let values = (0..2 * epochs).map(|i| 1.0 + i as f64).collect();
        summary.add_run(run, &scores(values)).unwrap();
    }
    serde_json::to_value(&summary).unwrap()
}

/// A summary's fields were checked each against the runs covered, never
/// against each other, so a `times` series shorter than the metrics (moving every "final epoch"
/// figure) or failures that the values held contradict were read and reported. Each is refused
/// when read, naming the field.
#[test]
fn counts_that_disagree_across_fields_are_refused_naming_the_field() {
    let read = |json: &serde_json::Value| serde_json::from_value::<Summary>(json.clone());
    let four = successful(4, 3);
    read(&four).unwrap();
    let two = successful(2, 3);
    let empty_timing = serde_json::to_value(liebayes_experiments::RunningStats::new()).unwrap();
    let cases: [(&str, Box<Edit>); 5] = [
        (
            "metric \"error\": its series has 3 epochs, more than the 1 of times",
            Box::new(|j| j["times"]["epochs"].as_array_mut().unwrap().truncate(1)),
        ),
        (
            "times, epoch 0: count 4 is more than the 0 successful runs",
            Box::new(move |j| {
                j["failures"] = serde_json::json!({"diverged": 4});
                j["timing"] = empty_timing.clone();
            }),
        ),
        (
            "metric \"error\", epoch 0: count 4 and non_finite 0 are more values than the 2 runs",
            Box::new(move |j| j["times"] = two["times"].clone()),
        ),
        (
            "times, epoch 1: count 4 is more than the 2 of epoch 0",
            Box::new(|j| {
                j["times"]["epochs"][0] = successful(2, 3)["times"]["epochs"][0].clone();
            }),
        ),
        (
            "trace: 3 epochs, more than the 2 of times",
            Box::new(|j| {
                j["times"]["epochs"].as_array_mut().unwrap().truncate(2);
                for m in 0..2 {
                    j["metrics"][m]["series"]["epochs"]
                        .as_array_mut()
                        .unwrap()
                        .truncate(2);
                }
            }),
        ),
    ];
    for (field, edit) in cases {
        let mut json = four.clone();
        edit(&mut json);
        let error = read(&json).unwrap_err().to_string();
        assert!(error.contains(field), "{field}: {error}");
    }
}

/// `runs` failed runs from `first`, each under its own reason `{prefix}{i:02}`.
fn failed(prefix: &str, first: u64, runs: u64, total: u64) -> Summary {
    let mut summary = Summary::new(label(0, total), first..first + runs).unwrap();
    for i in 0..runs {
        summary.add_failure(&format!("{prefix}{i:02}")).unwrap();
    }
    summary
}

/// Beyond 64 distinct failure reasons, the reasons kept were the first met,
/// so `merge A B` and `merge B A` gave different summaries (and a parallel study depended on its
/// scheduling). The first 64 in byte order are kept: every order gives the same JSON, bit for bit.
#[test]
fn merges_in_either_order_keep_the_same_failure_reasons() {
    let (a, b) = (failed("b", 0, 64, 128), failed("a", 64, 64, 128));
    let mut ab = a.clone();
    ab.merge(&b).unwrap();
    let mut ba = b.clone();
    ba.merge(&a).unwrap();
    let json = |s: &Summary| serde_json::to_string(s).unwrap();
    assert_eq!(json(&ab), json(&ba));
    assert_eq!(ab.failures().len(), 65);
    assert_eq!(ab.failures()["other reasons"], 64);
    assert!(
        ab.failures()
            .keys()
            .filter(|k| *k != "other reasons")
            .all(|k| k.starts_with('a'))
    );
    // Three parts in every order, and one summary failing in the reverse order: the same.
    let parts = [
        failed("c", 0, 40, 120),
        failed("a", 40, 40, 120),
        failed("b", 80, 40, 120),
    ];
    let mut merged = Vec::new();
    for order in [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ] {
        let mut m = Summary::default();
        for i in order {
            m.merge(&parts[i]).unwrap();
        }
        merged.push(json(&m));
    }
    let mut one = Summary::new(label(0, 120), 0..120).unwrap();
    for prefix in ["c", "b", "a"] {
        for i in (0..40).rev() {
            one.add_failure(&format!("{prefix}{i:02}")).unwrap();
        }
    }
    merged.push(json(&one));
    assert!(merged.iter().all(|m| *m == merged[0]), "{merged:?}");
    // Read back, the summary merges the same way.
    let back: Summary = serde_json::from_str(&merged[0]).unwrap();
    assert_eq!(json(&back), merged[0]);
}

/// Pooling epochs whose counts sum beyond `u64::MAX` saturated the
/// count. `pooled` refuses it with a typed error.
#[test]
fn pooling_beyond_u64_max_values_is_refused() {
    let half = 1_u64 << 63;
    let sum: liebayes_experiments::ExactSum = [half as f64].into_iter().collect();
    let epoch = serde_json::json!({
        "count": half, "non_finite": 0, "sum": sum, "sum_of_squares": sum,
        "min": 1.0, "max": 1.0,
    });
    let series: liebayes_experiments::MetricSeries =
        serde_json::from_value(serde_json::json!({ "epochs": [epoch, epoch] })).unwrap();
    let error = series.pooled().unwrap_err();
    assert!(
        matches!(error, ExperimentError::OutOfRange { .. })
            && error.to_string().contains("count plus non_finite"),
        "{error}"
    );
    // Either epoch alone pools.
    let one: liebayes_experiments::MetricSeries =
        serde_json::from_value(serde_json::json!({ "epochs": [epoch] })).unwrap();
    let pooled = one.pooled().unwrap();
    assert_eq!((pooled.count(), pooled.mean()), (half, Some(1.0)));
    // Merging the series with itself is refused the same way, and leaves it unchanged.
    let mut merged = series.clone();
    assert!(merged.merge(&series).is_err());
    assert_eq!(merged, series);
}

/// A summary's failures, an exact sum's limbs, a series' epochs and a
/// trace's times are refused at their first element beyond their limit, where they stood (the
/// same error for a file far longer), instead of being built whole and refused after.
#[test]
fn long_fields_are_refused_at_their_first_element_beyond_the_limit() {
    let summary = failed("reason ", 0, 3, 3);
    let with = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut json = serde_json::to_value(&summary).unwrap();
        edit(&mut json);
        serde_json::from_str::<Summary>(&json.to_string())
            .unwrap_err()
            .to_string()
    };
    let reasons = |n: usize| {
        move |j: &mut serde_json::Value| {
            for i in 0..n {
                j["failures"][format!("{i:06}")] = 0.into();
            }
        }
    };
    let errors = [with(&reasons(66)), with(&reasons(100_000))];
    assert!(
        errors[0].contains("failures") && errors[0].contains("more than the limit of 65"),
        "{}",
        errors[0]
    );
    assert_eq!(errors[0], errors[1]);
    let times = |n: usize| {
        move |j: &mut serde_json::Value| {
            j["trace"] = serde_json::json!({
                "run": 0,
                "times": (0..n).map(|k| k as f64).collect::<Vec<_>>(),
                "values": [],
            });
        }
    };
    let errors = [with(&times(MAX_STUDY_EPOCHS + 1)), with(&times(100_000))];
    assert!(
        errors[0].contains("trace's times") && errors[0].contains("more than the limit of 16384"),
        "{}",
        errors[0]
    );
    assert_eq!(errors[0], errors[1]);
}

/// `n` distinct metric names from `first` on (leaked: a metric's name is `'static`).
fn metric_names(first: usize, n: usize) -> Vec<&'static str> {
    (first..first + n)
        .map(|i| &*Box::leak(format!("metric{i:04}").into_boxed_str()))
        .collect()
}

/// A summary holds at most `MAX_METRICS` metrics, however they come: a crafted shard of 10 000
/// metrics made a merge take minutes (and its trace, epochs by metrics, could ask for gigabytes).
/// A run, a merge or a file beyond the limit is refused, the summary left as it was; a file's
/// trace values are refused at the first beyond 2^14 epochs of `MAX_METRICS` metrics.
#[test]
fn a_summary_holds_at_most_max_metrics() {
    let names = metric_names(0, MAX_METRICS + 2);
    let mut summary = Summary::new(label(0, 2), 0..2).unwrap();
    let before = summary.clone();
    let error = summary
        .add_run(
            0,
            &named(&names[..=MAX_METRICS], vec![1.0; MAX_METRICS + 1]),
        )
        .unwrap_err();
    assert!(error.to_string().contains("MAX_METRICS = 256"), "{error}");
    assert_eq!(summary, before);
    let half = MAX_METRICS / 2 + 1;
    let mut a = Summary::new(label(0, 2), 0..1).unwrap();
    a.add_run(0, &named(&names[..half], vec![1.0; half]))
        .unwrap();
    let mut b = Summary::new(label(0, 2), 1..2).unwrap();
    b.add_run(1, &named(&names[half..2 * half], vec![1.0; half]))
        .unwrap();
    let kept = a.clone();
    let error = a.merge(&b).unwrap_err();
    assert!(error.to_string().contains("number of metrics"), "{error}");
    assert_eq!(a, kept);
    // Through a file: the metrics beyond the limit, and a trace of more values than it can hold.
    let mut json = serde_json::to_value(&kept).unwrap();
    let metric = json["metrics"][0].clone();
    let metrics = json["metrics"].as_array_mut().unwrap();
    while metrics.len() <= MAX_METRICS {
        let mut m = metric.clone();
        m["name"] = format!("extra{}", metrics.len()).into();
        metrics.push(m);
    }
    let error = serde_json::from_str::<Summary>(&json.to_string()).unwrap_err();
    assert!(
        error.to_string().contains("a summary's metrics") && error.to_string().contains("256"),
        "{error}"
    );
    let mut json = serde_json::to_value(&kept).unwrap();
    json["trace"]["values"] = serde_json::json!([]);
    let values = vec!["0"; MAX_STUDY_EPOCHS * MAX_METRICS + 1].join(",");
    let text = json
        .to_string()
        .replacen("\"values\":[]", &format!("\"values\":[{values}]"), 1);
    let error = serde_json::from_str::<Summary>(&text).unwrap_err();
    assert!(error.to_string().contains("a trace's values"), "{error}");
}
