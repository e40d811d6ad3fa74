//! [`VonMisesFisher`]: the von Mises-Fisher distribution on the sphere S².

use crate::error::{DensityError, finite};
use crate::special;
use crate::traits::{
    Density, Entropy, KlDivergence, Product, Rotate, distribution_through_density,
};
use crate::von_mises::{check_concentration, within_concentration};
use liebayes_manifolds::{GroupAction, S2, So3};
use nalgebra::Vector3;
use rand::Rng;
use std::f64::consts::TAU;

/// Below this concentration the sampler uses the first-order expansion of Wood's inverse CDF (whose
/// closed form rounds to garbage for subnormal κ).
const SERIES_SAMPLER_BELOW: f64 = 1e-8;

/// The von Mises-Fisher distribution on S²:
///
/// `p(x) = C(κ) exp(κ μ · x)`, `C(κ) = κ / (4π sinh κ)` (`1/(4π)` at κ = 0),
///
/// with respect to the surface measure of the unit sphere (total area 4π). Natural parameter
/// `η = κ μ`; mean direction μ ∈ S², concentration κ ∈ [0, 1e300]. κ = 0 is the uniform distribution
/// whatever mean is given (so it compares equal to [`VonMisesFisher::uniform`]).
///
/// Range: κ from 0 (and subnormal κ) to 1e300. Log densities, entropy and KL are written with κ taken
/// out of the normaliser (`ln C(κ) + κ − κ |x − μ|²/2`), so they neither overflow nor cancel.
/// See `docs/densities/von_mises_fisher.md`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VonMisesFisher {
    mean: S2<f64>,
    kappa: f64,
}

impl VonMisesFisher {
    /// The distribution with mean direction `mean` and concentration `concentration ≥ 0`.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] for κ outside [0, 1e300].
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::{Density, Product, VonMisesFisher};
    /// use liebayes_manifolds::S2;
    /// use nalgebra::Vector3;
    /// let up = S2::new(Vector3::z()).unwrap();
    /// let p = VonMisesFisher::new(up, 10.0).unwrap();
    /// // E[x] = (coth κ − 1/κ) μ.
    /// let expected = 1.0 / 10.0_f64.tanh() - 0.1;
    /// assert!((p.first_moment() - Vector3::z() * expected).norm() < 1e-14);
    /// // The product of two with one mean adds the concentrations.
    /// assert!((p.product(&p).unwrap().concentration() - 20.0).abs() < 1e-12);
    /// assert_eq!(p.mode(), Some(up));
    /// ```
    pub fn new(mean: S2<f64>, concentration: f64) -> Result<Self, DensityError> {
        let kappa = check_concentration("concentration kappa", concentration)?;
        Ok(if kappa == 0.0 {
            Self::uniform()
        } else {
            Self { mean, kappa }
        })
    }

    /// The distribution with natural parameter `η = κ μ` (the uniform distribution for η = 0). The
    /// norm is taken after scaling by the largest component, so η of size 1e-300 or 1e300 keeps its
    /// direction and its κ.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for NaN or infinite components, [`DensityError::OutOfRange`] when
    /// κ = |η| exceeds 1e300.
    pub fn from_natural(eta: Vector3<f64>) -> Result<Self, DensityError> {
        for &v in eta.iter() {
            finite("eta component", v)?;
        }
        let scale = eta.amax();
        if scale == 0.0 {
            return Ok(Self::uniform());
        }
        let direction = eta / scale;
        let length = direction.norm(); // in [1, √3]
        // κ as `scaled_length` takes it, which `natural` keeps within κ.
        let kappa = check_concentration("concentration |eta|", scale * length)?;
        Ok(Self {
            mean: S2::new_unchecked(direction / length),
            kappa,
        })
    }

    /// The maximum-likelihood fit to a first moment `m = E[x]` (|m| < 1), the weighted mean of unit
    /// vectors: `κ = A₃⁻¹(|m|)` ([`vmf_mean_resultant_inverse`](special::vmf_mean_resultant_inverse)),
    /// `μ = m/|m|`; the uniform distribution for m = 0.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for a non-finite component, [`DensityError::OutOfRange`] unless
    /// `|m| < 1`.
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::VonMisesFisher;
    /// use liebayes_manifolds::S2;
    /// use nalgebra::Vector3;
    /// let p = VonMisesFisher::new(S2::new(Vector3::x()).unwrap(), 25.0).unwrap();
    /// let fitted = VonMisesFisher::from_first_moment(p.first_moment()).unwrap();
    /// assert!((fitted.concentration() / 25.0 - 1.0).abs() < 1e-12);
    /// ```
    pub fn from_first_moment(m: Vector3<f64>) -> Result<Self, DensityError> {
        for &v in m.iter() {
            finite("first moment component", v)?;
        }
        // The length by the largest component first: a squared norm below 2.2e-308 is subnormal,
        // and its square root would leave the direction off the sphere.
        let scale = m.amax();
        if scale == 0.0 {
            return Ok(Self::uniform());
        }
        let direction = m / scale;
        let length = direction.norm(); // in [1, √3]
        let kappa = special::vmf_mean_resultant_inverse(scale * length)?;
        if kappa == 0.0 {
            return Ok(Self::uniform());
        }
        Ok(Self {
            mean: S2::new_unchecked(direction / length),
            kappa,
        })
    }

    /// The uniform distribution on the sphere, `1/(4π)`.
    pub fn uniform() -> Self {
        Self {
            mean: S2::new_unchecked(Vector3::z()),
            kappa: 0.0,
        }
    }

    /// The natural parameter `η = κ μ`, rounded so that `|η| ≤ κ` as
    /// [`from_natural`](Self::from_natural) measures it: a mean unit only to rounding made `|η|`
    /// an ulp above κ = 1e300, and a product with the uniform was refused.
    pub fn natural(&self) -> Vector3<f64> {
        within_concentration(
            self.mean.as_vector() * self.kappa,
            self.kappa,
            scaled_length,
        )
    }

    /// The concentration κ.
    pub fn concentration(&self) -> f64 {
        self.kappa
    }

    /// The mean direction μ (the mode), or `None` for the uniform distribution.
    pub fn mean(&self) -> Option<S2<f64>> {
        (self.kappa > 0.0).then_some(self.mean)
    }

    /// The first moment of the embedded point, `E[x] = (coth κ − 1/κ) μ` (the mean resultant
    /// vector).
    pub fn first_moment(&self) -> Vector3<f64> {
        self.mean.as_vector() * special::vmf_mean_resultant_valid(self.kappa)
    }
}

/// `|η|`, taken after scaling by the largest component (no under- or overflow in the squares), as
/// [`VonMisesFisher::from_natural`] takes it.
fn scaled_length(eta: &Vector3<f64>) -> f64 {
    let scale = eta.amax();
    if scale == 0.0 {
        0.0
    } else {
        scale * (eta / scale).norm()
    }
}

impl Rotate<So3<f64>> for VonMisesFisher {
    /// Mean `R μ`, the same κ.
    fn rotated(&self, r: &So3<f64>) -> Result<Self, DensityError> {
        Ok(Self {
            mean: Self::act(r, &self.mean),
            kappa: self.kappa,
        })
    }

    /// `R x`, renormalised (a rotation keeps the norm to rounding).
    fn act(r: &So3<f64>, x: &S2<f64>) -> S2<f64> {
        S2::new_unchecked(r.act(x.as_vector()).normalize())
    }
}

distribution_through_density!(VonMisesFisher);

impl Density for VonMisesFisher {
    type Point = S2<f64>;

    /// `ln C(κ) + κ μ · x`, evaluated as `(ln C(κ) + κ) − κ |x − μ|²/2`: both terms are accurate
    /// and neither is of size κ where the density matters (the plain form lost 2e-14 at κ = 2000).
    fn log_pdf(&self, x: &S2<f64>) -> f64 {
        let gap = (x.as_vector() - self.mean.as_vector()).norm_squared();
        special::vmf_log_normalizer_plus_kappa(self.kappa) - 0.5 * self.kappa * gap
    }

    /// `ln Z = −ln C(κ) = ln(4π sinh κ / κ)`.
    fn log_normalizer(&self) -> f64 {
        self.kappa - special::vmf_log_normalizer_plus_kappa(self.kappa)
    }

    /// Wood's (1994) algorithm, which on S² needs no rejection: the cosine `w = μ · x` has the exact
    /// inverse CDF `w = 1 + ln(u + (1 − u) e^(−2κ)) / κ`, evaluated as
    /// `1 − w = −ln_1p((1 − u) expm1(−2κ)) / κ` so that neither small κ nor κ = 1e300 loses digits;
    /// below κ = 1e-8 (where that product rounds to nothing for subnormal κ) by its expansion
    /// `1 − w = 2(1 − u) − 2κ u (1 − u) + O(κ²)`, exact to rounding there. The direction around μ is
    /// uniform.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> S2<f64> {
        let u: f64 = rng.random();
        let one_minus_w = if self.kappa >= SERIES_SAMPLER_BELOW {
            -((1.0 - u) * (-2.0 * self.kappa).exp_m1()).ln_1p() / self.kappa
        } else {
            2.0 * (1.0 - u) * (1.0 - self.kappa * u)
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
        self.mean()
    }
}

impl Product for VonMisesFisher {
    /// `η = η₁ + η₂` (exact).
    fn product(&self, other: &Self) -> Result<Self, DensityError> {
        Self::from_natural(self.natural() + other.natural())
    }

    /// `ln ∫ p₁ p₂ dS = ln Z(η₁ + η₂) − ln Z(η₁) − ln Z(η₂)`, evaluated as
    /// `P(κ₁) + P(κ₂) − P(κ₁₂) + (κ₁₂ − κ₁ − κ₂)` with `P(κ) = ln C(κ) + κ` and
    /// `κ₁₂ − κ₁ − κ₂ = −κ₁ κ₂ |μ₁ − μ₂|² / (κ₁₂ + κ₁ + κ₂)`: nothing of size κ cancels. Finite for
    /// all accepted parameters.
    ///
    /// # Errors
    /// As [`product`](Product::product), exactly where it fails (κ₁₂ beyond the accepted range).
    fn log_product_integral(&self, other: &Self) -> Result<f64, DensityError> {
        self.product(other)?;
        let (k1, k2) = (self.kappa, other.kappa);
        // Scaled by the larger κ: |η₁ + η₂|² overflows past 1.3e154.
        let scale = k1.max(k2).max(f64::MIN_POSITIVE);
        let k12 = scale * (self.natural() / scale + other.natural() / scale).norm();
        let gap = (self.mean.as_vector() - other.mean.as_vector()).norm_squared();
        let excess = if k1 == 0.0 || k2 == 0.0 {
            0.0
        } else {
            -(k1 / (k12 + k1 + k2)) * k2 * gap
        };
        Ok(
            special::vmf_log_normalizer_plus_kappa(k1) + special::vmf_log_normalizer_plus_kappa(k2)
                - special::vmf_log_normalizer_plus_kappa(k12)
                + excess,
        )
    }
}

impl Entropy for VonMisesFisher {
    /// `ln Z − κ (coth κ − 1/κ)`, evaluated as `κ D(κ) − P(κ)` with `D = 1 − coth κ + 1/κ` (formed
    /// without cancellation) and `P(κ) = ln C(κ) + κ`: κD tends to 1, and nothing of size κ cancels.
    fn entropy(&self) -> f64 {
        self.kappa * special::vmf_one_minus_mean_resultant(self.kappa)
            - special::vmf_log_normalizer_plus_kappa(self.kappa)
    }
}

impl KlDivergence for VonMisesFisher {
    /// `(η_p − η_q) · E_p[x] − ln Z_p + ln Z_q`, evaluated as
    /// `P(κ_p) − P(κ_q) + κ_q |μ_p − μ_q|²/2 + D_p (κ_q cos Δ − κ_p)` with `P(κ) = ln C(κ) + κ`,
    /// `D = 1 − (coth κ − 1/κ)` and Δ the angle between the means: no term of size κ cancels, and
    /// equal arguments give exactly 0.
    fn kl_divergence(&self, other: &Self) -> f64 {
        let (kp, kq) = (self.kappa, other.kappa);
        let half_gap = 0.5 * (self.mean.as_vector() - other.mean.as_vector()).norm_squared();
        special::vmf_log_normalizer_plus_kappa(kp) - special::vmf_log_normalizer_plus_kappa(kq)
            + kq * half_gap
            + special::vmf_one_minus_mean_resultant(kp) * (kq * (1.0 - half_gap) - kp)
    }
}
