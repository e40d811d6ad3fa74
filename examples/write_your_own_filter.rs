//! Write your own filter from the operators: a heading on SO(2) driven by a gyroscope and corrected by a
//! compass whose reading wraps at ±π. `cargo run --release --example write_your_own_filter`.
//!
//! Two models, a process and a measurement, are all a user writes (here as types implementing the
//! model traits; `ProcessFn` and `MeasurementFn` make the same models from closures). They are built
//! once and used by reference at every step. The EKF and the UKF run them on the manifold (no angle is
//! ever wrapped by hand) and report their innovation, whose NIS checks them; a grid filter on the
//! circle, built from the same measurement model's likelihood, gives the exact posterior to compare
//! with.

use liebayes::densities::ManifoldGaussian;
use liebayes::manifolds::{Manifold, So2};
use liebayes::operators::grid::{CircularGrid, Diffusion};
use liebayes::operators::particle::{LikelihoodFn, Reweight};
use liebayes::operators::{
    Condition, Ekf, MeasurementModel, OperatorError, ProcessModel, Propagate, Ukf,
};
use nalgebra::{Matrix1, Vector1};

/// `a ⊟ b` on SO(2): the angle difference a − b wrapped to (−π, π], through the group rather than by
/// hand.
fn wrapped(a: f64, b: f64) -> f64 {
    So2::from_angle_unchecked(b).local(&So2::from_angle_unchecked(a))[0]
}

/// θ′ = θ + ω dt + w, w ~ N(0, q² dt): gyroscope integration with rate noise.
struct Gyro {
    q2: f64,
}

impl ProcessModel<So2<f64>, 1> for Gyro {
    /// (ω, dt).
    type Input = (f64, f64);

    fn transition(&self, x: &So2<f64>, &(rate, dt): &(f64, f64)) -> So2<f64> {
        x.retract(&Vector1::new(rate * dt))
    }

    fn noise(&self, _: &So2<f64>, &(_, dt): &(f64, f64)) -> Matrix1<f64> {
        Matrix1::new(self.q2 * dt)
    }
}

/// A compass reading of θ in (−π, π] with noise σ²; the residual wraps.
struct Compass {
    variance: f64,
}

impl MeasurementModel<So2<f64>, 1, 1> for Compass {
    fn predict(&self, x: &So2<f64>) -> Vector1<f64> {
        Vector1::new(x.angle())
    }

    fn noise(&self, _: &So2<f64>) -> Matrix1<f64> {
        Matrix1::new(self.variance)
    }

    fn residual(&self, z: &Vector1<f64>, predicted: &Vector1<f64>) -> Vector1<f64> {
        Vector1::new(wrapped(z[0], predicted[0]))
    }
}

fn main() -> Result<(), OperatorError> {
    let gyro = Gyro { q2: 0.01 };
    let compass = Compass {
        variance: 0.3_f64.powi(2),
    };
    // Start near +π; the compass readings will come from the other side of the cut.
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(3.0), Matrix1::new(0.5))?;
    let (mut ekf, mut ukf) = (prior.clone(), prior);
    let mut grid =
        CircularGrid::from_log_density(720, |t| -0.5 * wrapped(t, 3.0).powi(2) / 0.5, |_| ())?;
    // The models, wrapped once: by reference, `Ekf(&gyro)` is as good as `Ekf(gyro)`.
    let (ekf_gyro, ukf_gyro) = (Ekf(&gyro), Ukf::new(&gyro));
    let (ekf_compass, ukf_compass) = (Ekf(&compass), Ukf::new(&compass));
    // The grid's measurement: the compass likelihood at each cell's heading.
    let grid_compass = Reweight(LikelihoodFn::new(|t: &So2<f64>, z: &Vector1<f64>| {
        -0.5 * wrapped(z[0], t.angle()).powi(2) / compass.variance
            - 0.5 * (2.0 * std::f64::consts::PI * compass.variance).ln()
    }));
    for (rate, reading) in [(0.1, -3.05), (0.1, -2.95), (0.0, -3.0), (0.2, -2.8)] {
        let step = (rate, 1.0);
        ekf = ekf.propagate(&ekf_gyro, &step)?;
        ukf = ukf.propagate(&ukf_gyro, &step)?;
        // The grid's propagation: the circular convolution with the step's density, θ′ − θ ~ N(ω dt, q² dt)
        // (one wrap of the normal suffices at this spread). Stepped in place: no copy of the cells.
        let gyro_kernel =
            Diffusion(|d: &So2<f64>| (-0.5 * wrapped(d.angle(), rate).powi(2) / gyro.q2).exp());
        grid.propagate_in_place(&gyro_kernel, &())?;

        let z = Vector1::new(reading);
        let e = ekf.condition(&ekf_compass, &z)?;
        let u = ukf.condition(&ukf_compass, &z)?;
        let evidence = grid.condition_in_place(&grid_compass, &z)?.log_evidence;
        ekf = e.posterior;
        ukf = u.posterior;
        let m = grid.first_moment();
        println!(
            "reading {reading:+.2}: EKF {:+.4} rad, UKF {:+.4} rad, exact grid mean {:+.4} rad; \
             log evidence EKF {:.3}, UKF {:.3}, grid {:.3}; NIS EKF {:.2}, UKF {:.2}",
            ekf.mean().angle(),
            ukf.mean().angle(),
            m.y.atan2(m.x),
            e.log_evidence,
            u.log_evidence,
            evidence,
            e.report.nis(),
            u.report.nis(),
        );
    }
    Ok(())
}
