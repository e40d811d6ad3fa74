//! Azimuth alignment, after the blog post "Exact finite-state filter for azimuth alignment": a platform moves in the plane; its velocity is known in its own axes,
//! its position is measured in world axes, and the two frames differ by an unknown constant azimuth A:
//!
//! `ṙ = v + w` (r in platform axes, `w` white with PSD `q² I`), `z = R(A) r + n`, `n ~ N(0, σ_m² I)`,
//! `R(A) = [[cos A, −sin A], [sin A, cos A]]`.
//!
//! The joint posterior is exactly `p(r, A) = p(A) p(r | A)` with p(A) von Mises and
//! `p(r | A) = N(a + c cos A − c^× sin A, σ² I)`, `u^× = (−u_y, u_x)`: seven numbers (η, a, c, σ²),
//! [`AzimuthDensity`]. It is checked against [`GridReference`], a bank of exact Kalman filters over a
//! grid of azimuths built from the operators crate, and against the reference vectors `azimuth_vectors.json`.
//! The baselines (EKF, UKF, particle, grid and marginalized particle filters) share the
//! [`AzimuthFilter`] interface with it. [`scenario`] simulates the blog post's three scenarios and [`study()`]
//! runs the Monte Carlo summary of any [`Method`]. The math is in `docs/filters/azimuth.md`.

mod baselines;
mod density;
mod grid;
mod model;
pub mod scenario;
#[cfg(feature = "serde")]
mod serde_impls;
pub mod study;

pub use baselines::{
    AzimuthFilter, Estimate, GaussianBaseline, Linearisation, MarginalizedBaseline,
    ParticleBaseline, PositionAzimuth,
};
pub use density::{
    AzimuthDensity, AzimuthEstimates, CONCENTRATION_LIMIT, POSITION_LIMIT, VARIANCE_LIMIT,
};
pub use grid::GridReference;
pub use model::{PositionMeasurement, VelocityInput, VelocityProcess};
pub use study::{Method, Summary, study};
