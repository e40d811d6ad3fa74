//! # liebayes-filters
//!
//! The applications, each a composition of the operators:
//!
//! * [`azimuth`]: the exact von Mises × Gaussian filter for aligning two frames rotated by an unknown
//!   azimuth (the blog post "Exact finite-state filter for azimuth alignment"), with its brute-force reference (a grid of Kalman filters) and its scenarios.
//!
//! * [`attitude`]: IMU attitude: the data layer (IMU logs from the BROAD dataset and CSV files),
//!   the BROAD error metric and Madgwick's filter as a baseline.
//!
//! The IMU attitude filter (Bingham and heat kernel on SO(3)) and angle-of-arrival positioning (von
//! Mises-Fisher) follow in their own issues.

pub mod aoa;
pub mod attitude;
pub mod azimuth;
mod error;

pub use error::FilterError;

pub use liebayes_operators as operators;
