//! The inertial-navigation pieces against independent computations: the strapdown step against the
//! closed form of constant motion, the process noise against its analytic form for the error-state
//! convention, the prior's moments against the distribution they were drawn from, the scenario's
//! truth against the model, and bad input refused.

use liebayes_experiments::Scenario;
use liebayes_filters::inertial::{
    ErrorState, GRAVITY, ImuNoise, ImuStep, InertialConfig, InertialScenario, InitialVelocity,
    LeftInvariant, MAX_READING, Navigation, NavigationState, PositionFix, RightInvariant,
    Strapdown, integrate,
};
use liebayes_manifolds::{LieGroup, Manifold, So3};
use liebayes_operators::{MeasurementModel, ProcessModel};
use nalgebra::{Matrix3, SMatrix, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

fn still() -> Navigation {
    Navigation {
        rotation: So3::exp(&Vector3::new(0.1, -0.2, 0.7)),
        velocity: Vector3::new(1.0, 2.0, -0.5),
        position: Vector3::new(10.0, -3.0, 2.0),
        gyro_bias: Vector3::new(0.01, -0.02, 0.005),
        accel_bias: Vector3::new(0.1, 0.0, -0.05),
    }
}

#[test]
fn a_level_body_reading_gravity_moves_at_constant_velocity() {
    let x = still();
    // The readings of a body at rest in the world, plus the biases: the step keeps v and moves p by v dt.
    let force = x.rotation.inverse().rotate(&-GRAVITY) + x.accel_bias;
    let rate = x.gyro_bias;
    let dt = 0.3;
    let step = |rate: Vector3<f64>, force: Vector3<f64>| ImuStep::new(rate, force, dt).unwrap();
    let next = integrate(&x, &step(rate, force)).unwrap();
    assert!((next.velocity - x.velocity).norm() < 1e-14);
    assert!((next.position - (x.position + x.velocity * dt)).norm() < 1e-14);
    assert!(x.rotation.local(&next.rotation).norm() < 1e-15);
    // A constant acceleration a along the world x: p moves by v dt + a dt²/2.
    let a = Vector3::new(0.7, 0.0, 0.0);
    let next = integrate(&x, &step(rate, force + x.rotation.inverse().rotate(&a))).unwrap();
    assert!((next.position - (x.position + x.velocity * dt + a * (dt * dt / 2.0))).norm() < 1e-13);
    // A rate about the body z turns the attitude by ω dt.
    let next = integrate(&x, &step(rate + Vector3::new(0.0, 0.0, 2.0), force)).unwrap();
    assert!((x.rotation.local(&next.rotation) - Vector3::new(0.0, 0.0, 0.6)).norm() < 1e-14);
    // A state near overflow (its fields are public) is an error, not an infinite state.
    let far = Navigation {
        velocity: Vector3::new(f64::MAX, 0.0, 0.0),
        position: Vector3::new(f64::MAX, 0.0, 0.0),
        ..x
    };
    assert!(integrate(&far, &step(rate, force)).is_err());
    let lost = Navigation {
        position: Vector3::new(f64::NAN, 0.0, 0.0),
        ..x
    };
    assert!(integrate(&lost, &step(rate, force)).is_err());
}

#[test]
fn the_error_state_process_noise_is_the_analytic_one() {
    let noise = ImuNoise {
        gyro: 0.02,
        accel: 0.1,
        gyro_bias_walk: 1e-3,
        accel_bias_walk: 1e-2,
    };
    let process = Strapdown::new(noise).unwrap();
    let x = ErrorState::from_navigation(&still());
    let dt = 0.01;
    let u = ImuStep::new(Vector3::new(0.1, 0.2, 0.3), Vector3::new(0.0, 0.5, 9.8), dt).unwrap();
    let q = ProcessModel::noise(&process, &x, &u);
    // Body-frame attitude error: the rate noise maps through the right Jacobian of exp(ω dt) (≈ I dt
    // for small ω dt); velocity picks R n_a dt, position R n_a dt²/2.
    let rate = (u.angular_rate() - still().gyro_bias) * dt;
    let jr = So3::<f64>::right_jacobian(&rate);
    let attitude = jr * jr.transpose() * (noise.gyro * noise.gyro * dt);
    assert!(
        (q.fixed_view::<3, 3>(0, 0) - attitude).amax() < 1e-12,
        "{}",
        q.fixed_view::<3, 3>(0, 0)
    );
    let r = still().rotation.to_matrix();
    let velocity = r * r.transpose() * (noise.accel * noise.accel * dt);
    assert!((q.fixed_view::<3, 3>(3, 3) - velocity).amax() < 1e-11);
    let position = Matrix3::identity() * (noise.accel * noise.accel * dt.powi(3) / 4.0);
    assert!((q.fixed_view::<3, 3>(6, 6) - position).amax() < 1e-12);
    assert!((q[(9, 9)] - 1e-6 * dt).abs() < 1e-18 && (q[(12, 12)] - 1e-4 * dt).abs() < 1e-16);
    assert_eq!(q, q.transpose());
}

/// Central differences of `g(x ⊞ δ)` at δ = 0 with step h, g(x) taken as the origin (`g` returns
/// the change it measures).
fn central<const K: usize, const N: usize>(
    h: f64,
    g: impl Fn(usize, f64) -> SMatrix<f64, K, 1>,
) -> SMatrix<f64, K, N> {
    SMatrix::from_columns(&std::array::from_fn::<_, N, _>(|j| {
        (g(j, h) - g(j, -h)) / (2.0 * h)
    }))
}

/// `|found − want|max / |want|max`.
fn relative_error<const R: usize, const C: usize>(
    found: &SMatrix<f64, R, C>,
    want: &SMatrix<f64, R, C>,
) -> f64 {
    (found - want).amax() / want.amax()
}

/// The closed-form F, G (through Q) and H of the convention S against central differences of the
/// step and the fix in the convention N's own ⊞ and ⊟ (N = S but in the wrong-model check); `None`
/// when each agrees to 1e-6 of its largest entry, otherwise what differs.
fn closed_forms_differ<S: NavigationState, N: NavigationState>(
    x: &Navigation,
    u: &ImuStep,
) -> Option<String> {
    let (gyro, accel) = (0.02, 0.1);
    let noise = ImuNoise {
        gyro,
        accel,
        gyro_bias_walk: 0.0,
        accel_bias_walk: 0.0,
    };
    let process = Strapdown::new(noise).unwrap();
    let fix = PositionFix::new(1.0).unwrap();
    let state = N::from_navigation(x);
    let centre = ProcessModel::transition(&process, &state, u);
    // A step of 1e-5 in each coordinate: truncation about 1e-10, rounding 1e-16 |p| / 1e-5.
    let h = 1e-5;
    let moved = |j: usize, step: f64| {
        let mut e = SMatrix::<f64, 15, 1>::zeros();
        e[j] = step;
        state.retract(&e)
    };
    let f: SMatrix<f64, 15, 15> = central(h, |j, step| {
        centre.local(&ProcessModel::transition(&process, &moved(j, step), u))
    });
    // The step moves v′ and p′ linearly in f̃, in every convention: its columns take a step of
    // 1e5 h = 1 m/s², which stands above the rounding of p′ 1 km out at dt = 1 ms.
    let g: SMatrix<f64, 15, 6> = central(h, |j, step| {
        let (mut rate, mut force, scale) = (*u.angular_rate(), *u.specific_force(), 1e5);
        if j < 3 {
            rate[j] += step;
        } else {
            force[j - 3] += step * scale;
        }
        let reading = ImuStep::new(rate, force, u.dt()).unwrap();
        let change = centre.local(&ProcessModel::transition(&process, &state, &reading));
        if j < 3 { change } else { change / scale }
    });
    let variance = SMatrix::<f64, 6, 6>::from_fn(|i, j| match (i == j, i < 3) {
        (false, _) => 0.0,
        (true, true) => gyro * gyro / u.dt(),
        (true, false) => accel * accel / u.dt(),
    });
    let q = g * variance * g.transpose();
    let h_numeric: SMatrix<f64, 3, 15> = central(h, |j, step| {
        MeasurementModel::<N, 15, 3>::predict(&fix, &moved(j, step))
            - MeasurementModel::<N, 15, 3>::predict(&fix, &state)
    });
    let closed = S::from_navigation(x);
    let errors = [
        (
            "F",
            relative_error(&ProcessModel::jacobian(&process, &closed, u), &f),
        ),
        (
            "Q",
            relative_error(&ProcessModel::noise(&process, &closed, u), &q),
        ),
        (
            "H",
            relative_error(
                &MeasurementModel::<S, 15, 3>::jacobian(&fix, &closed),
                &h_numeric,
            ),
        ),
    ];
    errors
        .iter()
        .find(|(_, error)| error.is_nan() || *error > 1e-6)
        .map(|(name, error)| format!("{name}: relative error {error:e}"))
}

/// F, Q and H are written in closed form, once in the error-state EKF's error and carried into
/// each convention by its first-order error map: checked against central differences of the step
/// and the fix in each convention's own ⊞ and ⊟, at states from rest to 300 m/s and 1 km out,
/// rotations up to 2.9 rad in a step, and steps from 1 ms to 1 s. Another convention's closed forms
/// fail (the error-state EKF's for the left-invariant error, the left's for the right's).
#[test]
fn the_closed_form_jacobians_are_the_steps_derivatives() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut cases = 0;
    for (speed, distance) in [(0.0, 0.0), (5.0, 10.0), (300.0, 1e3)] {
        for (rate, dt) in [(0.3, 0.02), (2.9, 1.0), (3.0, 1e-3)] {
            let mut unit = || {
                let v = Vector3::<f64>::new(
                    rng.sample(StandardNormal),
                    rng.sample(StandardNormal),
                    rng.sample(StandardNormal),
                );
                v / v.norm()
            };
            let x = Navigation {
                rotation: So3::exp(&(unit() * 2.0)),
                velocity: unit() * speed,
                position: unit() * distance,
                gyro_bias: unit() * 0.01,
                accel_bias: unit() * 0.1,
            };
            let u = ImuStep::new(
                unit() * rate,
                unit() * 9.8 + Vector3::new(0.0, 0.0, 9.81),
                dt,
            )
            .unwrap();
            for differs in [
                closed_forms_differ::<ErrorState, ErrorState>(&x, &u),
                closed_forms_differ::<LeftInvariant, LeftInvariant>(&x, &u),
                closed_forms_differ::<RightInvariant, RightInvariant>(&x, &u),
            ] {
                assert_eq!(differs, None, "{x:?}, {u:?}");
                cases += 1;
            }
            // The wrong model: another convention's closed forms.
            assert!(closed_forms_differ::<ErrorState, LeftInvariant>(&x, &u).is_some());
            assert!(closed_forms_differ::<LeftInvariant, RightInvariant>(&x, &u).is_some());
        }
    }
    assert_eq!(cases, 27);
}

/// `propagate_covariance`, which skips F's bias rows `[0, I]`, against the dense products with F:
/// the same `F P Fᵀ` and `P Fᵀ` to rounding, in every convention, for a covariance with every
/// entry non-zero.
fn sparse_propagation_error<S: NavigationState>(x: &Navigation, u: &ImuStep) -> f64 {
    let process = Strapdown::new(ImuNoise {
        gyro: 0.02,
        accel: 0.1,
        gyro_bias_walk: 1e-3,
        accel_bias_walk: 1e-2,
    })
    .unwrap();
    let a = SMatrix::<f64, 15, 15>::from_fn(|i, j| {
        ((i * 7 + j * 3) as f64 * 0.37).sin() + if i == j { 4.0 } else { 0.0 }
    });
    let p = a * a.transpose();
    let state = S::from_navigation(x);
    let f = ProcessModel::jacobian(&process, &state, u);
    let (propagated, cross) = ProcessModel::propagate_covariance(&process, &state, u, &p);
    let (dense, dense_cross) = (f * p * f.transpose(), p * f.transpose());
    relative_error(&propagated, &dense).max(relative_error(&cross, &dense_cross))
}

#[test]
fn sparse_covariance_propagation_equals_the_dense_products() {
    let x = Navigation {
        velocity: Vector3::new(30.0, -12.0, 1.0),
        position: Vector3::new(800.0, 250.0, -40.0),
        ..still()
    };
    let u = ImuStep::new(
        Vector3::new(0.4, -0.2, 1.1),
        Vector3::new(0.3, 0.5, 9.8),
        0.02,
    )
    .unwrap();
    for error in [
        sparse_propagation_error::<ErrorState>(&x, &u),
        sparse_propagation_error::<LeftInvariant>(&x, &u),
        sparse_propagation_error::<RightInvariant>(&x, &u),
    ] {
        assert!(error <= 1e-14, "{error:e}");
    }
}

/// The accelerometer's share of Q in every convention, far from the origin: `σ_a² dt` on the
/// velocity, `σ_a² dt³/4` on the position and `σ_a² dt²/2` between them (isotropic noise, so in
/// any frame). Its central difference took a step of 1e-6 m/s², which moved the position by
/// 5e-13 m in a step of 1 ms: 1 km out the position block was 11 % off, 10 km out it was 0, 100 km
/// out 600 times too large. The gyroscope's noise is the smallest accepted, so that only the
/// accelerometer's remains.
#[test]
fn the_accelerometer_noise_is_exact_far_from_the_origin() {
    let noise = ImuNoise {
        gyro: 1e-30,
        accel: 0.05,
        gyro_bias_walk: 1e-4,
        accel_bias_walk: 1e-3,
    };
    let process = Strapdown::new(noise).unwrap();
    let blocks = |q: &SMatrix<f64, 15, 15>, v: usize, p: usize| {
        (
            q.fixed_view::<3, 3>(v, v).into_owned(),
            q.fixed_view::<3, 3>(p, p).into_owned(),
            q.fixed_view::<3, 3>(v, p).into_owned(),
        )
    };
    for dt in [1e-3, 1e-2] {
        let u = ImuStep::new(Vector3::new(0.1, 0.2, 0.3), Vector3::new(0.0, 0.5, 9.8), dt).unwrap();
        let a2 = noise.accel * noise.accel;
        let expected = [a2 * dt, a2 * dt.powi(3) / 4.0, a2 * dt * dt / 2.0];
        for (position, velocity) in [(0.0, 0.0), (1e3, 30.0), (1e4, 300.0), (1e6, 300.0)] {
            let x = Navigation {
                position: Vector3::new(position, -0.7 * position, 0.3 * position),
                velocity: Vector3::new(velocity, 0.5 * velocity, -0.2 * velocity),
                ..still()
            };
            // The velocity and position blocks' tangent indices: the error-state EKF's
            // [δθ; δv; δp], SE₂(3)'s [ρ; φ; ν] (position, attitude, velocity).
            let found = [
                blocks(
                    &ProcessModel::noise(&process, &ErrorState::from_navigation(&x), &u),
                    3,
                    6,
                ),
                blocks(
                    &ProcessModel::noise(&process, &LeftInvariant::from_navigation(&x), &u),
                    6,
                    0,
                ),
                blocks(
                    &ProcessModel::noise(&process, &RightInvariant::from_navigation(&x), &u),
                    6,
                    0,
                ),
            ];
            for (convention, (vv, pp, vp)) in ["error state", "left", "right"].iter().zip(found) {
                for (block, want) in [vv, pp, vp].iter().zip(expected) {
                    let error = (block - Matrix3::identity() * want).amax() / want;
                    assert!(
                        error < 1e-6,
                        "{convention}, dt {dt}, {position} m: {block} vs {want:e}"
                    );
                }
            }
        }
    }
}

#[test]
fn the_error_state_prior_has_the_moments_of_the_initial_distribution() {
    // The velocity known in the world frame: every error independent and Gaussian.
    let config = InertialConfig {
        initial_velocity: InitialVelocity::World,
        ..InertialConfig::default()
    };
    let scenario = InertialScenario::new(config).unwrap();
    let prior = scenario.prior::<ErrorState>().unwrap();
    let p = prior.covariance();
    // Body-frame attitude error at identity = world-frame error: diag(tilt², tilt², heading²); the
    // rest independent with the configured σ. 20 000 draws: relative error of a variance ≈ 1 %.
    let expected = SMatrix::<f64, 15, 15>::from_diagonal(&nalgebra::SVector::<f64, 15>::from_fn(
        |i, _| match i {
            0 | 1 => config.tilt_sigma.powi(2),
            2 => config.heading_sigma.powi(2),
            3..=5 => config.velocity_sigma.powi(2),
            6..=8 => config.position_sigma.powi(2),
            9..=11 => config.gyro_bias_sigma.powi(2),
            _ => config.accel_bias_sigma.powi(2),
        },
    ));
    for i in 0..15 {
        for j in 0..15 {
            let scale = (expected[(i, i)] * expected[(j, j)]).sqrt();
            assert!(
                (p[(i, j)] - expected[(i, j)]).abs() < 0.05 * scale,
                "P[{i}, {j}] = {} against {}",
                p[(i, j)],
                expected[(i, j)]
            );
        }
    }
}

#[test]
fn without_noise_the_truth_follows_the_filters_model() {
    let config = InertialConfig {
        duration: 5.0,
        // The smallest densities accepted (1e-300 squared to 0 and is refused now).
        imu: ImuNoise {
            gyro: 1e-30,
            accel: 1e-30,
            gyro_bias_walk: 0.0,
            accel_bias_walk: 0.0,
        },
        ..InertialConfig::default()
    };
    let scenario = InertialScenario::new(config).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let start = scenario.draw_initial(&mut ChaCha8Rng::seed_from_u64(3));
    let mut state = start;
    let mut fixes = 0;
    for step in scenario.simulate(&mut rng).unwrap() {
        state = integrate(&state, &step.input).unwrap();
        assert!((state.position - step.truth.position).norm() < 1e-9);
        assert!(state.rotation.local(&step.truth.rotation).norm() < 1e-12);
        fixes += usize::from(step.measurement.is_some());
    }
    assert_eq!(fixes, scenario.epochs());
    assert_eq!(fixes, 5);
}

/// An IMU whose white noise reaches beyond the sensor's range: every sample is still reported,
/// each reading saturated at a norm of MAX_READING, so that `ImuStep::new` accepts it (the
/// scenario ended silently at the first sample beyond the range).
#[test]
fn a_noisy_imu_saturates_and_the_run_goes_on() {
    let config = InertialConfig {
        duration: 1.0,
        imu: ImuNoise {
            gyro: 1e6,
            accel: 1e6,
            gyro_bias_walk: 1e6,
            accel_bias_walk: 1e6,
        },
        ..InertialConfig::default()
    };
    let scenario = InertialScenario::new(config).unwrap();
    let steps: Vec<_> = scenario
        .simulate(&mut ChaCha8Rng::seed_from_u64(5))
        .unwrap()
        .collect();
    assert_eq!(steps.len(), config.samples());
    let readings = steps
        .iter()
        .flat_map(|s| [s.input.angular_rate(), s.input.specific_force()]);
    assert!(readings.clone().all(|v| v.norm() <= MAX_READING));
    assert!(
        readings
            .filter(|v| v.norm() >= MAX_READING * (1.0 - 1e-15))
            .count()
            > steps.len()
    );
    for s in &steps {
        let again = ImuStep::new(
            *s.input.angular_rate(),
            *s.input.specific_force(),
            s.input.dt(),
        );
        assert_eq!(again.unwrap(), s.input);
    }
    assert!(
        steps
            .iter()
            .all(|s| s.truth.position.iter().all(|p| p.is_finite()))
    );
}

#[test]
fn bad_input_is_refused() {
    let v = Vector3::new(0.0, 0.0, 9.8);
    assert!(ImuStep::new(Vector3::new(f64::NAN, 0.0, 0.0), v, 0.01).is_err());
    assert!(
        ImuStep::new(
            Vector3::zeros(),
            Vector3::new(0.0, f64::INFINITY, 0.0),
            0.01
        )
        .is_err()
    );
    assert!(ImuStep::new(Vector3::zeros(), Vector3::new(0.0, 2e4, 0.0), 0.01).is_err());
    // A subnormal step passed, and then every filter's process noise σ²/dt was ∞ (its error
    // named the covariance, not dt): steps below 1e-6 s are refused, naming dt.
    for dt in [0.0, -0.01, 2.0, f64::NAN, 1e-320, 9e-7] {
        let error = ImuStep::new(Vector3::zeros(), v, dt).unwrap_err();
        assert!(error.to_string().contains("dt"), "dt = {dt}: {error}");
    }
    assert!(ImuStep::new(Vector3::zeros(), v, 1e-6).is_ok());
    assert!(PositionFix::new(0.0).is_err() && PositionFix::new(f64::NAN).is_err());
    let mut noise = ImuNoise {
        gyro: 0.01,
        accel: 0.1,
        gyro_bias_walk: 0.0,
        accel_bias_walk: 0.0,
    };
    assert!(Strapdown::new(noise).is_ok());
    noise.gyro = 0.0;
    assert!(Strapdown::new(noise).is_err());
    for broken in [
        InertialConfig {
            imu_rate: 0.0,
            ..InertialConfig::default()
        },
        InertialConfig {
            duration: f64::NAN,
            ..InertialConfig::default()
        },
        InertialConfig {
            fix_every: 0,
            ..InertialConfig::default()
        },
        InertialConfig {
            fix_every: 10_000,
            ..InertialConfig::default()
        },
        InertialConfig {
            heading_sigma: 2.0,
            ..InertialConfig::default()
        },
        InertialConfig {
            fix_sigma: -1.0,
            ..InertialConfig::default()
        },
    ] {
        assert!(InertialScenario::new(broken).is_err(), "{broken:?}");
    }
}

#[test]
fn the_position_fix_predicts_the_position() {
    let fix = PositionFix::new(0.5).unwrap();
    let x = ErrorState::from_navigation(&still());
    assert_eq!(
        MeasurementModel::<ErrorState, 15, 3>::predict(&fix, &x),
        still().position
    );
    let h = MeasurementModel::<ErrorState, 15, 3>::jacobian(&fix, &x);
    // Additive position error: H = [0, 0, I, 0, 0].
    assert!((h.fixed_view::<3, 3>(0, 6) - Matrix3::identity()).amax() < 1e-9);
    assert!(h.fixed_view::<3, 6>(0, 0).amax() < 1e-9 && h.fixed_view::<3, 6>(0, 9).amax() < 1e-9);
}

#[test]
fn a_velocity_known_in_the_body_frame_couples_with_the_heading() {
    // v = R_z(φ) v̂ + n with v̂ = 5 m/s along x: δv_y = 5 sin φ, and for φ ~ N(0, σ²),
    // E[φ sin φ] = σ² exp(−σ²/2); E[sin² φ] = (1 − exp(−2σ²))/2.
    let config = InertialConfig::default();
    let scenario = InertialScenario::new(config).unwrap();
    let p = *scenario.prior::<ErrorState>().unwrap().covariance();
    let s2 = config.heading_sigma.powi(2);
    let coupling = 5.0 * s2 * (-s2 / 2.0).exp();
    assert!(
        (p[(4, 2)] - coupling).abs() < 0.03 * coupling,
        "{} vs {coupling}",
        p[(4, 2)]
    );
    let spread = 25.0 * (1.0 - (-2.0 * s2).exp()) / 2.0 + config.velocity_sigma.powi(2);
    assert!(
        (p[(4, 4)] - spread).abs() < 0.03 * spread,
        "{} vs {spread}",
        p[(4, 4)]
    );
}

/// The inertial settings were checked by hand with ranges of their own. A fix
/// σ of 1e-200 squared to R = 0, and one of 1e-60 made every fix update fail; IMU densities of
/// 5e-324 squared to 0; a tiny initial σ passed `validate` and failed later with an error naming
/// no setting; readings were limited per component (norms up to 1.73e4) where the attitude
/// filters limit the norm to 1e4; the IMU rate had a range of its own, [1, 1e5] Hz, narrower than
/// the steps `ImuStep::new` takes. Each is now refused at the shared bound, naming the setting.
#[test]
fn inertial_settings_use_the_shared_ranges() {
    for sigma in [1e-60, 1e-200, 5e-324, 0.0, 2e6, f64::NAN] {
        let error = PositionFix::new(sigma).unwrap_err();
        assert!(error.to_string().contains("`sigma`"), "{error}");
    }
    assert!(PositionFix::new(1e-30).is_ok() && PositionFix::new(1e6).is_ok());
    let good = ImuNoise {
        gyro: 0.01,
        accel: 0.1,
        gyro_bias_walk: 0.0,
        accel_bias_walk: 1e-3,
    };
    assert!(Strapdown::new(good).is_ok());
    for (name, broken) in [
        (
            "gyro",
            ImuNoise {
                gyro: 5e-324,
                ..good
            },
        ),
        (
            "accel",
            ImuNoise {
                accel: 1e-31,
                ..good
            },
        ),
        (
            "gyro_bias_walk",
            ImuNoise {
                gyro_bias_walk: 1e-200,
                ..good
            },
        ),
        (
            "accel_bias_walk",
            ImuNoise {
                accel_bias_walk: 2e6,
                ..good
            },
        ),
    ] {
        let error = Strapdown::new(broken).unwrap_err();
        assert!(error.to_string().contains(&format!("`{name}`")), "{error}");
    }
}

/// The scenario's settings at the shared bounds, naming the field.
#[test]
fn inertial_config_uses_the_shared_ranges() {
    let good = ImuNoise {
        gyro: 0.01,
        accel: 0.1,
        gyro_bias_walk: 0.0,
        accel_bias_walk: 1e-3,
    };
    let config = InertialConfig::default();
    for (name, broken) in [
        (
            "fix_sigma",
            InertialConfig {
                fix_sigma: 1e-60,
                ..config
            },
        ),
        (
            "heading_sigma",
            InertialConfig {
                heading_sigma: 1e-40,
                ..config
            },
        ),
        (
            "tilt_sigma",
            InertialConfig {
                tilt_sigma: 5e-324,
                ..config
            },
        ),
        (
            "velocity_sigma",
            InertialConfig {
                velocity_sigma: 1e-200,
                ..config
            },
        ),
        (
            "position_sigma",
            InertialConfig {
                position_sigma: 1e-31,
                ..config
            },
        ),
        (
            "gyro_bias_sigma",
            InertialConfig {
                gyro_bias_sigma: 1e-60,
                ..config
            },
        ),
        (
            "accel_bias_sigma",
            InertialConfig {
                accel_bias_sigma: 2e3,
                ..config
            },
        ),
        (
            "imu_rate",
            InertialConfig {
                imu_rate: 0.5,
                ..config
            },
        ),
        (
            "imu_rate",
            InertialConfig {
                imu_rate: 1.1e6,
                ..config
            },
        ),
        (
            "gyro",
            InertialConfig {
                imu: ImuNoise {
                    gyro: 1e-300,
                    ..good
                },
                ..config
            },
        ),
    ] {
        let error = InertialScenario::new(broken).unwrap_err();
        assert!(
            error.to_string().contains(&format!("`{name}`")),
            "{name}: {error}"
        );
    }
    // The one rate range is the steps' own: 1e6 Hz (dt = 1e-6 s) is accepted by both.
    let fast = InertialConfig {
        imu_rate: 1e6,
        duration: 1e-3,
        fix_every: 100,
        ..config
    };
    assert!(InertialScenario::new(fast).is_ok());
    assert!(ImuStep::new(Vector3::zeros(), Vector3::zeros(), fast.dt()).is_ok());
}

/// Readings limited by their norm, with the attitude filters' constants.
#[test]
fn imu_readings_are_limited_by_norm_as_in_attitude() {
    // Readings by norm, as the attitude filters: (1e4, 1e4, 1e4) has norm 1.73e4.
    let v = Vector3::new(0.0, 0.0, 9.8);
    let over = Vector3::new(1e4, 1e4, 1e4);
    let error = ImuStep::new(over, v, 0.01).unwrap_err();
    assert!(error.to_string().contains("`angular_rate`"), "{error}");
    let error = ImuStep::new(Vector3::zeros(), over, 0.01).unwrap_err();
    assert!(error.to_string().contains("`specific_force`"), "{error}");
    let at_limit = Vector3::new(6e3, 8e3, 0.0);
    assert!(ImuStep::new(at_limit, at_limit, 0.01).is_ok());
    assert_eq!(MAX_READING, liebayes_filters::attitude::MAX_ANGULAR_RATE);
    assert_eq!(MAX_READING, liebayes_filters::attitude::MAX_SPECIFIC_FORCE);
}

/// A position fix of σ = 1e-9 m (within `FIX_SIGMA_RANGE`) against a prior of metres: R is below
/// the rounding of `H P Hᵀ`, and the right-invariant EKF refused 387 of 400 fixes (from the
/// first) as not positive definite, the left-invariant one's iterated update 312. The EKF's
/// and iterated updates now make such a step once more with R raised above that rounding.
///
/// Over 100 s (100 fixes), the error-state filter (both updates) and every iterated filter take
/// every fix. The error-state filters and the left-invariant iterated one end within ten fix σ of
/// the truth. The right-invariant iterated filter ends consistent, its NEES inside the two-sided
/// 99.9 % band of χ²₁₅ ([3.1, 39.7]), but millimetres off: its position coordinate `p − R R̂ᵀ p̂`
/// mixes the attitude error with the position, and R raised above the rounding of that
/// coordinate's tens of metres of variance is a fix of about 1e-4 m (seeds 1 to 11: up to 1.2e-2
/// m; seeds 1 to 9: NEES 3.6 to 30).
///
/// The one-pass invariant filters' retraction adds the attitude correction times the position
/// correction, a second-order error their covariance does not carry: from seed 8 the
/// left-invariant one took every fix and returned, as Ok, an estimate 1.4e11 m off with a σ of
/// nanometres (NEES 5e29). Its fixes are now refused for their linearisation, the state left as it
/// was (every one of the 100, from seeds 5 and 8), and the right-invariant one's first fix is
/// refused the same way.
#[test]
fn a_fix_finer_than_the_arithmetic_is_kept_right_or_refused() {
    use liebayes_filters::inertial::{Convention, FixUpdate, NAVIGATION_DIM};
    use liebayes_operators::evaluation::chi_square_quantile;
    // The standard normal 99.95 % quantile: a two-sided 99.9 % band.
    const Z: f64 = 3.290_526_731_491_926;
    let dof = NAVIGATION_DIM as f64;
    let band = chi_square_quantile(-Z, dof).unwrap()..=chi_square_quantile(Z, dof).unwrap();
    let config = InertialConfig {
        fix_sigma: 1e-9,
        duration: 100.0,
        ..InertialConfig::default()
    };
    for seed in [5, 8] {
        for update in [FixUpdate::OnePass, FixUpdate::Iterated] {
            for run in every_convention_runs(config, update, seed) {
                let (convention, label) = (run.convention, format!("seed {seed} {update:?}"));
                match (convention, update) {
                    (Convention::ErrorState, _)
                    | (Convention::LeftInvariant, FixUpdate::Iterated) => {
                        assert_eq!(run.refused, 0, "{convention:?} {label}");
                        assert!(run.error < 1e-8, "{convention:?} {label}: {} m", run.error);
                    }
                    (Convention::RightInvariant, FixUpdate::Iterated) => {
                        assert_eq!(run.refused, 0, "{convention:?} {label}");
                        assert!(
                            band.contains(&run.nees),
                            "{convention:?} {label}: NEES {}",
                            run.nees
                        );
                    }
                    (Convention::LeftInvariant, FixUpdate::OnePass) => {
                        assert_eq!(run.refused, run.fixes, "{convention:?} {label}");
                    }
                    (Convention::RightInvariant, FixUpdate::OnePass) => {
                        assert!(run.first_refused, "{convention:?} {label}");
                    }
                }
            }
        }
    }
}

/// One convention's run: its final position error (m), the NEES of its final estimate in its own
/// coordinates, and its fixes: how many, how many refused, and whether the first was.
struct ConventionRun {
    convention: liebayes_filters::inertial::Convention,
    error: f64,
    nees: f64,
    fixes: usize,
    refused: usize,
    first_refused: bool,
}

/// Every convention's filter with the fix `update`, over a run of `config` simulated from `seed`:
/// every prediction must be taken, and a fix may be refused only for its linearisation
/// ([`OperatorError::Linearisation`](liebayes_operators::OperatorError::Linearisation)), with the
/// filter's estimate then the one before the fix.
fn every_convention_runs(
    config: InertialConfig,
    update: liebayes_filters::inertial::FixUpdate,
    seed: u64,
) -> Vec<ConventionRun> {
    use liebayes_experiments::RecursiveFilter;
    use liebayes_filters::inertial::{Convention, InertialMethod};
    use liebayes_operators::OperatorError;
    let scenario = InertialScenario::new(config).unwrap();
    let steps: Vec<_> = scenario
        .simulate(&mut ChaCha8Rng::seed_from_u64(seed))
        .unwrap()
        .collect();
    let truth = steps.last().unwrap().truth;
    [
        Convention::ErrorState,
        Convention::LeftInvariant,
        Convention::RightInvariant,
    ]
    .into_iter()
    .map(|convention| {
        let method = InertialMethod::new(convention, update, &scenario)
            .unwrap_or_else(|e| panic!("{convention:?}: {e}"));
        let mut filter = method.filter();
        let (mut fixes, mut refused, mut first_refused) = (0, 0, false);
        for (k, step) in steps.iter().enumerate() {
            filter
                .predict(&step.input)
                .unwrap_or_else(|e| panic!("{convention:?} {update:?} step {k}: {e}"));
            if let Some(z) = &step.measurement {
                let before = filter.estimate().unwrap();
                match filter.update(z) {
                    Ok(_) => {}
                    Err(OperatorError::Linearisation { .. }) => {
                        assert_eq!(filter.estimate().unwrap(), before, "{convention:?} {k}");
                        refused += 1;
                        first_refused |= fixes == 0;
                    }
                    Err(e) => panic!("{convention:?} {update:?} fix at step {k}: {e}"),
                }
                fixes += 1;
            }
        }
        let estimate = filter.estimate().unwrap();
        let error = convention.error(&estimate.navigation, &truth);
        ConventionRun {
            convention,
            error: (estimate.navigation.position - truth.position).norm(),
            nees: error.dot(&estimate.covariance.cholesky().unwrap().solve(&error)),
            fixes,
            refused,
            first_refused,
        }
    })
    .collect()
}

/// Every convention's filter takes every step and fix of `config` from seed 5; their runs.
fn every_convention_takes_every_step(
    config: InertialConfig,
    update: liebayes_filters::inertial::FixUpdate,
) -> Vec<ConventionRun> {
    let runs = every_convention_runs(config, update, 5);
    for run in &runs {
        assert_eq!(run.refused, 0, "{:?} {update:?}", run.convention);
    }
    runs
}

/// An initial velocity σ that `InertialConfig::validate` accepts, 1e-30 m/s, made the invariant
/// priors' moments singular to rounding (the invariant velocity error is then a function of the
/// attitude error; the left- and right-invariant priors had eigenvalues of −7e-16 and −5e-19), and
/// no invariant filter could be built. The prior is now floored at the rounding of its largest
/// entries: every convention builds and takes 20 s of steps and fixes. With every initial σ at
/// 1e-30 and the IMU's default noise, the filters were built but their first prediction was
/// refused: `F P Fᵀ + Q` was singular to the rounding of Q. The prediction is now raised to that
/// rounding, and every convention takes every step of that run too.
#[test]
fn priors_singular_to_rounding_are_floored_at_it() {
    use liebayes_filters::inertial::FixUpdate;
    let slow = InertialConfig {
        velocity_sigma: 1e-30,
        duration: 20.0,
        ..InertialConfig::default()
    };
    every_convention_takes_every_step(slow, FixUpdate::OnePass);
    every_convention_takes_every_step(with_every_initial_sigma(slow, 1e-30), FixUpdate::OnePass);
}

/// Dead reckoning at 1 Hz for 17 000 s, with one fix at the end: every prediction is taken. F's
/// velocity and position columns, by central differences of a fixed 1e-6 step, were within 20 %
/// of the rounding of positions 1e9 m out (where the estimate drifts without fixes), and the
/// covariance grew by that factor every step: the error-state filter's passed 1e100 at step
/// 16 180, and the invariant filters' predictions were refused from steps 12 135 and 14 977.
///
/// The fix, against an estimate 1.3e9 m off with attitude lost, was then taken by the one-pass
/// error-state filter, which returned, as Ok, an estimate 5.8e7 m off with a σ of 0.49 m; steps
/// that scaled with the state made it refuse the fix for its linearisation, as the left-invariant
/// filter does. With F and Q in closed form the error-state filter takes the fix and ends 0.42 m
/// from the truth, its NEES 43 inside the two-sided band of one χ²(15) draw at ±5 normal σ
/// ([1.02, 59.7]); the left-invariant filter still refuses the fix, and the right-invariant one
/// takes it and stays 1.3e9 m off, over-confident (NEES 272, above that band) but finite.
#[test]
fn a_long_dead_reckoning_keeps_every_prediction() {
    use liebayes_filters::inertial::{Convention, FixUpdate};
    use liebayes_operators::evaluation::chi_square_quantile;
    let config = InertialConfig {
        imu_rate: 1.0,
        duration: 17_000.0,
        fix_every: 17_000,
        ..InertialConfig::default()
    };
    let band = (
        chi_square_quantile(-5.0, 15.0).unwrap(),
        chi_square_quantile(5.0, 15.0).unwrap(),
    );
    for run in every_convention_runs(config, FixUpdate::OnePass, 5) {
        assert_eq!(run.fixes, 1);
        match run.convention {
            Convention::ErrorState => assert!(
                run.refused == 0 && run.error < 1.0 && (band.0..=band.1).contains(&run.nees),
                "{} m, NEES {} (band {band:?})",
                run.error,
                run.nees
            ),
            Convention::LeftInvariant => assert_eq!(run.refused, 1),
            Convention::RightInvariant => assert!(
                run.refused == 0 && run.nees > band.1 && run.nees < 1e3,
                "NEES {} (band {band:?})",
                run.nees
            ),
        }
    }
}

/// Every σ and noise at the low end of its range (1e-30, the bias walks 0) and a fix every sample:
/// every convention takes every step and ends on the true position.
#[test]
fn the_smallest_settings_keep_every_step() {
    use liebayes_filters::inertial::{FixUpdate, ImuNoise};
    let config = InertialConfig {
        imu: ImuNoise {
            gyro: 1e-30,
            accel: 1e-30,
            gyro_bias_walk: 0.0,
            accel_bias_walk: 0.0,
        },
        fix_sigma: 1e-30,
        fix_every: 1,
        duration: 20.0,
        ..InertialConfig::default()
    };
    let conventions = every_convention_takes_every_step(
        with_every_initial_sigma(config, 1e-30),
        FixUpdate::OnePass,
    );
    // The IMU is the filters' model and its noise 1e-30: the fixes of 1e-30 m pin the position.
    for run in conventions {
        assert!(run.error < 1e-6, "{:?}: {} m", run.convention, run.error);
    }
}

/// `config` with each of its six initial standard deviations at `sigma`.
fn with_every_initial_sigma(config: InertialConfig, sigma: f64) -> InertialConfig {
    InertialConfig {
        heading_sigma: sigma,
        tilt_sigma: sigma,
        velocity_sigma: sigma,
        position_sigma: sigma,
        gyro_bias_sigma: sigma,
        accel_bias_sigma: sigma,
        ..config
    }
}
