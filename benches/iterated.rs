//! One measurement update of an attitude (world-frame errors) by gravity and a magnetic field
//! (M = 6): the one-pass EKF and UKF beside the iterated EKF and the iterated posterior
//! linearisation, from a prior near the truth (the steady state of a filter) and from a 30° prior
//! 30° away (the first update of the docs' study). `cargo bench --bench iterated`.

use criterion::{Criterion, criterion_group, criterion_main};
use liebayes::densities::ManifoldGaussian;
use liebayes::manifolds::{GroupAction, Left, LieGroup, So3};
use liebayes::operators::iterated::{IteratedEkf, IteratedUkf};
use liebayes::operators::{Condition, Ekf, MeasurementModel, Ukf};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use std::hint::black_box;
use std::time::Duration;

const GRAVITY: Vector3<f64> = Vector3::new(0.0, 0.0, 9.81);
const FIELD: Vector3<f64> = Vector3::new(0.4, 0.0, -0.916_515_138_991_168);

/// `z = [Rᵀ g; Rᵀ m] + n`, σ 0.05 and 0.01, analytic Jacobian `[R̂ᵀ hat(g); R̂ᵀ hat(m)]`.
struct Directions;

impl MeasurementModel<Left<So3<f64>>, 3, 6> for Directions {
    fn predict(&self, x: &Left<So3<f64>>) -> SVector<f64, 6> {
        let inverse = x.inverse();
        let (g, m) = (inverse.act(&GRAVITY), inverse.act(&FIELD));
        SVector::<f64, 6>::new(g[0], g[1], g[2], m[0], m[1], m[2])
    }

    fn noise(&self, _: &Left<So3<f64>>) -> SMatrix<f64, 6, 6> {
        SMatrix::<f64, 6, 6>::from_diagonal(&SVector::<f64, 6>::new(
            2.5e-3, 2.5e-3, 2.5e-3, 1e-4, 1e-4, 1e-4,
        ))
    }

    fn jacobian(&self, x: &Left<So3<f64>>) -> SMatrix<f64, 6, 3> {
        let (inverse, j_inverse) = (x.inverse(), x.j_inverse_self());
        let mut h = SMatrix::<f64, 6, 3>::zeros();
        h.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(inverse.j_act_self(&GRAVITY) * j_inverse));
        h.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(inverse.j_act_self(&FIELD) * j_inverse));
        h
    }
}

fn updates(c: &mut Criterion) {
    let truth = Left::new(So3::exp(&Vector3::new(0.3, -0.2, 1.0)));
    let z = Directions.predict(&truth);
    let cases = [
        ("near (0.3 deg prior, 0.3 deg off)", 0.3_f64, 0.3_f64),
        ("far (30 deg prior, 30 deg off)", 30.0, 30.0),
    ];
    for (name, sigma, offset) in cases {
        let mean =
            Left::new(So3::exp(&Vector3::new(offset.to_radians(), 0.0, 0.0))).compose(&truth);
        let prior =
            ManifoldGaussian::new(mean, Matrix3::identity() * sigma.to_radians().powi(2)).unwrap();
        let mut g = c.benchmark_group(format!("attitude update, {name}"));
        g.bench_function("EKF", |b| {
            b.iter(|| black_box(&prior).condition(&Ekf(&Directions), black_box(&z)));
        });
        g.bench_function("UKF", |b| {
            b.iter(|| black_box(&prior).condition(&Ukf::new(&Directions), black_box(&z)));
        });
        g.bench_function("iterated EKF", |b| {
            b.iter(|| black_box(&prior).condition(&IteratedEkf::new(&Directions), black_box(&z)));
        });
        g.bench_function("iterated sigma-point", |b| {
            b.iter(|| black_box(&prior).condition(&IteratedUkf::new(&Directions), black_box(&z)));
        });
        g.finish();
        let steps = prior
            .condition(&IteratedEkf::new(&Directions), &z)
            .unwrap()
            .report;
        let sigma_steps = prior
            .condition(&IteratedUkf::new(&Directions), &z)
            .unwrap()
            .report;
        println!(
            "{name}: iterated EKF {} steps ({:?}), iterated sigma-point {} steps ({:?})",
            steps.iterations(),
            steps.stop(),
            sigma_steps.iterations(),
            sigma_steps.stop()
        );
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    targets = updates
}
criterion_main!(benches);
