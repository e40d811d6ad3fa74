//! The production attitude filter: an error-state EKF on attitude × gyro bias × horizontal
//! velocity × the local magnetic field's heading offset × horizontal position, composed from the
//! library's parts ([`ManifoldGaussian`] on a
//! [`ProductManifold`](liebayes_manifolds::ProductManifold) of [`Left`]`<So3>` (world-frame
//! attitude error) and `Rn<8>`, propagated and conditioned by the
//! [`Ekf`] operators), with what real IMU data needs (the math and the measured figures are in the
//! attitude page of the project's documentation, `docs/filters/attitude.md`):
//!
//! * **strapdown** per sample, `R ← R exp([ω − b̂]ₓ Δt)`, and the covariance propagated once per
//!   block of samples from the block's preintegrated increments ([`BlockProcess`]);
//! * **bounded velocity**: the horizontal velocity `v` integrates `(R f)_xy` (the accelerometer in
//!   the world frame; gravity is vertical) and a pseudo-measurement `v = 0 ± σ_v` at a fixed
//!   interval says that a hand-held sensor does not run away; the velocity's error grows as
//!   `g × δθ`, so this observes the tilt without ever reading a single accelerometer sample as the
//!   gravity direction (linear accelerations average out instead of tilting the estimate);
//! * **bounded position**: the horizontal position integrates the velocity, and the
//!   pseudo-measurement `p = 0 ± σ_p` made with the velocity's says that a hand-held sensor stays
//!   within reach of where it started: a tilt error makes it drift as `½ g δθ t²`, a back-and-forth
//!   motion does not;
//! * **rest detection**: gyroscope and accelerometer within thresholds of their low-passed values
//!   for a minimum time; at rest, the low-passed gyroscope measures the bias and the velocity is
//!   zero to a tight σ;
//! * **heading-only magnetometer**: the heading of the field rotated into the world frame, a scalar
//!   measurement whose Jacobian has only the vertical component (the magnetometer never tilts the
//!   estimate; the tilt's share of the heading error is added to the measurement variance), taken
//!   from the latest magnetometer reading and the orientation at the time it was measured (a fixed
//!   delay), with disturbance rejection by field norm, dip and the innovation's NIS, and adoption of
//!   a new reference field when a disturbance lasts;
//! * **correlated magnetometer errors**: the heading of the local field differs from true north by
//!   an offset `c` that changes over tens of seconds, a first-order Gauss-Markov state the
//!   magnetometer measures together with the heading, so that averaging many magnetometer samples
//!   never makes the heading more certain than the field it points along;
//! * **initialisation** from the first sample (tilt from the accelerometer), and in 9D the heading
//!   from the first usable magnetometer reading (6D: the heading starts at zero).

mod magnetometer;
mod model;
mod params;
mod smoothing;

use super::data::{check_reading, scaled_unit};
use super::estimate::{AttitudeEstimate, ImuSample};
use crate::attitude::data::check_rate;
use crate::error::FilterError;
use liebayes_densities::{Bingham, HeatKernelSo3, ManifoldGaussian};
use liebayes_experiments::Smoothing;
use liebayes_experiments::{Nis, RecursiveFilter, Update};
use liebayes_manifolds::{Left, Rn, So3, Su2};
use liebayes_operators::smoother::{GaussianTransition, Prediction};
use liebayes_operators::{Condition, Ekf, MeasurementModel, OperatorError, Ukf};
use magnetometer::{FieldReference, Magnetometer, Verdict};
pub use model::{
    ATTITUDE, AttitudeState, BIAS, Block, BlockProcess, Heading, OFFSET, POSITION, STATE_DIM,
    UNIFORM_ROTATION_VARIANCE, VELOCITY,
};
use model::{RestBias, ZeroMotion, attitude_block, in_rest};
use nalgebra::{SMatrix, SVector, UnitQuaternion, Vector2, Vector3};
pub use params::{
    AttitudeParams, DisturbanceParams, FieldOffset, MEASURED_FIELD_OFFSET, MagnetometerParams,
    Propagation, RestParams, Sensors,
};
use smoothing::{Entry, Record};
pub use smoothing::{MAX_OFFLINE_EPOCHS, MAX_OFFLINE_SAMPLES};
use std::f64::consts::PI;

/// How many past orientations are kept to line the magnetometer up with the gyroscope.
const HISTORY: usize = 32;

/// The smallest horizontal fraction `|w_xy| / |w|` of a magnetometer reading w in the world frame
/// that gives a heading (its initialisation or an update): below it (a field within 0.06° of the
/// vertical: a magnet, or a reading far from the earth field) `atan2(w_x, w_y)` is an arbitrary
/// angle, and a 1e-3 horizontal fraction already turns a 1° tilt error into a heading error of
/// tens of degrees.
const MIN_HORIZONTAL_FRACTION: f64 = 1e-3;

/// The filter's settings and what follows from them and the rate: fixed once built.
#[derive(Clone, Debug)]
struct Settings {
    params: AttitudeParams,
    sensors: Sensors,
    dt: f64,
    process: BlockProcess,
    block_samples: usize,
    /// Bounded-velocity (and rest) updates every this many blocks.
    velocity_every: usize,
    /// Heading updates every this many blocks.
    mag_every: usize,
    /// The magnetometer's delay in samples.
    mag_delay: usize,
    /// Whether the steps journal what the offline smoother needs ([`AttitudeEkf::offline`]).
    record: bool,
}

/// Low-pass state of the rest detector.
#[derive(Clone, Debug, PartialEq)]
struct RestState {
    gyro: Vector3<f64>,
    acc: Vector3<f64>,
    since: f64,
}

/// The latest magnetometer reading, and how many samples ago it was taken.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Reading {
    field: Vector3<f64>,
    age: usize,
}

/// One sample's turn, computed from the state without changing it: the block's rotation with the
/// sample ([`Block::turned`]) and the orientation it gives.
#[derive(Clone, Copy, Debug)]
struct Turn {
    rotation: UnitQuaternion<f64>,
    orientation: UnitQuaternion<f64>,
}

/// The state of an initialised filter: everything a step changes, so that a step that can fail
/// part-way is undone by restoring a clone ([`AttitudeEkf::transaction`]).
#[derive(Clone, Debug)]
struct Running {
    density: ManifoldGaussian<AttitudeState, STATE_DIM>,
    /// The sample the density is of (the last block's end, or the last update).
    at: usize,
    /// The current orientation (strapdown between blocks).
    orientation: UnitQuaternion<f64>,
    /// The last sample's bias-corrected rate `ω − b̂`, which carries the reported orientation
    /// over the IMU's delay.
    rate: Vector3<f64>,
    block: Block,
    in_block: usize,
    /// Samples processed.
    count: usize,
    /// Blocks propagated.
    blocks: usize,
    history: [UnitQuaternion<f64>; HISTORY],
    rest: Option<RestState>,
    /// `None` until the heading is initialised (9D).
    magnet: Option<Magnetometer>,
    reading: Option<Reading>,
    /// A heading update fell due at a block's end and waits for the next magnetometer reading.
    heading_due: bool,
    /// The offline filter's record of the step so far (empty otherwise, and between steps).
    journal: Vec<Entry>,
}

/// The production attitude filter, stepped through [`RecursiveFilter`]: `predict` with each
/// sample's gyroscope and accelerometer, `update` with each fresh magnetometer reading. Its
/// settings are fixed when it is built; its state starts at the first sample
/// ([`is_initialised`](Self::is_initialised)). Every step is all or nothing.
///
/// # Example
/// A sensor lying still, level, facing North: the filter keeps the identity.
/// ```
/// use liebayes_experiments::RecursiveFilter;
/// use liebayes_filters::attitude::{AttitudeEkf, AttitudeParams, ImuSample, Sensors};
/// use nalgebra::Vector3;
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let mut filter = AttitudeEkf::new(AttitudeParams::default(), Sensors::NineD, 100.0)?;
/// let sample = ImuSample { gyro: Vector3::zeros(), acc: Vector3::new(0.0, 0.0, 9.81) };
/// let field = Vector3::new(0.0, 20.0, -40.0); // µT: North and down.
/// for _ in 0..500 {
///     filter.predict(&sample)?;
///     filter.update(&field)?;
/// }
/// let estimate = filter.estimate()?;
/// assert!(estimate.orientation.angle() < 1e-6);
/// let heading_sigma = estimate.covariance.expect("the EKF reports one")[(2, 2)].sqrt();
/// assert!(heading_sigma > 0.0 && heading_sigma < 0.3);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct AttitudeEkf {
    settings: Settings,
    state: Option<Running>,
    /// The offline filter's record of the run ([`offline`](Self::offline)).
    record: Option<Record>,
}

impl AttitudeEkf {
    /// A filter for samples at `rate` (Hz), not yet initialised (the first `predict` initialises
    /// it).
    ///
    /// # Errors
    /// As [`AttitudeParams::validate`]; [`FilterError::Setting`] for a rate that is not finite and
    /// positive.
    pub fn new(params: AttitudeParams, sensors: Sensors, rate: f64) -> Result<Self, FilterError> {
        params.validate()?;
        check_rate("AttitudeEkf::new", rate)?;
        let samples = |seconds: f64| samples_in(seconds, rate).max(1);
        let block_samples = samples(params.block);
        let in_blocks = |seconds: f64| samples(seconds).div_ceil(block_samples).max(1);
        let settings = Settings {
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
            mag_delay: samples_in(params.magnetometer.delay, rate).min(HISTORY - 1),
            dt: 1.0 / rate,
            sensors,
            params,
            record: false,
        };
        Ok(Self {
            settings,
            state: None,
            record: None,
        })
    }

    /// The offline filter: the same filter, which also records its forward pass so that at the
    /// end of a run it releases every sample's smoothed estimate, given every sample of the run
    /// (the [`Smoothing`] of the experiment layer; the forward pass's estimates are the causal
    /// filter's, bit for bit). The record grows by about 6 kB per epoch (a block, 0.08 s by
    /// default, 0.04 s with [`AttitudeParams::offline`]) and 24 bytes per sample: about 80 to
    /// 160 kB per second of data. It holds at most [`MAX_OFFLINE_SAMPLES`] samples and
    /// [`MAX_OFFLINE_EPOCHS`] epochs: a step beyond is `TooLarge`, the filter unchanged.
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn offline(
        params: AttitudeParams,
        sensors: Sensors,
        rate: f64,
    ) -> Result<Self, FilterError> {
        let mut filter = Self::new(params, sensors, rate)?;
        filter.settings.record = true;
        filter.record = Some(Record::default());
        Ok(filter)
    }

    /// Whether this is the offline filter ([`offline`](Self::offline)).
    pub fn is_offline(&self) -> bool {
        self.record.is_some()
    }

    /// The settings.
    pub fn params(&self) -> &AttitudeParams {
        &self.settings.params
    }

    /// The sensors used.
    pub fn sensors(&self) -> Sensors {
        self.settings.sensors
    }

    /// Whether the filter has processed its first sample.
    pub fn is_initialised(&self) -> bool {
        self.state.is_some()
    }

    /// The Gaussian of the last covariance propagation or update (`None` before the first
    /// sample): mean and world-frame covariance of the state ([`AttitudeState`]).
    pub fn density(&self) -> Option<&ManifoldGaussian<AttitudeState, STATE_DIM>> {
        self.state.as_ref().map(|s| &s.density)
    }

    /// The estimated gyro bias (rad/s), `None` before the first sample.
    pub fn bias(&self) -> Option<Vector3<f64>> {
        self.state.as_ref().map(|s| s.block.bias)
    }

    /// Whether the last sample was detected as rest.
    pub fn at_rest(&self) -> bool {
        self.state
            .as_ref()
            .is_some_and(|s| s.rest_detected(&self.settings))
    }

    /// Whether the magnetometer's last heading update was refused as disturbed (9D).
    pub fn magnetic_disturbance(&self) -> bool {
        self.state
            .as_ref()
            .and_then(|s| s.magnet.as_ref())
            .is_some_and(|m| m.disturbed)
    }

    /// The attitude marginal as a Bingham density on the unit quaternion about the estimate's
    /// orientation `R̂` (carried over the IMU's delay), with the second moments of the attitude
    /// covariance the estimate reports (the body-frame covariance `R̂ᵀ P_θθ R̂` of a
    /// left-translated diffusion about `R̂`, P_θθ as [`AttitudeParams::tilt_variance_scale`]
    /// calibrates it), as the talk's filter represents its state.
    ///
    /// # Errors
    /// [`OperatorError::NotReady`] before the first sample; [`FilterError::Density`] outside the
    /// Bingham's range (a variance below about 2e-6 rad²).
    pub fn attitude_bingham(&self) -> Result<Bingham, FilterError> {
        let s = self.running()?;
        let orientation = s.reported_orientation(&self.settings);
        let r = orientation.to_rotation_matrix().into_inner();
        let body = r.transpose()
            * self
                .settings
                .params
                .reported(&attitude_block(s.density.covariance()))
            * r;
        Ok(Bingham::from_diffusion_moment_matched(
            &Su2::from_unit_quaternion(orientation),
            &body,
        )?)
    }

    /// The attitude marginal as an isotropic heat kernel on SO(3), moment matched to
    /// [`attitude_bingham`](Self::attitude_bingham) (`E[R]` equal in trace).
    ///
    /// # Errors
    /// As [`attitude_bingham`](Self::attitude_bingham).
    pub fn attitude_heat_kernel(&self) -> Result<HeatKernelSo3, FilterError> {
        Ok(self.attitude_bingham()?.to_heat_kernel_moment_matched()?)
    }

    fn running(&self) -> Result<&Running, OperatorError> {
        self.state.as_ref().ok_or(NOT_READY)
    }

    /// After a successful step of the offline filter: the record keeps the sample's gyroscope
    /// (`None` for an update) and the step's journal (room reserved before the step).
    fn keep(&mut self, gyro: Option<&Vector3<f64>>) {
        if let (Some(record), Some(state)) = (&mut self.record, &mut self.state) {
            record.keep(gyro, &mut state.journal);
        }
    }

    /// Runs `step` on the state; on an error the state is restored to its value before it. The
    /// clone this costs (the density with its Cholesky factor and the orientation history, over
    /// 2 kB) is paid only by the steps that can fail part-way, a block's end and a magnetometer
    /// reading that initialises the heading or makes a heading update: per sample, the strapdown
    /// and the reading's bookkeeping cannot fail once the sample is checked, and go without it.
    fn transaction<T>(
        &mut self,
        step: impl FnOnce(&Settings, &mut Running) -> Result<T, OperatorError>,
    ) -> Result<T, OperatorError> {
        let Some(state) = &mut self.state else {
            return Err(NOT_READY);
        };
        let saved = state.clone();
        let result = step(&self.settings, state);
        if result.is_err() {
            *state = saved;
        }
        result
    }
}

/// What a filter without a sample reports.
const NOT_READY: OperatorError = OperatorError::NotReady {
    what: "attitude filter",
    needs: "a first sample (predict) to initialise its tilt",
};

impl Running {
    /// The orientation an estimate reports: the strapdown's, carried over the IMU's delay d to the
    /// last sample's time stamp, `R̂ exp([ω − b̂]ₓ d)` ([`AttitudeParams::imu_delay`]).
    fn reported_orientation(&self, settings: &Settings) -> UnitQuaternion<f64> {
        self.orientation * super::rotation(&(self.rate * settings.params.imu_delay))
    }

    /// The first sample: the tilt from the accelerometer, the heading unknown (σ π) until the
    /// first magnetometer reading (9D) or zero (6D).
    fn initialise(settings: &Settings, sample: &ImuSample) -> Result<Self, OperatorError> {
        let acc = &sample.acc;
        let up = scaled_unit(acc).ok_or(OperatorError::OutOfRange {
            what: "accelerometer (the first reading's norm)",
            value: acc.norm(),
            range: "> 0",
        })?;
        let tilt = UnitQuaternion::rotation_between(&up, &Vector3::z())
            .unwrap_or_else(|| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI));
        let p = &settings.params;
        // Without bias estimation the bias is pinned at zero by a negligible σ (1e-9 rad/s).
        let bias_sigma = if p.estimate_bias {
            p.initial_bias_sigma
        } else {
            1e-9
        };
        let mut sigma = SVector::<f64, STATE_DIM>::zeros();
        sigma[ATTITUDE.start] = p.initial_tilt_sigma;
        sigma[ATTITUDE.start + 1] = p.initial_tilt_sigma;
        sigma[ATTITUDE.start + 2] = PI;
        for i in BIAS {
            sigma[i] = bias_sigma;
        }
        for i in VELOCITY {
            sigma[i] = p.velocity_bound;
        }
        for i in POSITION {
            sigma[i] = p.position_bound;
        }
        sigma[OFFSET] = p.magnetometer.offset.as_ref().map_or(1e-9, |f| f.sigma);
        let mean = AttitudeState::new(
            Left::new(So3::from_unit_quaternion(tilt)),
            Rn::new_unchecked(SVector::<f64, 8>::zeros()),
        );
        let density =
            ManifoldGaussian::new(mean, SMatrix::from_diagonal(&sigma.component_mul(&sigma)))?;
        let mut state = Self {
            orientation: tilt,
            rate: sample.gyro,
            block: Block::empty(Vector3::zeros()),
            in_block: 0,
            count: 1,
            blocks: 0,
            history: [tilt; HISTORY],
            rest: p.rest.as_ref().map(|_| RestState {
                gyro: Vector3::zeros(),
                acc: *acc,
                since: 0.0,
            }),
            magnet: None,
            reading: None,
            heading_due: false,
            journal: Vec::new(),
            at: 0,
            density: density.clone(),
        };
        state.set_density(settings, density);
        Ok(state)
    }

    /// The heading from the first usable magnetometer reading `m` (its horizontal part in the world
    /// frame not negligible): the orientation is turned about the vertical by the reading's heading
    /// ψ, and so are the tilt and velocity errors (world-frame vectors) and the past orientations.
    /// The heading error is then `δθ_z = j_x δθ_x + j_y δθ_y − n − c` (`(j_x, j_y, −1) = ∂ψ/∂δθ`,
    /// n the reading's own error of σ `initial_heading_sigma`, c the field offset): its variance
    /// `a P aᵀ + σ_n²` and covariances `a P` with `a = (j_x, j_y, 0, …, 0, −1)`.
    fn initialise_heading(
        &mut self,
        settings: &Settings,
        m: &Vector3<f64>,
    ) -> Result<(), OperatorError> {
        let Some(field) = scaled_unit(m) else {
            return Ok(());
        };
        let w = self.orientation * field;
        if w.x.hypot(w.y) <= MIN_HORIZONTAL_FRACTION {
            return Ok(());
        }
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), w.x.atan2(w.y));
        // Every world-frame horizontal pair turns with the heading.
        let mut rotate = SMatrix::<f64, STATE_DIM, STATE_DIM>::identity();
        let r = turn.to_rotation_matrix().into_inner();
        let horizontal = r.fixed_view::<2, 2>(0, 0).into_owned();
        rotate
            .fixed_view_mut::<2, 2>(ATTITUDE.start, ATTITUDE.start)
            .copy_from(&horizontal);
        rotate
            .fixed_view_mut::<2, 2>(VELOCITY.start, VELOCITY.start)
            .copy_from(&horizontal);
        rotate
            .fixed_view_mut::<2, 2>(POSITION.start, POSITION.start)
            .copy_from(&horizontal);
        let mut cov = rotate * self.density.covariance() * rotate.transpose();
        let orientation = turn * self.orientation;
        let sigma = settings.params.initial_heading_sigma;
        // The unit reading: the heading and its Jacobian are scale-free, and a reading whose
        // squares underflow made the Jacobian vanish.
        let model = Heading {
            field,
            sigma,
            tilt_variance: 0.0,
        };
        let (_, j) = model.jacobian_full(&orientation);
        let mut a = SVector::<f64, STATE_DIM>::zeros();
        a[ATTITUDE.start] = j.x;
        a[ATTITUDE.start + 1] = j.y;
        a[OFFSET] = -1.0;
        let row = cov * a;
        let heading = ATTITUDE.start + 2;
        for k in 0..STATE_DIM {
            cov[(heading, k)] = row[k];
            cov[(k, heading)] = row[k];
        }
        cov[(heading, heading)] = a.dot(&row) + sigma * sigma;
        let mean = self.density.mean();
        let mut rest = *mean.second().coords();
        for pair in [VELOCITY.start, POSITION.start] {
            let i = in_rest(pair);
            let v = horizontal * Vector2::new(rest[i], rest[i + 1]);
            rest[i] = v.x;
            rest[i + 1] = v.y;
        }
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
        let reference =
            FieldReference::of(&(orientation * m)).ok_or(OperatorError::OutOfRange {
                what: "magnetometer reading (its norm)",
                value: m.norm(),
                range: "> 0",
            })?;
        self.magnet = Some(Magnetometer::new(reference));
        let (block, in_block, at) = (self.block, self.in_block, self.at);
        self.set_density(settings, next);
        // The pending block's increments stay: the orientation is the new start times them.
        self.block = block;
        self.in_block = in_block;
        self.at = at;
        self.orientation = orientation;
        if settings.record {
            self.journal.push(Entry::Restart);
        }
        Ok(())
    }

    fn rest_detected(&self, settings: &Settings) -> bool {
        match (&self.rest, &settings.params.rest) {
            (Some(s), Some(p)) => s.since >= p.min_duration,
            _ => false,
        }
    }

    /// The strapdown's [`Turn`] with a sample's gyroscope: the one part of a sample between blocks
    /// that can come out non-finite, computed (and checked) before anything changes.
    fn turn(&self, settings: &Settings, gyro: &Vector3<f64>) -> Turn {
        let rotation = self.block.turned(gyro, settings.dt);
        Turn {
            rotation,
            orientation: self.density.mean().first().inner().as_unit_quaternion() * rotation,
        }
    }

    /// One sample's gyroscope and accelerometer between blocks, with its [`Turn`]: the rest
    /// detector's low-pass, the sample joins the block and its orientation the history, and the
    /// last magnetometer reading ages by a sample. Cannot fail.
    fn strapdown(&mut self, settings: &Settings, sample: &ImuSample, turn: Turn) {
        let (gyro, acc, dt) = (&sample.gyro, &sample.acc, settings.dt);
        if let (Some(s), Some(p)) = (&mut self.rest, &settings.params.rest) {
            let a = (dt / p.filter_tau).min(1.0);
            s.gyro += (gyro - s.gyro) * a;
            s.acc += (acc - s.acc) * a;
            let still =
                (gyro - s.gyro).norm() < p.gyro_threshold && (acc - s.acc).norm() < p.acc_threshold;
            s.since = if still { s.since + dt } else { 0.0 };
        }
        self.rate = gyro - self.block.bias;
        self.block.push(turn.rotation, acc, dt);
        self.in_block += 1;
        self.orientation = turn.orientation;
        self.history[self.count % HISTORY] = self.orientation;
        self.count += 1;
        if let Some(reading) = &mut self.reading {
            reading.age += 1;
        }
    }

    /// Whether the next sample ends the block.
    fn block_ends(&self, settings: &Settings) -> bool {
        self.in_block + 1 >= settings.block_samples
    }

    /// The end of a block: the covariance propagation, the velocity (and rest) updates, and a
    /// heading update falling due.
    fn end_block(&mut self, settings: &Settings) -> Result<(), OperatorError> {
        self.flush(settings)?;
        self.blocks += 1;
        if self.blocks % settings.velocity_every == 0 {
            self.velocity_updates(settings)?;
        }
        if self.blocks % settings.mag_every == 0 {
            self.heading_due = true;
        }
        Ok(())
    }

    /// A magnetometer reading's bookkeeping. A magnetometer slower than the gyroscope repeats its
    /// last reading (sample and hold): a reading bit-identical to the last keeps its age, so that
    /// it is lined up with the orientation of the sample it was taken at.
    fn note_reading(&mut self, m: &Vector3<f64>) {
        match &mut self.reading {
            Some(r) if r.field == *m => {}
            _ => self.reading = Some(Reading { field: *m, age: 0 }),
        }
    }

    /// Whether a magnetometer reading now is only noted ([`note_reading`](Self::note_reading)):
    /// the heading is initialised and no heading update is due. Such a step cannot fail.
    fn only_notes_reading(&self) -> bool {
        self.magnet.is_some() && !self.heading_due
    }

    /// The magnetometer reading of the sample just processed (9D): the first usable one
    /// initialises the heading; a heading update that fell due since the last reading is made with
    /// it (after propagating the covariance over the samples of the block so far). Returns the
    /// update's log evidence and NIS when one was applied.
    fn magnetometer_step(
        &mut self,
        settings: &Settings,
        m: &Vector3<f64>,
    ) -> Result<Option<(f64, f64)>, OperatorError> {
        self.note_reading(m);
        if self.magnet.is_none() {
            self.initialise_heading(settings, m)?;
            return Ok(None);
        }
        if !self.heading_due {
            return Ok(None);
        }
        self.heading_due = false;
        if self.in_block > 0 {
            // The update conditions the state now: the samples since the block's start first.
            self.flush(settings)?;
        }
        self.heading_update(settings)
    }

    /// Propagates the covariance over the pending block.
    fn flush(&mut self, settings: &Settings) -> Result<(), OperatorError> {
        let process = &settings.process;
        let prediction = match settings.params.propagation {
            Propagation::Ekf => Ekf(process).predict_with_cross(&self.density, &self.block)?,
            Propagation::Ukf => Ukf::new(process).predict_with_cross(&self.density, &self.block)?,
        };
        let next = if settings.record {
            let next = prediction.density.clone();
            self.journal_transition(prediction);
            next
        } else {
            prediction.density
        };
        self.set_density(settings, next);
        Ok(())
    }

    /// Journals a transition from the current density (the offline filter).
    fn journal_transition(&mut self, prediction: Prediction<AttitudeState, STATE_DIM>) {
        self.journal.push(Entry::Transition {
            before: self.density.clone(),
            at: self.at,
            prediction,
        });
    }

    fn set_density(
        &mut self,
        settings: &Settings,
        density: ManifoldGaussian<AttitudeState, STATE_DIM>,
    ) {
        let mean = density.mean();
        self.orientation = *mean.first().inner().as_unit_quaternion();
        let bias = if settings.params.estimate_bias {
            mean.second()
                .coords()
                .fixed_rows::<3>(in_rest(BIAS.start))
                .into_owned()
        } else {
            Vector3::zeros()
        };
        self.block = Block::empty(bias);
        self.in_block = 0;
        self.at = self.count - 1;
        self.density = density;
    }

    /// Conditions on `z` unless the update's NIS exceeds `gate`; the log evidence and NIS when
    /// applied.
    fn condition<const M: usize>(
        &mut self,
        settings: &Settings,
        model: impl MeasurementModel<AttitudeState, STATE_DIM, M>,
        z: &SVector<f64, M>,
        gate: f64,
    ) -> Result<Option<(f64, f64)>, OperatorError> {
        let out = self.density.condition(&Ekf(model), z)?;
        let nis = out.report.nis();
        if nis > gate {
            return Ok(None);
        }
        self.set_density(settings, out.posterior);
        Ok(Some((out.log_evidence, nis)))
    }

    /// A new reference field has its own, unknown, heading offset: c becomes an independent
    /// `N(0, σ_c²)`.
    fn renew_offset(&mut self, settings: &Settings) -> Result<(), OperatorError> {
        let Some(f) = &settings.params.magnetometer.offset else {
            return Ok(());
        };
        let mut cov = *self.density.covariance();
        for i in 0..STATE_DIM {
            cov[(i, OFFSET)] = 0.0;
            cov[(OFFSET, i)] = 0.0;
        }
        cov[(OFFSET, OFFSET)] = f.sigma * f.sigma;
        let mean = self.density.mean();
        let mut rest = *mean.second().coords();
        rest[in_rest(OFFSET)] = 0.0;
        let next = ManifoldGaussian::new(
            AttitudeState::new(*mean.first(), Rn::new_unchecked(rest)),
            cov,
        )?;
        if settings.record {
            // The transition c′ = 0·c + w: `Cov(δ, δ′) = P Fᵀ`, P with the offset's column zeroed,
            // and the noise w ~ N(0, σ_c²) on the offset alone.
            let mut cross = *self.density.covariance();
            cross.column_mut(OFFSET).fill(0.0);
            let mut noise = SMatrix::zeros();
            noise[(OFFSET, OFFSET)] = f.sigma * f.sigma;
            self.journal_transition(Prediction {
                density: next.clone(),
                cross_covariance: cross,
                noise,
            });
        }
        self.set_density(settings, next);
        Ok(())
    }

    fn velocity_updates(&mut self, settings: &Settings) -> Result<(), OperatorError> {
        let at_rest = self.rest_detected(settings);
        let (sigma, rest_gyro) = match (&settings.params.rest, &self.rest) {
            (Some(p), Some(s)) if at_rest => (p.velocity_sigma, Some((s.gyro, p.bias_sigma))),
            _ => (settings.params.velocity_bound, None),
        };
        let bounds = ZeroMotion {
            velocity_sigma: sigma,
            position_sigma: settings.params.position_bound,
        };
        self.condition(settings, bounds, &SVector::zeros(), f64::INFINITY)?;
        if let (Some((gyro, sigma)), true) = (rest_gyro, settings.params.estimate_bias) {
            self.condition(settings, RestBias { sigma }, &gyro, f64::INFINITY)?;
        }
        Ok(())
    }

    /// The heading update with the latest reading, if it is recent enough for the orientation
    /// history and has a heading (a horizontal fraction above [`MIN_HORIZONTAL_FRACTION`]); its
    /// log evidence and NIS when applied.
    fn heading_update(&mut self, settings: &Settings) -> Result<Option<(f64, f64)>, OperatorError> {
        let (Some(reading), Some(mut magnet)) = (self.reading, self.magnet.clone()) else {
            return Ok(None);
        };
        let delay = settings.mag_delay + reading.age;
        if delay >= HISTORY {
            return Ok(None);
        }
        // The reading in the current IMU frame: R̂_nowᵀ R̂_then m (the current sample is
        // `count − 1`).
        let then = self.history[(self.count - 1 + HISTORY - delay) % HISTORY];
        let field = self.orientation.inverse() * (then * reading.field);
        let Some(observed) = FieldReference::of(&(self.orientation * field)) else {
            return Ok(None);
        };
        // As the heading's initialisation: a field with (nearly) no horizontal part has no
        // heading, so a reading whose horizontal fraction `|w_xy| / |w|` (w the unit reading in
        // the world frame) is at most 1e-3 makes no update (its atan2 was an arbitrary angle,
        // applied with full weight). The model takes the unit reading: the heading and its
        // Jacobian are scale-free, and the squares of a tiny reading underflowed.
        let Some(field) = scaled_unit(&field) else {
            return Ok(None);
        };
        let world = self.orientation * field;
        if world.x.hypot(world.y) <= MIN_HORIZONTAL_FRACTION {
            return Ok(None);
        }
        let interval = (settings.mag_every * settings.block_samples) as f64 * settings.dt;
        let disturbance = settings.params.magnetometer.disturbance.as_ref();
        let gate = match magnet.judge(&observed, interval, disturbance) {
            Verdict::Reject => {
                self.magnet = Some(magnet);
                return Ok(None);
            }
            Verdict::Use { gate, renew_offset } => {
                if renew_offset {
                    self.renew_offset(settings)?;
                }
                gate
            }
        };
        let p_tilt = attitude_block(self.density.covariance());
        let model = Heading {
            field,
            sigma: settings.params.magnetometer.heading_sigma,
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
        let applied = self.condition(settings, model, &SVector::<f64, 1>::zeros(), gate)?;
        magnet.conclude(&observed, applied.is_some(), interval, disturbance);
        self.magnet = Some(magnet);
        Ok(applied)
    }
}

/// The result of a step is kept only if the state is still a valid density (every density the
/// state takes is checked when built) with a finite orientation.
fn check_orientation(orientation: &UnitQuaternion<f64>) -> Result<(), OperatorError> {
    if let Some(&value) = orientation.coords.iter().find(|c| !c.is_finite()) {
        return Err(OperatorError::NonFinite {
            what: "attitude after the step",
            value,
        });
    }
    Ok(())
}

/// The production filter as the experiment layer drives it: [`predict`](RecursiveFilter::predict)
/// with one sample's gyroscope and accelerometer (the first initialises the tilt),
/// [`update`](RecursiveFilter::update) with that sample's magnetometer reading (ignored in 6D; the
/// first usable one initialises the heading; a reading equal to the last is a repeat of a
/// magnetometer slower than the gyroscope and keeps the age of the sample it was taken at). Readings must be finite and
/// within the sensors' range ([`MAX_ANGULAR_RATE`](super::MAX_ANGULAR_RATE),
/// [`MAX_SPECIFIC_FORCE`](super::MAX_SPECIFIC_FORCE), [`MAX_FIELD`](super::MAX_FIELD)). An update
/// reports the log evidence and NIS (χ²(1)) of the heading update it made; where it made none (no
/// update due, the reading rejected as disturbed or with a horizontal fraction of at most 1e-3
/// in the world frame, or 6D) the log evidence is 0 (no measurement
/// was conditioned on) and there is no NIS. Both steps are all or nothing.
impl RecursiveFilter for AttitudeEkf {
    type Input = ImuSample;
    type Measurement = Vector3<f64>;
    type Estimate = AttitudeEstimate;

    /// Between blocks the sample's orientation is computed and checked first, and the strapdown
    /// then made in place; the sample that ends a block makes it and then propagates and
    /// conditions on a copy of the state, kept only if every part succeeds.
    fn predict(&mut self, input: &ImuSample) -> Result<(), OperatorError> {
        input.check()?;
        if let Some(record) = &mut self.record {
            record.reserve()?;
        }
        if let Some(state) = &mut self.state {
            let turn = state.turn(&self.settings, &input.gyro);
            if state.block_ends(&self.settings) {
                self.transaction(|settings, s| {
                    s.strapdown(settings, input, turn);
                    s.end_block(settings)?;
                    check_orientation(&s.orientation)
                })?;
            } else {
                check_orientation(&turn.orientation)?;
                state.strapdown(&self.settings, input, turn);
            }
        } else {
            self.state = Some(Running::initialise(&self.settings, input)?);
        }
        self.keep(Some(&input.gyro));
        Ok(())
    }

    fn update(&mut self, z: &Vector3<f64>) -> Result<Update, OperatorError> {
        check_reading("magnetometer reading", z, super::MAX_FIELD)?;
        if let Some(record) = &mut self.record {
            record.reserve()?;
        }
        let applied = if self.settings.sensors == Sensors::NineD {
            let state = self.state.as_mut().ok_or(NOT_READY)?;
            if state.only_notes_reading() {
                // The orientation does not move: it is as checked at the last step.
                state.note_reading(z);
                None
            } else {
                self.transaction(|settings, s| {
                    let applied = s.magnetometer_step(settings, z)?;
                    check_orientation(&s.orientation)?;
                    Ok(applied)
                })?
            }
        } else {
            self.running()?;
            None
        };
        self.keep(None);
        Ok(applied.map_or(
            Update {
                log_evidence: 0.0,
                nis: None,
            },
            |(log_evidence, value)| Update {
                log_evidence,
                nis: Some(Nis { value, dof: 1 }),
            },
        ))
    }

    fn estimate(&self) -> Result<AttitudeEstimate, OperatorError> {
        let s = self.running()?;
        Ok(AttitudeEstimate {
            orientation: s.reported_orientation(&self.settings),
            covariance: Some(
                self.settings
                    .params
                    .reported(&attitude_block(s.density.covariance())),
            ),
        })
    }

    /// The offline filter's smoothing ([`AttitudeEkf::offline`]); `None` for the causal filter.
    fn smoothing(&mut self) -> Option<&mut dyn Smoothing<Estimate = AttitudeEstimate>> {
        if self.record.is_some() {
            Some(self)
        } else {
            None
        }
    }
}

/// The number of samples in `seconds` at `rate` (both checked finite and positive), rounded, at
/// most 2³⁰.
#[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
fn samples_in(seconds: f64, rate: f64) -> usize {
    // In [0, 2³⁰] before the cast: exact.
    (seconds * rate).round().clamp(0.0, f64::from(1u32 << 30)) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level() -> ImuSample {
        ImuSample {
            gyro: Vector3::zeros(),
            acc: Vector3::new(0.0, 0.0, 9.81),
        }
    }

    #[test]
    fn nothing_before_the_first_sample() {
        let f = AttitudeEkf::new(AttitudeParams::default(), Sensors::NineD, 100.0).unwrap();
        assert!(!f.is_initialised());
        assert_eq!(f.estimate(), Err(NOT_READY));
        let mut g = f.clone();
        assert_eq!(g.update(&Vector3::new(0.0, 20.0, -40.0)), Err(NOT_READY));
        assert!(!g.is_initialised());
    }

    #[test]
    fn a_failed_step_restores_every_field() {
        let mut f = AttitudeEkf::new(AttitudeParams::default(), Sensors::NineD, 100.0).unwrap();
        let field = Vector3::new(0.0, 20.0, -40.0);
        let turning = ImuSample {
            gyro: Vector3::new(0.1, -0.2, 0.3),
            ..level()
        };
        for _ in 0..57 {
            f.predict(&turning).unwrap();
            f.update(&field).unwrap();
        }
        let before = format!("{:?}", f.state);
        let wild = ImuSample {
            gyro: Vector3::new(1e200, 0.0, 0.0),
            ..level()
        };
        assert!(f.predict(&wild).is_err());
        assert!(f.update(&Vector3::new(f64::NAN, 0.0, 0.0)).is_err());
        assert_eq!(format!("{:?}", f.state), before);
    }
}
