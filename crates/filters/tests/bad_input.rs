//! Bad input never panics, hangs, aborts or silently yields NaN in the azimuth application: the
//! models, the exact filter, every baseline, the scenarios and the study are fed NaN, ±∞, ±MAX,
//! subnormals, zeros, singular and indefinite covariances and huge sizes, each call on its own thread
//! under a time limit. A call must return an error or a finite result (the exact filter's covariance
//! positive definite), and a filter must be exactly as it was after a step that failed. The fixed
//! cases at the end are the regressions of reported failures (`LIEBAYES_FUZZ_CASES` runs the
//! properties long).

use liebayes_filters::azimuth::scenario::{Config, Scenario, simulate, trajectory};
use liebayes_filters::azimuth::study::run_once;
use liebayes_filters::azimuth::{
    AzimuthDensity, AzimuthFilter, GaussianBaseline, GridReference, Linearisation,
    MarginalizedBaseline, Method, ParticleBaseline, PositionMeasurement, VelocityInput,
    VelocityProcess, study,
};
use liebayes_operators::{MAX_ELEMENTS, OperatorError};
use liebayes_reference::fuzz::{self, size, value};
use nalgebra::{Cholesky, Matrix2, Vector2};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

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

/// The exact filter's estimates are finite and Cov r symmetric with eigenvalues at least σ² up to
/// the rounding of its entries (`m ± h` in closed form, on the matrix scaled to unit size); it is
/// then positive definite in floating point too wherever its condition number is below 1e12.
fn sound(density: &AzimuthDensity) -> Result<(), TestCaseError> {
    let e = density.estimates();
    prop_assert!(e.kappa.is_finite());
    prop_assert!(e.mode.is_none_or(f64::is_finite));
    prop_assert!(e.sigma_a.is_none_or(|s| s.is_finite() && s >= 0.0));
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
    let _ = density.azimuth();
    Ok(())
}

/// A step through the common interface: unchanged after an error, finite estimate (or an error)
/// after success.
fn step_filter(
    filter: &mut dyn AzimuthFilter,
    process: VelocityProcess,
    input: &VelocityInput,
    measurement: PositionMeasurement,
    z: &Vector2<f64>,
) -> Result<(), TestCaseError> {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    // Compared as text: an estimate that overflows is an error holding NaN, which is not equal to
    // itself.
    let estimate = |f: &dyn AzimuthFilter| format!("{:?}", f.estimate());
    let before = estimate(filter);
    if filter.update(&measurement, z, &mut rng).is_err() {
        prop_assert_eq!(&before, &estimate(filter));
    }
    let before = estimate(filter);
    if filter.predict(&process, input, &mut rng).is_err() {
        prop_assert_eq!(&before, &estimate(filter));
    }
    if let Some(e) = fuzz::counted(filter.estimate()) {
        prop_assert!(finite(e.mean_r.iter()) && finite(e.cov_r.iter()));
        prop_assert!(e.rho.is_finite() && (0.0..=1.0).contains(&e.rho));
        prop_assert!(e.azimuth.is_none_or(f64::is_finite));
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

/// The exact filter from nasty parameters, stepped with nasty models and data.
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
                let process = VelocityProcess::new(q).unwrap_or(VelocityProcess::new(0.1).unwrap());
                let measurement = PositionMeasurement::new(sigma_m)
                    .unwrap_or(PositionMeasurement::new(1.0).unwrap());
                for ((z, v), dt) in zs.iter().zip(&velocities).zip(&dts) {
                    if let Some(value) = fuzz::counted(density.log_evidence(&measurement, z)) {
                        prop_assert!(value.is_finite());
                    }
                    let before = density;
                    if density.update(&measurement, z).is_err() {
                        prop_assert_eq!(before, density);
                    }
                    sound(&density)?;
                    let before = density;
                    let input = VelocityInput {
                        velocity: *v,
                        dt: *dt,
                    };
                    if density.predict(&process, &input).is_err() {
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

/// Every baseline from a nasty prior, stepped with nasty data through the common interface.
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
                let mut rng = ChaCha8Rng::seed_from_u64(2);
                let small = (1..=40).contains(&n);
                let mut filters: Vec<Box<dyn AzimuthFilter>> = Vec::new();
                match ParticleBaseline::new(n, r0, sigma0, &mut rng) {
                    Ok(f) => filters.push(Box::new(f)),
                    Err(OperatorError::TooLarge { .. }) => prop_assert!(!small),
                    Err(_) => {}
                }
                match MarginalizedBaseline::new(n, r0, sigma0, &mut rng) {
                    Ok(f) => filters.push(Box::new(f)),
                    Err(OperatorError::TooLarge { .. }) => prop_assert!(!small),
                    Err(_) => {}
                }
                match GridReference::new(n, r0, sigma0) {
                    Ok(f) => filters.push(Box::new(f)),
                    Err(OperatorError::TooLarge { .. }) => prop_assert!(!small),
                    Err(_) => {}
                }
                for kind in [Linearisation::Extended, Linearisation::Unscented] {
                    if let Some(f) = fuzz::counted(GaussianBaseline::new(kind, r0, sigma0)) {
                        filters.push(Box::new(f));
                    }
                }
                if let Some(f) = fuzz::counted(AzimuthDensity::new(r0, sigma0)) {
                    filters.push(Box::new(f));
                }
                let process = VelocityProcess::new(q).unwrap_or(VelocityProcess::new(0.1).unwrap());
                let measurement = PositionMeasurement::new(sigma_m)
                    .unwrap_or(PositionMeasurement::new(1.0).unwrap());
                let input = VelocityInput { velocity: v, dt };
                for filter in &mut filters {
                    step_filter(filter.as_mut(), process, &input, measurement, &z)?;
                    step_filter(filter.as_mut(), process, &input, measurement, &(z * 0.5))?;
                }
                Ok(())
            });
        },
    );
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
                    let valid = config.validate().is_ok();
                    let mut rng = ChaCha8Rng::seed_from_u64(3);
                    match simulate(Scenario::Line, &config, &mut rng) {
                        Ok(sim) => {
                            prop_assert!(valid && sim.positions.len() == steps);
                            prop_assert!(sim.true_azimuth.is_finite());
                            prop_assert!(sim.positions.iter().all(|p| finite(p.iter())));
                            prop_assert!(
                                sim.measurements.iter().flatten().all(|z| finite(z.iter()))
                            );
                        }
                        Err(_) => prop_assert!(!valid),
                    }
                    prop_assert_eq!(
                        trajectory(Scenario::Circle, &config, &mut rng).is_ok(),
                        valid
                    );
                    for method in [Method::Exact, Method::Ekf, Method::Particle(5)] {
                        if let Some(run) =
                            fuzz::counted(run_once(method, Scenario::Circle, &config, 4))
                        {
                            prop_assert!(valid);
                            prop_assert!(
                                run.epochs.iter().all(|e| finite(e.position_error.iter()))
                            );
                        }
                    }
                    if let Some(summary) =
                        fuzz::counted(study(Method::Exact, Scenario::Line, &config, runs, 5))
                    {
                        prop_assert!(valid && summary.runs == runs);
                        prop_assert!(summary.ns_per_step.is_finite());
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
        if fuzz::quick("update", || density.update(&tiny, &Vector2::new(3.0, 4.0))).is_err() {
            assert_eq!(before, density);
        }
        let e = fuzz::quick("estimates", || density.estimates());
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
    density.update(&precise, &Vector2::new(3.0, 4.0)).unwrap();
    let expected = 1e-18 / (1.0 + 1e-18);
    assert!(
        (density.sigma2() / expected - 1.0).abs() < 1e-15,
        "{}",
        density.sigma2()
    );
    density.update(&precise, &Vector2::new(3.0, 4.0)).unwrap();
    assert!(Cholesky::new(density.estimates().cov_r).is_some());
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
    assert!(GaussianBaseline::new(Linearisation::Extended, Vector2::zeros(), -1.0).is_err());
    assert!(GridReference::new(4, Vector2::zeros(), -1.0).is_err());
    let indefinite = Matrix2::new(1.0, 2.0, 2.0, 1.0);
    assert!(PositionMeasurement::isotropic_bound(&indefinite).is_err());
}

#[test]
fn baselines_refuse_huge_counts_before_drawing() {
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for n in [usize::MAX, liebayes_operators::MAX_ELEMENTS + 1] {
        assert!(matches!(
            fuzz::quick("MarginalizedBaseline::new(huge)", || {
                MarginalizedBaseline::new(n, Vector2::zeros(), 1.0, &mut rng)
            }),
            Err(OperatorError::TooLarge { .. })
        ));
        assert!(matches!(
            ParticleBaseline::new(n, Vector2::zeros(), 1.0, &mut rng),
            Err(OperatorError::TooLarge { .. })
        ));
        assert!(matches!(
            GridReference::new(n, Vector2::zeros(), 1.0),
            Err(OperatorError::TooLarge { .. })
        ));
    }
}

/// `steps` from a saturated cast used to reach `Vec::with_capacity(usize::MAX)`.
#[test]
fn simulations_refuse_sizes_before_allocating() {
    let config = Config {
        steps: usize::MAX,
        ..Config::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    assert!(matches!(
        fuzz::quick("simulate(steps = usize::MAX)", || simulate(
            Scenario::Line,
            &config,
            &mut rng
        )),
        Err(OperatorError::TooLarge { .. })
    ));
    assert!(matches!(
        fuzz::quick("steps_for(1e300, 1e-300)", || Config::steps_for(
            1e300, 1e-300
        )),
        Err(OperatorError::TooLarge { .. })
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
    let e = largest.estimates();
    assert!((e.kappa / 1e300 - 1.0).abs() < 1e-15 && e.sigma_a.unwrap() > 0.0);
}

/// A case the harness found: a prior at 1e300 m, a step of 1e300 s and a subnormal velocity, through
/// every baseline. Each step now fails with an error and leaves the filter as it was, or gives a
/// finite estimate.
#[test]
fn baselines_survive_a_prior_far_away_and_a_huge_step() {
    let (r0, sigma0) = (
        Vector2::new(f64::MIN_POSITIVE, 1e300),
        1.835_701_760_938_207_8,
    );
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let mut filters: Vec<Box<dyn AzimuthFilter>> = Vec::new();
    for filter in [
        ParticleBaseline::new(6, r0, sigma0, &mut rng)
            .map(|f| Box::new(f) as Box<dyn AzimuthFilter>),
        MarginalizedBaseline::new(6, r0, sigma0, &mut rng).map(|f| Box::new(f) as _),
        GridReference::new(6, r0, sigma0).map(|f| Box::new(f) as _),
        GaussianBaseline::new(Linearisation::Extended, r0, sigma0).map(|f| Box::new(f) as _),
        GaussianBaseline::new(Linearisation::Unscented, r0, sigma0).map(|f| Box::new(f) as _),
        AzimuthDensity::new(r0, sigma0).map(|f| Box::new(f) as _),
    ] {
        match filter {
            Ok(f) => filters.push(f),
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
    let process = VelocityProcess::new(8.002_486_246_475_813).unwrap();
    let measurement = PositionMeasurement::new(1.0).unwrap();
    let input = VelocityInput {
        velocity: Vector2::new(1e-160, 0.0),
        dt: 1e300,
    };
    for filter in &mut filters {
        step_filter(
            filter.as_mut(),
            process,
            &input,
            measurement,
            &Vector2::zeros(),
        )
        .unwrap();
    }
}
