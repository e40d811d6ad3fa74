//! The production attitude filter on the experiment layer: driven through `RecursiveFilter` it
//! gives the same estimates as `run_attitude_ekf`; a study of independent simulated runs (the
//! field offset the filter models, a magnetometer ten times slower than the gyroscope) keeps its
//! heading, tilt and whole-attitude NEES below the χ² bands' upper ends at every scored epoch
//! of the last ten seconds.

use liebayes_experiments::{RecursiveFilter, Scenario, Shard, Study, replay};
use liebayes_filters::attitude::{
    AttitudeEkf, AttitudeParams, AttitudeScorer, ImuSample, ImuScenario, Sensors,
    SimulationSettings, run_attitude_ekf, simulate,
};
use liebayes_operators::evaluation::chi_square_quantile;

/// The same log through `RecursiveFilter` (predict with the gyroscope and accelerometer, update
/// with the magnetometer, every sample) and through `run_attitude_ekf`: equal bit for bit.
#[test]
fn recursive_filter_replays_run_attitude_ekf() {
    let log = simulate(
        &SimulationSettings {
            samples: 3000,
            ..SimulationSettings::default()
        },
        5,
    )
    .unwrap();
    let params = AttitudeParams::default();
    let expected = run_attitude_ekf(&log, &params, Sensors::NineD).unwrap();
    let mut filter = AttitudeEkf::new(params, Sensors::NineD, log.rate()).unwrap();
    let mag = log.magnetometer().unwrap();
    let mut updates = 0;
    for (k, (g, a)) in log.gyroscope().iter().zip(log.accelerometer()).enumerate() {
        filter.predict(&ImuSample { gyro: *g, acc: *a }).unwrap();
        let u = filter.update(&mag[k]).unwrap();
        if let Some(nis) = u.nis {
            assert!(nis.value.is_finite() && u.log_evidence.is_finite());
            updates += 1;
        }
        let e = filter.estimate().unwrap();
        assert_eq!(e.orientation, expected.orientations[k], "sample {k}");
    }
    // A heading update every 0.5 s (a few rejected at most).
    assert!((15..=21).contains(&updates), "{updates} heading updates");
}

/// Bad input through the trait: refused with a typed error, the filter unchanged.
#[test]
fn recursive_filter_refuses_bad_input() {
    let mut filter = AttitudeEkf::new(AttitudeParams::default(), Sensors::NineD, 100.0).unwrap();
    assert!(filter.estimate().is_err(), "no estimate before a sample");
    let still = ImuSample {
        gyro: nalgebra::Vector3::zeros(),
        acc: nalgebra::Vector3::new(0.0, 0.0, 9.81),
    };
    filter.predict(&still).unwrap();
    filter
        .update(&nalgebra::Vector3::new(0.0, 20.0, -40.0))
        .unwrap();
    let before = filter.estimate().unwrap();
    let bad = ImuSample {
        gyro: nalgebra::Vector3::new(f64::NAN, 0.0, 0.0),
        ..still
    };
    let err = filter.predict(&bad).unwrap_err();
    assert!(err.to_string().contains("gyroscope"), "{err}");
    assert!(
        filter
            .update(&nalgebra::Vector3::new(0.0, f64::INFINITY, 0.0))
            .is_err()
    );
    assert_eq!(filter.estimate().unwrap(), before);
}

/// A study of 64 independent 30-s runs with the magnetometer at a tenth of the gyroscope's rate:
/// at every epoch of the last 10 s the mean NEES over the runs, per degree of freedom, stays below
/// the upper end of the two-sided 99.8 % band of χ²(64 k)/(64 k) (k = 1 heading, 2 tilt, 3
/// whole), and above 0.1 for the heading (it is not uselessly loose).
#[test]
fn study_nees_stays_below_the_chi_square_band() {
    let params = AttitudeParams::default();
    let settings = SimulationSettings {
        samples: 8572,
        field_offset: params.magnetometer.offset,
        ..SimulationSettings::default()
    };
    let rate = settings.rate;
    let scenario = ImuScenario::new(settings, 10).unwrap();
    let runs = 64;
    let study = Study::new("EKF 9D", runs, 11, Shard::WHOLE).unwrap();
    let summary = study
        .run(
            &scenario,
            &|_| Ok(AttitudeEkf::new(params.clone(), Sensors::NineD, rate).expect("valid")),
            &AttitudeScorer,
            &|_| {},
        )
        .unwrap();
    assert_eq!(summary.failure_count(), 0);
    let epochs = summary.series("heading_nees").unwrap().epochs().len();
    assert_eq!(epochs, scenario.epochs());
    let upper = |dof: f64| {
        let n = runs as f64 * dof;
        chi_square_quantile(3.090_232_306, n).unwrap() / n
    };
    let mean = |name: &str, k: usize| {
        summary.series(name).unwrap().epochs()[k]
            .mean()
            .expect("scored")
    };
    // The runs last 30 s: the last third of the epochs.
    let last_ten_seconds = epochs - epochs / 3;
    let (mut worst_heading, mut worst_tilt, mut worst_whole) = (0.0_f64, 0.0_f64, 0.0_f64);
    for k in last_ten_seconds..epochs {
        let (h, t, w) = (
            mean("heading_nees", k),
            mean("tilt_nees", k),
            mean("nees", k),
        );
        // The means of χ²(k) values are near k: per degree of freedom against the band.
        let (h, t, w) = (h, t / 2.0, w / 3.0);
        assert!(h < upper(1.0) && h > 0.1, "epoch {k}: heading NEES {h}");
        assert!(t < upper(2.0), "epoch {k}: tilt NEES per dof {t}");
        assert!(w < upper(3.0), "epoch {k}: NEES per dof {w}");
        worst_heading = worst_heading.max(h);
        worst_tilt = worst_tilt.max(t);
        worst_whole = worst_whole.max(w);
    }
    println!(
        "last 10 s, largest mean NEES per dof over {runs} runs: heading {worst_heading:.2} (band \
         upper {:.2}), tilt {worst_tilt:.2} ({:.2}), whole {worst_whole:.2} ({:.2})",
        upper(1.0),
        upper(2.0),
        upper(3.0)
    );
}

/// One run replayed by the experiment layer's loop: every epoch scored, the heading updates'
/// NIS recorded.
#[test]
fn replay_scores_every_magnetometer_epoch() {
    let scenario = ImuScenario::new(
        SimulationSettings {
            samples: 2000,
            ..SimulationSettings::default()
        },
        10,
    )
    .unwrap();
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(3);
    let steps = scenario.simulate(&mut rng).unwrap();
    let mut filter =
        AttitudeEkf::new(AttitudeParams::default(), Sensors::NineD, 2000.0 / 7.0).unwrap();
    let scores = replay(&mut filter, steps, &AttitudeScorer).unwrap();
    assert_eq!(scores.epochs(), 200);
    let nis: Vec<f64> = (0..200)
        .filter_map(|k| scores.get("nis", k))
        .filter(|v| v.is_finite())
        .collect();
    assert!(nis.len() >= 10, "{} heading updates scored", nis.len());
    assert!(ImuScenario::new(SimulationSettings::default(), 0).is_err());
}
