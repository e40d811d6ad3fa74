//! Consistency metrics for any filter: NEES with its chi-square band, and angle errors.
//!
//! For a consistent filter the normalised estimation error squared `NEES = eᵀ P⁻¹ e` of a d-dimensional
//! state has mean d; averaged over N independent runs, `N · mean NEES` is χ² with N d degrees of freedom
//! when the posterior is Gaussian, which gives the usual 95 % band for the average.

use nalgebra::{Cholesky, SMatrix, SVector};
use std::f64::consts::PI;

/// `eᵀ P⁻¹ e` by Cholesky; `None` when P is not positive definite.
pub fn nees<const D: usize>(
    error: &SVector<f64, D>,
    covariance: &SMatrix<f64, D, D>,
) -> Option<f64> {
    Cholesky::new(*covariance).map(|c| error.dot(&c.solve(error)))
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
