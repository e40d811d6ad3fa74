//! The process and measurement models of azimuth alignment, validated once at construction.

use liebayes_operators::OperatorError;
use nalgebra::Vector2;

/// `ṙ = v + w`: velocity integration in platform axes with white noise of PSD `q² I` (q in m/√s), so a
/// step of dt adds `v dt` to the position and `q² dt` to its variance per axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityProcess {
    q2: f64,
}

impl VelocityProcess {
    /// The process with noise density q (m/√s, q ≥ 0).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] unless q is finite and non-negative.
    pub fn new(q: f64) -> Result<Self, OperatorError> {
        if !(q.is_finite() && q >= 0.0) {
            return Err(OperatorError::OutOfRange {
                what: "velocity noise density q (m/sqrt(s))",
                value: q,
                range: "[0, infinity)",
            });
        }
        Ok(Self { q2: q * q })
    }

    /// q².
    pub fn noise_density(&self) -> f64 {
        self.q2
    }
}

/// The input of one propagation step: the velocity v in platform axes over the step dt.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct VelocityInput {
    /// v (m/s), platform axes.
    pub velocity: Vector2<f64>,
    /// dt (s), ≥ 0.
    pub dt: f64,
}

impl VelocityInput {
    /// Checks the input: finite velocity, finite non-negative dt.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] or [`OperatorError::OutOfRange`], saying which.
    pub fn validate(&self) -> Result<(), OperatorError> {
        if let Some(&value) = self.velocity.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "velocity input",
                value,
            });
        }
        if !(self.dt.is_finite() && self.dt >= 0.0) {
            return Err(OperatorError::OutOfRange {
                what: "time step dt",
                value: self.dt,
                range: "[0, infinity)",
            });
        }
        Ok(())
    }
}

/// `z = R(A) r + n`, `n ~ N(0, σ_m² I)`: the position in world axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionMeasurement {
    sigma_m2: f64,
}

impl PositionMeasurement {
    /// The measurement with noise standard deviation σ_m > 0 (m).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] unless σ_m is finite and positive.
    pub fn new(sigma_m: f64) -> Result<Self, OperatorError> {
        if !(sigma_m.is_finite() && sigma_m > 0.0) {
            return Err(OperatorError::OutOfRange {
                what: "position noise standard deviation sigma_m (m)",
                value: sigma_m,
                range: "(0, infinity)",
            });
        }
        Ok(Self {
            sigma_m2: sigma_m * sigma_m,
        })
    }

    /// σ_m².
    pub fn variance(&self) -> f64 {
        self.sigma_m2
    }

    /// The isotropic bound of a non-isotropic noise covariance `R_m`: `σ_m² = λ_max(R_m)`.
    ///
    /// With `R_m ≠ σ² I` the seven-number family is not closed (`docs/filters/azimuth.md`). The exact
    /// filter run with this bound is the exact posterior given `z + n′`, `n′ ~ N(0, λ_max I − R_m)`
    /// independent: a measurement with a little information thrown away, so the filter stays
    /// consistent (conservative) at the price of that information.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for non-finite entries, [`OperatorError::OutOfRange`] unless `R_m`
    /// is symmetric with a positive largest eigenvalue.
    pub fn isotropic_bound(noise: &nalgebra::Matrix2<f64>) -> Result<Self, OperatorError> {
        if let Some(&value) = noise.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "position noise covariance R_m",
                value,
            });
        }
        let asymmetry = (noise[(0, 1)] - noise[(1, 0)]).abs();
        if asymmetry > 1e-12 * noise.amax() {
            return Err(OperatorError::OutOfRange {
                what: "position noise covariance R_m (the value is |R_01 - R_10|)",
                value: asymmetry,
                range: "symmetric matrices",
            });
        }
        let largest = noise.symmetric_eigenvalues().max();
        Self::new(largest.sqrt())
    }
}
