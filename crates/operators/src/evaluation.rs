//! Evaluation for any filter: the metrics that tell a filter is right. Running the studies (seeded
//! runs, per-epoch series, summaries) is the experiment layer's job; these are the numbers it computes.
//!
//! * [`estimation_error`]: the error of an estimate on its manifold, `estimate ⊟ truth` (an angle
//!   error wraps through SO(2), never by hand).
//! * NEES and NIS: for a consistent filter the normalised error squared `eᵀ P⁻¹ e` of a d-dimensional
//!   state (NEES) or innovation (NIS, with e = ν and P = S) has mean d; averaged over N independent
//!   runs, `N · mean` is χ² with N d degrees of freedom when the posterior is Gaussian, which gives the
//!   95 % band of [`average_nees_band`].
//! * [`circular_consistency`]: the same question for an angle, without a Gaussian assumption.
//!
//! The statistics of many runs (means, RMS, bands of the mean, merged exactly across shards) are the
//! experiment layer's `RunningStats`: one running-statistics type for the whole library.

use crate::OperatorError;
use crate::error::{all_finite, check_size};
use crate::numerics::check_symmetric;
use liebayes_manifolds::Manifold;
use nalgebra::{Cholesky, SMatrix, SVector};

/// The error of an estimate against the truth on their manifold, `e = estimate ⊟ truth`
/// (`truth.local(estimate)`, a tangent vector at the truth): `estimate − truth` on Rⁿ, the angle
/// difference wrapped to (−π, π] on SO(2), the rotation vector of `truth⁻¹ · estimate` on SO(3).
/// NEES and RMSE are computed from it; a covariance held in the tangent space at the estimate (the
/// [`ManifoldGaussian`](liebayes_densities::ManifoldGaussian)'s) agrees with it to first order, and
/// exactly on Rⁿ and SO(2) (up to the sign, which NEES does not see).
///
/// # Example
/// ```
/// use liebayes_operators::evaluation::estimation_error;
/// use liebayes_operators::manifolds::So2;
///
/// // An estimate 0.2 rad past +π against a truth just below it: a small error, not 2π − 0.2.
/// let truth = So2::from_angle_unchecked(3.1);
/// let estimate = So2::from_angle_unchecked(3.3 - 2.0 * std::f64::consts::PI);
/// assert!((estimation_error(&truth, &estimate)[0] - 0.2).abs() < 1e-12);
/// ```
pub fn estimation_error<X: Manifold<D>, const D: usize>(
    truth: &X,
    estimate: &X,
) -> SVector<X::Scalar, D> {
    truth.local(estimate)
}

/// The normalised estimation error squared `eᵀ P⁻¹ e`, by Cholesky.
///
/// # Errors
/// [`OperatorError::NonFinite`] for a non-finite error or covariance entry, or a result that
/// overflows; [`OperatorError::OutOfRange`] when P is not symmetric (to a relative 1e-12);
/// [`OperatorError::NotPositiveDefinite`] when P is not positive definite.
pub fn nees<const D: usize>(
    error: &SVector<f64, D>,
    covariance: &SMatrix<f64, D, D>,
) -> Result<f64, OperatorError> {
    all_finite("estimation error e", error.iter())?;
    all_finite("covariance P of the NEES", covariance.iter())?;
    check_symmetric("covariance P of the NEES", covariance)?;
    let factor = Cholesky::new(*covariance).ok_or(OperatorError::NotPositiveDefinite {
        what: "covariance P of the NEES",
    })?;
    // The factor of a successful Cholesky decomposition has a positive diagonal.
    let value = factor
        .l_dirty()
        .solve_lower_triangular_unchecked(error)
        .norm_squared();
    all_finite(
        "NEES e^T P^-1 e (it overflows: the error is too large for P)",
        [value].iter(),
    )?;
    Ok(value)
}

/// The normalised innovation squared `νᵀ S⁻¹ ν` of a measurement's innovation ν with its predicted
/// covariance S (the same quadratic form as [`nees`]; mean M, the measurement dimension, for a consistent
/// filter, band from [`average_nees_band`] with d = M). The Kalman filters report it directly, from
/// their own factor of S: [`Innovation::nis`](crate::Innovation::nis).
///
/// # Errors
/// As [`nees`].
pub fn nis<const M: usize>(
    innovation: &SVector<f64, M>,
    covariance: &SMatrix<f64, M, M>,
) -> Result<f64, OperatorError> {
    nees(innovation, covariance)
}

/// The quantile of χ² with k degrees of freedom at the probability `p = Φ(z_p)` of the standard
/// normal quantile `z_p` (so that one argument serves every band: `z_p = ±1.96` for a 95 % band),
/// exact: the root x of `P(k/2, x/2) = p` ([`chi_square_cdf`]), found by bisection on a bracket
/// from the Wilson-Hilferty cube `k (1 − 2/(9k) + z_p √(2/(9k)))³` (in at most 200 halvings, to
/// a relative 1e-13), up to k = 1e4; beyond, the cube itself, whose relative error is then below
/// 1e-6. So it is accurate for a handful of degrees of freedom as for millions (the cube alone
/// errs by 10 % at k = 1). Valid for k ≥ 1 and |z_p| ≤ 37 (p representable away from 0 and 1).
///
/// # Errors
/// [`OperatorError::NonFinite`] for a non-finite z_p or k; [`OperatorError::OutOfRange`] for
/// k < 1 or |z_p| > 37.
pub fn chi_square_quantile(normal_quantile: f64, dof: f64) -> Result<f64, OperatorError> {
    all_finite(
        "chi-square quantile arguments (normal quantile, degrees of freedom)",
        [normal_quantile, dof].iter(),
    )?;
    if dof < 1.0 {
        return Err(OperatorError::OutOfRange {
            what: "degrees of freedom of the chi-square quantile",
            value: dof,
            range: "[1, infinity)",
        });
    }
    if normal_quantile.abs() > 37.0 {
        return Err(OperatorError::OutOfRange {
            what: "normal quantile of the chi-square quantile",
            value: normal_quantile,
            range: "[-37, 37]",
        });
    }
    let h = 2.0 / (9.0 * dof);
    let guess = dof * (1.0 - h + normal_quantile * h.sqrt()).powi(3).max(0.0);
    if dof > EXACT_DOF {
        // The cube is exact to about 1e-6 relative here (its error falls as 1/k), and the series
        // would need more than its 500 terms.
        all_finite(
            "chi-square quantile (it overflows: the normal quantile is too large)",
            [guess].iter(),
        )?;
        return Ok(guess);
    }
    // Work in the smaller tail: q = P(upper) for z > 0, else the lower tail, so that p near 1
    // keeps its digits.
    let upper = normal_quantile > 0.0;
    let tail = liebayes_densities::special::normal_cdf(-normal_quantile.abs());
    // The tail mass beyond x on the side of the quantile: decreasing in x for the upper tail,
    // increasing for the lower.
    let beyond = |x: f64| {
        // x > 0 and 1 ≤ k ≤ 1e4 here: the function cannot fail.
        let (lower, upper_mass) = chi_square_cdf(x, dof).unwrap_or((0.5, 0.5));
        if upper { upper_mass } else { lower }
    };
    // A bracket [low, high] with the root inside.
    let (mut low, mut high) = (guess.max(f64::MIN_POSITIVE) * 0.5, guess.max(1.0) * 2.0);
    for _ in 0..200 {
        let too_low = if upper {
            beyond(low) < tail
        } else {
            beyond(low) > tail
        };
        if !too_low {
            break;
        }
        low *= 0.5;
    }
    for _ in 0..200 {
        let too_high = if upper {
            beyond(high) > tail
        } else {
            beyond(high) < tail
        };
        if !too_high {
            break;
        }
        high *= 2.0;
    }
    for _ in 0..200 {
        let middle = 0.5 * (low + high);
        let below_root = if upper {
            beyond(middle) > tail
        } else {
            beyond(middle) < tail
        };
        if below_root {
            low = middle;
        } else {
            high = middle;
        }
        if high - low <= 1e-13 * high {
            break;
        }
    }
    Ok(0.5 * (low + high))
}

/// `ln(e^(−y) y^a / Γ(a))`, the prefactor of the incomplete gamma functions. Its terms reach
/// 4e4 at k = 1e4 and cancel to a few units, so for a ≥ 50 it is taken as
/// `−a (d − ln(1 + d)) + ½ ln a − ½ ln 2π − c(a)`, `d = y/a − 1` (`d − ln(1 + d)` by its series for
/// |d| < 0.3) and c(a) the Stirling series of ln Γ past its leading terms (four terms: below 1e-18
/// from a = 50); the direct form lost 5e-12 at k = 1e4.
fn log_prefactor(a: f64, y: f64) -> f64 {
    if a < 50.0 {
        return -y + a * y.ln() - libm::lgamma(a);
    }
    let d = y / a - 1.0;
    let d_minus_log = if d.abs() < 0.3 {
        // Σ_{n ≥ 2} (−1)ⁿ dⁿ / n: 0.3ⁿ/n is below 1e-18 from n = 32.
        let (mut power, mut sum) = (d * d, 0.0);
        for n in 2..40 {
            let term = power / f64::from(n);
            sum += if n % 2 == 0 { term } else { -term };
            power *= d;
        }
        sum
    } else {
        d - d.ln_1p()
    };
    let inverse = 1.0 / a;
    let inverse_squared = inverse * inverse;
    let stirling = inverse
        * (1.0 / 12.0
            - inverse_squared
                * (1.0 / 360.0 - inverse_squared * (1.0 / 1260.0 - inverse_squared / 1680.0)));
    -a * d_minus_log + 0.5 * a.ln() - 0.5 * (2.0 * std::f64::consts::PI).ln() - stirling
}

/// The most terms of the series of [`chi_square_cdf`] (at most 625 are needed, at k = 1e4; 500
/// stopped 1e-11 short there).
const SERIES_TERMS: u32 = 1000;

/// The most degrees of freedom [`chi_square_quantile`] inverts the distribution function for;
/// beyond, the Wilson-Hilferty cube is as accurate as the band needs.
const EXACT_DOF: f64 = 1e4;

/// The χ² distribution function with k degrees of freedom and its complement,
/// `(P(k/2, x/2), Q(k/2, x/2))`, the regularized incomplete gamma functions: by their series
/// `P(a, y) = e^(−y) y^a / Γ(a+1) Σ yⁿ / ((a+1)…(a+n))` for `y < a + 1`, and by the continued
/// fraction of Q (modified Lentz) beyond, each the complement of the other; at most
/// 1000 terms (they fall as `exp(−n²/k)` near y = a: about 625 at k = 1e4), to a
/// relative 1e-14 for k up to 1e4 (checked against 50-digit values). `(0, 1)` for x ≤ 0, `(1, 0)` for x = +∞.
///
/// # Errors
/// [`OperatorError::NonFinite`] for a NaN x or a non-finite k; [`OperatorError::OutOfRange`] for
/// k outside [1, 1e4].
pub fn chi_square_cdf(x: f64, dof: f64) -> Result<(f64, f64), OperatorError> {
    if x.is_nan() {
        return Err(OperatorError::NonFinite {
            what: "argument of the chi-square distribution function",
            value: x,
        });
    }
    all_finite(
        "degrees of freedom of the chi-square distribution function",
        [dof].iter(),
    )?;
    if !(1.0..=EXACT_DOF).contains(&dof) {
        return Err(OperatorError::OutOfRange {
            what: "degrees of freedom of the chi-square distribution function",
            value: dof,
            range: "[1, 1e4]",
        });
    }
    if x <= 0.0 {
        return Ok((0.0, 1.0));
    }
    if x.is_infinite() {
        return Ok((1.0, 0.0));
    }
    let (a, y) = (0.5 * dof, 0.5 * x);
    let log_front = log_prefactor(a, y);
    if y < a + 1.0 {
        let (mut term, mut sum) = (1.0 / a, 1.0 / a);
        for n in 1..SERIES_TERMS {
            term *= y / (a + f64::from(n));
            sum += term;
            if term < sum * 1e-17 {
                break;
            }
        }
        let p = (log_front + sum.ln()).exp().min(1.0);
        Ok((p, 1.0 - p))
    } else {
        let tiny = 1e-300;
        let mut b = y + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut fraction = d;
        for n in 1..500 {
            let n = f64::from(n);
            let an = -n * (n - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            fraction *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        let q = (log_front + fraction.ln()).exp().min(1.0);
        Ok((1.0 - q, q))
    }
}

/// The standard normal 97.5 % quantile.
pub const Z_975: f64 = 1.959_963_984_540_054;

/// The 2.5 % and 97.5 % quantiles of χ²(k), exact ([`chi_square_quantile`]): the one band every
/// consistency figure of the library is drawn with.
///
/// # Errors
/// [`OperatorError::OutOfRange`] for k = 0.
pub fn chi_square_band(dof: usize) -> Result<(f64, f64), OperatorError> {
    if dof == 0 {
        return Err(OperatorError::OutOfRange {
            what: "degrees of freedom of the chi-square band",
            value: 0.0,
            range: "at least 1",
        });
    }
    let dof = dof as f64;
    Ok((
        chi_square_quantile(-Z_975, dof)?,
        chi_square_quantile(Z_975, dof)?,
    ))
}

/// The two-sided 95 % band of the average NEES over `runs` runs of a `dim`-dimensional state:
/// the [`chi_square_band`] of `dim · runs` degrees of freedom divided by `runs` (the sum of `runs`
/// independent χ²(dim) values is χ²(dim · runs)).
///
/// # Errors
/// [`OperatorError::OutOfRange`] for `dim` or `runs` zero, [`OperatorError::TooLarge`] when
/// `dim · runs` exceeds [`MAX_ELEMENTS`](crate::MAX_ELEMENTS).
pub fn average_nees_band(dim: usize, runs: usize) -> Result<(f64, f64), OperatorError> {
    if dim == 0 || runs == 0 {
        return Err(OperatorError::OutOfRange {
            what: "dimension and number of runs of the NEES band",
            value: dim.min(runs) as f64,
            range: "at least 1 each",
        });
    }
    let dof = dim.saturating_mul(runs);
    check_size("degrees of freedom dim * runs of the NEES band", dof)?;
    let (low, high) = chi_square_band(dof)?;
    Ok((low / runs as f64, high / runs as f64))
}

/// The circular consistency statistic `(1 − cos e)/(1 − ρ)` of an angle error e against the
/// posterior's mean resultant length ρ = |E e^(iA)| about the reported circular mean.
///
/// For any posterior (not only von Mises), `E[cos(A − μ)] = ρ` exactly when μ is the circular mean, so
/// a consistent filter's statistic averages exactly 1 over runs: above 1 the filter is over-confident,
/// below 1 under-confident. It is the angular counterpart of NEES / d, and for a concentrated von Mises
/// (ρ ≈ 1 − 1/(2κ)) it tends to κ e², the usual one-dimensional NEES. `None` when ρ = 1 (a posterior
/// claiming certainty), ρ is not in [0, 1] or e is not finite; otherwise finite (at most 2/ε).
pub fn circular_consistency(error: f64, rho: f64) -> Option<f64> {
    ((0.0..1.0).contains(&rho) && error.is_finite()).then(|| (1.0 - error.cos()) / (1.0 - rho))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Against exact quantiles (mpmath, bisection on the regularised incomplete gamma function).
    #[test]
    fn wilson_hilferty_is_close_to_the_exact_quantiles() {
        for (k, low, high) in [
            (20.0, 9.590_777_392, 34.169_606_903),
            (1000.0, 914.257_153_8, 1_089.530_912_8),
        ] {
            let (got_low, got_high) = (
                chi_square_quantile(-Z_975, k).unwrap(),
                chi_square_quantile(Z_975, k).unwrap(),
            );
            assert!(
                (got_low / low - 1.0).abs() < 2e-3,
                "{k}: {got_low} vs {low}"
            );
            assert!(
                (got_high / high - 1.0).abs() < 2e-3,
                "{k}: {got_high} vs {high}"
            );
        }
    }

    /// The regularised lower incomplete gamma function P(a, x) by its power series (converges
    /// for every x > 0; here x < 20).
    fn regularised_gamma(a: f64, x: f64) -> f64 {
        let (mut term, mut sum) = (1.0 / a, 1.0 / a);
        for n in 1..500 {
            term *= x / (a + f64::from(n));
            sum += term;
        }
        // Γ(a) for a half-integer or integer a ≥ 1/2 by Γ(a + 1) = a Γ(a).
        let mut gamma = if a.fract() == 0.0 { 1.0 } else { PI.sqrt() };
        let mut b = if a.fract() == 0.0 { 1.0 } else { 0.5 };
        while b < a {
            gamma *= b;
            b += 1.0;
        }
        (a * x.ln() - x).exp() * sum / gamma
    }

    #[test]
    fn the_small_dof_band_holds_the_exact_quantiles() {
        // Published table values (k = 1, 2) and the χ² CDF, by its own series, at the band's ends.
        assert!((chi_square_band(1).unwrap().0 - 9.820_691e-4).abs() < 1e-9);
        assert!((chi_square_band(2).unwrap().1 - 7.377_759).abs() < 1e-6);
        for k in 1..20 {
            let (low, high) = chi_square_band(k).unwrap();
            let a = k as f64 / 2.0;
            assert!(
                (regularised_gamma(a, low / 2.0) - 0.025).abs() < 1e-10,
                "{k}"
            );
            assert!(
                (regularised_gamma(a, high / 2.0) - 0.975).abs() < 1e-10,
                "{k}"
            );
        }
        assert!(chi_square_band(0).is_err());
        // The Wilson-Hilferty cube is off by about half at the lower quantile of k = 2: why the
        // band is exact.
        let h = 2.0 / 18.0;
        let wh = 2.0 * (1.0 - h - Z_975 * f64::sqrt(h)).powi(3);
        assert!(
            (wh / chi_square_band(2).unwrap().0 - 1.0).abs() > 0.4,
            "{wh}"
        );
    }

    #[test]
    fn circular_consistency_is_one_for_a_consistent_spread() {
        assert_eq!(circular_consistency(0.3, 1.0), None);
        assert!((circular_consistency(PI, 0.0).unwrap() - 2.0).abs() < 1e-15);
    }

    #[test]
    fn nees_and_angle_errors() {
        let p = SMatrix::<f64, 2, 2>::new(4.0, 0.0, 0.0, 1.0);
        assert_eq!(nees(&SVector::<f64, 2>::new(2.0, 1.0), &p), Ok(2.0));
        assert!(nees(&SVector::<f64, 2>::new(2.0, 1.0), &SMatrix::zeros()).is_err());
        let angle = |a: f64| liebayes_manifolds::So2::from_angle_unchecked(a);
        assert!((estimation_error(&angle(2.0 * PI - 0.1), &angle(0.1))[0] - 0.2).abs() < 1e-12);
        assert!((estimation_error(&angle(0.0), &angle(-PI))[0].abs() - PI).abs() < 1e-12);
    }
}
