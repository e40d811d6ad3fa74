//! The attitude filter of the talk "Kalman Filtering on SO(3)" (ETRI, 2017), errata corrected: a
//! [`Bingham`] density on the unit quaternion, propagated with the gyroscope through a
//! left-translated diffusion `LD(q̄, Σ)` and updated with the accelerometer and magnetometer by adding
//! the direction-measurement matrices to the Bingham parameter ([`TalkFilter`]).
//!
//! Conventions: q is the IMU frame with respect to East-North-Up (Hamilton, scalar first,
//! `v_ENU = q v_IMU q*`), the talk's `r` being `R(q)ᵀ`; Σ is the covariance of the body-frame
//! deviation, `R = R(q̄) exp([ξ]ₓ)`.

use super::data::check_rate;
use super::data::{MAX_FIELD, check_reading, scaled_unit};
use super::ekf::Sensors;
use super::estimate::{AttitudeEstimate, ImuSample};
use super::madgwick::{broad_initial_state, enu_from_nwu};
use crate::error::{FilterError, positive_setting};
use liebayes_densities::Bingham;
use liebayes_experiments::{RecursiveFilter, Update};
use liebayes_manifolds::{Readable, Su2};
use liebayes_operators::OperatorError;
use nalgebra::{Matrix3, Matrix4, SymmetricEigen, Vector3};

/// The smallest direction noise σ_V, σ_W of [`TalkParams`]. One reading's
/// [`Bingham::from_direction`] of unit vectors has the eigenvalue spread `2/σ²`, which must stay
/// within [`Bingham::MAX_SPREAD`] = 1e12 (σ ≥ 1.414e-6), together with the spread the filter's own
/// state adds: 1e-5 (2 arcseconds, below any real sensor's direction noise) keeps a margin of 50
/// in the spread for it.
const MIN_DIRECTION_NOISE: f64 = 1e-5;

/// The range of [`TalkParams::initial_sigma`] σ₀ (rad): the initial `LD(q̄, σ₀² I)` as a Bingham
/// must have a mode. Below, its spread, about `2/σ₀²`, leaves [`Bingham::MAX_SPREAD`] (near
/// σ₀ = 1.4e-6). Above, the gap of its two largest eigenvalues shrinks like `e^{−σ₀²}` towards
/// the rounding of the eigenvalues beside the spread the accelerometer adds, and from 6.1 rad
/// `e^{−σ₀²}` rounds away altogether (the first step failed at σ₀ = 7). π (a σ of half a turn,
/// already close to uniform over rotations) keeps a margin. A direction noise near its own bound
/// ([`MIN_DIRECTION_NOISE`]) with a large σ₀ can still leave no mode: the rounding is relative to
/// the combined spread, and [`TalkFilter::new`] refuses such a pair with the rate (see
/// [`TalkParams`]).
const INITIAL_SIGMA_RANGE: (f64, f64) = (1.5e-6, std::f64::consts::PI);

/// The noise settings of [`TalkFilter`] (the talk's symbols).
///
/// Each setting has its own range ([`validate`](Self::validate)); at a sampling rate f
/// (Δt = 1/f) [`TalkFilter::new`] also refuses settings whose first step leaves a Bingham
/// without a mode, so that no step could run: it needs
///
/// `σ₀² + V ≤ min(ln(3 σ_V² / (40 ε)), ln 10¹⁰)` rad² (ln 10¹⁰ ≈ 23.0),
///
/// with `V = Δt² w r / (w + r)` the largest rotation variance a step adds, `w = σ_U² + σ_A² Δt²`,
/// `r = max(σ_Ω,0², s*)` and `s* = 2 σ_U² / (1 + √(1 + 4 σ_U² / (σ_A² Δt²)))` (0 for σ_A = 0).
/// A step diffuses by its smoothed rate variance `w σ_Ω² / (w + σ_Ω²)` times Δt², which grows
/// with the rate variance σ_Ω²; that moves monotonically from σ_Ω,0² to the fixed point s* of
/// its update `σ_Ω² ← σ_U² (σ_A² Δt² + σ_Ω²) / (w + σ_Ω²)`, so r is the largest it takes. The
/// first step's diffusion `(σ₀² + V) I` is isotropic, of variance s say: the gap of its
/// Bingham's two largest eigenvalues is about `12 e^{−s}` (its quaternion moments about the mean
/// differ by `e^{−s}`, which near the uniform density's moments of 1/4 is 1/12 of the eigenvalue
/// gap), the accelerometer's reading adds an eigenvalue spread `2/σ_V²` that leaves the
/// heading's gap as it is, and a mode needs the gap above `8 ε` times the spread (the rounding of
/// the eigenvalues): the bound keeps a margin of 10 on that, `12 e^{−s} ≥ 160 ε / σ_V²`. Each step
/// also fits a Bingham to moments ([`Bingham::from_second_moment`]) to a relative residual of
/// 1e-11, below which the gap `e^{−s}` is lost to the fit (the heading's matched variance then
/// wanders from step to step until the mode goes): the bound keeps `e^{−s} ≥ 1e-10`, ten times
/// that. Measured, the largest s whose filter ran 300 still samples without a refused step, in
/// 6D: 12, 21, 30 and 24 rad² at σ_V = 1e-5, 1e-3, 0.2 and 1e150 (where the bound is 10.4, 19.6,
/// 23.0 and 23.0); at 29.9 rad² (σ_V = 0.2) a 6D filter was stuck after 50 to 150 samples. The
/// defaults run down to 0.209 Hz (`V ≈ Δt²` rad², the initial rate variance 1 rad²/s² over the
/// interval).
///
/// The same bound caps every later step: in 6D nothing observes the heading, whose variance keeps
/// growing; each step's diffusion holds its eigenvalues at most at the bound (and at least at
/// [`TalkFilter::MIN_STEP_VARIANCE`]). A rotation variance s about one axis leaves the angle's
/// density within a relative `2 e^{−s/2}` of uniform (a wrapped normal's first Fourier
/// coefficient is `e^{−s/2}`), so at the cap a heading differs from the uniform one the exact
/// filter tends to by at most 1.1 % (cap 10.4 rad², σ_V = 1e-5) to 2e-5 (cap 23 rad²). Without
/// the cap a 6D filter whose steps add much variance (σ_U = 1 rad/s at 1 Hz) lost the mode after
/// 80 samples and refused every later step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TalkParams {
    /// σ_U (rad/s): gyroscope noise per sample, `G_k = Ω_k + U_k`. Finite, > 0.
    pub gyro_noise: f64,
    /// σ_A (rad/s²): the angular-rate random walk, `Ω_k = Ω_(k−1) + A_k Δt`. 0 or in
    /// [1.5e-154, 1e150] (a positive setting: its square a normal number).
    pub rate_walk: f64,
    /// σ_V: accelerometer noise on the unit gravity direction (dimensionless, about rad).
    /// In [1e-5, 1e150] (a smaller σ makes the Bingham nearly as concentrated as it can be).
    pub acc_noise: f64,
    /// σ_W: magnetometer noise on the unit field direction (dimensionless). In [1e-5, 1e150].
    pub mag_noise: f64,
    /// Standard deviation (rad) per axis of the initial diffusion `Σ₀ = σ₀² I`. In [1.5e-6, π]
    /// (the Bingham of the diffusion must have a mode and a spread it can hold).
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
    /// [`FilterError::Setting`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), FilterError> {
        let origin = "TalkParams";
        positive_setting(origin, "gyro_noise", self.gyro_noise)?;
        // 0 (a constant rate) or the shared positive range: a walk whose square underflows is
        // refused rather than read as none.
        if self.rate_walk != 0.0 {
            positive_setting(origin, "rate_walk", self.rate_walk)?;
        }
        for (setting, value) in [("acc_noise", self.acc_noise), ("mag_noise", self.mag_noise)] {
            if !(MIN_DIRECTION_NOISE..=1e150).contains(&value) {
                return Err(FilterError::Setting {
                    origin,
                    setting,
                    value: Readable(value).to_string(),
                    expected: "a direction noise in [1e-5, 1e150] (a smaller one makes a \
                               reading's Bingham nearly as concentrated as it can be)",
                });
            }
        }
        if !(INITIAL_SIGMA_RANGE.0..=INITIAL_SIGMA_RANGE.1).contains(&self.initial_sigma) {
            return Err(FilterError::Setting {
                origin,
                setting: "initial_sigma",
                value: Readable(self.initial_sigma).to_string(),
                expected: "a standard deviation in [1.5e-6, pi] rad (the initial Bingham \
                           must have a mode and a spread it can hold)",
            });
        }
        positive_setting(origin, "initial_rate_sigma", self.initial_rate_sigma)
    }
}

/// The talk's filter. State: a Bingham density on q (IMU w.r.t. ENU), the angular-rate estimate ω̄
/// and its variance σ_Ω². One sample (gyroscope g, accelerometer a, magnetometer m), with
/// `D = σ_U² + σ_A² Δt² + σ_Ω²`:
///
/// 1. **gyroscope**: the rate over the past interval
///    `ω̃ = ((σ_U² + σ_A² Δt²) ω̄ + σ_Ω² g)/D` (the Kalman smoother of `Ω_(k−1)` given `G_k`), with
///    variance `σ̃² = (σ_U² + σ_A² Δt²) σ_Ω² / D`; the Bingham is converted to `LD(q̄, Σ)` by exact
///    moment matching ([`Bingham::to_diffusion_moment_matched`]), turned `q̄ ← q̄ ⊗ exp(ω̃ Δt)`,
///    `Σ ← Eᵀ Σ E + σ̃² Δt² I` (E the rotation of ω̃ Δt; the isotropic convolution is exact), and
///    converted back ([`Bingham::from_diffusion_moment_matched`]); then the rate's Kalman update
///    `ω̄ ← (σ_U² ω̄ + (σ_A² Δt² + σ_Ω²) g)/D`, `σ_Ω² ← σ_U² (σ_A² Δt² + σ_Ω²)/D`;
/// 2. **accelerometer**: the Bingham parameter `M ← M + M_acc`, the natural parameter of
///    [`Bingham::from_direction`] for the unit gravity direction (reference `(0, 0, 1)`, σ_V), re-diagonalised by
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
    /// The largest rotation variance a step's diffusion keeps along any axis (rad²): the bound
    /// in [`TalkParams`].
    variance_cap: f64,
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
    /// The Bingham's moment-matched diffusion `(q̄, Σ)`, found when the state is kept
    /// ([`TalkFilter::commit`]) and used by the next step and the estimate; `None` while a step
    /// changes the Bingham.
    diffusion: Option<(Su2<f64>, Matrix3<f64>)>,
}

impl TalkFilter {
    /// The smallest rotation variance (rad², σ = 0.58 arcseconds) a step's diffusion keeps along any
    /// axis: its Bingham's spread, about `2/σ²`, is then at most a quarter of [`Bingham::MAX_SPREAD`],
    /// which leaves room for the accelerometer's and magnetometer's readings (`2/σ_V² + 2/σ_W²`, at
    /// most 4e10). Without it, the finest direction noise at a high rate (σ_V = 1e-5 at 1 MHz)
    /// concentrated the Bingham past the family's range within 50 samples, and every later step was
    /// refused. The floor only ever widens the density, by far less than any real gyroscope's drift.
    pub const MIN_STEP_VARIANCE: f64 = 4.0 * 2.0 / Bingham::MAX_SPREAD;

    /// A filter at `rate` Hz using `sensors`, initialised by its first sample.
    ///
    /// # Errors
    /// [`FilterError::Setting`] for parameters out of range (as [`TalkParams::validate`]), a rate
    /// outside [`RATE_RANGE`](super::RATE_RANGE), or settings whose first step at this rate
    /// leaves a Bingham without a mode (the bound in [`TalkParams`]), naming the settings and the
    /// rate.
    pub fn new(params: &TalkParams, sensors: Sensors, rate: f64) -> Result<Self, FilterError> {
        params.validate()?;
        check_rate("TalkFilter::new", rate)?;
        let dt = 1.0 / rate;
        let first = params.initial_sigma * params.initial_sigma + largest_step_variance(params, dt);
        let limit = mode_variance_bound(params.acc_noise);
        if first > limit {
            return Err(FilterError::Setting {
                origin: "TalkFilter::new",
                setting: "gyro_noise, rate_walk and initial_rate_sigma at this rate (with \
                          initial_sigma and acc_noise)",
                value: format!(
                    "a first diffusion of {first:e} rad^2 at {rate} Hz, beyond the {limit:.1} \
                     rad^2 whose Bingham keeps a mode"
                ),
                expected: "initial_sigma^2 plus the largest rotation variance a step adds of at \
                           most min(ln(3 acc_noise^2 / (40 eps)), ln 1e10) rad^2 (see TalkParams): \
                           a higher rate or smaller noises",
            });
        }
        Ok(Self {
            params: *params,
            sensors,
            interval: 1.0 / rate,
            variance_cap: limit,
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
    fn start(
        &self,
        acc: &Vector3<f64>,
        mag: Option<&Vector3<f64>>,
    ) -> Result<TalkState, OperatorError> {
        // A magnetometer reading that gives no heading (zero, or parallel to gravity) starts the
        // filter as without one.
        let initial = broad_initial_state(acc, mag)
            .or_else(|| broad_initial_state(acc, None))
            .ok_or(OperatorError::OutOfRange {
                what: "the talk filter's first accelerometer reading (its norm)",
                value: acc.norm(),
                range: "> 0, and not along the sensor's x axis when the magnetometer gives no heading",
            })?;
        let s0 = self.params.initial_sigma * self.params.initial_sigma;
        let bingham = Bingham::from_diffusion_moment_matched(
            &Su2::from_unit_quaternion(enu_from_nwu() * initial),
            &(Matrix3::identity() * s0),
        )?;
        Ok(TalkState {
            bingham,
            rate: Vector3::zeros(),
            rate_variance: self.params.initial_rate_sigma * self.params.initial_rate_sigma,
            acc: *acc,
            dip: (0.0, 0.0),
            first: None,
            diffusion: None,
        })
    }

    /// Keeps `state` if the next step and the estimate can use it: its Bingham has a mode and
    /// the moments of a diffusion ([`Bingham::to_diffusion_moment_matched`] succeeds); else
    /// that error, the filter unchanged.
    fn commit(&mut self, mut state: TalkState) -> Result<(), OperatorError> {
        state.diffusion = Some(state.bingham.to_diffusion_moment_matched()?);
        self.state = Some(state);
        Ok(())
    }

    /// Steps 1 and 2 with a sample, on `state`.
    fn gyro_and_gravity(
        &self,
        state: &mut TalkState,
        sample: &ImuSample,
    ) -> Result<(), OperatorError> {
        let p = &self.params;
        let dt = self.interval;
        let (su, walk, so) = (
            p.gyro_noise * p.gyro_noise,
            p.rate_walk * p.rate_walk * dt * dt,
            state.rate_variance,
        );
        let g = &sample.gyro;
        // Each formula weighs by a ratio in [0, 1], so that nothing overflows beside a walk of
        // up to 1e306 rad²/s².
        let denominator = su + walk + so;
        let smoothed = state.rate + (g - state.rate) * (so / denominator);
        let smoothed_variance = (su + walk) * (so / denominator);
        let (mean, covariance) = match state.diffusion.take() {
            Some(diffusion) => diffusion,
            None => state.bingham.to_diffusion_moment_matched()?,
        };
        let turn = super::rotation(&(smoothed * dt));
        let e = turn.to_rotation_matrix().into_inner();
        let covariance = held_within(
            &(e.transpose() * covariance * e + Matrix3::identity() * (smoothed_variance * dt * dt)),
            Self::MIN_STEP_VARIANCE,
            self.variance_cap,
        )?;
        let turned = Su2::from_unit_quaternion(*mean.as_unit_quaternion() * turn);
        state.bingham = Bingham::from_diffusion_moment_matched(&turned, &covariance)?;
        state.rate = g + (state.rate - g) * (su / denominator);
        state.rate_variance = su * ((walk + so) / denominator);
        state.acc = sample.acc;
        if let Some(a) = scaled_unit(&sample.acc) {
            let m = Bingham::from_direction(&a, &Vector3::z(), p.acc_noise)?.natural();
            state.bingham = add_natural(&state.bingham, &m)?;
        }
        Ok(())
    }

    /// Step 3 with a magnetometer reading, on `state`.
    fn field(&self, state: &mut TalkState, mag: &Vector3<f64>) -> Result<(), OperatorError> {
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
        let matrix = Bingham::from_direction(&m, &reference, self.params.mag_noise)?.natural();
        state.bingham = add_natural(&state.bingham, &matrix)?;
        state.diffusion = None;
        Ok(())
    }
}

/// `V = Δt² w r / (w + r)`, the largest rotation variance a step of the filter at the interval
/// `dt` adds (the derivation is in [`TalkParams`]): `w = σ_U² + σ_A² Δt²`, `r = max(σ_Ω,0², s*)`,
/// `s* = 2 σ_U² / (1 + √(1 + 4 σ_U² / (σ_A² Δt²)))`, in forms that neither overflow nor divide
/// 0 by 0 for validated settings (σ_A = 0 makes `4 σ_U² / 0 = ∞` and s* = 0).
fn largest_step_variance(params: &TalkParams, dt: f64) -> f64 {
    let su = params.gyro_noise * params.gyro_noise;
    let walk = params.rate_walk * params.rate_walk * dt * dt;
    let fixed_point = 2.0 * su / (1.0 + (1.0 + 4.0 * su / walk).sqrt());
    let r = (params.initial_rate_sigma * params.initial_rate_sigma).max(fixed_point);
    dt * dt / (1.0 / (su + walk) + 1.0 / r)
}

/// `min(ln(3 σ_V² / (40 ε)), ln 10¹⁰)` rad², the largest rotation variance along any axis whose
/// Bingham, with the accelerometer's reading added, keeps a mode (the derivation is in
/// [`TalkParams`]).
fn mode_variance_bound(acc_noise: f64) -> f64 {
    (3.0 * acc_noise * acc_noise / (40.0 * f64::EPSILON))
        .ln()
        .min(1e10f64.ln())
}

/// `Σ` with its eigenvalues clamped to `[floor, cap]`: `Σ` itself when they all lie within (the
/// usual case), else `V diag(clamp(λ)) Vᵀ`. An error when the eigendecomposition does not
/// converge within its bound (`Σ` is finite and symmetric here, so it does).
fn held_within(
    covariance: &Matrix3<f64>,
    floor: f64,
    cap: f64,
) -> Result<Matrix3<f64>, OperatorError> {
    let eigen = SymmetricEigen::try_new(*covariance, f64::EPSILON, 1000).ok_or(
        OperatorError::NotPositiveDefinite {
            what: "the talk filter's propagated diffusion (its eigendecomposition did not \
                   converge: check the gyroscope reading)",
        },
    )?;
    if eigen.eigenvalues.iter().all(|l| (floor..=cap).contains(l)) {
        return Ok(*covariance);
    }
    let clamped = eigen.eigenvalues.map(|l| l.clamp(floor, cap));
    Ok(eigen.eigenvectors * Matrix3::from_diagonal(&clamped) * eigen.eigenvectors.transpose())
}

/// The Bingham with natural parameter `M + extra` (symmetrised).
fn add_natural(bingham: &Bingham, extra: &Matrix4<f64>) -> Result<Bingham, OperatorError> {
    let natural = bingham.natural() + extra;
    Ok(Bingham::from_natural(
        (natural + natural.transpose()) * 0.5,
    )?)
}

/// The talk's filter on the experiment layer (see [`TalkFilter`]): `predict` is steps 1 and 2,
/// `update` step 3 (ignored in 6D). An update reports its log evidence as 0 (the filter does not
/// compute it) and no NIS. A step the Bingham family cannot hold (an eigenvalue spread beyond its
/// range: raise the noise settings), or whose Bingham no next step or estimate could use (no
/// mode, or moments of no diffusion: [`Bingham::to_diffusion_moment_matched`]), is an
/// [`OperatorError::Density`], and the filter is unchanged.
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
                ..self.start(&input.acc, None)?
            }
        };
        self.gyro_and_gravity(&mut state, input)?;
        self.commit(state)
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
                    let mut s = self.start(&first.acc, Some(z))?;
                    self.gyro_and_gravity(&mut s, &first)?;
                    s
                }
                None => current.clone(),
            };
            let mut state = state;
            self.field(&mut state, z)?;
            self.commit(state)?;
        }
        Ok(Update {
            log_evidence: 0.0,
            nis: None,
        })
    }

    /// The Bingham's mode (w ≥ 0) and the world-frame covariance `R Σ Rᵀ` of the moment-matched
    /// `LD(q̄, Σ)` ([`Bingham::to_diffusion_moment_matched`]).
    fn estimate(&self) -> Result<AttitudeEstimate, OperatorError> {
        let s = self.state.as_ref().ok_or(OperatorError::NotReady {
            what: "talk filter",
            needs: "a first sample (predict) to initialise its mean",
        })?;
        let (mean, body) = match s.diffusion {
            Some(diffusion) => diffusion,
            None => s.bingham.to_diffusion_moment_matched()?,
        };
        let q = *mean.as_unit_quaternion();
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
