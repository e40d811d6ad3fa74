//! # liebayes-densities
//!
//! Probability densities on the spaces of [`liebayes_manifolds`], the special functions they need, and
//! their algebra. All numbers are f64; each family documents its base measure and its range.
//!
//! | family | space | base measure |
//! |---|---|---|
//! | [`VonMises`], [`GenVonMises2`] | SO(2) | dθ (total 2π) |
//! | [`VonMisesFisher`] | S² | surface measure (total 4π) |
//! | [`Bingham`] | SU(2) = S³ (and SO(3)) | uniform probability measure |
//! | [`HeatKernelSo3`] | SO(3) | normalised Haar measure |
//! | [`Gaussian`] | Rⁿ | Lebesgue |
//! | [`ManifoldGaussian`] | any manifold | Lebesgue in the tangent coordinates at the mean |
//! | [`HarmonicGaussian`] | SO(2) × Rⁿ | dy dx |
//!
//! * The algebra is shared through traits: [`Density`] (`log_pdf`, `log_normalizer`, `sample`, `mode`),
//!   [`Product`] (Bayes with a conjugate likelihood, with the log evidence), [`Convolve`] (propagation
//!   where the family is closed), [`Entropy`], [`KlDivergence`].
//! * Moments are methods of each type.
//! * Named approximations (moment matching between families) carry their measured errors in
//!   `docs/densities/`.
//! * [`special`]: ln I₀, ln I₁, Bessel ratios Iₙ/I₀, A⁻¹ and the von Mises-Fisher functions, accurate to
//!   a few ulp from κ = 0 to 1e6.
//! * With the `proptest` feature, the `testing` module exports strategies for every family,
//!   quadrature on every space, and the density law suite (the `density_laws!` macro) that a family
//!   of your own can run in one line; build the docs with `cargo doc --all-features` (as docs.rs
//!   does) to see them.
//! * With the `serde` feature, every density serializes as its defining parameters and deserializes
//!   through its validated constructor: a file with a negative concentration or a covariance that is
//!   not positive definite is an error, never an invalid density.
//! * Every family's sampler is a [`rand::distr::Distribution`] of its points (`rng.sample(&p)`,
//!   `p.sample_iter(rng)`), the same draws as [`Density::sample`].
//!
//! # Input contract
//!
//! Every constructor takes the same limit for the same kind of value, and every result is finite
//! and valid, or the call returns a typed [`DensityError`]:
//!
//! * **Gaussian locations and spreads**: an entry of a covariance, and the trace `tr P⁻¹` of its
//!   inverse (which bounds every entry of the inverse), at most [`MAX_SCALE`] = 1e100 in
//!   magnitude, in [`Gaussian::new`], [`ManifoldGaussian::new`] and [`HarmonicGaussian::new`]
//!   alike, and the entries of what [`ManifoldGaussian::propagated_covariance`] returns; a mean
//!   (or feature) coordinate at most [`MAX_SCALE`] in [`Gaussian::new`] and
//!   [`HarmonicGaussian::new`]. [`ManifoldGaussian::new`]
//!   takes any finite mean ([`Manifold::is_finite`](liebayes_manifolds::Manifold::is_finite)): a
//!   point of a general manifold has no coordinates to bound, so an application whose state has a
//!   vector part checks its own prior mean (the azimuth and angle-of-arrival filters of the filters
//!   crate limit theirs to 1e100).
//! * **Concentrations**: each family documents its range (the generalised von Mises up to
//!   [`GenVonMises2::MAX_CONCENTRATION`] = 1e16); orders of [`special::bessel_ratio`] up to
//!   [`special::MAX_ORDER`].
//! * **Values that overflow**: a log density whose exact value is below −f64::MAX (a point 1e200
//!   standard deviations away) is −∞, documented per family; never NaN.
//!
//! # Naming contract
//!
//! Every family follows the same names, so that code written for one reads the same for another:
//!
//! * `new` takes the parameters users think in: a **location** (a point of the space, or an
//!   orientation) and a **spread** (a concentration, a variance or a covariance), validated, with a
//!   typed [`DensityError`] naming the valid range.
//! * `from_natural` builds the family from its exponential-family natural parameters and `natural`
//!   returns them (by value), for the families that are exponential families.
//! * `mean` is the location: the mean on the space (`Option` where the uniform member has none);
//!   `first_moment` / `second_moment` are the moments of the embedded point; `from_first_moment` /
//!   `from_second_moment` are the moment-matching inverses.
//! * [`Density::mode`] is the point of highest density, `None` where it is not unique.
//! * [`Rotate::rotated`] transports the density along the group that acts on its space.
//!
//! | family | `new` | `from_natural` / `natural` | `mean` | `Rotate` |
//! |---|---|---|---|---|
//! | [`VonMises`] | `(mean: So2, concentration κ)` | η = κ u(μ) | `Option<So2>` | `So2` |
//! | [`GenVonMises2`] | `(mean1, κ₁, mean2, κ₂)` | (η₁, η₂) | none (moments: `trigonometric_moments`) | `So2` |
//! | [`VonMisesFisher`] | `(mean: S2, concentration κ)` | η = κ μ | `Option<S2>` | `So3` |
//! | [`Bingham`] | `(orientation V, eigenvalues z)` | M = V diag(z) Vᵀ | none (antipodal; `second_moment`) | `Su2` |
//! | [`HeatKernelSo3`] | `(mean: So3, variance s)` | not an exponential family | `So3` | `So3` |
//! | [`Gaussian`] | `(mean, covariance)` | (h = Σ⁻¹μ, Λ = Σ⁻¹) | `&SVector` | none |
//! | [`ManifoldGaussian`] | `(mean, tangent covariance)` | not an exponential family | `&X` | left translation on a group |
//! | [`HarmonicGaussian`] | `(angle marginal, features B, covariance Σ)` | not offered | none (`marginal_moments`) | none |
//!
//! Laws that do not apply to a family are stated, not skipped silently: only the exponential
//! families with a conjugate self-product implement [`Product`] (the heat kernel, the manifold
//! Gaussian and the harmonic Gaussian do not: their pointwise products leave the family); the
//! manifold Gaussian has a closed KL only for equal means, so it offers
//! [`ManifoldGaussian::kl_divergence`] as a fallible method, not [`KlDivergence`].
#![cfg_attr(docsrs, feature(doc_cfg))]

mod bingham;
mod bingham_normalizer;
mod eigen;
mod error;
mod gaussian;
mod gen_von_mises;
mod harmonic_gaussian;
mod heat_kernel;
mod manifold_gaussian;
mod moment_matching;
pub mod quadrature;
mod scaled_bessel;
mod scaled_bessel_coefficients;
#[cfg(feature = "serde")]
mod serde_impls;
pub mod special;
#[cfg(feature = "proptest")]
#[cfg_attr(docsrs, doc(cfg(feature = "proptest")))]
pub mod testing;
mod traits;
mod von_mises;
mod von_mises_fisher;

pub use bingham::Bingham;
pub use error::DensityError;
pub use gaussian::{Gaussian, MAX_SCALE};
pub use gen_von_mises::{GenVonMises2, GenVonMises2Sampler};
pub use harmonic_gaussian::{HarmonicGaussian, harmonic_features};
pub use heat_kernel::HeatKernelSo3;
pub use liebayes_manifolds as manifolds;
pub use manifold_gaussian::ManifoldGaussian;
pub use traits::{Convolve, Density, Entropy, KlDivergence, Product, Rotate};
pub use von_mises::VonMises;
pub use von_mises_fisher::VonMisesFisher;
