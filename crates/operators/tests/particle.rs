//! The particle filter: resampling schemes unbiased (and systematic/residual within one copy of N wᵢ),
//! the log evidence and posterior mean against the exact Kalman filter on a conjugate problem, sets
//! from weighted samples, and the weighted mean on a manifold.

use liebayes_densities::Gaussian;
use liebayes_manifolds::{LieGroup, Manifold, Rn, So2, So3};
use liebayes_operators::kalman::LinearMeasurement;
use liebayes_operators::particle::{ParticleSet, Resampling, resample_indices};
use liebayes_operators::{Condition, OperatorError};
use nalgebra::{Matrix1, Vector1, Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

const SCHEMES: [Resampling; 4] = [
    Resampling::Multinomial,
    Resampling::Stratified,
    Resampling::Systematic,
    Resampling::Residual,
];

/// Mean copies over 4000 repetitions within 5 standard errors of N wᵢ (the per-repetition variance of a
/// count is at most N wᵢ (1 − wᵢ), the multinomial one).
#[test]
fn every_scheme_is_unbiased() {
    let weights = [0.05, 0.3, 0.001, 0.149, 0.5];
    let n = 20;
    let repetitions = 4000;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for scheme in SCHEMES {
        let mut counts = [0usize; 5];
        for _ in 0..repetitions {
            let indices = resample_indices(&weights, n, scheme, &mut rng).unwrap();
            assert_eq!(indices.len(), n, "{scheme:?}");
            for i in indices {
                counts[i] += 1;
            }
        }
        for (i, w) in weights.iter().enumerate() {
            let mean = counts[i] as f64 / f64::from(repetitions);
            let expected = n as f64 * w;
            let standard_error = (n as f64 * w * (1.0 - w) / f64::from(repetitions)).sqrt();
            assert!(
                (mean - expected).abs() <= 5.0 * standard_error + 1e-12,
                "{scheme:?}, particle {i}: {mean} copies vs {expected}"
            );
        }
    }
}

#[test]
fn systematic_and_residual_keep_the_floor_of_n_w() {
    let weights = [0.05, 0.3, 0.001, 0.149, 0.5];
    let n = 20;
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for scheme in [Resampling::Systematic, Resampling::Residual] {
        for _ in 0..200 {
            let indices = resample_indices(&weights, n, scheme, &mut rng).unwrap();
            for (i, w) in weights.iter().enumerate() {
                let copies = indices.iter().filter(|&&j| j == i).count() as f64;
                assert!(copies >= (n as f64 * w).floor(), "{scheme:?} {i}");
                if scheme == Resampling::Systematic {
                    assert!(copies <= (n as f64 * w).ceil(), "{scheme:?} {i}");
                }
            }
        }
    }
}

/// x ~ N(1, 4), z = x + N(0, 1), z = 3: the exact posterior is N(2.6, 0.8) and ln p(z) = ln N(3; 1, 5).
/// 20 000 prior particles estimate both within Monte Carlo error.
#[test]
fn reweighting_matches_the_kalman_filter() {
    let prior = Gaussian::new(Vector1::new(1.0), Matrix1::new(4.0)).unwrap();
    let model = LinearMeasurement::new(Matrix1::new(1.0), Matrix1::new(1.0)).unwrap();
    let exact = prior.condition(&model, &Vector1::new(3.0)).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let samples: Vec<f64> = (0..20_000)
        .map(|_| {
            let e: f64 = StandardNormal.sample(&mut rng);
            1.0 + 2.0 * e
        })
        .collect();
    let mut set = ParticleSet::from_samples(samples).unwrap();
    let log_evidence = set.condition(|x| -0.5 * (3.0 - x) * (3.0 - x)).unwrap()
        - 0.5 * (2.0 * std::f64::consts::PI).ln();
    assert!(
        (log_evidence - exact.log_evidence).abs() < 0.02,
        "{log_evidence} vs {}",
        exact.log_evidence
    );
    let mean = set.expectation(|x| *x);
    assert!((mean - exact.posterior.mean()[0]).abs() < 0.03, "{mean}");
    let ess = set.effective_sample_size();
    assert!(ess > 5000.0 && ess < 20_000.0, "{ess}");
    for scheme in SCHEMES {
        let mut copy = set.clone();
        assert!(copy.resample_if_degenerate(0.9, scheme, &mut rng));
        assert!((copy.effective_sample_size() - 20_000.0).abs() < 1e-6);
        let resampled_mean = copy.expectation(|x| *x);
        assert!(
            (resampled_mean - mean).abs() < 0.05,
            "{scheme:?}: {resampled_mean}"
        );
    }
}

#[test]
fn impossible_measurements_and_empty_sets_are_errors() {
    assert!(ParticleSet::<f64>::from_samples(vec![]).is_err());
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    assert!(resample_indices(&[], 5, Resampling::Systematic, &mut rng).is_err());
    assert!(
        resample_indices(&[1.0], 0, Resampling::Residual, &mut rng)
            .unwrap()
            .is_empty()
    );
    let mut set = ParticleSet::from_samples(vec![1.0, 2.0]).unwrap();
    assert!(set.condition(|_| f64::NEG_INFINITY).is_err());
    assert!(set.condition(|_| f64::NAN).is_err());
    // The failed updates left the weights as they were.
    assert_eq!(set.weights(), vec![0.5, 0.5]);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut points =
        ParticleSet::from_samples(vec![Rn::new_unchecked(Vector1::new(1.0)); 2]).unwrap();
    points
        .propagate(&mut rng, |x, _| x.retract(&Vector1::new(1.0)))
        .unwrap();
    assert_eq!(points.particles()[1].coords()[0], 2.0);
    set.try_propagate(|x| Ok(x + 1.0)).unwrap();
    assert_eq!(set.particles(), &[2.0, 3.0]);
}

/// The parallel weighting (feature `rayon`) gives the same weights and log evidence as the serial one.
#[cfg(feature = "rayon")]
#[test]
fn parallel_weighting_equals_serial() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let samples: Vec<f64> = (0..5000)
        .map(|_| rand::Rng::random::<f64>(&mut rng) * 10.0)
        .collect();
    let mut serial = ParticleSet::from_samples(samples.clone()).unwrap();
    let mut parallel = ParticleSet::from_samples(samples).unwrap();
    let likelihood = |x: &f64| -0.5 * (x - 3.0) * (x - 3.0);
    let a = serial.condition(likelihood).unwrap();
    let b = parallel.condition_parallel(likelihood).unwrap();
    assert_eq!(a, b);
    assert_eq!(serial.log_weights(), parallel.log_weights());
    assert!(parallel.condition_parallel(|_| f64::NAN).is_err());
}

/// A failed step leaves the set exactly as it was: weights and particles.
#[test]
fn failed_steps_leave_the_set_unchanged() {
    let mut set = ParticleSet::from_samples(vec![1.0, 2.0, 3.0]).unwrap();
    set.condition(|x| -x).unwrap();
    let (weights, particles) = (set.log_weights().to_vec(), set.particles().to_vec());
    let fail_at_two = |x: &f64| {
        if *x == 2.0 {
            Err(liebayes_operators::OperatorError::NonFinite {
                what: "test",
                value: f64::NAN,
            })
        } else {
            Ok((x + 10.0, 0.0))
        }
    };
    assert!(set.condition_with(fail_at_two).is_err());
    assert!(
        set.try_propagate(|x| fail_at_two(x).map(|(y, _)| y))
            .is_err()
    );
    assert!(
        set.condition(|x| if *x == 3.0 { f64::NAN } else { 0.0 })
            .is_err()
    );
    assert_eq!(set.log_weights(), &weights[..]);
    assert_eq!(set.particles(), &particles[..]);
    // And a successful one replaces both.
    set.condition_with(|x| Ok((x + 10.0, 0.0))).unwrap();
    assert_eq!(set.particles(), &[11.0, 12.0, 13.0]);
}

/// Weighted samples: linear and log weights give the set that reweighting equal samples gives, and
/// log weights far below the smallest f64 keep their ratios.
#[test]
fn weighted_samples_equal_reweighted_samples() {
    let particles: Vec<usize> = vec![0, 1, 2, 3];
    let weights = [0.5, 2.0, 0.0, 1.5];
    let from_linear = ParticleSet::from_weighted_samples(particles.clone(), &weights).unwrap();
    let mut reweighted = ParticleSet::from_samples(particles.clone()).unwrap();
    reweighted.condition(|x| weights[*x].ln()).unwrap();
    for (a, b) in from_linear
        .log_weights()
        .iter()
        .zip(reweighted.log_weights())
    {
        assert!(a == b || (a - b).abs() < 1e-15, "{a} vs {b}");
    }
    for (w, expected) in from_linear.weights().iter().zip([0.125, 0.5, 0.0, 0.375]) {
        assert!((w - expected).abs() < 1e-15, "{w} vs {expected}");
    }
    // Log weights with a huge offset and one of e^(−2000) relative: normalised in the log domain.
    let logs = [
        -5000.0,
        -5000.0 - 2000.0,
        f64::NEG_INFINITY,
        -5000.0 + 2.0_f64.ln(),
    ];
    let from_logs = ParticleSet::from_log_weighted_samples(particles, &logs).unwrap();
    let l = from_logs.log_weights();
    assert!((l[0] - (1.0_f64 / 3.0).ln()).abs() < 1e-12);
    assert!((l[1] - l[0] + 2000.0).abs() < 1e-9);
    assert_eq!(l[2], f64::NEG_INFINITY);
}

#[test]
fn bad_weights_are_refused_with_a_reason() {
    let two = || vec![1.0, 2.0];
    let message = |r: Result<ParticleSet<f64>, OperatorError>| r.unwrap_err().to_string();
    assert!(
        message(ParticleSet::from_weighted_samples(two(), &[1.0])).contains("number of weights")
    );
    assert!(
        message(ParticleSet::from_weighted_samples(two(), &[1.0, -0.5])).contains("[0, infinity)")
    );
    assert!(
        message(ParticleSet::from_weighted_samples(two(), &[1.0, f64::NAN])).contains("finite")
    );
    assert!(ParticleSet::from_weighted_samples(two(), &[1.0, f64::INFINITY]).is_err());
    assert!(message(ParticleSet::from_weighted_samples(two(), &[0.0, 0.0])).contains("zero"));
    assert!(ParticleSet::from_weighted_samples(Vec::<f64>::new(), &[]).is_err());
    assert!(ParticleSet::from_log_weighted_samples(two(), &[0.0, f64::NAN]).is_err());
    assert!(ParticleSet::from_log_weighted_samples(two(), &[0.0, f64::INFINITY]).is_err());
    let all_zero = [f64::NEG_INFINITY, f64::NEG_INFINITY];
    assert!(ParticleSet::from_log_weighted_samples(two(), &all_zero).is_err());
    assert!(ParticleSet::from_log_weighted_samples(two(), &[0.0, 0.0, 0.0]).is_err());
}

/// The weighted mean on the manifold: across the ±π cut on SO(2) (where an average of angles would
/// give 0), exactly the weighted average on Rⁿ, and the centre of a symmetric set on SO(3).
#[test]
fn the_mean_is_taken_on_the_manifold() {
    let angles = [PI - 0.1, -PI + 0.3, PI - 0.2];
    let set = ParticleSet::from_weighted_samples(
        angles
            .iter()
            .map(|a| So2::from_angle_unchecked(*a))
            .collect(),
        &[0.5, 0.25, 0.25],
    )
    .unwrap();
    // Unwrapped: 0.5 (π − 0.1) + 0.25 (π + 0.3) + 0.25 (π − 0.2) = π − 0.025.
    assert!(
        set.mean()
            .unwrap()
            .distance(&So2::from_angle_unchecked(PI - 0.025))
            < 1e-12
    );
    let points = [
        Vector2::new(1.0, 2.0),
        Vector2::new(-3.0, 0.5),
        Vector2::new(10.0, 1e3),
    ];
    let weights = [0.2, 0.7, 0.1];
    let set = ParticleSet::from_weighted_samples(
        points.iter().map(|p| Rn::new_unchecked(*p)).collect(),
        &weights,
    )
    .unwrap();
    let expected: Vector2<f64> = points.iter().zip(weights).map(|(p, w)| p * w).sum();
    assert!((set.mean().unwrap().coords() - expected).amax() < 1e-12 * expected.amax());
    let centre = So3::exp(&Vector3::new(0.3, -2.0, 1.0));
    let offsets = [Vector3::new(0.4, 0.1, -0.2), Vector3::new(-0.1, 0.3, 0.5)];
    let set = ParticleSet::from_samples(
        offsets
            .iter()
            .flat_map(|v| [centre.retract(v), centre.retract(&-v)])
            .collect(),
    )
    .unwrap();
    assert!(set.mean().unwrap().distance(&centre) < 1e-12);
}
