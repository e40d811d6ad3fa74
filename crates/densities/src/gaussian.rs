//! [`Gaussian`]: the multivariate normal distribution on Rⁿ.

use crate::eigen::smallest_eigenvalue;
use crate::error::{DensityError, finite};
use crate::manifold_gaussian::inverse_trace_above;
use crate::traits::{Convolve, Density, Entropy, KlDivergence, Product};
use nalgebra::{Cholesky, SMatrix, SVector};
use rand::Rng;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

/// Relative asymmetry accepted in a covariance or information matrix: `|A − Aᵀ| ≤ 1e-12 max|A|`.
pub(crate) const SYMMETRY_TOLERANCE: f64 = 1e-12;

/// The largest magnitude of a mean (or feature) coordinate, of an entry of a covariance and of the
/// trace `tr P⁻¹` of its inverse (which bounds every entry of the inverse) that the Gaussian
/// constructors accept ([`Gaussian::new`], [`ManifoldGaussian::new`](crate::ManifoldGaussian::new),
/// [`HarmonicGaussian::new`](crate::HarmonicGaussian::new)): so covariances from about 1e-100 to
/// 1e100 in every direction. With it every derived quantity (sums of two covariances or information
/// matrices, Mahalanobis distances between two means, the KL divergence, ln det, samples, the
/// entropy) stays finite.
pub const MAX_SCALE: f64 = 1e100;

/// The normal distribution `N(μ, Σ)` on Rⁿ, with respect to the Lebesgue measure:
///
/// `p(x) = (2π)^(−n/2) det(Σ)^(−1/2) exp(−½ (x − μ)ᵀ Σ⁻¹ (x − μ))`.
///
/// Stored in moment form with the Cholesky factor `Σ = L Lᵀ` (computed once at construction, so
/// `log_pdf` and `sample` solve triangular systems and never invert). Any symmetric positive definite Σ
/// is accepted, however ill-conditioned, as long as its Cholesky factorisation exists in f64, the
/// entries of μ and Σ are at most 1e100 in magnitude and so is `tr Σ⁻¹` (so covariances from about
/// 1e-100 to 1e100 in every direction); near-singular covariances are refused with an error, never
/// repaired silently.
#[derive(Clone, Debug, PartialEq)]
pub struct Gaussian<const N: usize> {
    mean: SVector<f64, N>,
    covariance: SMatrix<f64, N, N>,
    cholesky: SMatrix<f64, N, N>,
    information: SMatrix<f64, N, N>,
    log_det: f64,
}

/// `|L⁻¹ v|²` for a lower triangular factor L with a positive diagonal, by one triangular solve of
/// v scaled to its largest entry: 0 for v = 0, NaN for a NaN entry, and +∞ where the exact value
/// overflows (a solve that overflows on the way, whose next row could meet ∞ − ∞, has a whitened
/// entry beyond f64's range, so its squared length is beyond it too).
pub(crate) fn whitened_squared_norm<const N: usize>(
    factor: &SMatrix<f64, N, N>,
    v: &SVector<f64, N>,
) -> f64 {
    if v.iter().any(|x| x.is_nan()) {
        return f64::NAN;
    }
    let scale = v.amax();
    if scale == 0.0 || scale.is_infinite() {
        return scale * scale;
    }
    let z = factor.solve_lower_triangular_unchecked(&(v / scale));
    if z.iter().all(|x| x.is_finite()) {
        let root = scale * z.norm();
        root * root
    } else {
        f64::INFINITY
    }
}

/// Checks that every entry is at most [`MAX_SCALE`] in magnitude.
pub(crate) fn within_scale<const R: usize, const C: usize>(
    what: &'static str,
    m: &SMatrix<f64, R, C>,
) -> Result<(), DensityError> {
    largest_within_scale(what, m.amax())
}

/// [`within_scale`] for a matrix whose largest magnitude `largest` is known.
pub(crate) fn largest_within_scale(what: &'static str, largest: f64) -> Result<(), DensityError> {
    if largest > MAX_SCALE {
        return Err(DensityError::OutOfRange {
            what,
            value: largest,
            range: "entries of at most 1e100 in magnitude (the value shown is the largest)",
        });
    }
    Ok(())
}

/// Checks that a matrix is finite, symmetric (to [`SYMMETRY_TOLERANCE`]) and positive definite, and
/// returns its lower Cholesky factor.
fn spd_cholesky<const N: usize>(
    what: &'static str,
    m: &SMatrix<f64, N, N>,
) -> Result<SMatrix<f64, N, N>, DensityError> {
    for &v in m.iter() {
        finite(what, v)?;
    }
    within_scale(what, m)?;
    let scale = m.amax();
    let asymmetry = (m - m.transpose()).amax();
    if asymmetry > SYMMETRY_TOLERANCE * scale {
        return Err(DensityError::OutOfRange {
            what,
            value: asymmetry,
            range: "symmetric matrices (|A - A^T| <= 1e-12 max|A|); symmetrise it with (A + A^T)/2",
        });
    }
    let symmetric = (m + m.transpose()) * 0.5;
    Cholesky::new(symmetric)
        .map(|c| c.l())
        .ok_or_else(|| DensityError::OutOfRange {
            what,
            // The smallest eigenvalue for the message (a dynamic copy: this is the error path only).
            value: smallest_eigenvalue(N, symmetric.as_slice()),
            range: "positive definite matrices (the value shown is the smallest eigenvalue)",
        })
}

impl<const N: usize> Gaussian<N> {
    /// `N(mean, covariance)`.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for NaN or infinite entries, [`DensityError::OutOfRange`] for a
    /// covariance that is not symmetric or not positive definite (with its smallest eigenvalue), or
    /// when an entry of μ or Σ, or the trace `tr Σ⁻¹`, exceeds 1e100 (Σ = 1e308 I and Σ = 1e-310 I
    /// were accepted before, with an infinite or NaN information matrix). The trace bounds every
    /// entry of Σ⁻¹ and is the rule of [`ManifoldGaussian::new`](crate::ManifoldGaussian::new) and
    /// [`HarmonicGaussian::new`](crate::HarmonicGaussian::new), so the three accept the same
    /// covariances (Σ = 1.5e-100 I₂, whose inverse has entries of 6.7e99 and trace 1.3e100, was
    /// accepted here alone).
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::{Convolve, Density, Gaussian};
    /// use nalgebra::{Matrix2, Vector2};
    /// let p = Gaussian::new(Vector2::new(1.0, -1.0), Matrix2::new(2.0, 0.5, 0.5, 1.0)).unwrap();
    /// // At the mean, ln N = −ln(2π) − ½ ln det Σ (det Σ = 1.75).
    /// let peak = -(2.0 * std::f64::consts::PI).ln() - 0.5 * 1.75_f64.ln();
    /// assert!((p.log_pdf(p.mean()) - peak).abs() < 1e-14);
    /// // Convolution adds means and covariances.
    /// let sum = p.convolve(&p).unwrap();
    /// assert!((sum.covariance() - p.covariance() * 2.0).norm() < 1e-14);
    /// ```
    pub fn new(
        mean: SVector<f64, N>,
        covariance: SMatrix<f64, N, N>,
    ) -> Result<Self, DensityError> {
        for &v in mean.iter() {
            finite("mean", v)?;
        }
        within_scale("mean", &mean)?;
        let cholesky = spd_cholesky("covariance", &covariance)?;
        if let Some(inverse_trace) = inverse_trace_above(&cholesky, MAX_SCALE) {
            return Err(DensityError::OutOfRange {
                what: "trace of the inverse covariance Sigma^-1",
                value: inverse_trace,
                range: "at most 1e100: the covariance's eigenvalues must be above about 1e-100",
            });
        }
        let information = Cholesky::pack_dirty(cholesky).inverse();
        let log_det = 2.0 * cholesky.diagonal().iter().map(|d| d.ln()).sum::<f64>();
        Ok(Self {
            mean,
            covariance: covariance * 0.5 + covariance.transpose() * 0.5,
            cholesky,
            information,
            log_det,
        })
    }

    /// The Gaussian with natural parameters in information form, `p(x) ∝ exp(hᵀx − ½ xᵀ Λ x)`: the
    /// information vector `h = Σ⁻¹ μ` and the information matrix `Λ = Σ⁻¹`.
    ///
    /// # Errors
    /// As [`new`](Self::new), for Λ (and for the Σ and μ it gives).
    pub fn from_natural(
        information_vector: SVector<f64, N>,
        information_matrix: SMatrix<f64, N, N>,
    ) -> Result<Self, DensityError> {
        for &v in information_vector.iter() {
            finite("information vector", v)?;
        }
        let l = spd_cholesky("information matrix", &information_matrix)?;
        let chol = Cholesky::pack_dirty(l);
        let covariance = chol.inverse();
        let mean = chol.solve(&information_vector);
        Self::new(mean, covariance * 0.5 + covariance.transpose() * 0.5)
    }

    /// The mean μ.
    pub fn mean(&self) -> &SVector<f64, N> {
        &self.mean
    }

    /// The covariance Σ.
    pub fn covariance(&self) -> &SMatrix<f64, N, N> {
        &self.covariance
    }

    /// The lower Cholesky factor L with Σ = L Lᵀ.
    pub fn cholesky_factor(&self) -> &SMatrix<f64, N, N> {
        &self.cholesky
    }

    /// The natural parameters in information form, `(h, Λ) = (Σ⁻¹ μ, Σ⁻¹)` (Λ by the Cholesky
    /// factor, computed once at construction).
    pub fn natural(&self) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        (self.information * self.mean, self.information)
    }

    /// The squared Mahalanobis distance `(x − μ)ᵀ Σ⁻¹ (x − μ)`, by one triangular solve on the
    /// difference scaled to unit size (so that coordinates near f64::MAX give +∞, never NaN). NaN for
    /// a point with a NaN coordinate.
    ///
    /// # Panics
    /// Never: the Cholesky factor of a positive definite matrix has a positive diagonal.
    pub fn mahalanobis_squared(&self, x: &SVector<f64, N>) -> f64 {
        // Halves first: x − μ overflows for coordinates of opposite sign near f64::MAX.
        let half = x * 0.5 - self.mean * 0.5;
        // The factor of a successful Cholesky decomposition has a positive diagonal.
        4.0 * whitened_squared_norm(&self.cholesky, &half)
    }

    /// `ln det Σ`.
    pub fn log_determinant(&self) -> f64 {
        self.log_det
    }
}

impl<const N: usize> Density for Gaussian<N> {
    type Point = SVector<f64, N>;

    /// `−½ (n ln 2π + ln det Σ + (x − μ)ᵀ Σ⁻¹ (x − μ))`; −∞ where the Mahalanobis distance
    /// overflows (points beyond about 1e154 standard deviations), NaN for a point with a NaN
    /// coordinate.
    fn log_pdf(&self, x: &SVector<f64, N>) -> f64 {
        -0.5 * self.mahalanobis_squared(x) - self.log_normalizer()
    }

    /// `½ (n ln 2π + ln det Σ)`.
    fn log_normalizer(&self) -> f64 {
        0.5 * (N as f64 * (2.0 * PI).ln() + self.log_det)
    }

    /// `μ + L z`, z standard normal.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> SVector<f64, N> {
        let z = SVector::<f64, N>::from_fn(|_, _| rng.sample(StandardNormal));
        self.mean + self.cholesky * z
    }

    /// The mean.
    fn mode(&self) -> Option<SVector<f64, N>> {
        Some(self.mean)
    }
}

impl<const N: usize> rand::distr::Distribution<SVector<f64, N>> for Gaussian<N> {
    /// One draw, by [`Density::sample`].
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> SVector<f64, N> {
        Density::sample(self, rng)
    }
}

impl<const N: usize> Convolve for Gaussian<N> {
    /// The distribution of x + y: means and covariances add (exact).
    fn convolve(&self, other: &Self) -> Result<Self, DensityError> {
        Self::new(self.mean + other.mean, self.covariance + other.covariance)
    }
}

impl<const N: usize> Product for Gaussian<N> {
    /// Information forms add: `Λ = Λ₁ + Λ₂`, `h = h₁ + h₂`.
    fn product(&self, other: &Self) -> Result<Self, DensityError> {
        let (l1, l2) = (&self.information, &other.information);
        Self::from_natural(l1 * self.mean + l2 * other.mean, l1 + l2)
    }

    /// `ln ∫ p₁ p₂ = ln N(μ₁; μ₂, Σ₁ + Σ₂)`, by the Cholesky factor L of `Σ₁ + Σ₂` (entries at most
    /// 2e100, positive definite): `−½ (n ln 2π + ln det Σ₁₂ + |L⁻¹ (μ₁ − μ₂)|²)`.
    ///
    /// # Errors
    /// As [`product`](Product::product), exactly where it fails (the product's information matrix
    /// beyond the accepted range), and [`DensityError::OutOfRange`] where the value is not finite (a
    /// Mahalanobis distance beyond the f64 range).
    fn log_product_integral(&self, other: &Self) -> Result<f64, DensityError> {
        self.product(other)?;
        let sum = self.covariance + other.covariance;
        let value = Cholesky::new(sum).map_or(f64::NAN, |factor| {
            let l = factor.l();
            let log_det = 2.0 * l.diagonal().iter().map(|d| d.ln()).sum::<f64>();
            -0.5 * (whitened_squared_norm(&l, &(self.mean - other.mean))
                + N as f64 * (2.0 * PI).ln()
                + log_det)
        });
        if value.is_finite() {
            Ok(value)
        } else {
            Err(DensityError::OutOfRange {
                what: "log evidence ln N(mu1; mu2, Sigma1 + Sigma2)",
                value,
                range: "finite values: the means are too far apart for the covariances",
            })
        }
    }
}

impl<const N: usize> Entropy for Gaussian<N> {
    /// `½ (n (1 + ln 2π) + ln det Σ)`.
    fn entropy(&self) -> f64 {
        0.5 * (N as f64 * (1.0 + (2.0 * PI).ln()) + self.log_det)
    }
}

impl<const N: usize> KlDivergence for Gaussian<N> {
    /// `½ (tr(Σ_q⁻¹ Σ_p) + (μ_q − μ_p)ᵀ Σ_q⁻¹ (μ_q − μ_p) − n + ln det Σ_q − ln det Σ_p)`.
    fn kl_divergence(&self, other: &Self) -> f64 {
        let solved = other
            .cholesky
            .solve_lower_triangular(&self.cholesky)
            .expect("the Cholesky factor has a positive diagonal");
        let trace = solved.norm_squared(); // tr(Σ_q⁻¹ Σ_p) = ‖L_q⁻¹ L_p‖_F²
        0.5 * (trace + other.mahalanobis_squared(&self.mean) - N as f64 + other.log_det
            - self.log_det)
    }
}
