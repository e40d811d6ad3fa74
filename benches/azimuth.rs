//! Per-step cost (predict + update) of the exact azimuth filter beside its baselines: the EKF and UKF
//! on [r, A], the bootstrap particle filter (at 1000 particles and at the count that matches the exact
//! filter's azimuth RMSE on the circle scenario), the grid filter and the marginalized particle filter.
//! `cargo bench --bench azimuth`; figures in docs/benchmarks.md.
#![allow(missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use liebayes::experiments::RecursiveFilter;
use liebayes::filters::azimuth::{
    AzimuthDensity, AzimuthExact, PositionMeasurement, VelocityInput, VelocityProcess, ekf, exact,
    grid_filter, marginalized_filter, particle_filter, ukf,
};
use liebayes::operators::{Condition, Propagate};
use nalgebra::Vector2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Duration;

/// The particle count at which the bootstrap filter's azimuth RMSE comes within 5 % of the exact
/// filter's on the circle scenario over 300 runs (`liebayes particles`, docs/filters/azimuth.md).
const MATCHING_PARTICLES: usize = 20_000;

fn models() -> (
    VelocityProcess,
    PositionMeasurement,
    VelocityInput,
    Vector2<f64>,
) {
    (
        VelocityProcess::new(0.1).unwrap(),
        PositionMeasurement::new(1.0).unwrap(),
        VelocityInput {
            velocity: Vector2::new(-1.0, 2.0),
            dt: 0.1,
        },
        Vector2::new(3.0, -4.0),
    )
}

fn exact_filter(c: &mut Criterion) {
    let mut g = c.benchmark_group("azimuth exact filter");
    let (process, measurement, input, z) = models();
    let mut density = AzimuthDensity::new(Vector2::zeros(), 1.0).unwrap();
    g.bench_function("predict + update (the seven-number recursion)", |b| {
        b.iter(|| {
            density = density.propagate(&process, black_box(&input)).unwrap();
            density = density.conditioned(&measurement, black_box(&z)).unwrap();
        });
    });
    g.bench_function("predict + update with its log evidence (Condition)", |b| {
        b.iter(|| {
            density = density.propagate(&process, black_box(&input)).unwrap();
            density = density
                .condition(&measurement, black_box(&z))
                .unwrap()
                .posterior;
        });
    });
    g.bench_function("log evidence of a measurement", |b| {
        b.iter(|| {
            black_box(&density)
                .log_evidence(&measurement, black_box(&z))
                .unwrap()
        });
    });
    let density = AzimuthDensity::new(Vector2::zeros(), 1.0).unwrap();
    g.bench_function("predict", |b| {
        b.iter(|| {
            black_box(&density)
                .propagate(&process, black_box(&input))
                .unwrap()
        });
    });
    g.bench_function("point estimate", |b| {
        b.iter(|| black_box(&density).estimate());
    });
    g.finish();
}

/// One predict + update of `filter` per iteration, as a study steps it, on a stationary platform
/// measured at a fixed point (so that each filter's state stays in range).
fn step(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    label: &str,
    mut filter: impl RecursiveFilter<Input = VelocityInput, Measurement = Vector2<f64>>,
) {
    let (_, _, _, z) = models();
    let input = VelocityInput {
        velocity: Vector2::zeros(),
        dt: 0.1,
    };
    g.bench_function(label, |b| {
        b.iter(|| {
            filter.predict(black_box(&input)).unwrap();
            filter.update(black_box(&z)).unwrap();
        });
    });
}

fn baselines(c: &mut Criterion) {
    let mut g = c.benchmark_group("azimuth predict + update");
    let (p, m, _, _) = models();
    let r0 = Vector2::zeros();
    let rng = || ChaCha8Rng::seed_from_u64(1);
    step(&mut g, "exact", exact(p, m, r0, 1.0).unwrap());
    // The cost of a method's boxed filter (one Filter type for methods of different types).
    let boxed: Box<
        dyn RecursiveFilter<
                Input = VelocityInput,
                Measurement = Vector2<f64>,
                Estimate = <AzimuthExact as RecursiveFilter>::Estimate,
            > + Send,
    > = Box::new(exact(p, m, r0, 1.0).unwrap());
    step(&mut g, "exact, boxed", boxed);
    step(&mut g, "EKF", ekf(p, m, r0, 1.0).unwrap());
    step(&mut g, "UKF", ukf(p, m, r0, 1.0).unwrap());
    step(&mut g, "grid 360", grid_filter(360, p, m, r0, 1.0).unwrap());
    step(
        &mut g,
        "MPF 360",
        marginalized_filter(360, p, m, r0, 1.0, rng()).unwrap(),
    );
    step(
        &mut g,
        "PF 1000",
        particle_filter(1000, p, m, r0, 1.0, rng()).unwrap(),
    );
    step(
        &mut g,
        &format!("PF {MATCHING_PARTICLES}"),
        particle_filter(MATCHING_PARTICLES, p, m, r0, 1.0, rng()).unwrap(),
    );
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    targets = exact_filter, baselines
}
criterion_main!(benches);
