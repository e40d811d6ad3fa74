//! Long runs of the generic filters: the EKF and the UKF on SO(3), a particle filter and a grid
//! filter on the circle, each stepped many times over readings that wander through their whole
//! valid range (fast turns, long quiet stretches, readings far from the prediction). After every
//! step, whether it succeeded or was refused, the state must be valid: a finite mean on its
//! manifold and a symmetric positive definite covariance for the Gaussians; finite particles on the
//! circle and log weights that normalise, with an effective sample size in [1, N], for the particle
//! set; normalised log weights for the grid. A refused step must leave the state as it was.
//!
//! The test suite runs 20 000 steps of each (a few seconds); the long version, run by hand:
//!
//! ```sh
//! LIEBAYES_LONG_RUN_STEPS=100000000 cargo test --release -p liebayes-operators \
//!   --test long_run -- --ignored --nocapture
//! ```

use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::{GroupAction, LieGroup, Manifold, So2, So3};
use liebayes_operators::grid::{CircularGrid, Diffusion};
use liebayes_operators::particle::{
    LikelihoodFn, ParticleSet, Resampling, Reweight, SampleFn, Sampled,
};
use liebayes_operators::{Condition, Ekf, MeasurementFn, ProcessFn, Propagate, Ukf};
use nalgebra::{Matrix3, SMatrix, SVector, Vector1, Vector3};
use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Steps of the test-sized runs.
const TEST_STEPS: u64 = 20_000;

/// The long runs' steps: `LIEBAYES_LONG_RUN_STEPS`, 10⁸ by default.
fn long_steps() -> u64 {
    std::env::var("LIEBAYES_LONG_RUN_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000_000)
}

/// A normal draw.
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    rng.sample(StandardNormal)
}

/// A Gaussian's state is valid: a finite mean, a finite symmetric covariance with a Cholesky
/// factor.
fn valid_gaussian<X: Manifold<D, Scalar = f64>, const D: usize>(
    g: &ManifoldGaussian<X, D>,
) -> bool {
    let p = g.covariance();
    g.mean().is_finite()
        && p.iter().all(|v| v.is_finite())
        && (p - p.transpose()).amax() <= 1e-12 * p.amax()
        && p.cholesky().is_some()
}

/// Which Kalman filter a run steps.
#[derive(Clone, Copy, Debug)]
enum Kalman {
    Extended,
    Unscented,
}

/// `[Rᵀ g; Rᵀ m]`: gravity and a magnetic field seen in the body frame.
fn directions(x: &So3<f64>) -> SVector<f64, 6> {
    let g = x.inverse().act(&Vector3::new(0.0, 0.0, 1.0));
    let m = x.inverse().act(&Vector3::new(0.6, 0.0, 0.8));
    SVector::<f64, 6>::from_iterator(g.iter().chain(m.iter()).copied())
}

/// The EKF or UKF on SO(3) over `steps` steps: the truth turns by a rate that changes every 1000
/// steps (from still to 30 rad/s at 100 Hz, through the turn of π per step), the filter knows the
/// turn with noise, and the two directions are read with noise, every 7th reading replaced by one
/// from an unrelated orientation (far from the prediction) and every 11th missing.
fn kalman_run(kalman: Kalman, steps: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut truth = So3::<f64>::identity();
    let mut density =
        ManifoldGaussian::new(So3::identity(), Matrix3::identity() * 0.1).expect("a prior");
    let sigma = 0.02;
    let measurement = MeasurementFn::new(directions, move |_| {
        SMatrix::<f64, 6, 6>::identity() * (sigma * sigma)
    });
    let mut rate = Vector3::zeros();
    let (mut done, mut refused) = (0_u64, 0_u64);
    for k in 0..steps {
        if k % 1000 == 0 {
            let speed = [0.0, 0.01, 1.0, 30.0, 31.4][usize::try_from(k / 1000 % 5).unwrap_or(0)];
            rate = Vector3::new(normal(&mut rng), normal(&mut rng), normal(&mut rng)).normalize()
                * speed
                * 0.01;
        }
        let turn = So3::exp(&rate);
        truth = truth.compose(&turn).compose(&So3::exp(
            &(Vector3::new(normal(&mut rng), normal(&mut rng), normal(&mut rng)) * 1e-3),
        ));
        let known = turn;
        let process = ProcessFn::new(
            move |x: &So3<f64>, (): &()| x.compose(&known),
            |_, ()| Matrix3::identity() * 1e-6,
        );
        let before = density.clone();
        let predicted = match kalman {
            Kalman::Extended => density.propagate(&Ekf(process), &()),
            Kalman::Unscented => density.propagate(&Ukf::new(process), &()),
        };
        let Ok(predicted) = predicted else {
            refused += 1;
            assert_eq!(density, before, "a refused prediction changed the state");
            continue;
        };
        assert!(
            valid_gaussian(&predicted),
            "step {k}: predicted {predicted:?}"
        );
        density = predicted;
        if k % 11 == 0 {
            continue;
        }
        let seen = if k % 7 == 0 {
            So3::exp(&Vector3::new(
                normal(&mut rng),
                normal(&mut rng),
                normal(&mut rng),
            ))
        } else {
            truth
        };
        let z = directions(&seen) + SVector::<f64, 6>::from_fn(|_, _| sigma * normal(&mut rng));
        let step = match kalman {
            Kalman::Extended => density.condition(&Ekf(&measurement), &z),
            Kalman::Unscented => density.condition(&Ukf::new(&measurement), &z),
        };
        match step {
            Ok(step) => {
                assert!(step.log_evidence.is_finite(), "step {k}: log evidence");
                assert!(
                    valid_gaussian(&step.posterior),
                    "step {k}: {:?}",
                    step.posterior
                );
                density = step.posterior;
                done += 1;
            }
            Err(_) => refused += 1,
        }
    }
    eprintln!("{kalman:?} on SO(3): {steps} steps, {done} updates, {refused} refused");
    assert!(done > steps / 2, "{done} updates of {steps} steps");
}

/// A bootstrap particle filter of 200 particles on the circle over `steps` steps: a heading that
/// turns at a rate changing every 1000 steps, read as a bearing with 0.1 rad noise (every 9th
/// reading wild), resampled (systematic, then the other schemes in turn) when the effective sample
/// size falls below N/2.
fn particle_run(steps: u64) {
    const N: usize = 200;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut truth = So2::<f64>::identity();
    let mut set = ParticleSet::from_samples(
        (0..N)
            .map(|_| So2::from_angle_unchecked(std::f64::consts::PI * normal(&mut rng)))
            .collect(),
    )
    .expect("particles");
    let schemes = [
        Resampling::Systematic,
        Resampling::Multinomial,
        Resampling::Stratified,
        Resampling::Residual,
    ];
    let mut rate = 0.0;
    let (mut resampled, mut refused) = (0_u64, 0_u64);
    for k in 0..steps {
        if k % 1000 == 0 {
            rate = [0.0, 0.001, 0.1, 1.0, 3.1][usize::try_from(k / 1000 % 5).unwrap_or(0)];
        }
        truth = truth.retract(&Vector1::new(rate + 0.01 * normal(&mut rng)));
        let walk = SampleFn::new(move |x: &So2<f64>, (): &(), r: &mut dyn RngCore| {
            let e: f64 = r.sample(StandardNormal);
            Ok(x.retract(&Vector1::new(rate + 0.02 * e)))
        });
        let before = (set.particles().to_vec(), set.log_weights().to_vec());
        let sampler = Sampled::new(&walk, ChaCha8Rng::seed_from_u64(k));
        if set.propagate_in_place(&sampler, &()).is_err() {
            refused += 1;
            assert_eq!(
                (set.particles(), set.log_weights()),
                (&before.0[..], &before.1[..])
            );
        }
        let bearing = if k % 9 == 0 {
            std::f64::consts::PI * normal(&mut rng)
        } else {
            truth.angle() + 0.1 * normal(&mut rng)
        };
        let likelihood = Reweight(LikelihoodFn::new(move |x: &So2<f64>, (): &()| {
            ((x.angle() - bearing).cos() - 1.0) / 0.01
        }));
        let before = (set.particles().to_vec(), set.log_weights().to_vec());
        if set.condition_in_place(&likelihood, &()).is_err() {
            refused += 1;
            assert_eq!(
                (set.particles(), set.log_weights()),
                (&before.0[..], &before.1[..])
            );
        }
        let total: f64 = set.log_weights().iter().map(|l| l.exp()).sum();
        let ess = set.effective_sample_size();
        assert!(
            set.particles().iter().all(Manifold::is_finite)
                && (total - 1.0).abs() <= 1e-9
                && (1.0 - 1e-9..=N as f64 + 1e-9).contains(&ess),
            "step {k}: weights sum to {total}, ESS {ess}"
        );
        if ess < N as f64 / 2.0 {
            set.resample(
                schemes[usize::try_from(resampled % 4).unwrap_or(0)],
                &mut rng,
            );
            resampled += 1;
        }
        assert!(set.mean().is_ok_and(|m| m.is_finite()), "step {k}: mean");
    }
    eprintln!("particles on SO(2): {steps} steps, {resampled} resamplings, {refused} refused");
}

/// A grid filter of 64 cells on the circle over `steps` steps: a wrapped-normal diffusion whose
/// width changes every 1000 steps (from 1e-3 rad to 3 rad), a bearing reading with 0.1 rad noise
/// (every 9th wild, every 13th so sharp that it is 1e-300 wide in likelihood).
fn grid_run(steps: u64) {
    const CELLS: usize = 64;
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let mut grid = CircularGrid::uniform(CELLS, ()).expect("a grid");
    let mut truth = So2::<f64>::identity();
    let mut refused = 0_u64;
    for k in 0..steps {
        let width: f64 = [1e-3, 0.05, 0.3, 1.0, 3.0][usize::try_from(k / 1000 % 5).unwrap_or(0)];
        truth = truth.retract(&Vector1::new(width * normal(&mut rng)));
        let diffusion = Diffusion(move |w: &So2<f64>| (-0.5 * (w.angle() / width).powi(2)).exp());
        let before = grid.log_weights().to_vec();
        if grid.propagate_in_place(&diffusion, &()).is_err() {
            refused += 1;
            assert_eq!(grid.log_weights(), &before[..]);
        }
        let bearing = if k % 9 == 0 {
            std::f64::consts::PI * normal(&mut rng)
        } else {
            truth.angle() + 0.1 * normal(&mut rng)
        };
        let scale = if k % 13 == 0 { 1e300 } else { 100.0 };
        let likelihood = Reweight(LikelihoodFn::new(move |t: &So2<f64>, (): &()| {
            ((t.angle() - bearing).cos() - 1.0) * scale
        }));
        let before = grid.log_weights().to_vec();
        if grid.condition_in_place(&likelihood, &()).is_err() {
            refused += 1;
            assert_eq!(grid.log_weights(), &before[..]);
        }
        let total: f64 = grid.log_weights().iter().map(|l| l.exp()).sum();
        assert!(
            grid.log_weights().iter().all(|l| !l.is_nan() && *l <= 0.0)
                && (total - 1.0).abs() <= 1e-9,
            "step {k}: weights sum to {total}"
        );
        assert!(grid.first_moment().iter().all(|m| m.is_finite()));
    }
    eprintln!("grid on SO(2): {steps} steps, {refused} refused");
}

#[test]
fn the_ekf_stays_valid() {
    kalman_run(Kalman::Extended, TEST_STEPS);
}

#[test]
fn the_ukf_stays_valid() {
    kalman_run(Kalman::Unscented, TEST_STEPS);
}

#[test]
fn the_particle_filter_stays_valid() {
    particle_run(TEST_STEPS);
}

#[test]
fn the_grid_filter_stays_valid() {
    grid_run(TEST_STEPS);
}

#[test]
#[ignore = "the long run, by hand: LIEBAYES_LONG_RUN_STEPS=100000000"]
fn long_runs() {
    let steps = long_steps();
    kalman_run(Kalman::Extended, steps);
    kalman_run(Kalman::Unscented, steps);
    particle_run(steps);
    grid_run(steps);
}
