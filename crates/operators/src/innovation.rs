//! [`Innovation`]: what a Kalman-type conditioning step reports, and the Gaussian update it comes from.

use crate::OperatorError;
use crate::error::all_finite;
use crate::numerics::symmetric_part;
use nalgebra::{Cholesky, SMatrix, SVector};
use std::f64::consts::PI;

/// The by-products of a Gaussian measurement update of an N-dimensional state by an M-dimensional
/// measurement (the [`Condition::Report`](crate::Condition::Report) of the Kalman filter, the EKF and
/// the UKF):
///
/// * the innovation `ν = z ⊟ ẑ` (the measurement minus its prediction, with the model's residual);
/// * its predicted covariance S (`H P Hᵀ + R` for the linear and extended filters, the sigma-point
///   covariance plus R for the unscented one);
/// * the gain K, with `μ⁺ = μ ⊞ K ν`;
/// * the normalised innovation squared `NIS = νᵀ S⁻¹ ν`.
///
/// For a consistent filter ν is zero-mean Gaussian with covariance S, so the NIS is χ² with as many
/// degrees of freedom as the measurement's manifold has dimensions ([`dof`](Self::dof): M for a
/// vector in R^M, 2 per unit vector of a model that stacks directions on the sphere S² as 3
/// coordinates, see [`MeasurementModel::dof`](crate::MeasurementModel::dof)), independent from step
/// to step; averaged over n steps or runs it lies in the band of
/// [`average_nees_band`](crate::evaluation::average_nees_band)`(dof, n)` 95 % of the time. The fields
/// are read-only: they are the quantities of one step and stay consistent with each other.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Innovation<const N: usize, const M: usize> {
    nu: SVector<f64, M>,
    covariance: SMatrix<f64, M, M>,
    gain: SMatrix<f64, N, M>,
    nis: f64,
    dof: usize,
}

impl<const N: usize, const M: usize> Innovation<N, M> {
    /// The update from the innovation ν, its covariance S (symmetrised as `(S + Sᵀ)/2`) and the
    /// cross-covariance `C = Cov(δ, z)`: `K = C S⁻¹` by the Cholesky factor `S = L Lᵀ` (never
    /// inverted), `NIS = |L⁻¹ ν|²`, and the log evidence
    /// `ln N(ν; 0, S) = −½ (NIS + ln det S + M ln 2π)`, returned beside the report. `dof` is the
    /// dimension of the measurement's manifold (at most M).
    pub(crate) fn new(
        innovation: SVector<f64, M>,
        covariance: &SMatrix<f64, M, M>,
        cross_covariance: &SMatrix<f64, N, M>,
        dof: usize,
    ) -> Result<(Self, f64), OperatorError> {
        all_finite(
            "innovation z - h(x) (the measurement model predicted a non-finite value)",
            innovation.iter(),
        )?;
        let covariance = symmetric_part(covariance);
        let factor = Cholesky::new(covariance).ok_or(OperatorError::NotPositiveDefinite {
            what: "innovation covariance S (make the measurement noise R positive definite)",
        })?;
        let gain = factor.solve(&cross_covariance.transpose()).transpose();
        // The factor of a successful Cholesky decomposition has a positive diagonal.
        let nis = factor
            .l_dirty()
            .solve_lower_triangular_unchecked(&innovation)
            .norm_squared();
        let log_det = 2.0
            * factor
                .l_dirty()
                .diagonal()
                .iter()
                .map(|d| d.ln())
                .sum::<f64>();
        let log_evidence = -0.5 * (nis + log_det + M as f64 * (2.0 * PI).ln());
        // The log evidence holds the NIS, so one test covers both. A gain that overflows is refused by
        // the caller's check of the posterior it produces (mean μ ⊞ K ν and covariance).
        if !log_evidence.is_finite() {
            return Err(OperatorError::NonFinite {
                what: "innovation statistics (the NIS nu^T S^-1 nu or the log evidence overflow: the \
                       measurement is too far from its prediction for S, or S is nearly singular)",
                value: log_evidence,
            });
        }
        Ok((
            Self {
                nu: innovation,
                covariance,
                gain,
                nis,
                dof: dof.min(M),
            },
            log_evidence,
        ))
    }

    /// ν, the innovation `z ⊟ ẑ`.
    pub fn innovation(&self) -> &SVector<f64, M> {
        &self.nu
    }

    /// S, the innovation's predicted covariance.
    pub fn covariance(&self) -> &SMatrix<f64, M, M> {
        &self.covariance
    }

    /// K, the gain (`μ⁺ = μ ⊞ K ν`).
    pub fn gain(&self) -> &SMatrix<f64, N, M> {
        &self.gain
    }

    /// `νᵀ S⁻¹ ν`, computed in the step from the Cholesky factor of S (one triangular solve, no
    /// inverse): χ² with [`dof`](Self::dof) degrees of freedom for a consistent filter.
    pub fn nis(&self) -> f64 {
        self.nis
    }

    /// The degrees of freedom of the NIS: the dimension of the manifold the measurement lives on
    /// (M for a vector measurement, fewer when its M coordinates are constrained, as the 3
    /// coordinates of a unit vector carry 2).
    pub fn dof(&self) -> usize {
        self.dof
    }

    /// K ν, the correction of the mean in the tangent space at the prior mean.
    pub(crate) fn correction(&self) -> SVector<f64, N> {
        self.gain * self.nu
    }
}
