//! # liebayes-filters
//!
//! The applications, each a composition of the operators and driven through the experiment layer
//! (`liebayes_experiments::RecursiveFilter`, scenarios and studies):
//!
//! * [`azimuth`]: the exact von Mises × Gaussian filter for aligning two frames rotated by an
//!   unknown azimuth (the blog post "Exact finite-state filter for azimuth alignment"), its EKF,
//!   UKF, grid, particle and Rao-Blackwellised rivals, and its scenarios;
//! * [`aoa`]: angle-of-arrival positioning ("3D angle-of-arrival positioning using von
//!   Mises-Fisher distribution"): the two noise models, the EKFs, UKFs and particle filters of
//!   both, the exact single-update posterior by quadrature, and the square-track scenario;
//! * [`attitude`]: IMU attitude: the data layer (IMU logs from the BROAD dataset and CSV files),
//!   the BROAD error metric, Madgwick's filter as a baseline, the talk's Bingham filter and the
//!   production error-state EKF.
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod aoa;
pub mod attitude;
pub mod azimuth;
mod error;

pub use error::FilterError;

pub use liebayes_operators as operators;
