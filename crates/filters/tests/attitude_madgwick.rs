//! Madgwick's filter as the BROAD example evaluation runs it: the published figures on the trials
//! (the two shipped, or the twelve with `$LIEBAYES_BROAD_DIR`), its convergence at rest, its start, and a step that
//! overflows. Its gradients are checked against finite differences in its module.

use liebayes_experiments::RecursiveFilter;
use liebayes_filters::attitude::{
    BROAD_BETA, ImuSample, LogScenario, LogScore, Madgwick, Method, Sensors, broad_initial_state,
    enu_from_nwu, read_broad, run_log,
};
use liebayes_reference::broad::trials;
use nalgebra::{UnitQuaternion, Vector3};

/// The Madgwick column of the BROAD table (total / heading / inclination RMSE, degrees).
const PUBLISHED: [(&str, [f64; 3]); 12] = [
    ("01_undisturbed_slow_rotation_A", [2.31, 2.17, 0.78]),
    (
        "05_undisturbed_slow_rotation_with_breaks_B",
        [1.79, 1.63, 0.72],
    ),
    ("07_undisturbed_fast_rotation_B", [5.00, 4.33, 2.50]),
    ("10_undisturbed_slow_translation_A", [3.57, 1.71, 3.13]),
    (
        "14_undisturbed_slow_translation_with_breaks_B",
        [3.10, 1.60, 2.65],
    ),
    ("16_undisturbed_fast_translation_B", [4.82, 3.70, 3.09]),
    ("21_undisturbed_fast_combined", [7.16, 5.54, 4.53]),
    ("24_disturbed_tapping_A", [1.77, 1.24, 1.26]),
    ("27_disturbed_phone_vibration_B", [10.62, 10.50, 1.57]),
    ("28_disturbed_stationary_magnet_A", [8.33, 7.46, 3.70]),
    ("32_disturbed_attached_magnet_1cm", [15.76, 14.96, 4.97]),
    ("35_disturbed_attached_magnet_4cm", [3.27, 1.14, 3.06]),
];

/// The published figures have two decimals: a reproduction is within their rounding (0.005)
/// plus 0.005.
const TOLERANCE_DEG: f64 = 0.01;

/// Every available trial ([`trials`]: the two shipped, or the twelve) against its published
/// figures.
fn check_trials(published_figures: &[(&str, [f64; 3])]) {
    let method = Method::from_name("madgwick-9d").expect("a method");
    let mut worst = 0.0_f64;
    let available = trials();
    assert!(!available.is_empty());
    for (name, path) in available {
        let (_, published) = published_figures
            .iter()
            .find(|(n, _)| *n == name)
            .expect("a published figure for every trial");
        let log = read_broad(path).expect("BROAD trial reads");
        let scenario = LogScenario::new(log).expect("a non-empty trial");
        let recording = run_log(name, &scenario, &method).expect("Madgwick runs");
        let e = LogScore::of(&recording).errors().expect("scored");
        let ours = [e.total, e.heading, e.inclination];
        println!(
            "{name}: {:.4} / {:.4} / {:.4} (published {published:?})",
            ours[0], ours[1], ours[2]
        );
        for (o, p) in ours.iter().zip(published) {
            worst = worst.max((o - p).abs());
        }
    }
    println!("largest difference from the published figures: {worst:.4} deg");
    assert!(worst <= TOLERANCE_DEG, "largest difference {worst} deg");
}

#[test]
fn reproduces_the_published_figures() {
    check_trials(&PUBLISHED);
}

/// At rest with exact gravity and an earth field with a dip, from the identity, the 6D filter's
/// inclination and the 9D filter's orientation converge to the truth, up to the limit cycle of
/// the normalised gradient step: each step moves q by at most β Δt, an angle of 2 β Δt.
#[test]
fn converges_at_rest() {
    let rate = 100.0;
    let truth = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1); // IMU w.r.t. ENU
    let up = Vector3::z();
    let field_enu = Vector3::new(0.0, 20.0, -45.0); // north and down, µT
    let acc = truth.inverse() * (9.81 * up);
    let mag = truth.inverse() * field_enu;
    let sample = ImuSample {
        gyro: Vector3::zeros(),
        acc,
    };
    for with_mag in [false, true] {
        let sensors = if with_mag {
            Sensors::NineD
        } else {
            Sensors::SixD
        };
        let mut filter = Madgwick::new(0.5, sensors, rate).expect("valid");
        for _ in 0..6000 {
            filter.predict(&sample).expect("finite step");
            if with_mag {
                filter.update(&mag).expect("finite step");
            }
        }
        let est = filter.estimate().expect("an estimate").orientation;
        let bound = 2.0 * 0.5 / rate;
        let tilt = (est.inverse() * up).angle(&(truth.inverse() * up));
        assert!(tilt < bound, "tilt error {tilt} rad (mag {with_mag})");
        if with_mag {
            let total = est.angle_to(&truth);
            assert!(total < bound, "total error {total} rad");
        }
    }
}

/// The example's initial state gives the ENU orientation whose accelerometer prediction is the
/// first sample's direction (the example's convention, checked on a known orientation).
#[test]
fn initial_state_follows_the_example_construction() {
    let truth = UnitQuaternion::from_euler_angles(0.4, 0.1, -0.7);
    let acc = truth.inverse() * Vector3::new(0.0, 0.0, 9.81);
    let mag = truth.inverse() * Vector3::new(0.0, 20.0, -45.0);
    let q0 = broad_initial_state(&acc, Some(&mag)).expect("not degenerate");
    // The state's matrix has the normalised accelerometer as its third column.
    let r = q0.to_rotation_matrix();
    assert!((r.matrix().column(2) - acc.normalize()).norm() < 1e-12);
    assert!(broad_initial_state(&Vector3::zeros(), Some(&mag)).is_none());
    assert!(broad_initial_state(&mag, Some(&mag)).is_none());
    // 1e-13 rad apart, where the rounding of their cross product would pick the heading: none.
    let up = Vector3::new(0.0, 0.0, 9.81);
    assert!(broad_initial_state(&up, Some(&Vector3::new(1e-13, 0.0, 1.0))).is_none());
    // 1e-6 rad apart: the heading is the data's (x points along the field's tilt, against it).
    let q = broad_initial_state(&up, Some(&Vector3::new(1e-6, 0.0, 1.0))).expect("not parallel");
    assert!((q * Vector3::x() + Vector3::x()).norm() < 1e-9);
    // NWU's x (North) and y (West) are ENU's North and minus East.
    let q = enu_from_nwu();
    assert!((q * Vector3::x() - Vector3::y()).norm() < 1e-15);
    assert!((q * Vector3::y() + Vector3::x()).norm() < 1e-15);
    // A first sample with a zero accelerometer gives no start: refused, nothing set.
    let mut filter = Madgwick::new(BROAD_BETA, Sensors::NineD, 100.0).expect("valid");
    let zero = ImuSample {
        gyro: Vector3::zeros(),
        acc: Vector3::zeros(),
    };
    assert!(filter.predict(&zero).is_err());
    assert_eq!(filter.state(), None);
    assert!(filter.estimate().is_err());
}

/// A rate whose interval is huge is refused at construction (at 1e-305 Hz a step at the largest
/// angular rate overflowed); at the slowest accepted rate, 1e-3 Hz, that step is finite. (Bad
/// readings are refused by every filter alike: `attitude_data`.)
#[test]
fn a_rate_whose_steps_overflow_is_refused() {
    assert!(Madgwick::new(BROAD_BETA, Sensors::NineD, 1e-305).is_err());
    let mut slow = Madgwick::new(BROAD_BETA, Sensors::NineD, 1e-3).expect("valid");
    let fastest = ImuSample {
        gyro: Vector3::new(1e4, 0.0, 0.0),
        acc: Vector3::new(0.5, -0.3, 9.7),
    };
    slow.predict(&fastest).unwrap();
    let q = slow.state().unwrap();
    assert!(q.coords.iter().all(|v| v.is_finite()));
}

/// A first magnetometer reading that gives no heading (zero, or parallel to gravity) starts the
/// filter as without a magnetometer, in Madgwick's and the talk's filters alike.
#[test]
fn a_first_reading_without_a_heading_starts_as_6d() {
    let level = ImuSample {
        gyro: Vector3::zeros(),
        acc: Vector3::new(0.0, 0.0, 9.81),
    };
    for name in ["madgwick-9d", "talk-9d"] {
        for reading in [Vector3::zeros(), Vector3::new(0.0, 0.0, -40.0)] {
            let mut filter = Method::from_name(name).unwrap().build(100.0).unwrap();
            filter.predict(&level).unwrap();
            let six = filter.estimate().unwrap();
            filter.update(&reading).unwrap();
            let estimate = filter.estimate().unwrap();
            assert!(
                estimate.orientation.angle_to(&six.orientation) < 1e-9,
                "{name}, {reading:?}"
            );
        }
    }
}

/// A huge accepted gain with a reading whose gradient is tiny (norm 3.1e-162, its square
/// subnormal): `β / |∇|` overflowed, the 6D step of the 9D filter was left waiting by `predict`
/// and failed in every later call. The gradient is now normalised before the gain, and a sample
/// whose `(|ω|_∞ + β) Δt` exceeds ¼ is stepped at once, so the filter stays usable.
#[test]
fn a_huge_gain_with_a_tiny_gradient_leaves_a_finite_state() {
    let mut filter = Madgwick::new(1e150, Sensors::NineD, 100.0).expect("a finite gain");
    let level = ImuSample {
        gyro: Vector3::zeros(),
        acc: Vector3::new(0.0, 0.0, 9.81),
    };
    let tilted = ImuSample {
        gyro: Vector3::zeros(),
        acc: Vector3::new(1.5e-162, 0.0, 1.0),
    };
    filter.predict(&level).unwrap();
    filter.predict(&tilted).unwrap();
    let estimate = filter
        .estimate()
        .expect("the step after an accepted sample");
    assert!(estimate.orientation.coords.iter().all(|c| c.is_finite()));
    // The state is unit (rounding only).
    assert!((estimate.orientation.coords.norm() - 1.0).abs() < 1e-12);
    filter.predict(&level).expect("the filter is not stuck");
    assert!(filter.estimate().is_ok());
}

/// Β was any finite value ≥ 0 (5e-324 and 1e300 passed), checked by hand. It is now
/// 0 or the shared positive range [1.5e-154, 1e150], refused naming `beta`.
#[test]
fn the_gain_uses_the_shared_positive_range() {
    for beta in [5e-324, 1e-200, 1e151, 1e300, -0.1, f64::NAN, f64::INFINITY] {
        let error = Madgwick::new(beta, Sensors::NineD, 100.0).unwrap_err();
        assert!(error.to_string().contains("`beta`"), "{beta}: {error}");
    }
    for beta in [0.0, 1.5e-154, 0.1, 1e150] {
        assert!(Madgwick::new(beta, Sensors::NineD, 100.0).is_ok(), "{beta}");
    }
}
