//! # liebayes-densities
//!
//! Probability densities on the spaces of [`liebayes_manifolds`], and the special functions they need.
//!
//! This crate will own (see `docs/architecture.md`): `Gaussian<N>` on Rⁿ and `TangentGaussian<G>` on any
//! Lie group; `VonMises` and `GenVonMises2` on SO(2); `VonMisesFisher` on S²; `Bingham` on SU(2);
//! `HeatKernelSo3` (isotropic diffusion on SO(3)); the traits of their algebra (`log_pdf`,
//! `log_normalizer`, `sample`, `mode`, moments, `product`, `convolve`) and the module `special`
//! (log I0, Bessel ratios, the Bingham normaliser). It depends only on `liebayes-manifolds`.
//!
//! It is empty until the densities issue lands; the facade already re-exports it so that user code can
//! name it.

pub use liebayes_manifolds as manifolds;
