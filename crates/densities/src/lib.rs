//! # liebayes-densities
//!
//! Probability densities on the spaces of [`liebayes_manifolds`], and the special functions they need.
//!
//! * [`special`]: log I₀, log I₁, Bessel ratios Iₙ/I₀, the inverse of A(κ) = I₁/I₀, the von
//!   Mises-Fisher mean resultant length and log normaliser, all stable for κ from 0 to 1e6.
//!
//! The densities of the seeds (von Mises and its second-harmonic generalisation on SO(2), von
//! Mises-Fisher on S², Bingham on SU(2), the heat kernel on SO(3), Gaussians on Rⁿ and on the tangent
//! spaces of Lie groups) and the traits of their algebra are being built on top of this module.
//! The numbers are f64: the manifolds are generic over the scalar, the densities are not (yet).

mod bingham;
mod bingham_normalizer;
mod error;
mod gaussian;
mod gen_von_mises;
mod heat_kernel;
mod moment_matching;
mod quadrature;
pub mod special;
mod tangent_gaussian;
#[cfg(feature = "proptest")]
pub mod testing;
mod traits;
mod von_mises;
mod von_mises_fisher;

pub use bingham::Bingham;
pub use error::DensityError;
pub use gaussian::Gaussian;
pub use gen_von_mises::GenVonMises2;
pub use heat_kernel::HeatKernelSo3;
pub use liebayes_manifolds as manifolds;
pub use tangent_gaussian::TangentGaussian;
pub use traits::{Convolve, Density, Entropy, KlDivergence, Product};
pub use von_mises::VonMises;
pub use von_mises_fisher::VonMisesFisher;
