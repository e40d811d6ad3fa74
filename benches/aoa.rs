//! Cost of the angle-of-arrival filters with the square track's four anchors: the particle filter's
//! particle-updates per second (the von Mises-Fisher reweighting of Algorithm 1, serial and in
//! parallel with rayon, and a whole step with the sampled random walk), the azimuth-elevation
//! likelihood beside it, and the EKF and UKF per update with each model and the iterated EKF with
//! the von Mises-Fisher model, all in one run; and the maximum-likelihood fit of the
//! azimuth-elevation model's σ.
//! `cargo bench --bench aoa`; figures in docs/benchmarks.md.
#![allow(missing_docs)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use liebayes::experiments::RecursiveFilter;
use liebayes::filters::aoa::{
    AngleNoise, AzEl, AzElModel, CheckedReadings, DataModel, Prior, RandomWalk, UnitVectorModel,
    angle_ekf, angle_ukf, fit_angle_sigmas_to, square_track_anchors, vmf_ekf, vmf_iterated_ekf,
    vmf_particle_filter, vmf_ukf,
};
use liebayes::operators::Condition;
use liebayes::operators::Converted;
use liebayes::operators::particle::{Reweight, ReweightInParallel};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;
use std::hint::black_box;
use std::time::Duration;

const SIGMA: f64 = 0.174_532_925_199_432_95;

/// The readings of the square track's anchors of the point (1, 0.2, 0.05), as Model I would give
/// them without noise. Not of a point at z = 0: the Kalman filters, given the same readings at
/// every step, converged onto it, the EKF's mean to z = 4e-323, and every step on that subnormal
/// took microcode assists (8.3 µs where a step takes 2.9).
fn setup() -> (
    UnitVectorModel<4>,
    AzElModel<4>,
    RandomWalk,
    Prior,
    [AzEl; 4],
) {
    let anchors = square_track_anchors();
    let theta = Vector3::new(1.0, 0.2, 0.05);
    let readings = anchors.map(|a| AzEl::of_vector(&a.direction(&theta).unwrap().0).unwrap());
    (
        UnitVectorModel::new(anchors, 1.0 / (SIGMA * SIGMA)).unwrap(),
        AzElModel::new(
            anchors,
            AngleNoise::Fixed {
                sigma_az: SIGMA,
                sigma_el: SIGMA,
            },
        )
        .unwrap(),
        RandomWalk::new(0.5, 0.1).unwrap(),
        Prior::new(Vector3::new(1.1, 0.1, 0.2), 0.5).unwrap(),
        readings,
    )
}

fn particle_updates(c: &mut Criterion) {
    let (vmf, ae, walk, prior, readings) = setup();
    for n in [10_000_usize, 1_000_000] {
        let mut g = c.benchmark_group(format!("aoa particle filter, {n} particles"));
        g.throughput(Throughput::Elements(n as u64));
        if n > 100_000 {
            g.sample_size(10).measurement_time(Duration::from_secs(8));
        }
        let filter =
            vmf_particle_filter(vmf, walk, &prior, n, ChaCha8Rng::seed_from_u64(1)).unwrap();
        let mut set = filter.density().clone();
        let serial = Converted {
            model: Reweight(vmf),
            conversion: vmf.in_world_axes(),
        };
        let parallel = Converted {
            model: ReweightInParallel(vmf),
            conversion: vmf.in_world_axes(),
        };
        g.bench_function("VMF reweight, serial", |b| {
            b.iter(|| {
                set.condition_in_place(&serial, black_box(&readings))
                    .unwrap()
            });
        });
        g.bench_function("VMF reweight, parallel (rayon)", |b| {
            b.iter(|| {
                set.condition_in_place(&parallel, black_box(&readings))
                    .unwrap()
            });
        });
        let angles = Converted {
            model: Reweight(ae.clone()),
            conversion: CheckedReadings,
        };
        g.bench_function("AE reweight, serial", |b| {
            b.iter(|| {
                set.condition_in_place(&angles, black_box(&readings))
                    .unwrap()
            });
        });
        let mut pf = filter.clone();
        g.bench_function("VMF predict + update (PF-VMF step), serial", |b| {
            b.iter(|| {
                pf.predict(black_box(&0.25)).unwrap();
                pf.update(black_box(&readings)).unwrap();
            });
        });
        g.finish();
    }
}

fn kalman_updates(c: &mut Criterion) {
    let (vmf, ae, walk, prior, readings) = setup();
    let mut g = c.benchmark_group("aoa Kalman filters, predict + update");
    let ekf = vmf_ekf::<4, 12>(vmf, walk, &prior).unwrap();
    let ukf = vmf_ukf::<4, 12>(vmf, walk, &prior).unwrap();
    let iterated = vmf_iterated_ekf::<4, 12>(vmf, walk, &prior).unwrap();
    let ekf_ae = angle_ekf::<4, 8>(ae.clone(), walk, &prior).unwrap();
    let ukf_ae = angle_ukf::<4, 8>(ae, walk, &prior).unwrap();
    macro_rules! step {
        ($name:expr, $filter:expr) => {
            g.bench_function($name, |b| {
                let mut f = $filter.clone();
                b.iter(|| {
                    f.predict(black_box(&0.25)).unwrap();
                    f.update(black_box(&readings)).unwrap();
                });
            });
        };
    }
    step!("EKF-VMF", ekf);
    step!("UKF-VMF", ukf);
    step!("IEKF-VMF", iterated);
    step!("EKF-AE", ekf_ae);
    step!("UKF-AE", ukf_ae);
    g.finish();
}

/// The maximum-likelihood fit of the azimuth-elevation model's σ to 10⁵ Model I readings (the
/// paper's sample size) at directions uniform on the sphere.
fn sigma_fit(c: &mut Criterion) {
    let data = DataModel::NormalWithFlip {
        sigma_az: SIGMA,
        sigma_el: SIGMA,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let pairs: Vec<(AzEl, AzEl)> = (0..100_000)
        .map(|_| {
            // Uniform on the sphere: z uniform on [−1, 1], the longitude uniform.
            let (z, phi) = (rng.random_range(-1.0..1.0_f64), rng.random_range(-PI..PI));
            let rho = (1.0 - z * z).sqrt();
            let truth = Vector3::new(rho * phi.cos(), rho * phi.sin(), z);
            let reading = data.sample(&truth, &mut rng).unwrap();
            (reading, AzEl::of_vector(&truth).unwrap())
        })
        .collect();
    let mut g = c.benchmark_group("aoa sigma fit");
    g.sample_size(10);
    g.bench_function("AE-fitted sigmas, 1e5 readings", |b| {
        b.iter(|| fit_angle_sigmas_to(black_box(&pairs)).unwrap());
    });
    g.finish();
}

criterion_group!(benches, particle_updates, kalman_updates, sigma_fit);
criterion_main!(benches);
