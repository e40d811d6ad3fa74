//! # liebayes-filters
//!
//! The applications, each a composition of the operators: `azimuth` (the exact von Mises × Gaussian
//! filter for frame alignment), `attitude` (IMU attitude on SO(3) with Bingham and heat-kernel
//! densities) and `aoa` (angle-of-arrival positioning with von Mises-Fisher noise), each with its
//! scenario simulators and baselines.
//!
//! It is empty until the application issues land.

pub use liebayes_operators as operators;
