//! [`InertialScenario`]: a vehicle manoeuvring in three dimensions with a noisy, biased IMU and
//! position fixes, and the prior every filter starts from.

use super::state::{NAVIGATION_DIM, Navigation, NavigationState};
use super::strapdown::{FIX_SIGMA_RANGE, IMU_RATE_RANGE, ImuNoise, ImuStep, strapdown};
use crate::FilterError;
use crate::error::{SIGMA_RANGE, setting_in};
use liebayes_densities::ManifoldGaussian;
use liebayes_experiments::{ExperimentError, MAX_EPOCHS, Scenario, Step};
use liebayes_manifolds::{LieGroup, Readable, So3};
use nalgebra::{SMatrix, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The draws of the initial distribution whose moments give each filter its prior
/// ([`InertialScenario::prior`]).
pub const PRIOR_DRAWS: usize = 20_000;

/// How the initial velocity is uncertain.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InitialVelocity {
    /// Known in the body frame (a vehicle moving forward, its heading unknown): the true velocity
    /// is the prior's turned by the initial attitude error, plus Gaussian noise.
    #[default]
    Body,
    /// Known in the world frame, independently of the attitude: the prior's plus Gaussian noise.
    World,
}

/// The scenario's settings. The default: 60 s at 50 Hz, a position fix every second with
/// σ = 0.5 m, a consumer-grade IMU (gyroscope 0.01 rad/s/√Hz, accelerometer 0.05 m/s²/√Hz,
/// bias walks 1e-4 rad/s/√s and 1e-3 m/s²/√s), and an initial uncertainty of 30° in heading, 2°
/// in roll and pitch, 0.3 m/s (about a velocity known in the body frame), 1 m, 0.01 rad/s and
/// 0.1 m/s² (per axis, 1σ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertialConfig {
    /// Length of a run (s).
    pub duration: f64,
    /// IMU sampling rate (Hz).
    pub imu_rate: f64,
    /// IMU samples between position fixes.
    pub fix_every: usize,
    /// σ of a position fix per axis (m).
    pub fix_sigma: f64,
    /// The IMU's noise, which the filters assume too.
    pub imu: ImuNoise,
    /// Which frame the initial velocity is known in.
    pub initial_velocity: InitialVelocity,
    /// Initial 1σ of the heading (rad), a rotation about the world's vertical.
    pub heading_sigma: f64,
    /// Initial 1σ of roll and pitch (rad), rotations about the world's horizontal axes.
    pub tilt_sigma: f64,
    /// Initial 1σ of each velocity component (m/s).
    pub velocity_sigma: f64,
    /// Initial 1σ of each position component (m).
    pub position_sigma: f64,
    /// Initial 1σ of each gyroscope bias component (rad/s).
    pub gyro_bias_sigma: f64,
    /// Initial 1σ of each accelerometer bias component (m/s²).
    pub accel_bias_sigma: f64,
}

impl Default for InertialConfig {
    fn default() -> Self {
        Self {
            duration: 60.0,
            imu_rate: 50.0,
            fix_every: 50,
            fix_sigma: 0.5,
            imu: ImuNoise {
                gyro: 0.01,
                accel: 0.05,
                gyro_bias_walk: 1e-4,
                accel_bias_walk: 1e-3,
            },
            initial_velocity: InitialVelocity::Body,
            heading_sigma: 30f64.to_radians(),
            tilt_sigma: 2f64.to_radians(),
            velocity_sigma: 0.3,
            position_sigma: 1.0,
            gyro_bias_sigma: 0.01,
            accel_bias_sigma: 0.1,
        }
    }
}

impl InertialConfig {
    /// Checks the settings: the IMU rate in [`IMU_RATE_RANGE`](super::IMU_RATE_RANGE) = [1, 1e6] Hz
    /// (the steps [`ImuStep::new`] takes), the duration positive with at most 1e8 IMU samples, a fix
    /// at least every run, at most [`MAX_EPOCHS`] fixes; `fix_sigma` in
    /// [`FIX_SIGMA_RANGE`](super::FIX_SIGMA_RANGE) = [1e-30, 1e6] m, the initial σ's from the shared
    /// lower bound 1e-30 (a σ below it made the prior's `tr P⁻¹` exceed 1e100, an error naming no
    /// setting) up to 1e6 (velocity, position), π/2 (heading, tilt) or 1e3 (biases); the IMU's noise
    /// as [`ImuNoise::validate`].
    ///
    /// # Errors
    /// [`FilterError::Setting`] naming the field.
    pub fn validate(&self) -> Result<(), FilterError> {
        const ORIGIN: &str = "inertial::InertialConfig";
        let setting =
            |setting: &'static str, value: f64, expected: &'static str| FilterError::Setting {
                origin: ORIGIN,
                setting,
                value: Readable(value).to_string(),
                expected,
            };
        setting_in(
            ORIGIN,
            "imu_rate",
            self.imu_rate,
            IMU_RATE_RANGE,
            "a rate in [1, 1e6] Hz (a step in [1e-6, 1] s)",
        )?;
        if !(self.duration > 0.0 && self.duration * self.imu_rate <= 1e8) {
            return Err(setting(
                "duration",
                self.duration,
                "positive, at most 1e8 IMU samples",
            ));
        }
        if self.fix_every == 0 || self.epochs() == 0 || self.epochs() > MAX_EPOCHS {
            return Err(setting(
                "fix_every",
                self.fix_every as f64,
                "at least 1, with between 1 and 2^24 fixes in a run",
            ));
        }
        let low = SIGMA_RANGE.0;
        let half_turn = std::f64::consts::FRAC_PI_2;
        for (name, value, range, expected) in [
            (
                "fix_sigma",
                self.fix_sigma,
                FIX_SIGMA_RANGE,
                "a standard deviation in [1e-30, 1e6] m",
            ),
            (
                "heading_sigma",
                self.heading_sigma,
                (low, half_turn),
                "a standard deviation in [1e-30, pi/2] rad",
            ),
            (
                "tilt_sigma",
                self.tilt_sigma,
                (low, half_turn),
                "a standard deviation in [1e-30, pi/2] rad",
            ),
            (
                "velocity_sigma",
                self.velocity_sigma,
                (low, 1e6),
                "a standard deviation in [1e-30, 1e6] m/s",
            ),
            (
                "position_sigma",
                self.position_sigma,
                (low, 1e6),
                "a standard deviation in [1e-30, 1e6] m",
            ),
            (
                "gyro_bias_sigma",
                self.gyro_bias_sigma,
                (low, 1e3),
                "a standard deviation in [1e-30, 1e3] rad/s",
            ),
            (
                "accel_bias_sigma",
                self.accel_bias_sigma,
                (low, 1e3),
                "a standard deviation in [1e-30, 1e3] m/s^2",
            ),
        ] {
            setting_in(ORIGIN, name, value, range, expected)?;
        }
        self.imu.validate()
    }

    /// The number of IMU samples of a run.
    // The product is checked by `validate` to lie in (0, 1e8]; a NaN casts to 0.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    pub fn samples(&self) -> usize {
        (self.duration * self.imu_rate).round().clamp(0.0, 1e8) as usize
    }

    /// The number of position fixes of a run.
    pub fn epochs(&self) -> usize {
        self.samples() / self.fix_every.max(1)
    }

    /// The IMU step (s).
    pub fn dt(&self) -> f64 {
        1.0 / self.imu_rate
    }
}

/// The scenario: the vehicle starts level, heading along x at 5 m/s, and manoeuvres with a body
/// angular rate `(0.05 sin 0.5t, 0.05 cos 0.4t, 0.3 sin 0.1t)` rad/s and a forward acceleration
/// `0.5 sin 0.2t` m/s² (the specific force adds the reaction to gravity). The truth integrates the
/// filters' own strapdown model ([`integrate`](super::integrate)) with the true readings; the
/// IMU reports them plus the biases (random walks) and white noise, each reading saturating at a
/// norm of [`MAX_READING`](super::MAX_READING) (scaled down, its direction kept) like a real
/// sensor's range, so that every sample is one [`ImuStep::new`] accepts; a fix of the position every
/// `fix_every` samples.
/// The initial truth is drawn around the prior mean: a heading, roll and pitch error in the world
/// frame, the velocity known in the body or the world frame ([`InitialVelocity`]), and Gaussian
/// velocity, position and bias errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertialScenario {
    config: InertialConfig,
}

impl InertialScenario {
    /// The scenario of `config`.
    ///
    /// # Errors
    /// As [`InertialConfig::validate`].
    pub fn new(config: InertialConfig) -> Result<Self, FilterError> {
        config.validate()?;
        Ok(Self { config })
    }

    /// Its settings.
    pub fn config(&self) -> &InertialConfig {
        &self.config
    }

    /// The prior mean every filter starts from: level, heading along x, 5 m/s forward, at the
    /// origin, no bias.
    pub fn prior_mean() -> Navigation {
        Navigation {
            rotation: So3::identity(),
            velocity: Vector3::new(5.0, 0.0, 0.0),
            position: Vector3::zeros(),
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
        }
    }

    /// One draw of the initial truth.
    pub fn draw_initial(&self, rng: &mut ChaCha8Rng) -> Navigation {
        let c = &self.config;
        let mut normal = || -> f64 { StandardNormal.sample(rng) };
        let mean = Self::prior_mean();
        let tilt = Vector3::new(
            c.tilt_sigma * normal(),
            c.tilt_sigma * normal(),
            c.heading_sigma * normal(),
        );
        let mut vector = |sigma: f64| Vector3::new(normal(), normal(), normal()) * sigma;
        let attitude_error = So3::exp(&tilt);
        Navigation {
            rotation: attitude_error.compose(&mean.rotation),
            velocity: match c.initial_velocity {
                InitialVelocity::World => mean.velocity,
                InitialVelocity::Body => attitude_error.rotate(&mean.velocity),
            } + vector(c.velocity_sigma),
            position: mean.position + vector(c.position_sigma),
            gyro_bias: vector(c.gyro_bias_sigma),
            accel_bias: vector(c.accel_bias_sigma),
        }
    }

    /// The prior of a filter on the state S: the mean [`prior_mean`](Self::prior_mean) and the
    /// covariance of the initial distribution in S's own error coordinates,
    /// `P = (1/n) Σ (x̂ ⊟ xᵢ)(x̂ ⊟ xᵢ)ᵀ` over [`PRIOR_DRAWS`] draws of [`draw_initial`](Self::draw_initial)
    /// from a fixed stream: every filter is given the same initial information, each in its own
    /// convention (exact for the error-state EKF, whose errors are Gaussian by construction; the
    /// invariant errors' first two moments otherwise). Where the moments are singular to rounding
    /// (a velocity σ of 1e-30 makes the invariant velocity error a function of the attitude
    /// error; σ's below the rounding of a rotation make the attitude error its rounding), P is
    /// refused by [`ManifoldGaussian::new`]; it is then taken with `64 · 15 ε max Pᵢᵢ` added to
    /// its diagonal, the rounding of its largest entries (information finer than that is lost to
    /// the arithmetic anyway).
    ///
    /// # Errors
    /// [`FilterError::Density`] if the moments, with that floor too, are not a valid covariance.
    pub fn prior<S: NavigationState>(
        &self,
    ) -> Result<ManifoldGaussian<S, NAVIGATION_DIM>, FilterError> {
        let mean = S::from_navigation(&Self::prior_mean());
        let mut rng = ChaCha8Rng::seed_from_u64(0x5eed_0001);
        let mut sum = SMatrix::<f64, NAVIGATION_DIM, NAVIGATION_DIM>::zeros();
        for _ in 0..PRIOR_DRAWS {
            let e = mean.local(&S::from_navigation(&self.draw_initial(&mut rng)));
            sum += e * e.transpose();
        }
        let moments = sum / PRIOR_DRAWS as f64;
        ManifoldGaussian::new(mean.clone(), moments).or_else(|error| {
            let floor = 64.0 * NAVIGATION_DIM as f64 * f64::EPSILON * moments.diagonal().amax();
            let floored =
                moments + SMatrix::<f64, NAVIGATION_DIM, NAVIGATION_DIM>::identity() * floor;
            ManifoldGaussian::new(mean, floored).map_err(|_| FilterError::from(error))
        })
    }

    /// The true body rate and specific force at time t for the attitude `rotation`.
    fn true_readings(t: f64, rotation: &So3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let rate = Vector3::new(
            0.05 * (0.5 * t).sin(),
            0.05 * (0.4 * t).cos(),
            0.3 * (0.1 * t).sin(),
        );
        let forward = Vector3::new(0.5 * (0.2 * t).sin(), 0.0, 0.0);
        let force = forward - rotation.inverse().rotate(&super::strapdown::GRAVITY);
        (rate, force)
    }
}

/// The steps of one run of an [`InertialScenario`].
pub struct InertialSteps<'s> {
    scenario: &'s InertialScenario,
    rng: &'s mut ChaCha8Rng,
    truth: Navigation,
    sample: usize,
}

impl Iterator for InertialSteps<'_> {
    type Item = Step<Navigation, ImuStep, Vector3<f64>>;

    fn next(&mut self) -> Option<Self::Item> {
        let c = &self.scenario.config;
        if self.sample >= c.samples() {
            return None;
        }
        let dt = c.dt();
        let t = self.sample as f64 * dt;
        let (rate, force) = InertialScenario::true_readings(t, &self.truth.rotation);
        let mut normal = || -> f64 { StandardNormal.sample(&mut *self.rng) };
        let mut noise =
            |density: f64| Vector3::new(normal(), normal(), normal()) * (density / dt.sqrt());
        // The true motion: the noise-free readings plus the biases, which the strapdown step removes.
        let (biased_rate, biased_force) =
            (rate + self.truth.gyro_bias, force + self.truth.accel_bias);
        let measured_rate = biased_rate + noise(c.imu.gyro);
        let measured_force = biased_force + noise(c.imu.accel);
        // The truth is not limited to the sensor's range (the validated configuration keeps it
        // finite).
        let mut next = strapdown(&self.truth, &biased_rate, &biased_force, dt);
        let mut walk =
            |density: f64| Vector3::new(normal(), normal(), normal()) * (density * dt.sqrt());
        next.gyro_bias += walk(c.imu.gyro_bias_walk);
        next.accel_bias += walk(c.imu.accel_bias_walk);
        self.truth = next;
        self.sample += 1;
        let measurement = (self.sample % c.fix_every == 0).then(|| {
            let mut normal = || -> f64 { StandardNormal.sample(&mut *self.rng) };
            self.truth.position + Vector3::new(normal(), normal(), normal()) * c.fix_sigma
        });
        // dt = 1 / imu_rate lies in [1e-5, 1] for a validated configuration.
        let input = ImuStep::saturated(measured_rate, measured_force, dt);
        Some(Step {
            time: self.sample as f64 * dt,
            input,
            truth: self.truth,
            measurement,
        })
    }
}

impl Scenario for InertialScenario {
    type Truth = Navigation;
    type Input = ImuStep;
    type Measurement = Vector3<f64>;
    type Steps<'s> = InertialSteps<'s>;

    fn epochs(&self) -> usize {
        self.config.epochs()
    }

    fn simulate<'s>(
        &'s self,
        rng: &'s mut ChaCha8Rng,
    ) -> Result<InertialSteps<'s>, ExperimentError> {
        let truth = self.draw_initial(rng);
        Ok(InertialSteps {
            scenario: self,
            rng,
            truth,
            sample: 0,
        })
    }
}
