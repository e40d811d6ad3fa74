//! `liebayes attitude`: IMU attitude estimation on BROAD trials (`--broad DIR`), on a simulated log
//! (`--simulate`) or on a user's CSV log (`--csv FILE`): the liebayes EKF (9D and 6D), the talk's
//! filter and Madgwick's, their errors, NEES and throughput, files written all or nothing.

use crate::output::{self, OutputArgs};
use crate::report::{Table, emit, print};
use crate::sheet::Sheet;
use liebayes::experiments::{Shard, Study};
use liebayes::filters::attitude::{
    AttitudeEkf, AttitudeParams, AttitudeScorer, AttitudeTrack, BROAD_BETA, ImuLog, ImuScenario,
    NeesSums, Sensors, SimulationSettings, TalkParams, per_sample_errors, read_broad, read_imu_csv,
    run_attitude_ekf, run_madgwick, run_talk_filter, simulate, track_nees, trial_errors,
    write_estimates_csv,
};
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The methods compared, in table order.
pub const METHODS: [&str; 4] = [
    "liebayes EKF 9D",
    "liebayes EKF 6D",
    "talk filter 9D",
    "Madgwick",
];

/// VQF's published mean errors on BROAD's twelve undisturbed/disturbed trials (BROAD's README):
/// (label, total, heading, inclination) in degrees.
const VQF_PUBLISHED: [(&str, f64, f64, f64); 2] = [
    ("VQF 9D default (published, not run here)", 2.76, 2.61, 0.70),
    (
        "VQF 9D tauAcc=3 tauMag=20 (published, not run here)",
        2.44,
        2.27,
        0.70,
    ),
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
    /// The simulation's seed.
    #[arg(long, default_value_t = 1, requires = "simulate")]
    pub seed: u64,
    /// The simulated log's number of samples (default: the simulator's one minute).
    #[arg(long, requires = "simulate")]
    pub samples: Option<usize>,
    /// With --simulate: a study of this many independent simulated runs through the experiment
    /// layer instead (the field offset the filter models, a magnetometer reading every 10th
    /// sample; the EKF 9D): errors against the reported σ over time, NEES against χ² bands.
    #[arg(long, requires = "simulate", value_name = "N")]
    pub runs: Option<u64>,
    /// Folder for the estimates CSV files, error plots and `broad.summary.json` (nothing is
    /// written without it).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// Runs `liebayes attitude`.
///
/// # Errors
/// Bad input (missing folder, no trial, malformed file), a failed filter, or a file that cannot be
/// written; nothing is written then.
pub fn run(args: &Args) -> Result<(), String> {
    if let Some(dir) = &args.broad {
        let trials = broad_trials(dir)?;
        let mut output = output::prepare(&whole(args.out.clone()))?;
        broad(&trials, true, &mut output)?;
        output.finish()
    } else if let Some(file) = &args.csv {
        let mut output = output::prepare(&whole(args.out.clone()))?;
        csv(file, &mut output)?;
        output.finish()
    } else {
        let mut settings = SimulationSettings::default();
        if let Some(n) = args.samples {
            if n < 2 {
                return Err(format!("--samples is {n}: it must be at least 2"));
            }
            settings.samples = n;
        }
        let output = output::prepare(&whole(args.out.clone()))?;
        if let Some(runs) = args.runs {
            let table = study(&settings, runs, args.seed)?;
            return emit(&[table], &whole(args.out.clone()), output);
        }
        let mut output = output;
        simulated(&settings, args.seed, &mut output)?;
        output.finish()
    }
}

/// Samples between magnetometer readings in the study (a magnetometer at a tenth of the
/// gyroscope's rate, as in many IMUs).
const STUDY_MAGNETOMETER_EVERY: usize = 10;

/// Runs in the main job's study.
const MAIN_JOB_STUDY_RUNS: u64 = 32;

/// `runs` independent simulated logs of `settings` (with the field offset the filter models)
/// through the experiment layer, the EKF 9D on each: one table of per-epoch errors, reported σ
/// and NEES. (The 6D heading starts at zero, which is the simulator's own start: its heading
/// error would mean nothing here.)
fn study(settings: &SimulationSettings, runs: u64, seed: u64) -> Result<Table, String> {
    let params = AttitudeParams::default();
    let settings = SimulationSettings {
        field_offset: params.magnetometer.offset,
        ..settings.clone()
    };
    let (rate, samples) = (settings.rate, settings.samples);
    let scenario = ImuScenario::new(settings, STUDY_MAGNETOMETER_EVERY)
        .map_err(|e| format!("--simulate --runs: {e}"))?;
    let prototype = AttitudeEkf::new(params, Sensors::NineD, rate).map_err(|e| e.to_string())?;
    let summary = Study::new("EKF 9D", runs, seed, Shard::WHOLE)
        .and_then(|s| {
            s.run(
                &scenario,
                &|_| Ok(prototype.clone()),
                &AttitudeScorer,
                &|_| {},
            )
        })
        .map_err(|e| format!("--simulate --runs {runs}: {e}"))?;
    Ok(Table {
        name: "attitude_study".to_owned(),
        title: format!(
            "Attitude study: {runs} simulated runs of {samples} samples at {rate:.1} Hz (field \
             offset as modelled, a magnetometer reading every {STUDY_MAGNETOMETER_EVERY} samples), \
             seed {seed}"
        ),
        summaries: vec![summary],
        reference: None,
    })
}

/// The main job's attitude part: the simulated log, a study of simulated runs, and BROAD's trials
/// when the BROAD folder beside the project (or `$LIEBAYES_BROAD_DIR`) holds any (the talk filter,
/// ~130 µs per sample, runs on the simulated log only), files in `out`.
///
/// # Errors
/// As [`run`].
pub fn main_job(out: &Path) -> Result<(), String> {
    let mut output = output::prepare(&whole(Some(out.to_path_buf())))?;
    simulated(&SimulationSettings::default(), 1, &mut output)?;
    let table = study(&SimulationSettings::default(), MAIN_JOB_STUDY_RUNS, 1)?;
    emit(
        &[table],
        &whole(Some(out.to_path_buf())),
        output::prepare(&whole(Some(out.to_path_buf())))?,
    )?;
    let dir = std::env::var_os("LIEBAYES_BROAD_DIR")
        .map_or_else(|| PathBuf::from("../shared/broad"), PathBuf::from);
    match broad_trials(&dir) {
        Ok(trials) => {
            print(
                "\nBROAD: the talk filter runs on the simulated log only in the main job (~130 us per sample); `liebayes attitude --broad DIR` runs it on every trial.",
            );
            broad(&trials, false, &mut output)?;
        }
        Err(why) => print(&format!("\nBROAD skipped: {why}")),
    }
    output.finish()
}

/// The sorted `*.mat` files of `dir`.
fn broad_trials(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| format!("cannot read the BROAD folder {}: {e}", dir.display()))?;
    let mut trials: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "mat"))
        .collect();
    trials.sort();
    if trials.is_empty() {
        return Err(format!(
            "the BROAD folder {} holds no .mat trial",
            dir.display()
        ));
    }
    Ok(trials)
}

/// One method's runs, accumulated over the logs.
#[derive(Default)]
struct Tally {
    samples: usize,
    seconds: f64,
    /// The pooled NEES, for a method that reports σ.
    nees: Option<NeesSums>,
    errors: Vec<[f64; 3]>,
}

/// Runs `method` on `log`, timed (the run call only).
fn run_method(method: &str, log: &ImuLog) -> Result<(AttitudeTrack, f64), String> {
    let start = Instant::now();
    let track = match method {
        "liebayes EKF 9D" => run_attitude_ekf(log, &AttitudeParams::default(), Sensors::NineD),
        "liebayes EKF 6D" => run_attitude_ekf(log, &AttitudeParams::default(), Sensors::SixD),
        "talk filter 9D" => run_talk_filter(log, &TalkParams::default()).map(|r| r.track()),
        _ => run_madgwick(log, BROAD_BETA).map(AttitudeTrack::without_sigma),
    }
    .map_err(|e| format!("{method}: {e}"))?;
    Ok((track, start.elapsed().as_secs_f64()))
}

/// The file-name slug of a method: `liebayes-ekf-9d`.
fn slug(method: &str) -> String {
    method.to_lowercase().replace(' ', "-")
}

/// Scores a track: the errors (deg), the NEES sums, the SVG for the EKF 9D.
fn score(
    tally: &mut Tally,
    track: &AttitudeTrack,
    log: &ImuLog,
) -> Result<Vec<Option<(f64, f64)>>, String> {
    let e = trial_errors(&track.orientations, log).map_err(|e| e.to_string())?;
    tally.errors.push([e.total, e.heading, e.inclination]);
    let per = per_sample_errors(&track.orientations, log).map_err(|e| e.to_string())?;
    let movement = log.movement();
    let scored: Vec<Option<(f64, f64)>> = per
        .iter()
        .enumerate()
        .map(|(k, s)| {
            s.filter(|_| movement.is_none_or(|m| m[k]))
                .map(|s| (s.heading, s.inclination))
        })
        .collect();
    if let Some(n) = track_nees(track, log).map_err(|e| e.to_string())? {
        tally.nees.get_or_insert_with(NeesSums::default).add(&n);
    }
    Ok(scored)
}

/// Runs every method on every `(name, log)`, prints the tables and writes the files; returns the
/// tallies.
fn compare(
    logs: &[(String, ImuLog)],
    methods: &[&str],
    title: &str,
    output: &mut output::Output,
) -> Result<Vec<Tally>, String> {
    let mut tallies: Vec<Tally> = methods.iter().map(|_| Tally::default()).collect();
    for (name, log) in logs {
        let times: Vec<f64> = (0..log.len()).map(|k| k as f64 * log.interval()).collect();
        for (m, method) in methods.iter().enumerate() {
            let (track, seconds) = run_method(method, log)?;
            let tally = &mut tallies[m];
            tally.samples += log.len();
            tally.seconds += seconds;
            let scored = score(tally, &track, log).map_err(|e| format!("{name}, {method}: {e}"))?;
            if output.dir().is_some() {
                let mut bytes = Vec::new();
                write_estimates_csv(&mut bytes, &times, &track.orientations, name)
                    .map_err(|e| e.to_string())?;
                output.write(&format!("{name}.{}.csv", slug(method)), &bytes)?;
                if m == 0 {
                    let svg = errors_svg(name, &times, &scored, &track)?;
                    output.write(&format!("{name}.errors.svg"), svg.as_bytes())?;
                }
            }
        }
    }
    let mut header = vec!["trial".to_owned()];
    for method in methods {
        header.push(format!("{method} total"));
        header.push("heading".to_owned());
        header.push("incl.".to_owned());
    }
    let mut rows: Vec<Vec<String>> = logs
        .iter()
        .enumerate()
        .map(|(i, (name, _))| {
            std::iter::once(name.clone())
                .chain(
                    tallies
                        .iter()
                        .flat_map(|t| t.errors[i].map(|v| format!("{v:.2}"))),
                )
                .collect()
        })
        .collect();
    if logs.len() > 1 {
        rows.push(
            std::iter::once("mean".to_owned())
                .chain(tallies.iter().flat_map(|t| {
                    (0..3).map(|j| {
                        let s: f64 = t.errors.iter().map(|e| e[j]).sum();
                        format!("{:.2}", s / t.errors.len() as f64)
                    })
                }))
                .collect(),
        );
    }
    print(
        &Sheet {
            name: String::new(),
            title: format!("{title}: RMSE (deg) total / heading / inclination"),
            header,
            rows,
        }
        .render(),
    );
    let rows = methods
        .iter()
        .zip(&tallies)
        .map(|(method, t)| {
            let nees = |mean: fn(&NeesSums) -> f64| {
                t.nees
                    .as_ref()
                    .map_or_else(|| "-".into(), |n| format!("{:.2}", mean(n)))
            };
            vec![
                (*method).to_owned(),
                nees(NeesSums::heading_mean),
                nees(NeesSums::tilt_mean),
                format!("{:.0}", t.samples as f64 / t.seconds),
            ]
        })
        .collect();
    print(
        &Sheet {
            name: String::new(),
            title: format!(
                "{title}: NEES over scored samples (heading mean (e_h/sigma_h)^2, tilt mean \
                 (e_t/sigma_t)^2 with sigma_t^2 = Sxx + Syy; expected 1, values > 1 = \
                 over-confident) and throughput"
            ),
            header: ["method", "heading NEES", "tilt NEES", "samples/s"]
                .map(String::from)
                .to_vec(),
            rows,
        }
        .render(),
    );
    Ok(tallies)
}

/// `--broad`: every trial, the table with VQF's published row, and `broad.summary.json`.
fn broad(trials: &[PathBuf], talk: bool, output: &mut output::Output) -> Result<(), String> {
    let mut logs = Vec::with_capacity(trials.len());
    for path in trials {
        let log = read_broad(path).map_err(|e| e.to_string())?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        output::check_name(&name)?;
        logs.push((name, log));
    }
    let methods: Vec<&str> = METHODS
        .iter()
        .copied()
        .filter(|m| talk || *m != "talk filter 9D")
        .collect();
    let tallies = compare(&logs, &methods, "BROAD", output)?;
    for (label, total, heading, inclination) in VQF_PUBLISHED {
        print(&format!(
            "{label}: mean {total:.2} / {heading:.2} / {inclination:.2} deg"
        ));
    }
    if output.dir().is_some() {
        let mut errors_of = Vec::new();
        for (i, (name, _)) in logs.iter().enumerate() {
            let errors: serde_json::Map<String, serde_json::Value> = methods
                .iter()
                .zip(&tallies)
                .map(|(m, t)| ((*m).to_owned(), serde_json::json!(t.errors[i])))
                .collect();
            errors_of.push(serde_json::json!({"trial": name, "errors": errors}));
        }
        let throughput: serde_json::Map<String, serde_json::Value> = methods
            .iter()
            .zip(&tallies)
            .map(|(m, t)| {
                (
                    (*m).to_owned(),
                    serde_json::json!(t.samples as f64 / t.seconds),
                )
            })
            .collect();
        let nees: serde_json::Map<String, serde_json::Value> = methods
            .iter()
            .zip(&tallies)
            .filter_map(|(m, t)| {
                t.nees.map(|n| {
                    (
                        (*m).to_owned(),
                        serde_json::json!([n.heading_mean(), n.tilt_mean()]),
                    )
                })
            })
            .collect();
        let summary = serde_json::json!({
            "methods": methods,
            "trials": errors_of,
            "throughput": throughput,
            "nees": nees,
        });
        let text = serde_json::to_string_pretty(&summary).map_err(|e| e.to_string())?;
        output.write("broad.summary.json", text.as_bytes())?;
    }
    Ok(())
}

/// `--simulate`: every method on one simulated log, with the NEES bands.
fn simulated(
    settings: &SimulationSettings,
    seed: u64,
    output: &mut output::Output,
) -> Result<(), String> {
    let log = simulate(settings, seed).map_err(|e| format!("--simulate: {e}"))?;
    let n = log.len();
    let logs = vec![(format!("simulated_seed{seed}"), log)];
    compare(
        &logs,
        &METHODS,
        &format!("Simulated log ({n} samples, seed {seed})"),
        output,
    )?;
    // Heading NEES: chi-square with 1 degree of freedom per sample; tilt: 2 (two components over
    // Sxx + Syy, so the mean of n samples is chi2(2n)/(2n)).
    let band = |dof: f64| {
        let total = dof * n as f64;
        let half = 1.96 * (2.0 * total).sqrt() / total;
        (1.0 - half, 1.0 + half)
    };
    let (h0, h1) = band(1.0);
    let (t0, t1) = band(2.0);
    print(&format!(
        "NEES 95 % band for the mean of {n} independent samples: heading [{h0:.3}, {h1:.3}], \
         tilt [{t0:.3}, {t1:.3}]; consecutive samples are correlated, so the true band is wider."
    ));
    Ok(())
}

/// `--csv`: the EKF (9D, or 6D without a magnetometer) on a user's log.
fn csv(file: &Path, output: &mut output::Output) -> Result<(), String> {
    let origin = file.display().to_string();
    let reader = std::fs::File::open(file).map_err(|e| format!("{origin}: {e}"))?;
    let log = read_imu_csv(std::io::BufReader::new(reader), &origin).map_err(|e| e.to_string())?;
    let (sensors, method) = if log.magnetometer().is_some() {
        (Sensors::NineD, "liebayes EKF 9D")
    } else {
        (Sensors::SixD, "liebayes EKF 6D")
    };
    let track = run_attitude_ekf(&log, &AttitudeParams::default(), sensors)
        .map_err(|e| format!("{method}: {e}"))?;
    print(&format!("{method} on {origin}: {} samples", log.len()));
    if log.reference().is_some() {
        let e = trial_errors(&track.orientations, &log).map_err(|e| e.to_string())?;
        print(&format!(
            "RMSE (deg): total {:.2}, heading {:.2}, inclination {:.2}",
            e.total, e.heading, e.inclination
        ));
    }
    if output.dir().is_some() {
        let times: Vec<f64> = (0..log.len()).map(|k| k as f64 * log.interval()).collect();
        let mut bytes = Vec::new();
        write_estimates_csv(&mut bytes, &times, &track.orientations, &origin)
            .map_err(|e| e.to_string())?;
        let stem = file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        output.write(&format!("{stem}.{}.csv", slug(method)), &bytes)?;
    }
    Ok(())
}

/// The SVG of the EKF 9D's heading and inclination errors over time (deg) with its ±2σ band.
fn errors_svg(
    name: &str,
    times: &[f64],
    scored: &[Option<(f64, f64)>],
    track: &AttitudeTrack,
) -> Result<String, String> {
    let err = |e: DrawingAreaErrorKind<_>| e.to_string();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 700)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let panels = root.split_evenly((2, 1));
        let t_end = times.last().copied().unwrap_or(1.0).max(1e-9);
        for (i, (panel, (label, sigma))) in panels
            .iter()
            .zip([
                ("heading", track.heading_sigma.as_ref()),
                ("inclination", track.tilt_sigma.as_ref()),
            ])
            .enumerate()
        {
            let errors: Vec<(f64, f64)> = times
                .iter()
                .zip(scored)
                .filter_map(|(t, s)| s.map(|s| (*t, if i == 0 { s.0 } else { s.1 }.to_degrees())))
                .collect();
            let band: Vec<(f64, f64)> = sigma.map_or_else(Vec::new, |s| {
                times
                    .iter()
                    .zip(s)
                    .map(|(t, s)| (*t, 2.0 * s.to_degrees()))
                    .collect()
            });
            let top = errors
                .iter()
                .chain(&band)
                .map(|p| p.1)
                .fold(1.0_f64, f64::max)
                .min(180.0);
            let mut chart = ChartBuilder::on(panel)
                .caption(
                    format!("{name}: liebayes EKF 9D {label} error"),
                    ("sans-serif", 16),
                )
                .margin(10)
                .x_label_area_size(30)
                .y_label_area_size(50)
                .build_cartesian_2d(0.0..t_end, 0.0..top * 1.05)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("t (s)")
                .y_desc(format!("{label} error (deg)"))
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
