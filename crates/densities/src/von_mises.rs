//! [`VonMises`]: the von Mises distribution on the circle SO(2).

use crate::error::{DensityError, finite, non_negative};
use crate::special;
use crate::traits::{Density, Entropy, KlDivergence, Product};
use liebayes_manifolds::{LieGroup, So2};
use nalgebra::Vector2;
use rand::Rng;
use std::f64::consts::PI;

/// The von Mises distribution on the circle:
///
/// `p(θ) = exp(η · u(θ)) / (2π I₀(κ))`, `u(θ) = (cos θ, sin θ)`, κ = |η|, mean direction μ = arg η,
///
/// with respect to the Lebesgue measure dθ on the circle (total mass 2π). The natural parameter η ∈ R²
/// is stored, so κ = 0 (the uniform distribution) is an ordinary value and products are sums.
///
/// Range: κ from 0 to 1e6 and beyond; `log_pdf`, moments and KL use the log-space Bessel functions of
/// [`special`] and never overflow. See `docs/densities/von_mises.md`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VonMises {
    eta: Vector2<f64>,
}

impl VonMises {
    /// The distribution with natural parameter `η = κ (cos μ, sin μ)`.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for NaN or infinite components.
    pub fn new(eta: Vector2<f64>) -> Result<Self, DensityError> {
        finite("eta.x", eta.x)?;
        finite("eta.y", eta.y)?;
        Ok(Self { eta })
    }

    /// The distribution with mean direction `mean` and concentration `kappa ≥ 0`.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] for a negative κ.
    pub fn from_mean_concentration(mean: So2<f64>, kappa: f64) -> Result<Self, DensityError> {
        non_negative("concentration kappa", kappa)?;
        Ok(Self {
            eta: Vector2::new(mean.cos(), mean.sin()) * kappa,
        })
    }

    /// The uniform distribution, `1/(2π)`.
    pub fn uniform() -> Self {
        Self {
            eta: Vector2::zeros(),
        }
    }

    /// The maximum-likelihood fit to a first circular moment `m = E[u(θ)]` (|m| < 1):
    /// `κ = A⁻¹(|m|)`, `μ = arg m`.
    ///
    /// # Errors
    /// [`DensityError::OutOfRange`] unless `|m| < 1`.
    pub fn from_first_moment(m: &Vector2<f64>) -> Result<Self, DensityError> {
        let r = m.norm();
        let kappa = special::a1_inverse(r)?;
        Ok(Self {
            eta: if r > 0.0 {
                m * (kappa / r)
            } else {
                Vector2::zeros()
            },
        })
    }

    /// The natural parameter η.
    pub fn eta(&self) -> &Vector2<f64> {
        &self.eta
    }

    /// The concentration κ = |η|.
    pub fn concentration(&self) -> f64 {
        self.eta.x.hypot(self.eta.y)
    }

    /// The mean direction μ = arg η, or `None` for the uniform distribution (κ = 0). Defined for every
    /// κ > 0, including κ = 1e-300 (by atan2, which needs no normalisation).
    pub fn mean_direction(&self) -> Option<So2<f64>> {
        (self.concentration() > 0.0)
            .then(|| So2::from_angle_unchecked(self.eta.y.atan2(self.eta.x)))
    }

    /// The n-th trigonometric moment `E[(cos nθ, sin nθ)] = Aₙ(κ) (cos nμ, sin nμ)`, with
    /// `Aₙ = Iₙ/I₀`. The first is the mean resultant vector.
    pub fn trigonometric_moment(&self, n: u32) -> Vector2<f64> {
        let kappa = self.concentration();
        match self.mean_direction() {
            None => Vector2::zeros(),
            Some(mu) => {
                let (s, c) = (f64::from(n) * mu.angle()).sin_cos();
                Vector2::new(c, s) * special::bessel_ratio(n, kappa)
            }
        }
    }

    /// The mean resultant length `A(κ) = I₁(κ)/I₀(κ)`.
    pub fn mean_resultant_length(&self) -> f64 {
        special::a1(self.concentration())
    }

    /// The circular variance `1 − A(κ)`.
    pub fn circular_variance(&self) -> f64 {
        1.0 - self.mean_resultant_length()
    }

    /// **Approximation**: the von Mises closest to the convolution of `self` and `other` (the
    /// distribution of θ₁ + θ₂), matching the first trigonometric moment, which multiplies:
    /// `μ = μ₁ + μ₂`, `κ = A⁻¹(A(κ₁) A(κ₂))`. The convolution itself is not von Mises; the error of
    /// this approximation is measured in `docs/densities/von_mises.md`.
    #[must_use]
    pub fn convolve_moment_matched(&self, other: &Self) -> Self {
        let (k1, k2) = (self.concentration(), other.concentration());
        let (Some(mu1), Some(mu2)) = (self.mean_direction(), other.mean_direction()) else {
            return Self::uniform(); // convolving with the uniform distribution gives the uniform
        };
        let r = special::a1(k1) * special::a1(k2);
        // Past κ ≈ 5e7 the product rounds towards 1 and A⁻¹ loses all digits; there the matching
        // has the limit form 1/κ = 1/κ₁ + 1/κ₂ (A(κ) = 1 − 1/(2κ) + O(κ⁻²)).
        let kappa = if r < 1.0 - 1e-8 {
            special::a1_inverse(r).unwrap_or(f64::MAX)
        } else {
            1.0 / (1.0 / k1 + 1.0 / k2)
        };
        let mu = mu1.compose(&mu2);
        Self {
            eta: Vector2::new(mu.cos(), mu.sin()) * kappa,
        }
    }
}

impl Density for VonMises {
    type Point = So2<f64>;

    /// `η · (cos θ, sin θ) − ln(2π I₀(κ))`.
    fn log_pdf(&self, x: &So2<f64>) -> f64 {
        self.eta.x * x.cos() + self.eta.y * x.sin() - self.log_normalizer()
    }

    /// `ln(2π I₀(κ))`.
    fn log_normalizer(&self) -> f64 {
        (2.0 * PI).ln() + special::log_i0(self.concentration())
    }

    /// Best & Fisher's (1979) rejection sampler with a wrapped-Cauchy envelope, written with
    /// `r = s + √(1 + s²)`, `s = 1/(2κ)` (by `hypot`, so κ = 1e-300 and κ = 1e6 both work); the uniform
    /// distribution for κ = 0.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> So2<f64> {
        let kappa = self.concentration();
        let Some(mu) = self.mean_direction() else {
            return So2::from_angle_unchecked(rng.random_range(-PI..PI));
        };
        let s = 0.5 / kappa;
        let r = s + s.hypot(1.0);
        let w = loop {
            let z = (PI * rng.random::<f64>()).cos();
            let w = (1.0 + r * z) / (r + z);
            let y = kappa * (r - w);
            let v: f64 = rng.random();
            if y * (2.0 - y) - v >= 0.0 || (y / v).ln() + 1.0 - y >= 0.0 {
                break w;
            }
        };
        let angle = w.clamp(-1.0, 1.0).acos();
        let signed = if rng.random::<bool>() { angle } else { -angle };
        mu.compose(&So2::from_angle_unchecked(signed))
    }

    /// The mean direction (none for κ = 0).
    fn mode(&self) -> Option<So2<f64>> {
        self.mean_direction()
    }
}

impl Product for VonMises {
    /// `η = η₁ + η₂` (exact).
    fn product(&self, other: &Self) -> Result<Self, DensityError> {
        Ok(Self {
            eta: self.eta + other.eta,
        })
    }

    /// `ln ∫ p₁ p₂ dθ = ln Z(η₁ + η₂) − ln Z(η₁) − ln Z(η₂)`.
    fn log_product_integral(&self, other: &Self) -> f64 {
        let joint = Self {
            eta: self.eta + other.eta,
        };
        joint.log_normalizer() - self.log_normalizer() - other.log_normalizer()
    }
}

impl Entropy for VonMises {
    /// `ln(2π I₀(κ)) − κ A(κ)`.
    fn entropy(&self) -> f64 {
        let kappa = self.concentration();
        self.log_normalizer() - kappa * special::a1(kappa)
    }
}

impl KlDivergence for VonMises {
    /// `(η_p − η_q) · E_p[u] − ln Z_p + ln Z_q`, with `E_p[u] = A(κ_p) (cos μ_p, sin μ_p)`.
    fn kl_divergence(&self, other: &Self) -> f64 {
        let m = self.trigonometric_moment(1);
        (self.eta - other.eta).dot(&m) - self.log_normalizer() + other.log_normalizer()
    }
}
