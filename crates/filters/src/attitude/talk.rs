//! The attitude filter of the talk "Kalman Filtering on SO(3)" (ETRI, 2017), errata corrected: a
//! [`Bingham`] density on the unit quaternion, propagated with the gyroscope through a
//! left-translated diffusion `LD(q̄, Σ)` and updated with the accelerometer and magnetometer by adding
//! the direction-measurement matrices to the Bingham parameter ([`TalkFilter`]).
//!
//! Conventions: q is the IMU frame with respect to East-North-Up (Hamilton, scalar first,
//! `v_ENU = q v_IMU q*`), the talk's `r` being `R(q)ᵀ`; Σ is the covariance of the body-frame
//! deviation, `R = R(q̄) exp([ξ]ₓ)`.

use super::data::{DataError, MAX_FIELD, bad, check_positive, check_reading, scaled_unit};
use super::ekf::Sensors;
use super::estimate::{AttitudeEstimate, ImuSample};
use super::madgwick::{broad_initial_state, enu_from_nwu};
use crate::error::{FilterError, positive_setting};
use liebayes_experiments::{RecursiveFilter, Update};
use liebayes_operators::OperatorError;
use liebayes_densities::{Bingham, Density, DensityError, Rotate};
use liebayes_manifolds::Su2;
use nalgebra::{Matrix3, Matrix4, SymmetricEigen, UnitQuaternion, Vector3};

/// The direction-measurement matrix of the talk, in the filter's convention: for a reference
/// direction `h` (ENU) measured in the IMU frame as `v = R(q)ᵀ h + N(0, σ² I)`,
///
/// `exp(−|v − R(q)ᵀ h|² / (2σ²)) = exp(qᵀ M q)` for every unit q, exactly, with
///
/// `M = [ −|v − h|²/(2σ²)   (v × h)ᵀ/σ² ;  (v × h)/σ²   (v hᵀ + h vᵀ)/σ² − |v + h|²/(2σ²) I ]`.
///
/// (The talk's matrix is written for the active rotation `R(q) h`; the body-frame measurement is
/// its conjugate `diag(1, −1, −1, −1) M diag(1, −1, −1, −1)`, which flips the cross-product terms.)
/// Valid for finite vectors and a finite `σ > 0` whose entries stay finite.
///
/// # Errors
/// [`DataError::BadValue`] for a non-finite vector, a σ that is not finite and positive, or a
/// matrix that overflows.
pub fn direction_matrix(
    measured: &Vector3<f64>,
    reference: &Vector3<f64>,
    sigma: f64,
) -> Result<Matrix4<f64>, DataError> {
    check_positive("direction_matrix", "sigma", sigma)?;
    let (v, h) = (measured, reference);
    let inv = 1.0 / (sigma * sigma);
    let cross = v.cross(h) * inv;
    let block = (v * h.transpose() + h * v.transpose()) * inv
        - Matrix3::identity() * ((v + h).norm_squared() * 0.5 * inv);
    let mut m = Matrix4::zeros();
    m[(0, 0)] = -(v - h).norm_squared() * 0.5 * inv;
    for i in 0..3 {
        m[(0, i + 1)] = cross[i];
        m[(i + 1, 0)] = cross[i];
        for j in 0..3 {
            m[(i + 1, j + 1)] = block[(i, j)];
        }
    }
    if m.iter().all(|x| x.is_finite()) {
        Ok(m)
    } else {
        Err(bad(
            "direction_matrix",
            "measured, reference",
            format!("{:?}, {:?}", v.as_slice(), h.as_slice()),
            "finite vectors and a sigma giving a finite matrix",
        ))
    }
}

/// The second-moment matrix `E[q qᵀ]` of the left-translated diffusion `LD(1, Σ)` about the identity
/// (Σ the body-frame covariance, symmetric positive semi-definite, rad²). Exact: the rotation's first
/// moment is `E[R] = expm((Σ − tr Σ I)/2)`, so along an eigenvector of Σ (eigenvalue σᵢ²) it is
/// `eᵢ = exp(−(σⱼ² + σₖ²)/2)`; with `dᵢ = 1 − eᵢ`, the quaternion's moments are
/// `E[w²] = 1 − (d₁ + d₂ + d₃)/4`, `E[uᵢ²] = (dⱼ + dₖ − dᵢ)/4` along the eigenvectors, and the
/// cross terms zero. Computed with `exp_m1` so that tiny variances keep their relative accuracy.
///
/// # Errors
/// [`DataError::BadValue`] for a non-finite or non-symmetric Σ or a negative eigenvalue.
pub fn diffusion_second_moment(covariance: &Matrix3<f64>) -> Result<Matrix4<f64>, DataError> {
    let (values, vectors) = covariance_eigen(covariance)?;
    let total: f64 = values.sum();
    let d = values.map(|v| -(-(total - v) / 2.0).exp_m1());
    let sum_d = d.sum();
    let mut moments = Matrix4::zeros();
    moments[(0, 0)] = 1.0 - sum_d / 4.0;
    let diag = d.map(|di| (sum_d - 2.0 * di) / 4.0);
    let block = vectors * Matrix3::from_diagonal(&diag) * vectors.transpose();
    for i in 0..3 {
        for j in 0..3 {
            moments[(i + 1, j + 1)] = block[(i, j)];
        }
    }
    Ok(moments)
}

/// The Bingham with the second moments of `LD(mean, Σ)`: [`diffusion_second_moment`] fitted by
/// [`Bingham::from_second_moment`] about the identity, then turned to `mean` (`q ↦ mean q`).
/// Exact in the second moments (to the fit's 1e-11).
///
/// # Errors
/// As [`diffusion_second_moment`]; [`DataError::BadValue`] when the fit fails (a variance below
/// about 2e-6 rad², beyond [`Bingham::MAX_SPREAD`]).
pub fn bingham_from_diffusion(
    mean: &UnitQuaternion<f64>,
    covariance: &Matrix3<f64>,
) -> Result<Bingham, DataError> {
    let moments = diffusion_second_moment(covariance)?;
    let about_identity = Bingham::from_second_moment(moments)
        .map_err(|e| density_error("bingham_from_diffusion", &e))?;
    Ok(about_identity.rotated(&Su2::from_unit_quaternion(*mean)))
}

/// The left-translated diffusion `LD(q̄, Σ)` with the second moments of a Bingham: q̄ its mode
/// (w ≥ 0) and, with `U` the vector block of `E[p pᵀ]` for `p = q̄⁻¹ q`, in U's eigenbasis
/// `dᵢ = 2(Uⱼⱼ + Uₖₖ)`, `ln eᵢ = ln(1 − dᵢ)`, `T = tr Σ = −Σ ln eᵢ` and `σᵢ² = 2 ln eᵢ + T`
/// (the inverse of [`diffusion_second_moment`]). For an isotropic Bingham it is the heat kernel of
/// `Bingham::to_heat_kernel_moment_matched`.
///
/// # Errors
/// [`DataError::BadValue`] when the Bingham has no unique mode, is too diffuse (`dᵢ ≥ 1`) or too
/// anisotropic for a diffusion (a `σᵢ² < 0`).
pub fn diffusion_from_bingham(
    bingham: &Bingham,
) -> Result<(UnitQuaternion<f64>, Matrix3<f64>), DataError> {
    let origin = "diffusion_from_bingham";
    let mode = bingham.mode().ok_or_else(|| {
        bad(
            origin,
            "Bingham eigenvalues",
            format!("{:?}", bingham.eigenvalues().as_slice()),
            "a unique largest eigenvalue (a unique mode)",
        )
    })?;
    let about = bingham.rotated(&Su2::from_unit_quaternion(
        mode.as_unit_quaternion().inverse(),
    ));
    let s = about.second_moment();
    let block = Matrix3::from_fn(|r, c| 0.5 * (s[(r + 1, c + 1)] + s[(c + 1, r + 1)]));
    let eigen = SymmetricEigen::new(block);
    let u = eigen.eigenvalues;
    let d = Vector3::new(
        2.0 * (u[1] + u[2]),
        2.0 * (u[0] + u[2]),
        2.0 * (u[0] + u[1]),
    );
    if !d
        .iter()
        .all(|&di| di.is_finite() && (0.0..1.0).contains(&di))
    {
        return Err(bad(
            origin,
            "Bingham second moments",
            format!("{:?}", u.as_slice()),
            "a concentrated Bingham (every 2(U_jj + U_kk) in [0, 1))",
        ));
    }
    let log_e = d.map(|di| (-di).ln_1p());
    let total = -log_e.sum();
    let variances = log_e.map(|l| 2.0 * l + total);
    if variances.iter().any(|&v| v < 0.0) {
        return Err(bad(
            origin,
            "diffusion variances",
            format!("{:?}", variances.as_slice()),
            "a Bingham whose moments are those of a diffusion (non-negative variances)",
        ));
    }
    let covariance =
        eigen.eigenvectors * Matrix3::from_diagonal(&variances) * eigen.eigenvectors.transpose();
    Ok((*mode.as_unit_quaternion(), covariance))
}

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
/// 1. **gyroscope**: the rate over the past interval
///    `ω̃ = ((σ_U² + σ_A² Δt²) ω̄ + σ_Ω² g)/D` (the Kalman smoother of `Ω_(k−1)` given `G_k`), with
///    variance `σ̃² = (σ_U² + σ_A² Δt²) σ_Ω² / D`; the Bingham is converted to `LD(q̄, Σ)` by exact
///    moment matching ([`diffusion_from_bingham`]), turned `q̄ ← q̄ ⊗ exp(ω̃ Δt)`,
///    `Σ ← Eᵀ Σ E + σ̃² Δt² I` (E the rotation of ω̃ Δt; the isotropic convolution is exact), and
///    converted back ([`bingham_from_diffusion`]); then the rate's Kalman update
///    `ω̄ ← (σ_U² ω̄ + (σ_A² Δt² + σ_Ω²) g)/D`, `σ_Ω² ← σ_U² (σ_A² Δt² + σ_Ω²)/D`;
/// 2. **accelerometer**: the Bingham parameter `M ← M + M_acc`, the [`direction_matrix`] of the
///    unit gravity direction (reference `(0, 0, 1)`, σ_V), re-diagonalised by
///    [`Bingham::from_natural`] (Bayes' rule is exact in the natural parameter);
/// 3. **magnetometer** (9D): `M ← M + M_mag` with the unit field direction, reference
///    `(0, cos δ, −sin δ)` in ENU ([`field_reference_from`]) and σ_W. The talk takes the earth
///    field as known; here its dip is learned causally: the running mean of `â · m̂` over the
///    samples with a reading so far (one sample's dip would carry its noise into the tilt).
///
/// Steps 1 and 2 are the filter's `predict` with an [`ImuSample`], step 3 its `update` with a
/// magnetometer reading. The first sample initialises the mean (the construction of the BROAD
/// example, [`broad_initial_state`], turned to ENU: from the first magnetometer reading when it
/// comes with the first sample, the sample is then replayed from that start) with the diffusion
/// `σ₀² I` and the rate at `N(0, σ_Ω,0² I)`. Every step is all or nothing.
#[derive(Clone, Debug, PartialEq)]
pub struct TalkFilter {
    params: TalkParams,
    sensors: Sensors,
    interval: f64,
    state: Option<TalkState>,
}

/// The state of an initialised [`TalkFilter`].
#[derive(Clone, Debug, PartialEq)]
struct TalkState {
    bingham: Bingham,
    rate: Vector3<f64>,
    rate_variance: f64,
    /// The last sample's accelerometer, for the dip of the next magnetometer reading.
    acc: Vector3<f64>,
    /// `Σ â · m̂` and the number of readings in it.
    dip: (f64, f64),
    /// The first sample, until a magnetometer reading or the next sample comes.
    first: Option<ImuSample>,
}

impl TalkFilter {
    /// A filter at `rate` Hz using `sensors`, initialised by its first sample.
    ///
    /// # Errors
    /// [`FilterError::Data`] for parameters out of range (as [`TalkParams::validate`]),
    /// [`FilterError::Setting`] for a rate that is not finite and positive.
    pub fn new(params: &TalkParams, sensors: Sensors, rate: f64) -> Result<Self, FilterError> {
        params.validate()?;
        positive_setting("TalkFilter::new", "rate", rate)?;
        Ok(Self {
            params: *params,
            sensors,
            interval: 1.0 / rate,
            state: None,
        })
    }

    /// The Bingham density of q, `None` before the first sample.
    pub fn bingham(&self) -> Option<&Bingham> {
        self.state.as_ref().map(|s| &s.bingham)
    }

    /// The angular-rate estimate ω̄ (rad/s, IMU frame) and its per-axis variance σ_Ω², `None`
    /// before the first sample.
    pub fn rate(&self) -> Option<(Vector3<f64>, f64)> {
        self.state.as_ref().map(|s| (s.rate, s.rate_variance))
    }

    /// The state at the first sample, from its accelerometer and magnetometer readings.
    fn start(&self, acc: &Vector3<f64>, mag: Option<&Vector3<f64>>) -> Result<TalkState, DataError> {
        let origin = "TalkFilter (first sample)";
        let initial = broad_initial_state(acc, mag).ok_or_else(|| {
            bad(
                origin,
                "accelerometer",
                format!("{:?}", acc.as_slice()),
                "a non-zero first reading not parallel to the magnetometer",
            )
        })?;
        let s0 = self.params.initial_sigma * self.params.initial_sigma;
        let bingham =
            bingham_from_diffusion(&(enu_from_nwu() * initial), &(Matrix3::identity() * s0))?;
        Ok(TalkState {
            bingham,
            rate: Vector3::zeros(),
            rate_variance: self.params.initial_rate_sigma * self.params.initial_rate_sigma,
            acc: *acc,
            dip: (0.0, 0.0),
            first: None,
        })
    }

    /// Steps 1 and 2 with a sample, on `state`.
    fn gyro_and_gravity(&self, state: &mut TalkState, sample: &ImuSample) -> Result<(), DataError> {
        let p = &self.params;
        let dt = self.interval;
        let (su, walk, so) = (
            p.gyro_noise * p.gyro_noise,
            p.rate_walk * p.rate_walk * dt * dt,
            state.rate_variance,
        );
        let g = &sample.gyro;
        let denominator = su + walk + so;
        let smoothed = (state.rate * (su + walk) + g * so) / denominator;
        let smoothed_variance = (su + walk) * so / denominator;
        let (mean, covariance) = diffusion_from_bingham(&state.bingham)?;
        let turn = UnitQuaternion::from_scaled_axis(smoothed * dt);
        let e = turn.to_rotation_matrix().into_inner();
        let covariance =
            e.transpose() * covariance * e + Matrix3::identity() * (smoothed_variance * dt * dt);
        state.bingham = bingham_from_diffusion(&(mean * turn), &covariance)?;
        state.rate = (state.rate * su + g * (walk + so)) / denominator;
        state.rate_variance = su * (walk + so) / denominator;
        state.acc = sample.acc;
        if let Some(a) = scaled_unit(&sample.acc) {
            let m = direction_matrix(&a, &Vector3::z(), p.acc_noise)?;
            state.bingham = add_natural(&state.bingham, &m)?;
        }
        Ok(())
    }

    /// Step 3 with a magnetometer reading, on `state`.
    fn field(&self, state: &mut TalkState, mag: &Vector3<f64>) -> Result<(), DataError> {
        let Some(c) = dip_cosine(&state.acc, mag) else {
            return Ok(());
        };
        state.dip = (state.dip.0 + c, state.dip.1 + 1.0);
        let (Some(reference), Some(m)) = (
            field_reference_from(state.dip.0 / state.dip.1),
            scaled_unit(mag),
        ) else {
            return Ok(());
        };
        let matrix = direction_matrix(&m, &reference, self.params.mag_noise)?;
        state.bingham = add_natural(&state.bingham, &matrix)?;
        Ok(())
    }
}

/// The Bingham with natural parameter `M + extra` (symmetrised).
fn add_natural(bingham: &Bingham, extra: &Matrix4<f64>) -> Result<Bingham, DataError> {
    let natural = bingham.natural() + extra;
    Bingham::from_natural((natural + natural.transpose()) * 0.5)
        .map_err(|e| density_error("TalkFilter", &e))
}

/// A step's error as the experiment layer reports it.
fn step_error(e: &DataError) -> OperatorError {
    OperatorError::NotClosed {
        what: "talk filter step (the Bingham left its range: increase the noise settings)",
        value: match e {
            DataError::BadValue { row, .. } => *row as f64,
            _ => f64::NAN,
        },
    }
}

/// The talk's filter on the experiment layer (see [`TalkFilter`]): `predict` is steps 1 and 2,
/// `update` step 3 (ignored in 6D). An update reports its log evidence as 0 (the filter does not
/// compute it) and no NIS.
impl RecursiveFilter for TalkFilter {
    type Input = ImuSample;
    type Measurement = Vector3<f64>;
    type Estimate = AttitudeEstimate;

    fn predict(&mut self, input: &ImuSample) -> Result<(), OperatorError> {
        input.check()?;
        let mut state = if let Some(s) = &self.state {
            TalkState {
                first: None,
                ..s.clone()
            }
        } else {
            TalkState {
                first: Some(*input),
                ..self.start(&input.acc, None).map_err(|e| step_error(&e))?
            }
        };
        self.gyro_and_gravity(&mut state, input)
            .map_err(|e| step_error(&e))?;
        self.state = Some(state);
        Ok(())
    }

    fn update(&mut self, z: &Vector3<f64>) -> Result<Update, OperatorError> {
        check_reading("magnetometer reading", z, MAX_FIELD)?;
        let Some(current) = &self.state else {
            return Err(OperatorError::NotReady {
                what: "talk filter",
                needs: "a first sample (predict) to initialise its mean",
            });
        };
        if self.sensors == Sensors::NineD {
            let state = match current.first {
                // The first sample again, from the start its magnetometer reading gives.
                Some(first) => {
                    let mut s = self.start(&first.acc, Some(z)).map_err(|e| step_error(&e))?;
                    self.gyro_and_gravity(&mut s, &first)
                        .map_err(|e| step_error(&e))?;
                    s
                }
                None => current.clone(),
            };
            let mut state = state;
            self.field(&mut state, z).map_err(|e| step_error(&e))?;
            self.state = Some(state);
        }
        Ok(Update {
            log_evidence: 0.0,
            nis: None,
        })
    }

    /// The Bingham's mode (w ≥ 0) and the world-frame covariance `R Σ Rᵀ` of the moment-matched
    /// `LD(q̄, Σ)` ([`diffusion_from_bingham`]).
    fn estimate(&self) -> Result<AttitudeEstimate, OperatorError> {
        let s = self.state.as_ref().ok_or(OperatorError::NotReady {
            what: "talk filter",
            needs: "a first sample (predict) to initialise its mean",
        })?;
        let (q, body) = diffusion_from_bingham(&s.bingham).map_err(|e| step_error(&e))?;
        let r = q.to_rotation_matrix().into_inner();
        Ok(AttitudeEstimate {
            orientation: q,
            covariance: Some(r * body * r.transpose()),
        })
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

fn covariance_eigen(c: &Matrix3<f64>) -> Result<(Vector3<f64>, Matrix3<f64>), DataError> {
    let origin = "diffusion covariance";
    let scale = c.amax();
    if !c.iter().all(|x| x.is_finite()) || (c - c.transpose()).amax() > 1e-10 * (1.0 + scale) {
        return Err(bad(
            origin,
            "covariance",
            format!("{:?}", c.as_slice()),
            "a finite symmetric matrix (rad^2)",
        ));
    }
    let eigen = SymmetricEigen::new((c + c.transpose()) * 0.5);
    if eigen
        .eigenvalues
        .iter()
        .any(|&v| v < -1e-12 * (1.0 + scale))
    {
        return Err(bad(
            origin,
            "covariance eigenvalues",
            format!("{:?}", eigen.eigenvalues.as_slice()),
            "a positive semi-definite matrix",
        ));
    }
    Ok((eigen.eigenvalues.map(|v| v.max(0.0)), eigen.eigenvectors))
}

fn density_error(origin: &str, e: &DensityError) -> DataError {
    bad(
        origin,
        "Bingham state",
        e.to_string(),
        "a Bingham within the library's range (increase the noise settings)",
    )
}
