//! The two noise models of an angle-of-arrival reading and the rule converting one into the other:
//!
//! * **von Mises-Fisher** (the paper's equation (5), Model II): the reading's unit vector
//!   `u ~ VMF(R d, κ)`, `p(u) = κ/(4π sinh κ) exp(κ uᵀ R d)` on the sphere;
//! * **normal in azimuth and elevation** (equation (4), Model I): `az = az₀ + e_az`,
//!   `el = el₀ + e_el`, `e ~ N(0, σ²)`, reduced to one representation ([`AzEl::canonical`]: past a
//!   pole the elevation is reflected and the azimuth turned by π). As a filter's model it is the
//!   density [`az_el_log_density`]: the azimuth error wrapped and the normal truncated to (−π, π],
//!   the elevation normal truncated to [−π/2, π/2].
//! * the conversion (equation (7)): `σ_az² = σ_el² = 1/κ` for a filter with the angle model on
//!   von Mises-Fisher data, `κ = 1/max(σ_az², σ_el²)` the other way.
//! * [`AdaptiveSigmas`]: the standard deviations of Model I's reduced errors as a function of the
//!   true elevation (the paper's Fig. 1), from which the AE-adaptive filters take their σ.

use super::direction::AzEl;
use liebayes_densities::special::log_normal_mass;
use liebayes_manifolds::wrap_angle;
use liebayes_operators::OperatorError;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;

/// The range of an angle standard deviation σ (rad): below, `1/σ²` overflows as a precision; above,
/// the normal is flat over the circle many times over.
pub const SIGMA_RANGE: (f64, f64) = (1e-9, 1e3);

/// The range of a von Mises-Fisher concentration κ a filter uses: positive (the EKF and the UKF
/// take `1/κ` as a variance) and at most 1e12 (a direction known to 1e-6 rad).
pub const KAPPA_RANGE: (f64, f64) = (1e-12, 1e12);

/// Checks an angle standard deviation (rad) against [`SIGMA_RANGE`].
///
/// # Errors
/// [`OperatorError::NonFinite`] or [`OperatorError::OutOfRange`], naming `what`.
pub fn check_sigma(what: &'static str, sigma: f64) -> Result<f64, OperatorError> {
    if !sigma.is_finite() {
        return Err(OperatorError::NonFinite { what, value: sigma });
    }
    if !(SIGMA_RANGE.0..=SIGMA_RANGE.1).contains(&sigma) {
        return Err(OperatorError::OutOfRange {
            what,
            value: sigma,
            range: "[1e-9, 1e3] rad",
        });
    }
    Ok(sigma)
}

/// Checks a concentration against [`KAPPA_RANGE`].
///
/// # Errors
/// [`OperatorError::NonFinite`] or [`OperatorError::OutOfRange`].
pub fn check_kappa(kappa: f64) -> Result<f64, OperatorError> {
    let what = "von Mises-Fisher concentration kappa";
    if !kappa.is_finite() {
        return Err(OperatorError::NonFinite { what, value: kappa });
    }
    if !(KAPPA_RANGE.0..=KAPPA_RANGE.1).contains(&kappa) {
        return Err(OperatorError::OutOfRange {
            what,
            value: kappa,
            range: "[1e-12, 1e12]",
        });
    }
    Ok(kappa)
}

/// Equation (7), angles to unit vectors: `κ = 1 / max(σ_az², σ_el²)`.
///
/// # Errors
/// As [`check_sigma`] for either σ, and as [`check_kappa`] for the κ (a σ below 1e-6 rad gives a
/// κ above 1e12).
pub fn kappa_from_sigmas(sigma_az: f64, sigma_el: f64) -> Result<f64, OperatorError> {
    let sigma_az = check_sigma("azimuth standard deviation sigma_az (rad)", sigma_az)?;
    let sigma_el = check_sigma("elevation standard deviation sigma_el (rad)", sigma_el)?;
    check_kappa(1.0 / sigma_az.max(sigma_el).powi(2))
}

/// Equation (7), unit vectors to angles: `σ_az = σ_el = 1/√κ`.
///
/// # Errors
/// As [`check_kappa`] for κ, and as [`check_sigma`] for the σ (a κ below 1e-6 gives a σ above
/// 1e3 rad).
pub fn sigma_from_kappa(kappa: f64) -> Result<f64, OperatorError> {
    let kappa = check_kappa(kappa)?;
    check_sigma(
        "angle standard deviation 1/sqrt(kappa) (rad)",
        1.0 / kappa.sqrt(),
    )
}

/// The log density of a canonical reading y given the predicted direction y₀ under the
/// azimuth-elevation model with standard deviations σ_az, σ_el:
///
/// `ln N(wrap_angle(y_az − az₀); 0, σ_az²) − ln[Φ(π/σ_az) − Φ(−π/σ_az)]
///  + ln N(y_el − el₀; 0, σ_el²) − ln[Φ((π/2 − el₀)/σ_el) − Φ((−π/2 − el₀)/σ_el)]`,
///
/// a density in (az, el) on (−π, π] × [−π/2, π/2]; −∞ for a reading's elevation outside that
/// range. Finite for every accepted argument.
///
/// # Errors
/// [`OperatorError::NonFinite`] for a non-finite reading, and as [`AzEl::check_canonical`] for a
/// predicted direction that is not finite or has an elevation outside [−π/2, π/2]; as
/// [`check_sigma`] for a σ outside [`SIGMA_RANGE`].
pub fn az_el_log_density(
    y: &AzEl,
    predicted: &AzEl,
    sigma_az: f64,
    sigma_el: f64,
) -> Result<f64, OperatorError> {
    y.check_finite()?;
    predicted.check_canonical()?;
    let sigmas = AngleSigmas::new(
        check_sigma("sigma_az", sigma_az)?,
        check_sigma("sigma_el", sigma_el)?,
    );
    Ok(sigmas.log_density(y, predicted))
}

/// σ_az and σ_el with the constants of [`az_el_log_density`] that depend on them alone, computed
/// once for a model with fixed σ (the particle filter's hot path).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct AngleSigmas {
    sigma_az: f64,
    sigma_el: f64,
    /// `−ln σ_az − ln √(2π) − ln[Φ(π/σ_az) − Φ(−π/σ_az)]`.
    azimuth_constant: f64,
    /// `−ln σ_el − ln √(2π)`.
    elevation_constant: f64,
}

impl AngleSigmas {
    /// The constants of σ_az, σ_el.
    pub(crate) fn new(sigma_az: f64, sigma_el: f64) -> Self {
        let half_ln_tau = 0.5 * TAU.ln();
        Self {
            sigma_az,
            sigma_el,
            azimuth_constant: -sigma_az.ln()
                - half_ln_tau
                - log_normal_mass(-PI / sigma_az, PI / sigma_az),
            elevation_constant: -sigma_el.ln() - half_ln_tau,
        }
    }

    /// [`az_el_log_density`] of y given the predicted reading.
    pub(crate) fn log_density(&self, y: &AzEl, predicted: &AzEl) -> f64 {
        if y.elevation.abs() > FRAC_PI_2 {
            return f64::NEG_INFINITY;
        }
        let za = self.azimuth_residual(y, predicted);
        let (ze, mass) = self.elevation_residual(y, predicted);
        -0.5 * (za * za + ze * ze) + self.azimuth_constant + self.elevation_constant - mass
    }

    /// The azimuth's part of [`log_density`](Self::log_density) (σ_az alone):
    /// `ln N(wrap(y_az − az₀); 0, σ_az²) − ln[Φ(π/σ_az) − Φ(−π/σ_az)]`.
    pub(crate) fn azimuth_term(&self, y: &AzEl, predicted: &AzEl) -> f64 {
        let za = self.azimuth_residual(y, predicted);
        -0.5 * za * za + self.azimuth_constant
    }

    /// The elevation's part of [`log_density`](Self::log_density) (σ_el alone; −∞ for an
    /// elevation outside [−π/2, π/2]).
    pub(crate) fn elevation_term(&self, y: &AzEl, predicted: &AzEl) -> f64 {
        if y.elevation.abs() > FRAC_PI_2 {
            return f64::NEG_INFINITY;
        }
        let (ze, mass) = self.elevation_residual(y, predicted);
        -0.5 * ze * ze + self.elevation_constant - mass
    }

    /// The wrapped azimuth residual in units of σ_az.
    fn azimuth_residual(&self, y: &AzEl, predicted: &AzEl) -> f64 {
        // Each wrapped first: the difference of two azimuths near ±f64::MAX overflows to ±∞,
        // which wraps to NaN.
        wrap_angle(wrap_angle(y.azimuth) - wrap_angle(predicted.azimuth)) / self.sigma_az
    }

    /// The elevation residual in units of σ_el, and the log of the normal's mass on
    /// [−π/2, π/2] about the predicted elevation.
    fn elevation_residual(&self, y: &AzEl, predicted: &AzEl) -> (f64, f64) {
        let el0 = predicted.elevation;
        let mass = log_normal_mass(
            (-FRAC_PI_2 - el0) / self.sigma_el,
            (FRAC_PI_2 - el0) / self.sigma_el,
        );
        ((y.elevation - el0) / self.sigma_el, mass)
    }
}

/// The grid of [`AdaptiveSigmas`]: every degree of elevation from −90° to 90°.
pub const ADAPTIVE_GRID: usize = 181;

/// The standard deviations of Model I's errors after the reduction to one representation, as a
/// function of the true elevation el₀, on a 1° grid ([`ADAPTIVE_GRID`] points, linear
/// interpolation between them): for the elevation, the standard deviation of
/// `canonical(el₀ + e_el) − el₀` about its mean; for the azimuth, that of
/// `wrap_angle(e_az + π F)`, F = 1 when the reading was flipped over a pole (its mean is 0). Near a pole
/// a flip happens half the time and the azimuth error's standard deviation approaches π/√3 and more
/// (2.13 rad at σ = 10°), where the nominal model says σ_az.
///
/// Computed exactly, not by simulation: on each interval where the reduction is linear, the
/// moments of a normal truncated to it are closed-form (Φ and φ).
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveSigmas {
    sigma_az: Arc<[f64; ADAPTIVE_GRID]>,
    sigma_el: Arc<[f64; ADAPTIVE_GRID]>,
    mean_el: Arc<[f64; ADAPTIVE_GRID]>,
    flip: Arc<[f64; ADAPTIVE_GRID]>,
}

/// `(P, E[e; a<e<b], E[e²; a<e<b])` for `e ~ N(0, σ²)`.
fn truncated_moments(a: f64, b: f64, sigma: f64) -> (f64, f64, f64) {
    let density = |z: f64| {
        if z.is_infinite() {
            (0.0, 0.0)
        } else {
            let phi = (-0.5 * z * z).exp() / TAU.sqrt();
            (phi, z * phi)
        }
    };
    let (za, zb) = (a / sigma, b / sigma);
    let p = (log_normal_mass(za, zb)).exp();
    let ((pa, zpa), (pb, zpb)) = (density(za), density(zb));
    (p, sigma * (pa - pb), sigma * sigma * (p + zpa - zpb))
}

impl AdaptiveSigmas {
    /// The table for Model I data with standard deviations σ_az, σ_el (rad, in [`SIGMA_RANGE`]).
    ///
    /// # Errors
    /// As [`check_sigma`].
    pub fn model_one(sigma_az: f64, sigma_el: f64) -> Result<Self, OperatorError> {
        let sigma_az = check_sigma("azimuth standard deviation sigma_az (rad)", sigma_az)?;
        let sigma_el = check_sigma("elevation standard deviation sigma_el (rad)", sigma_el)?;
        let wrapped = |offset: f64| wrapped_second_moment(offset, sigma_az);
        let (direct, flipped) = (wrapped(0.0), wrapped(PI));
        let mut table = ([0.0; ADAPTIVE_GRID], [0.0; ADAPTIVE_GRID]);
        let (mut means, mut flips) = ([0.0; ADAPTIVE_GRID], [0.0; ADAPTIVE_GRID]);
        for i in 0..ADAPTIVE_GRID {
            let el0 = grid_elevation(i);
            let (mean, variance, flip) = reduced_elevation_error(el0, sigma_el);
            table.0[i] = ((1.0 - flip) * direct + flip * flipped).sqrt();
            table.1[i] = variance.max(0.0).sqrt();
            means[i] = mean;
            flips[i] = flip;
        }
        Ok(Self {
            sigma_az: Arc::new(table.0),
            sigma_el: Arc::new(table.1),
            mean_el: Arc::new(means),
            flip: Arc::new(flips),
        })
    }

    /// `(σ_az, σ_el)` at elevation `el` (rad; clamped to [−π/2, π/2]), interpolated linearly;
    /// `None` for a NaN elevation.
    pub fn at(&self, el: f64) -> Option<(f64, f64)> {
        if el.is_nan() {
            return None;
        }
        let (i, t) = grid_position(el);
        let lerp = |v: &[f64; ADAPTIVE_GRID]| {
            if i + 1 < ADAPTIVE_GRID {
                v[i] + t * (v[i + 1] - v[i])
            } else {
                v[i]
            }
        };
        Some((lerp(&self.sigma_az), lerp(&self.sigma_el)))
    }

    /// The grid elevations (rad) with, at each, `(σ_az, σ_el, E[elevation error], P(flip))`.
    pub fn table(&self) -> impl Iterator<Item = (f64, [f64; 4])> + '_ {
        (0..ADAPTIVE_GRID).map(|i| {
            (
                grid_elevation(i),
                [
                    self.sigma_az[i],
                    self.sigma_el[i],
                    self.mean_el[i],
                    self.flip[i],
                ],
            )
        })
    }
}

/// Grid elevation i (rad): −90° + i°.
fn grid_elevation(i: usize) -> f64 {
    (i as f64 - 90.0).to_radians()
}

/// The grid interval of `el` and the position in it, t ∈ [0, 1].
fn grid_position(el: f64) -> (usize, f64) {
    let degrees = el.clamp(-FRAC_PI_2, FRAC_PI_2).to_degrees() + 90.0;
    let floor = degrees.floor().clamp(0.0, (ADAPTIVE_GRID - 1) as f64);
    // In [0, 180]: exact.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let i = floor as usize;
    (i, (degrees - floor).clamp(0.0, 1.0))
}

/// How many half turns either side of the mean a normal of standard deviation σ is integrated
/// over: 40 σ, at least 2 (the mass beyond 40 σ is below 1e-300).
fn half_turns(sigma: f64) -> i64 {
    // σ ≤ 1e3: at most about 1.3e4 half turns.
    #[allow(clippy::cast_possible_truncation)]
    let n = (40.0 * sigma / PI).ceil() as i64;
    n.max(2)
}

/// `E[wrap_angle(e + offset)²]` for `e ~ N(0, σ²)`: on each turn `[−π − offset + 2kπ, π − offset + 2kπ)`
/// the wrapped value is `e + offset − 2kπ`.
fn wrapped_second_moment(offset: f64, sigma: f64) -> f64 {
    let turns = half_turns(sigma) / 2 + 1;
    (-turns..=turns)
        .map(|k| {
            let shift = offset - TAU * k as f64;
            let (p, m1, m2) = truncated_moments(-PI - shift, PI - shift, sigma);
            m2 + 2.0 * shift * m1 + shift * shift * p
        })
        .sum()
}

/// `(mean, variance, P(flip))` of the reduced elevation error `canonical(el₀ + e) − el₀`,
/// `e ~ N(0, σ²)`: on the half turn `[−π/2 + kπ, π/2 + kπ]` the reduced elevation is
/// `(−1)ᵏ (x − kπ)` and the reading is flipped for odd k.
fn reduced_elevation_error(el0: f64, sigma: f64) -> (f64, f64, f64) {
    let n = half_turns(sigma);
    let (mut m1, mut m2, mut flip) = (0.0, 0.0, 0.0);
    for k in -n..=n {
        let centre = PI * k as f64;
        let (lo, hi) = (centre - FRAC_PI_2 - el0, centre + FRAC_PI_2 - el0);
        let (p, e1, e2) = truncated_moments(lo, hi, sigma);
        // error = s (el0 + e − kπ) − el0 = s e + c.
        let s = if k % 2 == 0 { 1.0 } else { -1.0 };
        let c = s * (el0 - centre) - el0;
        m1 += s * e1 + c * p;
        m2 += e2 + 2.0 * s * c * e1 + c * c * p;
        if k % 2 != 0 {
            flip += p;
        }
    }
    (m1, m2 - m1 * m1, flip)
}
