//! serde round trips of the particle set, the grid, the linear models and the smoothers (feature
//! `serde`), a smoother checkpointed mid-run and resumed giving the uninterrupted run's estimates
//! bit for bit, and refusal of invalid states on reading.
#![cfg(feature = "serde")]

use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use liebayes_manifolds::So2;
use liebayes_operators::fixed_lag::FixedLagSmoother;
use liebayes_operators::grid::CircularGrid;
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::particle::{ParticleSet, Resampling};
use liebayes_operators::smoother::RtsSmoother;
use liebayes_operators::{Ekf, MeasurementFn, ProcessFn, Ukf};
use nalgebra::{Matrix1, Matrix2, Matrix2x3, Matrix3, Vector1};

/// Log weights agree to a few ulp of their size: reading renormalises by `ln Σ wᵢ`, 0 up to rounding.
fn assert_log_weights_close(a: &[f64], b: &[f64]) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert!(
            x == y || (x - y).abs() <= 4.0 * f64::EPSILON * x.abs().max(1.0),
            "{x} vs {y}"
        );
    }
}

#[test]
fn particle_sets_round_trip() {
    let particles: Vec<So2<f64>> = (0..7)
        .map(|i| So2::from_angle_unchecked(0.9 * f64::from(i) - 3.0))
        .collect();
    let log_weights = [-1e3, -2.5, 0.0, 7.0, f64::NEG_INFINITY, 1e-300, -700.0];
    let set = ParticleSet::from_log_weighted_samples(particles, &log_weights).unwrap();
    let text = serde_json::to_string(&set).unwrap();
    let back: ParticleSet<So2<f64>> = serde_json::from_str(&text).unwrap();
    assert_eq!(back.particles(), set.particles());
    assert_log_weights_close(back.log_weights(), set.log_weights());
}

#[test]
fn grids_round_trip() {
    let grid = CircularGrid::from_log_density(16, |t| 3.0 * t.cos(), |t| [t, t * t]).unwrap();
    let text = serde_json::to_string(&grid).unwrap();
    let back: CircularGrid<[f64; 2]> = serde_json::from_str(&text).unwrap();
    assert_eq!(back.cells(), grid.cells());
    assert_log_weights_close(back.log_weights(), grid.log_weights());
}

#[test]
fn linear_models_and_schemes_round_trip_exactly() {
    let process = LinearProcess::new(
        Matrix3::new(1.0, 0.1, 0.0, 0.0, 1.0, 0.1, 0.0, 0.0, 1.0),
        Matrix3::from_diagonal_element(1e-7) + Matrix3::from_element(1e-9),
    )
    .unwrap();
    let text = serde_json::to_string(&process).unwrap();
    assert_eq!(
        serde_json::from_str::<LinearProcess<3>>(&text).unwrap(),
        process
    );
    let measurement = LinearMeasurement::new(
        Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        Matrix2::new(0.5, 0.1, 0.1, 0.3),
    )
    .unwrap();
    let text = serde_json::to_string(&measurement).unwrap();
    assert_eq!(
        serde_json::from_str::<LinearMeasurement<3, 2>>(&text).unwrap(),
        measurement
    );
    for scheme in [
        Resampling::Multinomial,
        Resampling::Stratified,
        Resampling::Systematic,
        Resampling::Residual,
    ] {
        let text = serde_json::to_string(&scheme).unwrap();
        assert_eq!(serde_json::from_str::<Resampling>(&text).unwrap(), scheme);
    }
}

#[test]
fn invalid_states_are_refused_with_the_constructors_message() {
    let cases = [
        // More weights than particles.
        (
            r#"{"particles": [[1.0, 0.0]], "log_weights": [0.0, 0.0]}"#,
            "number of weights",
        ),
        // Every weight zero.
        (
            r#"{"particles": [[1.0, 0.0]], "log_weights": [-1e999]}"#,
            "",
        ),
        // An empty set.
        (r#"{"particles": [], "log_weights": []}"#, "particle"),
        // A point off the circle.
        (r#"{"particles": [[2.0, 0.0]], "log_weights": [0.0]}"#, ""),
    ];
    for (text, message) in cases {
        let error = serde_json::from_str::<ParticleSet<So2<f64>>>(text).unwrap_err();
        assert!(error.to_string().contains(message), "{text}: {error}");
    }
    let error =
        serde_json::from_str::<CircularGrid<()>>(r#"{"log_weights": [0.0, 1.0], "cells": [null]}"#)
            .unwrap_err();
    assert!(error.to_string().contains("grid log weights"), "{error}");
    // Q with a negative variance.
    let error =
        serde_json::from_str::<LinearProcess<1>>(r#"{"transition": [1.0], "noise": [-1.0]}"#)
            .unwrap_err();
    assert!(error.to_string().contains("covariance Q"), "{error}");
    let error = serde_json::from_str::<Resampling>(r#""Bootstrap""#).unwrap_err();
    assert!(error.to_string().contains("Systematic"), "{error}");
}

/// A deterministic compass reading at epoch k (the checkpoint's identity does not depend on it).
fn reading(k: u32) -> Vector1<f64> {
    Vector1::new(0.02 * f64::from(k) + 0.1 * (f64::from(k) * 1.7).sin())
}

#[test]
fn smoothers_checkpointed_mid_run_resume_bit_for_bit() {
    let gyro = ProcessFn::new(
        |x: &So2<f64>, rate: &f64| x.retract(&Vector1::new(*rate)),
        |_, _| Matrix1::new(1e-3),
    );
    let compass = MeasurementFn::new(
        |x: &So2<f64>| Vector1::new(x.angle()),
        |_| Matrix1::new(0.01),
    );
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(3.0), Matrix1::new(0.5)).unwrap();
    let (epochs, checkpoint) = (40_u32, 17_u32);
    // The RTS smoother: its whole record saved and read back at epoch 17.
    let rts_step = |rts: &mut RtsSmoother<So2<f64>, 1>, k: u32| {
        rts.propagate(&Ekf(&gyro), &0.02).unwrap();
        rts.condition(&Ukf::new(&compass), &reading(k)).unwrap();
    };
    let mut whole = RtsSmoother::new(prior.clone());
    let mut resumed = RtsSmoother::new(prior.clone());
    for k in 1..=epochs {
        rts_step(&mut whole, k);
        rts_step(&mut resumed, k);
        if k == checkpoint {
            let text = serde_json::to_string(&resumed).unwrap();
            resumed = serde_json::from_str(&text).unwrap();
        }
    }
    assert_eq!(resumed, whole);
    assert_eq!(resumed.smooth().unwrap(), whole.smooth().unwrap());
    // The fixed-lag smoother: its window saved and read back, its lagged outputs compared at every
    // epoch after.
    let lagged =
        |fixed: &mut FixedLagSmoother<So2<f64>, 1>| fixed.smooth().unwrap().lagged().cloned();
    let mut whole = FixedLagSmoother::new(prior.clone(), 5).unwrap();
    let mut resumed = whole.clone();
    for k in 1..=epochs {
        for fixed in [&mut whole, &mut resumed] {
            fixed.propagate(&Ekf(&gyro), &0.02).unwrap();
            fixed.condition(&Ekf(&compass), &reading(k)).unwrap();
        }
        if k == checkpoint {
            let text = serde_json::to_string(&resumed).unwrap();
            resumed = serde_json::from_str(&text).unwrap();
        }
        assert_eq!(lagged(&mut resumed), lagged(&mut whole), "epoch {k}");
    }
    assert!(lagged(&mut whole).is_some());
    // Malformed records are refused with the constructors' messages.
    let text = serde_json::to_string(&whole).unwrap();
    let wrong_lag = text.replacen("\"lag\":5", "\"lag\":4", 1);
    let error = serde_json::from_str::<FixedLagSmoother<So2<f64>, 1>>(&wrong_lag).unwrap_err();
    assert!(error.to_string().contains("window"), "{error}");
    let error =
        serde_json::from_str::<RtsSmoother<So2<f64>, 1>>(r#"{"filtered": [], "transitions": []}"#)
            .unwrap_err();
    assert!(error.to_string().contains("filtered densities"), "{error}");
}
