//! The three motion scenarios of the azimuth-alignment blog post, and a seeded simulator of truth and measurements: recorded
//! ([`simulate`]) or streamed step by step ([`trajectory`], for runs too long to record).

use super::density::variance_of;
use super::{PositionMeasurement, VelocityProcess};
use liebayes_manifolds::So2;
use liebayes_operators::{MAX_ELEMENTS, OperatorError};
use nalgebra::{Matrix2, Vector2};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

/// How the platform moves (velocity in its own axes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scenario {
    /// `v = 0`: the azimuth is unobservable.
    Static,
    /// `v = 0.5 (cos(2πt/10), sin(2πt/10))`: bounded circles around the origin.
    Circle,
    /// `v = (−1, 2)`: constant velocity, an ever longer lever arm.
    Line,
}

impl Scenario {
    /// All three, in the blog post's order.
    pub const ALL: [Scenario; 3] = [Scenario::Static, Scenario::Circle, Scenario::Line];

    /// The velocity at time t.
    pub fn velocity(self, t: f64) -> Vector2<f64> {
        match self {
            Scenario::Static => Vector2::zeros(),
            Scenario::Circle => {
                let (s, c) = (2.0 * PI * t / 10.0).sin_cos();
                Vector2::new(c, s) * 0.5
            }
            Scenario::Line => Vector2::new(-1.0, 2.0),
        }
    }

    /// Its name on the command line: `static`, `circle` or `line`.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::Static => "static",
            Scenario::Circle => "circle",
            Scenario::Line => "line",
        }
    }
}

/// Noise levels and timing; the default is the blog post's: 500 s, propagation every 0.1 s, a position
/// measurement every 1 s, σ_m = σ₀ = 1 m, q = 0.1 m/√s, initial position at the origin. The fields
/// are checked by [`validate`](Self::validate) before any simulation or study uses them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Initial position standard deviation σ₀ (m), per axis.
    pub sigma0: f64,
    /// Position measurement noise σ_m (m), per axis.
    pub sigma_m: f64,
    /// Velocity noise density q (m/√s).
    pub q: f64,
    /// Propagation step (s).
    pub dt: f64,
    /// A measurement every this many steps (at steps 0, n, 2n, …).
    pub measure_every: usize,
    /// Number of propagation steps.
    pub steps: usize,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            sigma0: 1.0,
            sigma_m: 1.0,
            q: 0.1,
            dt: 0.1,
            measure_every: 10,
            steps: 5000,
        }
    }
}

/// The largest time step (s): with a velocity of a few m/s the motion `v dt` stays far inside the
/// filters' position range.
pub const MAX_DT: f64 = 1e100;

impl Config {
    /// Checks the configuration: σ₀ and σ_m in [1.5e-154, 1e150] (the range of
    /// [`PositionMeasurement::new`]), q in [0, 1e150] ([`VelocityProcess::new`]), dt in
    /// (0, [`MAX_DT`]], `measure_every` at least 1 and `steps` from 1 to
    /// [`MAX_ELEMENTS`] (2³⁰).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] or [`OperatorError::TooLarge`], naming the field.
    pub fn validate(&self) -> Result<(), OperatorError> {
        PositionMeasurement::new(self.sigma_m)?;
        variance_of(
            "initial position standard deviation sigma_0 (m)",
            self.sigma0,
        )?;
        VelocityProcess::new(self.q)?;
        if !(self.dt > 0.0 && self.dt <= MAX_DT) {
            return Err(OperatorError::OutOfRange {
                what: "propagation step dt (s)",
                value: self.dt,
                range: "(0, 1e100]",
            });
        }
        if self.measure_every == 0 {
            return Err(OperatorError::OutOfRange {
                what: "measurement interval measure_every (steps)",
                value: 0.0,
                range: "at least 1",
            });
        }
        if self.steps == 0 {
            return Err(OperatorError::OutOfRange {
                what: "number of propagation steps",
                value: 0.0,
                range: "at least 1",
            });
        }
        if self.steps > MAX_ELEMENTS {
            return Err(OperatorError::TooLarge {
                what: "number of propagation steps",
                value: self.steps,
                max: MAX_ELEMENTS,
            });
        }
        Ok(())
    }

    /// The number of steps `round(duration / dt)` that covers `duration` seconds, checked (a ratio
    /// that would saturate a cast to `usize` is refused, not truncated).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] unless duration and dt are finite and positive with dt at most
    /// [`MAX_DT`]; [`OperatorError::TooLarge`] for more than [`MAX_ELEMENTS`] steps, or for a
    /// duration shorter than half a step (zero steps).
    pub fn steps_for(duration: f64, dt: f64) -> Result<usize, OperatorError> {
        if !(duration > 0.0 && duration.is_finite()) {
            return Err(OperatorError::OutOfRange {
                what: "simulated duration (s)",
                value: duration,
                range: "(0, infinity)",
            });
        }
        if !(dt > 0.0 && dt <= MAX_DT) {
            return Err(OperatorError::OutOfRange {
                what: "propagation step dt (s)",
                value: dt,
                range: "(0, 1e100]",
            });
        }
        let steps = (duration / dt).round();
        if steps > MAX_ELEMENTS as f64 {
            return Err(OperatorError::TooLarge {
                what: "number of propagation steps duration / dt",
                value: usize::MAX,
                max: MAX_ELEMENTS,
            });
        }
        if steps < 1.0 {
            return Err(OperatorError::OutOfRange {
                what: "number of propagation steps duration / dt",
                value: steps,
                range: "at least 1 (the duration is shorter than half a step)",
            });
        }
        // In [1, 2³⁰]: exact.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        Ok(steps as usize)
    }
}

/// One simulated run. At step k: if `k % measure_every == 0` the platform is measured at
/// `positions[k]` (`measurements[k]` is `Some`); then it moves with `velocities[k]` over dt plus noise.
#[derive(Clone, Debug)]
pub struct Simulation {
    /// The true azimuth A, uniform on [0, 2π).
    pub true_azimuth: f64,
    /// The velocity input of every step (platform axes).
    pub velocities: Vec<Vector2<f64>>,
    /// The true position at every step, before the step's motion (platform axes).
    pub positions: Vec<Vector2<f64>>,
    /// `z = R(A) r + n` where a measurement is taken.
    pub measurements: Vec<Option<Vector2<f64>>>,
}

/// A draw of `N(0, I₂)`.
pub(crate) fn normal2<R: Rng + ?Sized>(rng: &mut R) -> Vector2<f64> {
    Vector2::new(StandardNormal.sample(rng), StandardNormal.sample(rng))
}

/// Step k of a [`Trajectory`]: the true position before the step's motion, the measurement taken
/// there (if k is a measurement step) and the velocity of the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// The true position (platform axes).
    pub position: Vector2<f64>,
    /// `z = R(A) r + n`, at steps 0, n, 2n, … (n = `measure_every`).
    pub measurement: Option<Vector2<f64>>,
    /// The velocity input (platform axes).
    pub velocity: Vector2<f64>,
}

/// A run streamed step by step: the same draws, in the same order, as [`simulate`], without storing
/// them, so that runs of 10⁸ steps take no memory. An iterator over the configured number of steps.
#[derive(Debug)]
pub struct Trajectory<'r, R: ?Sized> {
    scenario: Scenario,
    config: Config,
    true_azimuth: f64,
    world_from_platform: Matrix2<f64>,
    position: Vector2<f64>,
    step: usize,
    rng: &'r mut R,
}

/// Starts a run: the true azimuth uniform on [0, 2π), the initial position from `N(0, σ₀² I)` (the
/// filters' prior).
///
/// # Errors
/// As [`Config::validate`].
pub fn trajectory<'r, R: Rng + ?Sized>(
    scenario: Scenario,
    config: &Config,
    rng: &'r mut R,
) -> Result<Trajectory<'r, R>, OperatorError> {
    config.validate()?;
    let true_azimuth = rng.random::<f64>() * 2.0 * PI;
    let position = normal2(rng) * config.sigma0;
    Ok(Trajectory {
        scenario,
        config: *config,
        true_azimuth,
        world_from_platform: So2::from_angle_unchecked(true_azimuth).to_matrix(),
        position,
        step: 0,
        rng,
    })
}

impl<R: ?Sized> Trajectory<'_, R> {
    /// The true azimuth A (rad).
    pub fn true_azimuth(&self) -> f64 {
        self.true_azimuth
    }
}

impl<R: Rng + ?Sized> Iterator for Trajectory<'_, R> {
    type Item = Step;

    fn next(&mut self) -> Option<Step> {
        let config = &self.config;
        if self.step >= config.steps {
            return None;
        }
        let k = self.step;
        let measurement = (k % config.measure_every == 0)
            .then(|| self.world_from_platform * self.position + normal2(self.rng) * config.sigma_m);
        let velocity = self.scenario.velocity(k as f64 * config.dt);
        let step = Step {
            position: self.position,
            measurement,
            velocity,
        };
        self.position += velocity * config.dt + normal2(self.rng) * (config.q * config.dt.sqrt());
        self.step += 1;
        Some(step)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.config.steps - self.step;
        (left, Some(left))
    }
}

/// Simulates and records a run (see [`trajectory`]).
///
/// # Errors
/// As [`Config::validate`], or [`OperatorError::TooLarge`] when the record cannot be allocated.
pub fn simulate<R: Rng + ?Sized>(
    scenario: Scenario,
    config: &Config,
    rng: &mut R,
) -> Result<Simulation, OperatorError> {
    let run = trajectory(scenario, config, rng)?;
    let too_large = |_| OperatorError::TooLarge {
        what: "number of recorded steps (their memory cannot be allocated)",
        value: config.steps,
        max: MAX_ELEMENTS,
    };
    let mut simulation = Simulation {
        true_azimuth: run.true_azimuth(),
        velocities: Vec::new(),
        positions: Vec::new(),
        measurements: Vec::new(),
    };
    simulation
        .velocities
        .try_reserve_exact(config.steps)
        .map_err(too_large)?;
    simulation
        .positions
        .try_reserve_exact(config.steps)
        .map_err(too_large)?;
    simulation
        .measurements
        .try_reserve_exact(config.steps)
        .map_err(too_large)?;
    for step in run {
        simulation.positions.push(step.position);
        simulation.measurements.push(step.measurement);
        simulation.velocities.push(step.velocity);
    }
    Ok(simulation)
}
