//! Gravity-aided attitude on SO(3) with body-frame (right) and world-frame (left) errors: the same
//! models, the same data, two error conventions, and their consistency measured.
//! `cargo run --release --example attitude_conventions`.
//!
//! A gyroscope drives the attitude R (body to world), `R′ = R exp(ω dt)`, with white rate noise; an
//! accelerometer at rest measures gravity in the body frame, `z = Rᵀ g + n`. Yaw (rotation about the
//! vertical) is unobservable: gravity says nothing about it. The models are written once, generic over the
//! state type, with the library's Jacobians (`j_compose_self`, `j_act_self`, `j_inverse_self`), which
//! follow the state type's error convention:
//!
//! * `So3` perturbs on the right (`R exp(δ)`, an error in the body frame). The unobservable direction,
//!   the vertical seen from the body, `R̂ᵀ e_z`, moves with every estimate, so each linearisation at a new
//!   estimate puts a little of the yaw into the observable directions: the filter gains yaw information
//!   that the data do not contain, and becomes over-confident.
//! * `Left<So3>` perturbs on the left (`exp(δ) R`, an error in the world frame). The measurement Jacobian
//!   is `R̂ᵀ hat(g)`, whose null space is the world vertical for every estimate, and the process Jacobian
//!   is the identity: no linearisation ever sees yaw, and the filter stays consistent.
//!
//! The NEES of the final attitude, averaged over independent runs, is compared with its 95 % χ² band;
//! `docs/conventions.md` records the measured figures. The test at the bottom checks that the
//! world-frame filters are inside the band (`cargo test --example attitude_conventions`).

use liebayes::densities::{Density, Gaussian, ManifoldGaussian};
use liebayes::manifolds::{GroupAction, Left, LieGroup, Manifold, So3};
use liebayes::operators::evaluation::average_nees_band;
use liebayes::operators::{
    Condition, Ekf, MeasurementModel, OperatorError, ProcessModel, Propagate, Ukf,
};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Standard gravity, world z up (m/s²).
const GRAVITY: f64 = 9.81;

/// `R′ = R exp(ω dt) ⊞ w`, `w ~ N(0, σ_g² dt I)`: isotropic, so the same covariance in the body and
/// the world frame.
struct Gyro {
    /// Rate noise density σ_g² (rad²/s).
    rate_noise: f64,
}

impl<G: LieGroup<3, Scalar = f64>> ProcessModel<G, 3> for Gyro {
    /// The measured rate ω (rad/s, body frame) and the step dt (s).
    type Input = (Vector3<f64>, f64);

    fn transition(&self, x: &G, (rate, dt): &(Vector3<f64>, f64)) -> G {
        x.compose(&G::exp(&(rate * *dt)))
    }

    fn noise(&self, _: &G, (_, dt): &(Vector3<f64>, f64)) -> Matrix3<f64> {
        Matrix3::identity() * (self.rate_noise * dt)
    }

    /// `J_compose_self`: `Ad(exp(−ω dt))` for right errors, `I` for left ones.
    fn jacobian(&self, x: &G, (rate, dt): &(Vector3<f64>, f64)) -> Matrix3<f64> {
        x.j_compose_self(&G::exp(&(rate * *dt)))
    }
}

/// `z = Rᵀ g + n`, `n ~ N(0, σ_a² I)`: the specific force at rest, in the body frame.
struct Accelerometer {
    /// σ_a² (m²/s⁴).
    variance: f64,
}

impl<G: GroupAction<3, 3, Scalar = f64>> MeasurementModel<G, 3, 3> for Accelerometer {
    fn predict(&self, x: &G) -> Vector3<f64> {
        x.inverse().act(&(Vector3::z() * GRAVITY))
    }

    fn noise(&self, _: &G) -> Matrix3<f64> {
        Matrix3::identity() * self.variance
    }

    /// The chain rule through `x⁻¹`: `J_act_self(x⁻¹, g) J_inverse_self(x)`; `hat(R̂ᵀ g)` for right
    /// errors, `R̂ᵀ hat(g)` for left ones.
    fn jacobian(&self, x: &G) -> Matrix3<f64> {
        x.inverse().j_act_self(&(Vector3::z() * GRAVITY)) * x.j_inverse_self()
    }
}

/// One study's settings.
#[derive(Clone, Copy, Debug)]
struct Settings {
    /// Prior standard deviation of every attitude component (rad).
    prior_sigma: f64,
    /// Number of gyroscope steps, step (s) and accelerometer period in steps.
    steps: usize,
    dt: f64,
    accel_every: usize,
    /// Independent runs.
    runs: usize,
}

const GYRO: Gyro = Gyro {
    rate_noise: 1e-4, // σ_g = 0.01 rad/s/√Hz
};
const ACCEL: Accelerometer = Accelerometer {
    variance: 0.05 * 0.05, // σ_a = 0.05 m/s²
};

/// The true angular rate at time t: a tumbling motion that turns the body's view of gravity.
fn true_rate(t: f64) -> Vector3<f64> {
    Vector3::new(0.4 * (0.5 * t).sin(), 0.3 * (0.3 * t).cos(), 0.2)
}

/// The filters of one run, on state type G.
enum Filter {
    Ekf,
    Ukf,
}

/// One run: simulated truth and sensors, the filter on state type G (whose error convention is the
/// point of the study), and the final NEES.
fn run<G>(filter: &Filter, settings: &Settings, seed: u64) -> Result<f64, OperatorError>
where
    G: GroupAction<3, 3, Scalar = f64> + From<So3<f64>>,
    So3<f64>: From<G>,
{
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let unit = Gaussian::new(Vector3::zeros(), Matrix3::identity())?;
    let prior_mean = So3::exp(&Vector3::new(0.3, -0.2, 1.0));
    // An isotropic prior is the same in both frames, so one truth serves both conventions.
    let mut truth = prior_mean.retract(&(unit.sample(&mut rng) * settings.prior_sigma));
    let mut density = ManifoldGaussian::new(
        G::from(prior_mean),
        Matrix3::identity() * settings.prior_sigma.powi(2),
    )?;
    let gyro_sigma = (GYRO.rate_noise / settings.dt).sqrt();
    for k in 0..settings.steps {
        let rate = true_rate(k as f64 * settings.dt);
        truth = truth.compose(&So3::exp(&(rate * settings.dt)));
        let input = (rate + unit.sample(&mut rng) * gyro_sigma, settings.dt);
        density = match filter {
            Filter::Ekf => density.propagate(&Ekf(&GYRO), &input)?,
            Filter::Ukf => density.propagate(&Ukf::new(&GYRO), &input)?,
        };
        if (k + 1) % settings.accel_every == 0 {
            let z = truth.inverse().rotate(&(Vector3::z() * GRAVITY))
                + unit.sample(&mut rng) * ACCEL.variance.sqrt();
            density = match filter {
                Filter::Ekf => density.condition(&Ekf(&ACCEL), &z)?.posterior,
                Filter::Ukf => density.condition(&Ukf::new(&ACCEL), &z)?.posterior,
            };
        }
    }
    Ok(density.mahalanobis_squared(&G::from(truth)))
}

/// The average final NEES over the runs.
fn average_nees<G>(filter: &Filter, settings: &Settings) -> Result<f64, OperatorError>
where
    G: GroupAction<3, 3, Scalar = f64> + From<So3<f64>>,
    So3<f64>: From<G>,
{
    let mut total = 0.0;
    for seed in 0..settings.runs as u64 {
        total += run::<G>(filter, settings, seed)?;
    }
    Ok(total / settings.runs as f64)
}

fn main() -> Result<(), OperatorError> {
    let base = Settings {
        prior_sigma: 0.0,
        steps: 6000,
        dt: 0.01,
        accel_every: 10,
        runs: 500,
    };
    let (low, high) = average_nees_band(3, base.runs)?;
    println!(
        "gravity-aided attitude, {} runs of {} s: average final NEES (95 % band [{low:.2}, {high:.2}])",
        base.runs,
        base.steps as f64 * base.dt
    );
    println!("prior sigma | EKF right | EKF left | UKF right | UKF left");
    for prior_deg in [10.0_f64, 30.0] {
        let settings = Settings {
            prior_sigma: prior_deg.to_radians(),
            ..base
        };
        println!(
            "{prior_deg:>8.0} deg | {:>9.2} | {:>8.2} | {:>9.2} | {:>8.2}",
            average_nees::<So3<f64>>(&Filter::Ekf, &settings)?,
            average_nees::<Left<So3<f64>>>(&Filter::Ekf, &settings)?,
            average_nees::<So3<f64>>(&Filter::Ukf, &settings)?,
            average_nees::<Left<So3<f64>>>(&Filter::Ukf, &settings)?,
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The world-frame filters are consistent: the average final NEES of 200 runs of 20 s lies in its
    /// 95 % band, for the EKF and the UKF, from a 30° prior. The body-frame filters on the same runs lie
    /// far above it (the check can tell the two apart).
    #[test]
    fn world_frame_errors_are_consistent() {
        let settings = Settings {
            prior_sigma: 30.0_f64.to_radians(),
            steps: 2000,
            dt: 0.01,
            accel_every: 10,
            runs: 200,
        };
        let (low, high) = average_nees_band(3, settings.runs).unwrap();
        for filter in [Filter::Ekf, Filter::Ukf] {
            let nees = average_nees::<Left<So3<f64>>>(&filter, &settings).unwrap();
            assert!(
                (low..=high).contains(&nees),
                "average NEES {nees} outside [{low}, {high}]"
            );
            let body_frame = average_nees::<So3<f64>>(&filter, &settings).unwrap();
            assert!(body_frame > 2.0 * high, "body-frame NEES {body_frame}");
        }
    }
}
