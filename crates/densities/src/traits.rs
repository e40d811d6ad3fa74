//! The algebra shared by the density families.
//!
//! Every density states its base measure in its docs (Lebesgue dθ on the circle, surface measure on
//! S², normalised Haar measure on SO(3), …); `log_pdf` and `log_normalizer` are with respect to it.

use crate::error::DensityError;
use rand::Rng;

/// A normalised probability density on a space of points.
///
/// Every family also implements [`rand::distr::Distribution`] for its points (on the density itself,
/// or on a sampler it builds, as [`GenVonMises2::sampler`](crate::GenVonMises2::sampler)), through
/// this trait's [`sample`](Density::sample): `rng.sample(&p)` and `p.sample_iter(rng)` draw the same
/// values as `Density::sample(&p, rng)`. With both traits in scope, `p.sample(rng)` is ambiguous:
/// write `rng.sample(&p)` or `Density::sample(&p, rng)`.
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
///
/// # Example
/// ```
/// use liebayes_densities::{Density, Gaussian, Product};
/// use nalgebra::{Matrix1, Vector1};
/// let p = Gaussian::new(Vector1::new(0.0), Matrix1::new(1.0)).unwrap();
/// let q = Gaussian::new(Vector1::new(2.0), Matrix1::new(1.0)).unwrap();
/// // N(0, 1) N(2, 1) ∝ N(1, 1/2); ∫ p q = N(2; 0, 2).
/// let r = p.product(&q).unwrap();
/// assert!((r.mean()[0] - 1.0).abs() < 1e-15 && (r.covariance()[0] - 0.5).abs() < 1e-15);
/// let expected = -0.5 * (4.0 * std::f64::consts::PI).ln() - 1.0;
/// assert!((p.log_product_integral(&q).unwrap() - expected).abs() < 1e-14);
/// ```
pub trait Product: Density + Sized {
    /// The normalised product `p q / ∫ p q`.
    ///
    /// # Errors
    /// Where the product is not a proper density of the family's accepted range (for example two
    /// Binghams whose summed eigenvalue spread exceeds the verified range).
    fn product(&self, other: &Self) -> Result<Self, DensityError>;

    /// `ln ∫ p q` with respect to the base measure: the log evidence of `other` seen as a likelihood.
    /// Finite whenever it is `Ok`.
    ///
    /// # Errors
    /// Exactly where [`product`](Product::product) fails (the normaliser of the product is then not
    /// available), and where the value is not a finite number.
    fn log_product_integral(&self, other: &Self) -> Result<f64, DensityError>;
}

/// Closed-form entropy `−∫ p ln p` with respect to the base measure.
///
/// # Example
/// ```
/// use liebayes_densities::{Entropy, VonMises};
/// use liebayes_manifolds::So2;
/// // The uniform distribution on the circle has the largest entropy, ln 2π.
/// let uniform = VonMises::new(So2::from_angle_unchecked(0.0), 0.0).unwrap();
/// assert!((uniform.entropy() - (2.0 * std::f64::consts::PI).ln()).abs() < 1e-15);
/// let peaked = VonMises::new(So2::from_angle_unchecked(0.0), 5.0).unwrap();
/// assert!(peaked.entropy() < uniform.entropy());
/// ```
pub trait Entropy: Density {
    /// The differential entropy.
    fn entropy(&self) -> f64;
}

/// Closed-form Kullback-Leibler divergence.
///
/// # Example
/// ```
/// use liebayes_densities::{Gaussian, KlDivergence};
/// use nalgebra::{Matrix1, Vector1};
/// let p = Gaussian::new(Vector1::new(0.0), Matrix1::new(1.0)).unwrap();
/// let q = Gaussian::new(Vector1::new(1.0), Matrix1::new(1.0)).unwrap();
/// // KL(N(0, 1) ‖ N(1, 1)) = 1/2; zero against itself.
/// assert!((p.kl_divergence(&q) - 0.5).abs() < 1e-15);
/// assert_eq!(p.kl_divergence(&p), 0.0);
/// ```
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

/// A density transported by a group acting on its space: [`rotated`](Rotate::rotated) is the
/// distribution of `g · x` for `x` drawn from `self`, exactly, in the same family.
///
/// The action is [`act`](Rotate::act): rotation of the circle by `So2`, of the sphere by `So3`,
/// left multiplication of unit quaternions by `Su2`, left composition on a group (left translation).
///
/// # Example
/// ```
/// use liebayes_densities::{Density, Rotate, VonMisesFisher};
/// use liebayes_manifolds::{S2, So3};
/// use nalgebra::Vector3;
/// let p = VonMisesFisher::new(S2::new(Vector3::x()).unwrap(), 3.0).unwrap();
/// let turn = So3::from_axis_angle(&Vector3::z(), std::f64::consts::FRAC_PI_2).unwrap();
/// // Turning the density turns its mean: x goes to y.
/// let turned = p.rotated(&turn)?;
/// assert!((turned.mode().unwrap().as_vector() - Vector3::y()).norm() < 1e-15);
/// # Ok::<(), liebayes_densities::DensityError>(())
/// ```
pub trait Rotate<G>: Density + Sized {
    /// The distribution of `g · x`, `x ~ self`: `rotated(g).log_pdf(act(g, x)) = log_pdf(x)`.
    ///
    /// # Errors
    /// Where the result overflows the representable range (the compact groups' rotations never
    /// do; a Gaussian moved by a pose whose translation is near overflow can).
    fn rotated(&self, g: &G) -> Result<Self, DensityError>;

    /// The action `g · x` on points that [`rotated`](Rotate::rotated) transports the density along.
    fn act(g: &G, x: &Self::Point) -> Self::Point;
}

/// `rand::distr::Distribution` for densities whose draws need nothing built beforehand: each calls
/// [`Density::sample`], so the two are one implementation.
macro_rules! distribution_through_density {
    ($($ty:ty),* $(,)?) => {
        $(
            impl rand::distr::Distribution<<$ty as Density>::Point> for $ty {
                /// One draw, by [`Density::sample`].
                fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> <$ty as Density>::Point {
                    Density::sample(self, rng)
                }
            }
        )*
    };
}
pub(crate) use distribution_through_density;
