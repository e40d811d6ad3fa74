//! The strapdown process model ([`Strapdown`]) driven by IMU samples ([`ImuStep`]), and the
//! position fix ([`PositionFix`]), each written once for every [`NavigationState`].

use super::state::{NAVIGATION_DIM, Navigation, NavigationState};
use crate::FilterError;
use crate::attitude::{MAX_ANGULAR_RATE, MAX_SPECIFIC_FORCE};
use crate::error::{SIGMA_RANGE, setting_in};
use liebayes_manifolds::{LieGroup, So3};
use liebayes_operators::{MeasurementModel, OperatorError, ProcessModel};
use nalgebra::{SMatrix, SVector, Vector3};

/// Gravity in the world frame (z up), m/s².
pub const GRAVITY: Vector3<f64> = Vector3::new(0.0, 0.0, -9.81);

/// The largest IMU step accepted (s).
pub const MAX_STEP: f64 = 1.0;

/// The smallest IMU step accepted (s): a rate of 1 MHz, the attitude filters' largest. Below it
/// the noise densities' per-step variances (`σ² / dt`) leave f64's range for a subnormal dt.
pub const MIN_STEP: f64 = 1e-6;

/// The largest norm of an angular rate (rad/s) and of a specific force (m/s²) an [`ImuStep`]
/// accepts: the attitude filters' sensor limits
/// [`MAX_ANGULAR_RATE`](crate::attitude::MAX_ANGULAR_RATE) and
/// [`MAX_SPECIFIC_FORCE`](crate::attitude::MAX_SPECIFIC_FORCE) (both 1e4), applied to the norm
/// as there, so that a reading one application accepts the other does too.
pub const MAX_READING: f64 = MAX_ANGULAR_RATE;

// One limit for both readings, as `MAX_READING` says.
const _: () = assert!(MAX_ANGULAR_RATE == MAX_SPECIFIC_FORCE);

/// The IMU rates (Hz) the inertial application accepts, `[1/MAX_STEP, 1/MIN_STEP]` = [1, 1e6]:
/// the one rate range, that of the steps [`ImuStep::new`] takes, which
/// [`InertialConfig::validate`](super::InertialConfig::validate) checks too.
pub const IMU_RATE_RANGE: (f64, f64) = (1.0 / MAX_STEP, 1.0 / MIN_STEP);

/// The range of the IMU's white noise densities and bias random walks ([`ImuNoise`]): [1e-30, 1e6]
/// (a walk may also be 0). The lower end is the shared standard deviations' (`σ = 1e-30`, far below
/// any sensor's): a density whose square underflows (5e-324 passed) is refused rather than read as
/// no noise. At the upper end the per-step variance `σ²/dt` is at most 1e18 for dt ≥ [`MIN_STEP`].
pub const NOISE_RANGE: (f64, f64) = (SIGMA_RANGE.0, 1e6);

/// The range of a position fix's standard deviation (m, [`PositionFix::new`] and the scenario's
/// `fix_sigma`): [1e-30, 1e6]. At 1e-30 the fix's information `3/σ² = 3e60` is far inside the
/// Gaussians' `tr P⁻¹ ≤ 1e100` (σ = 1e-60 passed and made every fix update fail; σ = 1e-200 made
/// R = 0).
pub const FIX_SIGMA_RANGE: (f64, f64) = (SIGMA_RANGE.0, 1e6);

/// One IMU sample held over a step: the measured angular rate ω̃ (rad/s) and specific force f̃
/// (m/s²), both in the body frame, and the step dt (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuStep {
    angular_rate: Vector3<f64>,
    specific_force: Vector3<f64>,
    dt: f64,
}

impl ImuStep {
    /// The sample, checked: readings finite with a norm at most [`MAX_READING`] = 1e4 (rad/s for
    /// ω̃, m/s² for f̃; the attitude filters' rule), dt in [[`MIN_STEP`], [`MAX_STEP`]] (a rate in
    /// [`IMU_RATE_RANGE`]).
    ///
    /// # Errors
    /// [`FilterError::Setting`] naming the reading or dt.
    pub fn new(
        angular_rate: Vector3<f64>,
        specific_force: Vector3<f64>,
        dt: f64,
    ) -> Result<Self, FilterError> {
        for (setting, reading, limit, expected) in [
            (
                "angular_rate",
                angular_rate,
                MAX_ANGULAR_RATE,
                "finite components, a norm at most 1e4 rad/s (MAX_ANGULAR_RATE)",
            ),
            (
                "specific_force",
                specific_force,
                MAX_SPECIFIC_FORCE,
                "finite components, a norm at most 1e4 m/s^2 (MAX_SPECIFIC_FORCE)",
            ),
        ] {
            // A NaN component makes the norm NaN, an overflow +∞: both fail the comparison.
            if !(reading.iter().all(|v| v.is_finite()) && reading.norm() <= limit) {
                return Err(setting_error(setting, format!("{reading:?}"), expected));
            }
        }
        if !(MIN_STEP..=MAX_STEP).contains(&dt) {
            return Err(setting_error("dt", dt.to_string(), "a step in [1e-6, 1] s"));
        }
        Ok(Self {
            angular_rate,
            specific_force,
            dt,
        })
    }

    /// The sample a sensor of range [`MAX_READING`] reports: a finite reading whose norm exceeds
    /// that range is scaled down to it, its direction kept (a saturating IMU), so that the sample
    /// is one [`new`](Self::new) accepts; for a dt in [[`MIN_STEP`], [`MAX_STEP`]] the caller has
    /// checked.
    pub(crate) fn saturated(
        angular_rate: Vector3<f64>,
        specific_force: Vector3<f64>,
        dt: f64,
    ) -> Self {
        Self {
            angular_rate: saturate(angular_rate, MAX_ANGULAR_RATE),
            specific_force: saturate(specific_force, MAX_SPECIFIC_FORCE),
            dt,
        }
    }

    /// ω̃ (rad/s, body frame).
    pub fn angular_rate(&self) -> &Vector3<f64> {
        &self.angular_rate
    }

    /// f̃ (m/s², body frame).
    pub fn specific_force(&self) -> &Vector3<f64> {
        &self.specific_force
    }

    /// dt (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }
}

/// A finite `v` scaled down to a norm of at most `limit` if it is longer, its direction kept (scaled
/// by its largest component first, so a norm that would overflow does not matter); shortened by a
/// few ulp more where rounding leaves the norm just above the limit.
fn saturate(v: Vector3<f64>, limit: f64) -> Vector3<f64> {
    let scale = v.amax();
    if !(scale.is_finite() && v.norm() > limit) {
        return v;
    }
    let unit = v / scale;
    let mut out = unit * (limit / unit.norm());
    for _ in 0..8 {
        if out.norm() <= limit {
            break;
        }
        out *= 1.0 - f64::EPSILON;
    }
    out
}

/// An [`ImuStep`] setting's error.
fn setting_error(setting: &'static str, value: String, expected: &'static str) -> FilterError {
    FilterError::Setting {
        origin: "inertial::ImuStep",
        setting,
        value,
        expected,
    }
}

/// One strapdown step with the readings of a checked sample held over its dt, corrected by the
/// biases: `ω = ω̃ − b_g`, `a = R (f̃ − b_a) + g`, `R′ = R exp(ω dt)`, `v′ = v + a dt`,
/// `p′ = p + v dt + ½ a dt²`; the biases are unchanged. Exact for readings that are constant over the
/// step in a body whose attitude is constant too (first order in ω dt otherwise).
///
/// # Errors
/// [`OperatorError::NonFinite`] when the state (its fields are public) is not finite or the step
/// overflows it.
pub fn integrate(state: &Navigation, step: &ImuStep) -> Result<Navigation, OperatorError> {
    let next = strapdown(state, &step.angular_rate, &step.specific_force, step.dt);
    let vectors = [
        next.velocity,
        next.position,
        next.gyro_bias,
        next.accel_bias,
    ];
    let values = vectors.iter().flat_map(|v| v.iter()).copied();
    if let Some(value) = values
        .chain(next.rotation.to_matrix().iter().copied())
        .find(|v| !v.is_finite())
    {
        return Err(OperatorError::NonFinite {
            what: "navigation state after a strapdown step (a state that is not finite or overflows)",
            value,
        });
    }
    Ok(next)
}

/// [`integrate`]'s step on raw readings, unchecked (the process model's transition, whose result
/// the filters check, its noise Jacobian's perturbed readings, and a scenario's true motion).
pub(crate) fn strapdown(
    state: &Navigation,
    angular_rate: &Vector3<f64>,
    specific_force: &Vector3<f64>,
    dt: f64,
) -> Navigation {
    let rate = angular_rate - state.gyro_bias;
    let acceleration = state.rotation.rotate(&(specific_force - state.accel_bias)) + GRAVITY;
    Navigation {
        rotation: state.rotation.compose(&So3::exp(&(rate * dt))),
        velocity: state.velocity + acceleration * dt,
        position: state.position + state.velocity * dt + acceleration * (0.5 * dt * dt),
        ..*state
    }
}

/// The IMU's noise: white noise densities of the gyroscope (rad/s/√Hz) and the accelerometer
/// (m/s²/√Hz), and the random walks of their biases (rad/s/√s, m/s²/√s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuNoise {
    /// Gyroscope white noise density (rad/s/√Hz).
    pub gyro: f64,
    /// Accelerometer white noise density (m/s²/√Hz).
    pub accel: f64,
    /// Gyroscope bias random walk (rad/s/√s).
    pub gyro_bias_walk: f64,
    /// Accelerometer bias random walk (m/s²/√s).
    pub accel_bias_walk: f64,
}

impl ImuNoise {
    /// Checks the white noise densities against [`NOISE_RANGE`] = [1e-30, 1e6], and the bias walks
    /// too, which may also be 0 (no walk).
    ///
    /// # Errors
    /// [`FilterError::Setting`] naming the density.
    pub fn validate(&self) -> Result<(), FilterError> {
        const ORIGIN: &str = "inertial::ImuNoise";
        for (setting, value) in [("gyro", self.gyro), ("accel", self.accel)] {
            setting_in(
                ORIGIN,
                setting,
                value,
                NOISE_RANGE,
                "a white noise density in [1e-30, 1e6] (its square a normal number)",
            )?;
        }
        for (setting, value) in [
            ("gyro_bias_walk", self.gyro_bias_walk),
            ("accel_bias_walk", self.accel_bias_walk),
        ] {
            if value != 0.0 {
                setting_in(
                    ORIGIN,
                    setting,
                    value,
                    NOISE_RANGE,
                    "0 or a bias random walk in [1e-30, 1e6] (its square a normal number)",
                )?;
            }
        }
        Ok(())
    }
}

/// The strapdown process on any [`NavigationState`] S: the transition is [`integrate`] with the
/// sample's readings, and the Jacobians are in closed form, derived once in the error-state EKF's
/// error e = [δθ; δv; δp; δb_g; δb_a] and carried into S's own error by
/// [`NavigationState::navigation_error`] and its inverse (E, E⁻¹, the identity on the biases):
/// `F = E⁻¹(f(x)) A E(x)`, `G = E⁻¹(f(x)) B`. With Φ = exp(ω dt), Jr the right Jacobian of
/// SO(3) at ω dt, f = f̃ − b_a and R the attitude before the step, the step moves e by
///
/// ```text
/// δθ′ = Φᵀ δθ − Jr dt δb_g                        + Jr dt n_g
/// δv′ = δv − R f̂ dt δθ − R dt δb_a                 + R dt n_a
/// δp′ = δp + dt δv − ½ R f̂ dt² δθ − ½ R dt² δb_a    + ½ R dt² n_a
/// ```
///
/// (f̂ the cross-product matrix; A the coefficients of the errors, B those of the readings' noise
/// n_g, n_a; the biases are unchanged): the exact derivative of the discrete step, not of a
/// continuous-time model. The noise is `Q = G Σ Gᵀ + diag(0, σ_bg² dt I, σ_ba² dt I)` with
/// `Σ = diag(σ_g² I, σ_a² I)/dt` (the white noise densities over one sample): the readings' noise
/// as the state's convention sees it (in the body frame for the error-state EKF's attitude,
/// rotated into the world for a right-invariant error). Being closed forms, F and Q keep their
/// accuracy at any distance from the origin, where central differences lose the position's
/// columns to the rounding of p.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strapdown {
    noise: ImuNoise,
}

impl Strapdown {
    /// The process with the IMU's noise.
    ///
    /// # Errors
    /// As [`ImuNoise::validate`].
    pub fn new(noise: ImuNoise) -> Result<Self, FilterError> {
        noise.validate()?;
        Ok(Self { noise })
    }

    /// The IMU's noise.
    pub fn noise(&self) -> &ImuNoise {
        &self.noise
    }
}

/// The step's Jacobians in the error-state EKF's error e ([`Strapdown`]): A's first nine rows
/// (the biases' rows are the identity's) and B's first nine (the readings' noise moves no bias).
fn navigation_jacobians(
    navigation: &Navigation,
    step: &ImuStep,
) -> (SMatrix<f64, 9, NAVIGATION_DIM>, SMatrix<f64, 9, 6>) {
    let dt = step.dt;
    let rate = (step.angular_rate - navigation.gyro_bias) * dt;
    let force = step.specific_force - navigation.accel_bias;
    let r = navigation.rotation.to_matrix();
    let jr_dt = So3::right_jacobian(&rate) * dt;
    let r_force = r * So3::hat(&force);
    let half_dt2 = 0.5 * dt * dt;
    let mut a = SMatrix::<f64, 9, NAVIGATION_DIM>::zeros();
    a.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&So3::exp(&rate).to_matrix().transpose());
    a.fixed_view_mut::<3, 3>(0, 9).copy_from(&-jr_dt);
    a.fixed_view_mut::<3, 3>(3, 0).copy_from(&(r_force * -dt));
    a.fixed_view_mut::<3, 3>(3, 12).copy_from(&(r * -dt));
    a.fixed_view_mut::<3, 3>(6, 0)
        .copy_from(&(r_force * -half_dt2));
    a.fixed_view_mut::<3, 3>(6, 12).copy_from(&(r * -half_dt2));
    for i in 0..3 {
        a[(3 + i, 3 + i)] = 1.0;
        a[(6 + i, 6 + i)] = 1.0;
        a[(6 + i, 3 + i)] = dt;
    }
    let mut b = SMatrix::<f64, 9, 6>::zeros();
    b.fixed_view_mut::<3, 3>(0, 0).copy_from(&jr_dt);
    b.fixed_view_mut::<3, 3>(3, 3).copy_from(&(r * dt));
    b.fixed_view_mut::<3, 3>(6, 3).copy_from(&(r * half_dt2));
    (a, b)
}

/// `E⁻¹(f(x))`: the map from the error e after the step into S's error
/// ([`NavigationState::from_navigation_error`] at the step's result).
fn error_after_step<S: NavigationState>(
    navigation: &Navigation,
    step: &ImuStep,
) -> SMatrix<f64, 9, 9> {
    S::from_navigation_error(&strapdown(
        navigation,
        &step.angular_rate,
        &step.specific_force,
        step.dt,
    ))
}

/// F's first nine rows, `M = E⁻¹(f(x)) A E(x)` (E acting on the first nine columns; the bias
/// columns are carried by E⁻¹ alone).
fn motion_rows<S: NavigationState>(
    navigation: &Navigation,
    step: &ImuStep,
) -> SMatrix<f64, 9, NAVIGATION_DIM> {
    let (a, _) = navigation_jacobians(navigation, step);
    let mut motion = error_after_step::<S>(navigation, step) * a;
    let errors = motion.fixed_columns::<9>(0) * S::navigation_error(navigation);
    motion.fixed_columns_mut::<9>(0).copy_from(&errors);
    motion
}

impl<S: NavigationState> ProcessModel<S, NAVIGATION_DIM> for Strapdown {
    type Input = ImuStep;

    fn transition(&self, x: &S, input: &ImuStep) -> S {
        S::from_navigation(&strapdown(
            &x.navigation(),
            &input.angular_rate,
            &input.specific_force,
            input.dt,
        ))
    }

    /// The closed form of [`Strapdown`]: `F = [M; 0, I]`, `M = E⁻¹(f(x)) A E(x)`.
    fn jacobian(&self, x: &S, input: &ImuStep) -> SMatrix<f64, NAVIGATION_DIM, NAVIGATION_DIM> {
        let mut f = SMatrix::<f64, NAVIGATION_DIM, NAVIGATION_DIM>::identity();
        f.fixed_rows_mut::<9>(0)
            .copy_from(&motion_rows::<S>(&x.navigation(), input));
        f
    }

    /// `P Fᵀ` and `F P Fᵀ` with F's bias rows `[0, I]` skipped: `P Fᵀ = [P Mᵀ, P_b]` (P_b the bias
    /// columns of P) and `F (P Fᵀ) = [M (P Fᵀ); its bias rows]`, 4 050 multiplications where the
    /// dense products take 6 750.
    fn propagate_covariance(
        &self,
        x: &S,
        input: &ImuStep,
        p: &SMatrix<f64, NAVIGATION_DIM, NAVIGATION_DIM>,
    ) -> (
        SMatrix<f64, NAVIGATION_DIM, NAVIGATION_DIM>,
        SMatrix<f64, NAVIGATION_DIM, NAVIGATION_DIM>,
    ) {
        let motion = motion_rows::<S>(&x.navigation(), input);
        let mut cross = *p;
        cross
            .fixed_columns_mut::<9>(0)
            .copy_from(&(p * motion.transpose()));
        let mut propagated = cross;
        propagated
            .fixed_rows_mut::<9>(0)
            .copy_from(&(motion * cross));
        (propagated, cross)
    }

    fn noise(&self, x: &S, input: &ImuStep) -> SMatrix<f64, NAVIGATION_DIM, NAVIGATION_DIM> {
        let navigation = x.navigation();
        let (_, b) = navigation_jacobians(&navigation, input);
        let g = error_after_step::<S>(&navigation, input) * b;
        let (gyro, accel) = (self.noise.gyro, self.noise.accel);
        let reading_variance = SVector::<f64, 6>::from_fn(|i, _| {
            let density = if i < 3 { gyro } else { accel };
            density * density / input.dt
        });
        let scaled = g * SMatrix::from_diagonal(&reading_variance);
        let mut q = SMatrix::<f64, NAVIGATION_DIM, NAVIGATION_DIM>::zeros();
        let readings = scaled * g.transpose();
        q.fixed_view_mut::<9, 9>(0, 0)
            .copy_from(&((readings + readings.transpose()) * 0.5));
        let (gyro_walk, accel_walk) = (self.noise.gyro_bias_walk, self.noise.accel_bias_walk);
        for i in 0..3 {
            q[(9 + i, 9 + i)] = gyro_walk * gyro_walk * input.dt;
            q[(12 + i, 12 + i)] = accel_walk * accel_walk * input.dt;
        }
        q
    }
}

/// A position fix `z = p + n`, `n ~ N(0, σ² I)` (world frame, m), on any [`NavigationState`], with
/// H in closed form in the state's own error convention.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionFix {
    sigma: f64,
}

impl PositionFix {
    /// The fix with standard deviation σ per axis (m), in [`FIX_SIGMA_RANGE`] = [1e-30, 1e6].
    ///
    /// # Errors
    /// [`FilterError::Setting`] for a σ outside that range.
    pub fn new(sigma: f64) -> Result<Self, FilterError> {
        setting_in(
            "inertial::PositionFix",
            "sigma",
            sigma,
            FIX_SIGMA_RANGE,
            "a standard deviation in [1e-30, 1e6] m (3/sigma^2 a Gaussian's information)",
        )?;
        Ok(Self { sigma })
    }

    /// σ (m).
    pub fn sigma(&self) -> f64 {
        self.sigma
    }
}

impl<S: NavigationState> MeasurementModel<S, NAVIGATION_DIM, 3> for PositionFix {
    fn predict(&self, x: &S) -> Vector3<f64> {
        x.navigation().position
    }

    fn noise(&self, _: &S) -> SMatrix<f64, 3, 3> {
        SMatrix::identity() * (self.sigma * self.sigma)
    }

    /// `H = [E_p, 0]`, E_p the position rows of [`NavigationState::navigation_error`] (δp = E_p ξ;
    /// the biases do not move the position): `[0, 0, I]` in the error-state EKF's `[δθ; δv; δp]`,
    /// `[R, 0, 0]` and `[I, −p̂, 0]` in SE₂(3)'s `[ρ; φ; ν]` for the left- and right-invariant errors.
    fn jacobian(&self, x: &S) -> SMatrix<f64, 3, NAVIGATION_DIM> {
        let mut h = SMatrix::<f64, 3, NAVIGATION_DIM>::zeros();
        h.fixed_columns_mut::<9>(0)
            .copy_from(&S::navigation_error(&x.navigation()).fixed_rows::<3>(6));
        h
    }
}
