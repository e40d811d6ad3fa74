//! Long runs stay valid: every attitude filter stepped through many samples of arbitrary (but
//! in-range) readings keeps a finite unit orientation and, where it has one, a symmetric positive
//! definite covariance, after every step, whether the step succeeded or was refused.
//!
//! The test runs 20 000 steps per filter (400 for the talk's); the long version is run by hand
//! (the talk's filter a fiftieth of the steps):
//! `LIEBAYES_LONG_RUN_STEPS=100000000 cargo test --release -p liebayes-filters --test
//! attitude_long_run -- --ignored --nocapture` (figures in docs/reliability.md).

use liebayes_experiments::RecursiveFilter;
use liebayes_filters::attitude::{AttitudeEstimate, AttitudeFilter, ImuSample, Method};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Whether an estimate is valid: a finite unit quaternion and, where there is one, a finite
/// symmetric positive definite covariance.
fn valid(e: &AttitudeEstimate) -> bool {
    let q = e.orientation.coords;
    let unit = q.iter().all(|c| c.is_finite()) && (q.norm() - 1.0).abs() < 1e-9;
    let covariance = e.covariance.is_none_or(|p| {
        p.iter().all(|c| c.is_finite())
            && (p - p.transpose()).amax() <= 1e-9 * p.amax()
            && p.cholesky().is_some()
    });
    unit && covariance
}

/// A reading of a random direction with a norm drawn log-uniformly in `[low, high]`.
fn reading(rng: &mut ChaCha8Rng, low: f64, high: f64) -> Vector3<f64> {
    let v = Vector3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    );
    let norm = (low.ln() + rng.random::<f64>() * (high.ln() - low.ln())).exp();
    v.try_normalize(1e-12).unwrap_or_else(Vector3::z) * norm
}

/// Steps `filter` through `steps` samples: mostly a sensor lying still with noise, with bursts of
/// fast rotation, large accelerations and a wandering field; every 97th sample a magnetometer
/// reading of a random direction and norm. Returns the number of refused steps.
fn run(mut filter: AttitudeFilter, steps: u64, seed: u64) -> u64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let earth = Vector3::new(0.0, 20.0, -40.0);
    let mut refused = 0;
    for k in 0..steps {
        let burst = (k / 500) % 4 == 3;
        let sample = ImuSample {
            gyro: if burst {
                reading(&mut rng, 1e-3, 30.0)
            } else {
                reading(&mut rng, 1e-6, 1e-2)
            },
            acc: if burst {
                reading(&mut rng, 0.1, 200.0)
            } else {
                Vector3::new(0.0, 0.0, 9.81) + reading(&mut rng, 1e-4, 0.1)
            },
        };
        if filter.predict(&sample).is_err() {
            refused += 1;
        }
        let field = if k % 97 == 0 {
            reading(&mut rng, 1.0, 1e3)
        } else {
            earth + reading(&mut rng, 1e-3, 1.0)
        };
        if filter.update(&field).is_err() {
            refused += 1;
        }
        let estimate = filter.estimate().expect("initialised by the first sample");
        assert!(valid(&estimate), "step {k}: {estimate:?}");
    }
    refused
}

/// The filters and the share of the steps each runs (the talk filter is about 300 times slower
/// than the EKF: it runs a fiftieth).
fn filters() -> [(&'static str, u64); 6] {
    [
        ("ekf-9d", 1),
        ("ekf-6d", 1),
        ("madgwick-9d", 1),
        ("madgwick-6d", 1),
        ("talk-9d", 50),
        ("talk-6d", 50),
    ]
}

#[test]
fn every_filter_stays_valid_over_arbitrary_readings() {
    for (name, share) in filters() {
        let filter = Method::from_name(name).unwrap().build(100.0).unwrap();
        let refused = run(filter, 20_000 / share, 7);
        // Every reading is within the sensors' limits: no step is refused.
        assert_eq!(refused, 0, "{name}");
    }
}

#[test]
#[ignore = "long: run by hand with LIEBAYES_LONG_RUN_STEPS"]
fn every_filter_stays_valid_over_a_long_run() {
    let steps: u64 = std::env::var("LIEBAYES_LONG_RUN_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    for (name, share) in filters() {
        let filter = Method::from_name(name).unwrap().build(100.0).unwrap();
        let refused = run(filter, steps / share, 11);
        println!("{name}: {} steps valid, {refused} refused", steps / share);
    }
}
