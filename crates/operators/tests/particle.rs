//! The particle filter: resampling schemes unbiased (and systematic/residual within one copy of N wᵢ),
//! and the log evidence and posterior mean against the exact Kalman filter on a conjugate problem.

use liebayes_densities::Gaussian;
use liebayes_operators::Condition;
use liebayes_operators::kalman::LinearMeasurement;
use liebayes_operators::particle::{ParticleSet, Resampling, resample_indices};
use nalgebra::{Matrix1, Vector1};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

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
            let indices = resample_indices(&weights, n, scheme, &mut rng);
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
            let indices = resample_indices(&weights, n, scheme, &mut rng);
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
    assert!(resample_indices(&[], 5, Resampling::Systematic, &mut rng).is_empty());
    assert!(resample_indices(&[1.0], 0, Resampling::Residual, &mut rng).is_empty());
    let mut set = ParticleSet::from_samples(vec![1.0, 2.0]).unwrap();
    assert!(set.condition(|_| f64::NEG_INFINITY).is_err());
    assert!(set.condition(|_| f64::NAN).is_err());
    // The failed updates left the weights as they were.
    assert_eq!(set.weights(), vec![0.5, 0.5]);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    set.propagate(&mut rng, |x, _| x + 1.0);
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
