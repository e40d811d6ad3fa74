//! The reports of every command, generic over the metrics a study records: the printed table, the
//! CSV files, the SVG plots and the JSON summary of each [`Table`], and `liebayes merge`, which reads
//! the JSON summaries of shards back and combines them.
//!
//! A metric is reported by its [`Reduction`]: an RMS for `RootMeanSquare`, a mean with its 95 % band
//! for `Mean` and `ChiSquare`, a percentage for `Rate`. A metric `<x>_error` with a matching
//! `<x>_sigma` is plotted as the error against its reported standard deviation. A metric kept per
//! run is reported by the quantiles of its run values over the runs, as they are or as percentage
//! differences from the table's reference row on the same runs, and drawn as box plots.

use crate::error::{CliError, Context as _, failed};
use crate::output::{Output, OutputArgs, check_name};
use liebayes::experiments::search::SizeSearch;
use liebayes::experiments::{
    Column, Figure, FigureKind, MAX_KEPT_RUNS, RunComparison, RunningStats, Shard, Summary, Table,
};
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::io::Read as _;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// The most epochs drawn in a plot; longer series are sampled at evenly spaced epochs.
pub const MAX_PLOTTED_EPOCHS: usize = 2000;

/// The most epochs per row written to the over-time and first-run CSV files; longer series are
/// sampled at evenly spaced epochs (the JSON summary keeps them all).
pub const MAX_CSV_EPOCHS: usize = 100_000;

/// The most panels of a plot (pairs `<x>_error`, `<x>_sigma`); further pairs are left out.
pub const MAX_PANELS: usize = 12;

/// The largest JSON summary `liebayes merge` reads (256 MiB).
pub const MAX_JSON_BYTES: u64 = 256 << 20;

/// The most JSON summaries read from one folder.
const MAX_FILES_PER_FOLDER: usize = 10_000;

/// The ending of a JSON summary's file name.
const JSON_ENDING: &str = ".summary.json";

/// Prints each table, then writes its files into the output folder, if there is one, all or
/// nothing ([`stage`], then the commit), and says where they went or, for a partial study, what is
/// missing.
///
/// # Errors
/// As [`stage`], or a file that cannot be moved into place.
pub fn emit(tables: &[Table], args: &OutputArgs, mut output: Output) -> Result<(), CliError> {
    stage(tables, args, &mut output)?;
    let Some(dir) = output.dir().map(Path::to_path_buf) else {
        return Ok(());
    };
    let missing = missing_runs(tables);
    let complete = args.shard == Shard::WHOLE && missing.is_empty();
    let written = output.commit()?;
    if complete {
        print(&format!(
            "wrote {} files into {}",
            written.len(),
            dir.display()
        ));
    } else if args.shard == Shard::WHOLE {
        print(&format!(
            "runs missing: {}\nwrote only the partial summaries into {}: merge them with the missing \
             runs' folders",
            missing.join("; "),
            dir.display()
        ));
    } else {
        let runs: Vec<String> = distinct(
            tables
                .iter()
                .flat_map(|t| &t.summaries)
                .map(|s| s.label().runs),
        )
        .iter()
        .map(u64::to_string)
        .collect();
        print(&format!(
            "shard {} of {} runs: partial summary in {}; combine with `liebayes merge`",
            args.shard,
            runs.join(" and "),
            dir.display()
        ));
    }
    Ok(())
}

/// Prints each table and writes its files into `output` (uncommitted: they appear when the
/// command commits it), if it has a folder: for a study covering all its runs,
/// `<name>_summary.csv`, `<name>_over_time.csv`, `<name>_first_run.csv`, `<name>_first_run.svg`,
/// `<name>_over_time.svg` (the plots when some metric `<x>_error` has its `<x>_sigma`), for each
/// metric `<m>` kept per run `<name>_<m>_relative.csv` and `<name>_<m>_relative.svg` (the quantiles
/// and box plots of the rows' percentage differences from the reference row, run by run; when the
/// table has a reference row that keeps `<m>`) or else `<name>_<m>_per_run.csv` and
/// `<name>_<m>_per_run.svg` (of the rows' run values), and `<name>.summary.json`; for a partial
/// study (a shard, or a merge that misses runs) only the JSON summary. The per-run tables are
/// printed for complete studies only. A command with files besides the tables stages them all in
/// one output and commits it once.
///
/// # Errors
/// A table that is not well formed (a bad or repeated name, inconsistent run ranges or trace, a
/// reference row that is not one of its rows), or a file that cannot be written; nothing is
/// written then.
pub fn stage(tables: &[Table], args: &OutputArgs, output: &mut Output) -> Result<(), CliError> {
    for (i, table) in tables.iter().enumerate() {
        check_table(table)?;
        if tables[..i].iter().any(|t| t.name == table.name) {
            return Err(format!("internal: two tables are named {:?}", table.name).into());
        }
    }
    let complete = args.shard == Shard::WHOLE && missing_runs(tables).is_empty();
    for table in tables {
        print(&render(table));
        if complete {
            for comparison in table.run_comparisons() {
                print(&render_runs(table, &comparison));
            }
        }
    }
    if output.dir().is_none() {
        return Ok(());
    }
    for table in tables {
        let json = serde_json::to_string(table)
            .context(|| format!("internal: table {} to JSON", table.name))?;
        output.write(&format!("{}{JSON_ENDING}", table.name), json.as_bytes())?;
        if complete {
            write_files(table, output)?;
        }
    }
    Ok(())
}

/// The runs the tables miss, one description per row that misses some (none for a whole study).
fn missing_runs(tables: &[Table]) -> Vec<String> {
    tables
        .iter()
        .flat_map(Table::missing_runs)
        .map(|m| m.to_string())
        .collect()
}

/// Prints a line on stdout; a closed stdout (the program piped into `head`) does not stop the
/// command, whose files are still written.
pub fn print(text: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stdout().lock(), "{text}");
}

/// Prints a particle-count search: the target, every count tried, and what was found.
/// `what` names the score with its unit (`"final azimuth RMSE (deg)"`), `of` the reference
/// filter (`"the exact filter"`).
pub fn print_search(
    name: &str,
    what: &str,
    of: &str,
    runs: u64,
    found: &SizeSearch,
    tolerance: f64,
) {
    print(&format!(
        "{name}: {of}'s {what} {} over {runs} runs",
        compact(Some(found.target))
    ));
    for t in &found.tried {
        print(&format!(
            "  {:>8} particles: {} {}, {} failed runs, {} us per step",
            t.count,
            what,
            compact(t.score.is_finite().then_some(t.score)),
            t.failures,
            compact(
                t.seconds_per_step
                    .is_finite()
                    .then_some(t.seconds_per_step * 1e6)
            )
        ));
    }
    print(&match (found.count, found.tried.last()) {
        (Some(n), _) => format!(
            "  -> {n} particles come within {} % of {of}",
            compact(Some(100.0 * tolerance))
        ),
        (None, Some(last)) => format!("  -> {} particles do not", last.count),
        (None, None) => "  -> no count was tried".to_owned(),
    });
}

/// Checks that the folders to merge exist and that the output folder is none of them (the merged
/// summaries would replace a shard's).
///
/// # Errors
/// A folder that cannot be read, or `out` among `dirs`.
pub fn check_merge_folders(dirs: &[PathBuf], out: &Path) -> Result<(), CliError> {
    let out = out.canonicalize().ok();
    for dir in dirs {
        let real = dir
            .canonicalize()
            .context(|| format!("cannot read the folder {}", dir.display()))?;
        if out.as_ref() == Some(&real) {
            return Err(format!(
                "--out {} is one of the folders to merge: choose another, its summaries would be \
                 replaced",
                dir.display()
            )
            .into());
        }
    }
    Ok(())
}

/// Reads every `*.summary.json` of each folder (at most 256 MiB each, at most 10 000 per folder),
/// groups the tables by name in the order first read, and merges their rows (`Summary::merge`,
/// exact: the result does not depend on the order or the split).
///
/// # Errors
/// A folder without summaries, an entry named like a summary that is not a regular file (a FIFO,
/// a folder, a device), a file too large, unreadable or not a table, tables of one name whose
/// titles or rows differ, or rows that do not merge (different studies, or runs in common: the
/// same shard given twice). The message names the file.
pub fn merge(dirs: &[PathBuf]) -> Result<Vec<Table>, CliError> {
    let mut tables: Vec<Table> = Vec::new();
    for dir in dirs {
        for file in summary_files(dir)? {
            let table = read_table(&file)?;
            match tables.iter_mut().find(|t| t.name == table.name) {
                Some(into) => {
                    into.merge(&table)
                        .context(|| format!("{}", file.display()))?;
                }
                None => tables.push(table),
            }
        }
    }
    Ok(tables)
}

/// The `*.summary.json` files of a folder, sorted by name. An entry named like a summary must be a
/// regular file (or a link to one), as a shard writes it: it is refused otherwise, before any file
/// of the folder is read, since opening a FIFO would block until something writes into it, and a
/// folder or a device is not a summary either. Entries named otherwise are not summaries and are
/// left alone.
fn summary_files(dir: &Path) -> Result<Vec<PathBuf>, CliError> {
    let cannot = || format!("cannot read the folder {}", dir.display());
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).context(cannot)? {
        let path = entry.context(cannot)?.path();
        let is_summary = path
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.ends_with(JSON_ENDING) && !n.starts_with('.'));
        if is_summary {
            // `metadata` follows links: a link to a summary is read as the summary.
            let metadata =
                std::fs::metadata(&path).context(|| format!("cannot read {}", path.display()))?;
            if !metadata.is_file() {
                return Err(format!(
                    "{} is named like a summary but is not a regular file (a FIFO, a folder or a \
                     device): move it out of the folder",
                    path.display()
                )
                .into());
            }
            if files.len() == MAX_FILES_PER_FOLDER {
                return Err(format!(
                    "{} holds more than {MAX_FILES_PER_FOLDER} summaries: split it",
                    dir.display()
                )
                .into());
            }
            files.push(path);
        }
    }
    if files.is_empty() {
        return Err(format!(
            "{} holds no *{JSON_ENDING} (give the --out folders of the shards)",
            dir.display()
        )
        .into());
    }
    files.sort();
    Ok(files)
}

/// One JSON summary, size-checked before it is read, then checked whole.
fn read_table(file: &Path) -> Result<Table, CliError> {
    let cannot = || format!("cannot read {}", file.display());
    let handle = std::fs::File::open(file).context(cannot)?;
    let size = handle.metadata().context(cannot)?.len();
    if size > MAX_JSON_BYTES {
        return Err(format!(
            "{} is {size} bytes, more than the {MAX_JSON_BYTES} a summary may have",
            file.display()
        )
        .into());
    }
    let mut text = String::new();
    handle
        .take(MAX_JSON_BYTES + 1)
        .read_to_string(&mut text)
        .context(cannot)?;
    if text.len() as u64 > MAX_JSON_BYTES {
        return Err(format!("{} grew beyond {MAX_JSON_BYTES} bytes", file.display()).into());
    }
    let table: Table = serde_json::from_str(&text)
        .context(|| format!("{} is not a liebayes summary", file.display()))?;
    check_table(&table).context(|| format!("{}", file.display()))?;
    Ok(table)
}

/// The distinct values, in the order first seen.
fn distinct(values: impl Iterator<Item = u64>) -> Vec<u64> {
    let mut out: Vec<u64> = Vec::new();
    for v in values {
        if !out.contains(&v) {
            out.push(v);
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Figures

/// Checks a table before anything of it is printed or written: the library's checks
/// ([`Table::validate`]), and that every file it would write has a plain name.
fn check_table(table: &Table) -> Result<(), CliError> {
    table.validate()?;
    check_name(&format!("{}{JSON_ENDING}", table.name))
        .context(|| format!("table name {:?}", table.name))?;
    for metric in table.per_run_metrics() {
        check_name(&run_file(table, &metric, "relative", "svg")).map_err(|e| {
            format!(
                "table {}: metric {metric:?} kept per run cannot name a file: {e}",
                table.name
            )
        })?;
    }
    Ok(())
}

/// The CSV columns' suffixes of a kind of figure.
fn suffixes(kind: FigureKind) -> &'static [&'static str] {
    match kind {
        FigureKind::Rms => &["rms"],
        FigureKind::Mean => &["mean", "low", "high"],
        FigureKind::Percent => &["percent"],
    }
}

/// A figure's printed cell.
fn cell(figure: Figure) -> String {
    match figure {
        Figure::Empty => "-".to_owned(),
        Figure::Rms(x) => compact(Some(x)),
        Figure::Mean(m, None) => compact(Some(m)),
        Figure::Mean(m, Some((l, h))) => format!(
            "{} [{}, {}]",
            compact(Some(m)),
            compact(Some(l)),
            compact(Some(h))
        ),
        Figure::Percent(p) => format!("{}%", compact(Some(p))),
    }
}

/// A figure's CSV values, as many as its kind's suffixes (empty where there is none).
fn values(figure: Figure, kind: FigureKind) -> Vec<Option<f64>> {
    match figure {
        Figure::Rms(x) | Figure::Percent(x) => vec![Some(x)],
        Figure::Mean(m, band) => vec![Some(m), band.map(|b| b.0), band.map(|b| b.1)],
        Figure::Empty => vec![None; suffixes(kind).len()],
    }
}

/// The number of epochs of a summary (of its epoch times).
fn epochs(s: &Summary) -> usize {
    s.times().epochs().len()
}

/// The mean time of epoch k.
fn time(s: &Summary, k: usize) -> Option<f64> {
    s.times().epochs().get(k).and_then(RunningStats::mean)
}

/// A number in at most 4 significant digits: fixed notation from 1e-3 to below 1e5, scientific
/// beyond; `-` for none.
fn compact(x: Option<f64>) -> String {
    let Some(x) = x else {
        return "-".to_owned();
    };
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let scientific = format!("{x:.3e}");
    let exponent: i32 = scientific
        .rsplit_once('e')
        .and_then(|(_, e)| e.parse().ok())
        .unwrap_or(0);
    if (-3..5).contains(&exponent) {
        let decimals = usize::try_from(3 - exponent).unwrap_or(0);
        format!("{x:.decimals$}")
    } else {
        scientific
    }
}

// ---------------------------------------------------------------------------------------------
// The printed table

/// The table as printed: the title, the figures at the final epoch, then the failures by reason and
/// the non-finite values left out, row by row.
fn render(table: &Table) -> String {
    let columns = table.columns();
    let mut heading = vec![
        "filter".to_owned(),
        "runs".to_owned(),
        "failures".to_owned(),
    ];
    heading.extend(columns.iter().map(Column::heading));
    heading.push("ns/step".to_owned());
    let mut rows = vec![heading];
    let mut notes = Vec::new();
    for s in &table.summaries {
        let last = epochs(s).saturating_sub(1);
        let mut row = vec![
            s.label().name.clone(),
            s.run_count().to_string(),
            s.failure_count().to_string(),
        ];
        row.extend(columns.iter().map(|c| cell(c.figure(s, last))));
        row.push(compact(ns_per_step(s)));
        rows.push(row);
        if s.failure_count() > 0 {
            let mut note = format!(
                "{}: {} of {} runs failed (left out of every figure):",
                s.label().name,
                s.failure_count(),
                s.run_count()
            );
            for (reason, count) in s.failures() {
                let _ = write!(note, "\n    {count} x {reason}");
            }
            notes.push(note);
        }
        for c in &columns {
            if let Some((stats, _)) = c.stats(s, last)
                && stats.count() > 0
                && stats.non_finite() > 0
            {
                notes.push(format!(
                    "{}: {} of the final values of {} are not finite (left out)",
                    s.label().name,
                    stats.non_finite(),
                    c.name
                ));
            }
        }
    }
    let mut out = format!("\n{}\n", table.title);
    if let Some(t) = table
        .summaries
        .first()
        .and_then(|s| time(s, epochs(s).saturating_sub(1)))
    {
        let _ = writeln!(
            out,
            "final epoch, t = {} s: RMS, mean [95% band], rate",
            compact(Some(t))
        );
    }
    out.push_str(&aligned(&rows));
    for note in notes {
        let _ = writeln!(out, "{note}");
    }
    let legend: Vec<String> = columns
        .iter()
        .filter_map(|c| meaning(&c.name).map(|m| format!("  {}: {m}", c.name)))
        .collect();
    if !legend.is_empty() {
        let _ = writeln!(out, "What the figures say:");
        for line in legend {
            let _ = writeln!(out, "{line}");
        }
        let _ = writeln!(out, "  ns/step: the filter's time per step (nanoseconds).");
    }
    out
}

/// A row's mean time per step in nanoseconds, if it has one that is finite in those units (a
/// summary's timing may hold any finite number of seconds).
fn ns_per_step(s: &Summary) -> Option<f64> {
    s.timing().mean().map(|t| t * 1e9).filter(|t| t.is_finite())
}

/// Rows of cells as printed: each column as wide as its widest cell, the first left-aligned, the
/// others right-aligned, two spaces apart, a line per row.
pub fn aligned(rows: &[Vec<String>]) -> String {
    let columns = rows.iter().map(Vec::len).max().unwrap_or(0);
    let widths: Vec<usize> = (0..columns)
        .map(|j| {
            rows.iter()
                .filter_map(|r| r.get(j))
                .map(|c| c.chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for row in rows {
        let cells: Vec<String> = row
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(j, (cell, &w))| {
                // Padded by hand: a formatting width above 65 535 panics, and a summary's labels
                // can be that long.
                let pad = " ".repeat(w.saturating_sub(cell.chars().count()));
                if j == 0 {
                    format!("{cell}{pad}")
                } else {
                    format!("{pad}{cell}")
                }
            })
            .collect();
        let _ = writeln!(out, "{}", cells.join("  ").trim_end());
    }
    out
}

/// What a metric's printed figure means, in a line under the table (`None` for a metric without
/// one: its name says it).
fn meaning(name: &str) -> Option<String> {
    let text = if let Some(what) = name.strip_suffix("_error") {
        format!("RMS over the runs of the {what} error (truth minus estimate)")
    } else if let Some(what) = name.strip_suffix("_sigma") {
        format!(
            "RMS over the runs of the filter's own {what} standard deviation: about the error when \
             the filter is consistent, far below it when over-confident"
        )
    } else if name == "nis" || name.ends_with("nees") {
        format!(
            "the mean {} (a chi-square value with the degrees of freedom of its metric) and, in \
             brackets, the 95 % band a consistent filter's mean falls in: above, over-confident; \
             below, cautious",
            name.to_uppercase().replace('_', " ")
        )
    } else {
        match name {
            "circular_consistency" => {
                "mean of (1 - cos e)/(1 - rho) of the azimuth error e against the filter's mean \
                 resultant length rho: 1 when its angular spread is right; a particle filter whose \
                 particles collapsed on one azimuth reports rho = 1 to rounding, and reads 1e9 or \
                 more"
            }
            "diverged" => {
                "share of the runs whose final azimuth error exceeds 10 deg (where the azimuth \
                 cannot be observed, the static scenario, every azimuth figure measures nothing)"
            }
            "log_evidence" => {
                "mean log likelihood of the last measurement under the prediction (0 for a step \
                 that conditioned on nothing)"
            }
            _ => return None,
        }
        .to_owned()
    };
    Some(text)
}

// ---------------------------------------------------------------------------------------------
// CSV

/// A CSV field: quoted when it holds a comma, a quote or a line break.
pub fn field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

/// A number as CSV: the shortest text that reads back to the same f64; empty for none.
fn number(x: Option<f64>) -> String {
    x.map_or(String::new(), |v| format!("{v:e}"))
}

/// The CSV headings of the figure columns.
fn figure_headings(columns: &[Column]) -> Vec<String> {
    columns
        .iter()
        .flat_map(|c| {
            suffixes(c.kind).iter().map(move |suffix| {
                let unit = if c.unit.is_empty() || c.kind == FigureKind::Percent {
                    String::new()
                } else {
                    format!(" ({})", c.unit)
                };
                field(&format!("{}_{suffix}{unit}", c.name))
            })
        })
        .collect()
}

/// The CSV cells of every figure column at epoch k of row `s`.
fn figure_cells(columns: &[Column], s: &Summary, k: usize) -> Vec<String> {
    columns
        .iter()
        .flat_map(|c| values(c.figure(s, k), c.kind))
        .map(number)
        .collect()
}

/// `<name>_summary.csv`: per row its runs, failures, the final-epoch figures and the time per step.
fn summary_csv(table: &Table) -> String {
    let columns = table.columns();
    let mut out = ["filter", "runs", "failures"].join(",");
    for h in figure_headings(&columns) {
        let _ = write!(out, ",{h}");
    }
    out.push_str(",ns_per_step\n");
    for s in &table.summaries {
        let last = epochs(s).saturating_sub(1);
        let mut cells = vec![
            field(&s.label().name),
            s.run_count().to_string(),
            s.failure_count().to_string(),
        ];
        cells.extend(figure_cells(&columns, s, last));
        cells.push(number(ns_per_step(s)));
        let _ = writeln!(out, "{}", cells.join(","));
    }
    out
}

/// `<name>_over_time.csv`: per row and epoch (at most [`MAX_CSV_EPOCHS`], evenly spaced), the
/// epoch's mean time and every figure.
fn over_time_csv(table: &Table) -> String {
    let columns = table.columns();
    let mut out = String::from("filter,epoch,t");
    for h in figure_headings(&columns) {
        let _ = write!(out, ",{h}");
    }
    out.push('\n');
    for s in &table.summaries {
        for k in evenly(epochs(s), MAX_CSV_EPOCHS) {
            let mut cells = vec![field(&s.label().name), k.to_string(), number(time(s, k))];
            cells.extend(figure_cells(&columns, s, k));
            let _ = writeln!(out, "{}", cells.join(","));
        }
    }
    out
}

/// `<name>_first_run.csv`: the trace of each row that has one (its run, time and every metric's
/// value per epoch, at most [`MAX_CSV_EPOCHS`] of them).
fn first_run_csv(table: &Table) -> String {
    let mut names: Vec<(String, String)> = Vec::new();
    for m in table.summaries.iter().flat_map(Summary::metrics) {
        if !names.iter().any(|(n, _)| *n == m.name) {
            names.push((m.name.clone(), m.unit.clone()));
        }
    }
    let mut out = String::from("filter,run,t");
    for (name, unit) in &names {
        let heading = if unit.is_empty() {
            name.clone()
        } else {
            format!("{name} ({unit})")
        };
        let _ = write!(out, ",{}", field(&heading));
    }
    out.push('\n');
    for s in &table.summaries {
        let Some(trace) = s.trace() else { continue };
        let width = s.metrics().len();
        let index: Vec<Option<usize>> = names
            .iter()
            .map(|(n, _)| s.metrics().iter().position(|m| m.name == *n))
            .collect();
        for k in evenly(trace.times.len(), MAX_CSV_EPOCHS) {
            let mut cells = vec![
                field(&s.label().name),
                trace.run.to_string(),
                number(Some(trace.times[k])),
            ];
            cells.extend(index.iter().map(|j| {
                number(
                    j.and_then(|j| trace.values.get(k * width + j).copied())
                        .filter(|v| v.is_finite()),
                )
            }));
            let _ = writeln!(out, "{}", cells.join(","));
        }
    }
    out
}

/// At most `max` indices of `0..len`, evenly spaced, the first and the last among them.
fn evenly(len: usize, max: usize) -> impl Iterator<Item = usize> {
    let n = len.min(max.max(2));
    (0..n).map(move |i| {
        if n < 2 {
            i
        } else {
            usize::try_from(i as u128 * (len as u128 - 1) / (n as u128 - 1)).unwrap_or(len - 1)
        }
    })
}

/// Writes the CSV files and the plots of a complete table.
fn write_files(table: &Table, output: &mut Output) -> Result<(), CliError> {
    let name = &table.name;
    output.write(
        &format!("{name}_summary.csv"),
        summary_csv(table).as_bytes(),
    )?;
    output.write(
        &format!("{name}_over_time.csv"),
        over_time_csv(table).as_bytes(),
    )?;
    output.write(
        &format!("{name}_first_run.csv"),
        first_run_csv(table).as_bytes(),
    )?;
    let plot = |e: Box<dyn std::error::Error>| failed(format!("plotting {name}"), e);
    if let Some(svg) = plot_first_run(table).map_err(plot)? {
        output.write(&format!("{name}_first_run.svg"), svg.as_bytes())?;
    }
    if let Some(svg) = plot_over_time(table).map_err(plot)? {
        output.write(&format!("{name}_over_time.svg"), svg.as_bytes())?;
    }
    for comparison in table.run_comparisons() {
        let kind = comparison.kind();
        output.write(
            &run_file(table, &comparison.metric, kind, "csv"),
            runs_csv(&comparison).as_bytes(),
        )?;
        let svg = plot_runs(table, &comparison).map_err(plot)?;
        output.write(
            &run_file(table, &comparison.metric, kind, "svg"),
            svg.as_bytes(),
        )?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Per-run values

/// The headings of the per-run quantiles.
const RUN_HEADINGS: [&str; 7] = ["min", "p5", "p25", "median", "p75", "p95", "max"];

/// `<name>_<metric>_<kind>.<ending>`.
fn run_file(table: &Table, metric: &str, kind: &str, ending: &str) -> String {
    format!("{}_{metric}_{kind}.{ending}", table.name)
}

/// A quantile for print: `-` for none.
fn quantile_cell(q: f64) -> String {
    compact(q.is_finite().then_some(q))
}

/// The printed per-run table: what it compares, then per row its quantiles and number of runs.
fn render_runs(table: &Table, c: &RunComparison) -> String {
    let mut heading = vec!["filter".to_owned()];
    heading.extend(RUN_HEADINGS.iter().map(|h| (*h).to_owned()));
    heading.push("runs".to_owned());
    let mut rows = vec![heading];
    for (label, q, n) in &c.rows {
        let mut row = vec![label.clone()];
        row.extend(q.iter().map(|&v| quantile_cell(v)));
        row.push(n.to_string());
        rows.push(row);
    }
    let mut out = format!(
        "
{}: {}
",
        table.name,
        c.describe()
    );
    if table.keeps_only_some_runs() {
        let _ = writeln!(
            out,
            "(the runs kept: the first {MAX_KEPT_RUNS} of each row)"
        );
    }
    out.push_str(&aligned(&rows));
    out
}

/// `<name>_<metric>_relative.csv` or `_per_run.csv`: per row its quantiles over the runs and the
/// number of runs.
fn runs_csv(c: &RunComparison) -> String {
    let unit = if c.unit.is_empty() {
        String::new()
    } else {
        format!(" ({})", c.unit)
    };
    let mut out = String::from("filter");
    for h in RUN_HEADINGS {
        let _ = write!(out, ",{}", field(&format!("{h}{unit}")));
    }
    out.push_str(",runs\n");
    for (label, q, n) in &c.rows {
        let mut cells = vec![field(label)];
        cells.extend(q.iter().map(|&v| number(v.is_finite().then_some(v))));
        cells.push(n.to_string());
        let _ = writeln!(out, "{}", cells.join(","));
    }
    out
}

// ---------------------------------------------------------------------------------------------
// SVG

type Plot<T> = Result<T, Box<dyn std::error::Error>>;
/// A row's index, label and curve.
type Curve = (usize, String, Vec<(f64, f64)>);

const COLOURS: [RGBColor; 6] = [
    RGBColor(0, 0, 0),
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
];

/// The quantities `x` of a summary with both `<x>_error` and `<x>_sigma`, with their indices.
fn pairs(s: &Summary) -> Vec<(String, usize, usize)> {
    let metrics = s.metrics();
    metrics
        .iter()
        .enumerate()
        .filter_map(|(i, m)| {
            let x = m.name.strip_suffix("_error")?;
            let sigma = format!("{x}_sigma");
            let j = metrics.iter().position(|m| m.name == sigma)?;
            Some((x.to_owned(), i, j))
        })
        .take(MAX_PANELS)
        .collect()
}

/// The first line of a title.
fn headline(title: &str) -> &str {
    title.lines().next().unwrap_or("")
}

/// The y-axis label of quantity `x` of a summary.
fn axis_label(s: &Summary, index: usize, what: &str) -> String {
    let unit = &s.metrics()[index].unit;
    if unit.is_empty() {
        what.to_owned()
    } else {
        format!("{what} ({unit})")
    }
}

/// `<name>_first_run.svg`: the trace of the first row that has one, a panel per `_error`/`_sigma`
/// pair (at most [`MAX_PANELS`]), the error and ±1 σ. `None` when no row has a trace with such a pair.
fn plot_first_run(table: &Table) -> Plot<Option<String>> {
    let Some((s, trace)) = table
        .summaries
        .iter()
        .find_map(|s| s.trace().map(|t| (s, t)))
    else {
        return Ok(None);
    };
    let pairs = pairs(s);
    if pairs.is_empty() || trace.times.is_empty() {
        return Ok(None);
    }
    let width = s.metrics().len();
    let t_end = trace.times.iter().copied().fold(1.0_f64, f64::max);
    let mut svg = String::new();
    {
        let height = u32::try_from(300 * pairs.len()).unwrap_or(u32::MAX);
        let root = SVGBackend::with_string(&mut svg, (900, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(
            &format!(
                "{}: {}, run {}",
                headline(&table.title),
                s.label().name,
                trace.run
            ),
            ("sans-serif", 18),
        )?;
        let panels = root.split_evenly((pairs.len(), 1));
        for (panel, (x, e, g)) in panels.iter().zip(&pairs) {
            let points: Vec<(f64, f64, f64)> = evenly(trace.times.len(), MAX_PLOTTED_EPOCHS)
                .filter_map(|k| {
                    let v = *trace.values.get(k * width + e)?;
                    let sigma = *trace.values.get(k * width + g)?;
                    (v.is_finite() && sigma.is_finite()).then_some((trace.times[k], v, sigma))
                })
                .collect();
            let m = points
                .iter()
                .fold(1e-9_f64, |m, &(_, v, s)| m.max(v.abs()).max(s.abs()))
                * 1.1;
            let mut chart = ChartBuilder::on(panel)
                .margin(8)
                .x_label_area_size(30)
                .y_label_area_size(70)
                .build_cartesian_2d(axis(0.0, t_end, 0.0..1.0), axis(-m, m, -1.0..1.0))?;
            chart
                .configure_mesh()
                .x_desc("t (s)")
                .y_desc(axis_label(s, *e, &format!("{x} error")))
                .draw()?;
            if points.is_empty() {
                chart.draw_series(std::iter::once(Text::new(
                    "no finite values (unobservable)",
                    (0.05 * t_end, 0.0),
                    ("sans-serif", 16),
                )))?;
                continue;
            }
            chart
                .draw_series(LineSeries::new(
                    points.iter().map(|&(t, v, _)| (t, v)),
                    &COLOURS[1],
                ))?
                .label("error")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], COLOURS[1]));
            for sign in [1.0, -1.0] {
                let series = chart.draw_series(LineSeries::new(
                    points.iter().map(|&(t, _, s)| (t, sign * s)),
                    &COLOURS[2],
                ))?;
                if sign > 0.0 {
                    series
                        .label("±1 sigma")
                        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], COLOURS[2]));
                }
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
        }
        root.present()?;
    }
    Ok(Some(svg))
}

/// A row's curve of the RMS of metric `index` over the epochs: (t, value) at positive finite values.
fn rms_curve(s: &Summary, index: usize) -> Vec<(f64, f64)> {
    let series = s.metrics()[index].series.epochs();
    evenly(series.len(), MAX_PLOTTED_EPOCHS)
        .filter_map(|k| {
            let rms = series[k].mean_square()?.sqrt();
            let t = time(s, k)?;
            (rms.is_finite() && rms > 0.0 && t.is_finite()).then_some((t, rms))
        })
        .collect()
}

/// `<name>_over_time.svg`: a panel per `_error`/`_sigma` pair (at most [`MAX_PANELS`]), each row's RMSE over time (solid)
/// beside the first row's RMS σ (dashed), on a log axis. `None` without such a pair.
fn plot_over_time(table: &Table) -> Plot<Option<String>> {
    let mut quantities: Vec<String> = Vec::new();
    for (x, _, _) in table.summaries.iter().flat_map(pairs) {
        if !quantities.contains(&x) && quantities.len() < MAX_PANELS {
            quantities.push(x);
        }
    }
    let Some(first) = table.summaries.first() else {
        return Ok(None);
    };
    if quantities.is_empty() {
        return Ok(None);
    }
    let t_end = (0..epochs(first))
        .filter_map(|k| time(first, k))
        .fold(1.0_f64, f64::max);
    let mut svg = String::new();
    {
        let height = u32::try_from(300 * quantities.len()).unwrap_or(u32::MAX);
        let root = SVGBackend::with_string(&mut svg, (900, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(
            &format!(
                "{}: RMSE over the runs (solid), {}'s RMS sigma (dashed)",
                headline(&table.title),
                first.label().name
            ),
            ("sans-serif", 18),
        )?;
        let panels = root.split_evenly((quantities.len(), 1));
        for (panel, x) in panels.iter().zip(&quantities) {
            rmse_panel(panel, table, x, t_end)?;
        }
        root.present()?;
    }
    Ok(Some(svg))
}

/// One panel of the over-time plot: every row's RMSE of `<x>_error` (solid) and the first row's
/// RMS of `<x>_sigma` (dashed), on a log axis.
fn rmse_panel(
    panel: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    table: &Table,
    x: &str,
    t_end: f64,
) -> Plot<()> {
    let Some(first) = table.summaries.first() else {
        return Ok(());
    };
    let index = |s: &Summary, name: &str| s.metrics().iter().position(|m| m.name == name);
    let (error, sigma) = (format!("{x}_error"), format!("{x}_sigma"));
    let curves: Vec<Curve> = table
        .summaries
        .iter()
        .enumerate()
        .filter_map(|(i, s)| Some((i, s.label().name.clone(), rms_curve(s, index(s, &error)?))))
        .collect();
    let dashed = index(first, &sigma)
        .map(|j| rms_curve(first, j))
        .unwrap_or_default();
    let values = curves
        .iter()
        .flat_map(|(_, _, c)| c)
        .chain(&dashed)
        .map(|p| p.1);
    let (low, high) = values.fold((f64::INFINITY, 0.0_f64), |(l, h), v| (l.min(v), h.max(v)));
    let unit_of = table
        .summaries
        .iter()
        .find_map(|s| index(s, &error).map(|i| (s, i)));
    let label = unit_of.map_or(format!("{x} RMSE"), |(s, i)| {
        axis_label(s, i, &format!("{x} RMSE"))
    });
    if !(low.is_finite() && high > 0.0) {
        let mut chart = ChartBuilder::on(panel)
            .margin(8)
            .build_cartesian_2d(axis(0.0, t_end, 0.0..1.0), 0.0..1.0)?;
        chart.draw_series(std::iter::once(Text::new(
            format!("{label}: no positive finite values"),
            (0.05 * t_end, 0.5),
            ("sans-serif", 16),
        )))?;
        return Ok(());
    }
    let mut chart = ChartBuilder::on(panel)
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(70)
        .build_cartesian_2d(
            axis(0.0, t_end, 0.0..1.0),
            axis(low * 0.8, high * 1.25, AXIS_LIMIT / 2.0..AXIS_LIMIT).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_desc(label)
        .y_label_formatter(&|v| compact(Some(*v)))
        .draw()?;
    for (i, name, curve) in &curves {
        let colour = COLOURS[i % COLOURS.len()];
        chart
            .draw_series(LineSeries::new(curve.iter().copied(), &colour))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    chart.draw_series(DashedLineSeries::new(
        dashed.iter().copied(),
        6,
        4,
        ShapeStyle::from(&COLOURS[0]),
    ))?;
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// The largest magnitude a plot axis reaches: a quarter of `f64::MAX`, so that an axis's width
/// (at most half of it) is finite.
const AXIS_LIMIT: f64 = f64::MAX / 4.0;

/// A plot axis from `low` to `high`, each clamped to ±[`AXIS_LIMIT`]; `fallback` when the clamped
/// range is empty or an end is NaN. Every axis is built through it: plotters' search for tick
/// marks never ends on an axis of infinite width, which finite values near `f64::MAX` (a diverged
/// filter's σ in a summary) would otherwise give. Points beyond the axis are drawn clipped.
pub fn axis(low: f64, high: f64, fallback: Range<f64>) -> Range<f64> {
    let (low, high) = (
        low.clamp(-AXIS_LIMIT, AXIS_LIMIT),
        high.clamp(-AXIS_LIMIT, AXIS_LIMIT),
    );
    if low < high { low..high } else { fallback }
}

/// The value range of a box plot: every finite quantile (and 0 for percentage differences),
/// padded by 5 % of the span (by 1 when all are equal); -1..1 without a finite value.
fn box_range(c: &RunComparison) -> Range<f64> {
    let zero = c.reference.is_some().then_some(0.0);
    let (low, high) = c
        .rows
        .iter()
        .flat_map(|r| r.1)
        .filter(|v| v.is_finite())
        .chain(zero)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    // Halves first: the span of two finite values can overflow.
    let span = high / 2.0 - low / 2.0;
    let pad = if span > 0.0 { 0.1 * span } else { 1.0 };
    if low.is_finite() && high.is_finite() {
        axis(low - pad, high + pad, -1.0..1.0)
    } else {
        -1.0..1.0
    }
}

/// The horizontal axis of a box plot: row i at x = i, the axis from -0.5 to n - 0.5, a tick and
/// the row's label at each row.
struct RowAxis {
    labels: Vec<String>,
}

impl RowAxis {
    /// The right end of the axis.
    fn right(&self) -> f64 {
        self.labels.len().max(1) as f64 - 0.5
    }
}

impl Ranged for RowAxis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let fraction = (value + 0.5) / (self.right() + 0.5);
        let pixel = f64::from(limit.0) + fraction * f64::from(limit.1 - limit.0);
        // A pixel position within the drawing (or just beyond it), far inside i32.
        #[allow(clippy::cast_possible_truncation)]
        let pixel = pixel.round().clamp(-1e6, 1e6) as i32;
        pixel
    }

    fn key_points<Hint: KeyPointHint>(&self, _hint: Hint) -> Vec<f64> {
        (0..self.labels.len()).map(|i| i as f64).collect()
    }

    fn range(&self) -> Range<f64> {
        -0.5..self.right()
    }
}

impl ValueFormatter<f64> for RowAxis {
    fn format(value: &f64) -> String {
        compact(Some(*value))
    }

    fn format_ext(&self, value: &f64) -> String {
        (0..self.labels.len())
            .find(|&i| (i as f64 - value).abs() < 1e-6)
            .map_or(String::new(), |i| self.labels[i].clone())
    }
}

/// `<name>_<metric>_relative.svg` or `_per_run.svg`: a box per row, from the 25 % to the 75 %
/// quantile with a line at the median, whiskers to the 5 % and 95 % quantiles, crosses at the
/// smallest and largest values; a dashed zero line for percentage differences; the rows labelled
/// on the horizontal axis; the table's title above.
fn plot_runs(table: &Table, c: &RunComparison) -> Plot<String> {
    let axis = RowAxis {
        labels: c.rows.iter().map(|r| r.0.clone()).collect(),
    };
    let right = axis.right();
    let rows = axis.labels.len();
    let values = box_range(c);
    let mut svg = String::new();
    {
        let width = u32::try_from(200 + 120 * rows)
            .unwrap_or(u32::MAX)
            .clamp(600, 2400);
        let root = SVGBackend::with_string(&mut svg, (width, 500)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(headline(&table.title), ("sans-serif", 18))?;
        let mut chart = ChartBuilder::on(&root)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(axis, values.clone())?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .y_desc(c.describe())
            .y_label_formatter(&|v| compact(Some(*v)))
            .draw()?;
        if c.reference.is_some() {
            chart.draw_series(DashedLineSeries::new(
                [(-0.5, 0.0), (right, 0.0)],
                6,
                4,
                ShapeStyle::from(&COLOURS[0]),
            ))?;
        }
        if c.rows.iter().all(|r| r.2 == 0) {
            chart.draw_series(std::iter::once(Text::new(
                "no finite values",
                (-0.4, values.start + 0.5 * (values.end - values.start)),
                ("sans-serif", 16),
            )))?;
        }
        for (i, (_, q, n)) in c.rows.iter().enumerate() {
            if *n == 0 {
                continue;
            }
            let x = i as f64;
            let colour = COLOURS[1 + i % (COLOURS.len() - 1)];
            let [min, p5, p25, median, p75, p95, max] = *q;
            let line = |points: Vec<(f64, f64)>, width: u32| {
                PathElement::new(points, colour.stroke_width(width))
            };
            chart.draw_series([
                line(
                    vec![
                        (x - 0.25, p25),
                        (x + 0.25, p25),
                        (x + 0.25, p75),
                        (x - 0.25, p75),
                        (x - 0.25, p25),
                    ],
                    2,
                ),
                line(vec![(x - 0.25, median), (x + 0.25, median)], 3),
                line(vec![(x, p75), (x, p95)], 1),
                line(vec![(x, p25), (x, p5)], 1),
                line(vec![(x - 0.1, p95), (x + 0.1, p95)], 1),
                line(vec![(x - 0.1, p5), (x + 0.1, p5)], 1),
            ])?;
            chart.draw_series(
                [min, max]
                    .into_iter()
                    .map(|v| Cross::new((x, v), 5, colour.stroke_width(1))),
            )?;
        }
        root.present()?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use liebayes::experiments::{Metric, Reduction, RunScores, StudyLabel};

    #[test]
    fn numbers_are_compact() {
        assert_eq!(compact(None), "-");
        assert_eq!(compact(Some(0.0)), "0");
        assert_eq!(compact(Some(1234.56)), "1235");
        assert_eq!(compact(Some(-0.5)), "-0.5000");
        assert_eq!(compact(Some(0.001_234_56)), "0.001235");
        assert_eq!(compact(Some(123_456.0)), "1.235e5");
        assert_eq!(compact(Some(1.5e-7)), "1.500e-7");
        assert_eq!(compact(Some(9.999_9)), "10.00");
        assert_eq!(compact(Some(f64::INFINITY)), "inf");
    }

    #[test]
    fn even_samples_keep_the_ends_and_the_bound() {
        assert_eq!(evenly(0, 10).count(), 0);
        assert_eq!(evenly(1, 10).collect::<Vec<_>>(), [0]);
        assert_eq!(evenly(5, 10).collect::<Vec<_>>(), [0, 1, 2, 3, 4]);
        assert_eq!(evenly(5, 1).collect::<Vec<_>>(), [0, 4]);
        let k: Vec<usize> = evenly(1_000_001, 1000).collect();
        assert_eq!(k.len(), 1000);
        assert_eq!((k[0], k[999]), (0, 1_000_000));
        assert!(k.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn csv_fields_are_quoted_when_needed() {
        assert_eq!(field("PF 1000"), "PF 1000");
        assert_eq!(field("exact, circle"), "\"exact, circle\"");
        assert_eq!(field("a \"b\""), "\"a \"\"b\"\"\"");
        assert_eq!(number(Some(0.1)).parse::<f64>(), Ok(0.1));
        assert_eq!(number(None), "");
    }

    /// A summary of `runs` of a synthetic two-metric study: run r scores error r, sigma 1 at
    /// epochs t = 1, 2.
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
        Table {
            name: "synthetic".to_owned(),
            title: "Synthetic".to_owned(),
            summaries,
            reference: None,
        }
    }

    #[test]
    fn the_table_prints_each_figure_and_the_failures() {
        // Runs 0..3 of B succeed and run 3 fails.
        let mut failing = summary("B", 0..3, 4);
        let mut failed = Summary::new(failing.label().clone(), 3..4).unwrap();
        failed.add_failure("step 3: diverged").unwrap();
        failing.merge(&failed).unwrap();
        let text = render(&table(vec![summary("A", 0..3, 3), failing]));
        // RMS of 0, 1, 2 is sqrt(5/3) = 1.291; runs 0, 1, 2 all diverged at the final epoch.
        assert!(text.contains("1.291") && text.contains("100.0%"), "{text}");
        assert!(
            text.contains("x_error (m)") && text.contains("ns/step"),
            "{text}"
        );
        assert!(text.contains("B: 1 of 4 runs failed") && text.contains("1 x step 3: diverged"));
        let csv = summary_csv(&table(vec![summary("A", 0..3, 3)]));
        assert_eq!(
            csv.lines().next(),
            Some(
                "filter,runs,failures,x_error_rms (m),x_sigma_rms (m),diverged_percent,ns_per_step"
            )
        );
        let over_time = over_time_csv(&table(vec![summary("A", 0..3, 3)]));
        assert_eq!(over_time.lines().count(), 3, "{over_time}");
        let first = first_run_csv(&table(vec![summary("A", 0..3, 3)]));
        assert_eq!(first.lines().nth(1), Some("A,0,1e0,0e0,1e0,0e0"));
    }

    #[test]
    fn a_trace_with_missing_values_survives_its_json() {
        let mut s = Summary::new(summary("A", 0..0, 1).label().clone(), 0..1).unwrap();
        let scores = RunScores {
            metrics: vec![Metric::new(
                "azimuth_error",
                Reduction::RootMeanSquare,
                "deg",
            )],
            times: vec![1.0],
            values: vec![f64::NAN],
            seconds_per_step: 1e-8,
        };
        s.add_run(0, &scores).unwrap();
        let text = serde_json::to_string(&table(vec![s])).unwrap();
        let back: Table = serde_json::from_str(&text).unwrap();
        assert!(back.summaries[0].trace().unwrap().values[0].is_nan());
    }

    #[test]
    fn plots_are_drawn_for_error_sigma_pairs_only() {
        let t = table(vec![summary("A", 0..3, 3), summary("B", 0..3, 3)]);
        let first = plot_first_run(&t).unwrap().unwrap();
        assert!(first.starts_with("<svg") && first.contains("x error"));
        let over = plot_over_time(&t).unwrap().unwrap();
        assert!(over.contains("x RMSE") && over.contains("\nB\n</text>"));
        let mut lone = Summary::new(summary("A", 0..0, 1).label().clone(), 0..1).unwrap();
        let scores = RunScores {
            metrics: vec![Metric::new("nees", Reduction::ChiSquare { dof: 2 }, "")],
            times: vec![1.0],
            values: vec![2.0],
            seconds_per_step: 1e-8,
        };
        lone.add_run(0, &scores).unwrap();
        assert!(
            plot_first_run(&table(vec![lone.clone()]))
                .unwrap()
                .is_none()
        );
        assert!(plot_over_time(&table(vec![lone])).unwrap().is_none());
    }

    /// A summary of `runs` of a study with a per-run RMS error: run r scores `error(r)` at both
    /// of its two epochs (so its run value is `error(r)`), and a mean that is not kept per run.
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

    /// Rows A (run r: error r + 1), B (1.5 times A's) and C ((r + 1)², so 100 r % above A), of
    /// the runs `runs` of 10, compared with `reference`.
    fn compared(runs: Range<u64>, reference: Option<usize>) -> Table {
        let one = |r: u64| (r + 1) as f64;
        Table {
            reference,
            ..table(vec![
                per_run_summary("A", runs.clone(), 10, one),
                per_run_summary("B", runs.clone(), 10, move |r| 1.5 * one(r)),
                per_run_summary("C", runs, 10, move |r| one(r) * one(r)),
            ])
        }
    }

    #[test]
    fn rows_are_compared_with_the_reference_run_by_run() {
        let comparisons = compared(0..10, Some(0)).run_comparisons();
        assert_eq!(comparisons.len(), 1, "only x_error is kept per run");
        let c = &comparisons[0];
        assert_eq!((c.metric.as_str(), c.kind()), ("x_error", "relative"));
        assert_eq!(c.reference.as_deref(), Some("A"));
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
        let text = render_runs(&compared(0..10, Some(0)), c);
        assert!(
            text.contains("percentage difference of x_error from A, per run (%)"),
            "{text}"
        );
        assert!(text.contains("median") && text.contains("450.0"), "{text}");
        let csv = runs_csv(c);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines[0],
            "filter,min (%),p5 (%),p25 (%),median (%),p75 (%),p95 (%),max (%),runs"
        );
        assert_eq!(lines.len(), 3);
        assert!(lines[2].starts_with("C,0e0,4.5e1,") && lines[2].ends_with(",9e2,10"));
        // Without a reference: the run values themselves, every row.
        let c = &compared(0..10, None).run_comparisons()[0];
        assert_eq!(
            (c.kind(), c.unit.as_str(), c.rows.len()),
            ("per_run", "m", 3)
        );
        // A's values 1, …, 10: median 5.5.
        assert_eq!(c.rows[0].1[3], 5.5);
        assert!(render_runs(&compared(0..10, None), c).contains("x_error per run (m)"));
    }

    #[test]
    fn merged_shards_give_the_whole_runs_per_run_csv() {
        let whole = compared(0..10, Some(1));
        let mut merged = compared(6..10, Some(1));
        merged.merge(&compared(0..3, Some(1))).unwrap();
        merged.merge(&compared(3..6, Some(1))).unwrap();
        assert!(merged.missing_runs().is_empty());
        let csv = |t: &Table| t.run_comparisons().iter().map(runs_csv).collect::<Vec<_>>();
        assert_eq!(csv(&merged), csv(&whole));
        // Through a file, with the reference row.
        let text = serde_json::to_string(&merged).unwrap();
        assert!(text.contains(r#""reference":1"#), "{text}");
        let back: Table = serde_json::from_str(&text).unwrap();
        assert_eq!(csv(&back), csv(&whole));
        // Shards compared with different rows do not merge.
        let mut other = compared(0..3, Some(0));
        let before = other.clone();
        let error = other.merge(&compared(3..6, Some(1))).unwrap_err();
        assert!(error.to_string().contains("reference row"), "{error}");
        assert_eq!(other, before);
    }

    #[test]
    fn a_reference_outside_the_rows_is_refused_and_nothing_written() {
        let dir = std::env::temp_dir().join(format!("liebayes-report-runs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let args = OutputArgs {
            out: Some(dir.clone()),
            shard: Shard::WHOLE,
        };
        let bad = compared(0..10, Some(3));
        let error = check_table(&bad).unwrap_err().to_string();
        assert!(error.contains("table synthetic") && error.contains("reference row 3"));
        let output = crate::output::prepare(&args).unwrap();
        assert!(emit(&[bad], &args, output).is_err());
        let names = |dir: &Path| -> Vec<String> {
            let mut names: Vec<String> = std::fs::read_dir(dir)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            names.sort();
            names
        };
        // Nothing written: the folder the output created is removed with the failure.
        assert!(!dir.exists());
        // A good table writes the per-run files beside the others.
        let output = crate::output::prepare(&args).unwrap();
        emit(&[compared(0..10, Some(0))], &args, output).unwrap();
        let written = names(&dir);
        for file in [
            "synthetic.summary.json",
            "synthetic_x_error_relative.csv",
            "synthetic_x_error_relative.svg",
        ] {
            assert!(
                written.iter().any(|w| w == file),
                "{file} not in {written:?}"
            );
        }
        assert!(
            !written.iter().any(|w| w.contains("per_run")),
            "{written:?}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
        // A metric kept per run whose name cannot name a file is refused (as the table is read).
        let mut json = serde_json::to_value(compared(0..10, None)).unwrap();
        json["summaries"][0]["metrics"][0]["name"] = serde_json::json!("a/b");
        let error = serde_json::from_value::<Table>(json).unwrap_err();
        assert!(error.to_string().contains("\"a/b\""), "{error}");
    }

    #[test]
    fn box_plots_label_every_row() {
        let t = compared(0..10, Some(0));
        let c = &t.run_comparisons()[0];
        let svg = plot_runs(&t, c).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.contains("Synthetic"),
            "{svg}"
        );
        for label in ["\nB\n</text>", "\nC\n</text>", "percentage difference"] {
            assert!(svg.contains(label), "{label} missing");
        }
        // Rows without a finite value are drawn empty, not refused.
        let empty = RunComparison {
            rows: vec![("A".to_owned(), [f64::NAN; 7], 0)],
            ..c.clone()
        };
        assert!(plot_runs(&t, &empty).unwrap().contains("no finite values"));
        assert_eq!(box_range(&empty), -1.0..1.0);
    }
}
