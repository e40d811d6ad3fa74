//! The particle filter: resampling schemes unbiased (and systematic/residual within one copy of N wᵢ),
//! the log evidence and posterior mean against the exact Kalman filter on a conjugate problem and
//! over a run of a bootstrap filter, propagation with resampling all or nothing, sets from weighted
//! samples, and the weighted mean on a manifold.

use liebayes_densities::Gaussian;
use liebayes_manifolds::{LieGroup, Manifold, Rn, So2, So3};
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::particle::{
    LikelihoodFn, ParticleSet, Resampling, Reweight, SampleFn, Sampled, finite_point,
    resample_indices,
};
use liebayes_operators::{Condition, OperatorError, Propagate};
use nalgebra::{Matrix1, Vector1, Vector2, Vector3};
use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::cell::Cell;
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

/// The variance of the number of draws in each group of particles (`groups` are the boundaries
/// between them, 0 first, the particle count last) that `scheme`'s construction gives, computed
/// from the weights (which must sum to 1) with cumulative weights `Cⱼ`:
/// * multinomial: N W (1 − W), W the group's weight;
/// * stratified: the draws below C are ⌊N C⌋ plus one with probability f = N C − ⌊N C⌋,
///   independently from stratum to stratum, so a group [a, b) in different strata has
///   f_a(1 − f_a) + f_b(1 − f_b), and within one stratum p(1 − p) with p = f_b − f_a;
/// * systematic: the count ⌈N C_b − u⌉ − ⌈N C_a − u⌉ averaged over a grid of 10⁵ offsets u;
/// * residual: ⌊N wᵢ⌋ each plus a multinomial count of R = N − Σ⌊N wⱼ⌋ draws from the residuals
///   rᵢ = N wᵢ − ⌊N wᵢ⌋: R r̃ (1 − r̃), r̃ the group's share of the residuals.
fn group_variances(weights: &[f64], n: usize, groups: &[usize], scheme: Resampling) -> Vec<f64> {
    let nf = n as f64;
    let scaled: Vec<f64> = weights.iter().map(|w| nf * w).collect();
    let below = |j: usize| scaled[..j].iter().sum::<f64>();
    let bernoulli = |f: f64| f * (1.0 - f);
    let residuals: Vec<f64> = scaled.iter().map(|x| x - x.floor()).collect();
    let rest: f64 = residuals.iter().sum();
    groups
        .windows(2)
        .map(|g| {
            let (a, b) = (below(g[0]), below(g[1]));
            match scheme {
                Resampling::Multinomial => {
                    let w = (b - a) / nf;
                    nf * w * (1.0 - w)
                }
                Resampling::Stratified if a.floor() == b.floor() => {
                    bernoulli(b.fract() - a.fract())
                }
                Resampling::Stratified => bernoulli(a.fract()) + bernoulli(b.fract()),
                Resampling::Systematic => {
                    let grid = 100_000;
                    let counts: Vec<f64> = (0..grid)
                        .map(|k| {
                            let u = (f64::from(k) + 0.5) / f64::from(grid);
                            let up_to = |c: f64| (c - u).ceil().clamp(0.0, nf);
                            up_to(b) - up_to(a)
                        })
                        .collect();
                    let mean = counts.iter().sum::<f64>() / f64::from(grid);
                    counts.iter().map(|c| (c - mean).powi(2)).sum::<f64>() / f64::from(grid)
                }
                Resampling::Residual => {
                    let share = residuals[g[0]..g[1]].iter().sum::<f64>() / rest;
                    rest * bernoulli(share)
                }
            }
        })
        .collect()
}

/// The mean and variance, over `repetitions` resamplings, of the number of draws in each group.
fn measured_groups(
    weights: &[f64],
    n: usize,
    groups: &[usize],
    scheme: Resampling,
    repetitions: u32,
    rng: &mut ChaCha8Rng,
) -> (Vec<f64>, Vec<f64>) {
    let mut sums = vec![(0.0, 0.0); groups.len() - 1];
    for _ in 0..repetitions {
        let indices = resample_indices(weights, n, scheme, rng).unwrap();
        for (g, (s, s2)) in groups.windows(2).zip(&mut sums) {
            let c = indices
                .iter()
                .filter(|&&j| (g[0]..g[1]).contains(&j))
                .count() as f64;
            *s += c;
            *s2 += c * c;
        }
    }
    let r = f64::from(repetitions);
    let means = sums.iter().map(|(s, _)| s / r).collect();
    let variances = sums
        .iter()
        .map(|(s, s2)| s2 / r - (s / r).powi(2))
        .collect();
    (means, variances)
}

/// Every value within 10 % of its expected one.
fn within(measured: &[f64], expected: &[f64]) -> bool {
    measured
        .iter()
        .zip(expected)
        .all(|(m, e)| (m - e).abs() <= 0.1 * e)
}

/// Each scheme's copies have the variance its construction gives ([`group_variances`]; 20 000
/// resamplings of 10 draws from weights whose N·Cᵢ = 1.3, 3.5, 6.6, 10 fall in different strata),
/// within 10 % (more than five standard errors of a sample variance here), and the stratified and
/// residual schemes are not mistaken for the multinomial one, nor the stratified for the systematic.
#[test]
fn each_scheme_has_the_variance_of_its_construction() {
    let weights = [0.13, 0.22, 0.31, 0.34];
    let (n, groups) = (10, [0, 1, 2, 3, 4]);
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let expected = |scheme| group_variances(&weights, n, &groups, scheme);
    for scheme in SCHEMES {
        let (_, measured) = measured_groups(&weights, n, &groups, scheme, 20_000, &mut rng);
        assert!(
            within(&measured, &expected(scheme)),
            "{scheme:?}: {measured:?} vs {:?}",
            expected(scheme)
        );
        if scheme != Resampling::Multinomial {
            let multinomial = expected(Resampling::Multinomial);
            assert!(!within(&measured, &multinomial), "{scheme:?}: {measured:?}");
        }
    }
    // The stratified scheme is not the systematic one (0.46 against 0.16 for the second particle).
    let (_, stratified) = measured_groups(
        &weights,
        n,
        &groups,
        Resampling::Stratified,
        20_000,
        &mut rng,
    );
    assert!(!within(&stratified, &expected(Resampling::Systematic)));
}

/// The multinomial and residual schemes draw their sorted points in blocks of 1024: with 3000
/// particles (weights ∝ 1 + i mod 7) and 3000 draws, the multinomial points span three blocks and
/// the residual remainder (R ≈ 1286) two, and the count runs in two halves meeting at particle
/// 1499, inside the second quarter. The draws in each quarter of the particles have the mean
/// N W (within five standard errors) and the variance of the construction (within 10 %: 4000
/// resamplings, 4.5 standard errors of a sample variance), and the two are not mistaken for each
/// other (quarter variances near 562 and 241).
#[test]
fn sorted_points_across_blocks_have_the_multinomial_law() {
    let m = 3000;
    let raw: Vec<f64> = (0..m).map(|i| f64::from(1 + i % 7)).collect();
    let total: f64 = raw.iter().sum();
    let weights: Vec<f64> = raw.iter().map(|w| w / total).collect();
    let n = 3000;
    let groups = [0, 750, 1500, 2250, 3000];
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let repetitions = 4000;
    for (scheme, other) in [
        (Resampling::Multinomial, Resampling::Residual),
        (Resampling::Residual, Resampling::Multinomial),
    ] {
        let (means, variances) =
            measured_groups(&weights, n, &groups, scheme, repetitions, &mut rng);
        let expected = group_variances(&weights, n, &groups, scheme);
        for ((g, mean), variance) in groups.windows(2).zip(&means).zip(&expected) {
            let w: f64 = weights[g[0]..g[1]].iter().sum();
            let standard_error = (variance / f64::from(repetitions)).sqrt();
            assert!(
                (mean - n as f64 * w).abs() <= 5.0 * standard_error,
                "{scheme:?}, particles {g:?}: mean {mean} vs {}",
                n as f64 * w
            );
        }
        assert!(
            within(&variances, &expected),
            "{scheme:?}: {variances:?} vs {expected:?}"
        );
        let wrong = group_variances(&weights, n, &groups, other);
        assert!(!within(&variances, &wrong), "{scheme:?}: {variances:?}");
    }
}

/// From 2048 weighted particles on, the multinomial and residual counts run in two halves that
/// meet at the cumulative weight of the first half. Where that weight is all, none, or one
/// particle on either side of the meeting point, the draws are still n sorted indices of
/// weighted particles, and the residual scheme still gives each particle its ⌊N wᵢ⌋ copies.
#[test]
fn the_two_halves_of_a_large_count_meet_exactly() {
    let size = 5000;
    let middle = (size - 1) / 2;
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let random: Vec<f64> = (0..size)
        .map(|i| if i % 7 == 0 { 0.0 } else { rng.random::<f64>() })
        .collect();
    // All the weight in the first fifth, and a trace on the last particle.
    let front: Vec<f64> = (0..size)
        .map(|i| match i {
            _ if i < 1000 => 1.0,
            _ if i == size - 1 => 1e-300,
            _ => 0.0,
        })
        .collect();
    // No weight in the first half.
    let back: Vec<f64> = (0..size).map(|i| f64::from(u8::from(i >= 3000))).collect();
    // Two spikes on either side of the meeting point, and a little everywhere.
    let spikes: Vec<f64> = (0..size)
        .map(|i| {
            if i == middle - 1 || i == middle {
                1.0
            } else {
                1e-4
            }
        })
        .collect();
    for (name, weights) in [
        ("random", &random),
        ("front", &front),
        ("back", &back),
        ("spikes", &spikes),
    ] {
        let total: f64 = weights.iter().sum();
        for scheme in [Resampling::Multinomial, Resampling::Residual] {
            for n in [1, 3, 2500, 5000, 12_345] {
                let indices = resample_indices(weights, n, scheme, &mut rng).unwrap();
                assert_eq!(indices.len(), n, "{name} {scheme:?} {n}");
                assert!(
                    indices.windows(2).all(|w| w[0] <= w[1]),
                    "{name} {scheme:?} {n}"
                );
                assert!(
                    indices.iter().all(|&i| weights[i] > 0.0),
                    "{name} {scheme:?} {n}"
                );
                if scheme == Resampling::Residual {
                    let mut copies = vec![0_usize; size];
                    for &i in &indices {
                        copies[i] += 1;
                    }
                    for (i, (&c, &w)) in copies.iter().zip(weights.iter()).enumerate() {
                        let floor = (n as f64 * w / total * (1.0 - 1e-12)).floor();
                        assert!(c as f64 >= floor, "{name} {n}: particle {i} {c} < {floor}");
                    }
                }
            }
        }
    }
}

/// Weights 1 : 3 : 0 : 4 scaled by a power of two (exact) from the smallest subnormal to where their
/// sum overflows give the same draws from the same generator state.
#[test]
fn weights_at_any_scale_give_the_same_draws() {
    for scheme in SCHEMES {
        let draws = |scale: f64| {
            let weights = [scale, 3.0 * scale, 0.0, 4.0 * scale];
            resample_indices(&weights, 1000, scheme, &mut ChaCha8Rng::seed_from_u64(8)).unwrap()
        };
        let plain = draws(1.0);
        // 2⁻¹⁰⁷⁴, the smallest subnormal, then 2⁻¹⁰⁰⁰ … 2¹⁰²¹.
        let scales = [f64::from_bits(1)]
            .into_iter()
            .chain([-1000, -900, -1, 1, 900, 1020, 1021].map(|e| 2f64.powi(e)));
        for scale in scales {
            assert_eq!(draws(scale), plain, "{scheme:?} {scale:e}");
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
    let likelihood = LikelihoodFn::new(|x: &f64, z: &f64| -0.5 * (z - x) * (z - x));
    let log_evidence = set
        .condition_in_place(&Reweight(likelihood), &3.0)
        .unwrap()
        .log_evidence
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
        copy.resample(scheme, &mut rng);
        assert!((copy.effective_sample_size() - 20_000.0).abs() < 1e-6);
        let resampled_mean = copy.expectation(|x| *x);
        assert!(
            (resampled_mean - mean).abs() < 0.05,
            "{scheme:?}: {resampled_mean}"
        );
    }
}

/// The weights' check names the first bad weight whatever their sum does: a negative weight
/// beside weights whose sum overflows, a NaN after a negative one, infinities of both signs; and
/// it accepts −0 (never drawn) and weights whose sum overflows.
#[test]
fn the_first_bad_weight_is_named_whatever_the_sum() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let refused = |weights: &[f64], scheme, rng: &mut ChaCha8Rng| {
        resample_indices(weights, 3, scheme, rng).unwrap_err()
    };
    for scheme in SCHEMES {
        for weights in [
            [f64::MAX, f64::MAX, -1.0],
            [-1.0, 2.0, 3.0],
            [1.0, 2.0, -5e-324],
        ] {
            let error = refused(&weights, scheme, &mut rng);
            let value = weights.iter().copied().find(|w| *w < 0.0).unwrap();
            assert!(
                matches!(error, OperatorError::OutOfRange { value: v, .. } if v == value),
                "{weights:?}: {error}"
            );
        }
        for (weights, value) in [
            ([1.0, -2.0, f64::NAN], f64::NAN),
            ([f64::INFINITY, f64::NEG_INFINITY, 1.0], f64::INFINITY),
            ([1.0, f64::NEG_INFINITY, f64::MAX], f64::NEG_INFINITY),
        ] {
            let error = refused(&weights, scheme, &mut rng);
            assert!(
                matches!(error, OperatorError::NonFinite { value: v, .. }
                    if v.to_bits() == value.to_bits() || (v.is_nan() && value.is_nan())),
                "{weights:?}: {error}"
            );
        }
        let indices = resample_indices(&[-0.0, 1.0, -0.0], 3, scheme, &mut rng).unwrap();
        assert_eq!(indices, vec![1, 1, 1], "{scheme:?}");
    }
    let indices = resample_indices(&[f64::MAX; 3], 3, Resampling::Systematic, &mut rng).unwrap();
    assert_eq!(indices, vec![0, 1, 2]);
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
    let constant = |value: f64| Reweight(LikelihoodFn::new(move |_: &f64, (): &()| value));
    for value in [f64::NEG_INFINITY, f64::NAN, f64::INFINITY] {
        let error = set.condition_in_place(&constant(value), &()).unwrap_err();
        assert!(matches!(error, OperatorError::NonFinite { .. }), "{error}");
        assert!(set.condition(&constant(value), &()).is_err());
    }
    // The failed updates left the weights as they were.
    assert_eq!(set.weights(), vec![0.5, 0.5]);
    let step = SampleFn::new(|x: &Rn<f64, 1>, (): &(), _: &mut dyn RngCore| {
        finite_point(x.retract(&Vector1::new(1.0)))
    });
    let model = Sampled::new(&step, ChaCha8Rng::seed_from_u64(1));
    let points = ParticleSet::from_samples(vec![Rn::new_unchecked(Vector1::new(1.0)); 2]).unwrap();
    let moved = points.propagate(&model, &()).unwrap();
    assert_eq!(moved.particles()[1].coords()[0], 2.0);
    // The by-value step left the set as it was.
    assert_eq!(points.particles()[1].coords()[0], 1.0);
    assert!(
        Sampled::with_resampling(
            &step,
            ChaCha8Rng::seed_from_u64(1),
            f64::NAN,
            Resampling::Residual
        )
        .is_err()
    );
    for fraction in [-0.1, 1.5, f64::INFINITY] {
        let refused = Sampled::with_resampling(
            &step,
            ChaCha8Rng::seed_from_u64(1),
            fraction,
            Resampling::Residual,
        );
        let message = refused.err().map(|e| e.to_string());
        assert!(message.is_some_and(|m| m.contains("[0, 1]")), "{fraction}");
    }
}

/// A process that fails at its `fail_at`-th draw (counting from 1), moving x to x + 10 otherwise.
fn failing_at(
    fail_at: usize,
) -> impl Fn(&f64, &(), &mut dyn RngCore) -> Result<f64, OperatorError> {
    let draws = Cell::new(0);
    move |x, (), _| {
        draws.set(draws.get() + 1);
        if draws.get() == fail_at {
            Err(OperatorError::NonFinitePoint { what: "test draw" })
        } else {
            Ok(x + 10.0)
        }
    }
}

/// A failed step leaves the set exactly as it was, weights and particles: a NaN likelihood, and a
/// propagation whose process fails after the resampling indices were drawn (the resampling is part of
/// the step, so it is undone too).
#[test]
fn failed_steps_leave_the_set_unchanged() {
    let mut set = ParticleSet::from_samples(vec![1.0, 2.0, 3.0, 4.0]).unwrap();
    // Weights ∝ e^(−4x): ESS ≈ 1.04 < 0.5 · 4, so the next propagation resamples.
    let steep = Reweight(LikelihoodFn::new(|x: &f64, (): &()| -4.0 * x));
    set.condition_in_place(&steep, &()).unwrap();
    assert!(set.effective_sample_size() < 2.0);
    let (weights, particles) = (set.log_weights().to_vec(), set.particles().to_vec());
    let nan_at_three = Reweight(LikelihoodFn::new(
        |x: &f64, (): &()| {
            if *x == 3.0 { f64::NAN } else { 0.0 }
        },
    ));
    assert!(set.condition_in_place(&nan_at_three, &()).is_err());
    for fail_at in 1..=4 {
        let model = Sampled::new(
            SampleFn::new(failing_at(fail_at)),
            ChaCha8Rng::seed_from_u64(5),
        );
        let error = set.propagate_in_place(&model, &()).unwrap_err();
        assert!(
            matches!(error, OperatorError::NonFinitePoint { .. }),
            "{error}"
        );
        assert_eq!(set.log_weights(), &weights[..]);
        assert_eq!(set.particles(), &particles[..]);
    }
    // The same step that succeeds: resampled (uniform weights), then moved.
    let model = Sampled::new(SampleFn::new(failing_at(0)), ChaCha8Rng::seed_from_u64(5));
    set.propagate_in_place(&model, &()).unwrap();
    assert!(set.log_weights().iter().all(|l| *l == -(4.0_f64).ln()));
    // Resampled from weights 0.98, 0.018, 3e-4, 6e-6: systematically, 4 copies of the first.
    assert_eq!(set.particles(), &[11.0; 4]);
    // Below the threshold nothing is resampled: weights kept, every particle moved.
    let mut kept = ParticleSet::from_weighted_samples(vec![1.0, 2.0], &[0.3, 0.7]).unwrap();
    let never = Sampled::with_resampling(
        SampleFn::new(failing_at(0)),
        ChaCha8Rng::seed_from_u64(5),
        0.0,
        Resampling::Multinomial,
    )
    .unwrap();
    kept.propagate_in_place(&never, &()).unwrap();
    assert_eq!(kept.particles(), &[11.0, 12.0]);
    assert!((kept.weights()[1] - 0.7).abs() < 1e-15);
}

/// The bootstrap filter on `x′ = 0.9 x + w`, `w ~ N(0, 0.5)`, `z = x + n`, `n ~ N(0, 0.3)`, from
/// `x₀ ~ N(1, 2)`, against the Kalman filter over 10 steps: at each step the weighted mean and
/// variance, and the accumulated log evidence, agree within 5 standard errors.
///
/// The standard errors come from the sample size: with ESS the effective sample size after the
/// update, the weighted mean of N particles has variance about `P (1/ESS + 1/N)` (the update's own
/// error, plus that of the N particles the prediction drew), and the weighted variance about
/// `2 P² (1/ESS + 1/N)`. The estimate `p̂(z) = Σ wᵢ p(z | xᵢ)` has relative variance
/// `1/ESS − 1/N` (the spread of the likelihood over the predicted particles), so the log evidence
/// accumulated over the steps has variance about `Σₜ (1/ESSₜ − 1/N) + 1/N` per step.
#[test]
fn a_bootstrap_filter_matches_the_kalman_filter() {
    let (a, q, r) = (0.9, 0.5, 0.3);
    let n: u32 = 20_000;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut exact = Gaussian::new(Vector1::new(1.0), Matrix1::new(2.0)).unwrap();
    let process = LinearProcess::new(Matrix1::new(a), Matrix1::new(q)).unwrap();
    let measurement = LinearMeasurement::new(Matrix1::new(1.0), Matrix1::new(r)).unwrap();
    let samples = (0..n)
        .map(|_| {
            let e: f64 = StandardNormal.sample(&mut rng);
            1.0 + 2.0_f64.sqrt() * e
        })
        .collect();
    let mut set = ParticleSet::from_samples(samples).unwrap();
    let draw = SampleFn::new(move |x: &f64, (): &(), rng: &mut dyn RngCore| {
        let w: f64 = StandardNormal.sample(rng);
        Ok(a * x + q.sqrt() * w)
    });
    let sampled = Sampled::new(draw, ChaCha8Rng::seed_from_u64(12));
    let gauss = Reweight(LikelihoodFn::new(move |x: &f64, z: &f64| {
        -0.5 * ((z - x) * (z - x) / r + (2.0 * PI * r).ln())
    }));
    let (mut truth, mut exact_evidence, mut evidence, mut evidence_variance) = (0.4, 0.0, 0.0, 0.0);
    let nf = f64::from(n);
    for step in 0..10 {
        let (w, e): (f64, f64) = (
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
        );
        truth = a * truth + q.sqrt() * w;
        let z = truth + r.sqrt() * e;
        exact = exact.propagate(&process, &Vector1::zeros()).unwrap();
        let update = exact.condition(&measurement, &Vector1::new(z)).unwrap();
        exact = update.posterior;
        exact_evidence += update.log_evidence;
        set.propagate_in_place(&sampled, &()).unwrap();
        evidence += set.condition_in_place(&gauss, &z).unwrap().log_evidence;
        let ess = set.effective_sample_size();
        evidence_variance += 1.0 / ess;
        let (p, m) = (exact.covariance()[0], exact.mean()[0]);
        let inflation = 1.0 / ess + 1.0 / nf;
        let mean = set.expectation(|x| *x);
        let variance = set.expectation(|x| (x - mean) * (x - mean));
        assert!(
            (mean - m).abs() < 5.0 * (p * inflation).sqrt(),
            "step {step}: mean {mean} vs {m} (ESS {ess})"
        );
        assert!(
            (variance - p).abs() < 5.0 * p * (2.0 * inflation).sqrt(),
            "step {step}: variance {variance} vs {p} (ESS {ess})"
        );
        assert!(
            (evidence - exact_evidence).abs() < 5.0 * evidence_variance.sqrt(),
            "step {step}: log evidence {evidence} vs {exact_evidence}"
        );
    }
}

/// Weighted samples: linear and log weights give the set that reweighting equal samples gives, and
/// log weights far below the smallest f64 keep their ratios.
#[test]
fn weighted_samples_equal_reweighted_samples() {
    let particles: Vec<usize> = vec![0, 1, 2, 3];
    let weights = [0.5, 2.0, 0.0, 1.5];
    let from_linear = ParticleSet::from_weighted_samples(particles.clone(), &weights).unwrap();
    let mut reweighted = ParticleSet::from_samples(particles.clone()).unwrap();
    let table = Reweight(LikelihoodFn::new(|x: &usize, (): &()| weights[*x].ln()));
    reweighted.condition_in_place(&table, &()).unwrap();
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

/// Every scheme returns its indices in increasing order, n of them, each of a particle of positive
/// weight (the draws are generated in order, without a sort).
#[test]
fn every_scheme_returns_sorted_indices_of_weighted_particles() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let weights: Vec<f64> = (0..300)
        .map(|i| if i % 7 == 0 { 0.0 } else { rng.random::<f64>() })
        .collect();
    for scheme in SCHEMES {
        for n in [1, 2, 299, 300, 1000] {
            let indices = resample_indices(&weights, n, scheme, &mut rng).unwrap();
            assert_eq!(indices.len(), n, "{scheme:?}");
            assert!(indices.windows(2).all(|w| w[0] <= w[1]), "{scheme:?} {n}");
            assert!(indices.iter().all(|&i| weights[i] > 0.0), "{scheme:?} {n}");
        }
    }
}

/// A failed propagation gives its draws back: the generator is restored, so the next step draws
/// what it would have drawn had the failed one not been tried (resampling first, then a draw per
/// particle before the process fails on its input).
#[test]
fn a_failed_propagation_gives_its_draws_back() {
    let walk = SampleFn::new(|x: &Rn<f64, 1>, u: &f64, rng: &mut dyn RngCore| {
        let w: f64 = StandardNormal.sample(rng);
        finite_point(x.retract(&Vector1::new(u * w)))
    });
    let start = || {
        let mut set = ParticleSet::from_samples(
            (0..50)
                .map(|k| Rn::new_unchecked(Vector1::new(f64::from(k))))
                .collect(),
        )
        .unwrap();
        // Uneven weights, so that the step resamples (drawing from the generator) first.
        let likelihood = LikelihoodFn::new(|x: &Rn<f64, 1>, (): &()| -x.coords()[0]);
        set.condition_in_place(&Reweight(&likelihood), &()).unwrap();
        set
    };
    let model = || {
        Sampled::with_resampling(
            &walk,
            ChaCha8Rng::seed_from_u64(3),
            0.9,
            Resampling::Multinomial,
        )
        .unwrap()
    };
    let (tried, clean) = (model(), model());
    let (mut a, mut b) = (start(), start());
    assert!(a.propagate_in_place(&tried, &f64::NAN).is_err());
    a.propagate_in_place(&tried, &1.0).unwrap();
    b.propagate_in_place(&clean, &1.0).unwrap();
    assert_eq!(a.particles(), b.particles());
}
