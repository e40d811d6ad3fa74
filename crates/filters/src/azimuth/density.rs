//! [`AzimuthDensity`]: the exact seven-number posterior of azimuth alignment.

use super::estimate::{AzimuthEstimate, AzimuthMoments};
use super::model::{PositionMeasurement, VelocityInput, VelocityProcess};
use liebayes_densities::{DensityError, GenVonMises2, HarmonicGaussian, VonMises, special};
use liebayes_experiments::Estimator;
use liebayes_manifolds::So2;
use liebayes_operators::{Condition, Conditioned, OperatorError, Propagate};
use nalgebra::{Matrix2, Matrix2x3, Vector2};
use std::f64::consts::PI;

/// `p(r, A) = M(A; η) · N(r; a + c cos A − c^× sin A, σ² I)`, with `M(A; η) ∝ exp(η · (cos A, sin A))`
/// von Mises and `u^× = (−u_y, u_x)`. Seven numbers: η, a, c (each in R²) and σ².
///
/// Writing vectors of the plane as complex numbers, `c cos A − c^× sin A = c e^(−iA)`, so given A the
/// position is `a + R(−A) c`: a known offset plus a vector fixed in the world frame, seen in the
/// platform frame. That is why the family is closed (see `docs/filters/azimuth.md`):
///
/// * **update** with z, `S = σ² + σ_m²`, `k = σ²/S`, `1 − k = σ_m²/S`: `p(z | A) = N(z; R(A) a + c, S I)`,
///   so `η⁺ = η + (a · (z − c), a × (z − c)) / S` (no second harmonics), `a⁺ = (1 − k) a`,
///   `c⁺ = (1 − k) c + k z`, `σ²⁺ = (1 − k) σ²`; log evidence
///   `ln p(z) = −ln(2πS) − (|z − c|² + |a|²)/(2S) + ln I₀(|η⁺|) − ln I₀(|η|)`;
/// * **propagation** over dt with velocity v: `a += v dt`, `σ² += q² dt`; η and c unchanged.
///
/// Both steps cost a few nanoseconds and allocate nothing; the log evidence adds two ln I₀. `a × b = a_x b_y − a_y b_x`.
///
/// **Valid range**, kept by every constructor and step: η with a norm κ = |η| up to
/// [`CONCENTRATION_LIMIT`] = 1e300, the components of a and c within
/// ±[`POSITION_LIMIT`] = ±1e150 m and σ² in [2.2e-308, [`VARIANCE_LIMIT`] = 1e300] m² (a positive
/// normal number), so that every moment of [`estimate`](Self::estimate), which holds |c|², is
/// finite; and the estimate's position covariance positive definite in f64 too: its eigenvalues
/// lie between `λ₋ = σ² + |c|²/(2(1 + κ)²)` and `λ₊ = σ² + min(½, 1/κ) |c|²`, and λ₋ must be at
/// least [`SPREAD_RATIO`] = 1e-13 times λ₊ (below, the smaller eigenvalue is lost to the rounding
/// of the larger one and the stored covariance is singular: a measurement 1e29 m from the
/// prediction did that, at κ = 4e29). A step whose result would leave the range (an overflow, a
/// variance that underflows or is lost to that rounding) is refused with an error and leaves the
/// density as it was.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AzimuthDensity {
    angle: VonMises,
    a: Vector2<f64>,
    c: Vector2<f64>,
    sigma2: f64,
}

/// The largest magnitude of a component of a or c (m): their squares stay finite.
pub const POSITION_LIMIT: f64 = 1e150;

/// The largest concentration κ = |η| of the azimuth, the von Mises family's limit.
pub const CONCENTRATION_LIMIT: f64 = 1e300;

/// The largest conditional variance σ² (m²).
pub const VARIANCE_LIMIT: f64 = 1e300;

/// The least ratio of the bounds on the smaller and the larger eigenvalue of the estimate's position
/// covariance (see [`AzimuthDensity`]): 1e-13, about 450 ε, so that the rounding of the stored
/// entries (a few ε of the larger eigenvalue) stays well below the smaller one and its Cholesky
/// factorisation succeeds.
pub const SPREAD_RATIO: f64 = 1e-13;

/// Refuses a non-finite measurement.
pub(super) fn check_measurement(z: &Vector2<f64>) -> Result<(), OperatorError> {
    match z.iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(OperatorError::NonFinite {
            what: "position measurement z",
            value,
        }),
        None => Ok(()),
    }
}

/// `u^× = (−u_y, u_x)`, u turned by +90°.
fn perp(u: &Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-u.y, u.x)
}

/// `a × b = a_x b_y − a_y b_x`.
fn cross(a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Which operation built a density, for the messages of [`AzimuthDensity::validated`].
#[derive(Clone, Copy)]
enum Origin {
    Parts,
    Update,
    Prediction,
}

impl Origin {
    /// What to name for (η, a or c, σ², σ² against the spread the azimuth adds).
    fn names(self) -> [&'static str; 4] {
        match self {
            Origin::Parts => [
                "azimuth density parameter eta",
                "azimuth density parameter a or c (m)",
                "conditional position variance sigma^2 (m^2)",
                "conditional position variance sigma^2 (m^2) against the spread of c",
            ],
            Origin::Update => [
                "eta after the update (it overflows: the measurement is too far from the \
                 prediction for the noise)",
                "a or c after the update (m; the measurement is too large)",
                "sigma^2 after the update (m^2; the measurement noise is too small against the \
                 variance)",
                "sigma^2 after the update (m^2) against the spread of c (the measurement is too \
                 far from the prediction for the noise)",
            ],
            Origin::Prediction => [
                "eta after the prediction",
                "a after the prediction (m; the velocity times dt is too large)",
                "sigma^2 after the prediction (m^2; q^2 dt is too large)",
                "sigma^2 after the prediction (m^2) against the spread of c",
            ],
        }
    }
}

/// The variance σ² of a standard deviation σ given to a constructor: σ in [1.5e-154, 1e150], so
/// that σ² is a positive normal number no larger than [`VARIANCE_LIMIT`].
///
/// # Errors
/// [`OperatorError::OutOfRange`] otherwise, naming `what`.
pub(super) fn variance_of(what: &'static str, sigma: f64) -> Result<f64, OperatorError> {
    let variance = sigma * sigma;
    if sigma > 0.0 && variance.is_normal() && variance <= VARIANCE_LIMIT {
        Ok(variance)
    } else {
        Err(OperatorError::OutOfRange {
            what,
            value: sigma,
            range: "[1.5e-154, 1e150] (its square must be a positive normal number up to 1e300)",
        })
    }
}

impl AzimuthDensity {
    /// The prior: uniform azimuth (η = 0) and `r ~ N(r₀, σ₀² I)` whatever the azimuth (a = r₀, c = 0).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for σ₀ outside [1.5e-154, 1e150] (negative, zero, or with a
    /// square that underflows or exceeds 1e300) or components of r₀ beyond ±1e150;
    /// [`OperatorError::NonFinite`] for a non-finite r₀.
    ///
    /// # Example
    /// ```
    /// use liebayes_filters::azimuth::{AzimuthDensity, PositionMeasurement};
    /// use nalgebra::Vector2;
    /// // The platform at r = (10, 0) in its own axes, turned by an unknown azimuth A.
    /// let prior = AzimuthDensity::new(Vector2::new(10.0, 0.0), 1.0).unwrap();
    /// let sensor = PositionMeasurement::new(0.1).unwrap();
    /// // A world position (0, 10): A is a quarter turn.
    /// let posterior = prior.conditioned(&sensor, &Vector2::new(0.0, 10.0)).unwrap();
    /// let azimuth = posterior.estimate().azimuth.unwrap().angle();
    /// assert!((azimuth - std::f64::consts::FRAC_PI_2).abs() < 1e-2);
    /// // The position variance is the Kalman one, σ₀² σ_m² / (σ₀² + σ_m²).
    /// assert!((posterior.sigma2() - 0.01 / 1.01).abs() < 1e-15);
    /// ```
    pub fn new(r0: Vector2<f64>, sigma0: f64) -> Result<Self, OperatorError> {
        let sigma2 = variance_of("initial position standard deviation sigma_0 (m)", sigma0)?;
        Self::from_parts(Vector2::zeros(), r0, Vector2::zeros(), sigma2)
    }

    /// The density with the given seven numbers.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for non-finite vectors, [`OperatorError::OutOfRange`] outside the
    /// valid range (see the type docs).
    pub fn from_parts(
        eta: Vector2<f64>,
        a: Vector2<f64>,
        c: Vector2<f64>,
        sigma2: f64,
    ) -> Result<Self, OperatorError> {
        Self::validated(eta, a, c, sigma2, Origin::Parts)
    }

    /// The density if the numbers are in the valid range.
    fn validated(
        eta: Vector2<f64>,
        a: Vector2<f64>,
        c: Vector2<f64>,
        sigma2: f64,
        origin: Origin,
    ) -> Result<Self, OperatorError> {
        let [eta_name, ..] = origin.names();
        if let Some(&value) = eta.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: eta_name,
                value,
            });
        }
        // κ = |η| must be in range too (η = (MAX, MAX) has finite components and κ = ∞): the von
        // Mises family's limit is this filter's.
        let angle = VonMises::from_natural(eta).map_err(|_| OperatorError::OutOfRange {
            what: eta_name,
            value: eta.x.hypot(eta.y),
            range: "concentration kappa = |eta| in [0, 1e300]",
        })?;
        Self::with_angle(angle, a, c, sigma2, origin)
    }

    /// The density with a valid angle if a, c and σ² are in the valid range.
    fn with_angle(
        angle: VonMises,
        a: Vector2<f64>,
        c: Vector2<f64>,
        sigma2: f64,
        origin: Origin,
    ) -> Result<Self, OperatorError> {
        let [_, position_name, variance_name, spread_name] = origin.names();
        if let Some(&value) = a.iter().chain(c.iter()).find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: position_name,
                value,
            });
        }
        if let Some(&value) = a.iter().chain(c.iter()).find(|v| v.abs() > POSITION_LIMIT) {
            return Err(OperatorError::OutOfRange {
                what: position_name,
                value,
                range: "[-1e150, 1e150] per component",
            });
        }
        if !(sigma2.is_normal() && sigma2 > 0.0 && sigma2 <= VARIANCE_LIMIT) {
            return Err(OperatorError::OutOfRange {
                what: variance_name,
                value: sigma2,
                range: "[2.2e-308, 1e300] (a positive normal number)",
            });
        }
        // The estimate's Cov r has eigenvalues σ² + A′(κ)|c|² and σ² + (A(κ)/κ)|c|² (see
        // `estimate`), with 1/(2(1 + κ)²) ≤ A′(κ) < A(κ)/κ ≤ min(½, 1/κ). First the bounds σ²
        // and σ² + |c|²/2, which need no κ (its hypot would double the cost of a step); only
        // where they are too far apart the bounds with κ.
        let spread = c.norm_squared();
        if sigma2 < SPREAD_RATIO * (sigma2 + 0.5 * spread)
            && Self::spread_too_large(angle.concentration(), spread, sigma2)
        {
            return Err(OperatorError::OutOfRange {
                what: spread_name,
                value: sigma2,
                range: "sigma^2 + |c|^2 / (2 (1 + kappa)^2) at least 1e-13 (sigma^2 + min(1/2, \
                        1/kappa) |c|^2) (below, the position covariance of the estimate is lost \
                        to rounding)",
            });
        }
        Ok(Self {
            angle,
            a,
            c,
            sigma2,
        })
    }

    /// Whether the bounds `σ² + s/(2(1 + κ)²)` and `σ² + min(½, 1/κ) s` on the eigenvalues of the
    /// estimate's position covariance (s = |c|²) are further apart than [`SPREAD_RATIO`].
    fn spread_too_large(kappa: f64, spread: f64, sigma2: f64) -> bool {
        let smallest = sigma2 + spread * 0.5 / ((1.0 + kappa) * (1.0 + kappa));
        let largest = sigma2 + spread * kappa.recip().min(0.5);
        smallest < SPREAD_RATIO * largest
    }

    /// η, the von Mises natural parameter of p(A).
    pub fn eta(&self) -> Vector2<f64> {
        self.angle.natural()
    }

    /// a, the azimuth-independent part of the conditional mean of r.
    pub fn a(&self) -> &Vector2<f64> {
        &self.a
    }

    /// c, the world-fixed part: the conditional mean is `a + c cos A − c^× sin A = a + R(−A) c`.
    pub fn c(&self) -> &Vector2<f64> {
        &self.c
    }

    /// σ², the conditional variance of each component of r (the same for every A).
    pub fn sigma2(&self) -> f64 {
        self.sigma2
    }

    /// The same density as the general Rao-Blackwellized composite of the densities crate (whose exact
    /// steps are the operators crate's `rao_blackwell`):
    /// `p(A) = GVM₂(η, 0)`, `E[r | A] = B φ(A)` with `B = [a, c, −c^×]`, `Cov[r | A] = σ² I`. Propagating
    /// that composite with the linear process and conditioning it on the rotated measurement
    /// `z = R(A) r + n` gives this filter's seven numbers again, with η₂ = 0 at every step
    /// (`tests/azimuth.rs` checks it at every epoch): this type is the composite's specialisation to
    /// the blog post's prior, stored in seven numbers instead of eleven and updated in a few nanoseconds.
    ///
    /// # Errors
    /// [`DensityError::OutOfRange`] for κ above the generalised von Mises family's
    /// [`GenVonMises2::MAX_CONCENTRATION`] (1e16); the composite's constructor errors otherwise.
    pub fn to_composite(&self) -> Result<HarmonicGaussian<2>, DensityError> {
        HarmonicGaussian::new(
            GenVonMises2::from_natural(self.eta(), Vector2::zeros())?,
            Matrix2x3::from_columns(&[self.a, self.c, -perp(&self.c)]),
            Matrix2::identity() * self.sigma2,
        )
    }

    /// The marginal p(A).
    pub fn azimuth(&self) -> VonMises {
        self.angle
    }

    /// `E[r | A] = a + c cos A − c^× sin A` (finite: a and c are in the valid range).
    pub fn conditional_mean(&self, azimuth: &So2<f64>) -> Vector2<f64> {
        self.a + self.c * azimuth.cos() - perp(&self.c) * azimuth.sin()
    }

    /// The density conditioned on a position measurement (the seven-number recursion, no special
    /// functions: the per-step hot path; [`Condition::condition`] adds the log evidence).
    ///
    /// `1 − k` is computed as `σ_m²/S` and σ²⁺ as the smaller variance times a factor in [½, 1], so
    /// that a measurement far more precise than the prior (σ_m² below ε σ²) still gives σ²⁺ ≈ σ_m²
    /// instead of rounding it to zero.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite z, and [`OperatorError::NonFinite`] or
    /// [`OperatorError::OutOfRange`] when the result would leave the valid range (see the type docs).
    pub fn conditioned(
        &self,
        model: &PositionMeasurement,
        z: &Vector2<f64>,
    ) -> Result<Self, OperatorError> {
        check_measurement(z)?;
        let r = model.variance();
        let s = self.sigma2 + r;
        let (k, keep) = (self.sigma2 / s, r / s);
        let w = z - self.c;
        let sigma2 = if self.sigma2 <= r {
            self.sigma2 * keep
        } else {
            r * k
        };
        Self::validated(
            self.eta() + Vector2::new(self.a.dot(&w), cross(&self.a, &w)) / s,
            self.a * keep,
            self.c * keep + z * k,
            sigma2,
            Origin::Update,
        )
    }

    /// The log evidence of a measurement under this density (before conditioning on it):
    /// `ln p(z) = −ln(2πS) − (|z − c|² + |a|²)/(2S) + ln I₀(|η⁺|) − ln I₀(|η|)`, S = σ² + σ_m², from
    /// `p(z | A) = N(z; R(A) a + c, S I)` integrated against the von Mises.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite z, or when the log evidence overflows (a
    /// measurement too far from the prediction for the noise).
    pub fn log_evidence(
        &self,
        model: &PositionMeasurement,
        z: &Vector2<f64>,
    ) -> Result<f64, OperatorError> {
        check_measurement(z)?;
        let s = self.sigma2 + model.variance();
        let w = z - self.c;
        let eta = self.eta() + Vector2::new(self.a.dot(&w), cross(&self.a, &w)) / s;
        // hypot, not norm: |η| near 1e-300 must not underflow.
        let value = -(2.0 * PI * s).ln() - (w.norm_squared() + self.a.norm_squared()) / (2.0 * s)
            + special::log_i0(eta.x.hypot(eta.y))?
            - special::log_i0(self.eta().x.hypot(self.eta().y))?;
        if !value.is_finite() {
            return Err(OperatorError::NonFinite {
                what: "log evidence of the measurement (it overflows: the measurement is too far \
                       from the prediction for the noise)",
                value,
            });
        }
        Ok(value)
    }

    /// The point estimates, from the first and second circular moments of p(A):
    ///
    /// `E r = a + ρ b₁`, `Cov r = σ² I + A′(κ) b₁ b₁ᵀ + (ρ/κ) b₂ b₂ᵀ`, with ρ = A(κ) = I₁(κ)/I₀(κ),
    /// μ the mean direction and `b₁ = c cos μ − c^× sin μ`, `b₂ = −c sin μ − c^× cos μ` (the columns
    /// of `[c, −c^×]` turned by μ). The coefficients are the variances of `cos(A − μ)` and
    /// `sin(A − μ)`, `A′(κ) = (1 + A₂)/2 − ρ²` and `(1 − A₂)/2 = ρ/κ` (Bessel recurrence), ½ each at
    /// κ = 0; the covariance of the two is zero. So Cov r is σ² I plus two positive semi-definite
    /// terms with non-negative coefficients, **positive definite at every κ by construction**: no
    /// difference of numbers near ½ is formed (A′ is taken at least 0, since it is positive for every
    /// κ and only its rounding could make it negative), and its eigenvalues are at least σ². The
    /// valid range keeps it positive definite as stored too (its eigenvalues within
    /// [`SPREAD_RATIO`] of each other, see [`AzimuthDensity`]).
    ///
    /// `σ_A² = −2 ln ρ` uses, where ρ has lost the digits of 1 − ρ, the expansions
    /// `−2 ln A(κ) = 1/κ + 1/(2κ²) + 11/(24κ³) + O(κ⁻⁴)` for κ ≥ 1e6 and
    /// `−2 ln A(κ) = 2 ln 2 − 2 ln κ + O(κ²)` for κ ≤ 1e-8 (relative error below 1e-18 and 1e-16),
    /// so σ_A is accurate and finite from κ = 5e-324 to κ = 1e300. The mean direction of a subnormal η
    /// is its direction after scaling by its largest component.
    pub fn estimate(&self) -> AzimuthEstimate {
        let eta = self.eta();
        // hypot, not norm: |η| = 1e-300 must not underflow to an unobservable azimuth.
        let kappa = eta.x.hypot(eta.y);
        // κ is the hypot of finite numbers, finite by the valid range: the functions cannot refuse it
        // (their limits at +∞, A = 1 and A′ = 0, are the fallbacks).
        let rho = special::a1(kappa).unwrap_or(1.0);
        let b = Matrix2::from_columns(&[self.c, -perp(&self.c)]);
        let sigma_r = Matrix2::identity() * self.sigma2;
        if kappa == 0.0 {
            return AzimuthEstimate {
                azimuth: None,
                rho: 0.0,
                circular_variance: f64::INFINITY,
                mean_r: self.a,
                cov_r: sigma_r + b * b.transpose() * 0.5,
            };
        }
        let scaled = eta / eta.amax();
        let direction = scaled / scaled.norm();
        let (b1, b2) = (b * direction, b * Vector2::new(-direction.y, direction.x));
        let along = special::a1_derivative(kappa).unwrap_or(0.0).max(0.0);
        let across = rho / kappa;
        AzimuthEstimate {
            azimuth: Some(So2::from_angle_unchecked(eta.y.atan2(eta.x))),
            rho,
            circular_variance: circular_variance(kappa, rho),
            mean_r: self.a + b1 * rho,
            cov_r: sigma_r + b1 * b1.transpose() * along + b2 * b2.transpose() * across,
        }
    }
}

/// `−2 ln A(κ)` for κ > 0 and ρ = A(κ) (see [`AzimuthDensity::estimate`]).
fn circular_variance(kappa: f64, rho: f64) -> f64 {
    if kappa >= 1e6 {
        let x = 1.0 / kappa;
        x * (1.0 + x * (0.5 + x * (11.0 / 24.0)))
    } else if kappa <= 1e-8 {
        2.0 * (std::f64::consts::LN_2 - kappa.ln())
    } else {
        -2.0 * rho.ln()
    }
}

impl Propagate<VelocityProcess> for AzimuthDensity {
    type Input = VelocityInput;

    /// Over one step of the velocity process: `a += v dt`, `σ² += q² dt`; η and c unchanged.
    ///
    /// # Errors
    /// As [`VelocityInput::validate`], or [`OperatorError::OutOfRange`] when the result would leave
    /// the valid range (`v dt` or `q² dt` too large).
    fn propagate(
        &self,
        model: &VelocityProcess,
        input: &VelocityInput,
    ) -> Result<Self, OperatorError> {
        input.validate()?;
        // η is unchanged: only a and σ² need checking.
        Self::with_angle(
            self.angle,
            self.a + input.velocity * input.dt,
            self.c,
            self.sigma2 + model.noise_density() * input.dt,
            Origin::Prediction,
        )
    }
}

impl Condition<PositionMeasurement> for AzimuthDensity {
    type Measurement = Vector2<f64>;
    type Report = ();

    /// [`conditioned`](AzimuthDensity::conditioned) with its
    /// [`log_evidence`](AzimuthDensity::log_evidence).
    fn condition(
        &self,
        model: &PositionMeasurement,
        z: &Vector2<f64>,
    ) -> Result<Conditioned<Self>, OperatorError> {
        Ok(Conditioned {
            log_evidence: self.log_evidence(model, z)?,
            posterior: self.conditioned(model, z)?,
            report: (),
        })
    }
}

impl Estimator<AzimuthDensity> for AzimuthMoments {
    type Estimate = AzimuthEstimate;

    /// [`AzimuthDensity::estimate`], checked.
    fn estimate(&self, density: &AzimuthDensity) -> Result<AzimuthEstimate, OperatorError> {
        density.estimate().checked()
    }
}
