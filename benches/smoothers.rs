//! The fixed-lag smoother's cost per epoch beside the plain EKF step it records: an attitude on
//! SO(3) (D = 3, two directions measured), lags 1, 10 and 50. Each iteration is one epoch:
//! a propagation and an update, then (for the smoother) the backward pass over its window.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use liebayes::densities::ManifoldGaussian;
use liebayes::manifolds::{GroupAction, LieGroup, So3};
use liebayes::operators::fixed_lag::FixedLagSmoother;
use liebayes::operators::{Condition, Ekf, MeasurementFn, ProcessFn, Propagate};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use std::hint::black_box;

fn attitude(c: &mut Criterion) {
    let increment = So3::exp(&Vector3::new(0.002, 0.005, -0.003));
    let gyro = ProcessFn::new(
        move |x: &So3<f64>, (): &()| x.compose(&increment),
        |_, ()| Matrix3::identity() * 1e-6,
    );
    let directions = |x: &So3<f64>| {
        let g = x.inverse().act(&Vector3::new(0.0, 0.0, 1.0));
        let m = x.inverse().act(&Vector3::new(0.6, 0.0, 0.8));
        SVector::<f64, 6>::from_iterator(g.iter().chain(m.iter()).copied())
    };
    let sensors = MeasurementFn::new(directions, |_| SMatrix::<f64, 6, 6>::identity() * 2.5e-3);
    let prior = ManifoldGaussian::new(
        So3::exp(&Vector3::new(0.5, -1.0, 2.0)),
        Matrix3::identity() * 0.04,
    )
    .unwrap();
    let reading = directions(&So3::exp(&Vector3::new(0.5, -1.0, 2.0)));
    let mut group = c.benchmark_group("SO(3) attitude, one epoch");
    group.bench_function("EKF step", |b| {
        let mut density = prior.clone();
        b.iter(|| {
            density.propagate_in_place(&Ekf(&gyro), &()).unwrap();
            density
                .condition_in_place(&Ekf(&sensors), black_box(&reading))
                .unwrap();
        });
    });
    for lag in [1, 10, 50] {
        group.bench_with_input(
            BenchmarkId::new("fixed-lag step and smooth", lag),
            &lag,
            |b, &lag| {
                let mut smoother = FixedLagSmoother::new(prior.clone(), lag).unwrap();
                b.iter(|| {
                    smoother.propagate(&Ekf(&gyro), &()).unwrap();
                    smoother
                        .condition(&Ekf(&sensors), black_box(&reading))
                        .unwrap();
                    black_box(
                        smoother
                            .smooth()
                            .unwrap()
                            .lagged()
                            .map(|s| s.covariance()[0]),
                    );
                });
            },
        );
    }
    group.finish();
}

criterion_group!(benches, attitude);
criterion_main!(benches);
