//! # liebayes-operators
//!
//! The two Bayesian operations as traits, generic over the density and the model:
//!
//! * [`Propagate`]: Chapman-Kolmogorov, `p(x′) = ∫ p(x′ | x, u) p(x) dx`, through a process model with
//!   an input u;
//! * [`Condition`]: Bayes, `p(x | z) = p(z | x) p(x) / p(z)`, with a measurement model, returning the
//!   posterior together with the log evidence `ln p(z)` (the log marginal likelihood), so that filters
//!   can be compared and models selected on the same data.
//!
//! Implemented so far: the linear Kalman filter on [`Gaussian<N>`](liebayes_densities::Gaussian)
//! ([`kalman`]), exact, with the Joseph-form covariance update; and the consistency metrics of
//! [`evaluation`] (NEES and its band, angle errors); the particle filter over any state type with four
//! resampling schemes ([`particle`]). The filters crate composes these into
//! applications (the azimuth filter's grid reference is a bank of these Kalman filters).

pub mod ekf;
mod error;
pub mod evaluation;
pub mod grid;
pub mod kalman;
mod manifold_gaussian;
mod numerics;
pub mod particle;
pub mod rao_blackwell;
mod traits;
pub mod ukf;

pub use ekf::Ekf;
pub use error::OperatorError;
pub use manifold_gaussian::{ManifoldGaussian, MeasurementModel, ProcessModel};
pub use traits::{Condition, Conditioned, Propagate};
pub use ukf::Ukf;

pub use liebayes_densities as densities;
