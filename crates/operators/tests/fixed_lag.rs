//! The fixed-lag smoother against the RTS smoother run on the measurements up to each epoch (the
//! definition of the fixed-lag posterior): on R² with a linear model (where the RTS smoother is
//! itself checked against the batch least-squares solution) and on SO(3) with a nonlinear
//! measurement, every epoch of the window to 1e-9; its lag from seconds; its records refused
//! when malformed.

use liebayes_densities::{Density, Gaussian, ManifoldGaussian};
use liebayes_manifolds::{GroupAction, LieGroup, Manifold, Rn, So3};
use liebayes_operators::fixed_lag::{FixedLagSmoother, MAX_EPOCH};
use liebayes_operators::smoother::{GaussianTransition, RtsSmoother};
use liebayes_operators::{Condition, Ekf, MeasurementFn, OperatorError, ProcessFn, Propagate, Ukf};
use nalgebra::{Matrix1, Matrix2, Matrix3, SMatrix, SVector, Vector1, Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// `max |a − b| / (1 + max |b|)` over the mean's tangent difference and the covariance.
fn distance<X: Manifold<D, Scalar = f64>, const D: usize>(
    a: &ManifoldGaussian<X, D>,
    b: &ManifoldGaussian<X, D>,
) -> f64 {
    let mean = b.mean().local(a.mean()).amax();
    let covariance = (a.covariance() - b.covariance()).amax() / (1.0 + b.covariance().amax());
    mean.max(covariance)
}

/// Conditions both smoothers on epoch k's measurement (if it has one).
type Measure<'a, X, const D: usize> =
    &'a dyn Fn(&mut RtsSmoother<X, D>, &mut FixedLagSmoother<X, D>, usize);

/// Runs `steps` epochs through a fixed-lag smoother of each lag in `lags` and, at every epoch k,
/// compares its window with the RTS smoother run on the same steps up to k.
fn check_against_rts<X, const D: usize, W>(
    prior: &ManifoldGaussian<X, D>,
    lags: &[usize],
    process: &W,
    inputs: &[W::Input],
    measure: Measure<'_, X, D>,
) where
    X: Manifold<D, Scalar = f64> + PartialEq,
    W: GaussianTransition<X, D>,
{
    for &lag in lags {
        let mut rts = RtsSmoother::new(prior.clone());
        let mut fixed = FixedLagSmoother::new(prior.clone(), lag).unwrap();
        measure(&mut rts, &mut fixed, 0);
        for (k, input) in inputs.iter().enumerate() {
            rts.propagate(process, input).unwrap();
            fixed.propagate(process, input).unwrap();
            measure(&mut rts, &mut fixed, k + 1);
            let reference = rts.smooth().unwrap();
            let current = fixed.current().clone();
            let window = fixed.smooth().unwrap();
            let epoch = (k + 1) as u64;
            assert_eq!(window.first_epoch(), epoch.saturating_sub(lag as u64));
            assert_eq!(window.len(), (k + 1).min(lag) + 1);
            assert_eq!(window.lagged().is_some(), k + 1 >= lag);
            for (j, smoothed) in (window.first_epoch()..).zip(window.iter()) {
                let off = distance(smoothed, &reference[usize::try_from(j).unwrap()]);
                assert!(
                    off < 1e-9,
                    "lag {lag}, epoch {epoch}, window epoch {j}: {off:e}"
                );
            }
            // The current epoch's smoothed density is its filtered one.
            assert!(window.get(epoch) == Some(&current));
        }
    }
}

#[test]
fn linear_fixed_lag_equals_rts_up_to_each_epoch() {
    let dt = 0.5_f64;
    let f = Matrix2::new(1.0, dt, 0.0, 1.0);
    let q = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.3;
    let process = ProcessFn::new(
        move |x: &Rn<f64, 2>, u: &Vector2<f64>| Rn::new_unchecked(f * x.coords() + u),
        move |_, _| q,
    )
    .with_jacobian(move |_, _| f);
    let r = 0.25;
    let position = MeasurementFn::new(
        |x: &Rn<f64, 2>| Vector1::new(x.coords()[0]),
        move |_| Matrix1::new(r),
    );
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let noise = Gaussian::new(Vector1::zeros(), Matrix1::new(r)).unwrap();
    let readings: Vec<f64> = (0..=30)
        .map(|k| 0.1 * f64::from(k) + noise.sample(&mut rng)[0])
        .collect();
    let inputs = vec![Vector2::new(0.05, -0.02); 30];
    let prior = ManifoldGaussian::new(
        Rn::new_unchecked(Vector2::new(1.0, -0.5)),
        Matrix2::new(2.0, 0.3, 0.3, 1.0),
    )
    .unwrap();
    let measure = |rts: &mut RtsSmoother<Rn<f64, 2>, 2>,
                   fixed: &mut FixedLagSmoother<Rn<f64, 2>, 2>,
                   k: usize| {
        // Every third epoch without a measurement, so the window spans unmeasured epochs.
        if k % 3 != 2 {
            let z = Vector1::new(readings[k]);
            rts.condition(&Ekf(&position), &z).unwrap();
            fixed.condition(&Ekf(&position), &z).unwrap();
        }
    };
    check_against_rts::<_, 2, _>(&prior, &[0, 1, 4, 40], &Ekf(&process), &inputs, &measure);
    check_against_rts::<_, 2, _>(&prior, &[3], &Ukf::new(&process), &inputs, &measure);
}

#[test]
fn so3_fixed_lag_agrees_with_rts_truncated_the_same_way() {
    let increment = So3::exp(&Vector3::new(0.02, 0.05, -0.03));
    let q = Matrix3::identity() * 0.01_f64.powi(2);
    let process = ProcessFn::new(
        move |x: &So3<f64>, (): &()| x.compose(&increment),
        move |_, ()| q,
    );
    let sigma = 0.05;
    let directions = |x: &So3<f64>| {
        let g = x.inverse().act(&Vector3::new(0.0, 0.0, 1.0));
        let m = x.inverse().act(&Vector3::new(0.6, 0.0, 0.8));
        SVector::<f64, 6>::from_iterator(g.iter().chain(m.iter()).copied())
    };
    let sensors = MeasurementFn::new(directions, move |_| {
        SMatrix::<f64, 6, 6>::identity() * (sigma * sigma)
    });
    let prior = ManifoldGaussian::new(
        So3::exp(&Vector3::new(0.5, -1.0, 2.0)),
        Matrix3::identity() * 0.04,
    )
    .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let noise = Gaussian::new(
        SVector::<f64, 6>::zeros(),
        SMatrix::<f64, 6, 6>::identity() * (sigma * sigma),
    )
    .unwrap();
    let mut truth = prior.sample(&mut rng);
    let readings: Vec<SVector<f64, 6>> = (0..=25)
        .map(|k| {
            if k > 0 {
                truth = ManifoldGaussian::new(truth.compose(&increment), q)
                    .unwrap()
                    .sample(&mut rng);
            }
            directions(&truth) + noise.sample(&mut rng)
        })
        .collect();
    let measure = |rts: &mut RtsSmoother<So3<f64>, 3>,
                   fixed: &mut FixedLagSmoother<So3<f64>, 3>,
                   k: usize| {
        rts.condition(&Ekf(&sensors), &readings[k]).unwrap();
        fixed.condition(&Ekf(&sensors), &readings[k]).unwrap();
    };
    let inputs = vec![(); 25];
    check_against_rts::<_, 3, _>(&prior, &[2, 6], &Ukf::new(&process), &inputs, &measure);
    check_against_rts::<_, 3, _>(&prior, &[5], &Ekf(&process), &inputs, &measure);
}

#[test]
fn the_lag_in_seconds_is_rounded_up_to_whole_epochs() {
    let prior =
        ManifoldGaussian::new(Rn::new_unchecked(Vector1::new(0.0)), Matrix1::new(1.0)).unwrap();
    let lag = |seconds: f64, step: f64| {
        FixedLagSmoother::with_lag_seconds(prior.clone(), seconds, step).map(|s| s.lag())
    };
    // 0.3 / 0.1 = 2.9999999999999996 and (0.1 + 0.2) / 0.1 = 3.0000000000000004: both 3 epochs.
    assert_eq!(lag(0.3, 0.1).unwrap(), 3);
    assert_eq!(lag(0.1 + 0.2, 0.1).unwrap(), 3);
    assert_eq!(lag(0.25, 0.1).unwrap(), 3);
    assert_eq!(lag(0.0, 0.01).unwrap(), 0);
    assert_eq!(lag(2.0, 0.5).unwrap(), 4);
    assert!(matches!(
        lag(f64::NAN, 0.1),
        Err(OperatorError::NonFinite { .. })
    ));
    assert!(matches!(
        lag(1.0, f64::INFINITY),
        Err(OperatorError::NonFinite { .. })
    ));
    assert!(matches!(
        lag(-1.0, 0.1),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        lag(1.0, 0.0),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        lag(1e300, 1e-300),
        Err(OperatorError::TooLarge { .. })
    ));
    assert!(matches!(
        FixedLagSmoother::new(prior.clone(), usize::MAX),
        Err(OperatorError::TooLarge { .. })
    ));
}

#[test]
fn malformed_records_and_failed_steps_are_refused() {
    let prior =
        ManifoldGaussian::new(Rn::new_unchecked(Vector1::new(0.0)), Matrix1::new(1.0)).unwrap();
    let walk = ProcessFn::new(|x: &Rn<f64, 1>, (): &()| *x, |_, ()| Matrix1::new(0.1));
    let mut fixed = FixedLagSmoother::new(prior.clone(), 2).unwrap();
    for _ in 0..4 {
        fixed.propagate(&Ekf(&walk), &()).unwrap();
    }
    let filtered: Vec<_> = fixed.window_filtered().iter().cloned().collect();
    let transitions: Vec<_> = fixed.window_transitions().iter().cloned().collect();
    assert_eq!((filtered.len(), transitions.len()), (3, 2));
    let rebuilt =
        FixedLagSmoother::from_records(2, 4, filtered.clone(), transitions.clone()).unwrap();
    assert_eq!(rebuilt, fixed);
    // A window too short for its epoch, one transition missing, a non-finite cross-covariance.
    assert!(FixedLagSmoother::from_records(2, 1, filtered.clone(), transitions.clone()).is_err());
    assert!(
        FixedLagSmoother::from_records(2, 4, filtered.clone(), transitions[..1].to_vec()).is_err()
    );
    let mut bad = transitions.clone();
    bad[0].cross_covariance[0] = f64::NAN;
    assert!(matches!(
        FixedLagSmoother::from_records(2, 4, filtered.clone(), bad.clone()),
        Err(OperatorError::NonFinite { .. })
    ));
    assert!(matches!(
        RtsSmoother::from_records(filtered.clone(), bad),
        Err(OperatorError::NonFinite { .. })
    ));
    // Epochs past 2^53 are refused, read back or counted to (no overflow at u64::MAX).
    for (lag, epoch) in [(usize::MAX, u64::MAX), (2, MAX_EPOCH + 1)] {
        assert!(matches!(
            FixedLagSmoother::from_records(lag, epoch, filtered.clone(), transitions.clone()),
            Err(OperatorError::OutOfRange { .. })
        ));
    }
    let mut last = FixedLagSmoother::from_records(2, MAX_EPOCH, filtered, transitions).unwrap();
    let at_last = last.clone();
    assert!(matches!(
        last.propagate(&Ekf(&walk), &()),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert_eq!(last, at_last);
    // A failed step leaves the smoother as it was.
    let before = fixed.clone();
    let bad_noise = ProcessFn::new(|x: &Rn<f64, 1>, (): &()| *x, |_, ()| Matrix1::new(f64::NAN));
    assert!(fixed.propagate(&Ekf(&bad_noise), &()).is_err());
    let sensor = MeasurementFn::new(|x: &Rn<f64, 1>| *x.coords(), |_| Matrix1::new(0.1));
    assert!(
        fixed
            .condition(&Ekf(&sensor), &Vector1::new(f64::NAN))
            .is_err()
    );
    assert_eq!(fixed, before);
    // A smoothing changes no state: its window is a buffer, not compared (it was, so that a
    // smoother was no longer equal to its copy after `smooth`).
    fixed.smooth().unwrap();
    assert_eq!(fixed, before);
    // A model's asymmetric Q or R is refused, not taken for its symmetric part: Q = [[1, 1e300],
    // [-1e300, 1]] passed as the identity.
    let walk2 = ProcessFn::new(
        |x: &Rn<f64, 2>, (): &()| *x,
        |_, ()| Matrix2::new(1.0, 1e300, -1e300, 1.0),
    );
    let sensor2 = MeasurementFn::new(
        |x: &Rn<f64, 2>| *x.coords(),
        |_| Matrix2::new(1.0, 0.5, 0.0, 1.0),
    );
    let prior2 =
        ManifoldGaussian::new(Rn::new_unchecked(Vector2::zeros()), Matrix2::identity()).unwrap();
    let mut two = FixedLagSmoother::new(prior2.clone(), 2).unwrap();
    let error = two.propagate(&Ekf(&walk2), &()).unwrap_err();
    assert!(matches!(error, OperatorError::OutOfRange { .. }), "{error}");
    let error = two
        .condition(&Ekf(&sensor2), &Vector2::zeros())
        .unwrap_err();
    assert!(matches!(error, OperatorError::OutOfRange { .. }), "{error}");
    assert!(prior2.propagate(&Ukf::new(&walk2), &()).is_err());
    assert!(
        prior2
            .condition(&Ukf::new(&sensor2), &Vector2::zeros())
            .is_err()
    );
}

/// A model's indefinite noise is refused by every step: a negative variance (a time step of the
/// wrong sign shrank the covariance it was added to) or a correlation above 1; a semi-definite
/// noise of rank one is valid.
#[test]
fn indefinite_model_noise_is_refused() {
    let prior2 =
        ManifoldGaussian::new(Rn::new_unchecked(Vector2::zeros()), Matrix2::identity()).unwrap();
    let mut two = FixedLagSmoother::new(prior2.clone(), 2).unwrap();
    let backwards = ProcessFn::new(
        |x: &Rn<f64, 2>, (): &()| *x,
        |_, ()| Matrix2::new(-0.5, 0.0, 0.0, 0.1),
    );
    let correlated = MeasurementFn::new(
        |x: &Rn<f64, 2>| *x.coords(),
        |_| Matrix2::new(1.0, 2.0, 2.0, 1.0),
    );
    for error in [
        two.propagate(&Ekf(&backwards), &()).unwrap_err(),
        prior2.propagate(&Ukf::new(&backwards), &()).unwrap_err(),
        two.condition(&Ekf(&correlated), &Vector2::zeros())
            .unwrap_err(),
        prior2
            .condition(&Ukf::new(&correlated), &Vector2::zeros())
            .unwrap_err(),
    ] {
        assert!(
            matches!(error, OperatorError::NotPositiveDefinite { .. }),
            "{error}"
        );
    }
    let rank_one = ProcessFn::new(
        |x: &Rn<f64, 2>, (): &()| *x,
        |_, ()| Matrix2::new(1.0, 1.0, 1.0, 1.0),
    );
    assert!(prior2.propagate(&Ekf(&rank_one), &()).is_ok());
}

/// A step whose result is positive definite but beyond the density's limits (a prior of
/// variance 1e-99 updated by a sensor of variance 1e-101 leaves `tr P⁻¹` near 2e101) is refused as
/// out of range, naming that limit, not as "not positive definite".
#[test]
fn a_result_beyond_the_densitys_limits_is_out_of_range() {
    let prior = ManifoldGaussian::new(
        Rn::new_unchecked(Vector2::zeros()),
        Matrix2::identity() * 1e-99,
    )
    .unwrap();
    let sharp = MeasurementFn::new(
        |x: &Rn<f64, 2>| *x.coords(),
        |_| Matrix2::identity() * 1e-101,
    );
    for error in [
        prior
            .condition(&Ekf(&sharp), &Vector2::zeros())
            .unwrap_err(),
        prior
            .condition(&Ukf::new(&sharp), &Vector2::zeros())
            .unwrap_err(),
    ] {
        assert!(
            matches!(error, OperatorError::OutOfRange { .. })
                && error.to_string().contains("1e100"),
            "{error}"
        );
    }
}

/// A constant-velocity track (the piecewise white noise `Γ Γᵀ`, rank 1; dt = 1e-3, q = r = 1)
/// from a diffuse prior of 1e30 per axis, its position read every 50 steps, smoothed with a lag
/// of 10. The filtered covariances are singular to rounding (until the second reading the
/// position moves with a velocity nothing has read, and the diffuse prior's rounding stays in
/// them after), and the backward step's sum `A P_f Aᵀ + G (Ω + P_s′) Gᵀ` failed its
/// factorisation: the window was first refused at step 66. The backward step is now raised to
/// its rounding, as the filters' steps are, and the window is smoothed at every step.
#[test]
fn a_diffuse_constant_velocity_track_is_smoothed_at_every_step() {
    use liebayes_operators::process_noise::piecewise_white_noise;
    let dt = 1e-3;
    let f = Matrix2::new(1.0, dt, 0.0, 1.0);
    let q = piecewise_white_noise::<2>(dt, 1.0).unwrap();
    let motion = ProcessFn::new(
        move |x: &Rn<f64, 2>, (): &()| Rn::new_unchecked(f * x.coords()),
        move |_: &Rn<f64, 2>, (): &()| q,
    )
    .with_jacobian(move |_: &Rn<f64, 2>, (): &()| f);
    let position = MeasurementFn::new(
        |x: &Rn<f64, 2>| Vector1::new(x.coords()[0]),
        |_: &Rn<f64, 2>| Matrix1::new(1.0),
    )
    .with_jacobian(|_: &Rn<f64, 2>| SMatrix::<f64, 1, 2>::new(1.0, 0.0));
    let prior = ManifoldGaussian::new(
        Rn::new_unchecked(Vector2::zeros()),
        Matrix2::identity() * 1e30,
    )
    .unwrap();
    let mut fixed = FixedLagSmoother::new(prior, 10).unwrap();
    for k in 0..200 {
        if k % 50 == 0 {
            let z = Vector1::new(f64::from(k) * dt);
            fixed.condition(&Ekf(&position), &z).unwrap();
        }
        fixed.smooth().unwrap_or_else(|e| panic!("step {k}: {e}"));
        fixed.propagate(&Ekf(&motion), &()).unwrap();
    }
}
