//! Evaluation for any filter: a Monte Carlo runner and the metrics that tell a filter is right.
//!
//! * [`MonteCarlo`]: independent runs, each seeded from its index so that results do not depend on
//!   the thread schedule; parallel with the `rayon` feature, with a progress bar with `progress`.
//! * [`estimation_error`]: the error of an estimate on its manifold, `estimate ⊟ truth` (an angle
//!   error wraps through SO(2), never by hand).
//! * NEES and NIS: for a consistent filter the normalised error squared `eᵀ P⁻¹ e` of a d-dimensional
//!   state (NEES) or innovation (NIS, with e = ν and P = S) has mean d; averaged over N independent
//!   runs, `N · mean` is χ² with N d degrees of freedom when the posterior is Gaussian, which gives the
//!   95 % band of [`average_nees_band`].
//! * [`circular_consistency`]: the same question for an angle, without a Gaussian assumption.
//! * [`Series`]: a per-epoch accumulator, for RMSE over time.
//! * [`MeanEstimate`]: a running mean with its 95 % confidence band (divergence rates, ratios).
//!
//! Every accumulator refuses a value that is not finite, or that would make its sums overflow, with
//! an error, and is then unchanged.

use crate::error::{all_finite, check_size, reserve, with_capacity};
use crate::{MAX_ELEMENTS, OperatorError};
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
/// overflows; [`OperatorError::NotPositiveDefinite`] when P is not positive definite.
pub fn nees<const D: usize>(
    error: &SVector<f64, D>,
    covariance: &SMatrix<f64, D, D>,
) -> Result<f64, OperatorError> {
    all_finite("estimation error e", error.iter())?;
    all_finite("covariance P of the NEES", covariance.iter())?;
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

/// The p-quantile of χ² with k degrees of freedom by the Wilson-Hilferty cube
/// `k (1 − 2/(9k) + z_p √(2/(9k)))³`, with z_p the standard normal quantile: relative error below 2e-3
/// for k ≥ 20 in the 2.5 % and 97.5 % tails (measured against exact quantiles; the average-NEES band
/// of 10 or more runs has k ≥ 20). Poor for a handful of degrees of freedom. An approximation, used
/// only to draw bands. Valid for k ≥ 1 and any finite z_p for which the cube is finite.
///
/// # Errors
/// [`OperatorError::NonFinite`] for a non-finite z_p or k, or a result that overflows;
/// [`OperatorError::OutOfRange`] for k < 1.
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
    let h = 2.0 / (9.0 * dof);
    let value = dof * (1.0 - h + normal_quantile * h.sqrt()).powi(3).max(0.0);
    all_finite(
        "chi-square quantile (it overflows: the normal quantile is too large)",
        [value].iter(),
    )?;
    Ok(value)
}

/// The standard normal 97.5 % quantile.
pub const Z_975: f64 = 1.959_963_984_540_054;

/// The two-sided 95 % band of the average NEES over `runs` runs of a `dim`-dimensional state.
///
/// # Errors
/// [`OperatorError::OutOfRange`] for `dim` or `runs` zero, [`OperatorError::TooLarge`] when
/// `dim · runs` exceeds [`MAX_ELEMENTS`].
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
    let dof = dof as f64;
    Ok((
        chi_square_quantile(-Z_975, dof)? / runs as f64,
        chi_square_quantile(Z_975, dof)? / runs as f64,
    ))
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

/// A running mean (Welford) with the 95 % confidence band of the mean from the sample variance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeanEstimate {
    count: usize,
    mean: f64,
    sum_sq: f64,
}

impl MeanEstimate {
    /// Adds a value.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a value that is not finite, or whose addition would make the
    /// running mean or sum of squares overflow; the estimate is then unchanged.
    pub fn add(&mut self, x: f64) -> Result<(), OperatorError> {
        all_finite("value added to a mean estimate", [x].iter())?;
        let count = self.count + 1;
        let delta = x - self.mean;
        let mean = self.mean + delta / count as f64;
        let sum_sq = self.sum_sq + delta * (x - mean);
        all_finite(
            "running mean or sum of squares (the values are too large: rescale them)",
            [delta, mean, sum_sq].iter(),
        )?;
        *self = Self {
            count,
            mean,
            sum_sq,
        };
        Ok(())
    }

    /// The number of values.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The mean, `None` with no values.
    pub fn mean(&self) -> Option<f64> {
        (self.count > 0).then_some(self.mean)
    }

    /// `mean ± 1.96 s / √n` (normal approximation of the mean's distribution); `None` below 2 values.
    pub fn band(&self) -> Option<(f64, f64)> {
        (self.count > 1).then(|| {
            let n = self.count as f64;
            let half = Z_975 * (self.sum_sq / (n - 1.0) / n).sqrt();
            (self.mean - half, self.mean + half)
        })
    }
}

/// Per-epoch sums over runs: add values at epoch k from each run, read the mean per epoch (for RMSE over
/// time, add squared errors and take the square root of the mean). At most
/// [`MAX_ELEMENTS`] epochs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    sums: Vec<f64>,
    counts: Vec<usize>,
}

/// What a series names when it cannot grow.
const EPOCHS: &str = "number of epochs of a series";

impl Series {
    /// Adds `value` at epoch k.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] for k at or above [`MAX_ELEMENTS`] (checked before growing) or
    /// when the series cannot grow to k + 1 epochs; [`OperatorError::NonFinite`] for a value that is
    /// not finite or would make the epoch's sum overflow. The series is then unchanged.
    pub fn add(&mut self, k: usize, value: f64) -> Result<(), OperatorError> {
        if k >= MAX_ELEMENTS {
            return Err(OperatorError::TooLarge {
                what: "epoch index of a series",
                value: k,
                max: MAX_ELEMENTS - 1,
            });
        }
        all_finite("value added to a series", [value].iter())?;
        let sum = self.sums.get(k).copied().unwrap_or(0.0) + value;
        all_finite(
            "sum of a series' epoch (the values are too large: rescale them)",
            [sum].iter(),
        )?;
        self.grow(k + 1)?;
        self.sums[k] = sum;
        self.counts[k] += 1;
        Ok(())
    }

    /// Grows to at least `len` epochs (len ≤ [`MAX_ELEMENTS`]).
    fn grow(&mut self, len: usize) -> Result<(), OperatorError> {
        if self.sums.len() < len {
            let more = len - self.sums.len();
            reserve(&mut self.sums, EPOCHS, more)?;
            reserve(&mut self.counts, EPOCHS, more)?;
            self.sums.resize(len, 0.0);
            self.counts.resize(len, 0);
        }
        Ok(())
    }

    /// Merges another series (from other runs).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] when a merged sum would overflow, [`OperatorError::TooLarge`]
    /// when the series cannot grow to the other's length; the series is then unchanged.
    pub fn merge(&mut self, other: &Series) -> Result<(), OperatorError> {
        if let Some(value) = self
            .sums
            .iter()
            .zip(&other.sums)
            .map(|(a, b)| a + b)
            .find(|v| !v.is_finite())
        {
            return Err(OperatorError::NonFinite {
                what: "sum of a series' epoch after merging (the values are too large: rescale them)",
                value,
            });
        }
        self.grow(other.sums.len())?;
        for (k, (s, c)) in other.sums.iter().zip(&other.counts).enumerate() {
            self.sums[k] += s;
            self.counts[k] += c;
        }
        Ok(())
    }

    /// The mean per epoch (NaN-free: epochs with no value are `None`).
    pub fn means(&self) -> Vec<Option<f64>> {
        self.sums
            .iter()
            .zip(&self.counts)
            .map(|(s, &c)| (c > 0).then(|| s / c as f64))
            .collect()
    }
}

/// Runs independent Monte Carlo replications. Run i is given its index; the job seeds its own random
/// number generator from it (for example `ChaCha8Rng::seed_from_u64(seed + i)`), so the results are the
/// same whatever the number of threads. With the `rayon` feature the runs are spread over all cores;
/// with `progress` a bar on standard error counts them (hidden when standard error is not a terminal).
#[derive(Clone, Debug)]
pub struct MonteCarlo {
    // Read only by the progress bar (feature `progress`).
    #[cfg_attr(not(feature = "progress"), allow(dead_code))]
    label: String,
    #[cfg_attr(not(feature = "progress"), allow(dead_code))]
    progress: bool,
}

impl MonteCarlo {
    /// A study named `label` (shown beside the progress bar).
    pub fn new(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            progress: true,
        }
    }

    /// Turns the progress bar off (it is on by default where the `progress` feature is).
    #[must_use]
    pub fn quiet(mut self) -> Self {
        self.progress = false;
        self
    }

    /// The results of `job(i)` for i in 0..runs, in order.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] for more than [`MAX_ELEMENTS`] runs or when their results cannot
    /// be allocated (checked before any run starts).
    pub fn run<T: Send>(
        &self,
        runs: usize,
        job: impl Fn(usize) -> T + Sync + Send,
    ) -> Result<Vec<T>, OperatorError> {
        let mut results = with_capacity("number of Monte Carlo runs", runs)?;
        #[cfg(feature = "progress")]
        {
            use indicatif::{
                ParallelProgressIterator, ProgressBar, ProgressDrawTarget, ProgressStyle,
            };
            use rayon::prelude::*;
            let bar = if self.progress {
                ProgressBar::with_draw_target(Some(runs as u64), ProgressDrawTarget::stderr())
            } else {
                ProgressBar::hidden()
            };
            if let Ok(style) =
                ProgressStyle::with_template("{msg:>24} [{bar:30}] {pos}/{len} runs, {elapsed}")
            {
                bar.set_style(style.progress_chars("=> "));
            }
            bar.set_message(self.label.clone());
            (0..runs)
                .into_par_iter()
                .progress_with(bar.clone())
                .map(job)
                .collect_into_vec(&mut results);
            bar.finish_and_clear();
        }
        #[cfg(all(feature = "rayon", not(feature = "progress")))]
        {
            use rayon::prelude::*;
            (0..runs)
                .into_par_iter()
                .map(job)
                .collect_into_vec(&mut results);
        }
        #[cfg(not(feature = "rayon"))]
        {
            results.extend((0..runs).map(job));
        }
        Ok(results)
    }
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

    #[test]
    fn series_and_means() {
        let mut a = Series::default();
        a.add(0, 1.0).unwrap();
        a.add(2, 4.0).unwrap();
        let mut b = Series::default();
        b.add(0, 3.0).unwrap();
        a.merge(&b).unwrap();
        assert_eq!(a.means(), vec![Some(2.0), None, Some(4.0)]);
        let mut m = MeanEstimate::default();
        assert_eq!(m.mean(), None);
        for x in [1.0, 2.0, 3.0, 4.0] {
            m.add(x).unwrap();
        }
        assert_eq!(m.mean(), Some(2.5));
        let (low, high) = m.band().unwrap();
        let half = Z_975 * (5.0_f64 / 3.0 / 4.0).sqrt();
        assert!((low - (2.5 - half)).abs() < 1e-12 && (high - (2.5 + half)).abs() < 1e-12);
        assert_eq!(circular_consistency(0.3, 1.0), None);
        assert!((circular_consistency(PI, 0.0).unwrap() - 2.0).abs() < 1e-15);
    }

    #[test]
    fn monte_carlo_runs_in_order() {
        let out = MonteCarlo::new("test").quiet().run(100, |i| i * i).unwrap();
        assert_eq!(out, (0..100).map(|i| i * i).collect::<Vec<_>>());
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
