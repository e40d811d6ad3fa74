//! Long runs stay valid: every azimuth filter (the exact filter, the EKF and UKF on `[r, A]`, the
//! bootstrap particle filter, the grid and the marginalized particle filter) stepped through many
//! epochs keeps a finite position mean, a finite symmetric positive semi-definite position
//! covariance (definite for all but the bootstrap particle filter, whose particles may collapse), a
//! mean resultant length in [0, 1] and a circular variance that is not NaN, after every step,
//! whether the step succeeded or was refused; a refused step leaves the estimate as it was.
//!
//! The readings are the circle and line scenarios' runs, one after another without resetting the
//! filter (so the truth jumps back to the origin every run, 100 s of 0.1 s steps, a position
//! measurement every second), with every 7th measurement replaced by a position drawn up to 10 km
//! away: readings that no track explains.
//!
//! The test runs 5 000 steps per filter; the long version is run by hand (the particle, grid and
//! marginalized filters, 20 to 200 times slower per step, a fiftieth of the steps):
//! `LIEBAYES_LONG_RUN_STEPS=100000000 cargo test --release -p liebayes-filters --test
//! azimuth_long_run -- --ignored --nocapture` (figures in docs/reliability.md).

mod common;

use liebayes_experiments::Method as _;
use liebayes_filters::azimuth::{AzimuthEstimate, AzimuthScenario, Config, Method, Motion};
use nalgebra::Vector2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Steps of the test-sized runs.
const TEST_STEPS: u64 = 5_000;

/// An estimate is valid: a finite position mean and a valid covariance (positive definite when
/// `definite`), ρ in [0, 1] and a circular variance in [0, ∞].
fn valid(e: &AzimuthEstimate, definite: bool) -> bool {
    e.mean_r.iter().all(|x| x.is_finite())
        && common::valid_covariance(&e.cov_r, definite)
        && (0.0..=1.0).contains(&e.rho)
        && e.circular_variance >= 0.0
}

/// Steps `method` through `steps` steps of alternating circle and line runs, every 7th
/// measurement replaced by a position up to 10 km away; returns the refused steps.
fn run(method: Method, steps: u64) -> u64 {
    let config = Config {
        steps: 1000,
        ..Config::default()
    };
    let scenarios = [Motion::Circle, Motion::Line]
        .map(|motion| AzimuthScenario::new(motion, config).expect("a valid scenario"));
    let definite = !matches!(method, Method::Particle(_));
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut wild = ChaCha8Rng::seed_from_u64(6);
    let mut filter = method
        .on(&scenarios[0])
        .expect("valid settings")
        .build(&mut rng)
        .expect("a filter");
    let corrupt = |z: &mut Vector2<f64>, measured: u64| {
        if measured % 7 == 0 {
            *z = Vector2::new(wild.random_range(-1e4..1e4), wild.random_range(-1e4..1e4));
        }
    };
    common::run(&mut *filter, &scenarios, steps, &mut rng, corrupt, |e| {
        valid(e, definite)
    })
}

/// The six filters, with the sizes the studies use.
const METHODS: [Method; 6] = [
    Method::Exact,
    Method::Ekf,
    Method::Ukf,
    Method::Particle(1000),
    Method::Grid(360),
    Method::Marginalized(360),
];

#[test]
fn every_filter_stays_valid() {
    for method in METHODS {
        let refused = run(method, TEST_STEPS);
        eprintln!("{}: {TEST_STEPS} steps, {refused} refused", method.label());
    }
}

#[test]
#[ignore = "the long run, by hand: LIEBAYES_LONG_RUN_STEPS=100000000"]
fn long_runs() {
    let steps = common::long_run_steps();
    for method in METHODS {
        let steps = match method {
            Method::Exact | Method::Ekf | Method::Ukf => steps,
            _ => steps / 50,
        };
        let refused = run(method, steps);
        eprintln!("{}: {steps} steps, {refused} refused", method.label());
    }
}
