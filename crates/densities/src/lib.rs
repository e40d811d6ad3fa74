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
//! * With the `proptest` feature, [`testing`] exports strategies for every family.

mod bingham;
mod bingham_normalizer;
mod error;
mod gaussian;
mod gen_von_mises;
mod harmonic_gaussian;
mod heat_kernel;
mod manifold_gaussian;
mod moment_matching;
mod quadrature;
mod scaled_bessel;
mod scaled_bessel_coefficients;
pub mod special;
#[cfg(feature = "proptest")]
pub mod testing;
mod traits;
mod von_mises;
mod von_mises_fisher;

pub use bingham::Bingham;
pub use error::DensityError;
pub use gaussian::Gaussian;
pub use gen_von_mises::{GenVonMises2, GenVonMises2Sampler};
pub use harmonic_gaussian::{HarmonicGaussian, harmonic_features};
pub use heat_kernel::HeatKernelSo3;
pub use liebayes_manifolds as manifolds;
pub use manifold_gaussian::ManifoldGaussian;
pub use traits::{Convolve, Density, Entropy, KlDivergence, Product, Rotate};
pub use von_mises::VonMises;
pub use von_mises_fisher::VonMisesFisher;
