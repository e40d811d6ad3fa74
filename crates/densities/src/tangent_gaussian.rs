//! [`TangentGaussian`]: a Gaussian in the tangent space of a Lie group ("concentrated Gaussian").

use crate::error::DensityError;
use crate::gaussian::Gaussian;
use crate::traits::Density;
use liebayes_manifolds::{Jacobian, LieGroup, Tangent};
use nalgebra::{SMatrix, SVector};
use rand::Rng;

/// The distribution of `μ ⊞ ξ = μ · exp(ξ)` with `ξ ~ N(0, Σ)` in the tangent space at the mean μ
/// (right perturbation, the convention of the whole library).
///
/// `log_pdf(x)` is the Gaussian log density of the tangent vector `ξ = x ⊟ μ`: a density with respect
/// to the Lebesgue measure **in exponential coordinates at μ**. It differs from the density against the
/// Haar measure by the factor `|det Jr(ξ)|⁻¹` (1 − |ξ|²/12 + … for SO(3)), so it is the usual
/// concentrated-Gaussian approximation, exact only in the limit of small Σ. Conversions to and from the
/// exact families (Bingham, heat kernel) are named approximations in those types.
#[derive(Clone, Debug)]
pub struct TangentGaussian<G, const D: usize> {
    mean: G,
    tangent: Gaussian<D>,
}

impl<G: LieGroup<D, Scalar = f64>, const D: usize> TangentGaussian<G, D> {
    /// The distribution `mean ⊞ N(0, covariance)`.
    ///
    /// # Errors
    /// As [`Gaussian::new`] for the covariance.
    pub fn new(mean: G, covariance: SMatrix<f64, D, D>) -> Result<Self, DensityError> {
        Ok(Self {
            mean,
            tangent: Gaussian::new(SVector::zeros(), covariance)?,
        })
    }

    /// The mean μ (a group element).
    pub fn mean(&self) -> &G {
        &self.mean
    }

    /// The covariance Σ of the tangent perturbation at the mean.
    pub fn covariance(&self) -> &SMatrix<f64, D, D> {
        self.tangent.covariance()
    }

    /// The first-order covariance `J Σ Jᵀ` of `f(x)` for a map with Jacobian `J` at the mean. Unlike
    /// [`propagate`](Self::propagate) it accepts rank-deficient results (rotating a point p cannot move
    /// it along p, so the covariance of R p is singular).
    pub fn propagated_covariance<const E: usize>(
        &self,
        jacobian: &Jacobian<f64, E, D>,
    ) -> SMatrix<f64, E, E> {
        jacobian * self.covariance() * jacobian.transpose()
    }

    /// **First-order propagation** through `y = f(x)` with right Jacobian `J = ∂f/∂x` at the mean:
    /// `y ~ f(μ) ⊞ N(0, J Σ Jᵀ)`. Exact for maps that are affine in the tangent coordinates (group
    /// translations, the adjoint); for others the error is of order Σ² times the second derivative.
    ///
    /// # Errors
    /// When `J Σ Jᵀ` is not positive definite (J rank-deficient): a degenerate Gaussian is refused,
    /// not repaired.
    pub fn propagate<H: LieGroup<E, Scalar = f64>, const E: usize>(
        &self,
        image_of_mean: H,
        jacobian: &Jacobian<f64, E, D>,
    ) -> Result<TangentGaussian<H, E>, DensityError> {
        TangentGaussian::new(image_of_mean, self.propagated_covariance(jacobian))
    }

    /// The distribution of `a · b` for independent `a ~ self` and `b ~ other`, to first order:
    /// mean `μ_a μ_b`, covariance `Ad(μ_b⁻¹) Σ_a Ad(μ_b⁻¹)ᵀ + Σ_b` (from `J_compose_self` and
    /// `J_compose_other`).
    ///
    /// # Errors
    /// Only if the resulting covariance overflows.
    pub fn compose(&self, other: &Self) -> Result<Self, DensityError> {
        let ja = self.mean.j_compose_self(&other.mean);
        let covariance = ja * self.covariance() * ja.transpose() + other.covariance();
        Self::new(self.mean.compose(&other.mean), covariance)
    }

    /// The tangent vector `x ⊟ μ` and its Gaussian log density.
    pub fn tangent_log_pdf(&self, x: &G) -> (Tangent<f64, D>, f64) {
        let xi = self.mean.local(x);
        (xi, self.tangent.log_pdf(&xi))
    }
}

impl<G: LieGroup<D, Scalar = f64>, const D: usize> Density for TangentGaussian<G, D> {
    type Point = G;

    /// The Gaussian log density of `x ⊟ μ` (in exponential coordinates at μ; see the type docs).
    fn log_pdf(&self, x: &G) -> f64 {
        self.tangent_log_pdf(x).1
    }

    /// `½ (d ln 2π + ln det Σ)`.
    fn log_normalizer(&self) -> f64 {
        self.tangent.log_normalizer()
    }

    /// `μ ⊞ ξ`, ξ ~ N(0, Σ).
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> G {
        self.mean.retract(&self.tangent.sample(rng))
    }

    /// The mean.
    fn mode(&self) -> Option<G> {
        Some(self.mean.clone())
    }
}
