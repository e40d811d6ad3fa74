//! Angle-of-arrival positioning, after "3D angle-of-arrival positioning using von Mises-Fisher
//! distribution" (Nurminen, Suomalainen, Müller, Ali-Löytty, Piché): anchors at known positions and
//! orientations measure the azimuth and elevation of a user, and filters estimate its position
//! θ ∈ R³.
//!
//! * [`direction`]: readings ([`AzEl`]), unit vectors and the one-representation rule;
//! * [`Anchor`]s and the square track's geometry ([`square_track_anchors`]);
//! * the noise models ([`noise`]: von Mises-Fisher, normal in azimuth and elevation, the
//!   conversion between them, the adaptive σ table) and the data they generate ([`DataModel`]);
//! * the measurement models ([`UnitVectorModel`], [`AzElModel`]) for the particle filter, the EKF,
//!   the UKF and the iterated EKF, and the filters built from them ([`vmf_particle_filter`],
//!   [`vmf_ekf`], [`vmf_iterated_ekf`], …);
//! * [`PositionEstimate`] and [`PositionScorer`], and the [`SquareTrack`] scenario.
//!
//! The math and the corrections to the paper are in `docs/filters/aoa.md`.

mod anchor;
mod comparison;
mod data;
pub mod direction;
mod estimate;
mod example;
mod filter;
mod method;
mod model;
pub mod noise;
mod process;
mod quadrature;
mod scenario;

pub use anchor::{Anchor, POSITION_LIMIT, square_track_anchors};
pub use comparison::{
    AngleSigmaFit, ComparisonRow, FILTER_MODELS, MAX_SAMPLES, MIN_SAMPLES, ModelComparison,
    PAPER_TABLE1, PaperColumn, compare_models, fit_angle_sigmas, fit_angle_sigmas_to,
};
pub use data::DataModel;
pub use direction::AzEl;
pub use estimate::{PositionEstimate, PositionMoments, PositionScorer};
pub use example::{UpdateExample, UpdateRow};
pub use filter::{
    AngleEkf, AngleIteratedEkf, AngleParticleFilter, AngleUkf, GaussianFilter, PRIOR_MEAN_LIMIT,
    PRIOR_STD_LIMIT, PRIOR_STD_MIN, PositionGaussian, Prior, RESAMPLE_BELOW, UKF_LAMBDA, VmfEkf,
    VmfIteratedEkf, VmfParticleFilter, VmfUkf, angle_ekf, angle_iterated_ekf,
    angle_particle_filter, angle_ukf, vmf_ekf, vmf_iterated_ekf, vmf_particle_filter, vmf_ukf,
};
pub use method::{
    Algorithm, ModelChoice, OnTrack, OnTrackReadings, PositionFilter, TrackFilter,
    particles_to_match, track_rmse,
};
pub use model::{
    AngleNoise, AzElModel, CheckedReadings, InWorldAxes, Position, Readings, StackedAngles,
    StackedUnitVectors, UnitVectorModel, WorldDirections,
};
pub use noise::{
    AdaptiveSigmas, KAPPA_RANGE, SIGMA_RANGE, az_el_log_density, kappa_from_sigmas,
    sigma_from_kappa,
};
pub use process::{DELTA_LIMIT, DELTA_MIN, Q_LIMIT, Q_MIN, RandomWalk};
pub use quadrature::{MIN_EFFECTIVE_NODES, PRIOR_LIMIT, exact_posterior};
pub use scenario::{SIDE_LIMIT, SquareTrack, TrackConfig, TrackReadings, TrackSteps, TruthModel};
