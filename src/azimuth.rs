//! PLACEHOLDER for the azimuth application module (replaced by the real one when the branches are
//! merged). It implements the interface every application module gives the binary (`Args`,
//! `Args::main_job`, `Plan::new`, `Plan::run`) with synthetic studies: the scores of each run are
//! drawn from the run's own stream, so that sharding and merging behave as for a real study, but no
//! filter runs.

use crate::output::OutputArgs;
use crate::report::Table;
use liebayes::experiments::study::MAX_RUNS;
use liebayes::experiments::{
    MAX_EPOCHS, Metric, Reduction, RunScores, Shard, StudyLabel, Summary, run_rngs,
};
use liebayes::rand::Rng as _;

/// Azimuth alignment (placeholder: synthetic scores, no filter runs).
#[derive(clap::Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Runs of the exact filter and the EKF.
    #[arg(long, default_value_t = 500)]
    pub runs: u64,
    /// Runs of the particle filter (0: leave it out).
    #[arg(long, default_value_t = 100)]
    pub baseline_runs: u64,
    /// Seed of the study (run k draws from stream k of it).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Simulated time (s), one measurement per second.
    #[arg(long, default_value_t = 500.0)]
    pub duration: f64,
    #[command(flatten)]
    pub output: OutputArgs,
}

impl Args {
    /// The settings of `cargo run --release` (the binary sets the output folder).
    pub fn main_job() -> Args {
        Args {
            runs: 500,
            baseline_runs: 100,
            seed: 1,
            duration: 500.0,
            output: OutputArgs {
                out: None,
                shard: Shard::WHOLE,
            },
        }
    }
}

/// Validated settings.
#[derive(Debug, Clone)]
pub struct Plan {
    runs: u64,
    baseline_runs: u64,
    seed: u64,
    epochs: usize,
}

/// The rows of each table: label, and whether it is a Kalman filter (with a NIS).
const ROWS: [(&str, bool); 3] = [("exact", true), ("EKF", true), ("PF 1000", false)];

impl Plan {
    /// Checks every setting; does no work.
    ///
    /// # Errors
    /// A run count outside [1, 2^40] (baseline runs: [0, 2^40]) or a duration outside [1, 2^24] s.
    pub fn new(args: &Args) -> Result<Plan, String> {
        if args.runs == 0 || args.runs > MAX_RUNS {
            return Err(format!("--runs is {}, outside [1, 2^40]", args.runs));
        }
        if args.baseline_runs > MAX_RUNS {
            return Err(format!(
                "--baseline-runs is {}, outside [0, 2^40]",
                args.baseline_runs
            ));
        }
        if !(1.0..=MAX_EPOCHS as f64).contains(&args.duration) {
            return Err(format!(
                "--duration is {} s, outside [1, 2^24] s",
                args.duration
            ));
        }
        Ok(Plan {
            runs: args.runs,
            baseline_runs: args.baseline_runs,
            seed: args.seed,
            // In [1, 2^24]: the cast is exact.
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            epochs: args.duration.floor() as usize,
        })
    }

    /// Runs shard `shard` of every study: two tables (two scenarios), three rows each. (No
    /// unobservable scenario: a trace holding NaN does not yet survive its JSON round trip.)
    ///
    /// # Errors
    /// Never, in this placeholder (a synthetic run cannot fail to be recorded).
    pub fn run(&self, shard: Shard) -> Result<Vec<Table>, String> {
        let mut tables = Vec::new();
        for scenario in ["circle", "line"] {
            let mut summaries = Vec::new();
            for (row, kalman) in ROWS {
                let runs = if kalman {
                    self.runs
                } else {
                    self.baseline_runs
                };
                if runs == 0 {
                    continue;
                }
                let label = StudyLabel {
                    name: row.to_owned(),
                    seed: self.seed,
                    runs,
                };
                let range = shard.runs(runs);
                let progress =
                    crate::progress::bar(&format!("{row}, {scenario}"), range.end - range.start);
                let mut summary = Summary::new(label, range.clone());
                for run in range.clone() {
                    if row == "EKF" && run % 10 == 7 {
                        summary.add_failure("step 12 (t = 1.2 s): synthetic failure");
                        continue;
                    }
                    let scores = self.scores(run, kalman);
                    summary.add_run(run, &scores).map_err(|e| e.to_string())?;
                    progress(run + 1 - range.start);
                }
                summaries.push(summary);
            }
            tables.push(Table {
                name: format!("azimuth_{scenario}"),
                title: format!(
                    "Azimuth alignment (placeholder), {scenario} scenario: {} epochs; seed {}",
                    self.epochs, self.seed
                ),
                summaries,
            });
        }
        Ok(tables)
    }

    /// Synthetic scores of one run: errors uniform with standard deviation σ(t) = 1/√t.
    fn scores(&self, run: u64, kalman: bool) -> RunScores {
        let metrics = vec![
            Metric::new("azimuth_error", Reduction::RootMeanSquare, "deg"),
            Metric::new("azimuth_sigma", Reduction::RootMeanSquare, "deg"),
            Metric::new("x_error", Reduction::RootMeanSquare, "m"),
            Metric::new("x_sigma", Reduction::RootMeanSquare, "m"),
            Metric::new("nees_position", Reduction::ChiSquare { dof: 2 }, ""),
            Metric::new("diverged", Reduction::Rate, ""),
            Metric::new("log_evidence", Reduction::Mean, ""),
            Metric::new(
                "nis",
                Reduction::ChiSquare {
                    dof: usize::from(kalman),
                },
                "",
            ),
        ];
        let (mut rng, _) = run_rngs(self.seed, run);
        let mut values = Vec::with_capacity(self.epochs * metrics.len());
        let mut times = Vec::with_capacity(self.epochs);
        for k in 0..self.epochs {
            let t = (k + 1) as f64;
            let sigma = 1.0 / t.sqrt();
            let mut draw = || sigma * 3.0_f64.sqrt() * (2.0 * rng.random::<f64>() - 1.0);
            let (a, x, y) = (draw(), draw(), draw());
            values.extend([
                a,
                sigma,
                x,
                sigma,
                (x * x + y * y) / (sigma * sigma),
                f64::from(u8::from(a.abs() > 3.0 * sigma)),
                -0.5 * (x / sigma).powi(2),
                if kalman {
                    (y / sigma).powi(2)
                } else {
                    f64::NAN
                },
            ]);
            times.push(t);
        }
        RunScores {
            metrics,
            times,
            values,
            seconds_per_step: 1e-8,
        }
    }
}
