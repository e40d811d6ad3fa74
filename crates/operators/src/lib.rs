//! # liebayes-operators
//!
//! The two Bayesian operations as traits, generic over the density and the model:
//!
//! * [`Propagate`]: Chapman-Kolmogorov, `p(x′) = ∫ p(x′ | x, u) p(x) dx`, through a process model with
//!   an input u;
//! * [`Condition`]: Bayes, `p(x | z) = p(z | x) p(x) / p(z)`, with a measurement model, returning the
//!   posterior together with the log evidence `ln p(z)` (the log marginal likelihood), so that filters
//!   can be compared and models selected on the same data, and the algorithm's report (the Kalman
//!   filters' [`Innovation`]: ν, S, K and the NIS).
//!
//! Each trait has a by-value step and an in-place one ([`Propagate::propagate_in_place`],
//! [`Condition::condition_in_place`], which returns the [`Evidence`]): a filter loop calls the
//! in-place form, which the particle set and the grid implement without allocating. Every step is
//! all or nothing: it returns a new density or a typed [`OperatorError`], and a density stepped in
//! place (particle set, grid, smoother) is unchanged by a failed step.
//!
//! The algorithms, each checked against an exact computation in the tests:
//!
//! * [`kalman`]: the linear Kalman filter on [`Gaussian<N>`](liebayes_densities::Gaussian), exact, in
//!   Joseph form;
//! * [`Ekf`] and [`Ukf`]: the extended and unscented Kalman filters on any
//!   [`Manifold`](liebayes_manifolds::Manifold), on the densities crate's
//!   [`ManifoldGaussian`](liebayes_densities::ManifoldGaussian) (mean on the manifold, covariance in
//!   its tangent space), with user [`ProcessModel`]s and [`MeasurementModel`]s ([`models`]: used by
//!   reference, or written from closures with [`ProcessFn`] and [`MeasurementFn`]);
//! * [`iterated`]: iterated updates of that Gaussian on any manifold ([`IteratedEkf`]: Gauss-Newton on
//!   the MAP cost with step control; [`IteratedUkf`]: iterated posterior linearisation with the
//!   UKF's sigma points), for measurements precise enough that one linearisation at the prior mean
//!   misleads;
//! * [`smoother`]: the Rauch-Tung-Striebel smoother for that Gaussian (EKF or UKF linearisation);
//!   [`fixed_lag`]: its online form, the density of epoch k − L after epoch k, in memory bounded by L;
//!   [`iterated_smoother`]: the MAP trajectory by Gauss-Newton relinearised over the whole run, its
//!   block-tridiagonal normal equations solved with nalgebra's fixed-size blocks or, from dimension
//!   15, faer's;
//! * [`particle`]: the particle filter over any state type (log weights, four resampling schemes, ESS
//!   threshold), propagated by sampling a [`SampledProcess`] ([`Sampled`]), conditioned by a
//!   [`Likelihood`] ([`Reweight`]; `ReweightInParallel` with the `rayon` feature) or, for particles carrying
//!   a density, by the payload's exact step given the particle's label ([`Given`]: the marginalized
//!   particle filter);
//! * [`grid`]: the grid filter on the circle, optionally carrying a density per cell (stepped with
//!   [`Given`]), a plain angle density stepped with [`Reweight`] and [`Diffusion`];
//! * [`rao_blackwell`]: the exact steps of the closed-form composite of an angle and a conditionally
//!   Gaussian vector ([`HarmonicGaussian`](liebayes_densities::HarmonicGaussian));
//! * [`converted`]: a model whose readings are converted once per step into the measurement its
//!   step takes (one data stream, several models of it);
//! * [`process_noise`]: a continuous model discretised (Van Loan), the white-noise blocks of the
//!   constant-velocity and constant-acceleration models, and the transport of a covariance between
//!   body-frame and world-frame errors (`Ad(x) P Ad(x)ᵀ`);
//! * [`evaluation`]: the consistency metrics (NEES, NIS, their χ² bands, a circular consistency
//!   statistic) and the estimation error on a manifold.
//!
//! The math of each is in `docs/operators/`; the filters crate composes them into applications.
//!
//! # Input contract
//!
//! Every step is all or nothing: it returns a finite, valid density (a finite mean on its
//! manifold, a symmetric positive definite covariance, log weights that normalise with an effective
//! sample size in [1, N]) with a finite log evidence, or a typed [`OperatorError`] saying what to
//! fix, and a density stepped in place is unchanged. A model's output is checked before it is used:
//! a process or measurement model returning NaN, ±∞ or a covariance that is not positive definite
//! makes the step fail, never the density. Counts (particles, draws, grid cells) are checked against
//! [`MAX_ELEMENTS`] = 2³⁰ before anything is allocated, and every iteration has a bound (the UKF's
//! sigma points, the smoother's passes, the χ² quantile's bisection). The Gaussians' limits are the
//! densities crate's (`MAX_SCALE` = 1e100).
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod converted;
pub mod ekf;
mod error;
pub mod evaluation;
pub mod fixed_lag;
pub mod grid;
mod innovation;
pub mod iterated;
pub mod iterated_smoother;
pub mod kalman;
pub mod models;
mod numerics;
pub mod particle;
pub mod process_noise;
pub mod rao_blackwell;
#[cfg(feature = "serde")]
mod serde_impls;
pub mod smoother;
mod traits;
pub mod ukf;

pub use converted::{Conversion, Converted};
pub use ekf::Ekf;
pub use error::{MAX_ELEMENTS, OperatorError};
pub use grid::Diffusion;
pub use innovation::Innovation;
pub use iterated::{IteratedEkf, IteratedUkf};
pub use models::{MeasurementFn, MeasurementModel, ProcessFn, ProcessModel};
pub use particle::{
    Given, LabelModel, Likelihood, LikelihoodFn, Reweight, SampleFn, Sampled, SampledProcess,
};
pub use traits::{Condition, Conditioned, Evidence, Propagate};
pub use ukf::{SquareRoot, Ukf};

pub use liebayes_densities as densities;
pub use liebayes_manifolds as manifolds;
