//! [`VonMisesFisher`]: the von Mises-Fisher distribution on the sphere S².

use crate::error::{DensityError, non_negative};
use crate::special;
use crate::traits::{Density, Entropy, KlDivergence, Product};
use liebayes_manifolds::{GroupAction, S2, So3};
use nalgebra::Vector3;
use rand::Rng;
use std::f64::consts::TAU;

/// The von Mises-Fisher distribution on S²:
///
/// `p(x) = C(κ) exp(κ μ · x)`, `C(κ) = κ / (4π sinh κ)` (`1/(4π)` at κ = 0),
///
/// with respect to the surface measure of the unit sphere (total area 4π). Natural parameter
/// `η = κ μ`; mean direction μ ∈ S², concentration κ ≥ 0.
///
/// Range: κ from 0 (and 1e-300) to 1e6 and beyond; the log normaliser never forms sinh κ
/// ([`special::vmf_log_normalizer`]). See `docs/densities/von_mises_fisher.md`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VonMisesFisher {
    mean: S2<f64>,
    kappa: f64,
}

impl VonMisesFisher {
    /// The distribution with mean direction `mean` and concentration `kappa ≥ 0`.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] for a negative κ.
    pub fn new(mean: S2<f64>, kappa: f64) -> Result<Self, DensityError> {
        non_negative("concentration kappa", kappa)?;
        Ok(Self { mean, kappa })
    }

    /// The distribution with natural parameter `η = κ μ` (the uniform distribution for η = 0).
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for NaN or infinite components.
    pub fn from_natural(eta: &Vector3<f64>) -> Result<Self, DensityError> {
        for &v in eta.iter() {
            crate::error::finite("eta component", v)?;
        }
        Ok(match S2::from_vector_normalizing(eta) {
            Ok(mean) => Self {
                mean,
                kappa: eta.norm(),
            },
            Err(_) => Self::uniform(),
        })
    }

    /// The uniform distribution on the sphere, `1/(4π)`.
    pub fn uniform() -> Self {
        Self {
            mean: S2::new_unchecked(Vector3::z()),
            kappa: 0.0,
        }
    }

    /// The natural parameter `η = κ μ`.
    pub fn eta(&self) -> Vector3<f64> {
        self.mean.as_vector() * self.kappa
    }

    /// The concentration κ.
    pub fn concentration(&self) -> f64 {
        self.kappa
    }

    /// The mean direction μ, or `None` for the uniform distribution.
    pub fn mean_direction(&self) -> Option<S2<f64>> {
        (self.kappa > 0.0).then_some(self.mean)
    }

    /// The mean vector `E[x] = (coth κ − 1/κ) μ`.
    pub fn mean_vector(&self) -> Vector3<f64> {
        self.mean.as_vector() * special::vmf_mean_resultant(self.kappa)
    }

    /// The distribution of `R x` for `x` drawn from this one: mean `R μ`, same κ.
    #[must_use]
    pub fn rotated(&self, r: &So3<f64>) -> Self {
        Self {
            mean: S2::new_unchecked(r.act(self.mean.as_vector())),
            kappa: self.kappa,
        }
    }
}

impl Density for VonMisesFisher {
    type Point = S2<f64>;

    /// `ln C(κ) + κ μ · x`.
    fn log_pdf(&self, x: &S2<f64>) -> f64 {
        special::vmf_log_normalizer(self.kappa)
            + self.kappa * self.mean.as_vector().dot(x.as_vector())
    }

    /// `ln Z = −ln C(κ) = ln(4π sinh κ / κ)`.
    fn log_normalizer(&self) -> f64 {
        -special::vmf_log_normalizer(self.kappa)
    }

    /// Wood's (1994) algorithm, which on S² needs no rejection: the cosine `w = μ · x` has the exact
    /// inverse CDF `w = 1 + ln(u + (1 − u) e^(−2κ)) / κ`, evaluated as
    /// `1 − w = −ln_1p((1 − u) expm1(−2κ)) / κ` so that neither κ → 0 nor κ = 1e6 loses digits; the
    /// direction around μ is uniform.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> S2<f64> {
        let u: f64 = rng.random();
        let one_minus_w = if self.kappa > 0.0 {
            -((1.0 - u) * (-2.0 * self.kappa).exp_m1()).ln_1p() / self.kappa
        } else {
            2.0 * (1.0 - u)
        };
        let one_minus_w = one_minus_w.clamp(0.0, 2.0);
        let w = 1.0 - one_minus_w;
        let radius = (one_minus_w * (2.0 - one_minus_w)).sqrt();
        let (s, c) = (TAU * rng.random::<f64>()).sin_cos();
        let basis = self.mean.tangent_basis();
        let x = self.mean.as_vector() * w + (basis.column(0) * c + basis.column(1) * s) * radius;
        S2::new_unchecked(x.normalize())
    }

    /// The mean direction (none for κ = 0).
    fn mode(&self) -> Option<S2<f64>> {
        self.mean_direction()
    }
}

impl Product for VonMisesFisher {
    /// `η = η₁ + η₂` (exact).
    fn product(&self, other: &Self) -> Result<Self, DensityError> {
        Self::from_natural(&(self.eta() + other.eta()))
    }

    /// `ln ∫ p₁ p₂ dS = ln Z(η₁ + η₂) − ln Z(η₁) − ln Z(η₂)`.
    fn log_product_integral(&self, other: &Self) -> f64 {
        let kappa = (self.eta() + other.eta()).norm();
        -special::vmf_log_normalizer(kappa) - self.log_normalizer() - other.log_normalizer()
    }
}

impl Entropy for VonMisesFisher {
    /// `ln Z − κ (coth κ − 1/κ)`.
    fn entropy(&self) -> f64 {
        self.log_normalizer() - self.kappa * special::vmf_mean_resultant(self.kappa)
    }
}

impl KlDivergence for VonMisesFisher {
    /// `(η_p − η_q) · E_p[x] − ln Z_p + ln Z_q`.
    fn kl_divergence(&self, other: &Self) -> f64 {
        (self.eta() - other.eta()).dot(&self.mean_vector()) - self.log_normalizer()
            + other.log_normalizer()
    }
}
