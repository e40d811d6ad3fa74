//! `liebayes inertial`: strapdown inertial navigation with position fixes, the error-state EKF
//! beside the left- and right-invariant EKFs on SE_2(3), each with a one-pass and an iterated fix,
//! on the same runs. The filters, the scenario and the scores come from the library
//! (`liebayes::filters::inertial`); this module parses, runs the studies and renders the table.

use crate::error::CliError;
use crate::output::{self, OutputArgs};
use crate::report::emit;
use clap::ValueEnum;
use liebayes::experiments::{Method as _, Study, Table};
use liebayes::filters::inertial::{
    Convention, FixUpdate, InertialConfig, InertialMethod, InertialScenario, InitialVelocity,
    NavigationScorer,
};

/// The largest number of runs of the command.
const MAX_RUNS: u64 = 1_000_000;

/// `liebayes inertial`'s settings.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Monte Carlo runs of every filter (60 s each).
    #[arg(long, default_value_t = 100)]
    pub runs: u64,
    /// Which frame the initial velocity is known in (the heading is uncertain by 30 degrees).
    #[arg(long, value_enum, default_value_t = Velocity::Body)]
    pub initial_velocity: Velocity,
    /// The study's seed (run k sees the same data in every filter's study).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub output: OutputArgs,
}

/// `--initial-velocity`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Velocity {
    /// Known in the body frame: a vehicle moving forward whose heading is unknown.
    Body,
    /// Known in the world frame, independently of the attitude.
    World,
}

impl Args {
    /// The main job's study: 30 runs, the velocity known in the body frame.
    pub fn main_job(out: &std::path::Path) -> Self {
        Self {
            runs: 30,
            initial_velocity: Velocity::Body,
            seed: 1,
            output: OutputArgs {
                out: Some(out.to_path_buf()),
                shard: liebayes::experiments::Shard::WHOLE,
            },
        }
    }
}

/// Runs every filter's study and prints (and writes) the table.
///
/// # Errors
/// Settings out of range, a study that cannot run, or files that cannot be written.
pub fn run(args: &Args) -> Result<(), CliError> {
    if args.runs == 0 || args.runs > MAX_RUNS {
        return Err(format!("--runs is {}: it must be from 1 to {MAX_RUNS}", args.runs).into());
    }
    let output = output::prepare(&args.output)?;
    let config = InertialConfig {
        initial_velocity: match args.initial_velocity {
            Velocity::Body => InitialVelocity::Body,
            Velocity::World => InitialVelocity::World,
        },
        ..InertialConfig::default()
    };
    let scenario = InertialScenario::new(config)?;
    let mut summaries = Vec::new();
    for update in [FixUpdate::OnePass, FixUpdate::Iterated] {
        for convention in Convention::ALL {
            let method = InertialMethod::new(convention, update, &scenario)?;
            let study = Study::new(method.label(), args.runs, args.seed, args.output.shard)?;
            summaries.push(study.run_method(&scenario, &method, &NavigationScorer, &|_| {})?);
        }
    }
    let title = format!(
        "Inertial navigation, {} s, a fix every second, heading uncertain by 30 degrees, velocity \
         known in the {} frame",
        config.duration,
        match args.initial_velocity {
            Velocity::Body => "body",
            Velocity::World => "world",
        }
    );
    let table = Table::new("inertial", &title, summaries, None)?;
    emit(&[table], &args.output, output)
}
