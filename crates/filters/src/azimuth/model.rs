//! The process and measurement models of azimuth alignment, validated once at construction.

use super::density::{VARIANCE_LIMIT, variance_of};
use liebayes_operators::OperatorError;
use nalgebra::Vector2;

/// `ṙ = v + w`: velocity integration in platform axes with white noise of PSD `q² I` (q in m/√s), so a
/// step of dt adds `v dt` to the position and `q² dt` to its variance per axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityProcess {
    q2: f64,
}

impl VelocityProcess {
    /// The process with noise density q in [0, 1e150] m/√s, so that q² is at most 1e300 (a q whose
    /// square underflows is a deterministic process, as q = 0). The exact density steps with any
    /// of these; a filter built from settings ([`exact`](super::exact), [`ekf`](super::ekf), …)
    /// takes q up to 1e49 ([`SETTING_SIGMA_RANGE`]), the range the Gaussian baselines can run.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for q negative, NaN or above 1e150.
    pub fn new(q: f64) -> Result<Self, OperatorError> {
        let q2 = q * q;
        if !(q >= 0.0 && q2 <= VARIANCE_LIMIT) {
            return Err(OperatorError::OutOfRange {
                what: "velocity noise density q (m/sqrt(s))",
                value: q,
                range: "[0, 1e150] (q^2 must be at most 1e300)",
            });
        }
        Ok(Self { q2 })
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
    /// Checks the input: finite velocity, finite non-negative dt, and a displacement `|v| dt` of at
    /// most [`POSITION_LIMIT`](super::POSITION_LIMIT) = 1e150 m (the positions' range: a step
    /// beyond it would leave every filter's second moments overflowing).
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
        let displacement = self.velocity.amax() * self.dt;
        if displacement > super::POSITION_LIMIT {
            return Err(OperatorError::OutOfRange {
                what: "displacement |v| dt of the step (m)",
                value: displacement,
                range: "[0, 1e150]",
            });
        }
        Ok(())
    }
}

/// `z = R(A) r + n`, `n ~ N(0, σ_m² I)`: the position in world axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionMeasurement {
    sigma_m2: f64,
    /// `ln(2π σ_m²)`, the likelihood's normaliser.
    log_normaliser: f64,
}

impl PositionMeasurement {
    /// The measurement with noise standard deviation σ_m in [1.5e-154, 1e150] m, so that σ_m² is a
    /// positive normal number up to 1e300 (σ_m = 1e-200 would square to zero: a measurement claiming
    /// to be exact, which the recursion cannot divide by). The exact density conditions on any of
    /// these; a filter built from settings ([`exact`](super::exact), [`ekf`](super::ekf), …) takes
    /// σ_m in [`SETTING_SIGMA_RANGE`] = [1e-49, 1e49], the range the Gaussian baselines can run.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for σ_m outside that range (zero, negative, NaN, infinite).
    pub fn new(sigma_m: f64) -> Result<Self, OperatorError> {
        let sigma_m2 = variance_of("position noise standard deviation sigma_m (m)", sigma_m)?;
        Ok(Self {
            sigma_m2,
            log_normaliser: (2.0 * std::f64::consts::PI * sigma_m2).ln(),
        })
    }

    /// σ_m².
    pub fn variance(&self) -> f64 {
        self.sigma_m2
    }

    /// `ln(2π σ_m²)`: the log-likelihood of z is `−|z − R(A) r|² / (2σ_m²) − ln(2π σ_m²)`.
    pub fn log_normaliser(&self) -> f64 {
        self.log_normaliser
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
    /// is symmetric (to 1e-12 of its largest entry) and positive semi-definite (its smallest
    /// eigenvalue at least −1e-12 times its largest entry), or when `√λ_max` is outside the range of
    /// [`new`](Self::new).
    pub fn isotropic_bound(noise: &nalgebra::Matrix2<f64>) -> Result<Self, OperatorError> {
        if let Some(&value) = noise.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "position noise covariance R_m",
                value,
            });
        }
        let scale = noise.amax();
        let asymmetry = (noise[(0, 1)] - noise[(1, 0)]).abs();
        if asymmetry > 1e-12 * scale {
            return Err(OperatorError::OutOfRange {
                what: "position noise covariance R_m (the value is |R_01 - R_10|)",
                value: asymmetry,
                range: "symmetric matrices",
            });
        }
        // The eigenvalues (m ± h) of the symmetric part, in closed form on the matrix scaled to
        // unit size so that nothing overflows: m = (p + r)/2, h = hypot((p − r)/2, q).
        let unit = if scale > 0.0 { noise / scale } else { *noise };
        let (p, r, q) = (
            unit[(0, 0)],
            unit[(1, 1)],
            0.5 * (unit[(0, 1)] + unit[(1, 0)]),
        );
        let (m, h) = (0.5 * (p + r), (0.5 * (p - r)).hypot(q));
        if m - h < -1e-12 {
            return Err(OperatorError::OutOfRange {
                what: "position noise covariance R_m (the value is its smallest eigenvalue)",
                value: (m - h) * scale,
                range: "positive semi-definite matrices",
            });
        }
        Self::new(((m + h) * scale).sqrt())
    }
}

/// The range of every standard deviation an azimuth filter is built with, the same for all six
/// constructors ([`exact`](super::exact), [`ekf`](super::ekf), [`ukf`](super::ukf),
/// [`grid_filter`](super::grid_filter), [`marginalized_filter`](super::marginalized_filter),
/// [`particle_filter`](super::particle_filter)) and for [`Config::validate`](super::Config::validate):
/// the prior's σ₀, the measurement's σ_m and the process noise density q (m/√s, which may also be
/// 0) in [1e-49, 1e49], so that σ² is in [1e-98, 1e98].
///
/// It is the range the Gaussian-based baselines can run, with a margin of 100 for the steps: their
/// Gaussians take covariance entries and inverse entries (or `tr P⁻¹`) up to
/// [`MAX_SCALE`](liebayes_densities::MAX_SCALE) = 1e100, so σ₀ = 1e-51 made the EKF's prior
/// `tr P⁻¹ = 2e102` and σ_m below about 1.4e-50 made every update fail, while the exact and the
/// particle filters took σ down to 1.5e-154. The exact filter's own types keep their wider range
/// ([`AzimuthDensity::new`](super::AzimuthDensity::new), [`PositionMeasurement::new`],
/// [`VelocityProcess::new`]); this range applies where a filter is built from settings.
///
/// The range bounds each setting (and so the Gaussians they make); it does not bound their
/// ratios. Settings many orders of magnitude apart (a prior or a process noise 1e49 times the
/// measurement noise) leave the EKF's and the UKF's covariances too ill-conditioned for f64 once
/// a measurement pins the position down: a step of theirs then fails with an error, at run time.
pub const SETTING_SIGMA_RANGE: (f64, f64) = (1e-49, 1e49);

/// The largest magnitude of a component of the prior mean r₀ (m) an azimuth filter is built
/// with: [`MAX_SCALE`](liebayes_densities::MAX_SCALE) = 1e100, the mean limit of the grid's and
/// the marginalized filter's Gaussians, for all six constructors.
pub const PRIOR_POSITION_LIMIT: f64 = liebayes_densities::MAX_SCALE;

/// `Ok(σ²)` for a standard deviation `sigma` in [`SETTING_SIGMA_RANGE`] (NaN refused), else
/// [`OperatorError::OutOfRange`] naming `what`.
pub(super) fn sigma_setting(what: &'static str, sigma: f64) -> Result<f64, OperatorError> {
    let (low, high) = SETTING_SIGMA_RANGE;
    if (low..=high).contains(&sigma) {
        Ok(sigma * sigma)
    } else {
        Err(OperatorError::OutOfRange {
            what,
            value: sigma,
            range: "[1e-49, 1e49] (the range every azimuth filter, the Gaussian ones included, \
                    can run)",
        })
    }
}

/// The settings check of all six azimuth filter constructors: the prior r₀ (finite, components
/// within ±[`PRIOR_POSITION_LIMIT`]) and σ₀, the measurement's σ_m and the process's q in
/// [`SETTING_SIGMA_RANGE`] (q may be 0). Returns σ₀².
///
/// # Errors
/// [`OperatorError::NonFinite`] for a non-finite r₀, [`OperatorError::OutOfRange`] for any other
/// setting out of its range, naming it.
pub(super) fn check_filter_settings(
    process: VelocityProcess,
    measurement: &PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
) -> Result<f64, OperatorError> {
    let (low, high) = SETTING_SIGMA_RANGE;
    let variance0 = sigma_setting("initial position standard deviation sigma_0 (m)", sigma0)?;
    if let Some(&value) = r0.iter().find(|v| !v.is_finite()) {
        return Err(OperatorError::NonFinite {
            what: "initial position r_0",
            value,
        });
    }
    if let Some(&value) = r0.iter().find(|v| v.abs() > PRIOR_POSITION_LIMIT) {
        return Err(OperatorError::OutOfRange {
            what: "initial position r_0 (m, a component)",
            value,
            range: "[-1e100, 1e100] per component",
        });
    }
    // The models store squares: compare them with the range's squares (rounding is monotone, so a
    // σ in the range always passes).
    let sigma_m2 = measurement.variance();
    if !(low * low..=high * high).contains(&sigma_m2) {
        return Err(OperatorError::OutOfRange {
            what: "position noise standard deviation sigma_m (m) of the filter's measurement model",
            value: sigma_m2.sqrt(),
            range: "[1e-49, 1e49] (the range every azimuth filter, the Gaussian ones included, \
                    can run)",
        });
    }
    if process.noise_density() > high * high {
        return Err(OperatorError::OutOfRange {
            what: "velocity noise density q (m/sqrt(s)) of the filter's process model",
            value: process.noise_density().sqrt(),
            range: "[0, 1e49] (the range every azimuth filter, the Gaussian ones included, can run)",
        });
    }
    Ok(variance0)
}
