//! `liebayes attitude`: IMU attitude estimation on BROAD trials (`--broad DIR`), on a simulated log
//! (`--simulate`, or a study of many with `--runs N`) or on a user's CSV log (`--csv FILE`). The
//! runs and their scores come from the library ([`evaluate`], [`Study`]); this module parses,
//! dispatches and renders the tables, plots and files (written all or nothing).

use crate::error::{CliError, Context as _};
use crate::output::{self, OutputArgs};
use crate::report::{emit, print, stage};
use crate::sheet::Sheet;
use liebayes::experiments::Table;
use liebayes::experiments::{MAX_EPOCHS, MAX_STUDY_EPOCHS, Shard, Study};
use liebayes::filters::attitude::{
    AtRate, AttitudeParams, AttitudeScorer, Evaluation, ImuScenario, LogRecording, LogScenario,
    MEASURED_FIELD_OFFSET, Method, Sensors, SimulationSettings, estimates, read_broad,
    read_imu_csv_at_most, run_log, sample_errors, simulate, write_estimates_csv,
};
use liebayes::filters::{FilterError, attitude::evaluate};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// The methods compared when none is named, in table order.
const DEFAULT_METHODS: [&str; 4] = ["ekf-9d", "ekf-6d", "talk-9d", "madgwick-9d"];

/// The methods of the main job's BROAD run: the talk filter (the slowest, docs/benchmarks.md) runs there on
/// the simulated log only.
const MAIN_JOB_BROAD_METHODS: [&str; 4] = ["ekf-9d", "ekf-6d", "ekf-offline-9d", "madgwick-9d"];

/// The methods of `--offline`: the production filter's smoothed estimates.
const OFFLINE_METHODS: [&str; 2] = ["ekf-offline-9d", "ekf-offline-6d"];

/// VQF's published mean errors on BROAD's twelve undisturbed/disturbed trials (BROAD's README):
/// (label, total, heading, inclination) in degrees.
const VQF_PUBLISHED: [(&str, f64, f64, f64); 3] = [
    ("VQF 9D default", 2.76, 2.61, 0.70),
    ("VQF 9D tauAcc=3 tauMag=20", 2.44, 2.27, 0.70),
    ("offline VQF 9D (acausal)", 2.25, 2.16, 0.49),
];

/// `liebayes attitude`: exactly one of --broad, --simulate, --csv.
#[derive(clap::Args, Debug, Clone)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["broad", "simulate", "csv"])))]
pub struct Args {
    /// A folder of BROAD trials (`*.mat`): every trial, every method, against the reference.
    #[arg(long, value_name = "DIR")]
    pub broad: Option<PathBuf>,
    /// A simulated log (one minute at 285.7 Hz by default) scored against its truth.
    #[arg(long)]
    pub simulate: bool,
    /// A CSV IMU log (`t,gx,gy,gz,ax,ay,az[,mx,my,mz]`): the EKF's estimates (9D, or 6D without a
    /// magnetometer).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// A method to run (repeat for several; default ekf-9d, ekf-6d, talk-9d, madgwick-9d): one of
    /// ekf-9d, ekf-6d, ekf-offline-9d, ekf-offline-6d, talk-9d, talk-6d, madgwick-9d, madgwick-6d.
    #[arg(long = "method", value_name = "NAME", value_parser = parse_method,
          conflicts_with_all = ["csv", "runs"])]
    pub methods: Vec<Method>,
    /// The offline estimate: the production filter's smoother over the whole log, every sample
    /// given every sample (ekf-offline-9d and ekf-offline-6d; with --csv, the one the log's
    /// sensors allow).
    #[arg(long, conflicts_with_all = ["methods", "runs"])]
    pub offline: bool,
    /// The simulation's seed.
    #[arg(long, default_value_t = 1, requires = "simulate")]
    pub seed: u64,
    /// The simulated log's number of samples, 2 to 16777216 (2^24, the most steps a run records;
    /// default: the simulator's one minute).
    #[arg(long, requires = "simulate", value_parser = parse_samples)]
    pub samples: Option<usize>,
    /// With --simulate: a study of this many independent simulated runs through the experiment
    /// layer instead (the field offset the filter models, a magnetometer reading every 10th
    /// sample; the EKF 9D told the simulated sensor noise): errors against the reported σ over
    /// time, NEES against χ² bands.
    #[arg(long, requires = "simulate", value_name = "N")]
    pub runs: Option<u64>,
    /// Folder for the estimates CSV files, error plots and `broad.summary.json` (nothing is
    /// written without it).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// A method by name ([`METHOD_NAMES`]).
fn parse_method(name: &str) -> Result<Method, CliError> {
    Ok(Method::from_name(name)?)
}

/// `--samples`, checked as the command line is parsed, before anything is simulated: from 2 (the
/// fewest a rate is inferred from) to [`MAX_EPOCHS`], the most steps a run records (each filter's
/// run, and each run of a study, records every sample).
fn parse_samples(text: &str) -> Result<usize, CliError> {
    text.parse()
        .ok()
        .filter(|n| (2..=MAX_EPOCHS).contains(n))
        .ok_or_else(|| {
            format!(
                "give a whole number from 2 to {MAX_EPOCHS} (2^24, the most steps a run records)"
            )
            .into()
        })
}

/// The named methods, or `names` when none was given.
fn methods_or(given: &[Method], names: &[&str]) -> Result<Vec<Method>, CliError> {
    if !given.is_empty() {
        return Ok(given.to_vec());
    }
    names.iter().map(|n| parse_method(n)).collect()
}

/// Runs `liebayes attitude` (`--samples` was checked as the command line was parsed).
///
/// # Errors
/// Bad input (missing folder, no trial, malformed file, a CSV log longer than a run records), a
/// failed filter, or a file that cannot be written; nothing is written then.
pub fn run(args: &Args) -> Result<(), CliError> {
    check_args(args)?;
    let mut output = output::prepare(&whole(args.out.clone()))?;
    let defaults: &[&str] = if args.offline {
        &OFFLINE_METHODS
    } else {
        &DEFAULT_METHODS
    };
    if let Some(dir) = &args.broad {
        let methods = methods_or(&args.methods, defaults)?;
        broad(&BroadTrials::read(dir)?, &methods, &mut output)?;
    } else if let Some(file) = &args.csv {
        csv(file, args.offline, &mut output)?;
    } else {
        let mut settings = SimulationSettings::default();
        if let Some(n) = args.samples {
            settings.samples = n;
        }
        if let Some(runs) = args.runs {
            let table = study(&settings, runs, args.seed)?;
            return emit(&[table], &whole(args.out.clone()), output);
        }
        let methods = methods_or(&args.methods, defaults)?;
        simulated(&settings, args.seed, &methods, &mut output)?;
    }
    output.finish()
}

/// What the command line alone decides, checked before any folder is made or file read: no
/// method named twice (each writes files of its own name), a study's samples within the epochs a
/// study holds (it scores every [`STUDY_MAGNETOMETER_EVERY`]th sample), and `--csv`'s output
/// file names plain names (they are made of the input file's name).
///
/// # Errors
/// The argument and what to change.
fn check_args(args: &Args) -> Result<(), CliError> {
    for (k, method) in args.methods.iter().enumerate() {
        if args.methods[..k].contains(method) {
            return Err(format!("--method {} is given twice", slug(method)).into());
        }
    }
    if let (Some(_), Some(samples)) = (args.runs, args.samples) {
        let most = MAX_STUDY_EPOCHS * STUDY_MAGNETOMETER_EVERY;
        if samples > most {
            return Err(format!(
                "--samples is {samples}: a study (--runs) takes at most {most} samples (it scores \
                 every {STUDY_MAGNETOMETER_EVERY}th, at most {MAX_STUDY_EPOCHS} epochs)"
            )
            .into());
        }
    }
    if let (Some(file), Some(_)) = (&args.csv, &args.out) {
        for filter in ["ekf", "ekf-offline"] {
            for sensors in ["9d", "6d"] {
                let method = parse_method(&format!("{filter}-{sensors}"))?;
                output::check_name(&csv_output_name(file, &method)).map_err(|e| {
                    CliError::from(format!(
                        "--csv {}: its estimates are written under the input's name, and {e}: \
                         rename the input file",
                        file.display()
                    ))
                })?;
            }
        }
    }
    Ok(())
}

/// The estimates file `--csv` writes for `method`: the input's stem and the method's slug.
fn csv_output_name(file: &Path, method: &Method) -> String {
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    format!("{stem}.{}.csv", slug(method))
}

/// Samples between magnetometer readings in the study (a magnetometer at a tenth of the
/// gyroscope's rate, as in many IMUs).
const STUDY_MAGNETOMETER_EVERY: usize = 10;

/// Runs in the main job's study.
const MAIN_JOB_STUDY_RUNS: u64 = 32;

/// `runs` independent simulated logs of `settings` (with the field offset the filter models)
/// through the experiment layer, the EKF 9D told the simulator's sensor noise
/// (`SimulationSettings::matched_noise`) on each: one table of per-epoch errors, reported σ and
/// NEES. (The 6D heading starts at zero, which is the simulator's own start: its heading error
/// would mean nothing here.)
fn study(settings: &SimulationSettings, runs: u64, seed: u64) -> Result<Table, CliError> {
    let settings = SimulationSettings {
        field_offset: Some(MEASURED_FIELD_OFFSET),
        ..settings.clone()
    };
    let params = settings
        .matched_noise(AttitudeParams::default())
        .context(|| "--simulate --runs".to_owned())?;
    let (rate, samples) = (settings.rate, settings.samples);
    let scenario = ImuScenario::new(settings, STUDY_MAGNETOMETER_EVERY)
        .context(|| "--simulate --runs".to_owned())?;
    let method = AtRate {
        method: Method::Ekf {
            params,
            sensors: Sensors::NineD,
        },
        rate,
    };
    let summary = Study::new("EKF 9D", runs, seed, Shard::WHOLE)
        .and_then(|s| s.run_method(&scenario, &method, &AttitudeScorer, &|_| {}))
        .context(|| format!("--simulate --runs {runs}"))?;
    Ok(Table {
        name: "attitude_study".to_owned(),
        title: format!(
            "Attitude study: {runs} simulated runs of {samples} samples at {rate:.1} Hz (field \
             offset as modelled, a magnetometer reading every {STUDY_MAGNETOMETER_EVERY} samples, \
             the filter told the simulated sensor noise), seed {seed}"
        ),
        summaries: vec![summary],
        reference: None,
    })
}

/// The seed of the main job's simulated log and study.
const MAIN_JOB_SEED: u64 = 1;

/// The name of the simulated log of `seed` (its files are `{name}.{method}.csv`).
fn simulated_name(seed: u64) -> String {
    format!("simulated_seed{seed}")
}

/// The main job's attitude part: every method on a simulated log, a study of simulated runs, and
/// the BROAD `trials` (read before the main job's first study); files in `out`, all committed
/// together when the part has succeeded.
///
/// # Errors
/// As [`run`].
pub fn main_job(out: &Path, trials: &BroadTrials) -> Result<(), CliError> {
    let settings = whole(Some(out.to_path_buf()));
    let mut output = output::prepare(&settings)?;
    let methods = methods_or(&[], &DEFAULT_METHODS)?;
    simulated(
        &SimulationSettings::default(),
        MAIN_JOB_SEED,
        &methods,
        &mut output,
    )?;
    let table = study(
        &SimulationSettings::default(),
        MAIN_JOB_STUDY_RUNS,
        MAIN_JOB_SEED,
    )?;
    stage(&[table], &settings, &mut output)?;
    print(&format!(
        "\nBROAD trials in {} (the talk filter, over a hundred times slower per sample than the \
         others, runs on the simulated log only here; `liebayes attitude --broad DIR` runs every \
         method):",
        trials.dir.display()
    ));
    broad(
        trials,
        &methods_or(&[], &MAIN_JOB_BROAD_METHODS)?,
        &mut output,
    )?;
    output.finish()
}

/// BROAD trials read and checked before anything runs on them: a bad folder or file fails the
/// command before any work.
pub struct BroadTrials {
    /// The folder read.
    dir: PathBuf,
    /// Each trial's name (its file's stem, a plain file name) and log, in file-name order.
    logs: Vec<(String, LogScenario)>,
}

impl BroadTrials {
    /// Reads every `*.mat` trial of `dir`.
    ///
    /// # Errors
    /// A folder that cannot be listed or holds no `.mat` file, a trial that does not read (the
    /// message names the file), or a trial whose name is not a plain file name.
    pub fn read(dir: &Path) -> Result<Self, CliError> {
        let paths = broad_trials(dir)?;
        // Every trial's output names first: a name too long for them would otherwise fail at its
        // first write, after the runs of the trials before it.
        let names = paths
            .iter()
            .map(|path| {
                let name = path
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                check_trial_name(&name).map(|()| name)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut logs = Vec::with_capacity(paths.len());
        for (path, name) in paths.iter().zip(names) {
            let log = read_broad(path)?;
            logs.push((name, LogScenario::new(log)?));
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            logs,
        })
    }

    /// The main job's trials: those of the folder `$LIEBAYES_BROAD_DIR` names, or else the two
    /// shipped with the repository (`data/broad`).
    ///
    /// # Errors
    /// As [`read`](Self::read).
    pub fn main_job() -> Result<Self, CliError> {
        let dir = std::env::var_os("LIEBAYES_BROAD_DIR").map_or_else(
            || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/broad"),
            PathBuf::from,
        );
        let trials = Self::read(&dir)?;
        // The main job writes the simulated log's files into the same folder as the trials'.
        let simulated = simulated_name(MAIN_JOB_SEED);
        if let Some((name, _)) = trials.logs.iter().find(|(name, _)| *name == simulated) {
            return Err(format!(
                "the BROAD trial {name}.mat in {} takes the name of the main job's simulated log: \
                 rename the trial file",
                dir.display()
            )
            .into());
        }
        Ok(trials)
    }
}

/// Refuses a trial name that is not a plain file name or too long for the names of its output
/// files (`{name}.{method}.csv` for every method, `{name}.errors.svg`).
///
/// # Errors
/// The name and the file name it would give.
fn check_trial_name(name: &str) -> Result<(), CliError> {
    output::check_name(name)?;
    let mut files = vec![format!("{name}.errors.svg")];
    for method in liebayes::filters::attitude::METHOD_NAMES {
        files.push(format!("{name}.{}.csv", slug(&parse_method(method)?)));
    }
    for file in files {
        output::check_name(&file).map_err(|_| {
            CliError::Invalid(format!(
                "the BROAD trial name {name:?} makes the output name {file:?}, longer than a \
                 file name may be here: rename the trial file"
            ))
        })?;
    }
    Ok(())
}

/// The sorted `*.mat` files of `dir`.
fn broad_trials(dir: &Path) -> Result<Vec<PathBuf>, CliError> {
    let entries = std::fs::read_dir(dir)
        .context(|| format!("cannot read the BROAD folder {}", dir.display()))?;
    let mut trials: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "mat"))
        .collect();
    trials.sort();
    // A FIFO or a device named like a trial would block the reader or never end.
    if let Some(odd) = trials
        .iter()
        .find(|p| !p.metadata().is_ok_and(|m| m.is_file()))
    {
        return Err(format!(
            "{} is named like a BROAD trial but is not a regular file: move it out of the folder",
            odd.display()
        )
        .into());
    }
    if trials.is_empty() {
        return Err(format!("the BROAD folder {} holds no .mat trial", dir.display()).into());
    }
    Ok(trials)
}

/// The file-name slug of a method: its name, `ekf-9d`.
fn slug(method: &Method) -> String {
    method.label().to_lowercase().replace(' ', "-")
}

/// Runs every method on every log, writing each run's estimates (and, for the first method, its
/// error plot) when there is an output folder; prints the tables.
fn compare(
    logs: &[(String, LogScenario)],
    methods: &[Method],
    title: &str,
    output: &mut output::Output,
) -> Result<Evaluation, CliError> {
    let writing = output.dir().is_some();
    let evaluation = evaluate(logs, methods, &mut |name, method, recording| {
        if writing {
            let file = format!("{name}.{}.csv", slug(method));
            write_estimates(output, &file, recording)?;
            if *method == methods[0] {
                let svg = errors_svg(name, &method.label(), recording).map_err(|message| {
                    FilterError::Setting {
                        origin: "error plot",
                        setting: "svg",
                        value: message,
                        expected: "a plot that renders",
                    }
                })?;
                output.write(&format!("{name}.errors.svg"), svg.as_bytes())?;
            }
        }
        Ok::<_, CliError>(())
    })?;
    print_tables(&evaluation, title);
    Ok(evaluation)
}

/// The RMSE table (per log, and the mean over logs) and the NEES and throughput table.
fn print_tables(evaluation: &Evaluation, title: &str) {
    let mut header = vec!["trial".to_owned()];
    for method in &evaluation.methods {
        header.extend([format!("{method} total"), "heading".into(), "incl.".into()]);
    }
    let cell = |e: Option<[f64; 3]>| {
        e.map_or_else(
            || ["-".into(), "-".into(), "-".into()],
            |e| e.map(|v| format!("{v:.2}")),
        )
    };
    let mut rows: Vec<Vec<String>> =
        evaluation
            .trials
            .iter()
            .zip(&evaluation.scores)
            .map(|(name, row)| {
                std::iter::once(name.clone())
                    .chain(row.iter().flat_map(|s| {
                        cell(s.errors().map(|e| [e.total, e.heading, e.inclination]))
                    }))
                    .collect()
            })
            .collect();
    if evaluation.trials.len() > 1 {
        rows.push(
            std::iter::once("mean".to_owned())
                .chain((0..evaluation.methods.len()).flat_map(|j| cell(evaluation.mean_errors(j))))
                .collect(),
        );
    }
    print(
        &Sheet {
            name: String::new(),
            title: format!(
                "{title}: RMSE (deg) of the total / heading / inclination error over the samples \
                 that count (BROAD's metric)"
            ),
            header,
            rows,
        }
        .render(),
    );
    let rows = evaluation
        .methods
        .iter()
        .enumerate()
        .filter_map(|(j, method)| {
            let pooled = evaluation.pooled(j)?;
            let nees = pooled.nees();
            let show = |i: usize| nees.map_or_else(|| "-".into(), |n| format!("{:.2}", n[i]));
            Some(vec![
                method.clone(),
                show(0),
                show(1),
                show(2),
                format!("{:.0}", pooled.throughput()),
            ])
        })
        .collect();
    print(
        &Sheet {
            name: String::new(),
            title: format!(
                "{title}: the reported uncertainty (NEES pooled over the samples that count) and \
                 the speed"
            ),
            header: ["method", "heading NEES", "tilt NEES", "NEES", "samples/s"]
                .map(String::from)
                .to_vec(),
            rows,
        }
        .render(),
    );
    print(
        "NEES: the squared error over the filter's own variance, chi-square with 1 (heading), 2 \
         (tilt) and 3 (whole attitude) degrees of freedom: a consistent filter's means are 1, 2 \
         and 3; above, it is over-confident; below, cautious. '-': the filter reports no \
         uncertainty. Consecutive samples are correlated, so a log's mean wanders further from \
         these values than independent samples would.",
    );
}

/// `--broad`: every trial, the tables with VQF's published row, and `broad.summary.json`.
fn broad(
    trials: &BroadTrials,
    methods: &[Method],
    output: &mut output::Output,
) -> Result<(), CliError> {
    let evaluation = compare(&trials.logs, methods, "BROAD", output)?;
    print(
        "VQF's published means over BROAD's twelve trials (not run here; total / heading / inclination):",
    );
    for (label, total, heading, inclination) in VQF_PUBLISHED {
        print(&format!(
            "  {label}: {total:.2} / {heading:.2} / {inclination:.2} deg"
        ));
    }
    if output.dir().is_some() {
        let text = serde_json::to_string_pretty(&summary_json(&evaluation))?;
        output.write("broad.summary.json", text.as_bytes())?;
    }
    Ok(())
}

/// The evaluation as JSON: per trial each method's RMSE, per method its pooled NEES (heading,
/// tilt, whole) and throughput.
fn summary_json(evaluation: &Evaluation) -> serde_json::Value {
    let trials: Vec<serde_json::Value> = evaluation
        .trials
        .iter()
        .zip(&evaluation.scores)
        .map(|(name, row)| {
            let errors: serde_json::Map<String, serde_json::Value> = evaluation
                .methods
                .iter()
                .zip(row)
                .map(|(m, s)| {
                    let e = s.errors().map(|e| [e.total, e.heading, e.inclination]);
                    (m.clone(), serde_json::json!(e))
                })
                .collect();
            serde_json::json!({"trial": name, "errors": errors})
        })
        .collect();
    let per_method =
        |f: &dyn Fn(usize) -> serde_json::Value| -> serde_json::Map<String, serde_json::Value> {
            evaluation
                .methods
                .iter()
                .enumerate()
                .map(|(j, m)| (m.clone(), f(j)))
                .collect()
        };
    serde_json::json!({
        "methods": evaluation.methods,
        "trials": trials,
        "nees": per_method(&|j| serde_json::json!(evaluation.pooled(j).and_then(|p| p.nees()))),
        "throughput": per_method(&|j| serde_json::json!(evaluation.pooled(j).map(|p| p.throughput()))),
    })
}

/// `--simulate`: every method on one simulated log.
fn simulated(
    settings: &SimulationSettings,
    seed: u64,
    methods: &[Method],
    output: &mut output::Output,
) -> Result<(), CliError> {
    let log = simulate(settings, seed).context(|| "--simulate".to_owned())?;
    let n = log.len();
    let logs = vec![(simulated_name(seed), LogScenario::new(log)?)];
    compare(
        &logs,
        methods,
        &format!("Simulated log ({n} samples, seed {seed})"),
        output,
    )?;
    Ok(())
}

/// `--csv`: the EKF (9D, or 6D without a magnetometer; `offline`: its smoother) on a user's log.
/// The run records every sample, so a log longer than [`MAX_EPOCHS`] samples is refused as it is
/// read, at its first line beyond them, before the filter runs.
fn csv(file: &Path, offline: bool, output: &mut output::Output) -> Result<(), CliError> {
    let origin = file.display().to_string();
    let reader = std::fs::File::open(file).context(|| origin.clone())?;
    let log = read_imu_csv_at_most(std::io::BufReader::new(reader), &origin, MAX_EPOCHS)?;
    let sensors = if log.magnetometer().is_some() {
        "9d"
    } else {
        "6d"
    };
    let filter = if offline { "ekf-offline" } else { "ekf" };
    let method = parse_method(&format!("{filter}-{sensors}"))?;
    let n = log.len();
    let scenario = LogScenario::new(log)?;
    let recording = run_log(&origin, &scenario, &method)?;
    print(&format!("{} on {origin}: {n} samples", method.label()));
    if let Some(e) = liebayes::filters::attitude::LogScore::of(&recording).errors() {
        print(&format!(
            "RMSE (deg): total {:.2}, heading {:.2}, inclination {:.2}",
            e.total, e.heading, e.inclination
        ));
    }
    if output.dir().is_some() {
        write_estimates(output, &csv_output_name(file, &method), &recording)?;
    }
    Ok(())
}

/// Writes a run's estimates as the file `file` of the output, in the CSV format of
/// `write_estimates_csv`, streamed to disk (a failed write names that file).
fn write_estimates(
    output: &mut output::Output,
    file: &str,
    recording: &LogRecording,
) -> Result<(), CliError> {
    let (times, orientations): (Vec<f64>, Vec<_>) = estimates(recording)
        .map(|(s, e)| (s.time, e.orientation))
        .unzip();
    let target = output
        .dir()
        .map_or_else(|| file.to_owned(), |d| d.join(file).display().to_string());
    output.write_with(file, |writer| {
        Ok(write_estimates_csv(writer, &times, &orientations, &target)?)
    })
}

/// The most samples an error plot draws: a 1000-pixel-wide plot of a 2²⁴-sample log would
/// otherwise be an SVG of hundreds of megabytes.
const MAX_PLOTTED_SAMPLES: usize = 4000;

/// The SVG of a run's heading and inclination errors over time (deg) with its ±2σ band where the
/// filter reports one, over the samples that count (every k-th, at most
/// [`MAX_PLOTTED_SAMPLES`] of them).
fn errors_svg(name: &str, label: &str, recording: &LogRecording) -> Result<String, String> {
    let err = |e: DrawingAreaErrorKind<_>| e.to_string();
    let stride = recording.steps.len().div_ceil(MAX_PLOTTED_SAMPLES).max(1);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 700)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let panels = root.split_evenly((2, 1));
        let t_end = recording.steps.last().map_or(1.0, |s| s.time).max(1e-9);
        for (i, (panel, axis)) in panels.iter().zip(["heading", "inclination"]).enumerate() {
            let mut errors = Vec::new();
            let mut band = Vec::new();
            for (step, estimate) in estimates(recording).step_by(stride) {
                let Some(truth) = &step.truth else { continue };
                let e = sample_errors(&estimate.orientation, truth);
                errors.push((
                    step.time,
                    if i == 0 { e.heading } else { e.inclination }.to_degrees(),
                ));
                if let Some((h, t)) = estimate.sigmas() {
                    band.push((step.time, 2.0 * if i == 0 { h } else { t }.to_degrees()));
                }
            }
            let top = errors
                .iter()
                .chain(&band)
                .map(|p| p.1)
                .fold(1.0_f64, f64::max)
                .min(180.0);
            let mut chart = ChartBuilder::on(panel)
                .caption(format!("{name}: {label} {axis} error"), ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(30)
                .y_label_area_size(50)
                .build_cartesian_2d(crate::report::axis(0.0, t_end, 0.0..1.0), 0.0..top * 1.05)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("t (s)")
                .y_desc(format!("{axis} error (deg)"))
                .draw()
                .map_err(err)?;
            chart
                .draw_series(LineSeries::new(errors, BLUE.stroke_width(1)))
                .map_err(err)?
                .label("error")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLUE));
            chart
                .draw_series(LineSeries::new(band, RED.stroke_width(1)))
                .map_err(err)?
                .label("2 sigma")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], RED));
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

fn whole(out: Option<PathBuf>) -> OutputArgs {
    OutputArgs {
        out,
        shard: Shard::WHOLE,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use liebayes::filters::attitude::METHOD_NAMES;

    #[test]
    fn every_listed_method_name_parses_and_others_do_not() {
        for name in METHOD_NAMES {
            assert!(parse_method(name).is_ok(), "{name}");
        }
        assert!(
            parse_method("vqf")
                .unwrap_err()
                .to_string()
                .contains("ekf-9d")
        );
    }
}
