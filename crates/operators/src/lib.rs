//! # liebayes-operators
//!
//! The Bayesian operators, generic over the state space and the density: `Propagate` (Chapman-Kolmogorov
//! through a process model) and `Condition` (Bayes with a measurement model, returning the posterior and
//! the log evidence); the linear Kalman filter, EKF and UKF on any `Manifold` (error state through
//! `retract`/`local`), the particle filter, the grid filter on the circle, Rao-Blackwellized composites
//! and the marginalized particle filter; and the evaluation tools (Monte Carlo runner, NEES/NIS).
//!
//! It depends on `liebayes-densities` and `liebayes-manifolds` only. It is empty until the operators
//! issue lands.

pub use liebayes_densities as densities;
