//! The production attitude filter on the experiment layer: the library's recorded run of a log
//! (`run_log`) gives the estimates of the filter stepped by hand through `RecursiveFilter`; a study
//! of independent simulated runs (the field offset the filter models, a magnetometer ten times
//! slower than the gyroscope) keeps its heading, tilt and whole-attitude NEES within bounds at
//! every scored epoch of the last ten seconds.

use liebayes_experiments::{RecursiveFilter, Scenario, Shard, Study, replay};
use liebayes_filters::attitude::{
    AtRate, AttitudeEkf, AttitudeParams, AttitudeScorer, ImuSample, ImuScenario, LogScenario,
    MEASURED_FIELD_OFFSET, Method, Sensors, SimulationSettings, run_log, simulate,
};
use liebayes_operators::evaluation::chi_square_quantile;

/// The same log stepped by hand through `RecursiveFilter` (predict with the gyroscope and
/// accelerometer, update with the magnetometer, every sample) and recorded by `run_log`: equal
/// bit for bit, and the heading updates' reports the same.
#[test]
fn run_log_replays_the_recursive_filter() {
    let log = simulate(
        &SimulationSettings {
            samples: 3000,
            ..SimulationSettings::default()
        },
        5,
    )
    .unwrap();
    let params = AttitudeParams::default();
    let method = Method::Ekf {
        params: params.clone(),
        sensors: Sensors::NineD,
    };
    let scenario = LogScenario::new(log.clone()).unwrap();
    let recording = run_log("simulated", &scenario, &method).unwrap();
    assert_eq!(recording.len(), log.len());
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
        let recorded = &recording.steps[k];
        assert_eq!(recorded.update, Some(u), "sample {k}");
        assert_eq!(recorded.estimate, filter.estimate().unwrap(), "sample {k}");
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

/// A study of 64 independent 30-s runs with the magnetometer at a tenth of the gyroscope's rate,
/// the filter told the simulator's sensor noise (`SimulationSettings::matched_noise`), over the
/// epochs of the last 10 s, the mean NEES over the runs per degree of freedom (a consistent
/// filter's is χ²(64 d)/(64 d), d = 1 heading, 2 tilt, 3 whole):
///
/// * the heading's is within the two-sided 99.8 % band of χ²(64)/64 at every epoch (measured
///   1.00 to 1.14 in [0.54, 1.64]): consistent both ways;
/// * the tilt's and the whole attitude's stay below the band's upper end at every epoch (not
///   over-confident), and their average over the epochs lies in [0.5, 2] per degree of freedom,
///   the band the BROAD figures are held to (measured: tilt 0.45 to 0.87, average 0.63; the χ²
///   band's lower end, 0.66, is not met: the reported tilt, calibrated on BROAD with
///   `AttitudeParams::tilt_variance_scale`, is slightly cautious on the simulator; the filter's
///   own covariance gave 0.10).
#[test]
fn study_nees_stays_in_the_band() {
    let settings = SimulationSettings {
        samples: 8572,
        field_offset: Some(MEASURED_FIELD_OFFSET),
        ..SimulationSettings::default()
    };
    let params = settings
        .matched_noise(AttitudeParams::default())
        .expect("matched settings");
    let rate = settings.rate;
    let scenario = ImuScenario::new(settings, 10).unwrap();
    let runs = 64;
    let study = Study::new("EKF 9D", runs, 11, Shard::WHOLE).unwrap();
    let method = |rate| AtRate {
        method: Method::Ekf {
            params: params.clone(),
            sensors: Sensors::NineD,
        },
        rate,
    };
    // A method that cannot be built is refused before any run, with its error as the source.
    let refused = study.run_method(&scenario, &method(0.0), &AttitudeScorer, &|_| {
        panic!("no run may start")
    });
    assert!(std::error::Error::source(&refused.unwrap_err()).is_some());
    let summary = study
        .run_method(&scenario, &method(rate), &AttitudeScorer, &|_| {})
        .unwrap();
    assert_eq!(summary.failure_count(), 0);
    let epochs = summary.series("heading_nees").unwrap().epochs().len();
    assert_eq!(epochs, scenario.epochs());
    // The two-sided 99.8 % band of the mean of χ²(runs d) per degree of freedom.
    let band = |dof: f64| {
        let n = runs as f64 * dof;
        let z = 3.090_232_306;
        (
            chi_square_quantile(-z, n).unwrap() / n,
            chi_square_quantile(z, n).unwrap() / n,
        )
    };
    let mean = |name: &str, k: usize| {
        summary.series(name).unwrap().epochs()[k]
            .mean()
            .expect("scored")
    };
    // The runs last 30 s: the last third of the epochs.
    let last_ten_seconds = epochs - epochs / 3;
    let names = ["heading_nees", "tilt_nees", "nees"];
    // Per metric: the smallest, largest and summed per-dof means over the epochs.
    let mut seen = [(f64::INFINITY, 0.0_f64, 0.0); 3];
    for k in last_ten_seconds..epochs {
        for (d, (name, s)) in names.iter().zip(&mut seen).enumerate() {
            let dof = (d + 1) as f64;
            let v = mean(name, k) / dof;
            let (low, high) = band(dof);
            assert!(v < high, "epoch {k}: {name} per dof {v} above {high}");
            if d == 0 {
                assert!(v > low, "epoch {k}: {name} {v} below {low}");
            }
            *s = (s.0.min(v), s.1.max(v), s.2 + v);
        }
    }
    let count = (epochs - last_ten_seconds) as f64;
    for (d, (name, (low, high, sum))) in names.iter().zip(seen).enumerate() {
        let average = sum / count;
        println!(
            "last 10 s, {name} per dof over {runs} runs: {low:.3} to {high:.3}, average \
             {average:.3} (band {:.3?})",
            band((d + 1) as f64)
        );
        assert!(
            (0.5..=2.0).contains(&average),
            "{name}: average per dof {average} outside [0.5, 2]"
        );
    }
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
