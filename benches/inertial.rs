//! The inertial filters' steps: one IMU propagation and one position fix (one-pass and iterated),
//! for the error-state EKF and the two invariant EKFs, from the prior of the default scenario.
//! Every Jacobian is in closed form, derived once in the error-state error and carried into each
//! convention by its first-order error map.
//! `cargo bench --bench inertial`.

use criterion::{Criterion, criterion_group, criterion_main};
use liebayes::densities::ManifoldGaussian;
use liebayes::filters::inertial::{
    ErrorState, ImuStep, InertialConfig, InertialScenario, LeftInvariant, NavigationState,
    PositionFix, RightInvariant, Strapdown,
};
use liebayes::operators::iterated::IteratedEkf;
use liebayes::operators::{Condition, Ekf, Propagate};
use nalgebra::Vector3;
use std::hint::black_box;
use std::time::Duration;

/// The three steps of one state type.
fn steps<S: NavigationState>(c: &mut Criterion, name: &str, scenario: &InertialScenario) {
    let prior: ManifoldGaussian<S, 15> = scenario.prior().expect("a valid prior");
    let process = Strapdown::new(scenario.config().imu).expect("valid noise");
    let fix = PositionFix::new(scenario.config().fix_sigma).expect("a valid sigma");
    let input = ImuStep::new(
        Vector3::new(0.01, -0.02, 0.1),
        Vector3::new(0.3, 0.0, 9.81),
        scenario.config().dt(),
    )
    .expect("a valid sample");
    let z = Vector3::new(0.5, -0.3, 0.2);
    let mut g = c.benchmark_group(format!("inertial, {name}"));
    g.bench_function("IMU propagation", |b| {
        b.iter(|| black_box(&prior).propagate(&Ekf(&process), black_box(&input)));
    });
    g.bench_function("fix, one-pass", |b| {
        b.iter(|| black_box(&prior).condition(&Ekf(&fix), black_box(&z)));
    });
    g.bench_function("fix, iterated", |b| {
        b.iter(|| black_box(&prior).condition(&IteratedEkf::<_, 3>::new(&fix), black_box(&z)));
    });
    g.finish();
}

fn inertial(c: &mut Criterion) {
    let scenario = InertialScenario::new(InertialConfig::default()).expect("valid settings");
    steps::<ErrorState>(c, "error-state", &scenario);
    steps::<LeftInvariant>(c, "left-invariant", &scenario);
    steps::<RightInvariant>(c, "right-invariant", &scenario);
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(Duration::from_secs(2)).warm_up_time(Duration::from_secs(1));
    targets = inertial
}
criterion_main!(benches);
