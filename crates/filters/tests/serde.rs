//! serde round trip of the azimuth filter's state (feature `serde`), mid-run, and refusal of a state
//! outside the valid range on reading.
#![cfg(feature = "serde")]

use liebayes_filters::azimuth::{
    AzimuthDensity, PositionMeasurement, VelocityInput, VelocityProcess,
};
use nalgebra::Vector2;

#[test]
fn a_state_saved_mid_run_continues_exactly() {
    let process = VelocityProcess::new(0.1).unwrap();
    let measurement = PositionMeasurement::new(3.0).unwrap();
    let mut density = AzimuthDensity::new(Vector2::new(0.5, -0.2), 1.0).unwrap();
    let step = |d: &mut AzimuthDensity, k: u32| {
        let t = f64::from(k) * 0.1;
        let input = VelocityInput {
            velocity: Vector2::new(t.cos(), t.sin()) * 5.0,
            dt: 0.1,
        };
        d.predict(&process, &input).unwrap();
        d.update(&measurement, &Vector2::new(10.0 * t.sin(), 3.0 - t))
            .unwrap();
    };
    for k in 0..20 {
        step(&mut density, k);
    }
    let text = serde_json::to_string(&density).unwrap();
    let mut restored: AzimuthDensity = serde_json::from_str(&text).unwrap();
    assert_eq!(restored, density);
    for k in 20..40 {
        step(&mut density, k);
        step(&mut restored, k);
    }
    assert_eq!(restored, density);
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
