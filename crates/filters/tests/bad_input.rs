//! Bad input never panics, hangs, aborts or silently yields NaN in the azimuth and
//! angle-of-arrival applications: the models, the exact filter, every baseline, the scenarios and
//! the study are fed NaN, ±∞, ±MAX, subnormals, zeros, singular and indefinite covariances and huge
//! sizes, each call on its own thread under a time limit. A call must return an error or a finite
//! result (the exact filter's covariance positive definite), and a filter must be exactly as it was
//! after a step that failed. The fixed cases at the end of the azimuth part are the regressions of
//! reported failures (`LIEBAYES_FUZZ_CASES` runs the properties long).

use liebayes_densities::{Gaussian, ManifoldGaussian};
use liebayes_experiments::{
    Estimator, ExperimentError, MAX_EPOCHS, MAX_RUNS, MAX_STUDY_EPOCHS, Recursive, RecursiveFilter,
    Scenario, Shard, StepOf, StepReport, Study, replay,
};
use liebayes_filters::aoa::{
    Anchor, AngleNoise, AzEl, AzElModel, DataModel, PositionEstimate, Prior, RandomWalk,
    SquareTrack, TrackConfig, UnitVectorModel, angle_ekf, angle_iterated_ekf,
    angle_particle_filter, angle_ukf, square_track_anchors, vmf_ekf, vmf_iterated_ekf,
    vmf_particle_filter, vmf_ukf,
};
use liebayes_filters::azimuth::{
    AzimuthDensity, AzimuthEstimate, AzimuthMoments, AzimuthScenario, AzimuthScorer, Config,
    Method, Motion, PositionAzimuth, PositionMeasurement, VelocityInput, VelocityProcess, ekf,
    exact, grid_filter, log_joint, marginalized_filter, particle_filter, ukf,
};
use liebayes_operators::grid::CircularGrid;
use liebayes_operators::particle::ParticleSet;
use liebayes_operators::{Condition, MAX_ELEMENTS, OperatorError, Propagate};
use liebayes_reference::fuzz::{self, size, value};
use nalgebra::Vector3;
use nalgebra::{Cholesky, Matrix2, Vector2};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::fmt::Debug;

fn vector() -> impl Strategy<Value = Vector2<f64>> {
    (value(), value()).prop_map(|(x, y)| Vector2::new(x, y))
}

/// Nasty 2 × 2 matrices, their symmetric parts (often indefinite) and singular `v vᵀ`.
fn covariance() -> impl Strategy<Value = Matrix2<f64>> {
    prop_oneof![
        (vector(), vector()).prop_map(|(a, b)| Matrix2::from_columns(&[a, b])),
        (value(), value(), value()).prop_map(|(p, q, r)| Matrix2::new(p, q, q, r)),
        vector().prop_map(|v| v * v.transpose()),
    ]
}

/// Mostly ordinary positive values, sometimes nasty ones: so that configurations are often valid.
fn mostly_valid() -> impl Strategy<Value = f64> {
    prop_oneof![3 => 0.01..2.0_f64, 1 => value()]
}

/// Mostly small counts, sometimes nasty ones.
fn mostly_small() -> impl Strategy<Value = usize> {
    prop_oneof![3 => 1..12_usize, 1 => size(MAX_ELEMENTS)]
}

fn finite<'a>(values: impl IntoIterator<Item = &'a f64>) -> bool {
    values.into_iter().all(|v| v.is_finite())
}

/// The models of a case: the fuzzed ones where they are valid, ordinary ones otherwise.
fn case_models(q: f64, sigma_m: f64) -> (VelocityProcess, PositionMeasurement) {
    (
        VelocityProcess::new(q).unwrap_or(VelocityProcess::new(0.1).unwrap()),
        PositionMeasurement::new(sigma_m).unwrap_or(PositionMeasurement::new(1.0).unwrap()),
    )
}

/// The exact filter's estimate is finite and Cov r symmetric with eigenvalues at least σ² up to
/// the rounding of its entries (`m ± h` in closed form, on the matrix scaled to unit size); it is
/// then positive definite in floating point too wherever its condition number is below 1e12. The
/// filter's estimator, which refuses moments that overflow, accepts it.
fn sound(density: &AzimuthDensity) -> Result<(), TestCaseError> {
    let eta = density.eta();
    prop_assert!(eta.x.hypot(eta.y).is_finite());
    let e = density.estimate();
    prop_assert!(e.azimuth.is_none_or(|a| a.angle().is_finite()));
    prop_assert!((0.0..=1.0).contains(&e.rho));
    prop_assert!(e.circular_variance >= 0.0);
    prop_assert!(e.sigma_a().is_none_or(|s| s.is_finite() && s >= 0.0));
    prop_assert!(finite(e.mean_r.iter()) && finite(e.cov_r.iter()));
    let cov = e.cov_r;
    prop_assert_eq!(cov[(0, 1)], cov[(1, 0)]);
    let scale = cov.amax();
    let unit = cov / scale;
    let (m, h) = (
        0.5 * (unit[(0, 0)] + unit[(1, 1)]),
        (0.5 * (unit[(0, 0)] - unit[(1, 1)])).hypot(unit[(0, 1)]),
    );
    let sigma2 = density.sigma2();
    prop_assert!(
        (m - h) * scale >= sigma2 * (1.0 - 1e-9) - 1e-14 * scale,
        "Cov r {cov:?} has eigenvalue {} below sigma^2 {sigma2}",
        (m - h) * scale
    );
    if scale <= 1e12 * sigma2 {
        prop_assert!(Cholesky::new(cov).is_some(), "Cov r {cov:?}");
    }
    prop_assert!(AzimuthMoments.estimate(density).is_ok());
    let _ = density.azimuth();
    Ok(())
}

/// The state of a filter's density as text, to compare it before and after a step that failed
/// (text, because a NaN would not equal itself): the numbers it holds, not its scratch buffers.
trait Snapshot {
    fn snapshot(&self) -> String;
}

impl Snapshot for AzimuthDensity {
    fn snapshot(&self) -> String {
        format!("{self:?}")
    }
}

impl Snapshot for ManifoldGaussian<PositionAzimuth, 3> {
    fn snapshot(&self) -> String {
        format!("{self:?}")
    }
}

impl<X: Clone + Debug> Snapshot for ParticleSet<X> {
    fn snapshot(&self) -> String {
        format!("{:?} {:?}", self.particles(), self.log_weights())
    }
}

impl<X: Debug> Snapshot for CircularGrid<X> {
    fn snapshot(&self) -> String {
        format!("{:?} {:?}", self.log_weights(), self.cells())
    }
}

/// A filter built from nasty parameters (`Err(TooLarge)` only if its size is not small), then
/// updated with each z and propagated with `input` after it: a failed step leaves the density as
/// it was; a successful update has a finite log evidence and NIS; an estimate is finite (or an
/// error).
fn exercise<D, P, M, E>(
    filter: Result<Recursive<D, P, M, E>, OperatorError>,
    small: bool,
    input: &VelocityInput,
    zs: &[Vector2<f64>],
) -> Result<(), TestCaseError>
where
    D: Propagate<P, Input = VelocityInput> + Condition<M, Measurement = Vector2<f64>> + Snapshot,
    <D as Condition<M>>::Report: StepReport,
    E: Estimator<D, Estimate = AzimuthEstimate>,
{
    if let Err(OperatorError::TooLarge { .. }) = &filter {
        prop_assert!(!small);
    }
    let Some(mut filter) = fuzz::counted(filter) else {
        return Ok(());
    };
    for z in zs {
        let before = filter.density().snapshot();
        if let Some(update) = fuzz::counted(filter.update(z)) {
            prop_assert!(update.log_evidence.is_finite());
            prop_assert!(
                update
                    .nis
                    .is_none_or(|n| n.value.is_finite() && n.value >= 0.0)
            );
        } else {
            prop_assert_eq!(&before, &filter.density().snapshot());
        }
        let before = filter.density().snapshot();
        if fuzz::counted(filter.predict(input)).is_none() {
            prop_assert_eq!(&before, &filter.density().snapshot());
        }
        if let Some(e) = fuzz::counted(filter.estimate()) {
            prop_assert!(finite(e.mean_r.iter()) && finite(e.cov_r.iter()));
            prop_assert!((0.0..=1.0).contains(&e.rho));
            prop_assert!(e.azimuth.is_none_or(|a| a.angle().is_finite()));
        }
    }
    Ok(())
}

/// Replays a filter through a simulated trajectory, scored by [`AzimuthScorer`]: where it runs to
/// the end, every epoch is scored and its position errors are finite.
fn replayed<F>(
    filter: Result<F, OperatorError>,
    trajectory: &[StepOf<AzimuthScenario>],
    epochs: usize,
) -> Result<(), TestCaseError>
where
    F: RecursiveFilter<
            Input = VelocityInput,
            Measurement = Vector2<f64>,
            Estimate = AzimuthEstimate,
        >,
{
    let Some(mut filter) = fuzz::counted(filter) else {
        return Ok(());
    };
    if let Some(scores) = fuzz::counted(replay(
        &mut filter,
        trajectory.iter().cloned(),
        &AzimuthScorer,
    )) {
        prop_assert_eq!(scores.epochs(), epochs);
        for k in 0..epochs {
            for metric in ["x_error", "y_error"] {
                prop_assert!(
                    scores.get(metric, k).is_some_and(f64::is_finite),
                    "{metric} at {k}"
                );
            }
        }
    }
    Ok(())
}

#[test]
fn models() {
    fuzz::run(
        "models",
        (value(), value(), covariance()),
        |(q, sigma, noise)| {
            fuzz::case("models", move || -> Result<(), TestCaseError> {
                if let Some(process) = fuzz::counted(VelocityProcess::new(q)) {
                    prop_assert!(
                        process.noise_density().is_finite() && process.noise_density() >= 0.0
                    );
                }
                for measurement in [
                    PositionMeasurement::new(sigma),
                    PositionMeasurement::isotropic_bound(&noise),
                ]
                .into_iter()
                .flatten()
                {
                    let v = measurement.variance();
                    prop_assert!(v.is_normal() && v > 0.0 && v <= 1e300);
                }
                Ok(())
            });
        },
    );
}

/// The exact filter from nasty parameters, stepped with nasty models and data: by value
/// (`log_evidence`, `conditioned`) and in place (`condition_in_place`, `propagate_in_place`, the
/// steps of its `Recursive` filter), which must agree.
#[test]
fn exact_filter() {
    fuzz::run(
        "exact_filter",
        (
            vector(),
            vector(),
            vector(),
            value(),
            vector(),
            value(),
            value(),
            value(),
            proptest::collection::vec(vector(), 3),
            proptest::collection::vec(vector(), 3),
            proptest::collection::vec(value(), 3),
        ),
        |(eta, a, c, sigma2, r0, sigma0, q, sigma_m, zs, velocities, dts)| {
            fuzz::case("exact_filter", move || -> Result<(), TestCaseError> {
                if let Some(d) = fuzz::counted(AzimuthDensity::new(r0, sigma0)) {
                    sound(&d)?;
                }
                let Ok(mut density) = AzimuthDensity::from_parts(eta, a, c, sigma2)
                    .or_else(|_| AzimuthDensity::new(r0, sigma0))
                else {
                    return Ok(());
                };
                sound(&density)?;
                let (process, measurement) = case_models(q, sigma_m);
                for ((z, v), dt) in zs.iter().zip(&velocities).zip(&dts) {
                    let evidence = fuzz::counted(density.log_evidence(&measurement, z));
                    prop_assert!(evidence.is_none_or(f64::is_finite));
                    let posterior = fuzz::counted(density.conditioned(&measurement, z));
                    if let Some(posterior) = &posterior {
                        sound(posterior)?;
                    }
                    let before = density;
                    if let Some(step) = fuzz::counted(density.condition_in_place(&measurement, z)) {
                        prop_assert_eq!(Some(step.log_evidence), evidence);
                        prop_assert_eq!(Some(density), posterior);
                    } else {
                        prop_assert_eq!(before, density);
                    }
                    sound(&density)?;
                    let before = density;
                    let input = VelocityInput {
                        velocity: *v,
                        dt: *dt,
                    };
                    if fuzz::counted(density.propagate_in_place(&process, &input)).is_none() {
                        prop_assert_eq!(before, density);
                    }
                    sound(&density)?;
                }
                if let Some(composite) = fuzz::counted(density.to_composite()) {
                    prop_assert!(finite(composite.covariance().iter()));
                }
                Ok(())
            });
        },
    );
}

/// Every filter from a nasty prior and nasty models, stepped with nasty data.
#[test]
fn baselines() {
    fuzz::run(
        "baselines",
        (
            size(MAX_ELEMENTS),
            vector(),
            value(),
            vector(),
            vector(),
            value(),
            value(),
            value(),
        ),
        |(n, r0, sigma0, z, v, dt, q, sigma_m)| {
            fuzz::case("baselines", move || -> Result<(), TestCaseError> {
                let rng = ChaCha8Rng::seed_from_u64(2);
                let small = (1..=40).contains(&n);
                let (p, m) = case_models(q, sigma_m);
                let input = VelocityInput { velocity: v, dt };
                let zs = [z, z * 0.5];
                exercise(
                    particle_filter(n, p, m, r0, sigma0, rng.clone()),
                    small,
                    &input,
                    &zs,
                )?;
                exercise(
                    marginalized_filter(n, p, m, r0, sigma0, rng),
                    small,
                    &input,
                    &zs,
                )?;
                exercise(grid_filter(n, p, m, r0, sigma0), small, &input, &zs)?;
                exercise(ekf(p, m, r0, sigma0), true, &input, &zs)?;
                exercise(ukf(p, m, r0, sigma0), true, &input, &zs)?;
                exercise(exact(p, m, r0, sigma0), true, &input, &zs)
            });
        },
    );
}

/// A shard of a few runs of a study of `runs` runs: a study of up to 2⁴⁰ runs is accepted, and
/// run here one shard at a time.
fn a_few_of(runs: u64) -> Shard {
    Shard::new(1, runs.div_ceil(8).max(1)).unwrap()
}

#[test]
fn scenarios_and_studies() {
    fuzz::run(
        "scenarios_and_studies",
        (
            mostly_valid(),
            mostly_valid(),
            mostly_valid(),
            mostly_valid(),
            mostly_small(),
            mostly_small(),
            mostly_small(),
            value(),
        ),
        |(sigma0, sigma_m, q, dt, measure_every, steps, runs, duration)| {
            fuzz::case(
                "scenarios_and_studies",
                move || -> Result<(), TestCaseError> {
                    if let Some(count) = fuzz::counted(Config::steps_for(duration, dt)) {
                        prop_assert!((1..=MAX_ELEMENTS).contains(&count));
                    }
                    let config = Config {
                        sigma0,
                        sigma_m,
                        q,
                        dt,
                        measure_every,
                        steps,
                    };
                    // A scenario refuses what `validate` refuses, and beyond it only a run
                    // longer than its motion lets the filters resolve.
                    let valid = config.validate().is_ok();
                    let (circle, line) = (
                        AzimuthScenario::new(Motion::Circle, config),
                        AzimuthScenario::new(Motion::Line, config),
                    );
                    for scenario in [&circle, &line] {
                        if let Err(error) = scenario {
                            let message = error.to_string();
                            prop_assert!(
                                !valid || message.contains("distance the motion covers"),
                                "{message}"
                            );
                        }
                    }
                    prop_assert!(circle.is_err() || valid);
                    let circle = fuzz::counted(circle);
                    let Some(line) = fuzz::counted(line) else {
                        return Ok(());
                    };
                    prop_assert!(valid);
                    let mut rng = ChaCha8Rng::seed_from_u64(3);
                    let mut count = 0;
                    for step in line.simulate(&mut rng).unwrap() {
                        count += 1;
                        prop_assert!(step.truth.second().angle().is_finite());
                        prop_assert!(finite(step.truth.first().coords().iter()));
                        prop_assert!(step.input.validate().is_ok());
                        prop_assert!(step.measurement.is_none_or(|z| finite(z.iter())));
                    }
                    prop_assert_eq!(count, steps);

                    let Some(circle) = circle else {
                        return Ok(());
                    };
                    let trajectory: Vec<_> = circle.simulate(&mut rng).unwrap().collect();
                    let (process, measurement) = (
                        VelocityProcess::new(q).unwrap(),
                        PositionMeasurement::new(sigma_m).unwrap(),
                    );
                    let (r0, epochs) = (Vector2::zeros(), circle.epochs());
                    replayed(exact(process, measurement, r0, sigma0), &trajectory, epochs)?;
                    replayed(ekf(process, measurement, r0, sigma0), &trajectory, epochs)?;
                    let pf = particle_filter(5, process, measurement, r0, sigma0, rng);
                    replayed(pf, &trajectory, epochs)?;

                    let runs = u64::try_from(runs).unwrap_or(u64::MAX);
                    let Some(study) =
                        fuzz::counted(Study::new("exact, line", runs, 5, a_few_of(runs)))
                    else {
                        prop_assert!(runs == 0 || runs > MAX_RUNS);
                        return Ok(());
                    };
                    if let Some(summary) =
                        fuzz::counted(Method::Exact.study(&line, &study, &|_| {}))
                    {
                        let covered = study.shard().runs(runs);
                        prop_assert_eq!(summary.run_count(), covered.end - covered.start);
                        prop_assert_eq!(summary.label().runs, runs);
                        prop_assert!(summary.timing().mean().is_none_or(f64::is_finite));
                    }
                    Ok(())
                },
            );
        },
    );
}

// The regressions, each of which panicked, hung or returned NaN before.

/// σ_m = 1e-200 squared to 0; two updates then gave η = NaN, `azimuth()` panicked and `estimates()`
/// hung. The constructor now refuses it, and the smallest accepted σ_m keeps every step finite.
#[test]
fn a_measurement_noise_that_squares_to_zero_is_refused() {
    assert!(matches!(
        fuzz::quick("PositionMeasurement::new(1e-200)", || {
            PositionMeasurement::new(1e-200)
        }),
        Err(OperatorError::OutOfRange { .. })
    ));
    let tiny = PositionMeasurement::new(1.5e-154).unwrap();
    let mut density = AzimuthDensity::new(Vector2::new(1.0, 2.0), 1.0).unwrap();
    for _ in 0..3 {
        // Each step either succeeds with a density in range or fails and changes nothing.
        let before = density;
        if fuzz::quick("update", || {
            density.condition_in_place(&tiny, &Vector2::new(3.0, 4.0))
        })
        .is_err()
        {
            assert_eq!(before, density);
        }
        let e = fuzz::quick("estimates", || density.estimate());
        assert!(e.cov_r.iter().all(|v| v.is_finite()));
        let _ = fuzz::quick("azimuth", || density.azimuth());
    }
}

/// A measurement far more precise than the prior (σ_m² below ε σ²) rounded `1 − k` to zero, and with
/// it σ²: every later Cov r was singular. `1 − k` is now σ_m²/S.
#[test]
fn a_precise_measurement_keeps_a_positive_variance() {
    let precise = PositionMeasurement::new(1e-9).unwrap();
    let mut density = AzimuthDensity::new(Vector2::new(1.0, 2.0), 1.0).unwrap();
    density
        .condition_in_place(&precise, &Vector2::new(3.0, 4.0))
        .unwrap();
    let expected = 1e-18 / (1.0 + 1e-18);
    assert!(
        (density.sigma2() / expected - 1.0).abs() < 1e-15,
        "{}",
        density.sigma2()
    );
    density
        .condition_in_place(&precise, &Vector2::new(3.0, 4.0))
        .unwrap();
    assert!(Cholesky::new(density.estimate().cov_r).is_some());
}

/// A reading far from the prediction (a corrupt sample 1.1e29 m off, found by the filter law
/// suite at another seed) concentrated the azimuth to κ = 4e29 and was taken: the estimate's
/// position covariance, σ² I plus terms of |c|²/κ = 1.8e27 m², was singular to rounding. Each
/// update now either keeps an estimate whose covariance factorises or is refused, the density
/// unchanged.
#[test]
fn a_reading_far_off_keeps_the_estimate_positive_definite_or_is_refused() {
    let model = PositionMeasurement::new(1.0).unwrap();
    let mut start = AzimuthDensity::new(Vector2::new(1.0, 2.0), 1.0).unwrap();
    start
        .condition_in_place(&model, &Vector2::new(3.0, 4.0))
        .unwrap();
    let mut refused = 0;
    for exponent in 0..=149 {
        let mut density = start;
        let z = Vector2::new(3.0, 1.1 * 10f64.powi(exponent));
        match density.condition_in_place(&model, &z) {
            Ok(_) => assert!(
                Cholesky::new(density.estimate().cov_r).is_some(),
                "y = 1.1e{exponent}: {:?}",
                density.estimate()
            ),
            Err(e) => {
                assert_eq!(density, start, "y = 1.1e{exponent}");
                assert!(!e.to_string().is_empty());
                refused += 1;
            }
        }
    }
    // The readings from 1.1e14 m on are refused (the smaller eigenvalue lost to rounding, or
    // further out an overflow); those before are taken. Without the check, the one 1.1e18 m off
    // was taken with a singular covariance.
    assert_eq!(refused, 136);
}

#[test]
fn constructors_refuse_derived_quantities_that_overflow() {
    assert!(
        fuzz::quick("VelocityProcess::new(1e200)", || VelocityProcess::new(
            1e200
        ))
        .is_err()
    );
    assert!(VelocityProcess::new(1e-200).is_ok());
    assert!(
        fuzz::quick("AzimuthDensity::new(r0, -1)", || AzimuthDensity::new(
            Vector2::zeros(),
            -1.0
        ))
        .is_err()
    );
    assert!(AzimuthDensity::new(Vector2::zeros(), 1e-200).is_err());
    assert!(AzimuthDensity::new(Vector2::new(1e200, 0.0), 1.0).is_err());
    let (p, m, r0) = (
        VelocityProcess::new(0.1).unwrap(),
        PositionMeasurement::new(1.0).unwrap(),
        Vector2::zeros(),
    );
    let rng = ChaCha8Rng::seed_from_u64(5);
    assert!(exact(p, m, r0, -1.0).is_err());
    assert!(ekf(p, m, r0, -1.0).is_err());
    assert!(ukf(p, m, r0, -1.0).is_err());
    assert!(grid_filter(4, p, m, r0, -1.0).is_err());
    assert!(particle_filter(4, p, m, r0, -1.0, rng.clone()).is_err());
    assert!(marginalized_filter(4, p, m, r0, -1.0, rng).is_err());
    let indefinite = Matrix2::new(1.0, 2.0, 2.0, 1.0);
    assert!(PositionMeasurement::isotropic_bound(&indefinite).is_err());
}

#[test]
fn baselines_refuse_huge_counts_before_drawing() {
    let rng = ChaCha8Rng::seed_from_u64(6);
    let (p, m, r0) = (
        VelocityProcess::new(0.1).unwrap(),
        PositionMeasurement::new(1.0).unwrap(),
        Vector2::zeros(),
    );
    for n in [usize::MAX, liebayes_operators::MAX_ELEMENTS + 1] {
        assert!(matches!(
            fuzz::quick("marginalized_filter(huge)", || {
                marginalized_filter(n, p, m, r0, 1.0, rng.clone())
            }),
            Err(OperatorError::TooLarge { .. })
        ));
        assert!(matches!(
            particle_filter(n, p, m, r0, 1.0, rng.clone()),
            Err(OperatorError::TooLarge { .. })
        ));
        assert!(matches!(
            grid_filter(n, p, m, r0, 1.0),
            Err(OperatorError::TooLarge { .. })
        ));
        for method in [
            Method::Particle(n),
            Method::Grid(n),
            Method::Marginalized(n),
        ] {
            assert!(matches!(
                method.validate(),
                Err(OperatorError::TooLarge { .. })
            ));
        }
    }
    // A study of a method of that size is refused before any run.
    let scenario = AzimuthScenario::new(Motion::Line, Config::default()).unwrap();
    let study = Study::new("PF huge, line", 4, 6, Shard::WHOLE).unwrap();
    assert!(
        fuzz::quick("Method::study(PF huge)", || Method::Particle(usize::MAX)
            .study(&scenario, &study, &|_| {}))
        .is_err()
    );
}

/// `steps` from a saturated cast used to reach `Vec::with_capacity(usize::MAX)`. Runs are streamed
/// now; the sizes are still refused before anything is drawn: the steps by the scenario, the
/// epochs of a run beyond what a replay scores, and beyond what a study summarises.
#[test]
fn simulations_refuse_sizes_before_allocating() {
    let config = Config {
        steps: usize::MAX,
        ..Config::default()
    };
    assert!(matches!(
        fuzz::quick("AzimuthScenario::new(steps = usize::MAX)", || {
            AzimuthScenario::new(Motion::Line, config)
        }),
        Err(OperatorError::TooLarge { .. })
    ));
    assert!(matches!(
        fuzz::quick("steps_for(1e300, 1e-300)", || Config::steps_for(
            1e300, 1e-300
        )),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(Config::steps_for(500.0, 0.1) == Ok(5000));
    assert!(
        Config {
            measure_every: 0,
            ..Config::default()
        }
        .validate()
        .is_err()
    );
    let every_step = |steps| {
        AzimuthScenario::new(
            Motion::Line,
            Config {
                steps,
                measure_every: 1,
                ..Config::default()
            },
        )
        .unwrap()
    };
    let longest = every_step(MAX_ELEMENTS);
    assert!(longest.epochs() > MAX_EPOCHS);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    assert!(matches!(
        fuzz::quick("simulate(epochs > MAX_EPOCHS)", || longest
            .simulate(&mut rng)
            .map(|_| ())),
        Err(ExperimentError::OutOfRange { .. })
    ));
    let study = Study::new("exact, line", 4, 7, Shard::WHOLE).unwrap();
    assert!(matches!(
        fuzz::quick("study(epochs > MAX_STUDY_EPOCHS)", || Method::Exact.study(
            &every_step(MAX_STUDY_EPOCHS + 1),
            &study,
            &|_| {}
        )),
        Err(ExperimentError::OutOfRange { .. })
    ));
}

/// η = (MAX, MAX) has finite components but κ = |η| = ∞: it was accepted, and every estimate was
/// NaN. It is refused, and so is any κ above the von Mises family's limit 1e300.
#[test]
fn a_concentration_that_overflows_is_refused() {
    for eta in [
        Vector2::new(f64::MAX, f64::MAX),
        Vector2::new(-f64::MAX, f64::MAX),
    ] {
        assert!(matches!(
            AzimuthDensity::from_parts(eta, Vector2::zeros(), Vector2::zeros(), 1.0),
            Err(OperatorError::OutOfRange { .. })
        ));
    }
    let largest = AzimuthDensity::from_parts(
        Vector2::new(0.6e300, 0.8e300),
        Vector2::zeros(),
        Vector2::zeros(),
        1.0,
    )
    .unwrap();
    let kappa = largest.eta().x.hypot(largest.eta().y);
    let e = largest.estimate();
    assert!((kappa / 1e300 - 1.0).abs() < 1e-15 && e.sigma_a().unwrap() > 0.0);
}

/// A case the harness found: a prior at 1e300 m, a step of 1e300 s and a subnormal velocity, through
/// every filter. Each step now fails with an error and leaves the filter as it was, or gives a
/// finite estimate.
#[test]
fn baselines_survive_a_prior_far_away_and_a_huge_step() {
    let (r0, sigma0) = (
        Vector2::new(f64::MIN_POSITIVE, 1e300),
        1.835_701_760_938_207_8,
    );
    let rng = ChaCha8Rng::seed_from_u64(8);
    let p = VelocityProcess::new(8.002_486_246_475_813).unwrap();
    let m = PositionMeasurement::new(1.0).unwrap();
    let input = VelocityInput {
        velocity: Vector2::new(1e-160, 0.0),
        dt: 1e300,
    };
    let zs = [Vector2::zeros()];
    exercise(
        particle_filter(6, p, m, r0, sigma0, rng.clone()),
        true,
        &input,
        &zs,
    )
    .unwrap();
    exercise(
        marginalized_filter(6, p, m, r0, sigma0, rng),
        true,
        &input,
        &zs,
    )
    .unwrap();
    exercise(grid_filter(6, p, m, r0, sigma0), true, &input, &zs).unwrap();
    exercise(ekf(p, m, r0, sigma0), true, &input, &zs).unwrap();
    exercise(ukf(p, m, r0, sigma0), true, &input, &zs).unwrap();
    exercise(exact(p, m, r0, sigma0), true, &input, &zs).unwrap();
}

// The angle-of-arrival models, filters and track.

fn vector3() -> impl Strategy<Value = Vector3<f64>> {
    (value(), value(), value()).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn readings() -> impl Strategy<Value = [AzEl; 4]> {
    proptest::array::uniform4((value(), value()).prop_map(|(a, e)| AzEl::new(a, e)))
}

/// A step of `filter` either fails and leaves it unchanged, or leaves a finite estimate.
fn aoa_step<F>(filter: &mut F, delta: f64, z: &[AzEl; 4]) -> Result<(), TestCaseError>
where
    F: RecursiveFilter<Input = f64, Measurement = [AzEl; 4], Estimate = PositionEstimate>
        + Clone
        + PartialEq
        + std::fmt::Debug,
{
    let before = filter.clone();
    if fuzz::counted(filter.predict(&delta)).is_none() {
        prop_assert_eq!(&*filter, &before);
    }
    let before = filter.clone();
    if fuzz::counted(filter.update(z)).is_none() {
        prop_assert_eq!(&*filter, &before);
    }
    if let Some(e) = fuzz::counted(filter.estimate()) {
        prop_assert!(
            e.mean
                .iter()
                .chain(e.covariance.iter())
                .all(|v| v.is_finite())
        );
    }
    Ok(())
}

#[test]
fn aoa_models_and_kalman_filters() {
    fuzz::run(
        "aoa_kalman",
        (
            vector3(),
            value(),
            value(),
            value(),
            value(),
            value(),
            vector3(),
            value(),
            readings(),
        ),
        |(anchor, kappa, sigma, q, mean_scale, std, m0, delta, z)| {
            fuzz::case("aoa_kalman", move || -> Result<(), TestCaseError> {
                let mut anchors = square_track_anchors();
                if let Some(a) = fuzz::counted(Anchor::at(anchor)) {
                    anchors[0] = a;
                }
                let Some(prior) = fuzz::counted(Prior::new(m0 * mean_scale.abs().min(1e3), std))
                else {
                    return Ok(());
                };
                let walk = fuzz::counted(RandomWalk::new(q, q))
                    .unwrap_or(RandomWalk::new(0.5, 0.1).unwrap());
                if let Some(vmf) = fuzz::counted(UnitVectorModel::new(anchors, kappa)) {
                    if let Some(mut f) = fuzz::counted(vmf_ekf::<4, 12>(vmf, walk, &prior)) {
                        aoa_step(&mut f, delta, &z)?;
                    }
                    if let Some(mut f) = fuzz::counted(vmf_ukf::<4, 12>(vmf, walk, &prior)) {
                        aoa_step(&mut f, delta, &z)?;
                    }
                    if let Some(mut f) = fuzz::counted(vmf_iterated_ekf::<4, 12>(vmf, walk, &prior))
                    {
                        aoa_step(&mut f, delta, &z)?;
                    }
                }
                let noise = AngleNoise::Fixed {
                    sigma_az: sigma,
                    sigma_el: sigma.abs(),
                };
                if let Some(ae) = fuzz::counted(AzElModel::new(anchors, noise)) {
                    if let Some(mut f) = fuzz::counted(angle_ekf::<4, 8>(ae.clone(), walk, &prior))
                    {
                        aoa_step(&mut f, delta, &z)?;
                    }
                    if let Some(mut f) =
                        fuzz::counted(angle_iterated_ekf::<4, 8>(ae.clone(), walk, &prior))
                    {
                        aoa_step(&mut f, delta, &z)?;
                    }
                    if let Some(mut f) = fuzz::counted(angle_ukf::<4, 8>(ae, walk, &prior)) {
                        aoa_step(&mut f, delta, &z)?;
                    }
                }
                Ok(())
            });
        },
    );
}

#[test]
fn aoa_particle_filters_and_scenarios() {
    fuzz::run(
        "aoa_particles",
        (
            size(MAX_ELEMENTS),
            value(),
            vector3(),
            value(),
            value(),
            readings(),
            value(),
            value(),
        ),
        |(n, kappa, m0, std, delta, z, side, sigma)| {
            fuzz::case("aoa_particles", move || -> Result<(), TestCaseError> {
                let anchors = square_track_anchors();
                let walk = RandomWalk::new(0.5, 0.1).unwrap();
                if let Some(prior) = fuzz::counted(Prior::new(m0, std)) {
                    let rng = ChaCha8Rng::seed_from_u64(1);
                    if let Some(vmf) = fuzz::counted(UnitVectorModel::new(anchors, kappa)) {
                        if let Some(mut f) =
                            fuzz::counted(vmf_particle_filter(vmf, walk, &prior, n, rng.clone()))
                        {
                            let before = (
                                f.density().particles().to_vec(),
                                f.density().log_weights().to_vec(),
                            );
                            if fuzz::counted(f.update(&z)).is_none() {
                                prop_assert_eq!(f.density().particles(), &before.0[..]);
                                prop_assert_eq!(f.density().log_weights(), &before.1[..]);
                            }
                            let _ = fuzz::counted(f.predict(&delta));
                            let _ = fuzz::counted(f.estimate());
                        }
                    }
                    let noise = AngleNoise::Fixed {
                        sigma_az: 0.2,
                        sigma_el: 0.2,
                    };
                    let ae = AzElModel::new(anchors, noise).unwrap();
                    if let Some(mut f) =
                        fuzz::counted(angle_particle_filter(ae, walk, &prior, n, rng))
                    {
                        let _ = fuzz::counted(f.update(&z));
                        let _ = fuzz::counted(f.estimate());
                    }
                }
                let config = TrackConfig {
                    side,
                    delta: delta.abs(),
                    ..TrackConfig::default()
                };
                let data = DataModel::NormalWithFlip {
                    sigma_az: sigma,
                    sigma_el: 0.1,
                };
                if let Some(track) = fuzz::counted(SquareTrack::new(anchors, data, config)) {
                    let mut sim = ChaCha8Rng::seed_from_u64(2);
                    for s in track.simulate(&mut sim).unwrap().take(3) {
                        prop_assert!(s.truth.coords().iter().all(|v| v.is_finite()));
                        for r in s.measurement.unwrap().readings().unwrap() {
                            prop_assert!(r.check_canonical().is_ok());
                        }
                    }
                }
                Ok(())
            });
        },
    );
}

/// Equation (7) both ways: a σ or κ outside the noise ranges, or a result outside them, is an
/// error (a zero σ gave κ = inf, a negative κ σ = NaN).
#[test]
fn noise_conversions_refuse_what_they_cannot_convert() {
    use liebayes_filters::aoa::{kappa_from_sigmas, sigma_from_kappa};
    for (az, el) in [
        (0.0, 0.0),
        (-1.0, 0.1),
        (f64::NAN, 0.1),
        (0.1, f64::INFINITY),
        (1e-7, 1e-7),
        (0.1, 1e4),
    ] {
        assert!(kappa_from_sigmas(az, el).is_err(), "{az}, {el}");
    }
    let kappa = kappa_from_sigmas(0.1, 0.05).unwrap();
    assert!((kappa - 100.0).abs() < 1e-12);
    for kappa in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e-9, 1e13] {
        assert!(sigma_from_kappa(kappa).is_err(), "{kappa}");
    }
    assert!((sigma_from_kappa(100.0).unwrap() - 0.1).abs() < 1e-15);
}

/// The direction's Jacobian at the anchor, and next to it where `1/|θ − s|` overflows: `None`
/// (it was a NaN matrix, and inf at 1e-310 m).
#[test]
fn a_direction_jacobian_at_or_next_to_the_anchor_is_none() {
    let rotation = liebayes_manifolds::So3::from_axis_angle(&Vector3::z(), 0.3).unwrap();
    let anchor = Anchor::new(Vector3::zeros(), rotation).unwrap();
    for theta in [
        Vector3::zeros(),
        Vector3::new(1e-310, 0.0, 0.0),
        Vector3::new(f64::NAN, 0.0, 0.0),
    ] {
        assert!(anchor.direction_jacobian(&theta).is_none(), "{theta}");
    }
    let jacobian = anchor
        .direction_jacobian(&Vector3::new(1e-300, 2e-300, 0.0))
        .unwrap();
    assert!(jacobian.iter().all(|v| v.is_finite()));
}

/// The RMS over runs of per-run errors near 1e200: finite (the squares overflowed to inf).
#[test]
fn the_track_rmse_of_huge_errors_is_finite() {
    use liebayes_experiments::{Metric, Reduction, RunScores, StudyLabel, Summary};
    use liebayes_filters::aoa::track_rmse;
    let label = StudyLabel {
        name: "huge".into(),
        seed: 0,
        runs: 2,
    };
    let mut summary = Summary::new(label, 0..2).unwrap();
    for (run, error) in [(0, 1e200), (1, 2e200)] {
        let scores = RunScores {
            metrics: vec![Metric::new("position_error", Reduction::RootMeanSquare, "m").per_run()],
            times: vec![0.0],
            values: vec![error],
            seconds_per_step: 1e-6,
        };
        summary.add_run(run, &scores).unwrap();
    }
    let rmse = track_rmse(&summary).unwrap();
    let expected = 2.5_f64.sqrt() * 1e200;
    assert!(
        (rmse - expected).abs() <= 4.0 * f64::EPSILON * expected,
        "{rmse:e}"
    );
}

/// The motions' velocity at a time that is not finite has no value (the circle's was NaN); at
/// the largest finite time it is finite.
#[test]
fn a_motion_at_a_time_that_is_not_finite_has_no_velocity() {
    for motion in Motion::ALL {
        for t in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(motion.velocity(t).is_none(), "{motion:?} at {t}");
        }
        let v = motion.velocity(f64::MAX).unwrap();
        assert!(v.iter().all(|x| x.is_finite()), "{motion:?}");
    }
}

/// A subnormal sampling rate made a log's interval infinite and its first sample's time NaN;
/// logs, simulations and the attitude filters now take rates in [1e-3, 1e6] Hz, and say so
/// legibly. An evaluation of no logs has no mean errors (it was 0/0).
#[test]
fn attitude_rates_outside_their_range_are_refused() {
    use liebayes_filters::attitude::{
        AttitudeEkf, AttitudeParams, Evaluation, ImuLog, Madgwick, RATE_RANGE, Sensors, TalkFilter,
        TalkParams,
    };
    let samples = || vec![Vector3::new(0.0, 0.0, 9.8); 2];
    for rate in [1e-310, 0.0, -1.0, f64::NAN, 2e6] {
        assert!(
            ImuLog::new(rate, samples(), samples(), None).is_err(),
            "{rate}"
        );
        assert!(Madgwick::new(0.1, Sensors::SixD, rate).is_err(), "{rate}");
        assert!(AttitudeEkf::new(AttitudeParams::default(), Sensors::SixD, rate).is_err());
        assert!(TalkFilter::new(&TalkParams::default(), Sensors::SixD, rate).is_err());
    }
    let log = ImuLog::new(RATE_RANGE.0, samples(), samples(), None).unwrap();
    assert!(log.interval().is_finite());
    // The message shows 1e300 as that, not as its 301 digits.
    let message = AttitudeEkf::new(AttitudeParams::default(), Sensors::SixD, 1e300)
        .unwrap_err()
        .to_string();
    assert!(message.contains("is 1e300,"), "{message}");
    let empty = Evaluation {
        trials: Vec::new(),
        methods: vec!["a method".into()],
        scores: Vec::new(),
    };
    assert_eq!(empty.mean_errors(0), None);
}

/// The second audit's angle-of-arrival and estimate findings: the von Mises-Fisher likelihood of a
/// position 1e200 m away was that of a perpendicular direction (and NaN at 1.5e308); a public
/// rotation matrix of NaN converted readings into NaN directions; the adaptive table at a NaN
/// elevation, a negative circular variance and a NaN attitude covariance gave NaN or zero σ.
#[test]
fn far_positions_and_malformed_public_fields() {
    use liebayes_filters::aoa::{AdaptiveSigmas, InWorldAxes, WorldDirections};
    use liebayes_filters::attitude::{AttitudeEstimate, TalkParams};
    use liebayes_manifolds::LieGroup;
    use liebayes_operators::Conversion;
    use liebayes_operators::particle::Likelihood;
    let anchor = Anchor::new(Vector3::zeros(), liebayes_manifolds::So3::identity()).unwrap();
    let model = UnitVectorModel::new([anchor], 10.0).unwrap();
    let at = |x: Vector3<f64>, v: Vector3<f64>| {
        model.log_likelihood(
            &liebayes_manifolds::Rn::new(x).unwrap(),
            &WorldDirections([v]),
        )
    };
    let aligned = at(Vector3::new(1.0, 0.0, 0.0), Vector3::x());
    assert!(aligned.is_finite());
    assert_eq!(at(Vector3::new(1e200, 0.0, 0.0), Vector3::x()), aligned);
    let diagonal = Vector3::new(1.0, 1.0, 0.0).normalize();
    assert!((at(Vector3::new(1.5e308, 1.5e308, 0.0), diagonal) - aligned).abs() < 1e-12);
    let readings = [AzEl::new(0.1, 0.2)];
    assert!(
        InWorldAxes([nalgebra::Matrix3::from_element(f64::NAN)])
            .convert(&readings)
            .is_err()
    );
    assert!(
        InWorldAxes([nalgebra::Matrix3::identity() * 1e300])
            .convert(&readings)
            .is_err()
    );
    let table = AdaptiveSigmas::model_one(0.1, 0.1).unwrap();
    assert_eq!(table.at(f64::NAN), None);
    assert!(table.at(f64::INFINITY).is_some());
    let estimate = AzimuthEstimate {
        azimuth: None,
        rho: 0.5,
        circular_variance: -1.0,
        mean_r: nalgebra::Vector2::zeros(),
        cov_r: nalgebra::Matrix2::identity(),
    };
    assert_eq!(estimate.sigma_a(), None);
    let attitude = AttitudeEstimate {
        orientation: nalgebra::UnitQuaternion::identity(),
        covariance: Some(nalgebra::Matrix3::from_element(f64::NAN)),
    };
    assert_eq!(attitude.sigmas(), None);
    let tiny = TalkParams {
        gyro_noise: 1e-200,
        ..TalkParams::default()
    };
    assert!(tiny.validate().is_err());
}

/// The square track's helpers on malformed public fields or a non-finite arc length: errors (they
/// returned NaN points and step lengths).
#[test]
fn the_track_helpers_refuse_what_they_cannot_place() {
    let config = TrackConfig::default();
    for s in [f64::NAN, f64::INFINITY] {
        assert!(config.point_at(s).is_err());
    }
    let far = config.point_at(1e300).unwrap();
    assert!(far.iter().all(|v| v.is_finite()));
    let flat = TrackConfig {
        side: 0.0,
        ..config
    };
    assert!(flat.point_at(1.0).is_err());
    let backwards = TrackConfig {
        delta: -1.0,
        ..config
    };
    assert!(backwards.step_length().is_err());
    let (mean, std) = config.step_length().unwrap();
    assert!(mean > 0.0 && std > 0.0);
}

/// `SquareTrack::readings` of a position it cannot place: a NaN or infinite coordinate, a position
/// exactly at an anchor, one so far that its distance overflows. Each was read as the anchor's
/// z-axis, a plausible reading of the wrong direction; each is now a typed error naming the
/// position. Next to an anchor, the readings are canonical.
#[test]
fn the_track_refuses_to_read_a_position_it_cannot_place() {
    let track = SquareTrack::paper(DataModel::VonMisesFisher { kappa: 32.8 }).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let theta = Vector3::new(1.0, bad, 0.0);
        assert!(
            matches!(
                track.readings(&theta, &mut rng),
                Err(OperatorError::NonFinite { what, .. }) if what.contains("true position")
            ),
            "{theta:?}"
        );
    }
    let far = Vector3::new(f64::MAX, f64::MAX, 0.0);
    assert!(matches!(
        track.readings(&far, &mut rng),
        Err(OperatorError::OutOfRange { value, .. }) if value == f64::INFINITY
    ));
    for anchor in track.anchors() {
        assert!(matches!(
            track.readings(anchor.position(), &mut rng),
            Err(OperatorError::OutOfRange { what, value, .. })
                if value == 0.0 && what.contains("true position")
        ));
        let next = anchor.position() + Vector3::new(0.0, 0.0, 1e-300);
        for reading in track.readings(&next, &mut rng).unwrap() {
            assert!(reading.check_canonical().is_ok(), "{reading:?}");
        }
    }
}

/// `DataModel::sample` trusted its public fields: σ = NaN gave NaN readings, and κ = −1 (which the
/// von Mises-Fisher family refuses) silently gave readings uniform over the sphere. It refuses them
/// as [`DataModel::validate`] does, and a true direction that is not a unit vector, before drawing.
#[test]
fn a_data_model_samples_only_with_valid_fields_and_a_unit_direction() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let up = Vector3::z();
    for bad in [
        DataModel::NormalWithFlip {
            sigma_az: f64::NAN,
            sigma_el: 0.1,
        },
        DataModel::NormalWithFlip {
            sigma_az: 0.1,
            sigma_el: -0.1,
        },
        DataModel::NormalWithFlip {
            sigma_az: f64::INFINITY,
            sigma_el: 0.1,
        },
        DataModel::VonMisesFisher { kappa: -1.0 },
        DataModel::VonMisesFisher { kappa: 0.0 },
        DataModel::VonMisesFisher { kappa: f64::NAN },
    ] {
        // As text: a NaN value would not equal itself.
        let refused = bad.sample(&up, &mut rng).map_err(|e| e.to_string());
        let invalid = bad.validate().map_err(|e| e.to_string());
        assert!(refused.is_err(), "{bad:?}: {refused:?}");
        assert_eq!(refused.err(), invalid.err(), "{bad:?}");
    }
    for data in [
        DataModel::NormalWithFlip {
            sigma_az: 0.1,
            sigma_el: 0.1,
        },
        DataModel::VonMisesFisher { kappa: 32.8 },
    ] {
        for direction in [
            Vector3::zeros(),
            Vector3::new(f64::NAN, 0.0, 1.0),
            Vector3::new(2.0, 0.0, 0.0),
        ] {
            assert!(
                matches!(
                    data.sample(&direction, &mut rng),
                    Err(OperatorError::Manifold { .. })
                ),
                "{data:?} {direction:?}"
            );
        }
        let reading = data.sample(&up, &mut rng).unwrap();
        assert!(reading.check_canonical().is_ok(), "{reading:?}");
    }
}

/// `log_joint` of a log evidence that is not finite was NaN in every cell (NaN), −∞ in every cell,
/// or +∞ in every cell but NaN (−∞ + ∞) in those of zero weight: it is refused. A finite one gives
/// −∞ exactly in those cells and finite values elsewhere.
#[test]
fn the_grid_joint_refuses_a_log_evidence_that_is_not_finite() {
    let cell = Gaussian::new(Vector2::zeros(), Matrix2::identity()).unwrap();
    let grid = CircularGrid::from_log_weights(&[0.0, f64::NEG_INFINITY, -1.0, -2.0], vec![cell; 4])
        .unwrap();
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(
            matches!(
                log_joint(&grid, bad),
                Err(OperatorError::NonFinite { what, .. }) if what.contains("log evidence")
            ),
            "{bad}"
        );
    }
    let joint = log_joint(&grid, -3.0).unwrap();
    assert_eq!(joint[1], f64::NEG_INFINITY);
    for j in [0, 2, 3] {
        assert!(joint[j].is_finite(), "{joint:?}");
    }
}
