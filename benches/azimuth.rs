//! Per-step cost (predict + update) of the exact azimuth filter beside its baselines: the EKF and UKF
//! on [r, A], the bootstrap particle filter (at 1000 particles and at the count that matches the exact
//! filter's azimuth RMSE on the circle scenario), the grid filter and the marginalized particle filter.
//! `cargo bench --bench azimuth`; figures in docs/benchmarks.md.
#![allow(missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use liebayes::filters::azimuth::scenario::Config;
use liebayes::filters::azimuth::{
    AzimuthDensity, Method, PositionMeasurement, VelocityInput, VelocityProcess,
};
use nalgebra::Vector2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Duration;

/// The particle count at which the bootstrap filter's azimuth RMSE comes within 5 % of the exact filter's
/// on the circle scenario over 300 runs (`liebayes particles --scenario circle --runs 300`,
/// docs/filters/azimuth.md).
const MATCHING_PARTICLES: usize = 20_000;

fn exact(c: &mut Criterion) {
    let mut g = c.benchmark_group("azimuth exact filter");
    let process = VelocityProcess::new(0.1).unwrap();
    let measurement = PositionMeasurement::new(1.0).unwrap();
    let input = VelocityInput {
        velocity: Vector2::new(-1.0, 2.0),
        dt: 0.1,
    };
    let z = Vector2::new(3.0, -4.0);
    let mut exact = AzimuthDensity::new(Vector2::zeros(), 1.0).unwrap();
    g.bench_function("predict + update", |b| {
        b.iter(|| {
            exact.predict(&process, black_box(&input)).unwrap();
            exact.update(&measurement, black_box(&z)).unwrap();
        });
    });
    g.bench_function("log evidence of a measurement", |b| {
        b.iter(|| {
            black_box(&exact)
                .log_evidence(&measurement, black_box(&z))
                .unwrap()
        });
    });
    let mut exact = AzimuthDensity::new(Vector2::zeros(), 1.0).unwrap();
    g.bench_function("predict", |b| {
        b.iter(|| exact.predict(&process, black_box(&input)).unwrap());
    });
    g.bench_function("point estimates", |b| {
        b.iter(|| black_box(&exact).estimates());
    });
    g.finish();
}

/// Every method through the common `AzimuthFilter` interface (one virtual call per step), on a
/// stationary platform measured at a fixed point, so that each filter's state stays in range.
fn baselines(c: &mut Criterion) {
    let mut g = c.benchmark_group("azimuth predict + update");
    let process = VelocityProcess::new(0.1).unwrap();
    let measurement = PositionMeasurement::new(1.0).unwrap();
    let input = VelocityInput {
        velocity: Vector2::zeros(),
        dt: 0.1,
    };
    let z = Vector2::new(3.0, -4.0);
    let config = Config::default();
    for method in [
        Method::Exact,
        Method::Ekf,
        Method::Ukf,
        Method::Grid(360),
        Method::Marginalized(360),
        Method::Particle(1000),
        Method::Particle(MATCHING_PARTICLES),
    ] {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut filter = method.build(&config, &mut rng).unwrap();
        g.bench_function(method.label(), |b| {
            b.iter(|| {
                filter
                    .predict(&process, black_box(&input), &mut rng)
                    .unwrap();
                filter
                    .update(&measurement, black_box(&z), &mut rng)
                    .unwrap();
            });
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    targets = exact, baselines
}
criterion_main!(benches);
