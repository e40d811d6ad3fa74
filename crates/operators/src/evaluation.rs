//! Evaluation for any filter: a Monte Carlo runner and the metrics that tell a filter is right.
//!
//! * [`MonteCarlo`]: independent runs, each seeded from its index so that results do not depend on
//!   the thread schedule; parallel with the `rayon` feature, with a progress bar with `progress`.
//! * NEES and NIS: for a consistent filter the normalised error squared `eᵀ P⁻¹ e` of a d-dimensional
//!   state (NEES) or innovation (NIS, with e = ν and P = S) has mean d; averaged over N independent
//!   runs, `N · mean` is χ² with N d degrees of freedom when the posterior is Gaussian, which gives the
//!   95 % band of [`average_nees_band`].
//! * [`circular_consistency`]: the same question for an angle, without a Gaussian assumption.
//! * [`Series`]: a per-epoch accumulator, for RMSE over time.
//! * [`MeanEstimate`]: a running mean with its 95 % confidence band (divergence rates, ratios).

use nalgebra::{Cholesky, SMatrix, SVector};
use std::f64::consts::PI;

/// The normalised estimation error squared `eᵀ P⁻¹ e` by Cholesky; `None` when P is not positive
/// definite.
pub fn nees<const D: usize>(
    error: &SVector<f64, D>,
    covariance: &SMatrix<f64, D, D>,
) -> Option<f64> {
    Cholesky::new(*covariance).map(|c| error.dot(&c.solve(error)))
}

/// The normalised innovation squared `νᵀ S⁻¹ ν` of a measurement's innovation ν with its predicted
/// covariance S (the same quadratic form as [`nees`]; mean M, the measurement dimension, for a consistent
/// filter, band from [`average_nees_band`] with d = M); `None` when S is not positive definite. The
/// Kalman filters report it directly, from their own factor of S:
/// [`Innovation::nis`](crate::Innovation::nis).
pub fn nis<const M: usize>(
    innovation: &SVector<f64, M>,
    covariance: &SMatrix<f64, M, M>,
) -> Option<f64> {
    nees(innovation, covariance)
}

/// The p-quantile of χ² with k degrees of freedom by the Wilson-Hilferty cube
/// `k (1 − 2/(9k) + z_p √(2/(9k)))³`, with z_p the standard normal quantile: relative error below 2e-3
/// for k ≥ 20 in the 2.5 % and 97.5 % tails (measured against exact quantiles; the average-NEES band
/// of 10 or more runs has k ≥ 20). Poor for a handful of degrees of freedom. An approximation, used
/// only to draw bands.
pub fn chi_square_quantile(normal_quantile: f64, dof: f64) -> f64 {
    let h = 2.0 / (9.0 * dof);
    dof * (1.0 - h + normal_quantile * h.sqrt()).powi(3).max(0.0)
}

/// The standard normal 97.5 % quantile.
pub const Z_975: f64 = 1.959_963_984_540_054;

/// The two-sided 95 % band of the average NEES over `runs` runs of a `dim`-dimensional state.
pub fn average_nees_band(dim: usize, runs: usize) -> (f64, f64) {
    let dof = (dim * runs) as f64;
    (
        chi_square_quantile(-Z_975, dof) / runs as f64,
        chi_square_quantile(Z_975, dof) / runs as f64,
    )
}

/// `a − b` wrapped to (−π, π].
pub fn angle_difference(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    if d > PI { d - 2.0 * PI } else { d }
}

/// The circular consistency statistic `(1 − cos e) / (1 − ρ)` of an angle error e against the
/// posterior's mean resultant length ρ = |E e^(iA)| about the reported circular mean.
///
/// For any posterior (not only von Mises), `E[cos(A − μ)] = ρ` exactly when μ is the circular mean, so
/// a consistent filter's statistic averages exactly 1 over runs: above 1 the filter is over-confident,
/// below 1 under-confident. It is the angular counterpart of NEES / d, and for a concentrated von Mises
/// (ρ ≈ 1 − 1/(2κ)) it tends to κ e², the usual one-dimensional NEES. `None` when ρ = 1 (a posterior
/// claiming certainty) or ρ is not in [0, 1].
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
    pub fn add(&mut self, x: f64) {
        self.count += 1;
        let delta = x - self.mean;
        self.mean += delta / self.count as f64;
        self.sum_sq += delta * (x - self.mean);
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
/// time, add squared errors and take the square root of the mean).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    sums: Vec<f64>,
    counts: Vec<usize>,
}

impl Series {
    /// Adds `value` at epoch k.
    pub fn add(&mut self, k: usize, value: f64) {
        self.grow(k + 1);
        self.sums[k] += value;
        self.counts[k] += 1;
    }

    fn grow(&mut self, len: usize) {
        if self.sums.len() < len {
            self.sums.resize(len, 0.0);
            self.counts.resize(len, 0);
        }
    }

    /// Merges another series (from other runs).
    pub fn merge(&mut self, other: &Series) {
        self.grow(other.sums.len());
        for (k, (s, c)) in other.sums.iter().zip(&other.counts).enumerate() {
            self.sums[k] += s;
            self.counts[k] += c;
        }
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
    pub fn run<T: Send>(&self, runs: usize, job: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
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
            let results = (0..runs)
                .into_par_iter()
                .progress_with(bar.clone())
                .map(job)
                .collect();
            bar.finish_and_clear();
            results
        }
        #[cfg(all(feature = "rayon", not(feature = "progress")))]
        {
            use rayon::prelude::*;
            (0..runs).into_par_iter().map(job).collect()
        }
        #[cfg(not(feature = "rayon"))]
        {
            (0..runs).map(job).collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against exact quantiles (mpmath, bisection on the regularised incomplete gamma function).
    #[test]
    fn wilson_hilferty_is_close_to_the_exact_quantiles() {
        for (k, low, high) in [
            (20.0, 9.590_777_392, 34.169_606_903),
            (1000.0, 914.257_153_8, 1_089.530_912_8),
        ] {
            let (got_low, got_high) = (
                chi_square_quantile(-Z_975, k),
                chi_square_quantile(Z_975, k),
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
        a.add(0, 1.0);
        a.add(2, 4.0);
        let mut b = Series::default();
        b.add(0, 3.0);
        a.merge(&b);
        assert_eq!(a.means(), vec![Some(2.0), None, Some(4.0)]);
        let mut m = MeanEstimate::default();
        assert_eq!(m.mean(), None);
        for x in [1.0, 2.0, 3.0, 4.0] {
            m.add(x);
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
        let out = MonteCarlo::new("test").quiet().run(100, |i| i * i);
        assert_eq!(out, (0..100).map(|i| i * i).collect::<Vec<_>>());
    }

    #[test]
    fn nees_and_angles() {
        let p = SMatrix::<f64, 2, 2>::new(4.0, 0.0, 0.0, 1.0);
        assert_eq!(nees(&SVector::<f64, 2>::new(2.0, 1.0), &p), Some(2.0));
        assert_eq!(
            nees(&SVector::<f64, 2>::new(2.0, 1.0), &SMatrix::zeros()),
            None
        );
        assert!((angle_difference(0.1, 2.0 * PI - 0.1) - 0.2).abs() < 1e-12);
        assert!((angle_difference(-PI, 0.0) - PI).abs() < 1e-12);
    }
}
