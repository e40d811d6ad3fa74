//! `liebayes azimuth`: the azimuth-alignment study's settings, checked before any run, and the
//! studies it runs (every filter on every chosen scenario), as tables for the report.

use crate::error::{CliError, Context as _};
use crate::output::OutputArgs;
use crate::progress;
use crate::report::print_search;
use clap::ValueEnum;
use liebayes::experiments::Table;
use liebayes::experiments::search::SearchSettings;
use liebayes::experiments::{MAX_RUNS, MAX_STUDY_EPOCHS, Shard, Study};
use liebayes::filters::azimuth::{AzimuthScenario, Config, Method, Motion, particles_to_match};

/// The largest particle or cell count a study may use: a study runs one filter per core, and
/// 10⁷ particles take about a gigabyte.
const MAX_FILTER_SIZE: usize = 10_000_000;

/// Which scenarios.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Scenarios {
    /// The platform at rest: the azimuth is unobservable.
    Static,
    /// Bounded circles.
    Circle,
    /// A straight line at constant velocity.
    Line,
    /// All three.
    All,
}

impl Scenarios {
    fn motions(self) -> &'static [Motion] {
        match self {
            Scenarios::Static => &[Motion::Static],
            Scenarios::Circle => &[Motion::Circle],
            Scenarios::Line => &[Motion::Line],
            Scenarios::All => &Motion::ALL,
        }
    }
}

/// The blog post's settings.
const DURATION: f64 = 500.0;

/// The simulation settings (by default those of the blog post that proposed the filter).
#[derive(clap::Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct Simulation {
    /// Simulated time (s).
    #[arg(long, default_value_t = DURATION)]
    pub duration: f64,
    /// Position measurement noise sigma_m (m).
    #[arg(long, default_value_t = Config::default().sigma_m)]
    pub sigma_m: f64,
    /// Initial position standard deviation sigma_0 (m).
    #[arg(long, default_value_t = Config::default().sigma0)]
    pub sigma0: f64,
    /// Velocity noise density q (m/sqrt(s)).
    #[arg(long, default_value_t = Config::default().q)]
    pub q: f64,
    /// Propagation step (s).
    #[arg(long, default_value_t = Config::default().dt)]
    pub dt: f64,
    /// A position measurement every this many steps.
    #[arg(long, default_value_t = Config::default().measure_every)]
    pub measure_every: usize,
}

impl Default for Simulation {
    fn default() -> Self {
        let c = Config::default();
        Self {
            duration: DURATION,
            sigma_m: c.sigma_m,
            sigma0: c.sigma0,
            q: c.q,
            dt: c.dt,
            measure_every: c.measure_every,
        }
    }
}

impl Simulation {
    /// The library's configuration, checked by the library, with a number of measurement epochs a
    /// study can summarise.
    fn config(&self) -> Result<Config, CliError> {
        let config = Config {
            sigma0: self.sigma0,
            sigma_m: self.sigma_m,
            q: self.q,
            dt: self.dt,
            measure_every: self.measure_every,
            steps: Config::steps_for(self.duration, self.dt)?,
        };
        config.validate()?;
        let epochs = config.steps.div_ceil(config.measure_every);
        if epochs > MAX_STUDY_EPOCHS {
            return Err(format!(
                "{epochs} measurement epochs (duration / dt / measure-every) is more than a study \
                 summarises ({MAX_STUDY_EPOCHS}): shorten --duration or raise --measure-every"
            )
            .into());
        }
        Ok(config)
    }

    fn describe(&self, config: &Config) -> String {
        format!(
            "{} s, dt {} s, a measurement every {} steps, sigma_0 {} m, sigma_m {} m, q {} m/sqrt(s)",
            self.duration, config.dt, config.measure_every, config.sigma0, config.sigma_m, config.q
        )
    }
}

/// Azimuth alignment: the exact seven-number filter and its baselines, Monte Carlo over runs.
#[derive(clap::Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Which scenario.
    #[arg(long, value_enum, default_value_t = Scenarios::All)]
    pub scenario: Scenarios,
    /// Monte Carlo runs of the exact filter, the EKF and the UKF.
    #[arg(long, default_value_t = 500)]
    pub runs: u64,
    /// Runs of the particle, grid and marginalized particle filters (their cost is 1000 times more;
    /// 0 leaves them out).
    #[arg(long, default_value_t = 100)]
    pub baseline_runs: u64,
    /// The study's seed (run k draws from its own streams of it, whatever the shard).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Particles of the bootstrap particle filter.
    #[arg(long, default_value_t = 1000)]
    pub particles: usize,
    /// Azimuths of the grid filter.
    #[arg(long, default_value_t = 360)]
    pub cells: usize,
    /// Azimuth particles of the marginalized particle filter.
    #[arg(long, default_value_t = 360)]
    pub mpf_particles: usize,
    #[command(flatten)]
    pub simulation: Simulation,
    #[command(flatten)]
    pub output: OutputArgs,
}

impl Args {
    /// The settings of `cargo run --release`: every filter on every scenario (the binary sets the
    /// output folder).
    pub fn main_job() -> Args {
        Args {
            scenario: Scenarios::All,
            runs: 500,
            baseline_runs: 100,
            seed: 1,
            particles: 1000,
            cells: 360,
            mpf_particles: 360,
            simulation: Simulation::default(),
            output: OutputArgs {
                out: None,
                shard: Shard::WHOLE,
            },
        }
    }
}

/// Checks a run count.
fn runs(what: &str, runs: u64, zero_allowed: bool) -> Result<u64, CliError> {
    if (runs == 0 && !zero_allowed) || runs > MAX_RUNS {
        return Err(format!(
            "{what} is {runs}: it must be from {} to 2^40",
            u8::from(!zero_allowed)
        )
        .into());
    }
    Ok(runs)
}

/// Checks a filter size: the library's range, and at most [`MAX_FILTER_SIZE`].
fn size(method: Method, what: &str, n: usize) -> Result<Method, CliError> {
    method.validate().context(|| what.to_string())?;
    if n > MAX_FILTER_SIZE {
        return Err(format!(
            "{what} is {n}: at most {MAX_FILTER_SIZE} (a study holds one filter per core)"
        )
        .into());
    }
    Ok(method)
}

/// The studies of `liebayes azimuth`, every setting checked.
#[derive(Debug)]
pub struct Plan {
    scenarios: Vec<AzimuthScenario>,
    methods: Vec<(Method, u64)>,
    seed: u64,
    settings: String,
}

impl Plan {
    /// Checks every setting; runs nothing.
    ///
    /// # Errors
    /// The first setting out of range, in one line that names it.
    pub fn new(args: &Args) -> Result<Plan, CliError> {
        let config = args.simulation.config()?;
        let runs = runs("--runs", args.runs, false)?;
        let baseline = runs_checked(args.baseline_runs)?;
        let mut methods = vec![
            (Method::Exact, runs),
            (Method::Ekf, runs),
            (Method::Ukf, runs),
        ];
        if baseline > 0 {
            methods.extend([
                (
                    size(
                        Method::Particle(args.particles),
                        "--particles",
                        args.particles,
                    )?,
                    baseline,
                ),
                (
                    size(Method::Grid(args.cells), "--cells", args.cells)?,
                    baseline,
                ),
                (
                    size(
                        Method::Marginalized(args.mpf_particles),
                        "--mpf-particles",
                        args.mpf_particles,
                    )?,
                    baseline,
                ),
            ]);
        }
        let scenarios = args
            .scenario
            .motions()
            .iter()
            .map(|&m| AzimuthScenario::new(m, config))
            .collect::<Result<_, _>>()?;
        Ok(Plan {
            scenarios,
            methods,
            seed: args.seed,
            settings: format!("{}; seed {}", args.simulation.describe(&config), args.seed),
        })
    }

    /// Runs shard `shard` of every study: one table per scenario, one row per filter.
    ///
    /// # Errors
    /// A study that cannot run (the message names the filter and the scenario).
    pub fn run(&self, shard: Shard) -> Result<Vec<Table>, CliError> {
        let mut tables = Vec::with_capacity(self.scenarios.len());
        for scenario in &self.scenarios {
            let name = scenario.motion().name();
            let mut summaries = Vec::with_capacity(self.methods.len());
            for &(method, runs) in &self.methods {
                let label = method.label();
                let study = Study::new(label.clone(), runs, self.seed, shard)
                    .context(|| format!("{label} on {name}"))?;
                let range = shard.runs(runs);
                let bar = progress::bar(&format!("{label} {name}"), range.end - range.start);
                summaries.push(
                    method
                        .study(scenario, &study, &bar)
                        .context(|| format!("{label} on {name}"))?,
                );
            }
            tables.push(Table {
                name: format!("azimuth_{name}"),
                title: format!("Azimuth alignment, {name} scenario: {}", self.settings),
                summaries,
                reference: None,
            });
        }
        Ok(tables)
    }
}

/// `--baseline-runs`, which may be 0 (no baselines).
fn runs_checked(n: u64) -> Result<u64, CliError> {
    runs("--baseline-runs", n, true)
}

/// The particle count of the bootstrap particle filter that matches the exact filter's final
/// azimuth RMSE on the same runs.
#[derive(clap::Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct ParticleArgs {
    /// Which scenario (static has no azimuth to match).
    #[arg(long, value_enum, default_value_t = Scenarios::Circle)]
    pub scenario: Scenarios,
    /// Runs per study (the particle filter's error is dominated by rare divergent runs: 100 are
    /// too few to decide within 5 %).
    #[arg(long, default_value_t = 300)]
    pub runs: u64,
    /// The study's seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// How close counts as matching: RMSE at most (1 + tolerance) times the exact filter's, in
    /// (0, 10].
    #[arg(long, default_value_t = 0.05)]
    pub tolerance: f64,
    /// The smallest particle count tried.
    #[arg(long, default_value_t = 1000)]
    pub low: u64,
    /// The largest particle count tried (at most 10^7).
    #[arg(long, default_value_t = 100_000)]
    pub high: u64,
    /// The search stops when the bracket is within this relative width, in (0, 1].
    #[arg(long, default_value_t = 0.1)]
    pub resolution: f64,
    #[command(flatten)]
    pub simulation: Simulation,
}

/// `liebayes particles`: the particle-count search on each chosen scenario, printed.
///
/// # Errors
/// A setting out of range (before any run), or a study that cannot run.
pub fn particles(args: &ParticleArgs) -> Result<(), CliError> {
    let config = args.simulation.config()?;
    let runs = runs("--runs", args.runs, false)?;
    if !(args.tolerance > 0.0 && args.tolerance <= 10.0) {
        return Err(format!("--tolerance is {}: it must be in (0, 10]", args.tolerance).into());
    }
    if !(args.resolution > 0.0 && args.resolution <= 1.0) {
        return Err(format!("--resolution is {}: it must be in (0, 1]", args.resolution).into());
    }
    let limit = MAX_FILTER_SIZE as u64;
    if args.low == 0 || args.low > args.high || args.high > limit {
        return Err(format!(
            "--low {} and --high {}: they must satisfy 1 <= low <= high <= {limit}",
            args.low, args.high
        )
        .into());
    }
    let scenarios: Vec<AzimuthScenario> = args
        .scenario
        .motions()
        .iter()
        .filter(|&&m| m != Motion::Static)
        .map(|&m| AzimuthScenario::new(m, config))
        .collect::<Result<_, _>>()?;
    if scenarios.is_empty() {
        return Err(
            "--scenario static: the azimuth is unobservable there, nothing to match".into(),
        );
    }
    for scenario in &scenarios {
        let name = scenario.motion().name();
        let study = Study::new("particle search", runs, args.seed, Shard::WHOLE)?;
        let bar = progress::bar(&format!("search {name}"), runs);
        let settings = SearchSettings {
            tolerance: args.tolerance,
            low: args.low,
            high: args.high,
            resolution: args.resolution,
        };
        let found =
            particles_to_match(scenario, &study, settings, &bar).context(|| name.to_string())?;
        print_search(
            name,
            "final azimuth RMSE (deg)",
            "the exact filter",
            runs,
            &found,
            args.tolerance,
        );
    }
    Ok(())
}
