//! Iterated updates on attitude: a wide prior meets precise gravity and magnetometer readings.
//! `cargo run --release --example iterated_attitude`.
//!
//! The attitude R (body to world) has world-frame errors (`Left<So3>`, `exp(δ) R`); its prior is 30°
//! (1σ) per axis around a wrong guess. An accelerometer at rest and a magnetometer read two known
//! world directions in the body frame, `z = [Rᵀ g; Rᵀ m] + n`, precisely (σ 0.05 m/s² on 9.81, σ 0.01
//! on a unit field), every 0.1 s; a gyroscope drives the attitude at 100 Hz in between.
//!
//! One linearisation at the prior mean, 30° or more from the truth, is wrong by far more than the
//! readings' noise: the one-pass EKF and UKF become over-confident at their first update, and the
//! error takes many updates to wear off. The iterated EKF (Gauss-Newton to the MAP) and the iterated
//! posterior linearisation relinearise at their own estimate and are consistent from the first
//! update. The study prints the run-averaged NEES per update epoch with its 95 % band, and the final
//! NEES of a 60 s run with a gyroscope bias in the state (`ProductManifold<Left<So3>, Rn<3>>`).
//! `docs/operators/iterated.md` records the figures; the tests at the bottom check the iterated EKF
//! against the band (`cargo test --example iterated_attitude`).

use liebayes::densities::{Density, Gaussian, ManifoldGaussian};
use liebayes::manifolds::{GroupAction, Left, LieGroup, Manifold, ProductManifold, Rn, So3};
use liebayes::operators::evaluation::average_nees_band;
use liebayes::operators::iterated::{IteratedEkf, IteratedUkf, IterationSettings, Stop};
use liebayes::operators::{
    Condition, Ekf, MeasurementModel, OperatorError, ProcessModel, Propagate, Ukf,
};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Gravity in the world frame, z up (m/s²), and the magnetic field (unit: the field's magnitude).
const GRAVITY: Vector3<f64> = Vector3::new(0.0, 0.0, 9.81);
const FIELD: Vector3<f64> = Vector3::new(0.4, 0.0, -0.916_515_138_991_168);

/// The sensors' standard deviations: accelerometer (m/s²), magnetometer (field units).
const ACCEL_SIGMA: f64 = 0.05;
const FIELD_SIGMA: f64 = 0.01;

/// Gyroscope rate noise density σ_g (rad/s/√Hz) and bias random walk σ_b (rad/s/√s).
const RATE_SIGMA: f64 = 0.01;
const BIAS_WALK_SIGMA: f64 = 1e-4;

/// The gyroscope step (s) and the readings' period in steps.
const DT: f64 = 0.01;
const READ_EVERY: usize = 10;

/// `z = [Rᵀ g; Rᵀ m] + n` on the attitude (any group acting on R³; world-frame errors here).
struct Directions;

impl<G: GroupAction<3, 3, Scalar = f64>> MeasurementModel<G, 3, 6> for Directions {
    fn predict(&self, x: &G) -> SVector<f64, 6> {
        let inverse = x.inverse();
        let (g, m) = (inverse.act(&GRAVITY), inverse.act(&FIELD));
        SVector::<f64, 6>::new(g[0], g[1], g[2], m[0], m[1], m[2])
    }

    fn noise(&self, _: &G) -> SMatrix<f64, 6, 6> {
        SMatrix::<f64, 6, 6>::from_diagonal(&SVector::<f64, 6>::new(
            ACCEL_SIGMA.powi(2),
            ACCEL_SIGMA.powi(2),
            ACCEL_SIGMA.powi(2),
            FIELD_SIGMA.powi(2),
            FIELD_SIGMA.powi(2),
            FIELD_SIGMA.powi(2),
        ))
    }

    /// `J_act_self(x⁻¹, v) J_inverse_self(x)` for v = g and m (`R̂ᵀ hat(v)` for world-frame errors).
    fn jacobian(&self, x: &G) -> SMatrix<f64, 6, 3> {
        let (inverse, j_inverse) = (x.inverse(), x.j_inverse_self());
        let mut h = SMatrix::<f64, 6, 3>::zeros();
        h.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(inverse.j_act_self(&GRAVITY) * j_inverse));
        h.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(inverse.j_act_self(&FIELD) * j_inverse));
        h
    }
}

/// Attitude and gyroscope bias, world-frame attitude errors.
type Biased = ProductManifold<Left<So3<f64>>, Rn<f64, 3>, 3, 3, 6>;

/// The directions read by the attitude factor of the biased state (`H = [H_R, 0]`).
impl MeasurementModel<Biased, 6, 6> for Directions {
    fn predict(&self, x: &Biased) -> SVector<f64, 6> {
        MeasurementModel::<Left<So3<f64>>, 3, 6>::predict(self, x.first())
    }

    fn noise(&self, x: &Biased) -> SMatrix<f64, 6, 6> {
        MeasurementModel::<Left<So3<f64>>, 3, 6>::noise(self, x.first())
    }

    fn jacobian(&self, x: &Biased) -> SMatrix<f64, 6, 6> {
        let mut h = SMatrix::<f64, 6, 6>::zeros();
        h.fixed_view_mut::<6, 3>(0, 0).copy_from(
            &MeasurementModel::<Left<So3<f64>>, 3, 6>::jacobian(self, x.first()),
        );
        h
    }
}

/// The gyroscope: `R′ = R exp((ω − b) dt)`, `b′ = b`, with the rate noise on the attitude
/// (isotropic, so `σ_g² dt I` in the world frame too) and the bias random walk on b.
struct Gyro;

impl ProcessModel<Biased, 6> for Gyro {
    /// The measured rate ω (rad/s, body frame) and the step dt (s).
    type Input = (Vector3<f64>, f64);

    fn transition(&self, x: &Biased, (rate, dt): &(Vector3<f64>, f64)) -> Biased {
        let turn = So3::exp(&((rate - x.second().coords()) * *dt));
        Biased::new(Left::new(x.first().inner().compose(&turn)), *x.second())
    }

    fn noise(&self, _: &Biased, (_, dt): &(Vector3<f64>, f64)) -> SMatrix<f64, 6, 6> {
        let mut q = SVector::<f64, 6>::from_element(BIAS_WALK_SIGMA.powi(2) * dt);
        q.fixed_rows_mut::<3>(0).fill(RATE_SIGMA.powi(2) * dt);
        SMatrix::from_diagonal(&q)
    }

    /// `[[I, −R′ Jr(θ) dt], [0, I]]`, θ = (ω − b) dt: a bias error ε turns R′ by `exp(−Jr(θ) ε dt)`
    /// on the right, `exp(−R′ Jr(θ) ε dt)` on the left.
    fn jacobian(&self, x: &Biased, input: &(Vector3<f64>, f64)) -> SMatrix<f64, 6, 6> {
        let (rate, dt) = input;
        let theta = (rate - x.second().coords()) * *dt;
        let turned = self.transition(x, input).first().inner().to_matrix();
        let mut f = SMatrix::<f64, 6, 6>::identity();
        f.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-turned * So3::right_jacobian(&theta) * *dt));
        f
    }
}

/// The attitude-only gyroscope, `R′ = R exp(ω dt)`: F = I for world-frame errors.
impl ProcessModel<Left<So3<f64>>, 3> for Gyro {
    type Input = (Vector3<f64>, f64);

    fn transition(&self, x: &Left<So3<f64>>, (rate, dt): &(Vector3<f64>, f64)) -> Left<So3<f64>> {
        Left::new(x.inner().compose(&So3::exp(&(rate * *dt))))
    }

    fn noise(&self, _: &Left<So3<f64>>, (_, dt): &(Vector3<f64>, f64)) -> Matrix3<f64> {
        Matrix3::identity() * (RATE_SIGMA.powi(2) * dt)
    }

    fn jacobian(&self, _: &Left<So3<f64>>, _: &(Vector3<f64>, f64)) -> Matrix3<f64> {
        Matrix3::identity()
    }
}

/// The updates compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Update {
    Ekf,
    Ukf,
    IteratedEkf,
    /// The iterated EKF with the covariance left at the prior mean (not transported).
    IteratedEkfUntransported,
    IteratedUkf,
}

const UPDATES: [Update; 5] = [
    Update::Ekf,
    Update::Ukf,
    Update::IteratedEkf,
    Update::IteratedEkfUntransported,
    Update::IteratedUkf,
];

impl Update {
    /// The posterior of one reading, the steps the iteration took and whether it converged (0 and
    /// `true` for the one-pass updates).
    fn apply<X, const D: usize>(
        self,
        density: &ManifoldGaussian<X, D>,
        z: &SVector<f64, 6>,
    ) -> Result<(ManifoldGaussian<X, D>, usize, bool), OperatorError>
    where
        X: Manifold<D, Scalar = f64>,
        Directions: MeasurementModel<X, D, 6>,
    {
        let untransported = IterationSettings::default().with_transport(false);
        Ok(match self {
            Update::Ekf => (density.condition(&Ekf(&Directions), z)?.posterior, 0, true),
            Update::Ukf => (
                density.condition(&Ukf::new(&Directions), z)?.posterior,
                0,
                true,
            ),
            Update::IteratedEkf => {
                let step = density.condition(&IteratedEkf::new(&Directions), z)?;
                (
                    step.posterior,
                    step.report.iterations(),
                    step.report.stop() == Stop::Converged,
                )
            }
            Update::IteratedEkfUntransported => {
                let iterated = IteratedEkf {
                    model: &Directions,
                    settings: untransported,
                };
                let step = density.condition(&iterated, z)?;
                (
                    step.posterior,
                    step.report.iterations(),
                    step.report.stop() == Stop::Converged,
                )
            }
            Update::IteratedUkf => {
                let step = density.condition(&IteratedUkf::new(&Directions), z)?;
                (
                    step.posterior,
                    step.report.iterations(),
                    step.report.stop() == Stop::Converged,
                )
            }
        })
    }

    /// The gyroscope step: linearised for the EKF-type updates, unscented for the UKF-type ones.
    fn propagate<X, const D: usize>(
        self,
        density: &ManifoldGaussian<X, D>,
        input: &(Vector3<f64>, f64),
    ) -> Result<ManifoldGaussian<X, D>, OperatorError>
    where
        X: Manifold<D, Scalar = f64>,
        Gyro: ProcessModel<X, D, Input = (Vector3<f64>, f64)>,
    {
        match self {
            Update::Ukf | Update::IteratedUkf => density.propagate(&Ukf::new(&Gyro), input),
            _ => density.propagate(&Ekf(&Gyro), input),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Update::Ekf => "EKF",
            Update::Ukf => "UKF",
            Update::IteratedEkf => "iterated EKF",
            Update::IteratedEkfUntransported => "iter. EKF, P at prior mean",
            Update::IteratedUkf => "iterated sigma-point",
        }
    }
}

/// One study: duration in readings, runs, whether the state holds the bias.
#[derive(Clone, Copy, Debug)]
struct Study {
    readings: usize,
    runs: usize,
    prior_sigma: f64,
    bias_sigma: f64,
}

/// The true angular rate at time t: a tumbling motion.
fn true_rate(t: f64) -> Vector3<f64> {
    Vector3::new(0.4 * (0.5 * t).sin(), 0.3 * (0.3 * t).cos(), 0.2)
}

/// The steps of the iterated updates and the number that did not converge.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    steps: usize,
    unconverged: usize,
}

/// The per-reading NEES of one run and its [`Tally`]: the first reading at t = 0, then one
/// every 0.1 s. `state` builds the filter's state from the attitude and the bias, and the estimate
/// error is measured on that state.
fn run<X, const D: usize>(
    update: Update,
    study: &Study,
    seed: u64,
    state: impl Fn(So3<f64>, Vector3<f64>) -> X,
    prior_covariance: SMatrix<f64, D, D>,
) -> Result<(Vec<f64>, Tally), OperatorError>
where
    X: Manifold<D, Scalar = f64>,
    Directions: MeasurementModel<X, D, 6>,
    Gyro: ProcessModel<X, D, Input = (Vector3<f64>, f64)>,
{
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let unit = Gaussian::new(Vector3::zeros(), Matrix3::identity())?;
    let guess = So3::exp(&Vector3::new(0.3, -0.2, 1.0));
    // World-frame error: the truth is exp(δ) · guess, δ ~ N(0, σ² I).
    let mut attitude = So3::exp(&(unit.sample(&mut rng) * study.prior_sigma)).compose(&guess);
    let mut bias = unit.sample(&mut rng) * study.bias_sigma;
    let mut density = ManifoldGaussian::new(state(guess, Vector3::zeros()), prior_covariance)?;
    let (mut nees, mut tally) = (Vec::with_capacity(study.readings), Tally::default());
    for reading in 0..study.readings {
        if reading > 0 {
            for k in 0..READ_EVERY {
                let t = ((reading - 1) * READ_EVERY + k) as f64 * DT;
                let rate = true_rate(t);
                attitude = attitude.compose(&So3::exp(&(rate * DT)));
                let measured = rate + bias + unit.sample(&mut rng) * (RATE_SIGMA / DT.sqrt());
                bias += unit.sample(&mut rng) * (BIAS_WALK_SIGMA * DT.sqrt());
                density = update.propagate(&density, &(measured, DT))?;
            }
        }
        let z = MeasurementModel::<So3<f64>, 3, 6>::predict(&Directions, &attitude)
            + SVector::<f64, 6>::from_iterator(
                (unit.sample(&mut rng) * ACCEL_SIGMA)
                    .iter()
                    .chain((unit.sample(&mut rng) * FIELD_SIGMA).iter())
                    .copied(),
            );
        let (posterior, steps, converged) = update.apply(&density, &z)?;
        density = posterior;
        tally.steps += steps;
        tally.unconverged += usize::from(!converged);
        nees.push(density.mahalanobis_squared(&state(attitude, bias)));
    }
    Ok((nees, tally))
}

/// The run-averaged NEES per reading and the [`Tally`] of all runs.
fn average<X, const D: usize>(
    update: Update,
    study: &Study,
    state: impl Fn(So3<f64>, Vector3<f64>) -> X + Copy,
    prior_covariance: SMatrix<f64, D, D>,
) -> Result<(Vec<f64>, Tally), OperatorError>
where
    X: Manifold<D, Scalar = f64>,
    Directions: MeasurementModel<X, D, 6>,
    Gyro: ProcessModel<X, D, Input = (Vector3<f64>, f64)>,
{
    let mut total = vec![0.0; study.readings];
    let mut tally = Tally::default();
    for seed in 0..study.runs as u64 {
        let (nees, run_tally) = run(update, study, seed, state, prior_covariance)?;
        total.iter_mut().zip(&nees).for_each(|(t, n)| *t += n);
        tally.steps += run_tally.steps;
        tally.unconverged += run_tally.unconverged;
    }
    Ok((total.iter().map(|t| t / study.runs as f64).collect(), tally))
}

/// The attitude study: 30° prior, 1 s (11 readings), 200 runs.
const ATTITUDE: Study = Study {
    readings: 11,
    runs: 200,
    prior_sigma: std::f64::consts::FRAC_PI_6, // 30°
    bias_sigma: 0.0,
};

/// The biased study: 60 s (601 readings), a bias of 0.01 rad/s (1σ per axis), 200 runs.
const BIASED: Study = Study {
    readings: 601,
    runs: 200,
    bias_sigma: 0.01,
    ..ATTITUDE
};

fn attitude_state(r: So3<f64>, _: Vector3<f64>) -> Left<So3<f64>> {
    Left::new(r)
}

fn biased_state(r: So3<f64>, b: Vector3<f64>) -> Biased {
    Biased::new(Left::new(r), Rn::new_unchecked(b))
}

fn attitude_average(update: Update, study: &Study) -> Result<(Vec<f64>, Tally), OperatorError> {
    average(
        update,
        study,
        attitude_state,
        Matrix3::identity() * study.prior_sigma.powi(2),
    )
}

fn biased_average(update: Update, study: &Study) -> Result<(Vec<f64>, Tally), OperatorError> {
    let mut p = SVector::<f64, 6>::from_element(study.bias_sigma.powi(2));
    p.fixed_rows_mut::<3>(0).fill(study.prior_sigma.powi(2));
    average(update, study, biased_state, SMatrix::from_diagonal(&p))
}

fn main() -> Result<(), OperatorError> {
    let (low, high) = average_nees_band(3, ATTITUDE.runs)?;
    println!(
        "attitude (world-frame errors), 30 deg prior, gravity + field every 0.1 s, {} runs (seeds 0..{}):",
        ATTITUDE.runs, ATTITUDE.runs
    );
    println!("run-averaged NEES per reading, 95 % band [{low:.2}, {high:.2}]");
    let columns: Vec<_> = UPDATES
        .iter()
        .map(|u| attitude_average(*u, &ATTITUDE))
        .collect::<Result<_, _>>()?;
    print!("| t (s) |");
    for update in UPDATES {
        print!(" {} |", update.name());
    }
    println!();
    for reading in 0..ATTITUDE.readings {
        print!("| {:.1} |", reading as f64 * READ_EVERY as f64 * DT);
        for (nees, _) in &columns {
            print!(" {:.2} |", nees[reading]);
        }
        println!();
    }
    let updates = (ATTITUDE.runs * ATTITUDE.readings) as f64;
    print!("| steps per update |");
    for (_, tally) in &columns {
        print!(" {:.2} |", tally.steps as f64 / updates);
    }
    println!();
    print!("| updates not converged |");
    for (_, tally) in &columns {
        print!(" {} |", tally.unconverged);
    }
    println!();

    let (low, high) = average_nees_band(6, BIASED.runs)?;
    println!(
        "\nattitude x gyro bias, 60 s, {} runs: final NEES, 95 % band [{low:.2}, {high:.2}]",
        BIASED.runs
    );
    println!("| update | final NEES | steps per update | updates not converged |");
    let updates = (BIASED.runs * BIASED.readings) as f64;
    for update in UPDATES {
        let (nees, tally) = biased_average(update, &BIASED)?;
        println!(
            "| {} | {:.2} | {:.2} | {} |",
            update.name(),
            nees[BIASED.readings - 1],
            tally.steps as f64 / updates,
            tally.unconverged
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// From the first reading on, the iterated EKF's run-averaged NEES lies in its 95 % band at every
    /// reading, where the one-pass EKF's lies far above it at the first.
    #[test]
    fn the_iterated_ekf_is_consistent_from_the_first_update() {
        let (low, high) = average_nees_band(3, ATTITUDE.runs).unwrap();
        let (iterated, _) = attitude_average(Update::IteratedEkf, &ATTITUDE).unwrap();
        for (reading, nees) in iterated.iter().enumerate() {
            assert!(
                (low..=high).contains(nees),
                "reading {reading}: NEES {nees} outside [{low}, {high}]"
            );
        }
        let (one_pass, _) = attitude_average(Update::Ekf, &ATTITUDE).unwrap();
        assert!(one_pass[0] > 10.0 * high, "one-pass NEES {}", one_pass[0]);
    }

    /// With the gyroscope bias in the state, the iterated EKF's final NEES after 60 s lies in its
    /// 95 % band.
    #[test]
    fn the_iterated_ekf_is_consistent_with_a_bias_after_a_minute() {
        let (low, high) = average_nees_band(6, BIASED.runs).unwrap();
        let (nees, _) = biased_average(Update::IteratedEkf, &BIASED).unwrap();
        let last = nees[BIASED.readings - 1];
        assert!(
            (low..=high).contains(&last),
            "final NEES {last} outside [{low}, {high}]"
        );
    }
}
