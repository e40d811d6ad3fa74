//! The `liebayes` command-line program.
//!
//! With no arguments: the azimuth filter's Monte Carlo summary on all three scenarios (500 runs each),
//! then short demonstrations of the manifolds and densities. `liebayes azimuth [--scenario …]
//! [--runs N] [--seed S]` runs the azimuth study alone.

use liebayes::manifolds::{GroupAction, LieGroup, Manifold, S2, So3, Su2};
use nalgebra::Vector3;
use std::f64::consts::PI;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        None => {
            println!(
                "liebayes {}: Bayesian state estimation on Lie groups\n",
                env!("CARGO_PKG_VERSION")
            );
            let result = azimuth(&[]);
            println!("\nThe library at work (manifolds and densities):");
            integrate_a_gyro();
            log_near_pi();
            jacobian_against_finite_difference();
            double_cover_and_sphere();
            densities_demo();
            result
        }
        Some("azimuth") => azimuth(&args[1..]),
        Some(other) => {
            eprintln!("unknown command {other:?}\n{USAGE}");
            ExitCode::FAILURE
        }
    }
}

const USAGE: &str =
    "usage: liebayes [azimuth [--scenario static|circle|line] [--runs N] [--seed S]]";

/// `liebayes azimuth`: the exact azimuth filter's Monte Carlo summary per scenario (all three by
/// default, 500 runs each, the seed's settings).
fn azimuth(args: &[String]) -> ExitCode {
    use liebayes::filters::azimuth::scenario::{Config, Scenario};
    use liebayes::filters::azimuth::{particle_study, study};
    let (mut scenarios, mut runs, mut seed) = (Scenario::ALL.to_vec(), 500_usize, 1_u64);
    let (mut particles, mut particle_runs) = (1000_usize, 20_usize);
    let mut it = args.iter();
    while let Some(flag) = it.next() {
        let value = it.next().map(String::as_str);
        let parsed = match (flag.as_str(), value) {
            ("--scenario", Some(name)) => Scenario::ALL
                .into_iter()
                .find(|s| s.name() == name)
                .map(|s| scenarios = vec![s]),
            ("--runs", Some(n)) => n.parse().ok().filter(|&n| n > 0).map(|n| runs = n),
            ("--seed", Some(s)) => s.parse().ok().map(|s| seed = s),
            ("--particles", Some(n)) => n.parse().ok().filter(|&n| n > 0).map(|n| particles = n),
            ("--particle-runs", Some(n)) => n.parse().ok().map(|n| particle_runs = n),
            _ => None,
        };
        if parsed.is_none() {
            eprintln!("bad argument {flag} {}\n{USAGE}", value.unwrap_or(""));
            return ExitCode::FAILURE;
        }
    }
    let config = Config::default();
    println!(
        "Azimuth alignment (seed 000), exact 7-number filter: {runs} runs per scenario, 500 s, \
         measurements every 1 s, sigma_0 = sigma_m = 1 m, q = 0.1 m/sqrt(s), seed {seed}"
    );
    println!(
        "{:<8} {:>16} {:>14} {:>12} {:>18} {:>12} {:>10}",
        "scenario", "azimuth RMSE deg", "mean sigma_A", "NEES r", "95% band", "diverged", "ns/step"
    );
    let degrees = |x: Option<f64>| {
        x.map_or("unobservable".to_string(), |r| {
            format!("{:.4}", r.to_degrees())
        })
    };
    for scenario in scenarios {
        match study(scenario, &config, runs, seed) {
            Ok(s) => println!(
                "{:<8} {:>16} {:>14} {:>12.3} {:>18} {:>12} {:>10.1}",
                scenario.name(),
                degrees(s.azimuth_rmse),
                degrees(s.mean_sigma_a),
                s.average_nees,
                format!("[{:.3}, {:.3}]", s.nees_band.0, s.nees_band.1),
                s.divergence_rate
                    .map_or("-".to_string(), |d| format!("{:.1}%", 100.0 * d)),
                s.ns_per_step
            ),
            Err(e) => {
                eprintln!("{}: {e}", scenario.name());
                return ExitCode::FAILURE;
            }
        }
        if particle_runs == 0 || scenario == Scenario::Static {
            continue;
        }
        match particle_study(scenario, &config, particle_runs, seed, particles) {
            Ok(s) => println!(
                "{:<8} {:>16.4} {:>14} {:>12} {:>18} {:>12} {:>10.1}   <- particle filter, {particles} particles, {} runs",
                "",
                s.azimuth_rmse.to_degrees(),
                "-",
                "-",
                "-",
                format!("{:.1}%", 100.0 * s.divergence_rate),
                s.ns_per_step,
                s.runs
            ),
            Err(e) => println!("{:<8} particle filter failed: {e}", ""),
        }
    }
    ExitCode::SUCCESS
}

/// Bayes on the circle, and diffusion on SO(3), with exact densities.
fn densities_demo() {
    use liebayes::densities::{Convolve, Density, HeatKernelSo3, Product, VonMises};
    use liebayes::manifolds::So2;
    let prior =
        VonMises::from_mean_concentration(So2::from_angle_unchecked(0.5), 4.0).expect("valid");
    let likelihood =
        VonMises::from_mean_concentration(So2::from_angle_unchecked(1.2), 1e6).expect("valid");
    let posterior = prior
        .product(&likelihood)
        .expect("von Mises products are exact");
    println!("\n6. Von Mises Bayes (prior kappa 4, likelihood kappa 1e6, no overflow):");
    println!(
        "   posterior mean {:.9} rad, kappa {:.3}, log evidence {:.6}",
        posterior.mean_direction().map_or(f64::NAN, |m| m.angle()),
        posterior.concentration(),
        prior.log_product_integral(&likelihood)
    );
    let gyro_noise = HeatKernelSo3::new(So3::identity(), 1e-4).expect("valid");
    let after_1000_steps = (1..1000).fold(gyro_noise, |acc, _| {
        acc.convolve(&gyro_noise).expect("variances stay finite")
    });
    println!(
        "7. SO(3) heat kernel: 1000 gyro steps of sigma^2 = 1e-4 convolve exactly to sigma^2 = {:.4}; \
         density at the centre {:.3e}",
        after_1000_steps.variance(),
        after_1000_steps.log_pdf(after_1000_steps.center()).exp()
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
