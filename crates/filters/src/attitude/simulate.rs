//! [`simulate`]: an IMU log with its true orientation, from [`SimulationSettings`].

use super::data::{DataError, ImuLog, MAX_SAMPLES, RATE_RANGE};
use super::ekf::{AttitudeParams, FieldOffset};
use crate::error::FilterError;
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::TAU;

/// How far the norm of [`SimulationSettings::initial_orientation`] may be from 1: the first
/// sample's readings are rotated by it as given, so a norm `1 + ε` scales them by up to about
/// `1 + 2ε` (10⁻⁶ is well below any sensor noise; a norm further off is a setting to normalise).
const INITIAL_ORIENTATION_TOLERANCE: f64 = 1e-6;

/// The most disturbances a simulation accepts: each sample scans them all, so the simulation
/// costs up to `samples × disturbances` interval tests; 10⁴ keeps that within 3·10¹² at the most
/// samples (2²⁸), hours rather than the days 10⁶ disturbances would take, and far above the few a
/// scenario needs.
const MAX_DISTURBANCES: usize = 10_000;

/// A magnetic disturbance: the field `offset` (µT, ENU) added to the earth field from `start` to
/// `end` (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disturbance {
    /// Start (s).
    pub start: f64,
    /// End (s).
    pub end: f64,
    /// The added field (µT, ENU).
    pub offset: Vector3<f64>,
}

/// The settings of a simulated IMU log. Units: rad/s, m/s², µT, s, Hz.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationSettings {
    /// Sampling rate (Hz), finite and positive.
    pub rate: f64,
    /// Number of samples, 1 to [`MAX_SAMPLES`].
    pub samples: usize,
    /// RMS of each component of the true rotation rate (rad/s), ≥ 0.
    pub rotation_rate: f64,
    /// Correlation time of the rotation rate (s), > 0: it is a stationary Ornstein-Uhlenbeck
    /// process per component, `ω_{k+1} = a ω_k + √(1 − a²) σ n`, `a = exp(−Δt / τ)`.
    pub rotation_time: f64,
    /// Bound on each component of the linear acceleration (m/s², ENU), ≥ 0: a sum of three
    /// sinusoids per axis (0.2 to 2 Hz, random phases) with amplitudes summing to this bound.
    pub acceleration_bound: f64,
    /// Standard deviation of the gyroscope's white noise per sample (rad/s), ≥ 0.
    pub gyro_noise: f64,
    /// Standard deviation of the accelerometer's white noise per sample (m/s²), ≥ 0.
    pub acc_noise: f64,
    /// Standard deviation of the magnetometer's white noise per sample (µT), ≥ 0.
    pub mag_noise: f64,
    /// The gyroscope bias random walk (rad/s/√s), ≥ 0: `b_{k+1} = b_k + σ_b √Δt n`.
    pub gyro_bias_walk: f64,
    /// The gyroscope bias at the start (rad/s).
    pub initial_gyro_bias: Vector3<f64>,
    /// Gravity (m/s²), > 0.
    pub gravity: f64,
    /// The earth field (µT, ENU), non-zero: for example `(0, 20, −44)`, north and down (dip 66°).
    pub earth_field: Vector3<f64>,
    /// Magnetic disturbance intervals, at most 10 000 (`MAX_DISTURBANCES`): every sample sums the
    /// ones active at its time, a cost of samples × disturbances.
    pub disturbances: Vec<Disturbance>,
    /// The local field's heading offset from the earth field's, a Gauss-Markov process (the model
    /// the production filter assumes), or `None` for none.
    pub field_offset: Option<FieldOffset>,
    /// The true orientation at the start (IMU w.r.t. ENU): finite, with a norm within 10⁻⁶ of 1
    /// (it is used as given for the first sample).
    pub initial_orientation: UnitQuaternion<f64>,
}

impl Default for SimulationSettings {
    /// One minute at 285.714 Hz (BROAD's rate) of hand-held motion with a consumer-grade IMU.
    fn default() -> Self {
        Self {
            rate: 2000.0 / 7.0,
            samples: 17_143,
            rotation_rate: 1.0,
            rotation_time: 0.5,
            acceleration_bound: 3.0,
            gyro_noise: 0.005,
            acc_noise: 0.05,
            mag_noise: 0.5,
            gyro_bias_walk: 1e-4,
            initial_gyro_bias: Vector3::new(0.01, -0.005, 0.003),
            gravity: 9.81,
            earth_field: Vector3::new(0.0, 20.0, -44.0),
            disturbances: Vec::new(),
            field_offset: None,
            initial_orientation: UnitQuaternion::identity(),
        }
    }
}

impl SimulationSettings {
    /// `params` with the sensor noise these settings simulate: the gyroscope's angle random walk
    /// `σ_g / √rate` (rad/√s), no IMU delay (the simulated samples are not late), the heading σ
    /// of one magnetometer sample `σ_m / |m_h|` (rad, m_h the earth field's horizontal part) and, when the simulated field has one, its heading
    /// offset's process. The other settings model what a real IMU has and the simulator does not
    /// (scale-factor errors, the time-correlated errors the velocity bound forgives) and are kept:
    /// this is the filter to check for consistency on simulated logs.
    ///
    /// # Errors
    /// [`FilterError::Data`] for settings [`simulate`] refuses; [`FilterError::Setting`] when the
    /// result is not a valid filter setting (a simulator without gyroscope or magnetometer noise,
    /// or an earth field without a horizontal part: no heading to measure).
    pub fn matched_noise(&self, params: AttitudeParams) -> Result<AttitudeParams, FilterError> {
        check_settings(self)?;
        let mut params = AttitudeParams {
            gyro_noise: self.gyro_noise / self.rate.sqrt(),
            imu_delay: 0.0,
            ..params
        };
        params.magnetometer.heading_sigma = self.mag_noise / self.earth_field.xy().norm();
        if self.field_offset.is_some() {
            params.magnetometer.offset = self.field_offset;
        }
        params.validate()?;
        Ok(params)
    }
}

/// The sample-to-sample model of [`simulate`], sample k at `t_k = k Δt`:
///
/// * truth: `q_{k+1} = q_k ⊗ exp(ω_k Δt)`, ω_k the true body rate (held over the interval);
/// * gyroscope: `ω_k + b_k + σ_g n`, b the bias random walk;
/// * accelerometer: `R(q_{k+½})ᵀ (a_{k+½} + g ẑ) + σ_a n`, a the linear acceleration (ENU),
///   both at the interval's middle (`q_{k+½} = q_k ⊗ exp(ω_k Δt/2)`, `t_k + Δt/2`): like the
///   gyroscope's, the sample is the interval's mean (to second order in the turn), as the filters
///   take it;
/// * magnetometer: `R(q_k)ᵀ (Rz(−c_k) m_E + d(t_k)) + σ_m n`, d the disturbance active at `t_k`
///   and c the field's heading offset (east of north): `c_0 ~ N(0, σ_c²)`,
///   `c_{k+1} = a c_k + √(1 − a²) σ_c n`, `a = exp(−Δt/τ_c)` (0 without `field_offset`);
///
/// n independent standard normal vectors drawn from `ChaCha8Rng::seed_from_u64(seed)`. The log's
/// reference is the truth and its movement mask is all true. The same settings and seed give the
/// same log.
///
/// # Errors
/// [`DataError::BadValue`] for a setting out of the range its field documents,
/// [`DataError::TooLarge`] for more than 10 000 disturbances or when the samples' memory cannot
/// be allocated.
pub fn simulate(settings: &SimulationSettings, seed: u64) -> Result<ImuLog, DataError> {
    check_settings(settings)?;
    let s = settings;
    let dt = 1.0 / s.rate;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a = (-dt / s.rotation_time).exp();
    let innovation = (1.0 - a * a).sqrt() * s.rotation_rate;
    // Three sinusoids per axis for the linear acceleration.
    let waves: Vec<[(f64, f64, f64); 3]> = (0..3)
        .map(|_| {
            let weights: [f64; 3] = [rng.random(), rng.random(), rng.random()];
            let sum: f64 = weights.iter().sum::<f64>().max(f64::MIN_POSITIVE);
            weights.map(|w| {
                let frequency = 0.2 + 1.8 * rng.random::<f64>();
                (
                    s.acceleration_bound * w / sum,
                    frequency,
                    TAU * rng.random::<f64>(),
                )
            })
        })
        .collect();
    let mut omega = normal(&mut rng) * s.rotation_rate;
    let mut bias = s.initial_gyro_bias;
    let mut q = s.initial_orientation;
    let offset_decay = s
        .field_offset
        .map(|f| ((-dt / f.correlation_time).exp(), f.sigma));
    let mut offset = offset_decay.map_or(0.0, |(_, sigma)| sigma * standard(&mut rng));
    let n = s.samples;
    let (mut gyr, mut acc, mut mag, mut truth) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // Up to 2^28 samples are accepted; buffers the system cannot give are an error, not an abort.
    let refused = |_| DataError::TooLarge {
        origin: "simulate".to_owned(),
        what: "the number of samples (their memory cannot be allocated)",
        size: n as u64,
        limit: MAX_SAMPLES as u64,
    };
    gyr.try_reserve_exact(n).map_err(refused)?;
    acc.try_reserve_exact(n).map_err(refused)?;
    mag.try_reserve_exact(n).map_err(refused)?;
    truth.try_reserve_exact(n).map_err(refused)?;
    let mut movement = Vec::new();
    movement.try_reserve_exact(n).map_err(refused)?;
    movement.resize(n, true);
    for k in 0..n {
        let t = k as f64 * dt;
        let middle = t + 0.5 * dt;
        let linear = Vector3::from_fn(|i, _| {
            waves[i]
                .iter()
                .map(|(amplitude, f, phase)| amplitude * (TAU * f * middle + phase).sin())
                .sum()
        });
        let disturbance: Vector3<f64> = s
            .disturbances
            .iter()
            .filter(|d| d.start <= t && t < d.end)
            .map(|d| d.offset)
            .sum();
        let to_sensor = q.inverse();
        let halfway = q * super::rotation(&(omega * (0.5 * dt)));
        gyr.push(omega + bias + normal(&mut rng) * s.gyro_noise);
        acc.push(
            halfway.inverse() * (linear + Vector3::z() * s.gravity)
                + normal(&mut rng) * s.acc_noise,
        );
        let field = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -offset) * s.earth_field;
        mag.push(to_sensor * (field + disturbance) + normal(&mut rng) * s.mag_noise);
        truth.push(Some(q));
        q *= super::rotation(&(omega * dt));
        q.renormalize();
        omega = omega * a + normal(&mut rng) * innovation;
        bias += normal(&mut rng) * (s.gyro_bias_walk * dt.sqrt());
        if let Some((a, sigma)) = offset_decay {
            offset = a * offset + (1.0 - a * a).sqrt() * sigma * standard(&mut rng);
        }
    }
    ImuLog::new_from(
        "simulate",
        ["gyroscope", "accelerometer", "magnetometer"],
        s.rate,
        gyr,
        acc,
        Some(mag),
    )?
    .with_reference(truth)?
    .with_movement(movement)
}

fn normal(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    Vector3::from_fn(|_, _| standard(rng))
}

fn standard(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// Checks every setting of a simulation (as [`simulate`] does before it draws anything).
pub(super) fn check_settings(s: &SimulationSettings) -> Result<(), DataError> {
    let bad = |variable: &str, value: String, expected| {
        Err(DataError::BadValue {
            origin: "simulate".to_owned(),
            variable: variable.to_owned(),
            row: 0,
            value,
            expected,
        })
    };
    if !(RATE_RANGE.0..=RATE_RANGE.1).contains(&s.rate) {
        return bad("rate", s.rate.to_string(), "a rate in [1e-3, 1e6] Hz");
    }
    let positive = [("rotation_time", s.rotation_time), ("gravity", s.gravity)];
    for (name, value) in positive {
        if !(value.is_finite() && value > 0.0) {
            return bad(name, value.to_string(), "finite and positive");
        }
    }
    let non_negative = [
        ("rotation_rate", s.rotation_rate),
        ("acceleration_bound", s.acceleration_bound),
        ("gyro_noise", s.gyro_noise),
        ("acc_noise", s.acc_noise),
        ("mag_noise", s.mag_noise),
        ("gyro_bias_walk", s.gyro_bias_walk),
    ];
    for (name, value) in non_negative {
        if !(value.is_finite() && value >= 0.0) {
            return bad(name, value.to_string(), "finite and non-negative");
        }
    }
    if s.samples == 0 || s.samples > MAX_SAMPLES {
        return bad("samples", s.samples.to_string(), "1 to 2^28 samples");
    }
    let finite = |v: &Vector3<f64>| v.iter().all(|c| c.is_finite());
    if !finite(&s.initial_gyro_bias) {
        return bad(
            "initial_gyro_bias",
            format!("{:?}", s.initial_gyro_bias.as_slice()),
            "finite",
        );
    }
    if !finite(&s.earth_field) || s.earth_field == Vector3::zeros() {
        return bad(
            "earth_field",
            format!("{:?}", s.earth_field.as_slice()),
            "finite and non-zero",
        );
    }
    // NaN and ±∞ components give a NaN or infinite norm.
    let norm = s.initial_orientation.coords.norm();
    if !norm.is_finite() || (norm - 1.0).abs() > INITIAL_ORIENTATION_TOLERANCE {
        return bad(
            "initial_orientation",
            format!(
                "{:?} of norm {norm}",
                s.initial_orientation.coords.as_slice()
            ),
            "a finite unit quaternion (norm within 1e-6 of 1; normalise it)",
        );
    }
    if let Some(f) = &s.field_offset {
        for (name, value) in [
            ("field_offset.sigma", f.sigma),
            ("field_offset.correlation_time", f.correlation_time),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return bad(name, value.to_string(), "finite and positive");
            }
        }
    }
    if s.disturbances.len() > MAX_DISTURBANCES {
        return Err(DataError::TooLarge {
            origin: "simulate".to_owned(),
            what: "the number of disturbances (merge overlapping ones)",
            size: s.disturbances.len() as u64,
            limit: MAX_DISTURBANCES as u64,
        });
    }
    for (row, d) in s.disturbances.iter().enumerate() {
        if !(d.start.is_finite() && d.end.is_finite() && d.start <= d.end && finite(&d.offset)) {
            return Err(DataError::BadValue {
                origin: "simulate".to_owned(),
                variable: "disturbances".to_owned(),
                row,
                value: format!("{d:?}"),
                expected: "finite start <= end (s) and a finite offset (µT)",
            });
        }
    }
    Ok(())
}
