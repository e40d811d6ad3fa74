//! The table of a report: each reduction's figure against its formula computed by hand, shards
//! merging to the whole bit for bit (and the same shard twice refused, the table unchanged),
//! malformed tables refused, and the run-by-run comparison against quantiles computed by hand.

use liebayes_experiments::{
    Column, ExperimentError, Figure, Metric, Reduction, RunScores, RunningStats, StudyLabel,
    Summary, Table,
};
use liebayes_operators::evaluation::average_nees_band;
use std::ops::Range;

/// The statistics of `values`.
fn stats(values: &[f64]) -> RunningStats {
    let mut s = RunningStats::new();
    for &v in values {
        s.add(v);
    }
    s
}

#[test]
fn figures_follow_their_reduction() {
    let values = [0.3, -1.2, 2.5, 0.7, -0.1];
    let n = values.len() as f64;
    let s = stats(&values);
    let rms = (values.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
    assert!(
        matches!(Reduction::RootMeanSquare.figure(&s), Figure::Rms(r) if (r - rms).abs() < 1e-15)
    );
    let mean = values.iter().sum::<f64>() / n;
    let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let Figure::Mean(m, Some((l, h))) = Reduction::Mean.figure(&s) else {
        panic!("a mean with a band")
    };
    assert!((m - mean).abs() < 1e-15);
    assert!((h - l - 2.0 * 1.959_964 * sd / n.sqrt()).abs() < 1e-6);
    let Figure::Mean(_, band) = Reduction::ChiSquare { dof: 2 }.figure(&s) else {
        panic!("a mean")
    };
    assert_eq!(band, average_nees_band(2, 5).ok());
    let rate = stats(&[1.0, 0.0, 0.0, 1.0]);
    assert_eq!(Reduction::Rate.figure(&rate), Figure::Percent(50.0));
    // A "rate" far beyond 1 has no finite percent: Empty, not Percent(inf).
    assert_eq!(Reduction::Rate.figure(&stats(&[1e307])), Figure::Empty);
    assert_eq!(Reduction::Mean.figure(&stats(&[f64::NAN])), Figure::Empty);
    assert_eq!(
        Reduction::Mean.figure(&stats(&[4.0])),
        Figure::Mean(4.0, None)
    );
}

/// A summary of `runs` of a synthetic two-metric study: run r scores error r, sigma 1 at epochs
/// t = 1, 2.
fn summary(name: &str, runs: Range<u64>, total: u64) -> Summary {
    let label = StudyLabel {
        name: name.to_owned(),
        seed: 7,
        runs: total,
    };
    let mut s = Summary::new(label, runs.clone()).unwrap();
    for r in runs {
        let scores = RunScores {
            metrics: vec![
                Metric::new("x_error", Reduction::RootMeanSquare, "m"),
                Metric::new("x_sigma", Reduction::RootMeanSquare, "m"),
                Metric::new("diverged", Reduction::Rate, ""),
            ],
            times: vec![1.0, 2.0],
            values: vec![r as f64, 1.0, 0.0, r as f64, 1.0, 1.0],
            seconds_per_step: 1e-8,
        };
        s.add_run(r, &scores).unwrap();
    }
    s
}

fn table(summaries: Vec<Summary>) -> Table {
    Table::new("synthetic", "Synthetic", summaries, None).unwrap()
}

#[test]
fn columns_and_figures_are_read_from_the_rows() {
    let t = table(vec![summary("A", 0..3, 3)]);
    let columns = t.columns();
    let headings: Vec<String> = columns.iter().map(Column::heading).collect();
    assert_eq!(headings, ["x_error (m)", "x_sigma (m)", "diverged"]);
    // RMS of 0, 1, 2 is sqrt(5/3); every run diverged at the second epoch, none at the first.
    let s = &t.summaries[0];
    assert_eq!(columns[0].figure(s, 1), Figure::Rms((5.0_f64 / 3.0).sqrt()));
    assert_eq!(columns[2].figure(s, 0), Figure::Percent(0.0));
    assert_eq!(columns[2].figure(s, 1), Figure::Percent(100.0));
    assert_eq!(columns[2].figure(s, 2), Figure::Empty);
}

#[test]
fn shards_merge_to_the_whole_and_twice_is_refused() {
    let whole = table(vec![summary("A", 0..10, 10)]);
    let mut merged = table(vec![summary("A", 0..4, 10)]);
    let missing =
        |t: &Table| -> Vec<String> { t.missing_runs().iter().map(ToString::to_string).collect() };
    assert_eq!(missing(&merged), ["synthetic A: runs 4..10 of 10"]);
    merged.merge(&table(vec![summary("A", 7..10, 10)])).unwrap();
    assert_eq!(missing(&merged), ["synthetic A: runs 4..7 of 10"]);
    let before = merged.clone();
    let twice = merged.merge(&table(vec![summary("A", 7..10, 10)]));
    assert!(
        matches!(&twice, Err(ExperimentError::Incompatible(m)) if m.starts_with("table synthetic, row A")),
        "{twice:?}"
    );
    assert!(merged.merge(&table(vec![summary("B", 4..7, 10)])).is_err());
    let mut retitled = table(vec![summary("A", 4..7, 10)]);
    retitled.title = "Other settings".to_owned();
    assert!(merged.merge(&retitled).is_err());
    assert_eq!(merged, before);
    merged.merge(&table(vec![summary("A", 4..7, 10)])).unwrap();
    assert!(merged.missing_runs().is_empty());
    // Everything but the measured timing is the whole study's, bit for bit.
    assert_eq!(
        serde_json::to_value(merged.summaries[0].metrics()).unwrap(),
        serde_json::to_value(whole.summaries[0].metrics()).unwrap()
    );
    assert_eq!(merged.summaries[0].trace(), whole.summaries[0].trace());
}

#[test]
fn many_missing_ranges_are_listed_up_to_four() {
    let mut t = table(vec![summary("A", 0..1, 20)]);
    for start in [3, 6, 9, 12, 15] {
        t.merge(&table(vec![summary("A", start..start + 1, 20)]))
            .unwrap();
    }
    let text = t.missing_runs()[0].to_string();
    assert_eq!(
        text,
        "synthetic A: runs 1..3, 4..6, 7..9, 10..12, and 2 more ranges of 20"
    );
}

#[test]
fn malformed_tables_are_refused() {
    for name in ["../escape", "", ".hidden", "a b", &"x".repeat(101)] {
        let error = Table::new(name, "t", vec![summary("A", 0..3, 3)], None).unwrap_err();
        assert!(matches!(error, ExperimentError::Invalid(_)), "{error}");
    }
    let error = Table::new("t", "t", vec![summary("A", 0..3, 3)], Some(1)).unwrap_err();
    assert!(error.to_string().contains("reference row 1"), "{error}");
    let mut json = serde_json::to_value(table(vec![summary("A", 0..3, 3)])).unwrap();
    json["summaries"][0]["runs"] = serde_json::json!([{ "start": 2, "end": 1 }]);
    // A summary is checked when read.
    let reversed = serde_json::from_value::<Table>(json.clone()).unwrap_err();
    assert!(reversed.to_string().contains("range 2..1"), "{reversed}");
    json["summaries"][0]["runs"] = serde_json::json!([{ "start": 0, "end": 3 }]);
    json["summaries"][0]["trace"]["values"] = serde_json::json!([1.0]);
    let short = serde_json::from_value::<Table>(json).unwrap_err();
    assert!(short.to_string().contains("trace: 1 values"), "{short}");
}

/// A summary of `runs` of a study with a per-run RMS error: run r scores `error(r)` at both of
/// its two epochs (so its run value is `error(r)`), and a mean that is not kept per run.
fn per_run_summary(
    name: &str,
    runs: Range<u64>,
    total: u64,
    error: impl Fn(u64) -> f64,
) -> Summary {
    let label = StudyLabel {
        name: name.to_owned(),
        seed: 7,
        runs: total,
    };
    let mut s = Summary::new(label, runs.clone()).unwrap();
    for r in runs {
        let scores = RunScores {
            metrics: vec![
                Metric::new("x_error", Reduction::RootMeanSquare, "m").per_run(),
                Metric::new("bias", Reduction::Mean, "m"),
            ],
            times: vec![1.0, 2.0],
            values: vec![error(r), 0.5, -error(r), 0.5],
            seconds_per_step: 1e-8,
        };
        s.add_run(r, &scores).unwrap();
    }
    s
}

/// Rows A (run r: error r + 1), B (1.5 times A's) and C ((r + 1)², so 100 r % above A), of the
/// runs `runs` of 10, compared with `reference`.
fn compared(runs: Range<u64>, reference: Option<usize>) -> Table {
    let one = |r: u64| (r + 1) as f64;
    let rows = vec![
        per_run_summary("A", runs.clone(), 10, one),
        per_run_summary("B", runs.clone(), 10, move |r| 1.5 * one(r)),
        per_run_summary("C", runs, 10, move |r| one(r) * one(r)),
    ];
    Table::new("synthetic", "Synthetic", rows, reference).unwrap()
}

#[test]
fn rows_are_compared_with_the_reference_run_by_run() {
    let comparisons = compared(0..10, Some(0)).run_comparisons();
    assert_eq!(comparisons.len(), 1, "only x_error is kept per run");
    let c = &comparisons[0];
    assert_eq!((c.metric.as_str(), c.kind()), ("x_error", "relative"));
    assert_eq!(c.reference.as_deref(), Some("A"));
    assert_eq!(
        c.describe(),
        "percentage difference of x_error from A, per run (%)"
    );
    assert_eq!(c.rows.len(), 2);
    // B: 50 % above A on every run.
    let (label, q, n) = &c.rows[0];
    assert_eq!((label.as_str(), *n), ("B", 10));
    assert!(q.iter().all(|v| (v - 50.0).abs() < 1e-12), "{q:?}");
    // C: 0, 100, …, 900 %; type-7 quantiles at h = 9 p: 0, 45, 225, 450, 675, 855, 900.
    let (label, q, n) = &c.rows[1];
    assert_eq!((label.as_str(), *n), ("C", 10));
    let expected = [0.0, 45.0, 225.0, 450.0, 675.0, 855.0, 900.0];
    for (v, e) in q.iter().zip(expected) {
        assert!((v - e).abs() < 1e-9, "{q:?}");
    }
    // Without a reference: the run values themselves, every row.
    let c = &compared(0..10, None).run_comparisons()[0];
    assert_eq!(
        (c.kind(), c.unit.as_str(), c.rows.len()),
        ("per_run", "m", 3)
    );
    assert_eq!(c.describe(), "x_error per run (m)");
    // A's values 1, …, 10: median 5.5.
    assert_eq!(c.rows[0].1[3], 5.5);
}

#[test]
fn merged_shards_compare_as_the_whole() {
    let whole = compared(0..10, Some(1));
    let mut merged = compared(6..10, Some(1));
    merged.merge(&compared(0..3, Some(1))).unwrap();
    merged.merge(&compared(3..6, Some(1))).unwrap();
    assert!(merged.missing_runs().is_empty());
    assert_eq!(merged.run_comparisons(), whole.run_comparisons());
    // Through a file, with the reference row.
    let text = serde_json::to_string(&merged).unwrap();
    assert!(text.contains(r#""reference":1"#), "{text}");
    let back: Table = serde_json::from_str(&text).unwrap();
    assert_eq!(back.run_comparisons(), whole.run_comparisons());
    // Shards compared with different rows do not merge.
    let mut other = compared(0..3, Some(0));
    let before = other.clone();
    let error = other.merge(&compared(3..6, Some(1))).unwrap_err();
    assert!(error.to_string().contains("reference row"), "{error}");
    assert_eq!(other, before);
    // A metric kept per run whose name cannot name a file is refused (here as it is read).
    let mut json = serde_json::to_value(compared(0..10, None)).unwrap();
    json["summaries"][0]["metrics"][0]["name"] = serde_json::json!("a/b");
    let error = serde_json::from_value::<Table>(json).unwrap_err();
    assert!(error.to_string().contains("\"a/b\""), "{error}");
}

/// A table with no rows, or with a row of a study of 0 runs, was accepted
/// and reported as a complete study (no runs missing). It is refused by `validate`, so when it is
/// built and when a reader checks a file, naming the field.
#[test]
fn a_table_without_rows_or_with_a_row_of_0_runs_is_refused() {
    let error = Table::new("empty", "Empty", Vec::new(), None).unwrap_err();
    assert!(
        matches!(&error, ExperimentError::Invalid(m) if m.contains("table empty: summaries is empty")),
        "{error}"
    );
    let no_runs = StudyLabel {
        name: "A".to_owned(),
        seed: 7,
        runs: 0,
    };
    let row = Summary::new(no_runs, 0..0).unwrap();
    let error = Table::new("zero", "Zero", vec![row.clone()], None).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("table zero, row A: label.runs is 0"),
        "{error}"
    );
    // Read from a file, a table is checked as `Table::new` checks it: both are refused, and so
    // are a name that is no plain file name and a reference past the rows.
    let good = Summary::new(
        StudyLabel {
            name: "A".to_owned(),
            seed: 7,
            runs: 1,
        },
        0..1,
    )
    .unwrap();
    for (name, summaries, reference, field) in [
        ("t", vec![], None, "summaries is empty"),
        ("t", vec![row], None, "label.runs is 0"),
        ("../../x", vec![good.clone()], None, "not a plain name"),
        ("t", vec![good], Some(7), "reference row 7"),
    ] {
        let file = serde_json::json!({
            "name": name, "title": "T", "summaries": summaries, "reference": reference,
        });
        let error = serde_json::from_value::<Table>(file)
            .unwrap_err()
            .to_string();
        assert!(error.contains(field), "{field}: {error}");
    }
}

/// Through tables: two shards whose failures hold more distinct reasons than
/// a summary keeps merge to the same table, bit for bit, in either order.
#[test]
fn table_shards_merge_to_the_same_json_in_either_order() {
    let shard = |runs: Range<u64>, prefix: &str| {
        let label = StudyLabel {
            name: "A".to_owned(),
            seed: 7,
            runs: 200,
        };
        let mut s = Summary::new(label, runs.clone()).unwrap();
        for r in runs {
            s.add_failure(&format!("{prefix} at step {r}")).unwrap();
        }
        Table::new("failing", "Failing", vec![s], None).unwrap()
    };
    let (first, second) = (
        shard(0..100, "not positive definite"),
        shard(100..200, "diverged"),
    );
    let mut ab = first.clone();
    ab.merge(&second).unwrap();
    let mut ba = second;
    ba.merge(&first).unwrap();
    assert_eq!(
        serde_json::to_string(&ab).unwrap(),
        serde_json::to_string(&ba).unwrap()
    );
    assert_eq!(ab.summaries[0].failures()["other reasons"], 200 - 64);
}
