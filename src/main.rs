//! The `liebayes` command-line program: argument parsing and dispatch. The studies live in the
//! application modules (`azimuth`), the reports in `report`, the files in `output`.
//!
//! With no arguments: the main job, the azimuth study with its files in `out/azimuth/`, then a
//! short angle-of-arrival run (model comparison, single update, 50 square-track runs) in
//! `out/aoa/`, then the attitude filters on a simulated log and on the BROAD trials (the `.mat`
//! files of `$LIEBAYES_BROAD_DIR`, or else the two in the project's `data/broad`), files in
//! `out/attitude/`, then the inertial filters (30 runs) in `out/inertial/`. The BROAD trials are
//! read first: a folder without a trial, or a trial that does not read, fails the job before any
//! study runs.
//! `liebayes attitude --broad DIR | --simulate | --csv FILE` and `liebayes inertial` run them alone.
//! `liebayes azimuth --help` lists the study's settings; `--shard K/N --out DIR` runs one part of
//! it, and `liebayes merge DIR... --out DIR` combines the parts exactly. `liebayes particles`
//! searches the particle count at which the particle filter matches the exact filter.

mod aoa;
mod attitude;
mod azimuth;
mod error;
mod inertial;
mod output;
mod progress;
mod report;
mod sheet;

use crate::error::CliError;
use clap::{Parser, Subcommand};
use liebayes::experiments::Shard;
use std::path::PathBuf;
use std::process::ExitCode;

/// Bayesian state estimation on Lie groups: exact filters and their baselines.
#[derive(Parser, Debug)]
#[command(name = "liebayes", version, allow_negative_numbers = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Azimuth alignment: the exact filter and its baselines, Monte Carlo over runs.
    Azimuth(azimuth::Args),
    /// Angle-of-arrival positioning with von Mises-Fisher noise: the model comparison, the single
    /// update and the square-track study.
    Aoa(aoa::Args),
    /// IMU attitude: the liebayes EKF, the talk's filter and Madgwick's on BROAD trials, a
    /// simulated log or a CSV log (exactly one of --broad DIR, --simulate, --csv FILE).
    Attitude(attitude::Args),
    /// Inertial navigation with position fixes: the error-state EKF and the invariant EKFs on
    /// SE_2(3), each with a one-pass and an iterated fix, on the same runs.
    Inertial(inertial::Args),
    /// The bootstrap particle filter's particle count that matches the exact filter's azimuth RMSE.
    Particles(azimuth::ParticleArgs),
    /// Combines the partial summaries of shards (the --out folders of `--shard K/N` runs) into the
    /// whole study's tables, CSV files, plots and summary.
    Merge(MergeArgs),
}

#[derive(clap::Args, Debug)]
struct MergeArgs {
    /// The folders of the shards' summaries (`*.summary.json`).
    #[arg(required = true, value_name = "DIR")]
    dirs: Vec<PathBuf>,
    /// Folder for the merged files (not one of the folders merged).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) => {
            // clap's first paragraph, on one line.
            let text = e.to_string();
            let first: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            return fail(&format!(
                "{} (see liebayes --help)",
                first.join(" ").trim_start_matches("error: ")
            ));
        }
    };
    if let Err(error) = output::remove_staged_on_signal() {
        return fail(&error.to_string());
    }
    let result = match cli.command {
        None => main_job(),
        Some(Command::Azimuth(args)) => study(&args),
        Some(Command::Aoa(args)) => aoa::run(&args),
        Some(Command::Attitude(args)) => attitude::run(&args),
        Some(Command::Inertial(args)) => inertial::run(&args),
        Some(Command::Particles(args)) => azimuth::particles(&args),
        Some(Command::Merge(args)) => merge(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => fail(&error.to_string()),
    }
}

/// One line on stderr and the failure exit code.
fn fail(message: &str) -> ExitCode {
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr().lock(), "liebayes: {message}");
    ExitCode::FAILURE
}

/// The main job: its input, the BROAD trials, read before anything runs or is printed (a bad
/// folder or trial fails at once, nothing written), then each part in turn, every part's folder
/// written when that part has succeeded.
fn main_job() -> Result<(), CliError> {
    let trials = attitude::BroadTrials::main_job()?;
    report::print(&format!(
        "liebayes {}: Bayesian state estimation on Lie groups",
        env!("CARGO_PKG_VERSION")
    ));
    let mut args = azimuth::Args::main_job();
    args.output = output::OutputArgs {
        out: Some(PathBuf::from("out/azimuth")),
        shard: Shard::WHOLE,
    };
    study(&args)?;
    aoa::main_job(&PathBuf::from("out/aoa"))?;
    attitude::main_job(&PathBuf::from("out/attitude"), &trials)?;
    inertial::run(&inertial::Args::main_job(&PathBuf::from("out/inertial")))?;
    report::print("\nThe manifolds and densities at work: cargo run --release --example tour");
    Ok(())
}

/// `liebayes azimuth`: settings and output folder checked before any run, then the studies, then
/// the report.
fn study(args: &azimuth::Args) -> Result<(), CliError> {
    let plan = azimuth::Plan::new(args)?;
    let output = output::prepare(&args.output)?;
    let tables = plan.run(args.output.shard)?;
    report::emit(&tables, &args.output, output)
}

/// `liebayes merge`: the folders checked, then read and merged, then reported as a whole run is.
fn merge(args: &MergeArgs) -> Result<(), CliError> {
    report::check_merge_folders(&args.dirs, &args.out)?;
    let settings = output::OutputArgs {
        out: Some(args.out.clone()),
        shard: Shard::WHOLE,
    };
    let output = output::prepare(&settings)?;
    let tables = report::merge(&args.dirs)?;
    report::emit(&tables, &settings, output)
}
