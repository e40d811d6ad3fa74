//! Benchmarks of the manifold layer: exp, log, compose, act and the Jacobians of `So3` and `Su2`, each
//! beside nalgebra's `UnitQuaternion` and `Rotation3` equivalent in the same run.
//!
//! Run: `cargo bench --bench manifolds` (figures in docs/benchmarks.md).

use criterion::{Criterion, criterion_group, criterion_main};
use liebayes::manifolds::{GroupAction, LieGroup, Manifold, So3, Su2};
use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use std::hint::black_box;
use std::time::Duration;

fn inputs() -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    (
        Vector3::new(0.3, -1.1, 0.7),
        Vector3::new(-0.4, 0.2, 2.1),
        Vector3::new(1.0, -2.0, 0.5),
    )
}

fn exp(c: &mut Criterion) {
    let (v, _, _) = inputs();
    let mut g = c.benchmark_group("exp");
    g.bench_function("So3", |b| b.iter(|| So3::exp(black_box(&v))));
    g.bench_function("Su2", |b| b.iter(|| Su2::exp(black_box(&v))));
    g.bench_function("nalgebra UnitQuaternion::from_scaled_axis", |b| {
        b.iter(|| UnitQuaternion::from_scaled_axis(*black_box(&v)));
    });
    g.bench_function("nalgebra Rotation3::from_scaled_axis", |b| {
        b.iter(|| Rotation3::from_scaled_axis(*black_box(&v)));
    });
    g.finish();
}

fn log(c: &mut Criterion) {
    let (v, _, _) = inputs();
    let (r, q) = (So3::exp(&v), Su2::exp(&v));
    let (uq, m) = (
        UnitQuaternion::from_scaled_axis(v),
        Rotation3::from_scaled_axis(v),
    );
    let mut g = c.benchmark_group("log");
    g.bench_function("So3", |b| b.iter(|| black_box(&r).log()));
    g.bench_function("Su2", |b| b.iter(|| black_box(&q).log()));
    g.bench_function("nalgebra UnitQuaternion::scaled_axis", |b| {
        b.iter(|| black_box(&uq).scaled_axis());
    });
    g.bench_function("nalgebra Rotation3::scaled_axis", |b| {
        b.iter(|| black_box(&m).scaled_axis());
    });
    g.finish();
}

fn compose(c: &mut Criterion) {
    let (v, w, _) = inputs();
    let (r1, r2) = (So3::exp(&v), So3::exp(&w));
    let (q1, q2) = (Su2::exp(&v), Su2::exp(&w));
    let (u1, u2) = (
        UnitQuaternion::from_scaled_axis(v),
        UnitQuaternion::from_scaled_axis(w),
    );
    let (m1, m2) = (
        Rotation3::from_scaled_axis(v),
        Rotation3::from_scaled_axis(w),
    );
    let mut g = c.benchmark_group("compose");
    g.bench_function("So3", |b| b.iter(|| black_box(&r1).compose(black_box(&r2))));
    g.bench_function("Su2", |b| b.iter(|| black_box(&q1).compose(black_box(&q2))));
    g.bench_function("nalgebra UnitQuaternion *", |b| {
        b.iter(|| black_box(&u1) * black_box(&u2));
    });
    g.bench_function("nalgebra Rotation3 *", |b| {
        b.iter(|| black_box(&m1) * black_box(&m2));
    });
    g.finish();
}

fn act(c: &mut Criterion) {
    let (v, _, p) = inputs();
    let (r, q) = (So3::exp(&v), Su2::exp(&v));
    let (u, m) = (
        UnitQuaternion::from_scaled_axis(v),
        Rotation3::from_scaled_axis(v),
    );
    let mut g = c.benchmark_group("act");
    g.bench_function("So3", |b| b.iter(|| black_box(&r).act(black_box(&p))));
    g.bench_function("Su2", |b| b.iter(|| black_box(&q).act(black_box(&p))));
    g.bench_function("nalgebra UnitQuaternion * Vector3", |b| {
        b.iter(|| black_box(&u) * black_box(&p));
    });
    g.bench_function("nalgebra Rotation3 * Vector3", |b| {
        b.iter(|| black_box(&m) * black_box(&p));
    });
    g.finish();
}

fn jacobians(c: &mut Criterion) {
    let (v, w, p) = inputs();
    let (r1, r2) = (So3::exp(&v), So3::exp(&w));
    let (q1, q2) = (Su2::exp(&v), Su2::exp(&w));
    let mut g = c.benchmark_group("jacobians");
    g.bench_function("So3 right_jacobian", |b| {
        b.iter(|| So3::right_jacobian(black_box(&v)));
    });
    g.bench_function("So3 right_jacobian_inverse", |b| {
        b.iter(|| So3::right_jacobian_inverse(black_box(&v)));
    });
    g.bench_function("So3 j_act_self", |b| {
        b.iter(|| black_box(&r1).j_act_self(black_box(&p)));
    });
    g.bench_function("So3 j_compose_self", |b| {
        b.iter(|| black_box(&r1).j_compose_self(black_box(&r2)));
    });
    g.bench_function("So3 j_local_other", |b| {
        b.iter(|| black_box(&r1).j_local_other(black_box(&r2)));
    });
    g.bench_function("So3 local", |b| {
        b.iter(|| black_box(&r1).local(black_box(&r2)));
    });
    g.bench_function("Su2 right_jacobian", |b| {
        b.iter(|| Su2::right_jacobian(black_box(&v)));
    });
    g.bench_function("Su2 j_act_self", |b| {
        b.iter(|| black_box(&q1).j_act_self(black_box(&p)));
    });
    g.bench_function("Su2 j_local_other", |b| {
        b.iter(|| black_box(&q1).j_local_other(black_box(&q2)));
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = exp, log, compose, act, jacobians
}
criterion_main!(benches);
