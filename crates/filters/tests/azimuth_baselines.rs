//! The baselines and the Monte Carlo study: each baseline runs through the common interface, the grid
//! filter with a fine grid reproduces the exact filter's estimates, the Gaussian baselines report their
//! wrapped-normal ρ, and the study is reproducible and finds the exact filter consistent.

use liebayes_filters::azimuth::scenario::{Config, Scenario, simulate};
use liebayes_filters::azimuth::study::{Method, run_once};
use liebayes_filters::azimuth::{
    AzimuthDensity, AzimuthFilter, GaussianBaseline, GridReference, Linearisation,
    PositionMeasurement, VelocityInput, VelocityProcess, study,
};
use liebayes_manifolds::So2;
use liebayes_operators::evaluation::estimation_error;
use nalgebra::{Matrix2, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn short(seconds: f64) -> Config {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let steps = (seconds * 10.0) as usize;
    Config {
        steps,
        ..Config::default()
    }
}

/// Every method runs 100 s of the line scenario without a failed step; those that do not lose their
/// azimuth particles end within 3° of the truth on this seed.
#[test]
fn every_method_runs_and_the_sound_ones_find_the_azimuth() {
    let config = short(100.0);
    for method in [
        Method::Exact,
        Method::Ekf,
        Method::Ukf,
        Method::Particle(500),
        Method::Grid(720),
        Method::Marginalized(720),
    ] {
        let run = run_once(method, Scenario::Line, &config, 3).unwrap();
        assert!(
            run.failure.is_none(),
            "{}: {:?}",
            method.label(),
            run.failure
        );
        assert_eq!(run.steps, 1000);
        assert_eq!(run.epochs.len(), 100);
        let last = run.epochs.last().unwrap();
        let error = last.azimuth_error.unwrap();
        eprintln!(
            "{}: final azimuth error {:.3} deg",
            method.label(),
            error.to_degrees()
        );
        if matches!(
            method,
            Method::Exact | Method::Ekf | Method::Grid(_) | Method::Marginalized(_)
        ) {
            assert!(
                error.abs() < 3f64.to_radians(),
                "{}: {error}",
                method.label()
            );
        }
    }
}

/// While a 2880-cell grid resolves the posterior (the first 60 s of the circle scenario), the grid
/// filter's estimate through the common interface equals the exact filter's: azimuth, ρ, E r, Cov r.
#[test]
fn fine_grid_filter_estimates_equal_the_exact_ones() {
    let config = short(60.0);
    let process = VelocityProcess::new(config.q).unwrap();
    let measurement = PositionMeasurement::new(config.sigma_m).unwrap();
    let sim = simulate(Scenario::Circle, &config, &mut ChaCha8Rng::seed_from_u64(4)).unwrap();
    let mut exact = AzimuthDensity::new(Vector2::zeros(), 1.0).unwrap();
    let mut grid = GridReference::new(2880, Vector2::zeros(), 1.0).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    for (k, v) in sim.velocities.iter().enumerate() {
        if let Some(z) = sim.measurements[k] {
            AzimuthFilter::update(&mut exact, &measurement, &z, &mut rng).unwrap();
            AzimuthFilter::update(&mut grid, &measurement, &z, &mut rng).unwrap();
            let (e, g) = (exact.estimate().unwrap(), grid.estimate().unwrap());
            assert!(
                (e.rho - g.rho).abs() < 1e-9,
                "{k}: rho {} vs {}",
                e.rho,
                g.rho
            );
            if let (Some(a), Some(b)) = (e.azimuth, g.azimuth) {
                let difference =
                    estimation_error(&So2::from_angle_unchecked(b), &So2::from_angle_unchecked(a))
                        [0];
                assert!(difference.abs() < 1e-8 / e.rho.max(1e-3), "{k}");
            }
            let scale = 1.0 + e.cov_r.amax();
            assert!((e.mean_r - g.mean_r).amax() < 1e-9 * scale, "{k}");
            assert!((e.cov_r - g.cov_r).amax() < 1e-9 * scale, "{k}");
        }
        let input = VelocityInput {
            velocity: *v,
            dt: config.dt,
        };
        AzimuthFilter::predict(&mut exact, &process, &input, &mut rng).unwrap();
        AzimuthFilter::predict(&mut grid, &process, &input, &mut rng).unwrap();
    }
}

#[test]
fn gaussian_baselines_report_a_wrapped_normal() {
    for kind in [Linearisation::Extended, Linearisation::Unscented] {
        let filter = GaussianBaseline::new(kind, Vector2::new(1.0, 2.0), 0.5).unwrap();
        let e = filter.estimate().unwrap();
        let variance = std::f64::consts::PI.powi(2) / 3.0;
        assert!((e.rho - (-variance / 2.0).exp()).abs() < 1e-15);
        assert!((e.sigma_a().unwrap() - variance.sqrt()).abs() < 1e-12);
        assert_eq!(e.mean_r, Vector2::new(1.0, 2.0));
        assert_eq!(e.cov_r, Matrix2::identity() * 0.25);
        assert!(GaussianBaseline::new(kind, Vector2::zeros(), 0.0).is_err());
        assert!(GaussianBaseline::new(kind, Vector2::new(f64::NAN, 0.0), 1.0).is_err());
    }
}

/// The study is the same on a second call (the timing aside), and over 300 runs of 200 s the exact
/// filter's average NEES of r lies in its 95 % band and its circular consistency band holds 1.
#[test]
fn study_is_reproducible_and_the_exact_filter_is_consistent() {
    let config = short(200.0);
    for scenario in [Scenario::Circle, Scenario::Line] {
        let a = study(Method::Exact, scenario, &config, 300, 77).unwrap();
        let b = study(Method::Exact, scenario, &config, 300, 77).unwrap();
        assert_eq!(a.azimuth_rmse, b.azimuth_rmse);
        assert_eq!(a.average_nees, b.average_nees);
        assert_eq!(a.first_run.epochs, b.first_run.epochs);
        let (low, high) = a.nees_band;
        assert!(
            (low..=high).contains(&a.average_nees),
            "{}: NEES {} outside [{low}, {high}]",
            scenario.name(),
            a.average_nees
        );
        let (c_low, c_high) = a.circular.band().unwrap();
        assert!(
            (c_low..=c_high).contains(&1.0),
            "{}: circular [{c_low}, {c_high}]",
            scenario.name()
        );
        assert_eq!(a.failures, 0);
        assert!(a.divergence_rate.is_some());
    }
    assert!(study(Method::Exact, Scenario::Line, &config, 0, 1).is_err());
    assert!(study(Method::Particle(0), Scenario::Line, &config, 1, 1).is_err());
}
