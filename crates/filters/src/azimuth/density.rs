//! [`AzimuthDensity`]: the exact seven-number posterior of azimuth alignment.

use super::model::{PositionMeasurement, VelocityInput, VelocityProcess};
use liebayes_densities::{DensityError, GenVonMises2, HarmonicGaussian, VonMises, special};
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
/// * **update** with z, `S = σ² + σ_m²`, `k = σ²/S`: `p(z | A) = N(z; R(A) a + c, S I)`, so
///   `η⁺ = η + (a · (z − c), a × (z − c)) / S` (no second harmonics), `a⁺ = (1 − k) a`,
///   `c⁺ = (1 − k) c + k z`, `σ²⁺ = (1 − k) σ²`; log evidence
///   `ln p(z) = −ln(2πS) − (|z − c|² + |a|²)/(2S) + ln I₀(|η⁺|) − ln I₀(|η|)`;
/// * **propagation** over dt with velocity v: `a += v dt`, `σ² += q² dt`; η and c unchanged.
///
/// Both steps cost a few nanoseconds and allocate nothing; the log evidence adds two ln I₀. `a × b = a_x b_y − a_y b_x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AzimuthDensity {
    eta: Vector2<f64>,
    a: Vector2<f64>,
    c: Vector2<f64>,
    sigma2: f64,
}

/// Point estimates of an [`AzimuthDensity`] (seed 000's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AzimuthEstimates {
    /// κ = |η|, the azimuth's concentration; 0 when it is unobservable so far.
    pub kappa: f64,
    /// The azimuth's mode (= its circular mean) in (−π, π], `None` when κ = 0 (uniform azimuth).
    pub mode: Option<f64>,
    /// `σ_A = √(−2 ln ρ)` with ρ = I₁(κ)/I₀(κ), the circular standard deviation (a standard deviation in
    /// the usual sense for κ ≳ 5); `None` when κ = 0 (it is infinite).
    pub sigma_a: Option<f64>,
    /// `E r` in platform axes.
    pub mean_r: Vector2<f64>,
    /// `Cov r`.
    pub cov_r: Matrix2<f64>,
}

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

impl AzimuthDensity {
    /// The prior: uniform azimuth (η = 0) and `r ~ N(r₀, σ₀² I)` whatever the azimuth (a = r₀, c = 0).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite r₀, [`OperatorError::OutOfRange`] unless σ₀ is
    /// finite and positive.
    pub fn new(r0: Vector2<f64>, sigma0: f64) -> Result<Self, OperatorError> {
        Self::from_parts(Vector2::zeros(), r0, Vector2::zeros(), sigma0 * sigma0)
    }

    /// The density with the given seven numbers.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for non-finite vectors, [`OperatorError::OutOfRange`] unless σ² is
    /// finite and positive.
    pub fn from_parts(
        eta: Vector2<f64>,
        a: Vector2<f64>,
        c: Vector2<f64>,
        sigma2: f64,
    ) -> Result<Self, OperatorError> {
        if let Some(&value) = eta
            .iter()
            .chain(a.iter())
            .chain(c.iter())
            .find(|v| !v.is_finite())
        {
            return Err(OperatorError::NonFinite {
                what: "azimuth density parameter (eta, a or c)",
                value,
            });
        }
        if !(sigma2.is_finite() && sigma2 > 0.0) {
            return Err(OperatorError::OutOfRange {
                what: "conditional position variance sigma^2",
                value: sigma2,
                range: "(0, infinity)",
            });
        }
        Ok(Self { eta, a, c, sigma2 })
    }

    /// η, the von Mises natural parameter of p(A).
    pub fn eta(&self) -> &Vector2<f64> {
        &self.eta
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
    /// the seed's prior, stored in seven numbers instead of eleven and updated in a few nanoseconds.
    ///
    /// # Errors
    /// Never for a valid density; the composite's constructor errors otherwise.
    pub fn to_composite(&self) -> Result<HarmonicGaussian<2>, DensityError> {
        HarmonicGaussian::new(
            GenVonMises2::from_natural(self.eta, Vector2::zeros())?,
            Matrix2x3::from_columns(&[self.a, self.c, -perp(&self.c)]),
            Matrix2::identity() * self.sigma2,
        )
    }

    /// The marginal p(A).
    ///
    /// # Panics
    /// Never: η is finite by construction and every update keeps it so.
    pub fn azimuth(&self) -> VonMises {
        VonMises::from_natural(self.eta).expect("eta is finite by construction")
    }

    /// `E[r | A] = a + c cos A − c^× sin A`.
    pub fn conditional_mean(&self, azimuth: f64) -> Vector2<f64> {
        let (s, c) = azimuth.sin_cos();
        self.a + self.c * c - perp(&self.c) * s
    }

    /// Conditions on a position measurement in place (the seven-number recursion, no special
    /// functions: this is the per-step hot path). [`Condition::condition`] also returns the log
    /// evidence; [`log_evidence`](Self::log_evidence) gives it alone.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite z (the density is left unchanged).
    pub fn update(
        &mut self,
        model: &PositionMeasurement,
        z: &Vector2<f64>,
    ) -> Result<(), OperatorError> {
        check_measurement(z)?;
        let s = self.sigma2 + model.variance();
        let k = self.sigma2 / s;
        let w = z - self.c;
        self.eta += Vector2::new(self.a.dot(&w), cross(&self.a, &w)) / s;
        self.a *= 1.0 - k;
        self.c = self.c * (1.0 - k) + z * k;
        self.sigma2 *= 1.0 - k;
        Ok(())
    }

    /// The log evidence of a measurement under this density (before conditioning on it):
    /// `ln p(z) = −ln(2πS) − (|z − c|² + |a|²)/(2S) + ln I₀(|η⁺|) − ln I₀(|η|)`, S = σ² + σ_m², from
    /// `p(z | A) = N(z; R(A) a + c, S I)` integrated against the von Mises.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite z.
    pub fn log_evidence(
        &self,
        model: &PositionMeasurement,
        z: &Vector2<f64>,
    ) -> Result<f64, OperatorError> {
        check_measurement(z)?;
        let s = self.sigma2 + model.variance();
        let w = z - self.c;
        let eta = self.eta + Vector2::new(self.a.dot(&w), cross(&self.a, &w)) / s;
        // hypot, not norm: |η| near 1e-300 must not underflow.
        Ok(
            -(2.0 * PI * s).ln() - (w.norm_squared() + self.a.norm_squared()) / (2.0 * s)
                + special::log_i0(eta.x.hypot(eta.y))?
                - special::log_i0(self.eta.x.hypot(self.eta.y))?,
        )
    }

    /// Propagates in place over one step of the velocity process.
    ///
    /// # Errors
    /// As [`VelocityInput::validate`] (the density is left unchanged).
    pub fn predict(
        &mut self,
        model: &VelocityProcess,
        input: &VelocityInput,
    ) -> Result<(), OperatorError> {
        input.validate()?;
        self.a += input.velocity * input.dt;
        self.sigma2 += model.noise_density() * input.dt;
        Ok(())
    }

    /// The point estimates (seed 000), from the first and second circular moments of p(A):
    ///
    /// `E r = a + c C₁ − c^× S₁`, `Cov r = σ² I + B Cov(cos A, sin A) Bᵀ`, `B = [c, −c^×]`, where
    /// `C₁ + i S₁ = ρ₁ e^(iμ)`. `Cov(cos A, sin A)` is formed in the frame of the mean direction μ as
    /// `diag(A′(κ), ρ₁/κ)` (= `((1 + ρ₂)/2 − ρ₁², (1 − ρ₂)/2)` by the Bessel recurrence) rotated by μ,
    /// so its small perpendicular variance at large κ is not a difference of numbers near ½.
    pub fn estimates(&self) -> AzimuthEstimates {
        // hypot, not norm: |η| = 1e-300 must not underflow to an unobservable azimuth.
        let kappa = self.eta.x.hypot(self.eta.y);
        // κ is the hypot of finite numbers: the functions refuse it only where it overflowed to +∞,
        // where their limits are A = 1, 1 − A = 0, A′ = 0.
        let rho = special::a1(kappa).unwrap_or(1.0);
        let (mode, sigma_a, along, across) = if kappa > 0.0 {
            let mu = self.eta.y.atan2(self.eta.x);
            // −2 ln A, as −2 ln(1 − (1 − A)) where A > ½ so that it keeps its digits at large κ.
            let log_rho = if rho > 0.5 {
                (-special::one_minus_a1(kappa).unwrap_or(0.0)).ln_1p()
            } else {
                rho.ln()
            };
            let sigma_a = (-2.0 * log_rho).sqrt();
            (
                Some(mu),
                Some(sigma_a),
                special::a1_derivative(kappa).unwrap_or(0.0),
                rho / kappa,
            )
        } else {
            (None, None, 0.5, 0.5)
        };
        let direction = self.eta / kappa.max(f64::MIN_POSITIVE);
        let (cos_mu, sin_mu) = if kappa > 0.0 {
            (direction.x, direction.y)
        } else {
            (1.0, 0.0)
        };
        let rotation = Matrix2::new(cos_mu, -sin_mu, sin_mu, cos_mu);
        let moments = rotation * Matrix2::new(along, 0.0, 0.0, across) * rotation.transpose();
        let b = Matrix2::from_columns(&[self.c, -perp(&self.c)]);
        let cov_r = Matrix2::identity() * self.sigma2 + b * moments * b.transpose();
        AzimuthEstimates {
            kappa,
            mode,
            sigma_a,
            mean_r: self.a + b * Vector2::new(rho * cos_mu, rho * sin_mu),
            cov_r: (cov_r + cov_r.transpose()) * 0.5,
        }
    }
}

impl Propagate<VelocityProcess> for AzimuthDensity {
    type Input = VelocityInput;

    /// See [`AzimuthDensity::predict`].
    fn propagate(
        &self,
        model: &VelocityProcess,
        input: &VelocityInput,
    ) -> Result<Self, OperatorError> {
        let mut next = *self;
        next.predict(model, input)?;
        Ok(next)
    }
}

impl Condition<PositionMeasurement> for AzimuthDensity {
    type Measurement = Vector2<f64>;
    type Report = ();

    /// See [`AzimuthDensity::update`].
    fn condition(
        &self,
        model: &PositionMeasurement,
        z: &Vector2<f64>,
    ) -> Result<Conditioned<Self>, OperatorError> {
        let log_evidence = self.log_evidence(model, z)?;
        let mut posterior = *self;
        posterior.update(model, z)?;
        Ok(Conditioned {
            posterior,
            log_evidence,
            report: (),
        })
    }
}

/// The azimuth as a point of SO(2), for callers that work on the group.
impl AzimuthEstimates {
    /// The mode as an [`So2`], `None` when κ = 0.
    pub fn mode_rotation(&self) -> Option<So2<f64>> {
        self.mode.map(So2::from_angle_unchecked)
    }
}
