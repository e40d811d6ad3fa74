//! Bad input never panics, hangs, aborts or silently yields NaN. Every public constructor and operator
//! of the crate (Kalman filter, EKF, UKF, their iterated updates, particle set, resampling, grid,
//! composites, the RTS, fixed-lag and iterated smoothers, the iterated smoother's block Jacobian,
//! evaluation metrics) is fed NaN, ±∞, ±MAX, subnormals, zeros, singular and indefinite covariances and huge
//! sizes, each call on its own thread under a time limit; it must return an error or a finite result,
//! and a container stepped in place must be exactly as it was after an error. The fixed cases at the
//! end are the regressions of reported failures (`LIEBAYES_FUZZ_CASES` runs the properties long).

use liebayes_densities::{Gaussian, GenVonMises2, HarmonicGaussian, ManifoldGaussian};
use liebayes_manifolds::{Manifold, Rn, So2};
use liebayes_operators::evaluation::{
    average_nees_band, chi_square_band, chi_square_cdf, chi_square_quantile, circular_consistency,
    nees,
};
use liebayes_operators::fixed_lag::FixedLagSmoother;
use liebayes_operators::grid::{CircularGrid, Diffusion};
use liebayes_operators::iterated::IterationSettings;
use liebayes_operators::iterated_smoother::{
    Backend, BlockJacobian, GaussNewton, IteratedSmoother, MAX_HALVINGS,
    MAX_ITERATIONS as MAX_GAUSS_NEWTON_ITERATIONS,
};
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::particle::{
    Given, LikelihoodFn, ParticleSet, Resampling, Reweight, SampleFn, Sampled, finite_point,
    resample_indices,
};
use liebayes_operators::rao_blackwell::RotatedMeasurement;
use liebayes_operators::smoother::RtsSmoother;
use liebayes_operators::{
    Condition, Ekf, IteratedEkf, IteratedUkf, MAX_ELEMENTS, MeasurementFn, MeasurementModel,
    OperatorError, ProcessFn, ProcessModel, Propagate, Ukf,
};
use liebayes_reference::fuzz::{self, size, value};
use nalgebra::{DMatrix, Matrix1, Matrix2, Matrix2x3, SMatrix, SVector, Vector1, Vector2};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::cell::Cell;

const SCHEMES: [Resampling; 4] = [
    Resampling::Multinomial,
    Resampling::Stratified,
    Resampling::Systematic,
    Resampling::Residual,
];

fn matrix<const R: usize, const C: usize>() -> impl Strategy<Value = SMatrix<f64, R, C>> {
    proptest::collection::vec(value(), R * C).prop_map(|v| SMatrix::from_column_slice(&v))
}

/// Covariances: nasty matrices, their symmetric parts (often indefinite), singular `v vᵀ` and
/// positive definite ones.
fn covariance<const N: usize>() -> impl Strategy<Value = SMatrix<f64, N, N>> {
    prop_oneof![
        matrix::<N, N>(),
        matrix::<N, N>().prop_map(|m| (m + m.transpose()) * 0.5),
        matrix::<N, 1>().prop_map(|v| v * v.transpose()),
        matrix::<N, N>().prop_map(|m| m * m.transpose() + SMatrix::identity()),
    ]
}

fn finite<'a>(values: impl IntoIterator<Item = &'a f64>) -> bool {
    values.into_iter().all(|v| v.is_finite())
}

fn finite_gaussian<const N: usize>(g: &Gaussian<N>) -> bool {
    finite(g.mean().iter()) && finite(g.covariance().iter())
}

fn finite_manifold_gaussian<X: Manifold<D, Scalar = f64>, const D: usize>(
    g: &ManifoldGaussian<X, D>,
) -> bool {
    g.mean().is_finite() && finite(g.covariance().iter()) && g.log_determinant().is_finite()
}

/// The prior the step cases start from: the nasty covariance when it is a valid one.
fn prior_or_default<const N: usize>(p: SMatrix<f64, N, N>) -> Gaussian<N> {
    Gaussian::new(SVector::repeat(0.5), p)
        .or_else(|_| Gaussian::new(SVector::repeat(0.5), SMatrix::identity()))
        .unwrap()
}

/// Weights that sum to one and an effective sample size in [1, N].
fn normalised(log_weights: &[f64], ess: f64) -> Result<(), TestCaseError> {
    prop_assert!(log_weights.iter().all(|l| !l.is_nan() && *l <= 1e-12));
    let total: f64 = log_weights.iter().map(|l| l.exp()).sum();
    prop_assert!((total - 1.0).abs() < 1e-12, "weights sum to {total}");
    prop_assert!(ess >= 1.0 - 1e-12 && ess <= log_weights.len() as f64 * (1.0 + 1e-12));
    Ok(())
}

/// The entry of `table` a coordinate picks, shifted: an arbitrary but deterministic lookup
/// (truncation intended).
#[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
fn pick(table: &[f64], x: f64, shift: usize) -> f64 {
    table[((x.abs() as usize) % table.len() + shift) % table.len()]
}

#[test]
fn kalman_filter() {
    fuzz::run(
        "kalman_filter",
        (
            matrix::<2, 2>(),
            covariance::<2>(),
            matrix::<1, 2>(),
            covariance::<1>(),
            covariance::<2>(),
            matrix::<2, 1>(),
            matrix::<1, 1>(),
        ),
        |(f, q, h, r, p, u, z)| {
            fuzz::case("kalman_filter", move || -> Result<(), TestCaseError> {
                let prior = prior_or_default(p);
                if let Some(process) = fuzz::counted(LinearProcess::new(f, q)) {
                    if let Some(next) = fuzz::counted(prior.propagate(&process, &u)) {
                        prop_assert!(finite_gaussian(&next));
                    }
                }
                if let Some(model) = fuzz::counted(LinearMeasurement::new(h, r)) {
                    if let Some(step) = fuzz::counted(prior.condition(&model, &z)) {
                        prop_assert!(finite_gaussian(&step.posterior));
                        prop_assert!(step.log_evidence.is_finite());
                        prop_assert!(step.report.nis().is_finite() && step.report.nis() >= 0.0);
                        prop_assert!(finite(step.report.gain().iter()));
                    }
                }
                Ok(())
            });
        },
    );
}

/// A position on R² at (1, 2) with the nasty covariance `p` when it is a valid one (the identity
/// at the origin otherwise).
fn position_prior(p: Matrix2<f64>) -> ManifoldGaussian<Rn<f64, 2>, 2> {
    ManifoldGaussian::new(Rn::new_unchecked(Vector2::new(1.0, 2.0)), p).unwrap_or_else(|_| {
        ManifoldGaussian::new(Rn::new_unchecked(Vector2::zeros()), Matrix2::identity()).unwrap()
    })
}

/// A range `scale · |x|` on R² with noise `r`.
fn range_model(scale: f64, r: f64) -> impl MeasurementModel<Rn<f64, 2>, 2, 1> {
    MeasurementFn::new(
        move |x: &Rn<f64, 2>| Vector1::new(x.coords().norm() * scale),
        move |_| Matrix1::new(r),
    )
}

/// The EKF and the UKF on SO(2) and R² with closure models whose outputs are nasty.
#[test]
fn ekf_and_ukf() {
    fuzz::run(
        "ekf_and_ukf",
        (
            value(),
            value(),
            value(),
            value(),
            value(),
            matrix::<2, 1>(),
            covariance::<2>(),
            value(),
            value(),
            value(),
        ),
        |(rate, q, scale, r, z, shift, p, alpha, beta, kappa)| {
            fuzz::case("ekf_and_ukf", move || -> Result<(), TestCaseError> {
                let heading =
                    ManifoldGaussian::new(So2::from_angle_unchecked(1.0), Matrix1::new(0.2))
                        .unwrap();
                let gyro = ProcessFn::new(
                    move |x: &So2<f64>, (): &()| x.retract(&Vector1::new(rate)),
                    move |_, ()| Matrix1::new(q),
                );
                let compass = MeasurementFn::new(
                    move |x: &So2<f64>| Vector1::new(scale * x.angle()),
                    move |_| Matrix1::new(r),
                );
                let position = position_prior(p);
                let drift = ProcessFn::new(
                    move |x: &Rn<f64, 2>, (): &()| Rn::new_unchecked(x.coords() + shift),
                    move |_, ()| Matrix2::identity() * q,
                );
                let range = range_model(scale, r);
                let z = Vector1::new(z);
                for next in [
                    heading.propagate(&Ekf(&gyro), &()),
                    heading.propagate(&Ukf::new(&gyro), &()),
                ]
                .into_iter()
                .chain(
                    Ukf::with_scaling(&gyro, alpha, beta, kappa)
                        .map(|m| heading.propagate(&m, &())),
                )
                .flatten()
                {
                    prop_assert!(finite_manifold_gaussian(&next));
                }
                for step in [
                    heading.condition(&Ekf(&compass), &z),
                    heading.condition(&Ukf::new(&compass), &z),
                ]
                .into_iter()
                .chain(
                    Ukf::with_scaling(&compass, alpha, beta, kappa)
                        .map(|m| heading.condition(&m, &z)),
                )
                .flatten()
                {
                    prop_assert!(finite_manifold_gaussian(&step.posterior));
                    prop_assert!(step.log_evidence.is_finite() && step.report.nis().is_finite());
                }
                for next in [
                    position.propagate(&Ekf(&drift), &()),
                    position.propagate(&Ukf::new(&drift), &()),
                ]
                .into_iter()
                .flatten()
                {
                    prop_assert!(finite_manifold_gaussian(&next));
                }
                for step in [
                    position.condition(&Ekf(&range), &z),
                    position.condition(&Ukf::new(&range), &z),
                ]
                .into_iter()
                .flatten()
                {
                    prop_assert!(finite_manifold_gaussian(&step.posterior));
                    prop_assert!(step.log_evidence.is_finite());
                }
                Ok(())
            });
        },
    );
}

/// Particle sets from nasty weights, stepped with nasty likelihoods and moves: normalised after
/// every step that succeeds, unchanged after every one that fails.
#[test]
fn particle_set() {
    fuzz::run(
        "particle_set",
        (
            proptest::collection::vec(value(), 0..6),
            proptest::collection::vec(value(), 1..6),
            proptest::collection::vec(value(), 6),
            proptest::collection::vec(value(), 6),
            value(),
        ),
        |(weights, log_weights, likelihoods, moves, fraction)| {
            fuzz::case("particle_set", move || -> Result<(), TestCaseError> {
                let points = |n: usize| {
                    (0..n)
                        .map(|i| Rn::new_unchecked(Vector1::new(i as f64)))
                        .collect::<Vec<_>>()
                };
                let _ = ParticleSet::from_weighted_samples(points(weights.len()), &weights);
                let Ok(mut set) =
                    ParticleSet::from_log_weighted_samples(points(log_weights.len()), &log_weights)
                else {
                    return Ok(());
                };
                normalised(set.log_weights(), set.effective_sample_size())?;
                let mut rng = ChaCha8Rng::seed_from_u64(1);
                let round = Cell::new(0);
                let walk = SampleFn::new(|x: &Rn<f64, 1>, (): &(), _: &mut dyn RngCore| {
                    finite_point(x.retract(&Vector1::new(pick(&moves, x.coords()[0], round.get()))))
                });
                let scheme = SCHEMES[log_weights.len() % 4];
                let chosen =
                    Sampled::with_resampling(&walk, ChaCha8Rng::seed_from_u64(2), fraction, scheme);
                prop_assert_eq!(chosen.is_ok(), (0.0..=1.0).contains(&fraction));
                let sampled =
                    chosen.unwrap_or_else(|_| Sampled::new(&walk, ChaCha8Rng::seed_from_u64(2)));
                for r in 0..3 {
                    round.set(r);
                    // Built per round (a likelihood is Sync, for the `rayon` feature).
                    let likelihood = Reweight(LikelihoodFn::new(|x: &Rn<f64, 1>, (): &()| {
                        pick(&likelihoods, x.coords()[0], r * 2)
                    }));
                    let before = (set.particles().to_vec(), set.log_weights().to_vec());
                    if let Some(step) = fuzz::counted(set.condition_in_place(&likelihood, &())) {
                        prop_assert!(
                            step.log_evidence.is_finite(),
                            "log evidence {}",
                            step.log_evidence
                        );
                    } else {
                        prop_assert_eq!(&before.0, set.particles());
                        prop_assert_eq!(&before.1, set.log_weights());
                    }
                    normalised(set.log_weights(), set.effective_sample_size())?;
                    let before = (set.particles().to_vec(), set.log_weights().to_vec());
                    if fuzz::counted(set.propagate_in_place(&sampled, &())).is_none() {
                        prop_assert_eq!(&before.0, set.particles());
                        prop_assert_eq!(&before.1, set.log_weights());
                    }
                    normalised(set.log_weights(), set.effective_sample_size())?;
                    prop_assert!(set.particles().iter().all(Manifold::is_finite));
                    if let Some(mean) = fuzz::counted(set.mean()) {
                        prop_assert!(mean.is_finite());
                    }
                    set.resample(SCHEMES[r % 4], &mut rng);
                    normalised(set.log_weights(), set.effective_sample_size())?;
                }
                Ok(())
            });
        },
    );
}

#[test]
fn resampling() {
    fuzz::run(
        "resampling",
        (proptest::collection::vec(value(), 0..6), size(MAX_ELEMENTS)),
        |(weights, n)| {
            fuzz::case("resampling", move || -> Result<(), TestCaseError> {
                let mut rng = ChaCha8Rng::seed_from_u64(2);
                for scheme in SCHEMES {
                    if let Some(indices) =
                        fuzz::counted(resample_indices(&weights, n, scheme, &mut rng))
                    {
                        prop_assert_eq!(indices.len(), n);
                        prop_assert!(
                            indices
                                .iter()
                                .all(|&i| i < weights.len() && weights[i] > 0.0)
                        );
                        prop_assert!(indices.windows(2).all(|w| w[0] <= w[1]));
                    }
                }
                Ok(())
            });
        },
    );
}

#[test]
fn grid() {
    fuzz::run(
        "grid",
        (
            size(MAX_ELEMENTS),
            proptest::collection::vec(value(), 1..5),
            proptest::collection::vec(value(), 1..5),
            proptest::collection::vec(value(), 1..5),
        ),
        |(n, log_density, likelihood, kernel)| {
            fuzz::case("grid", move || -> Result<(), TestCaseError> {
                let uniform = CircularGrid::uniform(n, ());
                prop_assert_eq!(uniform.is_ok(), (1..=40).contains(&n));
                let at = |table: &[f64], theta: f64| pick(table, theta * 100.0, 0);
                // A saved grid read back: the drawn log weights as they are, sometimes one too many.
                let cells = vec![(); log_density.len() - usize::from(n % 2 == 1)];
                if let Some(read) =
                    fuzz::counted(CircularGrid::from_log_weights(&log_density, cells))
                {
                    prop_assert!(read.len() == log_density.len());
                    normalised(read.log_weights(), 1.0)?;
                }
                let Ok(mut grid) =
                    CircularGrid::from_log_density(n.min(40), |t| at(&log_density, t), |_| ())
                else {
                    return Ok(());
                };
                let ess = |g: &CircularGrid<()>| {
                    1.0 / g.log_weights().iter().map(|l| (2.0 * l).exp()).sum::<f64>()
                };
                normalised(grid.log_weights(), ess(&grid))?;
                let before = grid.log_weights().to_vec();
                let bearing = Reweight(LikelihoodFn::new(|t: &So2<f64>, (): &()| {
                    at(&likelihood, t.angle())
                }));
                if let Some(step) = fuzz::counted(grid.condition_in_place(&bearing, &())) {
                    prop_assert!(
                        step.log_evidence.is_finite(),
                        "log evidence {}",
                        step.log_evidence
                    );
                } else {
                    prop_assert_eq!(&before, grid.log_weights());
                }
                normalised(grid.log_weights(), ess(&grid))?;
                let before = grid.log_weights().to_vec();
                let diffusion = Diffusion(|w: &So2<f64>| at(&kernel, w.angle()));
                if fuzz::counted(grid.propagate_in_place(&diffusion, &())).is_none() {
                    prop_assert_eq!(&before, grid.log_weights());
                }
                normalised(grid.log_weights(), ess(&grid))?;
                prop_assert!(finite(grid.first_moment().iter()));
                Ok(())
            });
        },
    );
}

/// The closed-form composite and the marginalized particle filter with nasty models.
#[test]
fn composites() {
    fuzz::run(
        "composites",
        (
            matrix::<2, 2>(),
            value(),
            matrix::<2, 2>(),
            covariance::<2>(),
            covariance::<2>(),
            matrix::<2, 1>(),
            matrix::<2, 1>(),
        ),
        |(h, sigma, f, q, r, z, u)| {
            fuzz::case("composites", move || -> Result<(), TestCaseError> {
                let prior = HarmonicGaussian::new(
                    GenVonMises2::from_natural(Vector2::new(0.5, 1.0), Vector2::zeros()).unwrap(),
                    Matrix2x3::new(1.0, 0.5, 0.0, -1.0, 0.0, 0.5),
                    Matrix2::identity() * 0.3,
                )
                .unwrap();
                let finite_composite = |g: &HarmonicGaussian<2>| {
                    let (eta1, eta2) = g.angle().natural();
                    finite(eta1.iter())
                        && finite(eta2.iter())
                        && finite(g.features().iter())
                        && finite(g.covariance().iter())
                };
                if let Some(model) = fuzz::counted(RotatedMeasurement::new(h, sigma)) {
                    if let Some(step) = fuzz::counted(prior.condition(&model, &z)) {
                        prop_assert!(
                            finite_composite(&step.posterior) && step.log_evidence.is_finite()
                        );
                    }
                }
                if let Some(process) = fuzz::counted(LinearProcess::new(f, q)) {
                    if let Some(next) = fuzz::counted(prior.propagate(&process, &u)) {
                        prop_assert!(finite_composite(&next));
                    }
                }
                let mut set = ParticleSet::from_samples(
                    [0.3, 2.0, -1.0]
                        .map(|a| {
                            (
                                a,
                                Gaussian::new(Vector2::zeros(), Matrix2::identity()).unwrap(),
                            )
                        })
                        .to_vec(),
                )
                .unwrap();
                let before = set.clone();
                let model = Given(|a: &f64| {
                    LinearMeasurement::new(So2::from_angle_unchecked(*a).to_matrix() * h[(0, 0)], r)
                });
                if let Some(step) = fuzz::counted(set.condition_in_place(&model, &z)) {
                    prop_assert!(
                        step.log_evidence.is_finite(),
                        "log evidence {}",
                        step.log_evidence
                    );
                } else {
                    prop_assert_eq!(before.log_weights(), set.log_weights());
                    for ((a, g), (b, h)) in before.particles().iter().zip(set.particles()) {
                        prop_assert_eq!(a, b);
                        prop_assert_eq!((g.mean(), g.covariance()), (h.mean(), h.covariance()));
                    }
                }
                prop_assert!(set.particles().iter().all(|(_, g)| finite_gaussian(g)));
                Ok(())
            });
        },
    );
}

#[test]
fn smoother() {
    fuzz::run(
        "smoother",
        (size(MAX_ELEMENTS), value(), value(), value(), value()),
        |(steps, rate, q, r, z)| {
            fuzz::case("smoother", move || -> Result<(), TestCaseError> {
                let prior =
                    ManifoldGaussian::new(So2::from_angle_unchecked(0.5), Matrix1::new(0.1))
                        .unwrap();
                prop_assert_eq!(
                    RtsSmoother::with_capacity(prior.clone(), steps).is_ok(),
                    steps <= 40
                );
                let gyro = ProcessFn::new(
                    move |x: &So2<f64>, (): &()| x.retract(&Vector1::new(rate)),
                    move |_, ()| Matrix1::new(q),
                );
                let compass = MeasurementFn::new(
                    |x: &So2<f64>| Vector1::new(x.angle()),
                    move |_| Matrix1::new(r),
                );
                let mut rts = RtsSmoother::new(prior);
                for _ in 0..3 {
                    let before = (rts.filtered().len(), rts.current().clone());
                    let propagated = rts.propagate(&Ekf(&gyro), &());
                    let conditioned = rts
                        .condition(&Ukf::new(&compass), &Vector1::new(z))
                        .map(|_| ());
                    if propagated.is_err() {
                        prop_assert_eq!(rts.filtered().len(), before.0);
                    }
                    if propagated.is_err() && conditioned.is_err() {
                        prop_assert_eq!(rts.current().mean(), before.1.mean());
                        prop_assert_eq!(rts.current().covariance(), before.1.covariance());
                    }
                }
                if let Some(smoothed) = fuzz::counted(rts.smooth()) {
                    prop_assert!(smoothed.iter().all(finite_manifold_gaussian));
                }
                Ok(())
            });
        },
    );
}

/// A heading on SO(2) at 1 rad, a gyro turning it by `rate` with noise `q`, and a compass that
/// reads `scale · sin θ` with noise `r`: the nonlinear models of the iterated cases.
fn heading_models(
    rate: f64,
    q: f64,
    scale: f64,
    r: f64,
) -> (
    ManifoldGaussian<So2<f64>, 1>,
    impl ProcessModel<So2<f64>, 1, Input = ()>,
    impl MeasurementModel<So2<f64>, 1, 1>,
) {
    let heading = ManifoldGaussian::new(So2::from_angle_unchecked(1.0), Matrix1::new(0.2)).unwrap();
    let gyro = ProcessFn::new(
        move |x: &So2<f64>, (): &()| x.retract(&Vector1::new(rate)),
        move |_, ()| Matrix1::new(q),
    );
    let sine = MeasurementFn::new(
        move |x: &So2<f64>| Vector1::new(scale * x.angle().sin()),
        move |_| Matrix1::new(r),
    );
    (heading, gyro, sine)
}

/// The iterated updates (EKF and posterior-linearised UKF, default and fuzzed settings) with
/// nasty models: a finite result or an error.
#[test]
fn iterated_updates() {
    fuzz::run(
        "iterated updates",
        (
            (value(), value(), value(), value()),
            (covariance::<2>(), value(), size(MAX_ELEMENTS)),
        ),
        |((scale, r, z, tolerance), (p, q, iterations))| {
            fuzz::case("iterated updates", move || -> Result<(), TestCaseError> {
                let (heading, _, sine) = heading_models(0.0, q, scale, r);
                let position = position_prior(p);
                let range = range_model(scale, r);
                let z = Vector1::new(z);
                // At most 50 iterations: the range goes to 1000, but not this test's time.
                let settings = IterationSettings::new(tolerance, iterations.min(50));
                prop_assert_eq!(
                    settings.is_ok(),
                    tolerance.is_finite() && tolerance >= 0.0 && iterations >= 1
                );
                let settings = settings.unwrap_or_default();
                let mut ekf = IteratedEkf::new(&sine);
                ekf.settings = settings;
                let mut ukf = IteratedUkf::new(&sine);
                ukf.settings = settings;
                for step in [heading.condition(&ekf, &z), heading.condition(&ukf, &z)]
                    .into_iter()
                    .flatten()
                {
                    prop_assert!(finite_manifold_gaussian(&step.posterior));
                    prop_assert!(step.log_evidence.is_finite() && step.report.nis().is_finite());
                }
                for step in [
                    position.condition(&IteratedEkf::new(&range), &z),
                    position.condition(&IteratedUkf::new(&range), &z),
                ]
                .into_iter()
                .flatten()
                {
                    prop_assert!(finite_manifold_gaussian(&step.posterior));
                    prop_assert!(step.log_evidence.is_finite());
                }
                Ok(())
            });
        },
    );
}

/// The fixed-lag smoother from fuzzed lag and step times, and the iterated smoother's recorder
/// and Gauss-Newton smoothing with fuzzed settings, with nasty models: a finite result or an
/// error, and a smoother stepped in place is as it was after an error.
#[test]
fn lagged_and_iterated_smoothers() {
    fuzz::run(
        "lagged and iterated smoothers",
        (
            (value(), value(), value(), value(), value()),
            (value(), value(), value()),
            (size(MAX_ELEMENTS), size(MAX_ELEMENTS), size(MAX_ELEMENTS)),
        ),
        |(
            (rate, q, scale, r, z),
            (lag_seconds, step_seconds, tolerance),
            (iterations, halvings, records),
        )| {
            fuzz::case(
                "lagged and iterated smoothers",
                move || -> Result<(), TestCaseError> {
                    let (heading, gyro, sine) = heading_models(rate, q, scale, r);
                    let z = Vector1::new(z);
                    // A lag of at most 40 epochs is made (a longer one is a valid size, but not this
                    // test's allocation).
                    if let Some(mut lagged) = FixedLagSmoother::with_lag_seconds(
                        heading.clone(),
                        lag_seconds,
                        step_seconds,
                    )
                    .ok()
                    .filter(|s| s.lag() <= 40)
                    {
                        for _ in 0..3 {
                            let before = lagged.clone();
                            if lagged.propagate(&Ekf(&gyro), &()).is_err() {
                                prop_assert!(lagged == before);
                            }
                            let before = lagged.clone();
                            if lagged.condition(&IteratedEkf::new(&sine), &z).is_err() {
                                prop_assert!(lagged == before);
                            }
                        }
                        if let Some(window) = fuzz::counted(lagged.smooth()) {
                            prop_assert!(window.iter().all(finite_manifold_gaussian));
                        }
                    }
                    prop_assert_eq!(
                        IteratedSmoother::<So2<f64>, (), 1, 1>::with_capacity(
                            heading.clone(),
                            records,
                            3
                        )
                        .is_ok(),
                        records <= 40
                    );
                    let mut smoother = IteratedSmoother::<So2<f64>, (), 1, 1>::new(heading);
                    for _ in 0..3 {
                        let before = smoother.forward().filtered().len();
                        if smoother.propagate(&gyro, &()).is_err() {
                            prop_assert_eq!(smoother.forward().filtered().len(), before);
                        }
                        let _ = smoother.condition(&sine, &z);
                    }
                    let gauss_newton = GaussNewton {
                        tolerance,
                        max_iterations: iterations,
                        max_halvings: halvings,
                    };
                    prop_assert_eq!(
                        gauss_newton.validate().is_ok(),
                        tolerance.is_finite()
                            && tolerance >= 0.0
                            && iterations <= MAX_GAUSS_NEWTON_ITERATIONS
                            && halvings <= MAX_HALVINGS
                    );
                    // At most 50 iterations, as above.
                    let settings = if iterations <= 50 {
                        gauss_newton
                    } else {
                        GaussNewton::default()
                    };
                    for smoothed in [
                        smoother.smooth(&gyro, &sine),
                        smoother.smooth_with(&gyro, &sine, &settings),
                    ]
                    .into_iter()
                    .flatten()
                    {
                        prop_assert!(smoothed.densities.iter().all(finite_manifold_gaussian));
                    }
                    Ok(())
                },
            );
        },
    );
}

#[test]
fn block_jacobian() {
    fuzz::run(
        "block jacobian",
        (
            size(MAX_ELEMENTS),
            matrix::<2, 2>(),
            matrix::<2, 2>(),
            matrix::<2, 2>(),
        ),
        |(epochs, own, first, second)| {
            fuzz::case("block jacobian", move || -> Result<(), TestCaseError> {
                let made = BlockJacobian::<2>::new(epochs);
                prop_assert_eq!(made.is_ok(), (1..40).contains(&epochs));
                let Ok(mut jacobian) = made else {
                    return Ok(());
                };
                for k in 0..epochs {
                    let before = jacobian.clone();
                    let rows = DMatrix::from_column_slice(2, 2, own.as_slice());
                    if jacobian.add_rows(k, rows.as_view()).is_err() {
                        prop_assert_eq!(&jacobian, &before);
                    }
                    let before = jacobian.clone();
                    if k + 1 < epochs && jacobian.set_transition(k, first, second).is_err() {
                        prop_assert_eq!(&jacobian, &before);
                    }
                }
                for backend in [Backend::FixedSize, Backend::Faer] {
                    let Some(factor) = fuzz::counted(jacobian.factor_with(backend)) else {
                        continue;
                    };
                    if let Some(marginals) = fuzz::counted(factor.marginal_covariances()) {
                        prop_assert!(marginals.iter().all(|m| finite(m.iter())));
                    }
                    let rhs = vec![Vector2::new(1.0, -1.0); epochs];
                    if let Some(x) = fuzz::counted(factor.solve(&rhs)) {
                        prop_assert!(x.iter().all(|v| finite(v.iter())));
                    }
                }
                Ok(())
            });
        },
    );
}

#[test]
fn evaluation() {
    fuzz::run(
        "evaluation",
        (
            matrix::<2, 1>(),
            covariance::<2>(),
            value(),
            value(),
            size(MAX_ELEMENTS),
            size(MAX_ELEMENTS),
        ),
        |(e, p, z, dof, dim, runs)| {
            fuzz::case("evaluation", move || -> Result<(), TestCaseError> {
                if let Some(value) = fuzz::counted(nees(&e, &p)) {
                    prop_assert!(value.is_finite() && value >= 0.0);
                }
                if let Some(value) = fuzz::counted(chi_square_quantile(z, dof)) {
                    prop_assert!(value.is_finite() && value >= 0.0);
                }
                if let Some((lower, upper)) = fuzz::counted(chi_square_cdf(z, dof)) {
                    prop_assert!((0.0..=1.0).contains(&lower) && (0.0..=1.0).contains(&upper));
                    prop_assert!((lower + upper - 1.0).abs() < 1e-12, "{lower} + {upper}");
                }
                if let Some((low, high)) = fuzz::counted(chi_square_band(dim)) {
                    prop_assert!(low.is_finite() && high.is_finite() && 0.0 <= low && low < high);
                }
                if let Some((low, high)) = fuzz::counted(average_nees_band(dim, runs)) {
                    prop_assert!(low.is_finite() && high.is_finite() && low <= high);
                }
                if let Some(value) = circular_consistency(z, dof) {
                    prop_assert!(value.is_finite() && value >= 0.0);
                }
                Ok(())
            });
        },
    );
}

// The regressions, each of which panicked, aborted, hung or returned a wrong value before.

/// Unnormalised weights used to be multiplied by N unchecked: `[1e300]` overflowed the capacity and
/// `[1e10, 0]` asked for 80 GB.
#[test]
fn resampling_normalises_its_weights_before_allocating() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for scheme in SCHEMES {
        assert_eq!(
            fuzz::quick("resample [1e300]", || resample_indices(
                &[1e300],
                1,
                scheme,
                &mut rng
            )),
            Ok(vec![0])
        );
        assert_eq!(
            fuzz::quick("resample [1e10, 0]", || resample_indices(
                &[1e10, 0.0],
                1,
                scheme,
                &mut rng
            )),
            Ok(vec![0])
        );
        assert_eq!(
            resample_indices(&[f64::MAX, f64::MAX], 2, scheme, &mut rng)
                .unwrap()
                .len(),
            2
        );
        assert!(matches!(
            fuzz::quick("resample to usize::MAX", || resample_indices(
                &[1.0],
                usize::MAX,
                scheme,
                &mut rng
            )),
            Err(OperatorError::TooLarge { .. })
        ));
    }
}

#[test]
fn containers_refuse_sizes_before_allocating() {
    assert!(matches!(
        fuzz::quick("CircularGrid::uniform(usize::MAX)", || {
            CircularGrid::uniform(usize::MAX, ())
        }),
        Err(OperatorError::TooLarge { .. })
    ));
    assert!(matches!(
        CircularGrid::uniform(MAX_ELEMENTS + 1, 0.0),
        Err(OperatorError::TooLarge { .. })
    ));
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(0.0), Matrix1::new(1.0)).unwrap();
    assert!(matches!(
        RtsSmoother::with_capacity(prior, usize::MAX),
        Err(OperatorError::TooLarge { .. })
    ));
    assert!(matches!(
        average_nees_band(usize::MAX, 2),
        Err(OperatorError::TooLarge { .. })
    ));
}

/// Log-likelihoods of −1e300 (or −1e15) used to absorb the normalisation: weights [1, 1], ESS 0.5.
#[test]
fn log_weights_stay_normalised_at_huge_offsets() {
    for offset in [-1e300, -1e15, 1e300] {
        let set =
            ParticleSet::from_log_weighted_samples(vec![0.0, 1.0], &[offset, offset]).unwrap();
        assert_eq!(set.weights(), vec![0.5, 0.5], "{offset}");
        assert_eq!(set.effective_sample_size(), 2.0);
        let mut set =
            ParticleSet::from_weighted_samples(vec![0.0, 1.0, 2.0], &[0.6, 0.3, 0.1]).unwrap();
        let constant = Reweight(LikelihoodFn::new(|_: &f64, (): &()| offset));
        let step = fuzz::quick("condition at a huge offset", || {
            set.condition_in_place(&constant, &())
        })
        .unwrap();
        assert_eq!(step.log_evidence, offset);
        for (w, expected) in set.weights().iter().zip([0.6, 0.3, 0.1]) {
            assert!((w - expected).abs() < 1e-15, "{offset}: {w} vs {expected}");
        }
    }
}

/// A model that returns a point that is not finite is refused with a typed error, by the EKF, the UKF,
/// the particle set and the smoother, and nothing changes.
#[test]
fn models_returning_nan_are_refused() {
    let prior = ManifoldGaussian::new(
        Rn::new_unchecked(Vector2::new(1.0, 2.0)),
        Matrix2::identity(),
    )
    .unwrap();
    let broken = ProcessFn::new(
        |_: &Rn<f64, 2>, (): &()| Rn::new_unchecked(Vector2::new(f64::NAN, 0.0)),
        |_, ()| Matrix2::identity(),
    )
    .with_jacobian(|_, ()| Matrix2::identity());
    for step in [
        prior.propagate(&Ekf(&broken), &()),
        prior.propagate(&Ukf::new(&broken), &()),
    ] {
        assert!(
            matches!(step, Err(OperatorError::NonFinitePoint { .. })),
            "{step:?}"
        );
    }
    let mut rts = RtsSmoother::new(prior.clone());
    for _ in 0..2 {
        assert!(matches!(
            rts.propagate(&Ekf(&broken), &()),
            Err(OperatorError::NonFinitePoint { .. })
        ));
        assert!(matches!(
            rts.propagate(&Ukf::new(&broken), &()),
            Err(OperatorError::NonFinitePoint { .. })
        ));
    }
    assert_eq!(rts.filtered().len(), 1);
    assert_eq!(rts.current().mean(), prior.mean());
    let unmeasurable = MeasurementFn::new(
        |x: &Rn<f64, 2>| Vector1::new(if x.coords()[0] == 1.0 { 0.0 } else { f64::NAN }),
        |_| Matrix1::new(1.0),
    );
    assert!(matches!(
        prior.condition(&Ukf::new(&unmeasurable), &Vector1::new(0.0)),
        Err(OperatorError::NonFinitePoint { .. })
    ));
    let mut set = ParticleSet::from_samples(vec![So2::from_angle_unchecked(0.5); 3]).unwrap();
    let before = set.particles().to_vec();
    let moved = Cell::new(0);
    let broken_walk = SampleFn::new(|x: &So2<f64>, (): &(), _: &mut dyn RngCore| {
        moved.set(moved.get() + 1);
        finite_point(if moved.get() == 2 {
            So2::from_cos_sin_unchecked(f64::NAN, 0.0)
        } else {
            x.retract(&Vector1::new(1.0))
        })
    });
    let step = set.propagate_in_place(
        &Sampled::new(broken_walk, ChaCha8Rng::seed_from_u64(4)),
        &(),
    );
    assert!(matches!(step, Err(OperatorError::NonFinitePoint { .. })));
    assert_eq!(set.particles(), &before[..]);
}

/// Sigma points whose weighted mean does not converge (a negative centre weight extrapolating across
/// the circle) give the manifold layer's error with the UKF's context, not a wrong mean.
#[test]
fn a_mean_that_does_not_converge_is_an_error() {
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(0.0), Matrix1::new(1.0)).unwrap();
    // α = 0.5 in one dimension: w₀ = −3 at the centre's image 0, 2 and 2 at the others' image 3.
    let split = ProcessFn::new(
        |x: &So2<f64>, (): &()| So2::from_angle_unchecked(if x.angle() == 0.0 { 0.0 } else { 3.0 }),
        |_, ()| Matrix1::new(0.1),
    );
    let ukf = Ukf::with_scaling(&split, 0.5, 2.0, 0.0).unwrap();
    let error = prior.propagate(&ukf, &()).unwrap_err();
    assert!(
        matches!(
            error,
            OperatorError::Manifold {
                source: liebayes_manifolds::ManifoldError::MeanNotConverged { .. },
                ..
            }
        ),
        "{error:?}"
    );
    assert!(error.to_string().contains("sigma points"), "{error}");
}

#[test]
fn unscented_scaling_is_refused_outside_its_range() {
    let model = ();
    for (alpha, beta, kappa) in [
        (1e-200, 2.0, 0.0),
        (0.0, 2.0, 0.0),
        (1e7, 2.0, 0.0),
        (1.0, 2.0, -1.0),
        (1.0, 2.0, 1e7),
        (1.0, 1e7, 0.0),
        (1e-6, 2.0, -0.5),
        (1.0, f64::NAN, 0.0),
    ] {
        assert!(
            Ukf::<_, 0>::with_scaling(model, alpha, beta, kappa).is_err(),
            "{alpha} {beta} {kappa}"
        );
    }
    assert!(Ukf::<_, 0>::with_scaling(model, 1e-3, 2.0, 0.0).is_ok());
}

/// An indefinite noise covariance with a non-negative diagonal used to be accepted.
#[test]
fn linear_models_need_positive_semi_definite_noise() {
    let indefinite = Matrix2::new(1.0, 2.0, 2.0, 1.0);
    assert!(matches!(
        LinearProcess::new(Matrix2::identity(), indefinite),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(LinearMeasurement::new(Matrix2::identity(), indefinite).is_err());
    // Singular is fine (a deterministic direction), and so are subnormal and huge scales.
    let singular = Matrix2::new(1.0, 1.0, 1.0, 1.0);
    for scale in [1.0, 1e300, 5e-324] {
        assert!(LinearProcess::new(Matrix2::identity(), singular * scale).is_ok());
    }
    assert!(RotatedMeasurement::new(SMatrix::<f64, 2, 2>::identity(), 1e-200).is_err());
}

/// A log evidence below −f64::MAX (a particle of log weight −1e308 holding the largest likelihood,
/// −1e308) used to be returned as −∞ beside weights that were updated; the harness's long run found
/// it. It is an error now, and the weights are unchanged.
#[test]
fn a_log_evidence_below_the_range_is_an_error() {
    let mut set = ParticleSet::from_log_weighted_samples(vec![0.0, 1.0], &[-1e308, 0.0]).unwrap();
    let before = set.log_weights().to_vec();
    let tiny = Reweight(LikelihoodFn::new(|x: &f64, (): &()| {
        if *x == 0.0 { -1e308 } else { f64::NEG_INFINITY }
    }));
    let step = set.condition_in_place(&tiny, &());
    assert!(
        matches!(step, Err(OperatorError::NonFinite { .. })),
        "{step:?}"
    );
    assert_eq!(set.log_weights(), &before[..]);
    let mut grid =
        CircularGrid::from_log_density(2, |t| if t == 0.0 { -1e308 } else { 0.0 }, |_| ()).unwrap();
    let before = grid.log_weights().to_vec();
    let tiny = Reweight(LikelihoodFn::new(|t: &So2<f64>, (): &()| {
        if t.angle() == 0.0 {
            -1e308
        } else {
            f64::NEG_INFINITY
        }
    }));
    assert!(grid.condition_in_place(&tiny, &()).is_err());
    assert_eq!(grid.log_weights(), &before[..]);
}

/// A process model whose own `propagate_covariance` (a sparse override) returns a finite
/// prediction but a NaN cross-covariance: the EKF's prediction is an error (it returned the NaN
/// cross-covariance, which a smoother stored and could then neither smooth nor read back).
#[test]
fn a_non_finite_cross_covariance_is_an_error() {
    struct Sparse;
    impl liebayes_operators::ProcessModel<Rn<f64, 1>, 1> for Sparse {
        type Input = ();
        fn transition(&self, x: &Rn<f64, 1>, (): &()) -> Rn<f64, 1> {
            *x
        }
        fn noise(&self, _: &Rn<f64, 1>, (): &()) -> Matrix1<f64> {
            Matrix1::new(0.1)
        }
        fn propagate_covariance(
            &self,
            _: &Rn<f64, 1>,
            (): &(),
            p: &Matrix1<f64>,
        ) -> (Matrix1<f64>, Matrix1<f64>) {
            (*p, Matrix1::new(f64::NAN))
        }
    }
    let prior =
        ManifoldGaussian::new(Rn::new_unchecked(Vector1::new(0.0)), Matrix1::new(1.0)).unwrap();
    let mut rts = RtsSmoother::new(prior);
    let before = rts.clone();
    assert!(matches!(
        rts.propagate(&Ekf(&Sparse), &()),
        Err(OperatorError::NonFinite { .. })
    ));
    assert_eq!(rts, before);
}
