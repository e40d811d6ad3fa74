//! The algebra shared by the density families.
//!
//! Every density states its base measure in its docs (Lebesgue dθ on the circle, surface measure on
//! S², normalised Haar measure on SO(3), …); `log_pdf` and `log_normalizer` are with respect to it.

use crate::error::DensityError;
use rand::Rng;

/// A normalised probability density on a space of points.
pub trait Density {
    /// The points the density lives on.
    type Point;

    /// `ln p(x)` with respect to the family's base measure.
    fn log_pdf(&self, x: &Self::Point) -> f64;

    /// `ln Z`, the logarithm of the normalising constant, `p(x) = exp(⟨η, T(x)⟩) / Z`.
    fn log_normalizer(&self) -> f64;

    /// One draw.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Self::Point;

    /// The point of highest density, or `None` where it is not unique (a uniform density, or a
    /// symmetric one with several maxima).
    fn mode(&self) -> Option<Self::Point>;
}

/// Bayes' rule with a conjugate likelihood: the normalised pointwise product `p q / ∫ p q`.
pub trait Product: Density + Sized {
    /// The normalised product `p q / ∫ p q`.
    ///
    /// # Errors
    /// Where the product is not a proper density (for example two Gaussians in information form whose
    /// summed precision is singular).
    fn product(&self, other: &Self) -> Result<Self, DensityError>;

    /// `ln ∫ p q` with respect to the base measure: the log evidence of `other` seen as a likelihood.
    fn log_product_integral(&self, other: &Self) -> f64;
}

/// Closed-form entropy `−∫ p ln p` with respect to the base measure.
pub trait Entropy: Density {
    /// The differential entropy.
    fn entropy(&self) -> f64;
}

/// Closed-form Kullback-Leibler divergence.
pub trait KlDivergence: Density {
    /// `KL(self ‖ other) = ∫ p ln(p/q) ≥ 0`, zero only for equal densities.
    fn kl_divergence(&self, other: &Self) -> f64;
}

/// Propagation where the family is closed under it: the distribution of `x ∘ y` for independent
/// `x ~ self`, `y ~ other` (sum on Rⁿ, composition on a group), in the same family, exactly.
/// Families that are not closed offer named approximations instead (for example
/// `VonMises::convolve_moment_matched`).
pub trait Convolve: Density + Sized {
    /// The exact convolution.
    ///
    /// # Errors
    /// Where the result overflows the representable range.
    fn convolve(&self, other: &Self) -> Result<Self, DensityError>;
}
