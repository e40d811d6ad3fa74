//! The attitude filter of the talk "Kalman Filtering on SO(3)" (ETRI, 2017), errata corrected: a
//! [`Bingham`] density on the unit quaternion, propagated with the gyroscope through a
//! left-translated diffusion `LD(q̄, Σ)` and updated with the accelerometer and magnetometer by adding
//! the direction-measurement matrices to the Bingham parameter ([`TalkFilter`], [`run_talk_filter`]).
//!
//! Conventions: q is the IMU frame with respect to East-North-Up (Hamilton, scalar first,
//! `v_ENU = q v_IMU q*`), the talk's `r` being `R(q)ᵀ`; Σ is the covariance of the body-frame
//! deviation, `R = R(q̄) exp([ξ]ₓ)`.

use super::data::{DataError, ImuLog, bad, check_positive, scaled_unit};
use super::madgwick::{broad_initial_state, enu_from_nwu};
use super::track::AttitudeTrack;
use liebayes_densities::{Bingham, DensityError};
use liebayes_manifolds::Su2;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The noise settings of [`TalkFilter`] (the talk's symbols).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TalkParams {
    /// σ_U (rad/s): gyroscope noise per sample, `G_k = Ω_k + U_k`. Finite, > 0.
    pub gyro_noise: f64,
    /// σ_A (rad/s²): the angular-rate random walk, `Ω_k = Ω_(k−1) + A_k Δt`. Finite, ≥ 0.
    pub rate_walk: f64,
    /// σ_V: accelerometer noise on the unit gravity direction (dimensionless, about rad).
    /// Finite, > 0.
    pub acc_noise: f64,
    /// σ_W: magnetometer noise on the unit field direction (dimensionless). Finite, > 0.
    pub mag_noise: f64,
    /// Standard deviation (rad) per axis of the initial diffusion `Σ₀ = σ₀² I`. Finite, > 0.
    pub initial_sigma: f64,
    /// σ_Ω,0 (rad/s): initial angular-rate standard deviation (the initial rate is 0). Finite, > 0.
    pub initial_rate_sigma: f64,
}

impl Default for TalkParams {
    /// A consumer-grade IMU moved by hand: σ_U = 0.005 rad/s, σ_A = 30 rad/s², σ_V = 0.2,
    /// σ_W = 0.2, σ₀ = 10°, σ_Ω,0 = 1 rad/s.
    fn default() -> Self {
        Self {
            gyro_noise: 0.005,
            rate_walk: 30.0,
            acc_noise: 0.2,
            mag_noise: 0.2,
            initial_sigma: 10f64.to_radians(),
            initial_rate_sigma: 1.0,
        }
    }
}

impl TalkParams {
    /// Checks every field against its documented range.
    ///
    /// # Errors
    /// [`DataError::BadValue`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), DataError> {
        let origin = "TalkParams";
        check_positive(origin, "gyro_noise", self.gyro_noise)?;
        if !(self.rate_walk.is_finite() && self.rate_walk >= 0.0) {
            return Err(bad(
                origin,
                "rate_walk",
                self.rate_walk.to_string(),
                "a finite non-negative rate walk in rad/s^2",
            ));
        }
        check_positive(origin, "acc_noise", self.acc_noise)?;
        check_positive(origin, "mag_noise", self.mag_noise)?;
        check_positive(origin, "initial_sigma", self.initial_sigma)?;
        check_positive(origin, "initial_rate_sigma", self.initial_rate_sigma)
    }
}

/// The talk's filter. State: a Bingham density on q (IMU w.r.t. ENU), the angular-rate estimate ω̄
/// and its variance σ_Ω². One sample (gyroscope g, accelerometer a, magnetometer m), with
/// `D = σ_U² + σ_A² Δt² + σ_Ω²`:
///
/// 1. **gyroscope** ([`propagate`](Self::propagate)): the rate over the past interval
///    `ω̃ = ((σ_U² + σ_A² Δt²) ω̄ + σ_Ω² g)/D` (the Kalman smoother of `Ω_(k−1)` given `G_k`), with
///    variance `σ̃² = (σ_U² + σ_A² Δt²) σ_Ω² / D`; the Bingham is converted to `LD(q̄, Σ)` by exact
///    moment matching ([`Bingham::to_diffusion_moment_matched`]), turned `q̄ ← q̄ ⊗ exp(ω̃ Δt)`,
///    `Σ ← Eᵀ Σ E + σ̃² Δt² I` (E the rotation of ω̃ Δt; the isotropic convolution is exact), and
///    converted back ([`Bingham::from_diffusion_moment_matched`]); then the rate's Kalman update
///    `ω̄ ← (σ_U² ω̄ + (σ_A² Δt² + σ_Ω²) g)/D`, `σ_Ω² ← σ_U² (σ_A² Δt² + σ_Ω²)/D`;
/// 2. **accelerometer and magnetometer** ([`update`](Self::update)): the Bingham parameter
///    `M ← M + M_acc + M_mag` with the natural parameters of [`Bingham::from_direction`] for the
///    unit gravity direction (reference
///    `(0, 0, 1)`, σ_V) and of the unit field direction (reference `(0, cos δ, −sin δ)` in ENU, δ the
///    dip, σ_W), re-diagonalised by [`Bingham::from_natural`].
///
/// The state is all-or-nothing: a failed step leaves it unchanged.
#[derive(Clone, Debug, PartialEq)]
pub struct TalkFilter {
    params: TalkParams,
    interval: f64,
    bingham: Bingham,
    rate: Vector3<f64>,
    rate_variance: f64,
    field_reference: Option<Vector3<f64>>,
}

impl TalkFilter {
    /// A filter at `rate` Hz starting at `LD(initial, σ₀² I)`, the angular rate at `N(0, σ_Ω,0² I)`,
    /// with the unit field reference `field_reference` in ENU (`None`: accelerometer only).
    ///
    /// # Errors
    /// [`DataError::BadValue`] for parameters out of range (as [`TalkParams::validate`]), a rate
    /// that is not finite and positive, a field reference that is not a finite unit vector, or an
    /// initial σ₀ too small or too large for a Bingham.
    pub fn new(
        params: &TalkParams,
        rate: f64,
        initial: &UnitQuaternion<f64>,
        field_reference: Option<Vector3<f64>>,
    ) -> Result<Self, DataError> {
        params.validate()?;
        check_positive("TalkFilter::new", "rate", rate)?;
        if let Some(m) = field_reference
            && !(m.iter().all(|c| c.is_finite()) && (m.norm() - 1.0).abs() <= 1e-9)
        {
            return Err(bad(
                "TalkFilter::new",
                "field_reference",
                format!("{:?}", m.as_slice()),
                "a finite unit vector (ENU)",
            ));
        }
        let s0 = params.initial_sigma * params.initial_sigma;
        let bingham = from_diffusion(initial, &(Matrix3::identity() * s0), "TalkFilter::new")?;
        Ok(Self {
            params: *params,
            interval: 1.0 / rate,
            bingham,
            rate: Vector3::zeros(),
            rate_variance: params.initial_rate_sigma * params.initial_rate_sigma,
            field_reference,
        })
    }

    /// The Bingham density of q.
    pub fn bingham(&self) -> &Bingham {
        &self.bingham
    }

    /// The angular-rate estimate ω̄ (rad/s, IMU frame) and its per-axis variance σ_Ω².
    pub fn rate(&self) -> (Vector3<f64>, f64) {
        (self.rate, self.rate_variance)
    }

    /// The estimate and its covariance: the Bingham's mode (IMU w.r.t. ENU, w ≥ 0) and the
    /// body-frame covariance Σ (rad²) of the moment-matched `LD(q̄, Σ)`
    /// ([`Bingham::to_diffusion_moment_matched`]).
    ///
    /// # Errors
    /// [`DataError::BadValue`] when that matching fails.
    pub fn estimate(&self) -> Result<(UnitQuaternion<f64>, Matrix3<f64>), DataError> {
        to_diffusion(&self.bingham, "TalkFilter::estimate")
    }

    /// Step 1 with the gyroscope sample `gyr` (rad/s, IMU frame).
    ///
    /// # Errors
    /// [`DataError::BadValue`] for a non-finite sample or a state the conversions refuse; the
    /// state is then unchanged.
    pub fn propagate(&mut self, gyr: &Vector3<f64>) -> Result<(), DataError> {
        if !gyr.iter().all(|c| c.is_finite()) {
            return Err(bad(
                "TalkFilter::propagate",
                "gyroscope",
                format!("{:?}", gyr.as_slice()),
                "finite readings in rad/s",
            ));
        }
        let p = &self.params;
        let dt = self.interval;
        let (su, walk, so) = (
            p.gyro_noise * p.gyro_noise,
            p.rate_walk * p.rate_walk * dt * dt,
            self.rate_variance,
        );
        let denominator = su + walk + so;
        let smoothed = (self.rate * (su + walk) + gyr * so) / denominator;
        let smoothed_variance = (su + walk) * so / denominator;
        let origin = "TalkFilter::propagate";
        let (mean, covariance) = to_diffusion(&self.bingham, origin)?;
        let turn = UnitQuaternion::from_scaled_axis(smoothed * dt);
        let e = turn.to_rotation_matrix().into_inner();
        let covariance =
            e.transpose() * covariance * e + Matrix3::identity() * (smoothed_variance * dt * dt);
        let bingham = from_diffusion(&(mean * turn), &covariance, origin)?;
        self.bingham = bingham;
        self.rate = (self.rate * su + gyr * (walk + so)) / denominator;
        self.rate_variance = su * (walk + so) / denominator;
        Ok(())
    }

    /// Step 2 with the accelerometer (any unit; its direction is used) and, when the filter has a
    /// field reference, the magnetometer (any unit). A zero reading skips its update.
    ///
    /// # Errors
    /// [`DataError::BadValue`] for a non-finite reading or a posterior the Bingham refuses (an
    /// eigenvalue spread beyond [`Bingham::MAX_SPREAD`]); the state is then unchanged.
    pub fn update(
        &mut self,
        acc: &Vector3<f64>,
        mag: Option<&Vector3<f64>>,
    ) -> Result<(), DataError> {
        let origin = "TalkFilter::update";
        let mut natural = self.bingham.natural();
        if let Some(a) = unit(origin, "accelerometer", acc)? {
            natural += direction(&a, &Vector3::z(), self.params.acc_noise, origin)?;
        }
        if let (Some(reference), Some(m)) = (self.field_reference, mag) {
            if let Some(m) = unit(origin, "magnetometer", m)? {
                natural += direction(&m, &reference, self.params.mag_noise, origin)?;
            }
        }
        let natural = (natural + natural.transpose()) * 0.5;
        self.bingham = Bingham::from_natural(natural).map_err(|e| density_error(origin, &e))?;
        Ok(())
    }
}

/// The result of [`run_talk_filter`]: per sample, the estimate after that sample's update.
#[derive(Clone, Debug, PartialEq)]
pub struct TalkRun {
    /// The Bingham mode: the IMU frame w.r.t. ENU, scalar first.
    pub orientations: Vec<UnitQuaternion<f64>>,
    /// The body-frame covariance Σ (rad²) of the moment-matched diffusion.
    pub covariances: Vec<Matrix3<f64>>,
}

impl TalkRun {
    /// The reported total standard deviation per sample, `√(tr Σ)` (rad): the RMS of the angle of
    /// a draw for a concentrated diffusion.
    pub fn reported_sigma(&self) -> Vec<f64> {
        self.covariances.iter().map(|c| c.trace().sqrt()).collect()
    }

    /// The run as an [`AttitudeTrack`]: the body-frame Σ moved to the world frame,
    /// `R(q) Σ R(q)ᵀ`, and split into heading and tilt standard deviations.
    pub fn track(&self) -> AttitudeTrack {
        let (heading, tilt) = self
            .orientations
            .iter()
            .zip(&self.covariances)
            .map(|(q, c)| {
                let r = q.to_rotation_matrix().into_inner();
                AttitudeTrack::sigmas_of_world_covariance(&(r * c * r.transpose()))
            })
            .unzip();
        AttitudeTrack {
            orientations: self.orientations.clone(),
            heading_sigma: Some(heading),
            tilt_sigma: Some(tilt),
        }
    }
}

/// The unit field reference in ENU from the cosine `c` of the angle between the gravity and field
/// directions measured in the IMU frame (`c = â · m̂`, the vertical component of the field
/// direction; ENU with North magnetic): `(0, √(1 − c²), c)`, c clamped to [−1, 1]. `None` for a
/// non-finite c.
pub fn field_reference_from(c: f64) -> Option<Vector3<f64>> {
    if !c.is_finite() {
        return None;
    }
    let c = c.clamp(-1.0, 1.0);
    Some(Vector3::new(0.0, (1.0 - c * c).sqrt(), c))
}

/// `â · m̂` of one sample, `None` when a reading is zero or not finite.
fn dip_cosine(acc: &Vector3<f64>, mag: &Vector3<f64>) -> Option<f64> {
    Some(scaled_unit(acc)?.dot(&scaled_unit(mag)?))
}

/// The talk's filter run on `log`: initial mean from the first sample (the BROAD example's
/// construction, [`broad_initial_state`], turned to ENU), then per sample [`TalkFilter::propagate`]
/// and [`TalkFilter::update`], the estimate after both. The talk takes the earth field m as known;
/// here its unit direction is [`field_reference_from`] the running mean of `â · m̂` over the
/// samples so far (causal; one sample's dip would carry its noise into the tilt for the whole run).
/// Without a magnetometer the filter uses the accelerometer only.
///
/// # Errors
/// As [`TalkFilter::new`]; [`DataError::NothingToScore`] for an empty log;
/// [`DataError::BadValue`] when the first sample gives no initial state or a step fails (with its
/// row).
pub fn run_talk_filter(log: &ImuLog, params: &TalkParams) -> Result<TalkRun, DataError> {
    let origin = "run_talk_filter";
    params.validate()?;
    let (Some(acc0), gyr, acc) = (
        log.accelerometer().first(),
        log.gyroscope(),
        log.accelerometer(),
    ) else {
        return Err(DataError::NothingToScore {
            origin: origin.to_owned(),
            message: "the log is empty".to_owned(),
        });
    };
    let mag = log.magnetometer();
    let initial = broad_initial_state(acc0, mag.map(|m| &m[0])).ok_or_else(|| {
        bad(
            origin,
            "accelerometer",
            format!("{:?}", acc0.as_slice()),
            "a non-zero first reading not parallel to the magnetometer",
        )
    })?;
    let (mut dip_sum, mut dip_count) = (0.0, 0.0);
    let field = match mag {
        Some(m) => {
            let c = dip_cosine(acc0, &m[0]).ok_or_else(|| {
                bad(
                    origin,
                    "magnetometer",
                    format!("{:?}", m[0].as_slice()),
                    "a non-zero first reading",
                )
            })?;
            field_reference_from(c)
        }
        None => None,
    };
    let mut filter = TalkFilter::new(params, log.rate(), &(enu_from_nwu() * initial), field)?;
    let mut run = TalkRun {
        orientations: Vec::with_capacity(log.len()),
        covariances: Vec::with_capacity(log.len()),
    };
    for k in 0..log.len() {
        if let Some(c) = mag.and_then(|m| dip_cosine(&acc[k], &m[k])) {
            dip_sum += c;
            dip_count += 1.0;
            filter.field_reference = field_reference_from(dip_sum / dip_count);
        }
        let step = filter
            .propagate(&gyr[k])
            .and_then(|()| filter.update(&acc[k], mag.map(|m| &m[k])))
            .and_then(|()| filter.estimate());
        let (q, covariance) = step.map_err(|e| with_row(origin, k, e))?;
        run.orientations.push(q);
        run.covariances.push(covariance);
    }
    Ok(run)
}

fn with_row(origin: &str, row: usize, e: DataError) -> DataError {
    match e {
        DataError::BadValue {
            variable,
            value,
            expected,
            ..
        } => DataError::BadValue {
            origin: origin.to_owned(),
            variable,
            row,
            value,
            expected,
        },
        other => other,
    }
}

/// `v / |v|` (scaled by its largest component first), `None` for a zero vector; an error for a
/// non-finite one.
fn unit(origin: &str, variable: &str, v: &Vector3<f64>) -> Result<Option<Vector3<f64>>, DataError> {
    if !v.iter().all(|c| c.is_finite()) {
        return Err(bad(
            origin,
            variable,
            format!("{:?}", v.as_slice()),
            "finite readings",
        ));
    }
    Ok(scaled_unit(v))
}

/// [`Bingham::from_diffusion_moment_matched`] with its error as a [`DataError`].
pub(super) fn from_diffusion(
    mean: &UnitQuaternion<f64>,
    covariance: &Matrix3<f64>,
    origin: &str,
) -> Result<Bingham, DataError> {
    Bingham::from_diffusion_moment_matched(&Su2::from_unit_quaternion(*mean), covariance)
        .map_err(|e| density_error(origin, &e))
}

/// [`Bingham::to_diffusion_moment_matched`] with its error as a [`DataError`].
fn to_diffusion(
    bingham: &Bingham,
    origin: &str,
) -> Result<(UnitQuaternion<f64>, Matrix3<f64>), DataError> {
    let (mean, covariance) = bingham
        .to_diffusion_moment_matched()
        .map_err(|e| density_error(origin, &e))?;
    Ok((*mean.as_unit_quaternion(), covariance))
}

/// The natural parameter of [`Bingham::from_direction`], with its error as a [`DataError`].
fn direction(
    measured: &Vector3<f64>,
    reference: &Vector3<f64>,
    sigma: f64,
    origin: &str,
) -> Result<nalgebra::Matrix4<f64>, DataError> {
    Bingham::from_direction(measured, reference, sigma)
        .map(|b| b.natural())
        .map_err(|e| density_error(origin, &e))
}

fn density_error(origin: &str, e: &DensityError) -> DataError {
    bad(
        origin,
        "Bingham state",
        e.to_string(),
        "a Bingham within the library's range (increase the noise settings)",
    )
}
