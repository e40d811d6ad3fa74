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

/// The step in ln σ of the central differences of the standard errors.
const DIFFERENCE_STEP: f64 = 1e-4;

/// The 1-D fits stop when the maximum is bracketed to this width in ln σ (the Monte Carlo
/// standard error of ln σ is 1e-5 or more up to [`MAX_SAMPLES`] readings).
const FIT_TOLERANCE: f64 = 1e-10;

/// At most this many evaluations a 1-D fit: golden-section steps alone shrink the bracket
/// `ln SIGMA_RANGE` (27.6 wide) below [`FIT_TOLERANCE`] in about 55, and Brent's method takes at
/// most about twice a golden search's steps.
const FIT_STEPS: usize = 100;

/// The maximum of the unimodal function `f` of `x ∈ [lo, hi]`, by Brent's method: the bracket
/// shrinks by a golden-section step, or by a step to the vertex of the parabola through the
/// three best points when that vertex lies inside the bracket and the step is less than half the
/// one before last (so the bracket shrinks at least as a golden search's every two steps). Smooth
/// functions take mostly parabolic steps and converge superlinearly: 19 to 29 evaluations for a
/// normal log likelihood in ln σ, where golden-section steps alone take about 55. Stops when the
/// bracket is within [`FIT_TOLERANCE`] of the best point, after at most [`FIT_STEPS`] evaluations.
fn unimodal_maximum(lo: f64, hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    // (3 − √5)/2: the golden section of a bracket.
    let golden = 0.5 * (3.0 - 5f64.sqrt());
    let (mut a, mut b) = (lo, hi);
    // The best point x, the second best w, the one before v, and their values (of −f, minimised).
    let mut x = a + golden * (b - a);
    let mut fx = -f(x);
    let (mut w, mut fw, mut v, mut fv) = (x, fx, x, fx);
    // The last step, and the one before it.
    let (mut step, mut previous) = (0.0_f64, 0.0_f64);
    let tolerance = 0.5 * FIT_TOLERANCE;
    for _ in 1..FIT_STEPS {
        let middle = 0.5 * (a + b);
        if (x - middle).abs() <= 2.0 * tolerance - 0.5 * (b - a) {
            break;
        }
        let mut parabolic = false;
        if previous.abs() > tolerance {
            // The vertex of the parabola through (v, fv), (w, fw), (x, fx), as x + p/q.
            let r = (x - w) * (fx - fv);
            let t = (x - v) * (fx - fw);
            let mut p = (x - v) * t - (x - w) * r;
            let mut q = 2.0 * (t - r);
            if q > 0.0 {
                p = -p;
            } else {
                q = -q;
            }
            let before_last = previous;
            previous = step;
            if p.abs() < (0.5 * q * before_last).abs() && p > q * (a - x) && p < q * (b - x) {
                step = p / q;
                let u = x + step;
                // Not within the tolerance of the bracket's ends.
                if u - a < 2.0 * tolerance || b - u < 2.0 * tolerance {
                    step = tolerance.copysign(middle - x);
                }
                parabolic = true;
            }
        }
        if !parabolic {
            // Golden section of the larger part of the bracket.
            previous = if x >= middle { a - x } else { b - x };
            step = golden * previous;
        }
        let u = if step.abs() >= tolerance {
            x + step
        } else {
            x + tolerance.copysign(step)
        };
        let fu = -f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, fv) = (w, fw);
            (w, fw) = (x, fx);
            (x, fx) = (u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv) = (w, fw);
                (w, fw) = (u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    x
}

/// The maximum-likelihood `(σ_az, σ_el)` of the azimuth-elevation model [`az_el_log_density`] for
/// readings `(y, y₀)`: each reading with the true direction it was drawn from (both canonical).
///
/// The log likelihood `Σᵢ ln p(yᵢ | y₀ᵢ; σ_az, σ_el)` is the sum of an azimuth part (σ_az only: the
/// wrapped normal truncated to (−π, π]) and an elevation part (σ_el only: the normal truncated to
/// [−π/2, π/2]); each is concave in `−1/(2σ²)` (an exponential family in it), hence unimodal in
/// ln σ, and is maximised on ln σ over [`SIGMA_RANGE`] by Brent's method. The standard
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
    // Checked above, and σ stays in SIGMA_RANGE: the density's own checks are not repeated. The
    // log likelihood is the azimuth's part plus the elevation's, each of one σ, so each search
    // sums its own part (the other σ's value is immaterial: 1 rad), with the σ's constants
    // computed once per σ.
    let azimuth = |sigma: f64| AngleSigmas::new(sigma, 1.0);
    let elevation = |sigma: f64| AngleSigmas::new(1.0, sigma);
    let azimuth_term = |s: &AngleSigmas, (y, y0): &(AzEl, AzEl)| s.azimuth_term(y, y0);
    let elevation_term = |s: &AngleSigmas, (y, y0): &(AzEl, AzEl)| s.elevation_term(y, y0);
    let total = |s: AngleSigmas, term: &dyn Fn(&AngleSigmas, &(AzEl, AzEl)) -> f64| {
        pairs.iter().map(|p| term(&s, p)).sum::<f64>()
    };
    let ln_az = unimodal_maximum(range.0, range.1, |x| total(azimuth(x.exp()), &azimuth_term));
    let ln_el = unimodal_maximum(range.0, range.1, |x| {
        total(elevation(x.exp()), &elevation_term)
    });
    let se = |ln_sigma: f64,
              at: &dyn Fn(f64) -> AngleSigmas,
              term: &dyn Fn(&AngleSigmas, &(AzEl, AzEl)) -> f64| {
        let h = DIFFERENCE_STEP;
        let (minus, centre, plus) = (
            at((ln_sigma - h).exp()),
            at(ln_sigma.exp()),
            at((ln_sigma + h).exp()),
        );
        let (mut scores, mut curvature) = (0.0, 0.0);
        for p in pairs {
            let (minus, centre, plus) = (term(&minus, p), term(&centre, p), term(&plus, p));
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
        sigma_az_se: se(ln_az, &azimuth, &azimuth_term)?,
        sigma_el_se: se(ln_el, &elevation, &elevation_term)?,
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// The maximum and the number of evaluations it took.
    fn counted(lo: f64, hi: f64, f: impl Fn(f64) -> f64) -> (f64, usize) {
        let calls = Cell::new(0);
        let x = unimodal_maximum(lo, hi, |x| {
            calls.set(calls.get() + 1);
            f(x)
        });
        (x, calls.get())
    }

    /// A normal log likelihood in ln σ, `−S e^{−2x}/2 − n x` (maximum at `x = ln √(S/n)`), found
    /// to the rounding of its values in far fewer evaluations than a golden-section search's 55; a
    /// bracket end when the function is monotone; and a flat function stops within its bound.
    #[test]
    fn brent_finds_the_maximum_in_few_evaluations() {
        let range = (SIGMA_RANGE.0.ln(), SIGMA_RANGE.1.ln());
        for (sum, n) in [(4.0, 100.0), (1e-6, 1e4), (3e5, 7.0), (1e-9, 1.0)] {
            let (x, calls) = counted(range.0, range.1, |x| -0.5 * sum * (-2.0 * x).exp() - n * x);
            let exact = (sum / n).sqrt().ln();
            eprintln!(
                "S = {sum}, n = {n}: {calls} evaluations, error {:.1e}",
                x - exact
            );
            assert!((x - exact).abs() < 1e-8, "{x} against {exact}");
            assert!(calls <= 35, "{calls} evaluations");
        }
        let (x, _) = counted(range.0, range.1, |x| x);
        assert!(range.1 - x < 1e-9, "{x}");
        let (x, _) = counted(range.0, range.1, |x| -x);
        assert!(x - range.0 < 1e-9, "{x}");
        let (x, calls) = counted(range.0, range.1, |_| 0.0);
        assert!(
            calls <= FIT_STEPS && (range.0..=range.1).contains(&x),
            "{calls} {x}"
        );
        // A kink: parabolas fit it badly, golden steps still close in.
        let (x, calls) = counted(range.0, range.1, |x| -(x - 0.3).abs());
        eprintln!("kink: {calls} evaluations, error {:.1e}", x - 0.3);
        assert!((x - 0.3).abs() < 1e-9 && calls <= FIT_STEPS);
    }
}
