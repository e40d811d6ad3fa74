//! Azimuth alignment, after the blog post "Exact finite-state filter for azimuth alignment": a
//! platform moves in the plane; its velocity is known in its own axes, its position is measured in
//! world axes, and the two frames differ by an unknown constant azimuth A:
//!
//! `ṙ = v + w` (r in platform axes, `w` white with PSD `q² I`), `z = R(A) r + n`,
//! `n ~ N(0, σ_m² I)`, `R(A)` the rotation by A, an [`So2`].
//!
//! The joint posterior is exactly `p(r, A) = p(A) p(r | A)` with p(A) von Mises and
//! `p(r | A) = N(a + c cos A − c^× sin A, σ² I)`, `u^× = (−u_y, u_x)`: seven numbers (η, a, c, σ²),
//! [`AzimuthDensity`]. Every filter here is an experiment-layer
//! [`Recursive`](liebayes_experiments::Recursive) filter (a density stepped by the operator traits)
//! with the estimate [`AzimuthEstimate`]:
//!
//! | filter | built by | density |
//! |---|---|---|
//! | exact | [`exact`] | [`AzimuthDensity`] |
//! | EKF, UKF | [`ekf`], [`ukf`] | a Gaussian on [`PositionAzimuth`] = R² × SO(2) |
//! | bootstrap particle filter | [`particle_filter`] | particles on [`PositionAzimuth`] |
//! | grid filter (the brute-force reference) | [`grid_filter`] | a Kalman filter at each of n azimuths |
//! | marginalized particle filter | [`marginalized_filter`] | azimuth particles, each with a Kalman filter |
//!
//! [`AzimuthScenario`] simulates the blog post's three motions ([`Motion`]) for the layer's
//! studies, [`AzimuthScorer`] scores the estimates, and [`Method`] names the filters for a study.
//! The math is in `docs/filters/azimuth.md`.

mod density;
mod estimate;
mod gaussian;
mod grid;
mod marginalized;
mod method;
mod model;
mod particle;
mod scenario;
#[cfg(feature = "serde")]
mod serde_impls;

pub use density::{
    AzimuthDensity, CONCENTRATION_LIMIT, POSITION_LIMIT, SPREAD_RATIO, VARIANCE_LIMIT,
};
pub use estimate::{AzimuthEstimate, AzimuthMoments, AzimuthScorer, DIVERGENCE_THRESHOLD};
pub use gaussian::{AzimuthEkf, AzimuthUkf, ekf, ukf};
pub use grid::{AzimuthGrid, grid_filter, log_joint};
pub use marginalized::{AzimuthMarginalized, marginalized_filter};
pub use method::{
    AzimuthFilter, Method, OnScenario, exact, final_azimuth_rmse, particles_to_match,
};
pub use model::{
    PRIOR_POSITION_LIMIT, PositionMeasurement, SETTING_SIGMA_RANGE, VelocityInput, VelocityProcess,
};
pub use particle::{AzimuthParticleFilter, particle_filter};
pub use scenario::{AzimuthScenario, AzimuthSteps, Config, MAX_DT, Motion};

use liebayes_manifolds::{ProductManifold, Rn, So2};

/// The state `[r, A]` ∈ R² × SO(2): r (platform axes) the first factor, A the second, tangent
/// `[δr; δA]`, `x ⊞ δ = (r + δr, A ⊞ δA)`. The truth of the scenarios, and the state of the
/// Gaussian and particle filters.
pub type PositionAzimuth = ProductManifold<Rn<f64, 2>, So2<f64>, 2, 1, 3>;

/// The exact filter.
pub type AzimuthExact = liebayes_experiments::Recursive<
    AzimuthDensity,
    VelocityProcess,
    PositionMeasurement,
    AzimuthMoments,
>;
