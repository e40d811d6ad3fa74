//! [`HarmonicGaussian`]: the joint density of an angle and a vector whose conditional mean is linear in
//! the angle's first harmonics.

use crate::error::DensityError;
use crate::gaussian::Gaussian;
use crate::gen_von_mises::GenVonMises2;
use nalgebra::{Cholesky, SMatrix, SVector, Vector3};

/// The features of the conditional mean, `φ(y) = (1, cos y, sin y)`.
pub fn harmonic_features(y: f64) -> Vector3<f64> {
    let (s, c) = y.sin_cos();
    Vector3::new(1.0, c, s)
}

/// `p(y, x) = GVM₂(y; η₁, η₂) · N(x; B φ(y), Σ)` over an angle y and a vector x ∈ Rᴺ, with
/// `φ(y) = (1, cos y, sin y)` ([`harmonic_features`]), B an N × 3 feature matrix and Σ the same for
/// every y. The base measure is `dy dx` (dy over the circle, total 2π).
///
/// The family is closed under linear processes of x and under two kinds of measurement (linear ones
/// independent of y, and measurements of x in a frame turned by y when `H Σ Hᵀ` is isotropic): the
/// operators crate's `rao_blackwell` module propagates and conditions it exactly, with the log evidence
/// (derivations in `docs/operators/rao_blackwell.md`). Seed 000's seven-number azimuth filter is the
/// special case `B = [a, c, −c^×]`, `Σ = σ² I`, η₂ = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct HarmonicGaussian<const N: usize> {
    angle: GenVonMises2,
    features: SMatrix<f64, N, 3>,
    covariance: SMatrix<f64, N, N>,
}

impl<const N: usize> HarmonicGaussian<N> {
    /// The density with angle marginal p(y), feature matrix B and conditional covariance Σ, stored
    /// symmetrised as `(Σ + Σᵀ)/2`, which must be positive definite.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for non-finite B or Σ, [`DensityError::OutOfRange`] when Σ is not
    /// positive definite.
    pub fn new(
        angle: GenVonMises2,
        features: SMatrix<f64, N, 3>,
        covariance: SMatrix<f64, N, N>,
    ) -> Result<Self, DensityError> {
        if let Some(&value) = features.iter().find(|v| !v.is_finite()) {
            return Err(DensityError::NonFinite {
                what: "feature matrix B",
                value,
            });
        }
        if let Some(&value) = covariance.iter().find(|v| !v.is_finite()) {
            return Err(DensityError::NonFinite {
                what: "conditional covariance Sigma",
                value,
            });
        }
        let covariance = (covariance + covariance.transpose()) * 0.5;
        if Cholesky::new(covariance).is_none() {
            return Err(DensityError::OutOfRange {
                what: "conditional covariance Sigma (value: its smallest diagonal entry)",
                value: covariance.diagonal().min(),
                range: "symmetric positive definite matrices",
            });
        }
        Ok(Self {
            angle,
            features,
            covariance,
        })
    }

    /// Independent y and x: `B = [μ, 0, 0]`, Σ the covariance of x.
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn independent(angle: GenVonMises2, x: &Gaussian<N>) -> Result<Self, DensityError> {
        let mut features = SMatrix::<f64, N, 3>::zeros();
        features.set_column(0, x.mean());
        Self::new(angle, features, *x.covariance())
    }

    /// p(y).
    pub fn angle(&self) -> &GenVonMises2 {
        &self.angle
    }

    /// B: `E[x | y] = B φ(y)`.
    pub fn features(&self) -> &SMatrix<f64, N, 3> {
        &self.features
    }

    /// Σ = Cov[x | y].
    pub fn covariance(&self) -> &SMatrix<f64, N, N> {
        &self.covariance
    }

    /// `E[x | y] = B φ(y)`.
    pub fn conditional_mean(&self, y: f64) -> SVector<f64, N> {
        self.features * harmonic_features(y)
    }

    /// The marginal moments of x: `E x = B E φ`, `Cov x = Σ + B Cov(φ) Bᵀ`, with the first and second
    /// trigonometric moments of p(y).
    pub fn marginal_moments(&self) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        let (m1, m2) = self.angle.trigonometric_moments();
        let mean_phi = Vector3::new(1.0, m1.x, m1.y);
        // E φ φᵀ: E cos² = (1 + E cos 2y)/2, E sin² = (1 − E cos 2y)/2, E cos sin = E sin 2y / 2.
        let second = SMatrix::<f64, 3, 3>::new(
            1.0,
            m1.x,
            m1.y,
            m1.x,
            0.5 * (1.0 + m2.x),
            0.5 * m2.y,
            m1.y,
            0.5 * m2.y,
            0.5 * (1.0 - m2.x),
        );
        let cov_phi = second - mean_phi * mean_phi.transpose();
        let cov = self.covariance + self.features * cov_phi * self.features.transpose();
        (self.features * mean_phi, (cov + cov.transpose()) * 0.5)
    }
}
