//! serde round trip of the azimuth filter's state (feature `serde`), mid-run, and refusal of a state
//! outside the valid range on reading.
#![cfg(feature = "serde")]

use liebayes_experiments::{AsIs, Metric, Recursive, Reduction, RunScores, Scorer, Step, replay};
use liebayes_filters::azimuth::{
    AzimuthDensity, PositionMeasurement, VelocityInput, VelocityProcess, exact,
};
use nalgebra::Vector2;

/// The seven numbers of the exact filter's density at each epoch (no truth is needed).
struct SevenNumbers;

impl Scorer<(), AzimuthDensity> for SevenNumbers {
    fn metrics(&self) -> Vec<Metric> {
        ["eta_x", "eta_y", "a_x", "a_y", "c_x", "c_y", "sigma2"]
            .into_iter()
            .map(|name| Metric::new(name, Reduction::Mean, ""))
            .collect()
    }

    fn score(&self, (): &(), density: &AzimuthDensity, values: &mut [f64]) {
        let (eta, a, c) = (density.eta(), density.a(), density.c());
        values.copy_from_slice(&[eta.x, eta.y, a.x, a.y, c.x, c.y, density.sigma2()]);
    }
}

/// The bits of every score (the NIS column is NaN for the exact filter, which has none).
fn bits(scores: &RunScores) -> Vec<u64> {
    scores.values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn a_state_saved_mid_run_continues_exactly() {
    let process = VelocityProcess::new(0.1).unwrap();
    let measurement = PositionMeasurement::new(3.0).unwrap();
    let steps: Vec<Step<(), VelocityInput, Vector2<f64>>> = (0..40_u32)
        .map(|k| {
            let t = f64::from(k) * 0.1;
            Step {
                time: t,
                input: VelocityInput {
                    velocity: Vector2::new(t.cos(), t.sin()) * 5.0,
                    dt: 0.1,
                },
                truth: (),
                measurement: Some(Vector2::new(10.0 * t.sin(), 3.0 - t)),
            }
        })
        .collect();
    let (first, second) = steps.split_at(20);
    let mut filter = exact(process, measurement, Vector2::new(0.5, -0.2), 1.0)
        .unwrap()
        .estimated_by(AsIs);
    replay(&mut filter, first.iter().cloned(), &SevenNumbers).unwrap();
    let text = serde_json::to_string(filter.density()).unwrap();
    let mut restored = Recursive::new(
        serde_json::from_str::<AzimuthDensity>(&text).unwrap(),
        process,
        measurement,
    );
    assert_eq!(restored.density(), filter.density());
    let original = replay(&mut filter, second.iter().cloned(), &SevenNumbers).unwrap();
    let continued = replay(&mut restored, second.iter().cloned(), &SevenNumbers).unwrap();
    assert_eq!(original.epochs(), 20);
    assert_eq!(
        bits(&continued),
        bits(&original),
        "the epochs after the save"
    );
    assert_eq!(restored.density(), filter.density());

    let input = VelocityInput {
        velocity: Vector2::new(1.5, -0.25),
        dt: 0.01,
    };
    let text = serde_json::to_string(&input).unwrap();
    assert_eq!(serde_json::from_str::<VelocityInput>(&text).unwrap(), input);
}

#[test]
fn states_outside_the_valid_range_are_refused() {
    for (text, message) in [
        (
            r#"{"eta": [0.0, 0.0], "a": [0.0, 0.0], "c": [0.0, 0.0], "sigma2": -1.0}"#,
            "sigma",
        ),
        (
            r#"{"eta": [0.0, 0.0], "a": [0.0, 0.0], "c": [0.0, 0.0], "sigma2": 0.0}"#,
            "sigma",
        ),
        (
            r#"{"eta": [0.0], "a": [0.0, 0.0], "c": [0.0, 0.0], "sigma2": 1.0}"#,
            "",
        ),
        (
            r#"{"eta": [0.0, 0.0], "a": [0.0, 0.0], "c": [0.0, 0.0]}"#,
            "sigma2",
        ),
    ] {
        let error = serde_json::from_str::<AzimuthDensity>(text).unwrap_err();
        assert!(error.to_string().contains(message), "{text}: {error}");
    }
}
