//! The baselines and the Monte Carlo study on the experiment layer: every method runs a study, the
//! grid filter with a fine grid reproduces the exact filter's estimates, the Gaussian baselines
//! report their wrapped-normal ρ, the study is reproducible and finds the exact filter consistent,
//! and the particle-count search finds a count that matches the exact filter.

use liebayes_experiments::search::SearchSettings;
use liebayes_experiments::{
    ExperimentError, Metric, Paired, PairedEstimate, RecursiveFilter, Reduction, Scenario, Scorer,
    Shard, Study, Summary, replay,
};
use liebayes_filters::azimuth::{
    AzimuthEstimate, AzimuthScenario, Config, Method, Motion, OnScenario, PositionAzimuth,
    PositionMeasurement, VelocityProcess, ekf, exact, final_azimuth_rmse, grid_filter,
    particles_to_match, ukf,
};
use liebayes_manifolds::Manifold;
use liebayes_operators::evaluation::average_nees_band;
use nalgebra::{Matrix2, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::sync::atomic::{AtomicU64, Ordering};

fn short(seconds: f64) -> Config {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let steps = (seconds * 10.0) as usize;
    Config {
        steps,
        ..Config::default()
    }
}

fn study(method: Method, motion: Motion, config: &Config, runs: u64, seed: u64) -> Summary {
    let scenario = AzimuthScenario::new(motion, *config).unwrap();
    let study = Study::new(method.label(), runs, seed, Shard::WHOLE).unwrap();
    method.study(&scenario, &study, &|_| {}).unwrap()
}

/// The final epoch's statistics of a metric.
fn last(summary: &Summary, metric: &str) -> liebayes_experiments::RunningStats {
    summary
        .series(metric)
        .unwrap()
        .epochs()
        .last()
        .unwrap()
        .clone()
}

/// Every method runs 100 s of the line scenario without a failed step; those that do not lose
/// their azimuth particles end within 3° of the truth on this seed.
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
        let summary = study(method, Motion::Line, &config, 1, 3);
        assert!(
            summary.failures().is_empty(),
            "{}: {:?}",
            method.label(),
            summary.failures()
        );
        assert_eq!(summary.series("azimuth_error").unwrap().epochs().len(), 100);
        let error = final_azimuth_rmse(&summary).unwrap();
        eprintln!("{}: final azimuth error {error:.3} deg", method.label());
        if matches!(
            method,
            Method::Exact | Method::Ekf | Method::Grid(_) | Method::Marginalized(_)
        ) {
            assert!(error < 3.0, "{}: {error}", method.label());
        }
    }
}

/// Two azimuth estimates against each other.
struct EstimateAgreement;

impl Scorer<PositionAzimuth, PairedEstimate<AzimuthEstimate, AzimuthEstimate>>
    for EstimateAgreement
{
    fn metrics(&self) -> Vec<Metric> {
        ["rho", "azimuth", "mean", "covariance"]
            .map(|name| Metric::new(name, Reduction::Mean, ""))
            .to_vec()
    }

    fn score(
        &self,
        _: &PositionAzimuth,
        pair: &PairedEstimate<AzimuthEstimate, AzimuthEstimate>,
        values: &mut [f64],
    ) {
        let (e, g) = (&pair.first, &pair.second);
        let scale = 1.0 + e.cov_r.amax();
        values[0] = (e.rho - g.rho).abs();
        // The azimuth difference, scaled to a tolerance of 1e-8 / ρ (its precision falls with ρ;
        // where one filter holds A uniform the other's ρ is zero to rounding, checked above).
        values[1] = match (e.azimuth, g.azimuth) {
            (Some(a), Some(b)) => b.local(&a)[0].abs() * e.rho.max(1e-3) * 0.1,
            _ => 0.0,
        };
        values[2] = (e.mean_r - g.mean_r).amax() / scale;
        values[3] = (e.cov_r - g.cov_r).amax() / scale;
    }
}

/// While a 2880-cell grid resolves the posterior (the first 60 s of the circle scenario), the grid
/// filter's estimate equals the exact filter's: azimuth, ρ, E r, Cov r.
#[test]
fn fine_grid_filter_estimates_equal_the_exact_ones() {
    let config = short(60.0);
    let process = VelocityProcess::new(config.q).unwrap();
    let measurement = PositionMeasurement::new(config.sigma_m).unwrap();
    let scenario = AzimuthScenario::new(Motion::Circle, config).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let steps = scenario.simulate(&mut rng).unwrap();
    let mut pair = Paired::new(
        exact(process, measurement, Vector2::zeros(), 1.0).unwrap(),
        grid_filter(2880, process, measurement, Vector2::zeros(), 1.0).unwrap(),
    );
    let scores = replay(&mut pair, steps, &EstimateAgreement).unwrap();
    assert_eq!(scores.epochs(), 60);
    for name in ["rho", "azimuth", "mean", "covariance"] {
        for k in 0..scores.epochs() {
            let error = scores.get(name, k).unwrap();
            assert!(error < 1e-9, "epoch {k}: {name} {error:e}");
        }
    }
}

#[test]
fn gaussian_baselines_report_a_wrapped_normal() {
    let process = VelocityProcess::new(0.1).unwrap();
    let measurement = PositionMeasurement::new(1.0).unwrap();
    let variance = std::f64::consts::PI.powi(2) / 3.0;
    let check = |e: AzimuthEstimate| {
        assert!((e.rho - (-variance / 2.0).exp()).abs() < 1e-15);
        assert!((e.sigma_a().unwrap() - variance.sqrt()).abs() < 1e-12);
        assert_eq!(e.mean_r, Vector2::new(1.0, 2.0));
        assert_eq!(e.cov_r, Matrix2::identity() * 0.25);
    };
    check(
        ekf(process, measurement, Vector2::new(1.0, 2.0), 0.5)
            .unwrap()
            .estimate()
            .unwrap(),
    );
    check(
        ukf(process, measurement, Vector2::new(1.0, 2.0), 0.5)
            .unwrap()
            .estimate()
            .unwrap(),
    );
    assert!(ekf(process, measurement, Vector2::zeros(), 0.0).is_err());
    assert!(ukf(process, measurement, Vector2::new(f64::NAN, 0.0), 1.0).is_err());
}

/// The study is the same on a second call (the timing aside), and over 300 runs of 200 s the exact
/// filter's final NEES of r lies in its 95 % band and its circular consistency's band holds 1.
#[test]
fn study_is_reproducible_and_the_exact_filter_is_consistent() {
    let config = short(200.0);
    for motion in [Motion::Circle, Motion::Line] {
        let a = study(Method::Exact, motion, &config, 300, 77);
        let b = study(Method::Exact, motion, &config, 300, 77);
        assert_eq!(a.metrics(), b.metrics());
        assert_eq!(a.trace(), b.trace());
        assert!(a.failures().is_empty());
        let nees = last(&a, "nees_position");
        let (low, high) = average_nees_band(2, usize::try_from(nees.count()).unwrap()).unwrap();
        let mean = nees.mean().unwrap();
        assert!(
            (low..=high).contains(&mean),
            "{}: NEES {mean} outside [{low}, {high}]",
            motion.name()
        );
        let circular = last(&a, "circular_consistency");
        let half = 1.96 * (circular.variance().unwrap() / circular.count() as f64).sqrt();
        let m = circular.mean().unwrap();
        assert!(
            (m - half..=m + half).contains(&1.0),
            "{}: circular {m} ± {half}",
            motion.name()
        );
        assert!(last(&a, "diverged").mean().is_some());
    }
    assert!(Study::new("exact", 0, 1, Shard::WHOLE).is_err());
    let scenario = AzimuthScenario::new(Motion::Line, config).unwrap();
    let one = Study::new("PF 0", 1, 1, Shard::WHOLE).unwrap();
    assert!(matches!(
        Method::Particle(0).study(&scenario, &one, &|_| {}),
        Err(ExperimentError::Method { .. })
    ));
}

/// The particle-count search on a short circle study: the count it returns passes (its RMSE within
/// 20 % of the exact filter's on the same runs, no failed run), the largest count it tried below
/// that did not, and the figures it reports are those of independent studies at those counts.
#[test]
fn the_particle_count_search_finds_a_count_that_matches_the_exact_filter() {
    let config = short(30.0);
    let scenario = AzimuthScenario::new(Motion::Circle, config).unwrap();
    let runs = Study::new("search", 40, 5, Shard::WHOLE).unwrap();
    let settings = |tolerance| SearchSettings {
        tolerance,
        low: 25,
        high: 6400,
        resolution: 0.25,
    };
    let runs_done = AtomicU64::new(0);
    let counted = |_| {
        runs_done.fetch_add(1, Ordering::Relaxed);
    };
    let search = particles_to_match(&scenario, &runs, settings(0.2), &counted).unwrap();
    eprintln!("particle search: {search:?}");
    let count = search.count.expect("6400 particles match the exact filter");
    let target = search.target * 1.2;
    let rmse_at = |n: u64| {
        let summary = study(
            Method::Particle(usize::try_from(n).unwrap()),
            Motion::Circle,
            &config,
            40,
            5,
        );
        (
            final_azimuth_rmse(&summary).unwrap(),
            summary.failure_count(),
        )
    };
    let (rmse, failures) = rmse_at(count);
    assert!(
        rmse <= target && failures == 0,
        "{count}: {rmse} vs {target}"
    );
    let below = search
        .tried
        .iter()
        .filter(|t| t.count < count)
        .map(|t| t.count)
        .max();
    if let Some(n) = below {
        let (rmse, failures) = rmse_at(n);
        assert!(
            rmse > target || failures > 0,
            "{n} passes too: {rmse} vs {target}"
        );
    }
    let exact_rmse =
        final_azimuth_rmse(&study(Method::Exact, Motion::Circle, &config, 40, 5)).unwrap();
    assert_eq!(exact_rmse, search.target);
    // Bad settings are refused before the exact filter's study runs (the progress counts runs).
    assert!(runs_done.swap(0, Ordering::Relaxed) > 0);
    assert!(particles_to_match(&scenario, &runs, settings(f64::NAN), &counted).is_err());
    assert_eq!(runs_done.load(Ordering::Relaxed), 0);
    let still = AzimuthScenario::new(Motion::Static, config).unwrap();
    assert!(particles_to_match(&still, &runs, settings(0.2), &|_| {}).is_err());
}

/// Every azimuth filter from the same settings, boxed.
fn all_six(
    process: VelocityProcess,
    measurement: PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
) -> Vec<(
    &'static str,
    Result<liebayes_filters::azimuth::AzimuthFilter, liebayes_operators::OperatorError>,
)> {
    use liebayes_filters::azimuth::{AzimuthFilter, marginalized_filter, particle_filter};
    let rng = ChaCha8Rng::seed_from_u64(1);
    let (p, m) = (process, measurement);
    vec![
        (
            "exact",
            exact(p, m, r0, sigma0).map(|f| Box::new(f) as AzimuthFilter),
        ),
        (
            "EKF",
            ekf(p, m, r0, sigma0).map(|f| Box::new(f) as AzimuthFilter),
        ),
        (
            "UKF",
            ukf(p, m, r0, sigma0).map(|f| Box::new(f) as AzimuthFilter),
        ),
        (
            "grid",
            grid_filter(36, p, m, r0, sigma0).map(|f| Box::new(f) as AzimuthFilter),
        ),
        (
            "MPF",
            marginalized_filter(36, p, m, r0, sigma0, rng.clone())
                .map(|f| Box::new(f) as AzimuthFilter),
        ),
        (
            "PF",
            particle_filter(100, p, m, r0, sigma0, rng).map(|f| Box::new(f) as AzimuthFilter),
        ),
    ]
}

/// Every one of the six filters refuses (`process`, `measurement`, `r0`, `sigma0`); with a
/// `config`, so do its check and a study's check of a method on those models (`OnScenario`,
/// refused before any run); each error names `setting`.
fn all_refuse(
    (process, measurement, r0, sigma0): (VelocityProcess, PositionMeasurement, Vector2<f64>, f64),
    config: Option<Config>,
    setting: &str,
) {
    for (name, filter) in all_six(process, measurement, r0, sigma0) {
        let error = filter
            .err()
            .unwrap_or_else(|| panic!("{name} took {setting} out of its range"));
        assert!(error.to_string().contains(setting), "{name}: {error}");
    }
    if let Some(config) = config {
        let error = config.validate().unwrap_err();
        assert!(error.to_string().contains(setting), "{error}");
        let on = OnScenario {
            method: Method::Ekf,
            process,
            measurement,
            sigma0,
        };
        let error = liebayes_experiments::Method::validate(&on).unwrap_err();
        assert!(error.to_string().contains(setting), "{error}");
    }
}

/// One prior (r₀, σ₀) had four accepted ranges. The exact and particle filters took
/// σ₀ in [1.5e-154, 1e150] and any r₀, the EKF and UKF σ₀ in about [1.4e-50, 1e50), the grid and
/// the marginalized filter |r₀| ≤ 1e100; `Config::validate` took all of them, and a study then
/// failed every run of four of the six methods. Now all six constructors and `Config::validate`
/// share one range, [1e-49, 1e49] for σ₀, σ_m and q and ±1e100 for r₀, and refuse just outside it,
/// naming the setting.
#[test]
fn every_azimuth_filter_and_the_config_share_one_settings_range() {
    let process = VelocityProcess::new(0.1).unwrap();
    let measurement = PositionMeasurement::new(1.0).unwrap();
    let r0 = Vector2::new(1.0, -2.0);
    for sigma0 in [0.99e-49, 1e-51, 1e-100, 1.01e49, 1e50, 1e149] {
        let config = Config {
            sigma0,
            ..Config::default()
        };
        all_refuse((process, measurement, r0, sigma0), Some(config), "sigma_0");
    }
    for sigma_m in [0.99e-49, 1e-60, 1.01e49, 1e149] {
        let measurement = PositionMeasurement::new(sigma_m).unwrap();
        let config = Config {
            sigma_m,
            ..Config::default()
        };
        all_refuse((process, measurement, r0, 1.0), Some(config), "sigma_m");
    }
    for q in [1.01e49, 1e149] {
        let process = VelocityProcess::new(q).unwrap();
        let config = Config {
            q,
            ..Config::default()
        };
        all_refuse(
            (process, measurement, r0, 1.0),
            Some(config),
            "q (m/sqrt(s))",
        );
    }
    // q √dt above 1e49: every Gaussian propagation would add q² dt > 1e98.
    let config = Config {
        q: 1e45,
        dt: 1e9,
        ..Config::default()
    };
    let error = config.validate().unwrap_err();
    assert!(error.to_string().contains("q (m/sqrt(s))"), "{error}");
    for r in [1.01e100, 1e150, -1e300] {
        all_refuse(
            (process, measurement, Vector2::new(0.0, r), 1.0),
            None,
            "r_0",
        );
    }
}

/// Settings each within its range whose run the filters could not take, found by a probe that ran
/// every filter for thousands of steps: σ₀ = σ_m = 1e-49 with q = 0 and a measurement every step
/// (the Gaussian baselines and the grid filters passed `tr Σ⁻¹ ≤ 1e100` at the 49th update and
/// refused every later one), q = 1e49 with 20 000 steps between measurements (the covariance
/// passed 1e100 at step 100) and dt = 1e30 on the line (positions too coarse for σ = 1: the UKF
/// refused every step from the first). Each is refused when the scenario is made, naming what
/// bounds it; inside the bounds every method runs without a failed step (just inside the first
/// two; the third is necessary, not sufficient: the UKF's manifold mean stops at an absolute step
/// of 1e-10, which positions of 1e9 m no longer resolve).
#[test]
fn runs_that_would_leave_the_filters_range_are_refused() {
    let tiny = Config {
        sigma0: 1e-49,
        sigma_m: 1e-49,
        q: 0.0,
        dt: 0.1,
        measure_every: 1,
        steps: 5000,
    };
    let quiet = Config {
        sigma0: 1e49,
        sigma_m: 1e49,
        q: 1e49,
        dt: 1.0,
        measure_every: 20_000,
        steps: 20_000,
    };
    let far = Config {
        sigma0: 1.0,
        sigma_m: 1.0,
        q: 0.0,
        dt: 1e30,
        measure_every: 1,
        steps: 2000,
    };
    for (config, motion, named) in [
        (tiny, Motion::Static, "precision"),
        (quiet, Motion::Static, "between two"),
        (far, Motion::Line, "distance the motion covers"),
    ] {
        let error = AzimuthScenario::new(motion, config).unwrap_err();
        assert!(error.to_string().contains(named), "{error}");
    }
    let inside = [
        (Config { steps: 20, ..tiny }, Motion::Static),
        (
            Config {
                measure_every: 1,
                steps: 200,
                ..quiet
            },
            Motion::Line,
        ),
        (
            Config {
                dt: 100.0,
                steps: 20,
                ..far
            },
            Motion::Line,
        ),
    ];
    for (config, motion) in inside {
        every_method_runs(motion, &config, 3, 5);
    }
}

/// A study of `runs` runs of every method on `config` and `motion`, none with a failed step.
fn every_method_runs(motion: Motion, config: &Config, runs: u64, seed: u64) {
    for method in [
        Method::Exact,
        Method::Ekf,
        Method::Ukf,
        Method::Particle(50),
        Method::Grid(36),
        Method::Marginalized(36),
    ] {
        let summary = study(method, motion, config, runs, seed);
        assert!(
            summary.failures().is_empty(),
            "{} on {config:?}: {:?}",
            method.label(),
            summary.failures()
        );
    }
}

/// At the ends of the shared range every filter runs.
#[test]
fn every_azimuth_filter_runs_at_the_ends_of_the_settings_range() {
    // At the ends of the range, the whole problem scaled to either end: every filter is built, and
    // a study of a few steps runs every method without a failure. (The range bounds each setting
    // and the Gaussians they make; settings far apart from each other, such as a prior or a process
    // noise 1e49 times the measurement noise, are another matter: the EKF's and the UKF's
    // covariances are then too ill-conditioned for f64, a step error at run time.) The circle's
    // velocity (0.5 m/s) is not scaled: at the small end the platform stands still.
    let at_ends = [
        (1e-49, 1e-49, 1e-50, Motion::Static),
        (1e49, 1e49, 1e49, Motion::Circle),
        (1.0, 1.0, 0.0, Motion::Circle),
    ];
    for (sigma0, sigma_m, q, motion) in at_ends {
        let (p, m) = (
            VelocityProcess::new(q).unwrap(),
            PositionMeasurement::new(sigma_m).unwrap(),
        );
        for (name, filter) in all_six(p, m, Vector2::new(0.0, 1e100), sigma0) {
            assert!(filter.is_ok(), "{name}: {:?}", filter.err());
        }
        let config = Config {
            sigma0,
            sigma_m,
            q,
            dt: 1.0,
            measure_every: 1,
            steps: 3,
        };
        config.validate().unwrap();
        every_method_runs(motion, &config, 4, 3);
    }
}
