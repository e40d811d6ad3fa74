//! A `Recursive` filter checkpointed mid-run (feature `serde`) and resumed continues the
//! uninterrupted run bit for bit: whole, when its density and models are serde (the linear Kalman
//! filter), and through its density alone when its models are closures.
#![cfg(feature = "serde")]

use liebayes_densities::{Gaussian, ManifoldGaussian};
use liebayes_experiments::{Recursive, RecursiveFilter};
use liebayes_manifolds::{Manifold, So2};
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::{Ekf, MeasurementFn, ProcessFn};
use nalgebra::{Matrix1, Matrix2, RowVector2, Vector1, Vector2};

/// A deterministic reading at step k (the identity does not depend on the values).
fn reading(k: u32) -> f64 {
    0.3 * f64::from(k) + (1.3 * f64::from(k)).sin()
}

#[test]
fn a_linear_kalman_filter_resumes_from_its_checkpoint_bit_for_bit() {
    let process =
        LinearProcess::new(Matrix2::new(1.0, 0.5, 0.0, 1.0), Matrix2::identity() * 0.01).unwrap();
    let sensor = LinearMeasurement::new(RowVector2::new(1.0, 0.0), Matrix1::new(0.2)).unwrap();
    let prior = Gaussian::new(Vector2::new(0.0, 0.3), Matrix2::identity()).unwrap();
    let mut whole = Recursive::new(prior.clone(), process.clone(), sensor.clone());
    let mut resumed = Recursive::new(prior, process, sensor);
    for k in 1..=30 {
        for filter in [&mut whole, &mut resumed] {
            filter.predict(&Vector2::zeros()).unwrap();
            filter.update(&Vector1::new(reading(k))).unwrap();
        }
        if k == 13 {
            let text = serde_json::to_string(&resumed).unwrap();
            resumed = serde_json::from_str(&text).unwrap();
        }
        assert_eq!(
            resumed.estimate().unwrap(),
            whole.estimate().unwrap(),
            "step {k}"
        );
    }
}

#[test]
fn a_filter_with_closure_models_resumes_from_its_density_bit_for_bit() {
    let models = || {
        (
            Ekf(ProcessFn::new(
                |x: &So2<f64>, (): &()| x.retract(&Vector1::new(0.3)),
                |_, ()| Matrix1::new(1e-3),
            )),
            Ekf(MeasurementFn::new(
                |x: &So2<f64>| Vector1::new(x.angle()),
                |_| Matrix1::new(0.01),
            )),
        )
    };
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(3.0), Matrix1::new(0.1)).unwrap();
    let (process, sensor) = models();
    let mut whole = Recursive::new(prior.clone(), process, sensor);
    let (process, sensor) = models();
    let mut resumed = Recursive::new(prior, process, sensor);
    for k in 1..=30 {
        for filter in [&mut whole, &mut resumed] {
            filter.predict(&()).unwrap();
            filter.update(&Vector1::new(reading(k))).unwrap();
        }
        if k == 17 {
            let text = serde_json::to_string(resumed.density()).unwrap();
            let (process, sensor) = models();
            resumed = Recursive::new(serde_json::from_str(&text).unwrap(), process, sensor);
        }
        assert_eq!(
            resumed.estimate().unwrap(),
            whole.estimate().unwrap(),
            "step {k}"
        );
    }
}
