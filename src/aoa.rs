//! `liebayes aoa`: angle-of-arrival positioning with von Mises-Fisher noise. `table1` compares the
//! measurement models (the paper's Table 1), `update` runs the single-update example against its
//! exact posterior, `track` the square-track study (the paper's Fig. 4) with, optionally, a
//! near-optimal reference and the particle count that matches it.

use crate::error::{CliError, Context as _, failed};
use crate::output::{self, OutputArgs};
use crate::progress;
use crate::report::{self, print, print_search};
use crate::sheet::{Segment, Sheet, segments_svg};
use clap::{Subcommand, ValueEnum};
use liebayes::experiments::Table;
use liebayes::experiments::search::SearchSettings;
use liebayes::experiments::{MAX_RUNS, MAX_STUDY_EPOCHS, Shard, Study};
use liebayes::filters::aoa::{
    Algorithm, DataModel, FILTER_MODELS, MAX_SAMPLES, MIN_SAMPLES, ModelChoice, PAPER_TABLE1,
    SquareTrack, TrackConfig, TrackFilter, TruthModel, UpdateExample, compare_models,
    fit_angle_sigmas, particles_to_match, square_track_anchors,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::PathBuf;

/// The largest particle count a study may use (a study holds one filter per core; 10⁷ particles of
/// R³ take 240 MB).
const MAX_PARTICLES: usize = 10_000_000;

/// Half the last printed digit of the paper's Table 1 (two decimals).
const PAPER_ROUNDING: f64 = 0.005;

/// Angle-of-arrival positioning: the paper's model comparison, single update and square track.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    #[command(subcommand)]
    pub command: AoaCommand,
}

/// The three parts of the paper.
#[derive(Subcommand, Debug, Clone)]
pub enum AoaCommand {
    /// The model comparison (Table 1): normalised exp of the mean log likelihood of each filter
    /// model on data from Model I and Model II.
    Table1(Table1Args),
    /// The single-update example (Sec. 4.2): every filter's posterior mean beside the exact one.
    Update(UpdateArgs),
    /// The square-track study (Sec. 4.3, Fig. 4): every filter, Monte Carlo over runs.
    Track(TrackArgs),
}

/// Runs `liebayes aoa <part>`.
///
/// # Errors
/// A setting out of range (before any work), a failed computation, or a file that cannot be
/// written.
pub fn run(args: &Args) -> Result<(), CliError> {
    match &args.command {
        AoaCommand::Table1(a) => table1(a),
        AoaCommand::Update(a) => update(a),
        AoaCommand::Track(a) => track(a),
    }
}

/// The model comparison's settings.
#[derive(clap::Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct Table1Args {
    /// Which data models.
    #[arg(long, value_enum, default_value_t = Data::Both)]
    pub data: Data,
    /// Monte Carlo samples of the comparison, and of the AE-fitted model's fit: from 2 to 2^26
    /// (the paper: 1e5).
    #[arg(long, default_value_t = 100_000)]
    pub samples: usize,
    /// The seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub noise: Noise,
    /// Folder for `aoa_table1.csv` (nothing is written without it).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// `liebayes aoa table1`: Table 1 beside the paper's numbers.
///
/// # Errors
/// As [`run`].
pub fn table1(args: &Table1Args) -> Result<(), CliError> {
    let n = samples("--samples", args.samples)?;
    let models = args.noise.models(args.data)?;
    let mut output = output::prepare(&whole(args.out.clone()))?;
    let paper_setting = (args.noise.sigma_deg - 10.0).abs() < 1e-12;
    let mut rows = Vec::new();
    for data in &models {
        let mut rng = ChaCha8Rng::seed_from_u64(args.seed);
        let fit = fit_angle_sigmas(data, n, &mut rng)?;
        let comparison = compare_models(data, n, (fit.sigma_az, fit.sigma_el), &mut rng)?;
        let paper = PAPER_TABLE1.iter().find(|c| c.data == data.name());
        for (i, row) in comparison.rows.iter().enumerate() {
            let parameters = match (row.sigmas, row.kappa) {
                (Some((a, e)), _) => format!(
                    "sigma_az {:.2} deg, sigma_el {:.2} deg",
                    a.to_degrees(),
                    e.to_degrees()
                ),
                (None, Some(k)) => format!("kappa {k:.2}"),
                (None, None) => "sigma from the table at the true elevation".into(),
            };
            let printed = paper.filter(|_| paper_setting).map(|p| p.normalised[i]);
            rows.push(vec![
                data.name().to_owned(),
                FILTER_MODELS[i].to_owned(),
                parameters,
                format!("{:.4} +- {:.4}", row.log_likelihood, row.log_likelihood_se),
                format!("{:.4} +- {:.4}", row.normalised, row.normalised_se),
                printed.map_or_else(|| "-".into(), |p| format!("{p:.2}")),
                printed.map_or_else(
                    || "-".into(),
                    |p| {
                        let beyond = ((row.normalised - p).abs() - PAPER_ROUNDING).max(0.0);
                        format!("{:.1}", beyond / row.normalised_se)
                    },
                ),
            ]);
        }
        rows.push(vec![
            data.name().to_owned(),
            "(fit)".into(),
            format!(
                "sigma_az {:.2} +- {:.2} deg, sigma_el {:.2} +- {:.2} deg{}",
                fit.sigma_az.to_degrees(),
                fit.sigma_az_se.to_degrees(),
                fit.sigma_el.to_degrees(),
                fit.sigma_el_se.to_degrees(),
                paper
                    .filter(|_| paper_setting)
                    .map_or_else(String::new, |p| format!(
                        " (paper: {} / {} deg)",
                        p.fitted_sigma_deg.0, p.fitted_sigma_deg.1
                    ))
            ),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
        ]);
    }
    let sheet = Sheet {
        name: "aoa_table1".into(),
        title: format!(
            "AoA model comparison (Table 1): normalised exp of the mean log likelihood, {n} \
             samples, sigma {} deg; seed {}",
            args.noise.sigma_deg, args.seed
        ),
        header: [
            "data",
            "filter model",
            "parameters",
            "L (nats)",
            "exp(L) normalised",
            "paper",
            "beyond rounding (s.e.)",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    };
    print(&sheet.render());
    write_sheets(&[sheet], &[], output.dir().is_some(), &mut output)?;
    output.finish()
}

/// The single update's settings.
#[derive(clap::Args, Debug, Clone)]
pub struct UpdateArgs {
    /// Particles of the particle filters.
    #[arg(long, default_value_t = 200_000)]
    pub particles: usize,
    /// The particle filters' seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Folder for the CSV table and the SVG plots (nothing is written without it).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// `liebayes aoa update`: the single-update example, corrected and literal elevation.
///
/// # Errors
/// As [`run`].
pub fn update(args: &UpdateArgs) -> Result<(), CliError> {
    let n = particles("--particles", args.particles)?;
    let mut output = output::prepare(&whole(args.out.clone()))?;
    let rng = ChaCha8Rng::seed_from_u64(args.seed);
    let mut sheets = Vec::new();
    let mut plots = Vec::new();
    for (corrected, name) in [(true, "corrected"), (false, "literal")] {
        let example = UpdateExample::paper(corrected)?;
        let rows = example.run(n, &rng)?;
        let elevation = example.reading.elevation;
        let title = format!(
            "AoA single update ({name} elevation {:.4} rad): prior N((0.3, -0.3, -2), 0.75^2 I), \
             sigma 5 deg, kappa {:.1}, {n} particles",
            elevation, example.kappa
        );
        let m0 = *example.prior.mean();
        let segments: Vec<Segment> = rows
            .iter()
            .map(|r| (r.filter.clone(), m0.into(), r.mean.into()))
            .collect();
        plots.push((
            format!("aoa_update_{name}.svg"),
            segments_svg(
                &title,
                &segments,
                (*example.anchor.position()).into(),
                example.reading.unit_vector().into(),
            )
            .map_err(|e| failed(format!("plotting aoa_update_{name}"), e))?,
        ));
        sheets.push(Sheet {
            name: format!("aoa_update_{name}"),
            title,
            header: [
                "filter",
                "x (m)",
                "y (m)",
                "z (m)",
                "from exact (m)",
                "bearing (deg)",
            ]
            .map(String::from)
            .to_vec(),
            rows: rows
                .iter()
                .map(|r| {
                    vec![
                        r.filter.clone(),
                        format!("{:.4}", r.mean.x),
                        format!("{:.4}", r.mean.y),
                        format!("{:.4}", r.mean.z),
                        r.from_exact
                            .map_or_else(|| "-".into(), |d| format!("{d:.4}")),
                        format!("{:.2}", r.bearing_deg),
                    ]
                })
                .collect(),
        });
    }
    for sheet in &sheets {
        print(&sheet.render());
    }
    write_sheets(&sheets, &plots, output.dir().is_some(), &mut output)?;
    output.finish()
}

/// `liebayes aoa track`: settings and output folder checked before any run, then the studies,
/// then the report (tables, per-run box plots, files).
///
/// # Errors
/// As [`run`].
pub fn track(args: &TrackArgs) -> Result<(), CliError> {
    // The folder first: the plan fits the noise models, which takes a while at large sizes.
    let output = output::prepare(&args.output)?;
    let plan = TrackPlan::new(args)?;
    let tables = plan.run(args.output.shard)?;
    report::emit(&tables, &args.output, output)
}

/// The main job's angle-of-arrival part: Table 1 at the paper's 1e5 samples, the single update,
/// and a short square-track study (50 runs, 2000 particles), files in `out`.
///
/// # Errors
/// As [`run`].
pub fn main_job(out: &std::path::Path) -> Result<(), CliError> {
    let noise = Noise { sigma_deg: 10.0 };
    table1(&Table1Args {
        data: Data::Both,
        samples: 100_000,
        seed: 1,
        noise: noise.clone(),
        out: Some(out.to_path_buf()),
    })?;
    update(&UpdateArgs {
        particles: 200_000,
        seed: 1,
        out: Some(out.to_path_buf()),
    })?;
    let mut args = TrackArgs::main_job();
    args.output.out = Some(out.to_path_buf());
    track(&args)
}

/// Output settings of a command that is not sharded.
fn whole(out: Option<PathBuf>) -> OutputArgs {
    OutputArgs {
        out,
        shard: Shard::WHOLE,
    }
}

/// Writes each sheet's CSV and each (file name, SVG) plot, if there is a folder.
fn write_sheets(
    sheets: &[Sheet],
    plots: &[(String, String)],
    folder: bool,
    output: &mut output::Output,
) -> Result<(), CliError> {
    if !folder {
        return Ok(());
    }
    for sheet in sheets {
        output.write(&format!("{}.csv", sheet.name), sheet.csv().as_bytes())?;
    }
    for (name, svg) in plots {
        output.write(name, svg.as_bytes())?;
    }
    Ok(())
}

/// Which data models.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Data {
    /// Model I: normal azimuth and elevation errors with flipping.
    Model1,
    /// Model II: von Mises-Fisher unit vectors.
    Model2,
    /// Both.
    Both,
}

/// The noise level shared by the parts (the paper's σ = 10°, κ = 1/σ² = 32.8).
#[derive(clap::Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct Noise {
    /// The data's angle standard deviation σ (deg); Model II uses κ = 1/σ² (σ in rad).
    #[arg(long, default_value_t = 10.0)]
    pub sigma_deg: f64,
}

impl Noise {
    /// The data models chosen, checked.
    fn models(&self, data: Data) -> Result<Vec<DataModel>, CliError> {
        let sigma = self.sigma_deg.to_radians();
        let one = DataModel::NormalWithFlip {
            sigma_az: sigma,
            sigma_el: sigma,
        };
        let two = DataModel::VonMisesFisher {
            kappa: 1.0 / (sigma * sigma),
        };
        let models = match data {
            Data::Model1 => vec![one],
            Data::Model2 => vec![two],
            Data::Both => vec![one, two],
        };
        for m in &models {
            m.validate()
                .context(|| format!("--sigma-deg {}", self.sigma_deg))?;
        }
        Ok(models)
    }
}

/// A data model's short name for files: `model1`, `model2`.
fn file_name(data: &DataModel) -> &'static str {
    match data {
        DataModel::NormalWithFlip { .. } => "model1",
        DataModel::VonMisesFisher { .. } => "model2",
    }
}

/// Checks a count of simulated readings of the model comparison or the σ fit against the
/// library's range, [`MIN_SAMPLES`] (the fewest with a standard error) to [`MAX_SAMPLES`], before
/// any work.
fn samples(what: &str, n: usize) -> Result<usize, CliError> {
    if !(MIN_SAMPLES..=MAX_SAMPLES).contains(&n) {
        return Err(format!(
            "{what} is {n}: it must be from {MIN_SAMPLES} (a standard error needs two) to \
             {MAX_SAMPLES}"
        )
        .into());
    }
    Ok(n)
}

/// Checks a run count.
fn runs(what: &str, n: u64, zero_allowed: bool) -> Result<u64, CliError> {
    if (n == 0 && !zero_allowed) || n > MAX_RUNS {
        return Err(format!(
            "{what} is {n}: it must be from {} to 2^40",
            u8::from(!zero_allowed)
        )
        .into());
    }
    Ok(n)
}

/// Checks a particle count.
fn particles(what: &str, n: usize) -> Result<usize, CliError> {
    if n == 0 || n > MAX_PARTICLES {
        return Err(format!("{what} is {n}: it must be from 1 to {MAX_PARTICLES}").into());
    }
    Ok(n)
}

/// The square-track study's settings.
#[derive(clap::Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
pub struct TrackArgs {
    /// Which data models.
    #[arg(long, value_enum, default_value_t = Data::Both)]
    pub data: Data,
    /// Monte Carlo runs of every filter.
    #[arg(long, default_value_t = 500)]
    pub runs: u64,
    /// Particles of the particle filters.
    #[arg(long, default_value_t = 10_000)]
    pub particles: usize,
    /// How the truth moves: along the square (the paper), or by the filters' own random walk (where
    /// a consistent filter's NEES is chi-square).
    #[arg(long, value_enum, default_value_t = Truth::Square)]
    pub truth: Truth,
    /// Steps per run (64: one lap on average).
    #[arg(long, default_value_t = TrackConfig::default().epochs)]
    pub steps: usize,
    /// Simulated readings of the AE-fitted filters' maximum-likelihood fit: from 2 to 2^26.
    #[arg(long, default_value_t = 100_000)]
    pub fit_samples: usize,
    /// Runs of the near-optimal reference (a particle filter with --reference-particles), the first
    /// runs of the study; 0 leaves it out.
    #[arg(long, default_value_t = 0)]
    pub reference_runs: u64,
    /// Particles of the reference particle filter.
    #[arg(long, default_value_t = 1_000_000)]
    pub reference_particles: usize,
    /// With a reference: search the particle count at which PF-VMF comes within this relative
    /// tolerance of the reference's RMSE on its runs (0.01: 1 %).
    #[arg(long)]
    pub match_tolerance: Option<f64>,
    /// The study's seed (run k reads the same data in every filter's study).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub noise: Noise,
    #[command(flatten)]
    pub output: OutputArgs,
}

/// `--truth`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Truth {
    /// Along the square with random step lengths (the paper's equation (12)).
    Square,
    /// The filters' random walk (13).
    RandomWalk,
}

impl TrackArgs {
    /// The settings of the main job's short run.
    pub fn main_job() -> Self {
        Self {
            data: Data::Both,
            runs: 50,
            particles: 2000,
            truth: Truth::Square,
            steps: TrackConfig::default().epochs,
            fit_samples: 100_000,
            reference_runs: 0,
            reference_particles: 1_000_000,
            match_tolerance: None,
            seed: 1,
            noise: Noise { sigma_deg: 10.0 },
            output: OutputArgs {
                out: None,
                shard: Shard::WHOLE,
            },
        }
    }
}

/// One data model's studies.
#[derive(Debug)]
struct TrackStudies {
    track: SquareTrack<4>,
    filters: Vec<TrackFilter>,
}

/// The studies of `liebayes aoa track`, every setting checked.
#[derive(Debug)]
pub struct TrackPlan {
    studies: Vec<TrackStudies>,
    runs: u64,
    reference: Option<(u64, usize)>,
    tolerance: Option<f64>,
    seed: u64,
    settings: String,
}

impl TrackPlan {
    /// Checks every setting and fits the AE-fitted filters' σ; runs no study.
    ///
    /// # Errors
    /// The first setting out of range, in one line that names it.
    pub fn new(args: &TrackArgs) -> Result<Self, CliError> {
        let runs = runs("--runs", args.runs, false)?;
        let n = particles("--particles", args.particles)?;
        let fit = samples("--fit-samples", args.fit_samples)?;
        let reference_runs = runs_at_most(args.reference_runs, runs)?;
        let reference = (reference_runs > 0)
            .then(|| {
                particles("--reference-particles", args.reference_particles)
                    .map(|p| (reference_runs, p))
            })
            .transpose()?;
        if let Some(t) = args.match_tolerance {
            if reference.is_none() {
                return Err("--match-tolerance needs a reference: give --reference-runs".into());
            }
            if !(t > 0.0 && t <= 10.0) {
                return Err(format!("--match-tolerance is {t}: it must be in (0, 10]").into());
            }
            if args.output.shard != Shard::WHOLE {
                return Err(
                    "--match-tolerance searches whole studies: it cannot run in a shard".into(),
                );
            }
        }
        if args.steps > MAX_STUDY_EPOCHS {
            return Err(format!(
                "--steps is {}: a study summarises at most {MAX_STUDY_EPOCHS} epochs",
                args.steps
            )
            .into());
        }
        let config = TrackConfig {
            epochs: args.steps,
            truth: match args.truth {
                Truth::Square => TruthModel::Square,
                Truth::RandomWalk => TruthModel::RandomWalk,
            },
            ..TrackConfig::default()
        };
        let mut studies = Vec::new();
        for data in args.noise.models(args.data)? {
            let track = SquareTrack::new(square_track_anchors(), data, config)
                .context(|| format!("--steps {}", args.steps))?;
            let mut rng = ChaCha8Rng::seed_from_u64(args.seed);
            let fitted =
                fit_angle_sigmas(&data, fit, &mut rng).map(|f| (f.sigma_az, f.sigma_el))?;
            let models = ModelChoice::paper(&data, fitted)?;
            let mut filters = Vec::with_capacity(13);
            for model in models {
                // The iterated EKF with the von Mises-Fisher model only: with the
                // azimuth-elevation model its iterates are drawn onto an anchor's vertical axis,
                // where the azimuth is undefined, and the model is inconsistent in every algorithm
                // (docs/filters/aoa.md).
                let iterated =
                    matches!(model, ModelChoice::Vmf { .. }).then_some(Algorithm::IteratedEkf);
                let algorithms = [Algorithm::Particle(n), Algorithm::Ekf, Algorithm::Ukf];
                for algorithm in algorithms.into_iter().chain(iterated) {
                    filters.push(TrackFilter {
                        algorithm,
                        model: model.clone(),
                    });
                }
            }
            studies.push(TrackStudies { track, filters });
        }
        Ok(Self {
            studies,
            runs,
            reference,
            tolerance: args.match_tolerance,
            seed: args.seed,
            settings: format!(
                "sigma {} deg, {} steps, {} particles, truth {:?}; seed {}",
                args.noise.sigma_deg, args.steps, n, args.truth, args.seed
            ),
        })
    }

    /// Runs shard `shard` of every study: per data model, the Fig. 4 table (reference row PF-VMF)
    /// and, with a reference, the table of every filter beside it (reference row: the reference).
    ///
    /// # Errors
    /// A study that cannot run (the message names the filter and the data model).
    pub fn run(&self, shard: Shard) -> Result<Vec<Table>, CliError> {
        let mut tables = Vec::new();
        for TrackStudies { track, filters } in &self.studies {
            let data = track.data();
            let mut summaries = Vec::with_capacity(filters.len());
            for filter in filters {
                summaries.push(self.study(track, filter, &filter.label(), self.runs, shard)?);
            }
            let optimum = self
                .reference
                .map(|(runs, n)| -> Result<Table, CliError> {
                    let reference = TrackFilter {
                        algorithm: Algorithm::Particle(n),
                        model: filters[0].model.clone(),
                    };
                    let label = format!("PF-VMF {n}");
                    let mut rows = vec![self.study(track, &reference, &label, runs, shard)?];
                    rows.extend(summaries.iter().cloned());
                    if let Some(tolerance) = self.tolerance {
                        self.search(track, &filters[0].model, &rows[0], runs, tolerance)?;
                    }
                    Ok(Table {
                        name: format!("aoa_optimum_{}", file_name(data)),
                        title: format!(
                            "AoA square track, {} data: every filter against a {n}-particle \
                             PF-VMF on its {runs} runs; {}",
                            data.name(),
                            self.settings
                        ),
                        summaries: rows,
                        reference: Some(0),
                    })
                })
                .transpose()?;
            tables.push(Table {
                name: format!("aoa_track_{}", file_name(data)),
                title: format!(
                    "AoA square track, {} data: RMSE difference from PF-VMF per run; {}",
                    data.name(),
                    self.settings
                ),
                summaries,
                reference: Some(0),
            });
            tables.extend(optimum);
        }
        Ok(tables)
    }

    fn study(
        &self,
        track: &SquareTrack<4>,
        filter: &TrackFilter,
        label: &str,
        runs: u64,
        shard: Shard,
    ) -> Result<liebayes::experiments::Summary, CliError> {
        let name = track.data().name();
        let study = Study::new(label.to_owned(), runs, self.seed, shard)
            .context(|| format!("{label} on {name}"))?;
        let range = shard.runs(runs);
        let bar = progress::bar(&format!("{label} {name}"), range.end - range.start);
        filter
            .study(track, &study, &bar)
            .context(|| format!("{label} on {name}"))
    }

    /// The particle-count search against the reference, printed.
    fn search(
        &self,
        track: &SquareTrack<4>,
        model: &ModelChoice,
        reference: &liebayes::experiments::Summary,
        runs: u64,
        tolerance: f64,
    ) -> Result<(), CliError> {
        let name = track.data().name();
        let study = Study::new("PF-VMF search", runs, self.seed, Shard::WHOLE)?;
        let bar = progress::bar(&format!("search {name}"), runs);
        let settings = SearchSettings {
            tolerance,
            low: 100,
            high: MAX_PARTICLES as u64,
            resolution: 0.1,
        };
        let found = particles_to_match(track, model, &study, reference, settings, &bar)
            .context(|| name.to_string())?;
        print_search(
            name,
            "track RMSE (m)",
            "the reference",
            runs,
            &found,
            tolerance,
        );
        Ok(())
    }
}

/// `--reference-runs`: 0 (none) up to `--runs`.
fn runs_at_most(n: u64, runs: u64) -> Result<u64, CliError> {
    if n > runs {
        return Err(format!(
            "--reference-runs is {n}: at most --runs ({runs}), its runs are the study's first"
        )
        .into());
    }
    Ok(n)
}
