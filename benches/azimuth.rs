//! Per-step cost of the exact azimuth filter (predict + update, and each alone) beside the grid of
//! Kalman filters it is checked against. `cargo bench --bench azimuth`; figures in docs/benchmarks.md.
#![allow(missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use liebayes::filters::azimuth::{
    AzimuthDensity, GridReference, PositionMeasurement, VelocityInput, VelocityProcess,
};
use nalgebra::Vector2;
use std::hint::black_box;
use std::time::Duration;

fn azimuth(c: &mut Criterion) {
    let mut g = c.benchmark_group("azimuth filter step");
    let process = VelocityProcess::new(0.1).unwrap();
    let measurement = PositionMeasurement::new(1.0).unwrap();
    let input = VelocityInput {
        velocity: Vector2::new(-1.0, 2.0),
        dt: 0.1,
    };
    let z = Vector2::new(3.0, -4.0);
    let mut exact = AzimuthDensity::new(Vector2::zeros(), 1.0).unwrap();
    g.bench_function("exact: predict + update", |b| {
        b.iter(|| {
            exact.predict(&process, black_box(&input)).unwrap();
            exact.update(&measurement, black_box(&z)).unwrap();
        });
    });
    g.bench_function("exact: log evidence of a measurement", |b| {
        b.iter(|| {
            black_box(&exact)
                .log_evidence(&measurement, black_box(&z))
                .unwrap()
        });
    });
    let mut exact = AzimuthDensity::new(Vector2::zeros(), 1.0).unwrap();
    g.bench_function("exact: predict", |b| {
        b.iter(|| exact.predict(&process, black_box(&input)).unwrap());
    });
    g.bench_function("exact: point estimates", |b| {
        b.iter(|| black_box(&exact).estimates());
    });
    for n in [90, 360] {
        let mut grid = GridReference::new(n, Vector2::zeros(), 1.0).unwrap();
        g.bench_function(
            format!("grid of {n} Kalman filters: predict + update"),
            |b| {
                b.iter(|| {
                    grid.predict(&process, black_box(&input)).unwrap();
                    grid.update(&measurement, black_box(&z)).unwrap();
                });
            },
        );
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    targets = azimuth
}
criterion_main!(benches);
