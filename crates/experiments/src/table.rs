//! A table of studies: the rows one report compares (one [`Summary`] per filter), its checks, the
//! exact merge of its shards, the runs it misses, its columns and figures, and the run-by-run
//! comparison of its rows. A renderer (text, CSV, plots) reads everything it shows from here.

use crate::run_values::{MAX_KEPT_RUNS, quantiles, relative_differences};
use crate::score::{Figure, Reduction};
use crate::study::MAX_RUNS;
use crate::{ExperimentError, RunningStats, Summary};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::ops::Range;

/// The longest table name.
pub const MAX_NAME_LEN: usize = 100;

/// The studies of one report: a name (`azimuth_circle`, the stem of its files), a title describing
/// the settings, one summary per row (row label: the summary's study name, for example `"EKF"`), and
/// optionally the row the others are compared with run by run. Shards of a table merge
/// ([`Table::merge`]) only when their names, titles, row labels and reference rows agree.
///
/// # Example
/// Two shards of one study merge to the whole, and a table says which runs it still misses:
/// ```
/// use liebayes_experiments::{Metric, Reduction, RunScores, StudyLabel, Summary, Table};
///
/// let shard = |runs: std::ops::Range<u64>| -> Summary {
///     let label = StudyLabel { name: "EKF".into(), seed: 7, runs: 10 };
///     let mut s = Summary::new(label, runs.clone()).unwrap();
///     for r in runs {
///         let scores = RunScores {
///             metrics: vec![Metric::new("x_error", Reduction::RootMeanSquare, "m")],
///             times: vec![1.0],
///             values: vec![r as f64],
///             seconds_per_step: 1e-8,
///         };
///         s.add_run(r, &scores).unwrap();
///     }
///     s
/// };
/// let table = |runs| Table::new("demo", "A demonstration", vec![shard(runs)], None);
/// let mut merged = table(0..4)?;
/// merged.merge(&table(7..10)?)?;
/// assert_eq!(merged.missing_runs()[0].to_string(), "demo EKF: runs 4..7 of 10");
/// assert!(merged.merge(&table(7..10)?).is_err()); // the same shard twice
/// merged.merge(&table(4..7)?)?;
/// assert!(merged.missing_runs().is_empty());
/// # Ok::<(), liebayes_experiments::ExperimentError>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TableFields")]
pub struct Table {
    /// The stem of the table's file names: a plain name (ASCII letters, digits, `_`, `-`, `.`).
    pub name: String,
    /// What was studied, with its settings (the printed table's heading, the plots' titles).
    pub title: String,
    /// One summary per row.
    pub summaries: Vec<Summary>,
    /// The row (an index into `summaries`) the other rows are compared with, run by run: for
    /// each metric kept per run, the report gives the quantiles of every other row's percentage
    /// difference from this row's value on the same run (same simulated data), `100 (v / v_ref −
    /// 1)`. `None`: the quantiles of each row's run values themselves.
    pub reference: Option<usize>,
}

/// The serialized form of [`Table`], checked as [`Table::new`] checks a table when converted.
#[derive(Deserialize)]
#[serde(rename = "Table", deny_unknown_fields)]
struct TableFields {
    name: String,
    title: String,
    summaries: Vec<Summary>,
    reference: Option<usize>,
}

impl TryFrom<TableFields> for Table {
    type Error = String;

    fn try_from(f: TableFields) -> Result<Self, String> {
        Self::new(&f.name, &f.title, f.summaries, f.reference).map_err(|e| e.to_string())
    }
}

impl Table {
    /// A table, checked ([`Table::validate`]); a table read from a file is checked the same way.
    ///
    /// # Errors
    /// As [`Table::validate`].
    pub fn new(
        name: &str,
        title: &str,
        summaries: Vec<Summary>,
        reference: Option<usize>,
    ) -> Result<Self, ExperimentError> {
        let table = Self {
            name: name.to_owned(),
            title: title.to_owned(),
            summaries,
            reference,
        };
        table.validate()?;
        Ok(table)
    }

    /// Checks what a table must satisfy before it is reported (built in code or read from a file):
    /// a plain name of at most [`MAX_NAME_LEN`] characters not starting with `.`, at least one row,
    /// a reference row among its rows, metrics kept per run with plain names (they name files), run
    /// ranges sorted, disjoint and inside the study, a study of 1 to [`MAX_RUNS`] runs in each row,
    /// and a trace with one value per metric and epoch.
    ///
    /// A table without rows, or with a row of a study of 0 runs, is refused here, so when it is
    /// read (a reader runs this check on every file, as the command line's `merge` does) and when
    /// it is built ([`Table::new`]): no study has such rows ([`Study::new`](crate::Study::new)
    /// refuses 0 runs), and [`missing_runs`](Self::missing_runs) would call it complete.
    ///
    /// # Errors
    /// [`ExperimentError::Invalid`] naming the table, the row and what is wrong.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        let invalid = |what: String| Err(ExperimentError::Invalid(format!("table {what}")));
        if !is_plain_name(&self.name) {
            return invalid(format!(
                "name {:?} is not a plain name (1 to {MAX_NAME_LEN} ASCII letters, digits, '_', \
                 '-' or '.', not starting with '.')",
                self.name
            ));
        }
        if self.summaries.is_empty() {
            return invalid(format!(
                "{}: summaries is empty, but a table has at least one row (one study per \
                 filter compared)",
                self.name
            ));
        }
        if let Some(r) = self.reference {
            if r >= self.summaries.len() {
                return invalid(format!(
                    "{}: the reference row {r} is not one of its {} rows (0 to {})",
                    self.name,
                    self.summaries.len(),
                    self.summaries.len() - 1
                ));
            }
        }
        for metric in self.per_run_metrics() {
            if !is_plain_name(&metric) {
                return invalid(format!(
                    "{}: metric {metric:?} is kept per run but its name is not plain (ASCII \
                     letters, digits, '_', '-' or '.'): it names a file",
                    self.name
                ));
            }
        }
        for s in &self.summaries {
            let label = s.label();
            let bad = |what: String| invalid(format!("{}, row {}: {what}", self.name, label.name));
            if label.runs == 0 || label.runs > MAX_RUNS {
                return bad(format!(
                    "label.runs is {}, outside [1, {MAX_RUNS}] (a study has at least one run)",
                    label.runs
                ));
            }
            let mut end = 0;
            for r in s.runs() {
                if r.start < end || r.start >= r.end || r.end > label.runs {
                    return bad(format!(
                        "run range {}..{} is not sorted, disjoint and inside 0..{}",
                        r.start, r.end, label.runs
                    ));
                }
                end = r.end;
            }
            if let Some(trace) = s.trace() {
                let expected = trace.times.len().checked_mul(s.metrics().len());
                if expected != Some(trace.values.len()) {
                    return bad(format!(
                        "its trace has {} values for {} epochs of {} metrics",
                        trace.values.len(),
                        trace.times.len(),
                        s.metrics().len()
                    ));
                }
            }
        }
        Ok(())
    }

    /// Adds the rows of `other` (another shard of the same table) to these, exactly
    /// ([`Summary::merge`]: the result does not depend on the order or the split), after checking
    /// that both have the same name, title, rows and reference row: all rows merge, or none, and
    /// the table is unchanged on an error.
    ///
    /// # Errors
    /// [`ExperimentError::Incompatible`] for a different name, title, rows or reference row, or
    /// rows that do not merge (runs in common: the same shard given twice).
    pub fn merge(&mut self, other: &Table) -> Result<(), ExperimentError> {
        let differ = |what: &str, here: String, before: String| {
            Err(ExperimentError::Incompatible(format!(
                "table {} has {what} {here} here and {before} before{}",
                self.name,
                if what == "the title" {
                    ": were the shards run with different settings?"
                } else {
                    ""
                }
            )))
        };
        let labels = |t: &Table| -> Vec<String> {
            t.summaries.iter().map(|s| s.label().name.clone()).collect()
        };
        if self.name != other.name {
            return differ(
                "the name",
                format!("{:?}", other.name),
                format!("{:?}", self.name),
            );
        }
        if self.title != other.title {
            return differ(
                "the title",
                format!("{:?}", other.title),
                format!("{:?}", self.title),
            );
        }
        if labels(self) != labels(other) {
            return differ(
                "the rows",
                format!("{:?}", labels(other)),
                format!("{:?}", labels(self)),
            );
        }
        if self.reference != other.reference {
            return differ(
                "the reference row",
                format!("{:?}", other.reference),
                format!("{:?}", self.reference),
            );
        }
        let mut merged = self.summaries.clone();
        for (a, b) in merged.iter_mut().zip(&other.summaries) {
            a.merge(b).map_err(|e| {
                let why = match e {
                    ExperimentError::Incompatible(why) => why,
                    other => other.to_string(),
                };
                ExperimentError::Incompatible(format!(
                    "table {}, row {}: {why}",
                    self.name,
                    b.label().name
                ))
            })?;
        }
        self.summaries = merged;
        Ok(())
    }

    /// The runs each row misses, one entry per incomplete row, in row order: empty for a table
    /// covering all its runs.
    pub fn missing_runs(&self) -> Vec<MissingRuns> {
        let mut out = Vec::new();
        for s in &self.summaries {
            let total = s.label().runs;
            let mut ranges: Vec<Range<u64>> = Vec::new();
            let mut next = 0;
            for r in s.runs() {
                if r.start > next {
                    ranges.push(next..r.start);
                }
                next = r.end;
            }
            if next < total {
                ranges.push(next..total);
            }
            if !ranges.is_empty() {
                out.push(MissingRuns {
                    table: self.name.clone(),
                    row: s.label().name.clone(),
                    ranges,
                    of: total,
                });
            }
        }
        out
    }

    /// The table's columns: every metric of every row once (by name and kind of figure), in the
    /// order first met over the rows.
    pub fn columns(&self) -> Vec<Column> {
        let mut out: Vec<Column> = Vec::new();
        for m in self.summaries.iter().flat_map(Summary::metrics) {
            let column = Column {
                name: m.name.clone(),
                unit: m.unit.clone(),
                kind: FigureKind::of(m.reduction),
            };
            if !out
                .iter()
                .any(|c| c.name == column.name && c.kind == column.kind)
            {
                out.push(column);
            }
        }
        out
    }

    /// The names of the metrics kept per run in some row, in the order first met.
    pub fn per_run_metrics(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for m in self.summaries.iter().flat_map(Summary::metrics) {
            if m.per_run.is_some() && !out.contains(&m.name) {
                out.push(m.name.clone());
            }
        }
        out
    }

    /// One comparison per metric kept per run: when the table's reference row keeps the metric,
    /// every other row that keeps it, by the quantiles of its percentage differences from the
    /// reference on the same runs ([`relative_differences`]); otherwise every row that keeps it,
    /// by the quantiles of its run values. Of the runs kept ([`MAX_KEPT_RUNS`] per row).
    pub fn run_comparisons(&self) -> Vec<RunComparison> {
        let mut out = Vec::new();
        for metric in self.per_run_metrics() {
            let reference = self.reference.and_then(|r| {
                let s = self.summaries.get(r)?;
                Some((r, s.label().name.clone(), s.run_values(&metric)?))
            });
            let unit = self
                .summaries
                .iter()
                .flat_map(Summary::metrics)
                .find(|m| m.name == metric)
                .map(|m| m.unit.clone())
                .unwrap_or_default();
            let mut rows = Vec::new();
            for (i, s) in self.summaries.iter().enumerate() {
                let Some(values) = s.run_values(&metric) else {
                    continue;
                };
                let (q, n) = match &reference {
                    Some((r, _, _)) if *r == i => continue,
                    Some((_, _, base)) => run_quantiles(&relative_differences(base, values)),
                    None => run_quantiles(&values.values().iter().map(|v| v.1).collect::<Vec<_>>()),
                };
                rows.push((s.label().name.clone(), q, n));
            }
            out.push(RunComparison {
                unit: if reference.is_some() {
                    "%".to_owned()
                } else {
                    unit
                },
                reference: reference.map(|(_, label, _)| label),
                metric,
                rows,
            });
        }
        out
    }

    /// Whether some row's study has more runs than a summary keeps run values of.
    pub fn keeps_only_some_runs(&self) -> bool {
        self.summaries
            .iter()
            .any(|s| s.label().runs > MAX_KEPT_RUNS)
    }
}

/// Whether `name` is a plain name: 1 to [`MAX_NAME_LEN`] ASCII letters, digits, `_`, `-` or `.`,
/// not starting with `.` (safe as a file name on every system).
pub fn is_plain_name(name: &str) -> bool {
    let plain = name
        .bytes()
        .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-' || b == b'.');
    plain && !name.is_empty() && name.len() <= MAX_NAME_LEN && !name.starts_with('.')
}

/// The runs one row of a table misses ([`Table::missing_runs`]); displayed as
/// `"<table> <row>: runs 10..20, 25..30 of 30"` (at most four ranges listed).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MissingRuns {
    /// The table's name.
    pub table: String,
    /// The row's label.
    pub row: String,
    /// The missing run ranges, sorted.
    pub ranges: Vec<Range<u64>>,
    /// The study's number of runs.
    pub of: u64,
}

impl fmt::Display for MissingRuns {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        /// The most ranges listed.
        const LISTED: usize = 4;
        let mut text: Vec<String> = self
            .ranges
            .iter()
            .take(LISTED)
            .map(|g| format!("{}..{}", g.start, g.end))
            .collect();
        if self.ranges.len() > LISTED {
            text.push(format!("and {} more ranges", self.ranges.len() - LISTED));
        }
        write!(
            f,
            "{} {}: runs {} of {}",
            self.table,
            self.row,
            text.join(", "),
            self.of
        )
    }
}

/// The kind of figure a reduction gives, which decides a column's cells: an RMS, a mean with its
/// band, a percentage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FigureKind {
    /// [`Reduction::RootMeanSquare`].
    Rms,
    /// [`Reduction::Mean`] and [`Reduction::ChiSquare`].
    Mean,
    /// [`Reduction::Rate`].
    Percent,
}

impl FigureKind {
    /// The kind of `reduction`'s figure.
    pub fn of(reduction: Reduction) -> Self {
        match reduction {
            Reduction::RootMeanSquare => FigureKind::Rms,
            Reduction::Mean | Reduction::ChiSquare { .. } => FigureKind::Mean,
            Reduction::Rate => FigureKind::Percent,
        }
    }
}

/// A column of a table: a metric's name, its unit and the kind of its figures.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Column {
    /// The metric's name.
    pub name: String,
    /// Its unit (`""` for a pure number).
    pub unit: String,
    /// The kind of its figures.
    pub kind: FigureKind,
}

impl Column {
    /// The heading of the column: the name and the unit (`x_error (m)`).
    pub fn heading(&self) -> String {
        if self.unit.is_empty() {
            self.name.clone()
        } else {
            format!("{} ({})", self.name, self.unit)
        }
    }

    /// The metric's statistics at epoch k of row `s`, with their reduction, if it records them.
    pub fn stats<'s>(&self, s: &'s Summary, k: usize) -> Option<(&'s RunningStats, Reduction)> {
        let m = s
            .metrics()
            .iter()
            .find(|m| m.name == self.name && FigureKind::of(m.reduction) == self.kind)?;
        m.series.epochs().get(k).map(|e| (e, m.reduction))
    }

    /// The figure of this column at epoch k of row `s` ([`Figure::Empty`] when the row lacks it).
    pub fn figure(&self, s: &Summary, k: usize) -> Figure {
        self.stats(s, k)
            .map_or(Figure::Empty, |(stats, reduction)| reduction.figure(stats))
    }
}

/// The probabilities of the per-run quantiles: the smallest value, 5 %, the quartiles, the median,
/// 95 % and the largest value.
pub const RUN_PROBABILITIES: [f64; 7] = [0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 1.0];

/// The quantiles over the runs of one metric kept per run, for each row of a table: of the rows'
/// run values, or of their percentage differences from the reference row's
/// ([`Table::run_comparisons`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RunComparison {
    /// The metric's name.
    pub metric: String,
    /// Its unit (`"%"` for percentage differences).
    pub unit: String,
    /// The reference row's label, when the rows are compared with it.
    pub reference: Option<String>,
    /// Per row: its label, the quantiles at [`RUN_PROBABILITIES`] (NaN without a value) and the
    /// number of finite values they are of.
    pub rows: Vec<(String, [f64; 7], usize)>,
}

impl RunComparison {
    /// `relative` for percentage differences, `per_run` for run values.
    pub fn kind(&self) -> &'static str {
        if self.reference.is_some() {
            "relative"
        } else {
            "per_run"
        }
    }

    /// What the quantiles are of, with the unit.
    pub fn describe(&self) -> String {
        match &self.reference {
            Some(r) => format!(
                "percentage difference of {} from {r}, per run (%)",
                self.metric
            ),
            None if self.unit.is_empty() => format!("{} per run", self.metric),
            None => format!("{} per run ({})", self.metric, self.unit),
        }
    }
}

/// The quantiles of `values` at [`RUN_PROBABILITIES`], with the number of finite values.
fn run_quantiles(values: &[f64]) -> ([f64; 7], usize) {
    let q = quantiles(values, &RUN_PROBABILITIES);
    let mut out = [f64::NAN; 7];
    out.copy_from_slice(&q);
    (out, values.iter().filter(|v| v.is_finite()).count())
}
