//! [`HarmonicGaussian`]: the joint density of an angle and a vector whose conditional mean is linear in
//! the angle's first harmonics.

use crate::error::DensityError;
use crate::gaussian::{
    Gaussian, MAX_SCALE, SYMMETRY_TOLERANCE, whitened_squared_norm, within_scale,
};
use crate::gen_von_mises::GenVonMises2;
use crate::manifold_gaussian::inverse_trace_above;
use crate::traits::{Density, Entropy, KlDivergence};
use liebayes_manifolds::So2;
use nalgebra::{Cholesky, Matrix3, SMatrix, SVector, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

/// The features of the conditional mean, `φ(y) = (1, cos y, sin y)`, of an angle (a point of the
/// circle, so that the features are finite).
pub fn harmonic_features(y: &So2<f64>) -> Vector3<f64> {
    Vector3::new(1.0, y.cos(), y.sin())
}

/// `p(y, x) = GVM₂(y; η₁, η₂) · N(x; B φ(y), Σ)` over an angle y and a vector x ∈ Rᴺ, with
/// `φ(y) = (1, cos y, sin y)` ([`harmonic_features`]), B an N × 3 feature matrix and Σ the same for
/// every y. The base measure is `dy dx` (dy over the circle, total 2π); a point is the pair
/// `(y, x)`.
///
/// The family is closed under linear processes of x and under two kinds of measurement (linear ones
/// independent of y, and measurements of x in a frame turned by y when `H Σ Hᵀ` is isotropic): the
/// operators crate's `rao_blackwell` module propagates and conditions it exactly, with the log evidence
/// (derivations in `docs/operators/rao_blackwell.md`). The azimuth-alignment filter's seven-number posterior (an angle and a 2-D drift with a von Mises marginal) is
/// the special case `B = [a, c, −c^×]`, `Σ = σ² I`, η₂ = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct HarmonicGaussian<const N: usize> {
    angle: GenVonMises2,
    features: SMatrix<f64, N, 3>,
    covariance: SMatrix<f64, N, N>,
    /// L, lower triangular, `Σ = L Lᵀ`.
    cholesky: SMatrix<f64, N, N>,
    /// `ln det Σ`.
    log_det: f64,
}

impl<const N: usize> HarmonicGaussian<N> {
    /// The density with angle marginal p(y), feature matrix B and conditional covariance Σ, which
    /// must be symmetric to the rule of [`Gaussian::new`] (`max|Σ − Σᵀ| ≤ 1e-12 max|Σ|`) and
    /// positive definite; it is stored symmetrised as `(Σ + Σᵀ)/2`, which removes only that
    /// rounding.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for non-finite B or Σ, [`DensityError::OutOfRange`] when Σ is not
    /// symmetric (beyond 1e-12 of its largest entry: symmetrise it with `(Σ + Σᵀ)/2` first) or not
    /// positive definite, or for an entry of B or Σ, or the trace of Σ⁻¹, above
    /// [`MAX_SCALE`](crate::MAX_SCALE) = 1e100, the limit of every Gaussian.
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
        within_scale("feature matrix B", &features)?;
        within_scale("conditional covariance Sigma", &covariance)?;
        // The Gaussian's rule: a Σ such as [[1, 1e100], [−1e100, 1]] is not a covariance, and
        // averaging it with its transpose would silently make it the identity.
        let asymmetry = (covariance - covariance.transpose()).amax();
        if asymmetry > SYMMETRY_TOLERANCE * covariance.amax() {
            return Err(DensityError::OutOfRange {
                what: "conditional covariance Sigma (value: max |Sigma - Sigma^T|)",
                value: asymmetry,
                range: "symmetric matrices (|A - A^T| <= 1e-12 max|A|); symmetrise it with \
                        (A + A^T)/2",
            });
        }
        let covariance = (covariance + covariance.transpose()) * 0.5;
        let Some(factor) = Cholesky::new(covariance) else {
            return Err(DensityError::OutOfRange {
                what: "conditional covariance Sigma (value: its smallest diagonal entry)",
                value: covariance.diagonal().min(),
                range: "symmetric positive definite matrices",
            });
        };
        let cholesky = factor.unpack();
        if let Some(inverse_trace) = inverse_trace_above(&cholesky, MAX_SCALE) {
            return Err(DensityError::OutOfRange {
                what: "trace of the inverse conditional covariance Sigma^-1",
                value: inverse_trace,
                range: "at most 1e100: Sigma's eigenvalues must be above about 1e-100",
            });
        }
        let log_det = 2.0 * cholesky.diagonal().iter().map(|d| d.ln()).sum::<f64>();
        Ok(Self {
            angle,
            features,
            covariance,
            cholesky,
            log_det,
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
    pub fn conditional_mean(&self, y: &So2<f64>) -> SVector<f64, N> {
        self.features * harmonic_features(y)
    }

    /// The lower Cholesky factor L with `Σ = L Lᵀ` (computed once, at construction).
    pub fn cholesky_factor(&self) -> &SMatrix<f64, N, N> {
        &self.cholesky
    }

    /// `E φ(y)` and `E φ(y) φ(y)ᵀ` under p(y), from its first and second trigonometric moments:
    /// `E cos² = (1 + E cos 2y)/2`, `E sin² = (1 − E cos 2y)/2`, `E cos sin = E sin 2y / 2`.
    fn feature_moments(&self) -> (Vector3<f64>, Matrix3<f64>) {
        let (m1, m2) = self.angle.trigonometric_moments();
        let second = Matrix3::new(
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
        (Vector3::new(1.0, m1.x, m1.y), second)
    }

    /// The marginal moments of x: `E x = B E φ`, with the first trigonometric moments of p(y), and
    /// `Cov x = Σ + B Cov(φ) Bᵀ`. The second term is summed over the angle's quadrature nodes as
    /// `Σᵢ pᵢ vᵢ vᵢᵀ`, `vᵢ = B (φ(yᵢ) − E φ)` (the centred harmonics of the angle's normaliser
    /// rule): a sum of squares, positive semi-definite by construction and accurate to its own size
    /// at any concentration, so `Cov x` is positive definite (up to the rounding of adding it to
    /// Σ). The form `E φφᵀ − E φ E φᵀ` cancelled to ±1e-16 where the variance of cos y is 5e-25 (κ
    /// = 1e12), and `Cov x` came out negative for Σ = 1e-30.
    pub fn marginal_moments(&self) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        let (mean_phi, _) = self.feature_moments();
        let harmonics = self.features.fixed_columns::<2>(1);
        let mut spread = SMatrix::<f64, N, N>::zeros();
        self.angle.for_each_centred_harmonic(|r, p| {
            let v = harmonics * r;
            spread += v * v.transpose() * p;
        });
        let cov = self.covariance + spread;
        (self.features * mean_phi, (cov + cov.transpose()) * 0.5)
    }

    /// `(x − B φ(y))ᵀ Σ⁻¹ (x − B φ(y))`, by one triangular solve; +∞ for a finite x whose residual
    /// overflows (x within 1e100 of ±f64::MAX), the exact value's overflow.
    fn conditional_mahalanobis_squared(&self, y: &So2<f64>, x: &SVector<f64, N>) -> f64 {
        let residual = x - self.conditional_mean(y);
        if residual.iter().any(|r| r.is_infinite()) && x.iter().all(|v| v.is_finite()) {
            return f64::INFINITY;
        }
        // The factor of a successful Cholesky decomposition has a positive diagonal.
        whitened_squared_norm(&self.cholesky, &residual)
    }

    /// `½ (N ln 2π + ln det Σ)`, the conditional Gaussian's log normaliser.
    fn gaussian_log_normalizer(&self) -> f64 {
        0.5 * (N as f64 * (2.0 * PI).ln() + self.log_det)
    }
}

impl<const N: usize> Density for HarmonicGaussian<N> {
    type Point = (So2<f64>, SVector<f64, N>);

    /// `ln GVM₂(y) − ½ (N ln 2π + ln det Σ + (x − B φ(y))ᵀ Σ⁻¹ (x − B φ(y)))`, against dy dx.
    fn log_pdf(&self, (y, x): &Self::Point) -> f64 {
        self.angle.log_pdf(y)
            - 0.5 * self.conditional_mahalanobis_squared(y, x)
            - self.gaussian_log_normalizer()
    }

    /// `ln Z_angle + ½ (N ln 2π + ln det Σ)`.
    fn log_normalizer(&self) -> f64 {
        self.angle.log_normalizer() + self.gaussian_log_normalizer()
    }

    /// y from the angle marginal (see [`GenVonMises2`]'s sampler), then `x = B φ(y) + L z`, z standard
    /// normal.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Self::Point {
        let y = self.angle.sample(rng);
        let z = SVector::<f64, N>::from_fn(|_, _| rng.sample(StandardNormal));
        let x = self.conditional_mean(&y) + self.cholesky * z;
        (y, x)
    }

    /// `(y*, B φ(y*))` with y* the angle marginal's mode: `p(y, x) ≤ p(y) N(0; 0, Σ)` with equality
    /// at `x = B φ(y)`; `None` where the angle has no unique mode.
    fn mode(&self) -> Option<Self::Point> {
        self.angle.mode().map(|y| (y, self.conditional_mean(&y)))
    }
}

impl<const N: usize> rand::distr::Distribution<(So2<f64>, SVector<f64, N>)>
    for HarmonicGaussian<N>
{
    /// One draw, by [`Density::sample`].
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> (So2<f64>, SVector<f64, N>) {
        Density::sample(self, rng)
    }
}

impl<const N: usize> Entropy for HarmonicGaussian<N> {
    /// `H(y) + H(x | y) = H_GVM₂ + ½ (N (1 + ln 2π) + ln det Σ)` (the conditional entropy does not
    /// depend on y).
    fn entropy(&self) -> f64 {
        self.angle.entropy() + 0.5 * (N as f64 * (1.0 + (2.0 * PI).ln()) + self.log_det)
    }
}

impl<const N: usize> KlDivergence for HarmonicGaussian<N> {
    /// The chain rule, `KL(p(y) ‖ q(y)) + E_p(y)[KL(p(x|y) ‖ q(x|y))]`, with the Gaussian term
    /// `½ (tr(Σ_q⁻¹ Σ_p) − N + ln det Σ_q − ln det Σ_p + tr(ΔBᵀ Σ_q⁻¹ ΔB E_p[φ φᵀ]))`, `ΔB = B_p − B_q`
    /// (the mean gap `ΔB φ(y)` averaged over p(y) through its trigonometric moments).
    fn kl_divergence(&self, other: &Self) -> f64 {
        let (_, second) = self.feature_moments();
        // L_q⁻¹ L_p and L_q⁻¹ ΔB: tr(Σ_q⁻¹ Σ_p) = ‖L_q⁻¹ L_p‖²_F, ΔBᵀ Σ_q⁻¹ ΔB = Wᵀ W.
        let trace = other
            .cholesky
            .solve_lower_triangular_unchecked(&self.cholesky)
            .norm_squared();
        let w = other
            .cholesky
            .solve_lower_triangular_unchecked(&(self.features - other.features));
        let gap = (w.transpose() * w).component_mul(&second).sum();
        self.angle.kl_divergence(&other.angle)
            + 0.5 * (trace - N as f64 + other.log_det - self.log_det + gap)
    }
}
