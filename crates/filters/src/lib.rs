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
//!   production error-state EKF;
//! * [`inertial`]: strapdown inertial navigation with position fixes and IMU biases, by the
//!   error-state EKF and the invariant EKFs on SE_2(3), compared for consistency.
//!
//! # Input contract
//!
//! Readings beyond a sensor's physical range are refused, by the readers (naming the file and the
//! row) and by every filter step: gyroscope rates above [`attitude::MAX_ANGULAR_RATE`] = 1e4 rad/s,
//! specific forces above [`attitude::MAX_SPECIFIC_FORCE`] = 1e4 m/s², magnetic fields above
//! [`attitude::MAX_FIELD`] = 1e9; angle-of-arrival noise σ and κ within [`aoa::SIGMA_RANGE`] and
//! [`aoa::KAPPA_RANGE`]. Files are checked before they are trusted: a BROAD `.mat` file at most
//! [`attitude::MAX_MAT_FILE_BYTES`], every element's and sub-element's declared size against the
//! bytes it lies in, the values its matrices declare at most [`attitude::MAX_MAT_DECLARED_BYTES`]
//! as doubles, matrices nested at most [`attitude::MAX_MAT_NESTING`] deep, a log at most
//! [`attitude::MAX_SAMPLES`] samples, CSV lines of at most 4 096 bytes. Every filter's step is all
//! or nothing: a non-finite or invalid result is an error ([`FilterError`], or the operators'
//! error through the experiment layer) and the filter is left as it was; counts of particles and
//! cells are checked against the operators' `MAX_ELEMENTS` before anything is allocated. Settings
//! are checked against the range in which every step keeps working, when a filter is made: the
//! attitude EKF's standard deviations in [1e-30, 1e4] (rad, rad/s, m/s, m), the talk filter's
//! direction noises at least 1e-5 and its initial σ in [1.5e-6, π] rad; every azimuth filter's
//! σ₀, σ_m and q in [`azimuth::SETTING_SIGMA_RANGE`] = [1e-49, 1e49] and r₀ within ±1e100 (one
//! range for all six constructors and the scenario's settings); the angle-of-arrival prior's σ₀
//! in [1e-49, 1e6] m ([`aoa::PRIOR_STD_MIN`]); the inertial fix σ and IMU noise densities from
//! 1e-30 ([`inertial::FIX_SIGMA_RANGE`], [`inertial::NOISE_RANGE`]) and its IMU readings by their
//! norm, as the attitude filters'. A positive setting whose square would underflow (a noise
//! density, a gain, a random walk) is refused, naming it; a walk or a gain may also be 0.
#![cfg_attr(docsrs, feature(doc_cfg))]

pub mod aoa;
pub mod attitude;
pub mod azimuth;
mod error;
pub mod inertial;
mod scaled;

pub use error::FilterError;

pub use liebayes_operators as operators;
