//! The `liebayes` command-line program.
//!
//! With no arguments: the azimuth study on all three scenarios (every filter, the blog post's settings), its
//! CSV and SVG files in `out/azimuth/`, then short demonstrations of the manifolds and densities.
//! `liebayes azimuth --help` lists the study's options; `liebayes particles` finds the particle count at
//! which the bootstrap particle filter matches the exact filter's azimuth RMSE.

mod report;

use clap::{Parser, Subcommand, ValueEnum};
use liebayes::filters::azimuth::scenario::{Config, Scenario};
use liebayes::filters::azimuth::{Method, Summary, study};
use liebayes::manifolds::{GroupAction, LieGroup, Manifold, S2, So3, Su2};
use nalgebra::Vector3;
use std::f64::consts::PI;
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
    /// Azimuth alignment: the exact seven-number filter and its baselines, Monte Carlo over runs.
    Azimuth(AzimuthArgs),
    /// The bootstrap particle filter's particle count that reaches the exact filter's azimuth RMSE.
    Particles(ParticleArgs),
    /// Short demonstrations of the manifolds and densities.
    Demo,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ScenarioArg {
    Static,
    Circle,
    Line,
    All,
}

impl ScenarioArg {
    fn scenarios(self) -> Vec<Scenario> {
        match self {
            ScenarioArg::Static => vec![Scenario::Static],
            ScenarioArg::Circle => vec![Scenario::Circle],
            ScenarioArg::Line => vec![Scenario::Line],
            ScenarioArg::All => Scenario::ALL.to_vec(),
        }
    }
}

/// The simulation settings (by default those of the blog post that proposed the filter).
#[derive(clap::Args, Debug, Clone)]
struct Simulation {
    /// Simulated time (s).
    #[arg(long, default_value_t = 500.0)]
    duration: f64,
    /// Position measurement noise sigma_m (m).
    #[arg(long, default_value_t = 1.0)]
    sigma_m: f64,
    /// Initial position standard deviation sigma_0 (m).
    #[arg(long, default_value_t = 1.0)]
    sigma0: f64,
    /// Velocity noise density q (m/sqrt(s)).
    #[arg(long, default_value_t = 0.1)]
    q: f64,
    /// Propagation step (s).
    #[arg(long, default_value_t = 0.1)]
    dt: f64,
    /// A position measurement every this many steps.
    #[arg(long, default_value_t = 10)]
    measure_every: usize,
}

impl Simulation {
    /// The library's configuration, checked by the library.
    fn config(&self) -> Result<Config, String> {
        let config = Config {
            sigma0: self.sigma0,
            sigma_m: self.sigma_m,
            q: self.q,
            dt: self.dt,
            measure_every: self.measure_every,
            steps: Config::steps_for(self.duration, self.dt).map_err(|e| e.to_string())?,
        };
        config.validate().map_err(|e| e.to_string())?;
        Ok(config)
    }
}

#[derive(clap::Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
struct AzimuthArgs {
    /// Which scenario.
    #[arg(long, value_enum, default_value_t = ScenarioArg::All)]
    scenario: ScenarioArg,
    /// Monte Carlo runs of the exact filter, the EKF and the UKF.
    #[arg(long, default_value_t = 500)]
    runs: usize,
    /// Runs of the particle, grid and marginalized particle filters (their cost is 1000 times more).
    #[arg(long, default_value_t = 100)]
    baseline_runs: usize,
    /// Seed of run 0 (run i uses seed + i).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where to write the CSV tables and SVG plots (none written when absent).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Particles of the bootstrap particle filter.
    #[arg(long, default_value_t = 1000)]
    particles: usize,
    /// Azimuths of the grid filter.
    #[arg(long, default_value_t = 360)]
    cells: usize,
    /// Azimuth particles of the marginalized particle filter.
    #[arg(long, default_value_t = 360)]
    mpf_particles: usize,
    #[command(flatten)]
    simulation: Simulation,
}

#[derive(clap::Args, Debug, Clone)]
#[command(allow_negative_numbers = true)]
struct ParticleArgs {
    /// Which scenario.
    #[arg(long, value_enum, default_value_t = ScenarioArg::Circle)]
    scenario: ScenarioArg,
    /// Runs per particle count (the particle filter's error is dominated by rare divergent runs: 100 are
    /// too few to decide within 5 %).
    #[arg(long, default_value_t = 300)]
    runs: usize,
    /// Seed of run 0.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// How close counts as reaching it: RMSE at most (1 + tolerance) times the exact filter's. The exact
    /// posterior is optimal, so a particle filter only approaches its RMSE from above.
    #[arg(long, default_value_t = 0.05)]
    tolerance: f64,
    /// The particle counts to try, in increasing order; the search stops at the first that matches.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1000,2000,5000,10000,20000,50000"
    )]
    counts: Vec<usize>,
    #[command(flatten)]
    simulation: Simulation,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        None => {
            println!(
                "liebayes {}: Bayesian state estimation on Lie groups\n",
                env!("CARGO_PKG_VERSION")
            );
            let result =
                match Cli::parse_from(["liebayes", "azimuth", "--out", "out/azimuth"]).command {
                    Some(Command::Azimuth(args)) => azimuth(&args),
                    _ => Err("internal: the default command did not parse".into()),
                };
            demos();
            result
        }
        Some(Command::Azimuth(args)) => azimuth(&args),
        Some(Command::Particles(args)) => particles(&args),
        Some(Command::Demo) => {
            demos();
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("liebayes: {message}");
            ExitCode::FAILURE
        }
    }
}

fn demos() {
    println!("\nThe library at work (manifolds and densities):");
    integrate_a_gyro();
    log_near_pi();
    jacobian_against_finite_difference();
    double_cover_and_sphere();
    densities_demo();
}

/// `liebayes azimuth`: every filter on every chosen scenario, a table per scenario, and the files.
fn azimuth(args: &AzimuthArgs) -> Result<(), String> {
    let config = args.simulation.config()?;
    let methods = [
        (Method::Exact, args.runs),
        (Method::Ekf, args.runs),
        (Method::Ukf, args.runs),
        (Method::Particle(args.particles), args.baseline_runs),
        (Method::Grid(args.cells), args.baseline_runs),
        (Method::Marginalized(args.mpf_particles), args.baseline_runs),
    ];
    println!(
        "Azimuth alignment: {} s, dt {} s, a measurement every {} steps, sigma_0 {} m, \
         sigma_m {} m, q {} m/sqrt(s); seed {}",
        args.simulation.duration,
        config.dt,
        config.measure_every,
        config.sigma0,
        config.sigma_m,
        config.q,
        args.seed
    );
    println!(
        "Final epoch. Divergence: final azimuth error > 10 deg (or a failed step). Circular \
         consistency: mean of (1 - cos e)/(1 - rho), 1 when consistent."
    );
    for scenario in args.scenario.scenarios() {
        println!("\n{} scenario", scenario.name());
        println!(
            "{:<10} {:>5} {:>11} {:>10} {:>9} {:>16} {:>20} {:>9} {:>10}",
            "filter",
            "runs",
            "az RMSE deg",
            "sigma_A deg",
            "NEES r",
            "95% band",
            "circular (95% band)",
            "diverged",
            "ns/step"
        );
        let mut summaries = Vec::new();
        // The plot of errors over time compares every method on the same runs: the cheap methods are
        // run a second time with the costly ones' run count when the two differ.
        let mut plotted = Vec::new();
        for &(method, runs) in &methods {
            if runs == 0 {
                continue;
            }
            let run = |runs| {
                study(method, scenario, &config, runs, args.seed)
                    .map_err(|e| format!("{} on {}: {e}", method.label(), scenario.name()))
            };
            let summary = run(runs)?;
            print_row(&summary);
            if args.out.is_some() && args.baseline_runs > 0 && runs != args.baseline_runs {
                plotted.push(run(args.baseline_runs)?);
            } else {
                plotted.push(summary.clone());
            }
            summaries.push(summary);
        }
        if let Some(dir) = &args.out {
            let files = report::write_scenario(dir, &summaries, &plotted)
                .map_err(|e| format!("writing into {}: {e}", dir.display()))?;
            println!("wrote {} files into {}", files.len(), dir.display());
        }
    }
    Ok(())
}

fn print_row(s: &Summary) {
    let degrees = |x: Option<f64>| {
        x.map_or("unobserv.".to_string(), |r| {
            format!("{:.4}", r.to_degrees())
        })
    };
    let circular = match (s.circular.mean(), s.circular.band()) {
        (Some(m), Some((l, h))) if m < 1e3 => format!("{m:.3} [{l:.2}, {h:.2}]"),
        (Some(m), _) => format!("{m:.2e}"),
        _ => "-".to_string(),
    };
    println!(
        "{:<10} {:>5} {:>11} {:>10} {:>9.3} {:>16} {:>20} {:>9} {:>10.0}",
        s.method.label(),
        s.runs,
        degrees(s.azimuth_rmse),
        degrees(s.mean_sigma_a),
        s.average_nees,
        format!("[{:.3}, {:.3}]", s.nees_band.0, s.nees_band.1),
        circular,
        s.divergence_rate
            .map_or("-".to_string(), |d| format!("{:.1}%", 100.0 * d)),
        s.ns_per_step
    );
}

/// `liebayes particles`: the smallest tried particle count whose azimuth RMSE is within the tolerance of
/// the exact filter's, on the same runs.
fn particles(args: &ParticleArgs) -> Result<(), String> {
    let config = args.simulation.config()?;
    for scenario in args.scenario.scenarios() {
        let exact = study(Method::Exact, scenario, &config, args.runs, args.seed)
            .map_err(|e| e.to_string())?;
        let Some(target) = exact.azimuth_rmse else {
            println!(
                "{}: the azimuth is unobservable; nothing to match",
                scenario.name()
            );
            continue;
        };
        println!(
            "{}: exact filter azimuth RMSE {:.4} deg over {} runs, {:.0} ns/step",
            scenario.name(),
            target.to_degrees(),
            args.runs,
            exact.ns_per_step
        );
        for &n in &args.counts {
            let pf = study(Method::Particle(n), scenario, &config, args.runs, args.seed)
                .map_err(|e| e.to_string())?;
            let rmse = pf.azimuth_rmse.unwrap_or(f64::INFINITY);
            println!(
                "  {n:>7} particles: RMSE {:.4} deg, diverged {:.1}%, {:.0} ns/step ({:.0} x exact)",
                rmse.to_degrees(),
                100.0 * pf.divergence_rate.unwrap_or(0.0),
                pf.ns_per_step,
                pf.ns_per_step / exact.ns_per_step
            );
            if rmse <= target * (1.0 + args.tolerance) {
                println!(
                    "  -> {n} particles reach the exact filter's RMSE within {:.0}%",
                    100.0 * args.tolerance
                );
                break;
            }
        }
    }
    Ok(())
}

/// Bayes on the circle, and diffusion on SO(3), with exact densities.
fn densities_demo() {
    use liebayes::densities::{Convolve, Density, HeatKernelSo3, Product, VonMises};
    use liebayes::manifolds::So2;
    let prior = VonMises::new(So2::from_angle_unchecked(0.5), 4.0).expect("valid");
    let likelihood = VonMises::new(So2::from_angle_unchecked(1.2), 1e6).expect("valid");
    let posterior = prior
        .product(&likelihood)
        .expect("von Mises products are exact");
    println!("\n6. Von Mises Bayes (prior kappa 4, likelihood kappa 1e6, no overflow):");
    println!(
        "   posterior mean {:.9} rad, kappa {:.3}, log evidence {:.6}",
        posterior.mean().map_or(f64::NAN, |m| m.angle()),
        posterior.concentration(),
        prior
            .log_product_integral(&likelihood)
            .expect("finite for von Mises densities")
    );
    let gyro_noise = HeatKernelSo3::new(So3::identity(), 1e-4).expect("valid");
    let after_1000_steps = (1..1000).fold(gyro_noise, |acc, _| {
        acc.convolve(&gyro_noise).expect("variances stay finite")
    });
    println!(
        "7. SO(3) heat kernel: 1000 gyro steps of sigma^2 = 1e-4 convolve exactly to sigma^2 = {:.4}; \
         density at the centre {:.3e}",
        after_1000_steps.variance(),
        after_1000_steps.log_pdf(&after_1000_steps.mean()).exp()
    );
}

/// Integrates a constant angular rate with 10 000 right-multiplied steps and compares with the closed form.
fn integrate_a_gyro() {
    let rate = Vector3::new(0.3, -0.2, 0.9);
    let (dt, steps) = (1e-3, 10_000);
    let step = So3::exp(&(rate * dt));
    let mut attitude = So3::identity();
    for _ in 0..steps {
        attitude = attitude.compose(&step);
    }
    let exact = So3::exp(&(rate * dt * f64::from(steps)));
    println!("1. Gyro integration: 10 000 steps of exp(omega dt) composed on the right");
    println!(
        "   angle {:.12} rad, error against exp(omega T): {:.2e} rad\n",
        attitude.angle(),
        attitude.distance(&exact)
    );
}

/// Shows that the logarithm stays exact at and next to a half turn.
fn log_near_pi() {
    println!("2. Logarithm next to a half turn (the classic failure point of matrix-based logs)");
    let axis = Vector3::new(2.0, -1.0, 2.0) / 3.0;
    for delta in [1e-6, 1e-12, 0.0] {
        let v = axis * (PI - delta);
        let error = (So3::exp(&v).log() - v).norm();
        let matrix = nalgebra::Rotation3::from_scaled_axis(v);
        let matrix_error = (matrix.scaled_axis() - v).norm();
        println!(
            "   angle pi - {delta:.0e}: |log(exp(v)) - v| = {error:.1e} (nalgebra Rotation3::scaled_axis: {matrix_error:.1e})"
        );
    }
    println!();
}

/// Compares the right Jacobian of the action with a central finite difference.
fn jacobian_against_finite_difference() {
    let r = So3::exp(&Vector3::new(0.4, 1.1, -0.7));
    let p = Vector3::new(1.0, -2.0, 0.5);
    let analytic = r.j_act_self(&p);
    let h = 1e-6;
    let numeric = nalgebra::Matrix3::from_fn(|i, j| {
        let e = Vector3::ith(j, h);
        (r.retract(&e).act(&p)[i] - r.retract(&-e).act(&p)[i]) / (2.0 * h)
    });
    println!("3. Right Jacobian of R p with respect to R (perturbation R exp(delta)), -R hat(p)");
    println!(
        "   max |analytic - central difference| = {:.1e}\n",
        (analytic - numeric).amax()
    );
}

/// The double cover SU(2) -> SO(3), and a geodesic step on the sphere.
fn double_cover_and_sphere() {
    let q = Su2::exp(&Vector3::new(0.0, 0.0, 1.0));
    println!(
        "4. SU(2) is a double cover: q and -q are {:.6} apart on SU(2) (tangent norm 2 pi),",
        q.distance(&q.antipode())
    );
    println!(
        "   and {:.1e} apart as rotations in SO(3)",
        q.to_so3().distance(&q.antipode().to_so3())
    );
    let north = S2::new(Vector3::z()).expect("unit vector");
    let moved = north.retract(&nalgebra::Vector2::new(PI / 2.0, 0.0));
    println!(
        "5. S2: a quarter great circle from the north pole reaches {:.3?}, at angle {:.12} rad",
        moved.as_vector().as_slice(),
        north.distance(&moved)
    );
}
