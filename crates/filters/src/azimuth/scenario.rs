//! The three motion scenarios of the azimuth-alignment blog post, as an experiment-layer
//! [`Scenario`]: the truth `[r, A]`, the velocity inputs and the position measurements of a run,
//! streamed step by step from the run's generator (a run of 10⁸ steps takes no memory).

use super::model::{SETTING_SIGMA_RANGE, sigma_setting};
use super::{PositionAzimuth, PositionMeasurement, VelocityInput, VelocityProcess};
use liebayes_experiments::{ExperimentError, MAX_EPOCHS, Scenario, Step};
use liebayes_manifolds::{Rn, So2};
use liebayes_operators::{MAX_ELEMENTS, OperatorError};
use nalgebra::{Matrix2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

/// How the platform moves (velocity in its own axes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// `v = 0`: the azimuth is unobservable.
    Static,
    /// `v = 0.5 (cos(2πt/10), sin(2πt/10))`: bounded circles around the origin.
    Circle,
    /// `v = (−1, 2)`: constant velocity, an ever longer lever arm.
    Line,
}

impl Motion {
    /// All three, in the blog post's order.
    pub const ALL: [Motion; 3] = [Motion::Static, Motion::Circle, Motion::Line];

    /// The velocity (m/s) at time t (s); `None` for a time that is not finite (the circle's
    /// velocity has no value there).
    pub fn velocity(self, t: f64) -> Option<Vector2<f64>> {
        if !t.is_finite() {
            return None;
        }
        Some(match self {
            Motion::Static => Vector2::zeros(),
            Motion::Circle => {
                // One turn every 10 s: the phase π (t / 5) is finite for every finite t.
                let (s, c) = (PI * (t / 5.0)).sin_cos();
                Vector2::new(c, s) * 0.5
            }
            Motion::Line => Vector2::new(-1.0, 2.0),
        })
    }

    /// The largest speed |v| (m/s) of the motion: 0, 0.5 and √5.
    pub fn max_speed(self) -> f64 {
        match self {
            Motion::Static => 0.0,
            Motion::Circle => 0.5,
            Motion::Line => 5f64.sqrt(),
        }
    }

    /// Its name on the command line: `static`, `circle` or `line`.
    pub fn name(self) -> &'static str {
        match self {
            Motion::Static => "static",
            Motion::Circle => "circle",
            Motion::Line => "line",
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

/// The largest variance (m²) a run may add between two measurements: with the prior's or a
/// posterior's (at most 1e98 each) it stays within the Gaussian baselines' 1e100.
const MAX_VARIANCE_BETWEEN: f64 = 1e98;

/// The largest position precision (1/m², per axis) a run may reach: half of what the Gaussians'
/// `tr Σ⁻¹ ≤ 1e100` allows over two axes, leaving room for the filters' rounding.
const MAX_PRECISION: f64 = 2.5e99;

/// How many times its smallest standard deviation the platform may travel in a run: at a distance
/// d from the origin the spacing of f64 positions is about `ε d`, so beyond `1e12 σ` it is above
/// `2e-4 σ` and a sigma-point filter's points round onto its mean.
const RESOLVED_EXTENT: f64 = 1e12;

/// The largest time step (s): with a velocity of a few m/s the motion `v dt` stays far inside the
/// filters' position range.
pub const MAX_DT: f64 = 1e100;

impl Config {
    /// Checks the configuration with the range every azimuth filter is built with, so that a
    /// configuration it accepts, each of the six filters can run: σ₀ and σ_m in
    /// [`SETTING_SIGMA_RANGE`] = [1e-49, 1e49], q in [0, 1e49], dt in (0, [`MAX_DT`]] with the
    /// per-step noise `q √dt` at most 1e49 (so `q² dt ≤ 1e98`, a variance the Gaussian baselines
    /// add in one propagation), `measure_every` at least 1 and `steps` from 1 to
    /// [`MAX_ELEMENTS`] (2³⁰); and over the whole run, the variance added between two
    /// measurements `q² dt min(measure_every, steps)` at most 1e98 and the largest position
    /// precision the measurements reach at most 2.5e99 per axis (half the Gaussians' limit on
    /// `tr Σ⁻¹`): with q = 0, σ₀ = σ_m = 1e-49 and a measurement every step, the Gaussian
    /// baselines and the grid filters passed it at the 49th update and refused every later one.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] or [`OperatorError::TooLarge`], naming the field.
    pub fn validate(&self) -> Result<(), OperatorError> {
        sigma_setting(
            "position noise standard deviation sigma_m (m)",
            self.sigma_m,
        )?;
        PositionMeasurement::new(self.sigma_m)?;
        sigma_setting(
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
        // q ≤ 1e49 and q √dt ≤ 1e49 (dt ≤ 1e100 keeps √dt finite and the product exact enough).
        let per_step = self.q * self.dt.sqrt();
        if !(self.q <= SETTING_SIGMA_RANGE.1 && per_step <= SETTING_SIGMA_RANGE.1) {
            return Err(OperatorError::OutOfRange {
                what: "velocity noise density q (m/sqrt(s)), with its per-step q sqrt(dt)",
                value: self.q,
                range: "q in [0, 1e49] with q sqrt(dt) at most 1e49 (q^2 dt <= 1e98, a variance \
                        every azimuth filter can add in a step)",
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
        let between = self.between_measurements();
        if between > MAX_VARIANCE_BETWEEN {
            return Err(OperatorError::OutOfRange {
                what: "position variance q^2 dt min(measure_every, steps) added between two \
                       measurements (m^2)",
                value: between,
                range: "at most 1e98 (with the prior's, within the Gaussian baselines' 1e100): \
                        measure more often or take a smaller q or dt",
            });
        }
        let precision = self.largest_precision();
        if precision > MAX_PRECISION {
            return Err(OperatorError::OutOfRange {
                what: "largest position precision per axis (1/m^2) the run's measurements reach",
                value: precision,
                range: "at most 2.5e99 (half the Gaussians' trace of the inverse covariance, \
                        1e100, over two axes): fewer measurements, a larger sigma_m or sigma_0, \
                        or some process noise q",
            });
        }
        Ok(())
    }

    /// `q² dt min(measure_every, steps)`, the position variance a run adds between two
    /// measurements (m², per axis).
    fn between_measurements(&self) -> f64 {
        self.q * self.q * self.dt * self.measure_every.min(self.steps) as f64
    }

    /// The largest position precision λ (1/m², per axis) a Kalman filter reaches over the run:
    /// the first measurement gives `λ₁ = 1/σ₀² + 1/σ_m²`, and each later one adds `1/σ_m²` to a
    /// prior precision at most the last posterior's and at most `1/v`, v the variance added
    /// between measurements ([`between_measurements`](Self::between_measurements)), so with U
    /// measurements `λ ≤ max(λ₁, min(λ₁ + (U − 1)/σ_m², 1/v + 1/σ_m²))` (exact for q = 0).
    fn largest_precision(&self) -> f64 {
        let each = 1.0 / (self.sigma_m * self.sigma_m);
        let first = 1.0 / (self.sigma0 * self.sigma0) + each;
        let updates = self.steps.div_ceil(self.measure_every) as f64;
        let later = 1.0 / self.between_measurements() + each;
        first.max((first + (updates - 1.0) * each).min(later))
    }

    /// The number of steps `round(duration / dt)` that covers `duration` seconds, checked (a ratio
    /// that would saturate a cast to `usize` is refused, not truncated).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] unless duration and dt are finite and positive with dt at most
    /// [`MAX_DT`], for more than [`MAX_ELEMENTS`] steps, or for a
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
            return Err(OperatorError::OutOfRange {
                what: "number of propagation steps duration / dt",
                value: steps,
                range: "[1, 2^30]: a shorter duration or a longer dt",
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

/// A draw of `N(0, I₂)`.
pub(crate) fn normal2<R: Rng + ?Sized>(rng: &mut R) -> Vector2<f64> {
    Vector2::new(StandardNormal.sample(rng), StandardNormal.sample(rng))
}

/// The azimuth-alignment scenario: a motion and its settings, checked at construction.
///
/// A run draws the true azimuth A uniform on [0, 2π) and the initial position from
/// `N(0, σ₀² I)` (the filters' prior). Step 0 is the start (an input of dt = 0, the platform
/// measured where it starts); step k ≥ 1 moves the platform over dt with the velocity of time
/// `(k − 1) dt` plus `N(0, q² dt I)`, and measures `z = R(A) r + n` when k is a multiple of
/// `measure_every`. So a run has `steps` steps and `⌈steps / measure_every⌉` measurement epochs,
/// at times `0, n dt, 2n dt, …`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AzimuthScenario {
    motion: Motion,
    config: Config,
}

impl AzimuthScenario {
    /// The scenario.
    ///
    /// # Errors
    /// As [`Config::validate`], and [`OperatorError::OutOfRange`] when the motion takes the
    /// platform farther than `1e12` times the smallest position standard deviation the run
    /// reaches (`|v|max dt steps ≤ 1e12 / √λ`, λ the largest precision of [`Config::validate`]):
    /// farther, positions are too coarse in f64 for the filters to resolve that deviation (a UKF's
    /// sigma points round onto its mean; the run of `dt = 1e30` on the line refused every step
    /// from the first).
    pub fn new(motion: Motion, config: Config) -> Result<Self, OperatorError> {
        config.validate()?;
        let extent = motion.max_speed() * config.dt * config.steps as f64;
        let smallest_sigma = 1.0 / config.largest_precision().sqrt();
        if extent > RESOLVED_EXTENT * smallest_sigma {
            return Err(OperatorError::OutOfRange {
                what: "distance the motion covers in the run, |v|max dt steps (m)",
                value: extent,
                range: "at most 1e12 times the smallest position standard deviation the run \
                        reaches: a shorter run or step, or a larger sigma_m",
            });
        }
        Ok(Self { motion, config })
    }

    /// The motion.
    pub fn motion(&self) -> Motion {
        self.motion
    }

    /// The settings.
    pub fn config(&self) -> &Config {
        &self.config
    }
}

/// The steps of one run of an [`AzimuthScenario`], drawn as they are taken.
#[derive(Debug)]
pub struct AzimuthSteps<'s> {
    scenario: &'s AzimuthScenario,
    azimuth: So2<f64>,
    world_from_platform: Matrix2<f64>,
    position: Vector2<f64>,
    step: usize,
    rng: &'s mut ChaCha8Rng,
}

impl Iterator for AzimuthSteps<'_> {
    type Item = Step<PositionAzimuth, VelocityInput, Vector2<f64>>;

    fn next(&mut self) -> Option<Self::Item> {
        let config = &self.scenario.config;
        let k = self.step;
        if k >= config.steps {
            return None;
        }
        let input = if k == 0 {
            VelocityInput {
                velocity: Vector2::zeros(),
                dt: 0.0,
            }
        } else {
            // The validated configuration keeps every step's time finite.
            let velocity = self.scenario.motion.velocity((k - 1) as f64 * config.dt)?;
            self.position +=
                velocity * config.dt + normal2(self.rng) * (config.q * config.dt.sqrt());
            VelocityInput {
                velocity,
                dt: config.dt,
            }
        };
        let measurement = (k % config.measure_every == 0)
            .then(|| self.world_from_platform * self.position + normal2(self.rng) * config.sigma_m);
        self.step += 1;
        Some(Step {
            time: k as f64 * config.dt,
            input,
            truth: PositionAzimuth::new(Rn::new_unchecked(self.position), self.azimuth),
            measurement,
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.scenario.config.steps - self.step;
        (left, Some(left))
    }
}

impl Scenario for AzimuthScenario {
    type Truth = PositionAzimuth;
    type Input = VelocityInput;
    type Measurement = Vector2<f64>;
    type Steps<'s> = AzimuthSteps<'s>;

    fn epochs(&self) -> usize {
        self.config.steps.div_ceil(self.config.measure_every)
    }

    /// Starts a run: the true azimuth, then the initial position, from `rng`.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] when the run would have more than [`MAX_EPOCHS`]
    /// measurement epochs.
    fn simulate<'s>(
        &'s self,
        rng: &'s mut ChaCha8Rng,
    ) -> Result<AzimuthSteps<'s>, ExperimentError> {
        if self.epochs() > MAX_EPOCHS {
            return Err(ExperimentError::OutOfRange {
                what: "number of measurement epochs steps / measure_every",
                value: self.epochs().to_string(),
                range: "[1, 2^24]",
            });
        }
        let azimuth = So2::from_angle_unchecked(rng.random::<f64>() * 2.0 * PI);
        let position = normal2(rng) * self.config.sigma0;
        Ok(AzimuthSteps {
            scenario: self,
            azimuth,
            world_from_platform: azimuth.to_matrix(),
            position,
            step: 0,
            rng,
        })
    }
}
