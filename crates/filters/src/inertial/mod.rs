//! Inertial navigation: a strapdown IMU corrected by position fixes, with the biases of the
//! gyroscope and the accelerometer estimated alongside, by the EKF in three conventions for the
//! navigation error.
//!
//! * [`Navigation`], the state by its parts, and [`NavigationState`], a filter's representation of
//!   it: [`ErrorState`] (the error-state EKF: attitude error on the right, additive velocity and
//!   position errors), [`LeftInvariant`] and [`RightInvariant`] (the invariant EKFs: the extended
//!   pose on SE_2(3), [`Se23`](liebayes_manifolds::Se23), with its error on the right or on the
//!   left), each with the biases beside it;
//! * [`Strapdown`], the process driven by [`ImuStep`]s, and [`PositionFix`], written once for every
//!   representation: the conventions differ in their manifold and its first-order error map
//!   ([`NavigationState::navigation_error`]), so the Jacobians are derived once, in closed form, and
//!   the generic [`Ekf`](liebayes_operators::Ekf) linearises each in its own error;
//! * [`InertialScenario`], a manoeuvring vehicle with a biased, noisy IMU and fixes, with the one
//!   initial distribution given to every filter in its own coordinates ([`InertialScenario::prior`]);
//! * [`InertialMethod`] and [`NavigationScorer`], to compare them on the experiment layer (position,
//!   velocity and heading errors, the NEES of the whole state and of the navigation part).
//!
//! The math and the measured consistency are in `docs/filters/inertial.md`.

mod estimate;
mod method;
mod scenario;
mod state;
mod strapdown;

pub use estimate::{Convention, NavigationEstimate, NavigationScorer, ToNavigation};
pub use method::{FixUpdate, InertialEkf, InertialFilter, InertialMethod};
pub use scenario::{InertialConfig, InertialScenario, InertialSteps, InitialVelocity, PRIOR_DRAWS};
pub use state::{
    ErrorState, LeftInvariant, NAVIGATION_DIM, Navigation, NavigationState, RightInvariant,
};
pub use strapdown::{
    FIX_SIGMA_RANGE, GRAVITY, IMU_RATE_RANGE, ImuNoise, ImuStep, MAX_READING, MAX_STEP, MIN_STEP,
    NOISE_RANGE, PositionFix, Strapdown, integrate,
};
