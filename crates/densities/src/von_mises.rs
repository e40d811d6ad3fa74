//! [`VonMises`]: the von Mises distribution on the circle SO(2).

use crate::error::{DensityError, finite};
use crate::scaled_bessel;
use crate::special;
use crate::traits::{
    Density, Entropy, KlDivergence, Product, Rotate, distribution_through_density,
};
use liebayes_manifolds::{LieGroup, So2};
use nalgebra::{SVector, Vector2};
use rand::Rng;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

/// The largest accepted concentration of the circular families (von Mises and von Mises-Fisher): sums
/// of two natural parameters (products) stay finite below it, and so do `κ² ` scaled by 1e-8.
pub(crate) const MAX_CONCENTRATION: f64 = 1e300;

/// Below this concentration the sampler proposes from the uniform distribution.
const UNIFORM_ENVELOPE_BELOW: f64 = 1e-3;

/// Above this concentration the sampler proposes from a Gaussian in the angle (the wrapped-normal
/// limit); below, Best & Fisher's envelope is as fast and accepts a little more (0.66 against 0.64).
const GAUSSIAN_ENVELOPE_ABOVE: f64 = 1e8;

/// Proposals a draw makes at most: every envelope accepts at least 0.63 of them, so 200 rejections in a
/// row have probability below 1e-86.
const MAX_PROPOSALS: usize = 200;

/// Checks a concentration against [0, 1e300] (+∞, the norm of components that overflowed, is out of
/// that range rather than non-finite input).
pub(crate) fn check_concentration(what: &'static str, kappa: f64) -> Result<f64, DensityError> {
    if kappa.is_nan() {
        return Err(DensityError::NonFinite { what, value: kappa });
    }
    if !(0.0..=MAX_CONCENTRATION).contains(&kappa) {
        return Err(DensityError::OutOfRange {
            what,
            value: kappa,
            range: "[0, 1e300]",
        });
    }
    Ok(kappa.abs())
}

/// `κ (c, s)` for a unit vector (c, s), shrunk by a few ulp where rounding makes its norm exceed κ
/// (see [`within_concentration`]): a concentration κ at a family's limit then gives a natural
/// parameter that `from_natural` accepts (κ = 1e300 gave |η| = 1.0000000000000002e300 for 7.8 % of
/// the angles, refused by the serde round trip and by a product with the uniform).
pub(crate) fn natural_of_unit(c: f64, s: f64, kappa: f64) -> Vector2<f64> {
    within_concentration(Vector2::new(c, s) * kappa, kappa, hypot)
}

/// `|η|` of a von Mises natural parameter, as [`VonMises::concentration`] takes it.
pub(crate) fn hypot(eta: &Vector2<f64>) -> f64 {
    eta.x.hypot(eta.y)
}

/// `η` itself when `norm(η) ≤ κ`, else η rescaled to `κ η / norm(η)` and shrunk by an ulp at a time
/// until `norm(η) ≤ κ` exactly (`norm` the length as the family's `from_natural` computes it): for
/// a natural parameter whose length should be κ and exceeds it by rounding (a unit vector times κ,
/// η turned by a rotation that is unit only to rounding), so that it stays within the
/// concentration limit that κ is within.
pub(crate) fn within_concentration<const N: usize>(
    mut eta: SVector<f64, N>,
    kappa: f64,
    norm: impl Fn(&SVector<f64, N>) -> f64,
) -> SVector<f64, N> {
    // One rescale leaves the length within a few ulp of κ, and at most a few ulp steps bring it to
    // κ or just below; the loop is bounded, and each step shrinks a normal η.
    let length = norm(&eta);
    if length > kappa {
        eta *= kappa / length;
        for _ in 0..8 {
            if norm(&eta) <= kappa {
                break;
            }
            eta *= 1.0 - f64::EPSILON;
        }
    }
    eta
}

/// `κ (cos d − 1)` for the angle d between η (|η| = κ) and the unit vector (c, s), without cancellation
/// at any κ: `η·u − κ` where η·u ≤ 0, and `−(η × u)² / (κ + η·u)` (the same, as
/// `κ (cos d − 1) = −κ sin² d / (1 + cos d)`) where η·u > 0. Never overflows for κ ≤ f64::MAX.
pub(crate) fn scaled_cos_minus_one(eta: &Vector2<f64>, kappa: f64, c: f64, s: f64) -> f64 {
    let dot = eta.x * c + eta.y * s;
    if dot <= 0.0 {
        dot - kappa
    } else {
        let cross = eta.x * s - eta.y * c;
        -cross * (cross / (kappa + dot))
    }
}

/// One rotation by an angle d from the mean direction of a von Mises of concentration κ > 0, by
/// rejection from the envelope of κ's regime (see [`VonMises::sample`]). Each proposal takes one
/// sine and cosine (of d/2 or of πU/2) and the accepted rotation `(cos d, sin d)` is formed from
/// them, with no further trigonometric call: `cos d = 1 − 2 sin²(d/2)`, `sin d = 2 sin(d/2)
/// cos(d/2)`; in Best & Fisher's branch `cos d = w` and `sin d = ±√((1 − w)(1 + w))`.
pub(crate) fn sample_offset<R: Rng + ?Sized>(kappa: f64, rng: &mut R) -> So2<f64> {
    // The rotation by d from (sin(d/2), cos(d/2)).
    let of_half =
        |(sh, ch): (f64, f64)| So2::from_cos_sin_unchecked(1.0 - 2.0 * sh * sh, 2.0 * sh * ch);
    if kappa < UNIFORM_ENVELOPE_BELOW {
        let mut half = (0.0, 1.0);
        for _ in 0..MAX_PROPOSALS {
            half = (0.5 * rng.random_range(-PI..PI)).sin_cos();
            if rng.random::<f64>().ln() < -2.0 * kappa * half.0 * half.0 {
                break;
            }
        }
        of_half(half)
    } else if kappa > GAUSSIAN_ENVELOPE_ABOVE {
        // 1 − cos d ≥ 2d²/π² on [−π, π]: the Gaussian of variance π²/(4κ) bounds the density.
        let sigma = PI / (2.0 * kappa.sqrt());
        let mut half = (0.0, 1.0);
        for _ in 0..MAX_PROPOSALS {
            let offset = sigma * rng.sample::<f64, _>(StandardNormal);
            if offset.abs() > PI {
                continue;
            }
            half = (0.5 * offset).sin_cos();
            // κ (2d²/π² − 2 sin²(d/2)) = ½ (d/σ)² − ½ (2√κ sin(d/2))², both terms O(1) at any κ.
            let (scaled, sine) = (offset / sigma, 2.0 * kappa.sqrt() * half.0);
            if rng.random::<f64>().ln() < 0.5 * (scaled * scaled - sine * sine) {
                break;
            }
        }
        of_half(half)
    } else {
        // Best & Fisher: wrapped Cauchy envelope, r = s + √(1 + s²), s = 1/(2κ), z = cos(πU),
        // w = (1 + r z)/(r + z), y = κ (r − w). Written with r − 1 = s + s²/(1 + √(1 + s²)),
        // 1 ∓ z = 2 sin²(πU/2), 2 cos²(πU/2) and 1 − w = (r − 1)(1 − z)/(r − 1 + 1 + z), so that y and
        // the angle keep their digits at large κ (in the plain form r − w loses log₁₀ κ digits).
        let s = 0.5 / kappa;
        // s ≤ 500 here: 1 + s² is far from overflow, and its square root as exact as `hypot`.
        let r_minus_one = s + s * s / (1.0 + (1.0 + s * s).sqrt());
        let mut one_minus_w = 0.0;
        for _ in 0..MAX_PROPOSALS {
            let (sh, ch) = (0.5 * PI * rng.random::<f64>()).sin_cos();
            let (one_minus_z, one_plus_z) = (2.0 * sh * sh, 2.0 * ch * ch);
            one_minus_w = r_minus_one * one_minus_z / (r_minus_one + one_plus_z);
            let y = kappa * (r_minus_one + one_minus_w);
            let v: f64 = rng.random();
            if y * (2.0 - y) - v >= 0.0 || (y / v).ln() + 1.0 - y >= 0.0 {
                break;
            }
        }
        // cos d = w, and sin d = √((1 − w)(1 + w)) from 1 − w, accurate for w near 1.
        let one_minus_w = one_minus_w.clamp(0.0, 2.0);
        let sine = (one_minus_w * (2.0 - one_minus_w)).sqrt();
        let sine = if rng.random::<bool>() { sine } else { -sine };
        So2::from_cos_sin_unchecked(1.0 - one_minus_w, sine)
    }
}

/// The mean direction `η / |η|` of a natural parameter of norm κ > 0, by one division (by the angle
/// `atan2(η_y, η_x)` for κ below 1e-150, where the quotient of subnormal components loses its
/// unit length).
pub(crate) fn direction(eta: &Vector2<f64>, kappa: f64) -> So2<f64> {
    if kappa >= 1e-150 {
        So2::from_cos_sin_unchecked(eta.x / kappa, eta.y / kappa)
    } else {
        So2::from_angle_unchecked(eta.y.atan2(eta.x))
    }
}

/// The von Mises distribution on the circle:
///
/// `p(θ) = exp(η · u(θ)) / (2π I₀(κ))`, `u(θ) = (cos θ, sin θ)`, κ = |η|, mean direction μ = arg η,
///
/// with respect to the Lebesgue measure dθ on the circle (total mass 2π). The natural parameter η ∈ R²
/// is stored, so κ = 0 (the uniform distribution) is an ordinary value and products are sums.
///
/// Range: κ from 0 (and subnormal κ) to 1e300; `log_pdf`, entropy and KL are written with the scaled
/// Bessel functions (`κ (cos d − 1) − ln 2π − (ln I₀(κ) − κ)`), so they neither overflow nor cancel, and
/// are accurate to a few ulp at any κ. See `docs/densities/von_mises.md`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VonMises {
    eta: Vector2<f64>,
}

impl VonMises {
    /// The distribution with mean direction `mean` and concentration `concentration` in
    /// [0, 1e300]: `η = κ (cos μ, sin μ)`, rounded so that `|η| ≤ κ` (so every density it makes,
    /// κ = 1e300 included, is one [`from_natural`](Self::from_natural) and the serde round trip
    /// accept).
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] for κ outside [0, 1e300].
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::{Density, VonMises};
    /// use liebayes_densities::manifolds::So2;
    ///
    /// let p = VonMises::new(So2::from_angle_unchecked(0.5), 4.0).unwrap();
    /// assert_eq!(p.concentration(), 4.0);
    /// assert!(p.log_pdf(&So2::from_angle_unchecked(0.5)) > p.log_pdf(&So2::from_angle_unchecked(2.0)));
    /// ```
    pub fn new(mean: So2<f64>, concentration: f64) -> Result<Self, DensityError> {
        let kappa = check_concentration("concentration kappa", concentration)?;
        Ok(Self {
            eta: natural_of_unit(mean.cos(), mean.sin(), kappa),
        })
    }

    /// The distribution with natural parameter `η = κ (cos μ, sin μ)`.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for NaN or infinite components, [`DensityError::OutOfRange`] when
    /// κ = |η| exceeds 1e300.
    pub fn from_natural(eta: Vector2<f64>) -> Result<Self, DensityError> {
        finite("eta.x", eta.x)?;
        finite("eta.y", eta.y)?;
        // |η| ≤ √2 max(|η_x|, |η_y|): the norm (a slow hypot) is needed only near the limit.
        if eta.x.abs().max(eta.y.abs()) > MAX_CONCENTRATION * std::f64::consts::FRAC_1_SQRT_2 {
            check_concentration("concentration |eta|", eta.x.hypot(eta.y))?;
        }
        Ok(Self { eta })
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
    /// [`DensityError::OutOfRange`] unless `|m| < 1` (NaN included). Every |m| < 1 gives a finite κ
    /// (at most 4.5e15).
    pub fn from_first_moment(m: Vector2<f64>) -> Result<Self, DensityError> {
        let r = m.x.hypot(m.y);
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
    pub fn natural(&self) -> Vector2<f64> {
        self.eta
    }

    /// The concentration κ = |η|.
    pub fn concentration(&self) -> f64 {
        self.eta.x.hypot(self.eta.y)
    }

    /// The mean direction μ = arg η (the circular mean, also the mode), or `None` for the uniform
    /// distribution (κ = 0): η/κ, and for κ below 1e-150, where a quotient of subnormal components
    /// is not of unit length, the angle atan2(η_y, η_x); so defined for every κ > 0, including
    /// κ = 1e-300.
    pub fn mean(&self) -> Option<So2<f64>> {
        let kappa = self.concentration();
        (kappa > 0.0).then(|| direction(&self.eta, kappa))
    }

    /// The n-th trigonometric moment `E[(cos nθ, sin nθ)] = Aₙ(κ) (cos nμ, sin nμ)`, with
    /// `Aₙ = Iₙ/I₀`, for n ≤ [`special::MAX_ORDER`]. The first is the mean resultant vector.
    ///
    /// # Errors
    /// [`DensityError::OutOfRange`] for n > [`special::MAX_ORDER`].
    pub fn trigonometric_moment(&self, n: u32) -> Result<Vector2<f64>, DensityError> {
        special::check_order(n)?;
        Ok(self.first_moments_of_order(n))
    }

    /// [`Self::trigonometric_moment`] for a valid order.
    fn first_moments_of_order(&self, n: u32) -> Vector2<f64> {
        let kappa = self.concentration();
        match self.mean() {
            None => Vector2::zeros(),
            Some(mu) => {
                let (s, c) = (f64::from(n) * mu.angle()).sin_cos();
                Vector2::new(c, s) * special::ratio(n, kappa)
            }
        }
    }

    /// The mean resultant length `A(κ) = I₁(κ)/I₀(κ)`.
    pub fn mean_resultant_length(&self) -> f64 {
        special::mean_resultant(self.concentration())
    }

    /// The circular variance `1 − A(κ)`, accurate to a few ulp at any κ (≈ 1/(2κ) for large κ).
    pub fn circular_variance(&self) -> f64 {
        scaled_bessel::one_minus_a1(self.concentration())
    }

    /// **Approximation**: the von Mises closest to the convolution of `self` and `other` (the
    /// distribution of θ₁ + θ₂), matching the first trigonometric moment, which multiplies:
    /// `μ = μ₁ + μ₂`, `κ = A⁻¹(A(κ₁) A(κ₂))`, the complement `1 − A₁A₂ = D₁ + D₂ − D₁D₂` (D = 1 − A)
    /// formed without cancellation so that concentrated inputs keep their digits. The convolution
    /// itself is not von Mises; the error of this approximation is measured in
    /// `docs/densities/von_mises.md`.
    #[must_use]
    pub fn convolve_moment_matched(&self, other: &Self) -> Self {
        let (k1, k2) = (self.concentration(), other.concentration());
        let (Some(mu1), Some(mu2)) = (self.mean(), other.mean()) else {
            return Self::uniform(); // convolving with the uniform distribution gives the uniform
        };
        let (d1, d2) = (
            scaled_bessel::one_minus_a1(k1),
            scaled_bessel::one_minus_a1(k2),
        );
        let d = d1 + d2 - d1 * d2;
        let kappa = if d > 0.5 {
            special::a1_inverse_valid(special::mean_resultant(k1) * special::mean_resultant(k2))
        } else {
            special::a1_inverse_of_complement(d)
        }
        .min(k1.min(k2)); // rounding aside, the result is less concentrated than either input
        let mu = mu1.compose(&mu2);
        Self {
            eta: Vector2::new(mu.cos(), mu.sin()) * kappa,
        }
    }
}

impl Density for VonMises {
    type Point = So2<f64>;

    /// `η · u(θ) − ln(2π I₀(κ))`, evaluated as `κ (cos d − 1) − ln 2π − (ln I₀(κ) − κ)` (d = θ − μ):
    /// each term is accurate to a few ulp and none is of size κ, so the sum is too (the plain form
    /// lost 164 ulp at κ = 800).
    fn log_pdf(&self, x: &So2<f64>) -> f64 {
        let kappa = self.concentration();
        scaled_cos_minus_one(&self.eta, kappa, x.cos(), x.sin())
            - (2.0 * PI).ln()
            - scaled_bessel::log_scaled_i0(kappa)
    }

    /// `ln(2π I₀(κ))`.
    fn log_normalizer(&self) -> f64 {
        (2.0 * PI).ln() + special::ln_i0(self.concentration())
    }

    /// Exact rejection sampling, from the envelope that suits κ (each accepts at least 63 % of its
    /// proposals; see `docs/densities/von_mises.md` for the bounds):
    ///
    /// * κ = 0: the uniform distribution;
    /// * κ < 1e-3: uniform proposals d, accepted with probability `e^(κ (cos d − 1))` ≥ e^(−2κ);
    /// * 1e-3 ≤ κ ≤ 1e8: Best & Fisher's (1979) wrapped-Cauchy envelope, with `r = s + √(1 + s²)`,
    ///   `s = 1/(2κ)`, written with `r − 1` and `1 − w` formed without cancellation (the plain form
    ///   lost log₁₀ κ digits and never accepted at κ = 1e16, where `r − w` rounded to 0);
    /// * κ > 1e8: Gaussian proposals d ~ N(0, π²/(4κ)) restricted to [−π, π], accepted with
    ///   probability `e^(κ (2d²/π² − 2 sin²(d/2)))` ≤ 1 (as 1 − cos d ≥ 2d²/π² there); the rate tends
    ///   to 2/π. This is the wrapped-normal limit, exact at every κ.
    ///
    /// A draw makes at most 200 proposals and, were all rejected (probability below 1e-86), keeps the
    /// last one.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> So2<f64> {
        let kappa = self.concentration();
        if kappa == 0.0 {
            return So2::from_angle_unchecked(rng.random_range(-PI..PI));
        }
        direction(&self.eta, kappa).compose(&sample_offset(kappa, rng))
    }

    /// The mean direction (none for κ = 0).
    fn mode(&self) -> Option<So2<f64>> {
        self.mean()
    }
}

impl Product for VonMises {
    /// `η = η₁ + η₂` (exact).
    ///
    /// # Errors
    /// As [`VonMises::from_natural`]: the product's concentration |η₁ + η₂| may exceed 1e300.
    fn product(&self, other: &Self) -> Result<Self, DensityError> {
        Self::from_natural(self.eta + other.eta)
    }

    /// `ln ∫ p₁ p₂ dθ = ln Z(η₁ + η₂) − ln Z(η₁) − ln Z(η₂)`, evaluated as
    /// `ℓ(κ₁₂) − ℓ(κ₁) − ℓ(κ₂) − ln 2π + (κ₁₂ − κ₁ − κ₂)` with `ℓ(κ) = ln I₀(κ) − κ` and
    /// `κ₁₂ − κ₁ − κ₂ = −κ₁ κ₂ |μ̂₁ − μ̂₂|² / (κ₁₂ + κ₁ + κ₂)` (unit mean vectors μ̂), so nothing of
    /// size κ cancels. Finite for all accepted parameters (κ₁₂ ≤ 2e300).
    ///
    /// # Errors
    /// As [`product`](Product::product), exactly where it fails (κ₁₂ beyond 1e300).
    fn log_product_integral(&self, other: &Self) -> Result<f64, DensityError> {
        self.product(other)?;
        let (k1, k2) = (self.concentration(), other.concentration());
        let joint = self.eta + other.eta;
        let k12 = joint.x.hypot(joint.y);
        let excess = if k1 == 0.0 || k2 == 0.0 {
            0.0
        } else {
            let gap = self.eta / k1 - other.eta / k2;
            -(k1 / (k12 + k1 + k2)) * k2 * gap.norm_squared()
        };
        Ok(scaled_bessel::log_scaled_i0(k12)
            - scaled_bessel::log_scaled_i0(k1)
            - scaled_bessel::log_scaled_i0(k2)
            - (2.0 * PI).ln()
            + excess)
    }
}

impl Entropy for VonMises {
    /// `ln(2π I₀(κ)) − κ A(κ)`, evaluated as `ln 2π + (ln I₀(κ) − κ) + κ (1 − A(κ))`: the last term
    /// tends to ½ and nothing of size κ cancels (the plain form lost 1522 ulp at κ = 2000).
    fn entropy(&self) -> f64 {
        let kappa = self.concentration();
        (2.0 * PI).ln()
            + scaled_bessel::log_scaled_i0(kappa)
            + kappa * scaled_bessel::one_minus_a1(kappa)
    }
}

impl KlDivergence for VonMises {
    /// `(η_p − η_q) · E_p[u] − ln Z_p + ln Z_q`, with `E_p[u] = A(κ_p) (cos μ_p, sin μ_p)`, evaluated as
    /// `ℓ(κ_q) − ℓ(κ_p) + κ_q |μ̂_p − μ̂_q|²/2 + D_p (κ_q cos Δ − κ_p)` with `ℓ(κ) = ln I₀(κ) − κ`,
    /// `D = 1 − A` and Δ the angle between the means: no term of size κ cancels, and equal arguments
    /// give exactly 0.
    fn kl_divergence(&self, other: &Self) -> f64 {
        let (kp, kq) = (self.concentration(), other.concentration());
        let (unit_p, unit_q) = (unit_or_x(&self.eta, kp), unit_or_x(&other.eta, kq));
        let half_gap = 0.5 * (unit_p - unit_q).norm_squared(); // 1 − cos Δ
        let cos_delta = 1.0 - half_gap;
        scaled_bessel::log_scaled_i0(kq) - scaled_bessel::log_scaled_i0(kp)
            + kq * half_gap
            + scaled_bessel::one_minus_a1(kp) * (kq * cos_delta - kp)
    }
}

impl Rotate<So2<f64>> for VonMises {
    /// Mean direction `g μ`, the same κ: η turned by g (exact up to the rounding of one rotation),
    /// kept at `|η| ≤ κ` (the rounding of [`new`](VonMises::new)), so that a density at the
    /// concentration limit stays within it (κ = 1e300 turned by some angles gave |η| one ulp above
    /// 1e300, which the serde reader and a product with the uniform refused).
    fn rotated(&self, g: &So2<f64>) -> Result<Self, DensityError> {
        let (c, s) = (g.cos(), g.sin());
        let turned = Vector2::new(
            c * self.eta.x - s * self.eta.y,
            s * self.eta.x + c * self.eta.y,
        );
        Ok(Self {
            eta: within_concentration(turned, self.concentration(), hypot),
        })
    }

    /// `g x`.
    fn act(g: &So2<f64>, x: &So2<f64>) -> So2<f64> {
        g.compose(x)
    }
}

distribution_through_density!(VonMises);

/// `η / κ`, or the x axis for κ = 0 (any unit vector serves there: the terms it enters vanish).
fn unit_or_x(eta: &Vector2<f64>, kappa: f64) -> Vector2<f64> {
    if kappa > 0.0 {
        eta / kappa
    } else {
        Vector2::x()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// At large κ the offset is N(0, 1/κ) to O(1/κ²), so κ d² has mean 1 and variance 2: its sample
    /// mean over n draws must lie within 5 standard errors √(2/n) of 1, in both large-κ branches and
    /// across their hand-over; and every offset of the Gaussian branch must be finite and in [−π, π].
    #[test]
    fn large_concentrations_sample_the_wrapped_normal_limit() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
        let n = 20_000;
        for kappa in [
            1e4,
            1e7,
            1e8,
            1.000_000_1e8,
            1e12,
            1e16,
            1e300,
            f64::MAX / 2.0,
        ] {
            let mean = (0..n)
                .map(|_| {
                    let d = sample_offset(kappa, &mut rng).angle();
                    assert!(d.is_finite() && d.abs() <= PI, "κ {kappa:e}: {d}");
                    kappa * d * d
                })
                .sum::<f64>()
                / f64::from(n);
            let tolerance = 5.0 * (2.0 / f64::from(n)).sqrt();
            assert!(
                (mean - 1.0).abs() < tolerance,
                "κ {kappa:e}: E[κ d²] = {mean}"
            );
        }
    }
}
