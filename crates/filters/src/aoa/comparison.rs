//! The paper's model comparison (Sec. 4.1, equations (10)–(11), Table 1) and the
//! maximum-likelihood σ of the azimuth-elevation model.
//!
//! The true direction θ is uniform on the unit sphere (one anchor at the origin, R = I) and the
//! reading y is drawn from a [`DataModel`] (Model I: normal with flipping; Model II: von
//! Mises-Fisher). Each filter model's goodness of fit is the expected log density of the reading
//! **as a density in (az, el)**, `L = E[ln p(y_az, y_el | θ)]` (nats), by Monte Carlo over n
//! samples:
//!
//! | model | `ln p(y | θ)` |
//! |---|---|
//! | AE-nominal | [`az_el_log_density`] with the data's σ (Model II data: `σ = 1/√κ`, rule (7)) |
//! | AE-fitted | [`az_el_log_density`] with the maximum-likelihood σ ([`fit_angle_sigmas`]) |
//! | AE-adaptive | [`az_el_log_density`] with σ from [`AdaptiveSigmas::model_one`] at the true elevation |
//! | VMF | `ln VMF(u(y); θ, κ) + ln cos y_el` (κ from rule (7) for Model I data, the data's κ for Model II) |
//!
//! `ln cos y_el` is the area element of the sphere in (az, el) (the paper's `ln sin(y_el + π/2)`),
//! which turns the von Mises-Fisher density on the sphere into a density in the angles. The table's
//! entries are `exp(L_i) / Σ_j exp(L_j)`.

use super::data::{DataModel, angles_of};
use super::direction::AzEl;
use super::noise::{
    AdaptiveSigmas, AngleSigmas, SIGMA_RANGE, az_el_log_density, check_sigma, kappa_from_sigmas,
    sigma_from_kappa,
};
use liebayes_densities::special::vmf_log_normalizer;
use liebayes_operators::OperatorError;
use nalgebra::{Matrix4, Vector3, Vector4};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

/// The largest number of Monte Carlo samples [`compare_models`] and [`fit_angle_sigmas`] accept
/// (2²⁶ ≈ 6.7e7; the fit stores 32 bytes per sample).
pub const MAX_SAMPLES: usize = 1 << 26;

/// The fewest Monte Carlo samples [`compare_models`] and [`fit_angle_sigmas`] accept: every result
/// comes with a standard error, which one sample cannot give (its sample variance is 0/0; the
/// sandwich estimate of the fit is 0, the score of a single term vanishing at its own maximum).
pub const MIN_SAMPLES: usize = 2;

/// The filter models of Table 1, in the order of [`ModelComparison::rows`].
pub const FILTER_MODELS: [&str; 4] = ["AE-nominal", "AE-fitted", "AE-adaptive", "VMF"];

/// One data column of the paper's Table 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperColumn {
    /// `"Model I"` or `"Model II"`.
    pub data: &'static str,
    /// `exp(L)` normalised to sum to one, in the order of [`FILTER_MODELS`] (two decimals).
    pub normalised: [f64; 4],
    /// The AE-fitted model's `(σ_az, σ_el)` (degrees, rounded).
    pub fitted_sigma_deg: (f64, f64),
    /// The VMF model's κ (rounded).
    pub kappa: f64,
}

/// The paper's Table 1: data from Model I (σ = 10°) and from Model II (κ = (180/(10π))² ≈ 32.83).
/// (An independent recomputation finds σ_az ≈ 19.7° for the Model II fit, where the paper prints
/// 21°.)
pub const PAPER_TABLE1: [PaperColumn; 2] = [
    PaperColumn {
        data: "Model I",
        normalised: [0.13, 0.21, 0.33, 0.32],
        fitted_sigma_deg: (18.0, 10.0),
        kappa: 33.0,
    },
    PaperColumn {
        data: "Model II",
        normalised: [0.11, 0.24, 0.30, 0.35],
        fitted_sigma_deg: (21.0, 10.0),
        kappa: 33.0,
    },
];

/// A direction uniform on the unit sphere (a normalised standard normal vector).
fn uniform_direction<R: Rng + ?Sized>(rng: &mut R) -> Vector3<f64> {
    // The norm of three standard normals is zero with probability zero; redraw then (bounded).
    for _ in 0..64 {
        let v: Vector3<f64> = Vector3::from_fn(|_, _| StandardNormal.sample(&mut *rng));
        let n = v.norm();
        if n > 1e-300 && n.is_finite() {
            return v / n;
        }
    }
    Vector3::z()
}

/// Checks a sample count against [[`MIN_SAMPLES`], [`MAX_SAMPLES`]].
fn check_samples(samples: usize) -> Result<(), OperatorError> {
    if samples < MIN_SAMPLES {
        return Err(OperatorError::OutOfRange {
            what: "number of Monte Carlo samples",
            value: samples as f64,
            range: "at least 2, for a standard error (the paper uses 1e5)",
        });
    }
    if samples > MAX_SAMPLES {
        return Err(OperatorError::TooLarge {
            what: "number of Monte Carlo samples",
            value: samples,
            max: MAX_SAMPLES,
        });
    }
    Ok(())
}

/// The maximum-likelihood σ of the azimuth-elevation model, with standard errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngleSigmaFit {
    /// σ_az (rad).
    pub sigma_az: f64,
    /// σ_el (rad).
    pub sigma_el: f64,
    /// The Monte Carlo standard error of σ_az (rad).
    pub sigma_az_se: f64,
    /// The Monte Carlo standard error of σ_el (rad).
    pub sigma_el_se: f64,
    /// The number of readings fitted.
    pub samples: usize,
}

/// Golden-section steps of the 1-D fits: the bracket `ln SIGMA_RANGE` (27.6 wide) shrinks by
/// 0.618 per step, to below 1e-11 in 80.
const GOLDEN_STEPS: usize = 80;

/// The step in ln σ of the central differences of the standard errors.
const DIFFERENCE_STEP: f64 = 1e-4;

/// The maximum of the concave function `f` of `x ∈ [lo, hi]` by golden-section search.
fn golden_maximum(lo: f64, hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (lo, hi);
    let (mut x1, mut x2) = (b - ratio * (b - a), a + ratio * (b - a));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..GOLDEN_STEPS {
        if f1 >= f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - ratio * (b - a);
            f1 = f(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + ratio * (b - a);
            f2 = f(x2);
        }
    }
    if f1 >= f2 { x1 } else { x2 }
}

/// The maximum-likelihood `(σ_az, σ_el)` of the azimuth-elevation model [`az_el_log_density`] for
/// readings `(y, y₀)`: each reading with the true direction it was drawn from (both canonical).
///
/// The log likelihood `Σᵢ ln p(yᵢ | y₀ᵢ; σ_az, σ_el)` is the sum of an azimuth part (σ_az only: the
/// wrapped normal truncated to (−π, π]) and an elevation part (σ_el only: the normal truncated to
/// [−π/2, π/2]); each is concave in `−1/(2σ²)` (an exponential family in it), hence unimodal in
/// ln σ, and is maximised by golden-section search on ln σ over [`SIGMA_RANGE`]. The standard
/// errors are the sandwich (robust: the data need not come from the model) estimate
/// `se(ln σ) = √(Σᵢ sᵢ²) / |Σᵢ hᵢ|` with `sᵢ`, `hᵢ` the first and second derivatives of the i-th
/// term in ln σ (central differences), `se(σ) = σ se(ln σ)`.
///
/// # Errors
/// [`OperatorError::OutOfRange`] for fewer than [`MIN_SAMPLES`] readings, or a reading or a
/// direction that is not finite and canonical (as [`AzEl::check_canonical`]), or a log likelihood
/// flat at the fitted σ (no standard error: readings without noise);
/// [`OperatorError::TooLarge`] above [`MAX_SAMPLES`].
pub fn fit_angle_sigmas_to(pairs: &[(AzEl, AzEl)]) -> Result<AngleSigmaFit, OperatorError> {
    check_samples(pairs.len())?;
    for (y, y0) in pairs {
        y.check_canonical()?;
        y0.check_canonical()?;
    }
    let range = (SIGMA_RANGE.0.ln(), SIGMA_RANGE.1.ln());
    // Checked above, and σ stays in SIGMA_RANGE: the density's own checks are not repeated.
    let term =
        |(y, y0): &(AzEl, AzEl), az: f64, el: f64| AngleSigmas::new(az, el).log_density(y, y0);
    let total = |az: f64, el: f64| pairs.iter().map(|p| term(p, az, el)).sum::<f64>();
    // The other σ is held at 1 rad: its part is a constant of each search.
    let ln_az = golden_maximum(range.0, range.1, |x| total(x.exp(), 1.0));
    let ln_el = golden_maximum(range.0, range.1, |x| total(1.0, x.exp()));
    let se = |ln_sigma: f64, at: &dyn Fn(&(AzEl, AzEl), f64) -> f64| {
        let h = DIFFERENCE_STEP;
        let (mut scores, mut curvature) = (0.0, 0.0);
        for p in pairs {
            let (minus, centre, plus) = (
                at(p, (ln_sigma - h).exp()),
                at(p, ln_sigma.exp()),
                at(p, (ln_sigma + h).exp()),
            );
            scores += ((plus - minus) / (2.0 * h)).powi(2);
            curvature += (plus - 2.0 * centre + minus) / (h * h);
        }
        let se = ln_sigma.exp() * scores.sqrt() / curvature.abs();
        // A flat log likelihood (curvature 0: readings without noise put the maximum at the
        // range's end) has no standard error.
        if curvature < 0.0 && se.is_finite() {
            Ok(se)
        } else {
            Err(OperatorError::OutOfRange {
                what: "curvature of the log likelihood at the fitted sigma",
                value: curvature,
                range: "(-inf, 0): the likelihood is flat there (readings without noise fit a \
                        sigma at the end of SIGMA_RANGE)",
            })
        }
    };
    Ok(AngleSigmaFit {
        sigma_az: ln_az.exp(),
        sigma_el: ln_el.exp(),
        sigma_az_se: se(ln_az, &|p, s| term(p, s, 1.0))?,
        sigma_el_se: se(ln_el, &|p, s| term(p, 1.0, s))?,
        samples: pairs.len(),
    })
}

/// [`fit_angle_sigmas_to`] on `samples` readings drawn from `data` at directions uniform on the
/// sphere (the paper: 1e5).
///
/// # Errors
/// As [`DataModel::validate`]; [`OperatorError::OutOfRange`] below [`MIN_SAMPLES`],
/// [`OperatorError::TooLarge`] above [`MAX_SAMPLES`] or when the readings' memory cannot be
/// allocated (checked before anything is drawn).
pub fn fit_angle_sigmas<R: Rng + ?Sized>(
    data: &DataModel,
    samples: usize,
    rng: &mut R,
) -> Result<AngleSigmaFit, OperatorError> {
    data.validate()?;
    check_samples(samples)?;
    let mut pairs = Vec::new();
    pairs
        .try_reserve_exact(samples)
        .map_err(|_| OperatorError::TooLarge {
            what: "number of Monte Carlo samples (their memory cannot be allocated)",
            value: samples,
            max: MAX_SAMPLES,
        })?;
    for _ in 0..samples {
        let theta = uniform_direction(rng);
        pairs.push((data.sample(&theta, rng)?, angles_of(&theta)?));
    }
    fit_angle_sigmas_to(&pairs)
}

/// One row of Table 1: a filter model's parameters, its L and its normalised `exp(L)`, with Monte
/// Carlo standard errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ComparisonRow {
    /// The filter model (one of [`FILTER_MODELS`]).
    pub model: &'static str,
    /// `(σ_az, σ_el)` (rad) of an AE model with fixed σ; `None` for AE-adaptive and VMF.
    pub sigmas: Option<(f64, f64)>,
    /// κ of the VMF model; `None` for the AE models.
    pub kappa: Option<f64>,
    /// `L`, the mean log density of the readings (nats).
    pub log_likelihood: f64,
    /// Its standard error: the samples' standard deviation / √n.
    pub log_likelihood_se: f64,
    /// `exp(L) / Σ exp(L_j)`.
    pub normalised: f64,
    /// Its standard error by the delta method (with the covariances of the four L, which share
    /// the samples).
    pub normalised_se: f64,
}

/// Table 1 for one data model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelComparison {
    /// The data model's name (`"Model I"`, `"Model II"`).
    pub data: &'static str,
    /// The rows, in the order of [`FILTER_MODELS`].
    pub rows: [ComparisonRow; 4],
    /// The covariance of the four L estimates (nats²; the per-sample covariance / n).
    pub covariance: [[f64; 4]; 4],
    /// The number of samples.
    pub samples: usize,
}

/// Table 1 for readings from `data`: the four models' L over `samples` Monte Carlo draws of
/// (θ uniform on the sphere, y from `data`), with the AE-fitted model's σ `fitted = (σ_az, σ_el)`
/// (rad; from [`fit_angle_sigmas`] on separate draws), the normalised `exp(L)` and their standard
/// errors. The gradient of `pᵢ = exp(Lᵢ)/Σ exp(Lⱼ)` is `∂pᵢ/∂Lⱼ = pᵢ(δᵢⱼ − pⱼ)`, so
/// `Var pᵢ = gᵢᵀ C gᵢ` with C the covariance of the L.
///
/// # Errors
/// As [`DataModel::validate`]; a fitted σ outside [`SIGMA_RANGE`] (as the noise's σ check);
/// [`OperatorError::OutOfRange`] below [`MIN_SAMPLES`], [`OperatorError::TooLarge`] above
/// [`MAX_SAMPLES`]; [`OperatorError::NonFinite`] for a reading exactly at a pole of the anchor (a
/// zero area element: probability zero).
pub fn compare_models<R: Rng + ?Sized>(
    data: &DataModel,
    samples: usize,
    fitted: (f64, f64),
    rng: &mut R,
) -> Result<ModelComparison, OperatorError> {
    data.validate()?;
    check_samples(samples)?;
    let fitted = (
        check_sigma("fitted azimuth standard deviation sigma_az (rad)", fitted.0)?,
        check_sigma(
            "fitted elevation standard deviation sigma_el (rad)",
            fitted.1,
        )?,
    );
    let (nominal, kappa) = match *data {
        DataModel::NormalWithFlip { sigma_az, sigma_el } => {
            ((sigma_az, sigma_el), kappa_from_sigmas(sigma_az, sigma_el)?)
        }
        DataModel::VonMisesFisher { kappa } => {
            let sigma = sigma_from_kappa(kappa)?;
            ((sigma, sigma), kappa)
        }
    };
    let adaptive = AdaptiveSigmas::model_one(nominal.0, nominal.1)?;
    let log_c = vmf_log_normalizer(kappa).map_err(|_| OperatorError::OutOfRange {
        what: "von Mises-Fisher concentration kappa",
        value: kappa,
        range: "[1e-12, 1e12]",
    })?;
    // Welford's running mean and co-moment of the four per-sample log densities.
    let (mut mean, mut comoment) = (Vector4::<f64>::zeros(), Matrix4::<f64>::zeros());
    for i in 0..samples {
        let theta = uniform_direction(rng);
        let y = data.sample(&theta, rng)?;
        let truth = angles_of(&theta)?;
        let (az, el) = adaptive
            .at(truth.elevation)
            .ok_or(OperatorError::NonFinite {
                what: "elevation of a drawn direction",
                value: truth.elevation,
            })?;
        let values = Vector4::new(
            az_el_log_density(&y, &truth, nominal.0, nominal.1)?,
            az_el_log_density(&y, &truth, fitted.0, fitted.1)?,
            az_el_log_density(&y, &truth, az, el)?,
            log_c + kappa * y.unit_vector().dot(&theta) + y.elevation.cos().ln(),
        );
        if let Some(&value) = values.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "log density of a reading (a reading exactly at a pole of the anchor)",
                value,
            });
        }
        let delta = values - mean;
        mean += delta / (i + 1) as f64;
        comoment += delta * (values - mean).transpose();
    }
    // The sample covariance / n: at least two samples, checked above.
    let n = samples as f64;
    let covariance = comoment / ((n - 1.0) * n);
    let peak = mean.max();
    let exp = mean.map(|l| (l - peak).exp());
    let p = exp / exp.sum();
    let rows = std::array::from_fn(|i| {
        let g = Vector4::from_fn(|j, _| p[i] * (f64::from(u8::from(i == j)) - p[j]));
        ComparisonRow {
            model: FILTER_MODELS[i],
            sigmas: match i {
                0 => Some(nominal),
                1 => Some(fitted),
                _ => None,
            },
            kappa: (i == 3).then_some(kappa),
            log_likelihood: mean[i],
            log_likelihood_se: covariance[(i, i)].sqrt(),
            normalised: p[i],
            normalised_se: g.dot(&(covariance * g)).max(0.0).sqrt(),
        }
    });
    Ok(ModelComparison {
        data: data.name(),
        rows,
        covariance: std::array::from_fn(|i| std::array::from_fn(|j| covariance[(i, j)])),
        samples,
    })
}
