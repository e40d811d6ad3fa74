//! Instruction counts of the manifold layer beside nalgebra, and of one EKF and one UKF step of the
//! azimuth baselines, a measurement that does not depend on the load of a shared machine. Each
//! operation sits in its own never-inlined function, called 10⁶ times on varied inputs (the filter
//! steps 10⁵ times, as in `cargo bench --bench azimuth`); callgrind's inclusive count of that function
//! divided by the number of calls is the cost of one call, free of the codegen of the surrounding loop.
//!
//! ```sh
//! cargo build --release --example bench_instructions
//! valgrind --tool=callgrind --callgrind-out-file=callgrind.out target/release/examples/bench_instructions
//! callgrind_annotate --inclusive=yes callgrind.out | grep 'bench_instructions::op_'
//! ```

use liebayes::experiments::RecursiveFilter;
use liebayes::filters::azimuth::{
    AzimuthEkf, AzimuthUkf, PositionMeasurement, VelocityInput, VelocityProcess, ekf, ukf,
};
use liebayes::manifolds::{GroupAction, LieGroup, Se2, Se3, So3};
use nalgebra::{Isometry2, Isometry3, Matrix3, Matrix6, UnitQuaternion, Vector2, Vector3, Vector6};
use std::hint::black_box;

const INPUTS: u32 = 100_000;
const REPEATS: usize = 10;

#[inline(never)]
fn op_exp_ours(v: &Vector3<f64>) -> So3<f64> {
    So3::exp(v)
}

#[inline(never)]
fn op_exp_nalgebra(v: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::from_scaled_axis(*v)
}

#[inline(never)]
fn op_log_ours(r: &So3<f64>) -> Vector3<f64> {
    r.log()
}

#[inline(never)]
fn op_log_nalgebra(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    q.scaled_axis()
}

#[inline(never)]
fn op_compose_ours(a: &So3<f64>, b: &So3<f64>) -> So3<f64> {
    a.compose(b)
}

#[inline(never)]
fn op_compose_nalgebra(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    a * b
}

#[inline(never)]
fn op_act_ours(r: &So3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
    r.act(p)
}

#[inline(never)]
fn op_act_nalgebra(q: &UnitQuaternion<f64>, p: &Vector3<f64>) -> Vector3<f64> {
    q * p
}

/// Steps of the filter benchmarks.
const FILTER_STEPS: usize = 100_000;

/// One predict + update of the azimuth EKF as a study steps it (a stationary platform measured at
/// a fixed point, as in the criterion benchmark).
#[inline(never)]
fn op_ekf_step(filter: &mut AzimuthEkf) {
    filter_step(filter);
}

/// The same for the UKF.
#[inline(never)]
fn op_ukf_step(filter: &mut AzimuthUkf) {
    filter_step(filter);
}

fn filter_step(
    filter: &mut impl RecursiveFilter<Input = VelocityInput, Measurement = Vector2<f64>>,
) {
    let input = VelocityInput {
        velocity: Vector2::zeros(),
        dt: 0.1,
    };
    filter.predict(black_box(&input)).unwrap();
    filter.update(black_box(&Vector2::new(3.0, -4.0))).unwrap();
}

#[inline(never)]
fn op_se3_compose(a: &Se3<f64>, b: &Se3<f64>) -> Se3<f64> {
    a.compose(b)
}

#[inline(never)]
fn op_isometry3_compose(a: &Isometry3<f64>, b: &Isometry3<f64>) -> Isometry3<f64> {
    a * b
}

#[inline(never)]
fn op_se3_exp(v: &Vector6<f64>) -> Se3<f64> {
    Se3::exp(v)
}

#[inline(never)]
fn op_se3_log(x: &Se3<f64>) -> Vector6<f64> {
    x.log()
}

#[inline(never)]
fn op_se3_right_jacobian(v: &Vector6<f64>) -> Matrix6<f64> {
    Se3::right_jacobian(v)
}

#[inline(never)]
fn op_se3_right_jacobian_inverse(v: &Vector6<f64>) -> Matrix6<f64> {
    Se3::right_jacobian_inverse(v)
}

#[inline(never)]
fn op_se2_compose(a: &Se2<f64>, b: &Se2<f64>) -> Se2<f64> {
    a.compose(b)
}

#[inline(never)]
fn op_isometry2_compose(a: &Isometry2<f64>, b: &Isometry2<f64>) -> Isometry2<f64> {
    a * b
}

#[inline(never)]
fn op_se2_exp(v: &Vector3<f64>) -> Se2<f64> {
    Se2::exp(v)
}

#[inline(never)]
fn op_se2_log(x: &Se2<f64>) -> Vector3<f64> {
    x.log()
}

#[inline(never)]
fn op_se2_right_jacobian(v: &Vector3<f64>) -> Matrix3<f64> {
    Se2::right_jacobian(v)
}

/// The poses on tangents built from the rotation inputs: SE(3) `[ρ; φ]` with ρ = (1, −2, 0.5) + φ,
/// SE(2) `[ρ_x, ρ_y, θ]` with θ = ±|φ|.
fn poses(v: &[Vector3<f64>]) {
    let t3: Vec<_> = v
        .iter()
        .map(|p| Vector6::new(1.0 + p.x, p.y - 2.0, 0.5 + p.z, p.x, p.y, p.z))
        .collect();
    let t2: Vec<_> = v
        .iter()
        .map(|p| Vector3::new(1.0 + p.y, p.z - 2.0, p.norm().copysign(p.x)))
        .collect();
    let se3: Vec<_> = t3.iter().map(Se3::exp).collect();
    let iso3: Vec<Isometry3<f64>> = se3.iter().map(|x| (*x).into()).collect();
    let se2: Vec<_> = t2.iter().map(Se2::exp).collect();
    let iso2: Vec<Isometry2<f64>> = se2.iter().map(|x| (*x).into()).collect();
    for _ in 0..REPEATS {
        for i in 0..v.len() {
            let j = (i + 1) % v.len();
            black_box(op_se3_compose(black_box(&se3[i]), black_box(&se3[j])));
            black_box(op_isometry3_compose(
                black_box(&iso3[i]),
                black_box(&iso3[j]),
            ));
            black_box(op_se3_exp(black_box(&t3[i])));
            black_box(op_se3_log(black_box(&se3[i])));
            black_box(op_se3_right_jacobian(black_box(&t3[i])));
            black_box(op_se3_right_jacobian_inverse(black_box(&t3[i])));
            black_box(op_se2_compose(black_box(&se2[i]), black_box(&se2[j])));
            black_box(op_isometry2_compose(
                black_box(&iso2[i]),
                black_box(&iso2[j]),
            ));
            black_box(op_se2_exp(black_box(&t2[i])));
            black_box(op_se2_log(black_box(&se2[i])));
            black_box(op_se2_right_jacobian(black_box(&t2[i])));
        }
    }
}

fn main() {
    let v: Vec<_> = (0..INPUTS)
        .map(|i| {
            let t = f64::from(i) * 0.001;
            let angle = 3.0 * f64::from((i * 7919) % 1000) / 1000.0;
            Vector3::new(t.sin(), (1.3 * t).cos(), 0.5).normalize() * angle
        })
        .collect();
    let ours: Vec<_> = v.iter().map(So3::exp).collect();
    let theirs: Vec<_> = v
        .iter()
        .map(|x| UnitQuaternion::from_scaled_axis(*x))
        .collect();
    for _ in 0..REPEATS {
        for i in 0..v.len() {
            let j = (i + 1) % v.len();
            black_box(op_exp_ours(black_box(&v[i])));
            black_box(op_exp_nalgebra(black_box(&v[i])));
            black_box(op_log_ours(black_box(&ours[i])));
            black_box(op_log_nalgebra(black_box(&theirs[i])));
            black_box(op_compose_ours(black_box(&ours[i]), black_box(&ours[j])));
            black_box(op_compose_nalgebra(
                black_box(&theirs[i]),
                black_box(&theirs[j]),
            ));
            black_box(op_act_ours(black_box(&ours[i]), black_box(&v[j])));
            black_box(op_act_nalgebra(black_box(&theirs[i]), black_box(&v[j])));
        }
    }
    let process = VelocityProcess::new(0.1).unwrap();
    let measurement = PositionMeasurement::new(1.0).unwrap();
    let mut ekf = ekf(process, measurement, Vector2::zeros(), 1.0).unwrap();
    let mut ukf = ukf(process, measurement, Vector2::zeros(), 1.0).unwrap();
    for _ in 0..FILTER_STEPS {
        op_ekf_step(&mut ekf);
        op_ukf_step(&mut ukf);
    }
    poses(&v);
    println!(
        "{} calls of each manifold operation, {FILTER_STEPS} filter steps",
        v.len() * REPEATS
    );
}
