//! The production attitude filter: an error-state EKF on attitude × gyro bias × horizontal
//! velocity × the local magnetic field's heading offset, composed from the library's parts
//! ([`ManifoldGaussian`] on a [`ProductManifold`] of [`Left`]`<So3>` (world-frame attitude error)
//! and `Rn<6>`, propagated and conditioned by the
//! [`Ekf`] operators), with what real IMU data needs (see `docs/filters/attitude.md`):
//!
//! * **strapdown** per sample, `R ← R exp([ω − b̂]ₓ Δt)`, and the covariance propagated once per
//!   block of samples from the block's preintegrated increments ([`BlockProcess`]);
//! * **bounded velocity**: the horizontal velocity `v` integrates `(R f)_xy` (the accelerometer in
//!   the world frame; gravity is vertical) and a pseudo-measurement `v = 0 ± σ_v` at a fixed
//!   interval says that a hand-held sensor does not run away; the velocity's error grows as
//!   `g × δθ`, so this observes the tilt without ever reading a single accelerometer sample as the
//!   gravity direction (linear accelerations average out instead of tilting the estimate);
//! * **rest detection**: gyroscope and accelerometer within thresholds of their low-passed values
//!   for a minimum time; at rest, the low-passed gyroscope measures the bias and the velocity is
//!   zero to a tight σ;
//! * **heading-only magnetometer**: the heading of the field rotated into the world frame, a scalar
//!   measurement whose Jacobian has only the vertical component (the magnetometer never tilts the
//!   estimate; the tilt's share of the heading error is added to the measurement variance), taken
//!   from the freshest magnetometer sample and the orientation at the time it was measured (a fixed
//!   delay), with disturbance rejection by field norm, dip and the innovation's NIS, and adoption of
//!   a new reference field when a disturbance lasts;
//! * **correlated magnetometer errors**: the heading of the local field differs from true north by
//!   an offset `c` that changes over tens of seconds (the field of a room varies from place to
//!   place by degrees; a phone or magnet carried with the sensor shifts it), a first-order
//!   Gauss-Markov state the magnetometer measures together with the heading, so that averaging many
//!   magnetometer samples never makes the heading more certain than the field it points along;
//! * **initialisation** from the first sample (tilt from the accelerometer, heading from the
//!   magnetometer in 9D, zero heading in 6D).

use super::data::{DataError, ImuLog, bad, check_positive, scaled_unit};
use super::study::{AttitudeEstimate, ImuSample};
use super::talk::from_diffusion;
use super::track::AttitudeTrack;
use liebayes_densities::{Bingham, HeatKernelSo3, ManifoldGaussian};
use liebayes_experiments::{Nis, RecursiveFilter, Update};
use liebayes_manifolds::wrap_angle;
use liebayes_manifolds::{Left, ProductManifold, Rn, So3};
use liebayes_operators::{
    Condition, Ekf, MeasurementModel, OperatorError, ProcessModel, Propagate, Ukf,
};
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector2, Vector3};
use std::f64::consts::PI;

/// The filter's state: attitude (IMU frame w.r.t. ENU, error `R = exp([δθ]ₓ) R̂` in the world
/// frame) × (gyro bias b (rad/s, IMU frame), horizontal velocity v (m/s, East, North), the local
/// field's heading offset c (rad, the field's heading east of true north)); tangent order
/// (δθ, δb, δv, δc).
pub type AttitudeState = ProductManifold<Left<So3<f64>>, Rn<f64, 6>, 3, 6, 9>;

/// The state's dimension.
pub const STATE_DIM: usize = 9;

/// Tangent index of the field's heading offset c.
const OFFSET: usize = 8;

/// The operator that propagates the Gaussian over a block ([`BlockProcess`]); the measurement
/// updates are always [`Ekf`] (the heading measurement is defined by its Jacobian: it has no tilt
/// column, so that the magnetometer never tilts the estimate).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Propagation {
    /// First order, with the block's analytic Jacobian.
    Ekf,
    /// The unscented transform ([`Ukf`] with its defaults: 2 × 9 + 1 sigma points).
    Ukf,
}

/// Which sensors the filter uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sensors {
    /// Gyroscope, accelerometer and magnetometer.
    NineD,
    /// Gyroscope and accelerometer: heading is integrated only (and starts at zero).
    SixD,
}

/// Rest detection (all thresholds on the deviation of a sample from the low-passed signal).
#[derive(Clone, Debug, PartialEq)]
pub struct RestParams {
    /// Gyroscope threshold (rad/s).
    pub gyro_threshold: f64,
    /// Accelerometer threshold (m/s²).
    pub acc_threshold: f64,
    /// Time both must hold before the sensor counts as at rest (s).
    pub min_duration: f64,
    /// Time constant of the first-order low-pass filters (s).
    pub filter_tau: f64,
    /// σ of the zero-velocity measurement at rest (m/s).
    pub velocity_sigma: f64,
    /// σ of the low-passed gyroscope as a measurement of the bias at rest (rad/s).
    pub bias_sigma: f64,
}

/// Magnetic disturbance rejection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisturbanceParams {
    /// Relative deviation of the field norm from the reference that counts as disturbed.
    pub norm_threshold: f64,
    /// Deviation of the dip angle from the reference that counts as disturbed (rad).
    pub dip_threshold: f64,
    /// Largest normalised innovation squared accepted...
    pub nis_gate: f64,
    /// ...for at most this long (s): a gate that has rejected every sample for this long lets the
    /// next one through (otherwise a heading that drifted out of the gate would never return).
    pub gate_time: f64,
    /// Time constant with which the reference norm and dip follow accepted samples (s).
    pub reference_tau: f64,
    /// A disturbed field that stays consistent with itself this long becomes the new reference (s).
    pub new_field_time: f64,
    /// For this long after the start (s) every sample is used and the reference is their running
    /// mean: the first sample's dip carries the first tilt's error (linear acceleration).
    pub first_field_time: f64,
}

/// The heading offset of the local field from true north, a first-order Gauss-Markov process:
/// `c′ = a c + w`, `a = exp(−T/τ)`, `w ~ N(0, σ_c² (1 − a²))`, stationary `c ~ N(0, σ_c²)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldOffset {
    /// Stationary σ_c (rad).
    pub sigma: f64,
    /// Correlation time τ (s).
    pub correlation_time: f64,
}

/// The magnetometer's use (9D).
#[derive(Clone, Debug, PartialEq)]
pub struct MagnetometerParams {
    /// σ of the heading measurement (rad): the magnetometer noise and the field's errors that are
    /// independent from one update to the next.
    pub heading_sigma: f64,
    /// The field's correlated heading error; `None` treats every error as independent (the
    /// offset stays zero).
    pub offset: Option<FieldOffset>,
    /// Time between heading updates (s).
    pub interval: f64,
    /// How much older a magnetometer sample is than the gyroscope sample of the same row (s).
    pub delay: f64,
    /// Disturbance rejection; `None` uses every sample.
    pub disturbance: Option<DisturbanceParams>,
}

/// The one parameter set of the production filter (SI units, angles in rad).
#[derive(Clone, Debug, PartialEq)]
pub struct AttitudeParams {
    /// Gyroscope angle random walk (rad/√s).
    pub gyro_noise: f64,
    /// Attitude noise proportional to the rotation rate (√s): the gyroscope's scale-factor and
    /// axis errors, whose variance per second is `(rate_noise |ω|)²`.
    pub rate_noise: f64,
    /// Gyro bias random walk (rad/s/√s); with `estimate_bias == false` the bias stays at zero.
    pub bias_walk: f64,
    /// Whether the gyro bias is estimated.
    pub estimate_bias: bool,
    /// Initial σ of the gyro bias (rad/s).
    pub initial_bias_sigma: f64,
    /// Initial σ of each tilt component (rad).
    pub initial_tilt_sigma: f64,
    /// Initial σ of the heading (rad): 9D, from the first magnetometer sample.
    pub initial_heading_sigma: f64,
    /// σ of the bounded-velocity pseudo-measurement `v = 0` (m/s).
    pub velocity_bound: f64,
    /// Velocity random walk (m/s/√s): accelerometer noise and the drift the pseudo-measurement
    /// forgives between updates.
    pub velocity_walk: f64,
    /// Time between bounded-velocity (and rest) updates (s).
    pub velocity_interval: f64,
    /// Largest time between covariance propagations (s).
    pub block: f64,
    /// How the covariance is propagated over a block.
    pub propagation: Propagation,
    /// Rest detection; `None` never detects rest.
    pub rest: Option<RestParams>,
    /// The magnetometer's use (9D only).
    pub magnetometer: MagnetometerParams,
}

impl Default for AttitudeParams {
    fn default() -> Self {
        Self {
            gyro_noise: 0.26f64.to_radians(),
            rate_noise: 0.004,
            bias_walk: 0.001f64.to_radians(),
            estimate_bias: true,
            initial_bias_sigma: 0.5f64.to_radians(),
            initial_tilt_sigma: 10f64.to_radians(),
            initial_heading_sigma: 10f64.to_radians(),
            velocity_bound: 0.5,
            velocity_walk: 0.3,
            velocity_interval: 0.5,
            block: 0.04,
            propagation: Propagation::Ekf,
            rest: Some(RestParams {
                gyro_threshold: 2f64.to_radians(),
                acc_threshold: 0.5,
                min_duration: 1.5,
                filter_tau: 0.5,
                velocity_sigma: 0.02,
                bias_sigma: 0.05f64.to_radians(),
            }),
            magnetometer: MagnetometerParams {
                heading_sigma: 12f64.to_radians(),
                offset: Some(FieldOffset {
                    sigma: 4f64.to_radians(),
                    correlation_time: 120.0,
                }),
                interval: 0.5,
                delay: 0.012,
                disturbance: Some(DisturbanceParams {
                    norm_threshold: 0.1,
                    dip_threshold: 10f64.to_radians(),
                    nis_gate: 25.0,
                    gate_time: 5.0,
                    reference_tau: 20.0,
                    new_field_time: 20.0,
                    first_field_time: 5.0,
                }),
            },
        }
    }
}

impl AttitudeParams {
    /// Checks every setting.
    ///
    /// # Errors
    /// [`DataError::BadValue`] naming the first setting that is not finite and positive (or, for
    /// the thresholds, non-negative).
    pub fn validate(&self) -> Result<(), DataError> {
        let o = "AttitudeParams";
        for (name, v) in [
            ("gyro_noise", self.gyro_noise),
            ("rate_noise", self.rate_noise),
            ("bias_walk", self.bias_walk),
            ("initial_bias_sigma", self.initial_bias_sigma),
            ("initial_tilt_sigma", self.initial_tilt_sigma),
            ("initial_heading_sigma", self.initial_heading_sigma),
            ("velocity_bound", self.velocity_bound),
            ("velocity_walk", self.velocity_walk),
            ("velocity_interval", self.velocity_interval),
            ("block", self.block),
            (
                "magnetometer.heading_sigma",
                self.magnetometer.heading_sigma,
            ),
            ("magnetometer.interval", self.magnetometer.interval),
        ] {
            check_positive(o, name, v)?;
        }
        if !(self.magnetometer.delay.is_finite() && (0.0..=1.0).contains(&self.magnetometer.delay))
        {
            return Err(bad(
                o,
                "magnetometer.delay",
                self.magnetometer.delay.to_string(),
                "a delay in [0, 1] s",
            ));
        }
        if let Some(f) = &self.magnetometer.offset {
            check_positive(o, "magnetometer.offset.sigma", f.sigma)?;
            check_positive(
                o,
                "magnetometer.offset.correlation_time",
                f.correlation_time,
            )?;
        }
        if let Some(r) = &self.rest {
            for (name, v) in [
                ("rest.gyro_threshold", r.gyro_threshold),
                ("rest.acc_threshold", r.acc_threshold),
                ("rest.min_duration", r.min_duration),
                ("rest.filter_tau", r.filter_tau),
                ("rest.velocity_sigma", r.velocity_sigma),
                ("rest.bias_sigma", r.bias_sigma),
            ] {
                check_positive(o, name, v)?;
            }
        }
        if let Some(d) = &self.magnetometer.disturbance {
            for (name, v) in [
                ("disturbance.norm_threshold", d.norm_threshold),
                ("disturbance.dip_threshold", d.dip_threshold),
                ("disturbance.nis_gate", d.nis_gate),
                ("disturbance.gate_time", d.gate_time),
                ("disturbance.reference_tau", d.reference_tau),
                ("disturbance.new_field_time", d.new_field_time),
                ("disturbance.first_field_time", d.first_field_time),
            ] {
                check_positive(o, name, v)?;
            }
        }
        Ok(())
    }
}

/// The preintegrated increments of one block of gyroscope and accelerometer samples, in the IMU
/// frame at the block's start (`ΔRᵢ` the rotation from the start to sample i):
/// `ΔR = Π exp([ωᵢ − b̂]ₓ Δt)`, `Δv = Σ ΔRᵢ fᵢ Δt`, `B = Σ ΔRᵢ Δt`, `T = n Δt`, with the bias `b̂`
/// they were integrated with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block {
    /// `ΔR`.
    pub rotation: UnitQuaternion<f64>,
    /// `Δv` (m/s, start frame).
    pub velocity: Vector3<f64>,
    /// `B` (s): how the bias moves the attitude.
    pub bias_coupling: Matrix3<f64>,
    /// `T` (s).
    pub duration: f64,
    /// `b̂` (rad/s).
    pub bias: Vector3<f64>,
}

impl Block {
    fn empty(bias: Vector3<f64>) -> Self {
        Self {
            rotation: UnitQuaternion::identity(),
            velocity: Vector3::zeros(),
            bias_coupling: Matrix3::zeros(),
            duration: 0.0,
            bias,
        }
    }

    /// Adds one sample: gyroscope ω, accelerometer f, interval Δt.
    fn push(&mut self, gyro: &Vector3<f64>, acc: &Vector3<f64>, dt: f64) {
        self.rotation *= UnitQuaternion::from_scaled_axis((gyro - self.bias) * dt);
        let r = self.rotation.to_rotation_matrix().into_inner();
        self.velocity += r * acc * dt;
        self.bias_coupling += r * dt;
        self.duration += dt;
    }
}

/// The block's process model on [`AttitudeState`]:
/// `R′ = exp(−[R B (b − b̂)]ₓ) R ΔR`, `b′ = b`, `v′ = v + (R Δv)_xy`, `c′ = a c` with
/// `a = exp(−T/τ_c)`; noise `diag((σ_g² + s² |ω̄|²) T I₃, σ_b² T I₃, σ_v² T I₂, σ_c² (1 − a²))`
/// (|ω̄| the block's mean rate); Jacobian (world-frame error) `∂δθ′/∂δb = −R B`,
/// `∂δv′/∂δθ = −[R Δv]ₓ` restricted to the two tilt columns (the accelerometer never turns the
/// heading: its horizontal part is velocity, not direction, information), `∂δc′/∂δc = a`. The
/// bias's second-order effect on v inside a block is omitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockProcess {
    /// Gyroscope angle random walk (rad/√s).
    pub gyro_noise: f64,
    /// Rate-proportional attitude noise (√s).
    pub rate_noise: f64,
    /// Bias random walk (rad/s/√s).
    pub bias_walk: f64,
    /// Velocity random walk (m/s/√s).
    pub velocity_walk: f64,
    /// The field offset's process; `None` keeps it constant without noise.
    pub offset: Option<FieldOffset>,
}

impl BlockProcess {
    /// The offset's factor `a = exp(−T/τ_c)` over `t` seconds (1 without an offset process).
    fn offset_decay(&self, t: f64) -> f64 {
        self.offset
            .as_ref()
            .map_or(1.0, |f| (-t / f.correlation_time).exp())
    }
}

impl ProcessModel<AttitudeState, STATE_DIM> for BlockProcess {
    type Input = Block;

    fn transition(&self, x: &AttitudeState, u: &Block) -> AttitudeState {
        let r = x.first().inner().as_unit_quaternion();
        let rest = x.second().coords();
        let bias = rest.fixed_rows::<3>(0).into_owned();
        let turn = r * (u.bias_coupling * (bias - u.bias)).into_owned();
        let attitude = UnitQuaternion::from_scaled_axis(-turn) * r * u.rotation;
        let dv = r * u.velocity;
        let mut next = *rest;
        next[3] += dv.x;
        next[4] += dv.y;
        next[5] *= self.offset_decay(u.duration);
        AttitudeState::new(
            Left::new(So3::from_unit_quaternion(attitude)),
            Rn::new_unchecked(next),
        )
    }

    fn noise(&self, _x: &AttitudeState, u: &Block) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        let t = u.duration;
        // (rate_noise |ω̄|)² T with |ω̄| = angle(ΔR)/T.
        let turned = self.rate_noise * u.rotation.angle();
        let attitude =
            self.gyro_noise * self.gyro_noise * t + turned * turned / t.max(f64::MIN_POSITIVE);
        let mut q = SMatrix::<f64, STATE_DIM, STATE_DIM>::zeros();
        for i in 0..3 {
            q[(i, i)] = attitude;
            q[(i + 3, i + 3)] = self.bias_walk * self.bias_walk * t;
        }
        for i in 6..8 {
            q[(i, i)] = self.velocity_walk * self.velocity_walk * t;
        }
        if let Some(f) = &self.offset {
            let a = self.offset_decay(t);
            q[(OFFSET, OFFSET)] = f.sigma * f.sigma * (1.0 - a * a);
        }
        q
    }

    fn jacobian(&self, x: &AttitudeState, u: &Block) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        let r = x.first().inner().as_unit_quaternion().to_rotation_matrix();
        let mut f = SMatrix::<f64, STATE_DIM, STATE_DIM>::identity();
        let rb = r.matrix() * u.bias_coupling;
        f.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-rb));
        let a = r * u.velocity;
        // −[a]ₓ, rows x and y, columns of the two tilt components.
        f[(6, 1)] = a.z;
        f[(7, 0)] = -a.z;
        f[(OFFSET, OFFSET)] = self.offset_decay(u.duration);
        f
    }
}

/// A linear measurement of a slice of the state's tangent: `z = x[offset..offset + M]`, noise
/// `σ² I`. The zero-velocity (`offset` 6, M = 2) and rest-bias (`offset` 3, M = 3) measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StateSlice<const M: usize> {
    /// The first tangent coordinate measured.
    pub offset: usize,
    /// σ of each component.
    pub sigma: f64,
}

impl<const M: usize> MeasurementModel<AttitudeState, STATE_DIM, M> for StateSlice<M> {
    fn predict(&self, x: &AttitudeState) -> SVector<f64, M> {
        x.second()
            .coords()
            .fixed_rows::<M>(self.offset - 3)
            .into_owned()
    }

    fn noise(&self, _x: &AttitudeState) -> SMatrix<f64, M, M> {
        SMatrix::<f64, M, M>::identity() * (self.sigma * self.sigma)
    }

    fn jacobian(&self, _x: &AttitudeState) -> SMatrix<f64, M, STATE_DIM> {
        let mut h = SMatrix::<f64, M, STATE_DIM>::zeros();
        for i in 0..M {
            h[(i, self.offset + i)] = 1.0;
        }
        h
    }
}

/// The heading-only magnetometer measurement: the heading `ψ = atan2(m_E, m_N)` of the measured
/// field `m` (IMU frame, brought to the current sample) rotated into the world frame by the
/// state's attitude, less the field's offset c, measured as 0 (North is the reference field's
/// north) with the wrapped residual. Jacobian: `∂/∂δθ_z = −1`, `∂/∂δc = −1`, the tilt columns
/// zero; their share of the error, `h_t P_tt h_tᵀ` with `h_t = ∂ψ/∂δθ_xy`, is in the variance
/// (`tilt_variance`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heading {
    /// The magnetometer reading in the current IMU frame.
    pub field: Vector3<f64>,
    /// σ of the heading (rad).
    pub sigma: f64,
    /// The tilt's share of the heading variance (rad²).
    pub tilt_variance: f64,
}

impl Heading {
    /// The world-frame field and `∂ψ/∂δθ` (all three columns) at the attitude `r`.
    fn jacobian_full(&self, r: &UnitQuaternion<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let m = r * self.field;
        let h2 = (m.x * m.x + m.y * m.y).max(f64::MIN_POSITIVE);
        // dψ/dm = (m_N, −m_E, 0)/h², dm/dδθ = −[m]ₓ.
        let dpsi = Vector3::new(m.y / h2, -m.x / h2, 0.0);
        (m, -(m.cross_matrix().transpose() * dpsi))
    }
}

impl MeasurementModel<AttitudeState, STATE_DIM, 1> for Heading {
    fn predict(&self, x: &AttitudeState) -> SVector<f64, 1> {
        let m = x.first().inner().as_unit_quaternion() * self.field;
        SVector::<f64, 1>::new(wrap_angle(m.x.atan2(m.y) - x.second().coords()[5]))
    }

    fn noise(&self, _x: &AttitudeState) -> SMatrix<f64, 1, 1> {
        SMatrix::<f64, 1, 1>::new(self.sigma * self.sigma + self.tilt_variance)
    }

    fn residual(&self, z: &SVector<f64, 1>, predicted: &SVector<f64, 1>) -> SVector<f64, 1> {
        SVector::<f64, 1>::new(wrap_angle(z[0] - predicted[0]))
    }

    fn jacobian(&self, _x: &AttitudeState) -> SMatrix<f64, 1, STATE_DIM> {
        let mut h = SMatrix::<f64, 1, STATE_DIM>::zeros();
        h[(0, 2)] = -1.0;
        h[(0, OFFSET)] = -1.0;
        h
    }
}

/// The reference field's norm and dip, learned online.
#[derive(Clone, Copy, Debug, PartialEq)]
struct FieldReference {
    norm: f64,
    dip: f64,
}

/// The magnetometer's running state.
#[derive(Clone, Debug, PartialEq)]
struct MagnetState {
    reference: FieldReference,
    /// The candidate for a new reference during a disturbance, and since when it has held (s).
    candidate: Option<(FieldReference, f64)>,
    last: Vector3<f64>,
    /// Samples since the last fresh (changed) reading.
    age: usize,
    disturbed: bool,
    /// Time the NIS gate has rejected every sample (s).
    gated: f64,
    /// Time the reference has been learned from (s).
    learned: f64,
}

/// How many past orientations are kept to line the magnetometer up with the gyroscope.
const HISTORY: usize = 32;

/// Low-pass state of the rest detector.
#[derive(Clone, Debug, PartialEq)]
struct RestState {
    gyro: Vector3<f64>,
    acc: Vector3<f64>,
    since: f64,
}

/// The production attitude filter, one sample at a time ([`AttitudeEkf::process_sample`]); see the module
/// documentation for the model.
#[derive(Clone, Debug)]
pub struct AttitudeEkf {
    params: AttitudeParams,
    sensors: Sensors,
    dt: f64,
    process: BlockProcess,
    block_samples: usize,
    /// Bounded-velocity (and rest) updates every this many blocks.
    velocity_every: usize,
    /// Heading updates every this many blocks.
    mag_every: usize,
    /// Blocks propagated so far.
    blocks: usize,
    mag_delay: usize,
    density: Option<ManifoldGaussian<AttitudeState, STATE_DIM>>,
    /// The current orientation (strapdown between blocks).
    orientation: UnitQuaternion<f64>,
    block: Block,
    in_block: usize,
    count: usize,
    history: [UnitQuaternion<f64>; HISTORY],
    rest: Option<RestState>,
    magnet: Option<MagnetState>,
    /// A heading update fell due at a block's end and waits for the next magnetometer reading.
    heading_due: bool,
}

impl AttitudeEkf {
    /// A filter for samples at `rate` (Hz), not yet initialised (the first [`process_sample`](Self::process_sample)
    /// initialises it).
    ///
    /// # Errors
    /// As [`AttitudeParams::validate`]; [`DataError::BadValue`] for a rate that is not finite and
    /// positive.
    pub fn new(params: AttitudeParams, sensors: Sensors, rate: f64) -> Result<Self, DataError> {
        params.validate()?;
        check_positive("AttitudeEkf::new", "rate", rate)?;
        let dt = 1.0 / rate;
        let samples = |seconds: f64| samples_in(seconds, rate).max(1);
        let block_samples = samples(params.block);
        let in_blocks = |seconds: f64| samples(seconds).div_ceil(block_samples).max(1);
        Ok(Self {
            process: BlockProcess {
                gyro_noise: params.gyro_noise,
                rate_noise: params.rate_noise,
                bias_walk: if params.estimate_bias {
                    params.bias_walk
                } else {
                    0.0
                },
                velocity_walk: params.velocity_walk,
                offset: params.magnetometer.offset,
            },
            block_samples,
            velocity_every: in_blocks(params.velocity_interval),
            mag_every: in_blocks(params.magnetometer.interval),
            blocks: 0,
            mag_delay: samples_in(params.magnetometer.delay, rate).min(HISTORY - 1),
            dt,
            sensors,
            params,
            density: None,
            orientation: UnitQuaternion::identity(),
            block: Block::empty(Vector3::zeros()),
            in_block: 0,
            count: 0,
            history: [UnitQuaternion::identity(); HISTORY],
            rest: None,
            magnet: None,
            heading_due: false,
        })
    }

    /// The orientation after the last sample (IMU frame w.r.t. ENU); identity before the first.
    pub fn orientation(&self) -> UnitQuaternion<f64> {
        self.orientation
    }

    /// The Gaussian of the last covariance propagation or update (`None` before the first
    /// sample): mean and world-frame covariance of (attitude, bias, velocity).
    pub fn density(&self) -> Option<&ManifoldGaussian<AttitudeState, STATE_DIM>> {
        self.density.as_ref()
    }

    /// The world-frame attitude error covariance (rad²), zero before the first sample.
    pub fn attitude_covariance(&self) -> Matrix3<f64> {
        self.density.as_ref().map_or_else(Matrix3::zeros, |d| {
            d.covariance().fixed_view::<3, 3>(0, 0).into_owned()
        })
    }

    /// The estimated gyro bias (rad/s).
    pub fn bias(&self) -> Vector3<f64> {
        self.block.bias
    }

    /// Whether the last sample was detected as rest.
    pub fn at_rest(&self) -> bool {
        self.rest_detected()
    }

    /// Whether the magnetometer is currently rejected as disturbed (9D).
    pub fn magnetic_disturbance(&self) -> bool {
        self.magnet.as_ref().is_some_and(|m| m.disturbed)
    }

    /// The attitude marginal as a Bingham density on the unit quaternion, with the second moments
    /// of the Gaussian's attitude part (the body-frame covariance `R̂ᵀ P_θθ R̂` of a left-translated
    /// diffusion about `R̂`), as the talk's filter represents its state.
    ///
    /// # Errors
    /// [`DataError::BadValue`] before the first sample or outside the Bingham's range (a variance
    /// below about 2e-6 rad²).
    pub fn attitude_bingham(&self) -> Result<Bingham, DataError> {
        let r = self.orientation.to_rotation_matrix().into_inner();
        if self.density.is_none() {
            return Err(bad(
                "AttitudeEkf::attitude_bingham",
                "state",
                "uninitialised".to_owned(),
                "a filter that has processed a sample",
            ));
        }
        let body = r.transpose() * self.attitude_covariance() * r;
        from_diffusion(&self.orientation, &body, "AttitudeEkf::attitude_bingham")
    }

    /// The attitude marginal as an isotropic heat kernel on SO(3), moment matched to
    /// [`attitude_bingham`](Self::attitude_bingham) (`E[R]` equal in trace).
    ///
    /// # Errors
    /// As [`attitude_bingham`](Self::attitude_bingham).
    pub fn attitude_heat_kernel(&self) -> Result<HeatKernelSo3, DataError> {
        self.attitude_bingham()?
            .to_heat_kernel_moment_matched()
            .map_err(|e| {
                bad(
                    "AttitudeEkf::attitude_heat_kernel",
                    "Bingham",
                    e.to_string(),
                    "a Bingham within the heat kernel's range",
                )
            })
    }

    /// Processes one sample: gyroscope (rad/s), accelerometer (m/s²) and, in 9D, the
    /// magnetometer (any unit; `None` when a sample has none, or repeats the last reading when the
    /// magnetometer is slower than the gyroscope). The first sample initialises the tilt, the first
    /// usable magnetometer reading the heading.
    ///
    /// # Errors
    /// [`DataError::BadValue`] for a non-finite reading, a zero first accelerometer reading, or a
    /// step whose result is not a valid density (the state is then left as before the call).
    pub fn process_sample(
        &mut self,
        gyro: &Vector3<f64>,
        acc: &Vector3<f64>,
        mag: Option<&Vector3<f64>>,
    ) -> Result<(), DataError> {
        let mag = mag.filter(|_| self.sensors == Sensors::NineD);
        let row = self.count;
        self.transaction(|f| {
            f.imu_step(gyro, acc)?;
            if let Some(m) = mag {
                f.magnetometer_step(m)?;
            }
            Ok(())
        })
        .map_err(|e| {
            let variable = match &e {
                OperatorError::NonFinite { what, .. } | OperatorError::OutOfRange { what, .. } => {
                    *what
                }
                _ => "filter step",
            };
            DataError::BadValue {
                origin: "AttitudeEkf::process_sample".to_owned(),
                variable: variable.to_owned(),
                row,
                value: e.to_string(),
                expected: "finite readings, a non-zero first accelerometer reading, and steps \
                           that keep a valid Gaussian (check the noise settings)",
            }
        })
    }

    /// Runs `step`; on an error the filter is restored to its state before it.
    fn transaction<T>(
        &mut self,
        step: impl FnOnce(&mut Self) -> Result<T, OperatorError>,
    ) -> Result<T, OperatorError> {
        let saved = (
            self.density.clone(),
            self.orientation,
            self.block,
            self.in_block,
            self.rest.clone(),
            self.magnet.clone(),
            self.history,
            self.blocks,
            self.count,
            self.heading_due,
        );
        let result = step(self);
        if result.is_err() {
            (
                self.density,
                self.orientation,
                self.block,
                self.in_block,
                self.rest,
                self.magnet,
                self.history,
                self.blocks,
                self.count,
                self.heading_due,
            ) = saved;
        }
        result
    }

    /// The first sample: the tilt from the accelerometer, the heading unknown (σ π) until the
    /// first magnetometer reading.
    fn initialise(&mut self, acc: &Vector3<f64>) -> Result<(), OperatorError> {
        let up = scaled_unit(acc).ok_or(OperatorError::OutOfRange {
            what: "accelerometer (the first reading's norm)",
            value: acc.norm(),
            range: "> 0",
        })?;
        let tilt = UnitQuaternion::rotation_between(&up, &Vector3::z())
            .unwrap_or_else(|| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI));
        let p = &self.params;
        let mut cov = SMatrix::<f64, STATE_DIM, STATE_DIM>::zeros();
        // Without bias estimation the bias is pinned at zero by a negligible σ (1e-9 rad/s).
        let bias_sigma = if p.estimate_bias {
            p.initial_bias_sigma
        } else {
            1e-9
        };
        let offset_sigma = p.magnetometer.offset.as_ref().map_or(1e-9, |f| f.sigma);
        let diag = [
            p.initial_tilt_sigma,
            p.initial_tilt_sigma,
            PI,
            bias_sigma,
            bias_sigma,
            bias_sigma,
            p.velocity_bound,
            p.velocity_bound,
            offset_sigma,
        ];
        for (i, s) in diag.iter().enumerate() {
            cov[(i, i)] = s * s;
        }
        let mean = AttitudeState::new(
            Left::new(So3::from_unit_quaternion(tilt)),
            Rn::new_unchecked(SVector::<f64, 6>::zeros()),
        );
        self.set_density(ManifoldGaussian::new(mean, cov)?);
        self.history = [tilt; HISTORY];
        self.rest = self.params.rest.as_ref().map(|_| RestState {
            gyro: Vector3::zeros(),
            acc: *acc,
            since: 0.0,
        });
        self.count = 1;
        Ok(())
    }

    /// The heading from the first usable magnetometer reading `m` (its horizontal part in the world
    /// frame not negligible): the orientation is turned about the vertical by the reading's heading
    /// ψ, and so are the tilt and velocity errors (world-frame vectors) and the past orientations.
    /// The heading error is then `δθ_z = j_x δθ_x + j_y δθ_y − n − c` (`(j_x, j_y, −1) = ∂ψ/∂δθ`,
    /// n the reading's own error of σ `initial_heading_sigma`, c the field offset): its variance
    /// `a P aᵀ + σ_n²` and covariances `a P` with `a = (j_x, j_y, 0, …, 0, −1)`.
    fn initialise_heading(&mut self, m: &Vector3<f64>) -> Result<(), OperatorError> {
        let Some(field) = scaled_unit(m) else {
            return Ok(());
        };
        let w = self.orientation * field;
        if w.x.hypot(w.y) <= 1e-3 {
            return Ok(());
        }
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), w.x.atan2(w.y));
        let density = self.density.as_ref().expect("initialised");
        // Every world-frame horizontal pair turns with the heading.
        let mut rotate = SMatrix::<f64, STATE_DIM, STATE_DIM>::identity();
        let r = turn.to_rotation_matrix().into_inner();
        let horizontal = r.fixed_view::<2, 2>(0, 0).into_owned();
        rotate.fixed_view_mut::<2, 2>(0, 0).copy_from(&horizontal);
        rotate.fixed_view_mut::<2, 2>(6, 6).copy_from(&horizontal);
        let mut cov = rotate * density.covariance() * rotate.transpose();
        let orientation = turn * self.orientation;
        let sigma = self.params.initial_heading_sigma;
        let model = Heading {
            field: *m,
            sigma,
            tilt_variance: 0.0,
        };
        let (_, j) = model.jacobian_full(&orientation);
        let mut a = SVector::<f64, STATE_DIM>::zeros();
        a[0] = j.x;
        a[1] = j.y;
        a[OFFSET] = -1.0;
        let row = cov * a;
        for k in 0..STATE_DIM {
            cov[(2, k)] = row[k];
            cov[(k, 2)] = row[k];
        }
        cov[(2, 2)] = a.dot(&row) + sigma * sigma;
        let mean = density.mean();
        let mut rest = *mean.second().coords();
        let v = horizontal * Vector2::new(rest[3], rest[4]);
        rest[3] = v.x;
        rest[4] = v.y;
        let start = turn * mean.first().inner().as_unit_quaternion();
        let next = ManifoldGaussian::new(
            AttitudeState::new(
                Left::new(So3::from_unit_quaternion(start)),
                Rn::new_unchecked(rest),
            ),
            cov,
        )?;
        for q in &mut self.history {
            *q = turn * *q;
        }
        let world = orientation * m;
        self.magnet = Some(MagnetState {
            reference: FieldReference {
                norm: m.norm(),
                dip: (world.z / m.norm()).clamp(-1.0, 1.0).asin(),
            },
            candidate: None,
            last: *m,
            age: 0,
            disturbed: false,
            gated: 0.0,
            learned: 0.0,
        });
        let (block, in_block) = (self.block, self.in_block);
        self.set_density(next);
        // The pending block's increments stay: the orientation is the new start times them.
        self.block = block;
        self.in_block = in_block;
        self.orientation = orientation;
        Ok(())
    }

    fn rest_detected(&self) -> bool {
        match (&self.rest, &self.params.rest) {
            (Some(s), Some(p)) => s.since >= p.min_duration,
            _ => false,
        }
    }

    /// One sample's gyroscope and accelerometer: rest detection, strapdown, and at the end of a
    /// block the covariance propagation and the velocity (and rest) updates.
    fn imu_step(&mut self, gyro: &Vector3<f64>, acc: &Vector3<f64>) -> Result<(), OperatorError> {
        check_finite("gyroscope reading", gyro)?;
        check_finite("accelerometer reading", acc)?;
        if self.density.is_none() {
            return self.initialise(acc);
        }
        let dt = self.dt;
        if let (Some(s), Some(p)) = (&mut self.rest, &self.params.rest) {
            let a = (dt / p.filter_tau).min(1.0);
            s.gyro += (gyro - s.gyro) * a;
            s.acc += (acc - s.acc) * a;
            let still =
                (gyro - s.gyro).norm() < p.gyro_threshold && (acc - s.acc).norm() < p.acc_threshold;
            s.since = if still { s.since + dt } else { 0.0 };
        }
        self.block.push(gyro, acc, dt);
        self.in_block += 1;
        let mean = self.density.as_ref().map(|d| *d.mean().first().inner());
        if let Some(start) = mean {
            self.orientation = start.as_unit_quaternion() * self.block.rotation;
        }
        self.history[self.count % HISTORY] = self.orientation;
        self.count += 1;
        if let Some(state) = &mut self.magnet {
            state.age += 1;
        }
        if self.in_block >= self.block_samples {
            self.flush()?;
            self.blocks += 1;
            if self.blocks % self.velocity_every == 0 {
                self.velocity_updates()?;
            }
            if self.blocks % self.mag_every == 0 {
                self.heading_due = true;
            }
        }
        Ok(())
    }

    /// The magnetometer reading of the sample [`imu_step`](Self::imu_step) just processed (9D): the
    /// first usable one initialises the heading; a reading equal to the last is a repeat (its age
    /// grows); a heading update that fell due since the last reading is made with it (after
    /// propagating the covariance over the samples of the block so far). Returns the update's log
    /// evidence and NIS when one was applied.
    fn magnetometer_step(&mut self, m: &Vector3<f64>) -> Result<Option<(f64, f64)>, OperatorError> {
        check_finite("magnetometer reading", m)?;
        if self.density.is_none() {
            return Ok(None);
        }
        let Some(state) = &mut self.magnet else {
            self.initialise_heading(m)?;
            return Ok(None);
        };
        if *m != state.last {
            state.last = *m;
            state.age = 0;
        }
        if !self.heading_due {
            return Ok(None);
        }
        self.heading_due = false;
        if self.in_block > 0 {
            // The update conditions the state now: the samples since the block's start first.
            self.flush()?;
        }
        self.heading_update()
    }

    /// Propagates the covariance over the pending block.
    fn flush(&mut self) -> Result<(), OperatorError> {
        let density = self.density.as_ref().expect("initialised");
        let next = match self.params.propagation {
            Propagation::Ekf => density.propagate(&Ekf(&self.process), &self.block)?,
            Propagation::Ukf => density.propagate(&Ukf::new(&self.process), &self.block)?,
        };
        self.set_density(next);
        Ok(())
    }

    fn set_density(&mut self, density: ManifoldGaussian<AttitudeState, STATE_DIM>) {
        let mean = density.mean();
        self.orientation = *mean.first().inner().as_unit_quaternion();
        let bias = if self.params.estimate_bias {
            mean.second().coords().fixed_rows::<3>(0).into_owned()
        } else {
            Vector3::zeros()
        };
        self.block = Block::empty(bias);
        self.in_block = 0;
        self.density = Some(density);
    }

    fn condition<const M: usize>(
        &mut self,
        model: impl MeasurementModel<AttitudeState, STATE_DIM, M>,
        z: &SVector<f64, M>,
        gate: f64,
    ) -> Result<Option<(f64, f64)>, OperatorError> {
        let density = self.density.as_ref().expect("initialised");
        let out = density.condition(&Ekf(model), z)?;
        let nis = out.report.nis();
        if nis > gate {
            return Ok(None);
        }
        self.set_density(out.posterior);
        Ok(Some((out.log_evidence, nis)))
    }

    /// A new reference field has its own, unknown, heading offset: c becomes an independent
    /// `N(0, σ_c²)`.
    fn renew_offset(&mut self) -> Result<(), OperatorError> {
        let (Some(f), Some(density)) = (&self.params.magnetometer.offset, &self.density) else {
            return Ok(());
        };
        let mut cov = *density.covariance();
        for i in 0..STATE_DIM {
            cov[(i, OFFSET)] = 0.0;
            cov[(OFFSET, i)] = 0.0;
        }
        cov[(OFFSET, OFFSET)] = f.sigma * f.sigma;
        let mean = density.mean();
        let mut rest = *mean.second().coords();
        rest[5] = 0.0;
        let next = ManifoldGaussian::new(
            AttitudeState::new(*mean.first(), Rn::new_unchecked(rest)),
            cov,
        )?;
        self.set_density(next);
        Ok(())
    }

    fn velocity_updates(&mut self) -> Result<(), OperatorError> {
        let at_rest = self.rest_detected();
        let (sigma, rest_gyro) = match (&self.params.rest, &self.rest) {
            (Some(p), Some(s)) if at_rest => (p.velocity_sigma, Some((s.gyro, p.bias_sigma))),
            _ => (self.params.velocity_bound, None),
        };
        self.condition(
            StateSlice::<2> { offset: 6, sigma },
            &Vector2::zeros(),
            f64::INFINITY,
        )?;
        if let (Some((gyro, bias_sigma)), true) = (rest_gyro, self.params.estimate_bias) {
            self.condition(
                StateSlice::<3> {
                    offset: 3,
                    sigma: bias_sigma,
                },
                &gyro,
                f64::INFINITY,
            )?;
        }
        Ok(())
    }

    /// The heading update with the last reading, if it is recent enough for the orientation
    /// history; its log evidence and NIS when applied.
    fn heading_update(&mut self) -> Result<Option<(f64, f64)>, OperatorError> {
        let Some(state) = self.magnet.clone() else {
            return Ok(None);
        };
        let delay = self.mag_delay + state.age;
        if delay >= HISTORY {
            return Ok(None);
        }
        // The reading in the current IMU frame: R̂_nowᵀ R̂_then m (the current sample is
        // `count − 1`).
        let then = self.history[(self.count - 1 + HISTORY - delay) % HISTORY];
        let field = self.orientation.inverse() * (then * state.last);
        let norm = field.norm();
        if norm <= 0.0 {
            return Ok(None);
        }
        let world = self.orientation * field;
        let observed = FieldReference {
            norm,
            dip: (world.z / norm).clamp(-1.0, 1.0).asin(),
        };
        let interval = (self.mag_every * self.block_samples) as f64 * self.dt;
        let mut state = state;
        let mut gate = f64::INFINITY;
        if let Some(d) = self.params.magnetometer.disturbance {
            let consistent = |r: &FieldReference| {
                (observed.norm - r.norm).abs() <= d.norm_threshold * r.norm
                    && (observed.dip - r.dip).abs() <= d.dip_threshold
            };
            if state.learned < d.first_field_time {
                // The first reference: the running mean of the samples so far.
                state.learned += interval;
                let a = interval / state.learned;
                state.reference.norm += (observed.norm - state.reference.norm) * a;
                state.reference.dip += (observed.dip - state.reference.dip) * a;
                state.candidate = None;
            } else if consistent(&state.reference) {
                state.candidate = None;
            } else {
                // A lasting, self-consistent disturbance becomes the new reference.
                state.candidate = match state.candidate {
                    Some((c, held)) if consistent(&c) => Some((c, held + interval)),
                    _ => Some((observed, 0.0)),
                };
                match state.candidate {
                    Some((c, held)) if held >= d.new_field_time => {
                        state.reference = c;
                        state.candidate = None;
                        self.renew_offset()?;
                    }
                    _ => {
                        state.disturbed = true;
                        self.magnet = Some(state);
                        return Ok(None);
                    }
                }
            }
            if state.gated < d.gate_time {
                gate = d.nis_gate;
            }
        }
        let p_tilt = self.attitude_covariance();
        let model = Heading {
            field,
            sigma: self.params.magnetometer.heading_sigma,
            tilt_variance: 0.0,
        };
        let (_, h) = model.jacobian_full(&self.orientation);
        let tilt_variance = h[0] * h[0] * p_tilt[(0, 0)]
            + 2.0 * h[0] * h[1] * p_tilt[(0, 1)]
            + h[1] * h[1] * p_tilt[(1, 1)];
        let model = Heading {
            tilt_variance: tilt_variance.max(0.0),
            ..model
        };
        let applied = self.condition(model, &SVector::<f64, 1>::zeros(), gate)?;
        let accepted = applied.is_some();
        state.disturbed = !accepted;
        state.gated = if accepted {
            0.0
        } else {
            state.gated + interval
        };
        if accepted {
            if let Some(d) = &self.params.magnetometer.disturbance {
                let a = (interval / d.reference_tau).min(1.0);
                state.reference.norm += (observed.norm - state.reference.norm) * a;
                state.reference.dip += (observed.dip - state.reference.dip) * a;
            }
        }
        self.magnet = Some(state);
        Ok(applied)
    }
}

/// `Ok` when every component of `v` is finite, else [`OperatorError::NonFinite`] naming `what`.
fn check_finite(what: &'static str, v: &Vector3<f64>) -> Result<(), OperatorError> {
    match v.iter().find(|x| !x.is_finite()) {
        Some(&value) => Err(OperatorError::NonFinite { what, value }),
        None => Ok(()),
    }
}

/// The production filter as the experiment layer drives it: [`predict`](RecursiveFilter::predict)
/// with one sample's gyroscope and accelerometer, [`update`](RecursiveFilter::update) with that
/// sample's magnetometer reading (ignored in 6D); both all or nothing, as
/// [`AttitudeEkf::process_sample`]. An update reports the log evidence and NIS (χ²(1)) of the heading
/// update it made, NaN and none when it made none (no update due, or the reading rejected).
impl RecursiveFilter for AttitudeEkf {
    type Input = ImuSample;
    type Measurement = Vector3<f64>;
    type Estimate = AttitudeEstimate;

    fn predict(&mut self, input: &ImuSample) -> Result<(), OperatorError> {
        self.transaction(|f| f.imu_step(&input.gyro, &input.acc))
    }

    fn update(&mut self, z: &Vector3<f64>) -> Result<Update, OperatorError> {
        let applied = if self.sensors == Sensors::NineD {
            self.transaction(|f| f.magnetometer_step(z))?
        } else {
            None
        };
        Ok(applied.map_or(
            Update {
                log_evidence: f64::NAN,
                nis: None,
            },
            |(log_evidence, value)| Update {
                log_evidence,
                nis: Some(Nis { value, dof: 1 }),
            },
        ))
    }

    fn estimate(&self) -> Result<AttitudeEstimate, OperatorError> {
        if self.density.is_none() {
            return Err(OperatorError::OutOfRange {
                what: "attitude filter samples processed",
                value: 0.0,
                range: "at least 1 before an estimate",
            });
        }
        Ok(AttitudeEstimate {
            orientation: self.orientation,
            covariance: self.attitude_covariance(),
        })
    }
}

/// The number of samples in `seconds` at `rate` (both checked finite and positive), rounded, at
/// most 2³⁰.
#[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
fn samples_in(seconds: f64, rate: f64) -> usize {
    // In [0, 2³⁰] before the cast: exact.
    (seconds * rate).round().clamp(0.0, f64::from(1u32 << 30)) as usize
}

/// The production filter run over a log, causally from the first sample; each estimate is the
/// orientation after that sample's update, with the heading and tilt σ of the covariance at that
/// time.
///
/// # Errors
/// As [`AttitudeEkf::new`] and [`AttitudeEkf::process_sample`] (with the sample's row);
/// [`DataError::NothingToScore`] for an empty log.
pub fn run_attitude_ekf(
    log: &ImuLog,
    params: &AttitudeParams,
    sensors: Sensors,
) -> Result<AttitudeTrack, DataError> {
    if log.is_empty() {
        return Err(DataError::NothingToScore {
            origin: "run_attitude_ekf".to_owned(),
            message: "the log is empty".to_owned(),
        });
    }
    let mut filter = AttitudeEkf::new(params.clone(), sensors, log.rate())?;
    let n = log.len();
    let (mut orientations, mut heading, mut tilt) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let mag = log.magnetometer();
    for (row, (g, a)) in log.gyroscope().iter().zip(log.accelerometer()).enumerate() {
        filter
            .process_sample(g, a, mag.map(|m| &m[row]))
            .map_err(|e| with_row(e, row))?;
        orientations.push(filter.orientation());
        let (h, t) = AttitudeTrack::sigmas_of_world_covariance(&filter.attitude_covariance());
        heading.push(h);
        tilt.push(t);
    }
    Ok(AttitudeTrack {
        orientations,
        heading_sigma: Some(heading),
        tilt_sigma: Some(tilt),
    })
}

fn with_row(e: DataError, sample: usize) -> DataError {
    match e {
        DataError::BadValue {
            origin,
            variable,
            value,
            expected,
            ..
        } => DataError::BadValue {
            origin,
            variable,
            row: sample,
            value,
            expected,
        },
        other => other,
    }
}
