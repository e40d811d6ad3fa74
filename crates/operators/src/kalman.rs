//! The linear Kalman filter: [`Gaussian<N>`] propagated through `x′ = F x + u + w`, `w ~ N(0, Q)`, and
//! conditioned on `z = H x + n`, `n ~ N(0, R)`. Both steps are exact, except where rounding would
//! refuse them: there a floor at that rounding is added (below).
//!
//! Conditioning, with innovation `ν = z − H μ` and its covariance `S = H Σ Hᵀ + R` (factored by
//! Cholesky, never inverted):
//!
//! * gain `K = Σ Hᵀ S⁻¹`, mean `μ + K ν`;
//! * covariance in Joseph form `(I − K H) Σ (I − K H)ᵀ + K R Kᵀ`, symmetric and positive semi-definite
//!   by construction whatever the rounding in K, unlike the short form `(I − K H) Σ`; summed as the
//!   Gram matrices `X Xᵀ + Y Yᵀ`, `X = (I − K H) L` with `Σ = L Lᵀ` and `Y = K L_R`, each of which
//!   rounds at the size of its own entries rather than at that of Σ: after a reading far finer
//!   than the prediction, where `I − K H` all but cancels, the product rounded to a negative
//!   posterior variance;
//! * log evidence `ln N(z; H μ, S) = −½ (νᵀ S⁻¹ ν + ln det S + m ln 2π)`;
//! * the report, an [`Innovation`]: ν, S, K and the NIS `νᵀ S⁻¹ ν`.
//!
//! When R is below the rounding of `H Σ Hᵀ` and S or the posterior loses positive definiteness to
//! it, the update is made once more with `R + 64 M ε max(max |Sᵢᵢ|, |H|²_F max |Σᵢⱼ|) I`, as the
//! [EKF](crate::ekf)'s: information finer than the arithmetic holds is dropped.
//!
//! Propagation is `N(F μ + u, F Σ Fᵀ + Q)`. When rounding leaves that covariance singular (a Σ far
//! finer than a singular Q, such as the piecewise white noise `Γ Γᵀ σ²` of a constant-velocity
//! model after a fix of variance 1e-18 of one step's noise, or a diffuse prior on a velocity not
//! yet read): when its Cholesky factorisation fails, or succeeds with a pivot of its correlation
//! matrix below `N ε` (a variable fixed by the others to within the rounding of its own variance,
//! such as a velocity after two exact readings of the position), it is made once more with
//! `Q + 64 N ε max |P′ᵢᵢ| I`: the variances finer than the arithmetic holds are raised to that
//! floor, and the prediction is slightly wider than the exact one.

use crate::error::all_finite;
use crate::numerics::{
    above_rounding, check_symmetric, is_diagonal, raised_to_rounding, rounding_scale,
    symmetric_part,
};
use crate::{Condition, Conditioned, Innovation, OperatorError, Propagate};
use liebayes_densities::{DensityError, Gaussian};
use nalgebra::{Cholesky, SMatrix, SVector};

/// The linear process `x′ = F x + u + w`, `w ~ N(0, Q)`; the input is u.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearProcess<const N: usize> {
    transition: SMatrix<f64, N, N>,
    noise: SMatrix<f64, N, N>,
}

impl<const N: usize> LinearProcess<N> {
    /// The process with transition matrix F and noise covariance Q (symmetric positive semi-definite;
    /// a zero Q is a deterministic process). Any finite entries are accepted; a product
    /// `F Σ Fᵀ + Q` that overflows is refused by the step that computes it.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for NaN or infinite entries, [`OperatorError::OutOfRange`] for a Q
    /// that is not symmetric (to 1e-12 of its largest entry) or not positive semi-definite (an
    /// eigenvalue below −1e-12 times its largest entry).
    pub fn new(
        transition: SMatrix<f64, N, N>,
        noise: SMatrix<f64, N, N>,
    ) -> Result<Self, OperatorError> {
        all_finite("process transition matrix F", transition.iter())?;
        all_finite("process noise covariance Q", noise.iter())?;
        check_covariance("process noise covariance Q", &noise)?;
        Ok(Self { transition, noise })
    }

    /// F.
    pub fn transition(&self) -> &SMatrix<f64, N, N> {
        &self.transition
    }

    /// Q.
    pub fn noise(&self) -> &SMatrix<f64, N, N> {
        &self.noise
    }
}

/// The linear measurement `z = H x + n`, `n ~ N(0, R)`.
#[derive(Clone, Debug, PartialEq)]
///
/// # Example
/// ```
/// use liebayes_operators::densities::Gaussian;
/// use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
/// use liebayes_operators::{Condition, Propagate};
/// use nalgebra::{Matrix1, Matrix2, Vector1, Vector2};
///
/// // Constant velocity, position measured: the Kalman filter is the Gaussian's own propagate and condition.
/// let process = LinearProcess::new(Matrix2::new(1.0, 1.0, 0.0, 1.0), Matrix2::identity() * 0.01).unwrap();
/// let sensor = LinearMeasurement::new(nalgebra::Matrix1x2::new(1.0, 0.0), Matrix1::new(0.25)).unwrap();
/// let prior = Gaussian::new(Vector2::new(0.0, 1.0), Matrix2::identity()).unwrap();
/// let predicted = prior.propagate(&process, &Vector2::zeros()).unwrap();
/// assert_eq!(predicted.mean(), &Vector2::new(1.0, 1.0));
/// let step = predicted.condition(&sensor, &Vector1::new(1.0)).unwrap();
/// // The reading equals the prediction: the mean stays, the position variance shrinks.
/// assert!((step.posterior.mean() - Vector2::new(1.0, 1.0)).norm() < 1e-12);
/// assert!(step.posterior.covariance()[(0, 0)] < 0.25);
/// ```
pub struct LinearMeasurement<const N: usize, const M: usize> {
    matrix: SMatrix<f64, M, N>,
    noise: SMatrix<f64, M, M>,
}

impl<const N: usize, const M: usize> LinearMeasurement<N, M> {
    /// The measurement with matrix H and noise covariance R (symmetric positive semi-definite; the
    /// innovation covariance H Σ Hᵀ + R must then be positive definite at every update).
    ///
    /// # Errors
    /// As [`LinearProcess::new`], for H and R.
    pub fn new(
        matrix: SMatrix<f64, M, N>,
        noise: SMatrix<f64, M, M>,
    ) -> Result<Self, OperatorError> {
        all_finite("measurement matrix H", matrix.iter())?;
        all_finite("measurement noise covariance R", noise.iter())?;
        check_covariance("measurement noise covariance R", &noise)?;
        Ok(Self { matrix, noise })
    }

    /// H.
    pub fn matrix(&self) -> &SMatrix<f64, M, N> {
        &self.matrix
    }

    /// R.
    pub fn noise(&self) -> &SMatrix<f64, M, M> {
        &self.noise
    }
}

/// The rounding allowed in a covariance's symmetry and in its smallest eigenvalue, relative to its
/// largest entry.
const COVARIANCE_TOLERANCE: f64 = 1e-12;

/// Symmetric to 1e-12 relative and positive semi-definite to the same tolerance: the Cholesky
/// factorisation of `M / max|M| + 1e-12 I` exists, that is the smallest eigenvalue of M is at least
/// about `−1e-12 max|M|` (the rounding of a covariance computed as a product). Scaling first keeps
/// huge and subnormal entries in range; the factorisation is bounded, and the eigenvalue shown in the
/// error is computed on the error path only.
fn check_covariance<const K: usize>(
    what: &'static str,
    m: &SMatrix<f64, K, K>,
) -> Result<(), OperatorError> {
    check_symmetric(what, m)?;
    let scale = m.amax();
    if scale == 0.0 {
        return Ok(());
    }
    let scaled = m / scale;
    let symmetric = (scaled + scaled.transpose()) * 0.5;
    let shifted = symmetric + SMatrix::<f64, K, K>::identity() * COVARIANCE_TOLERANCE;
    if Cholesky::new(shifted).is_none() {
        return Err(OperatorError::OutOfRange {
            what,
            value: smallest_eigenvalue(&symmetric) * scale,
            range: "positive semi-definite matrices (the value shown is the smallest eigenvalue)",
        });
    }
    Ok(())
}

/// The smallest eigenvalue of a symmetric matrix with entries in [−1, 1] (a dynamic copy and a
/// bounded iteration: error messages only; NaN if the iteration does not converge).
fn smallest_eigenvalue<const K: usize>(m: &SMatrix<f64, K, K>) -> f64 {
    nalgebra::SymmetricEigen::try_new(
        nalgebra::DMatrix::from_column_slice(K, K, m.as_slice()),
        f64::EPSILON,
        1000,
    )
    .map_or(f64::NAN, |e| e.eigenvalues.min())
}

/// The Gaussian a step returns, if its mean, covariance and log determinant are finite (a product
/// that overflows is refused, not carried on).
pub(crate) fn checked<const N: usize>(
    g: Gaussian<N>,
    what: &'static str,
) -> Result<Gaussian<N>, OperatorError> {
    all_finite(
        what,
        g.mean()
            .iter()
            .chain(g.covariance().iter())
            .chain(std::iter::once(&g.log_determinant())),
    )?;
    Ok(g)
}

/// Joseph's form of the updated covariance, `(I − K H) Σ (I − K H)ᵀ + K R Kᵀ`, positive
/// semi-definite whatever the rounding in K, from the Cholesky factor `Σ = L Lᵀ`: summed as two
/// Gram matrices, `X Xᵀ` with `X = (I − K H) L` and `Y Yᵀ` with `Y = K L_R`
/// (`R = L_R L_Rᵀ`, `L_R = diag(√rₘ)` for a diagonal R; `K R Kᵀ` itself, symmetrised, for a
/// singular R, which has no Cholesky factor). A Gram matrix rounds at the size of its own
/// entries; the product `(I − K H) Σ (I − K H)ᵀ` rounds at the size of Σ, and after a reading
/// far finer than the prior, where `I − K H` all but cancels along the reading, that rounding
/// swamped the posterior's variance there and left it negative (a constant-acceleration track
/// was refused in 123 of 450 settings of step, noise and prior; 3 now). Each Gram matrix is
/// symmetric to the bit, and so is their sum.
pub(crate) fn joseph<const N: usize, const M: usize>(
    factor: &SMatrix<f64, N, N>,
    gain: &SMatrix<f64, N, M>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
) -> SMatrix<f64, N, N> {
    joseph_from_spread(
        &((SMatrix::<f64, N, N>::identity() - gain * h) * factor),
        gain,
        r,
    )
}

/// Joseph's form from its first factor `X = (I − K H) L` formed by the caller:
/// `X Xᵀ + K R Kᵀ`, the second term as [`joseph`] forms it.
pub(crate) fn joseph_from_spread<const N: usize, const M: usize>(
    spread: &SMatrix<f64, N, N>,
    gain: &SMatrix<f64, N, M>,
    r: &SMatrix<f64, M, M>,
) -> SMatrix<f64, N, N> {
    let noise_factor = if is_diagonal(r) {
        Some(SMatrix::from_diagonal(&r.diagonal().map(f64::sqrt)))
    } else {
        Cholesky::new(*r).map(|c| c.l())
    };
    let noise = noise_factor.map_or_else(
        || symmetric_part(&(gain * r * gain.transpose())),
        |l| {
            let y = gain * l;
            y * y.transpose()
        },
    );
    spread * spread.transpose() + noise
}

impl<const N: usize> Propagate<LinearProcess<N>> for Gaussian<N> {
    type Input = SVector<f64, N>;

    /// `N(F μ + u, F Σ Fᵀ + Q)`.
    fn propagate(
        &self,
        model: &LinearProcess<N>,
        input: &SVector<f64, N>,
    ) -> Result<Self, OperatorError> {
        all_finite("process input u", input.iter())?;
        let f = &model.transition;
        let covariance = f * self.covariance() * f.transpose() + model.noise;
        let mean = f * self.mean() + input;
        checked(
            predicted(
                &covariance,
                |c| Gaussian::new(mean, c),
                Gaussian::cholesky_factor,
            )?,
            "predicted mean F mu + u or covariance F Sigma F^T + Q (it overflows)",
        )
    }
}

/// A linear prediction's density, `build(F Σ Fᵀ + Q)` from that `covariance` symmetrised,
/// [raised to its rounding](raised_to_rounding) (`Q + 64 N ε max P′ᵢᵢ I`) when rounding left it
/// singular, which its Cholesky `factor` (the density's own) shows (see the module docs): Q is
/// positive semi-definite and Σ definite, so such a failure is rounding's.
///
/// # Errors
/// [`OperatorError::NotPositiveDefinite`] when the raised covariance fails too, else the
/// density's own error.
pub(crate) fn predicted<T, const N: usize>(
    covariance: &SMatrix<f64, N, N>,
    build: impl Fn(SMatrix<f64, N, N>) -> Result<T, DensityError>,
    factor: impl Fn(&T) -> &SMatrix<f64, N, N>,
) -> Result<T, OperatorError> {
    const WHAT: &str = "predicted covariance F Sigma F^T + Q";
    raised_to_rounding(
        covariance,
        |c| definite(&build, symmetric_part(c), WHAT),
        factor,
        WHAT,
    )
    .map(|(density, _)| density)
}

/// `build(covariance)`, its refusal of a covariance that is not positive definite returned as
/// [`OperatorError::NotPositiveDefinite`] naming `what` (which [`above_rounding`] retries).
fn definite<T, const N: usize>(
    build: impl Fn(SMatrix<f64, N, N>) -> Result<T, DensityError>,
    covariance: SMatrix<f64, N, N>,
    what: &'static str,
) -> Result<T, OperatorError> {
    build(covariance).map_err(|error| {
        if Cholesky::new(covariance).is_none() {
            OperatorError::NotPositiveDefinite { what }
        } else {
            error.into()
        }
    })
}

impl<const N: usize, const M: usize> Condition<LinearMeasurement<N, M>> for Gaussian<N> {
    type Measurement = SVector<f64, M>;
    type Report = Innovation<N, M>;

    /// The Kalman update in Joseph form, with `ln N(z; H μ, S)` and the [`Innovation`] (see the module
    /// docs).
    fn condition(
        &self,
        model: &LinearMeasurement<N, M>,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<Self, Innovation<N, M>>, OperatorError> {
        all_finite("measurement z", z.iter())?;
        let h = &model.matrix;
        let sigma = self.covariance();
        let sigma_ht = sigma * h.transpose();
        above_rounding::<_, M>(
            || rounding_scale(h, sigma, &model.noise),
            |floor| {
                let r = model.noise + SMatrix::<f64, M, M>::identity() * floor;
                let (report, log_evidence) =
                    Innovation::new(z - h * self.mean(), &(h * sigma_ht + r), &sigma_ht, M)?;
                let covariance = joseph(self.cholesky_factor(), report.gain(), h, &r);
                let mean = self.mean() + report.correction();
                let posterior = checked(
                    definite(
                        |c| Gaussian::new(mean, c),
                        covariance,
                        "posterior covariance",
                    )?,
                    "posterior mean or covariance (it overflows)",
                )?;
                Ok(Conditioned {
                    posterior,
                    log_evidence,
                    report,
                })
            },
        )
    }
}
