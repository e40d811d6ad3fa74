//! [`InertialMethod`]: an inertial filter a study compares, built for an [`InertialScenario`].

use super::estimate::{Convention, NavigationEstimate, ToNavigation};
use super::scenario::{InertialConfig, InertialScenario};
use super::state::{ErrorState, LeftInvariant, NAVIGATION_DIM, NavigationState, RightInvariant};
use super::strapdown::{ImuStep, PositionFix, Strapdown};
use crate::FilterError;
use liebayes_densities::ManifoldGaussian;
use liebayes_experiments::{Recursive, RecursiveFilter};
use liebayes_operators::{Ekf, OperatorError};
use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;

/// An inertial filter, whatever its convention: IMU steps in, position fixes measured, a
/// [`NavigationEstimate`] out.
pub type InertialFilter = Box<
    dyn RecursiveFilter<Input = ImuStep, Measurement = Vector3<f64>, Estimate = NavigationEstimate>
        + Send,
>;

/// The EKF on the state S with the strapdown process and the position fix.
pub type InertialEkf<S> = Recursive<
    ManifoldGaussian<S, NAVIGATION_DIM>,
    Ekf<Strapdown>,
    Ekf<PositionFix, 3>,
    ToNavigation,
>;

/// The EKF of a convention on a scenario: its models and its prior
/// ([`InertialScenario::prior`]), computed once and cloned into each run's filter.
#[derive(Clone, Debug)]
pub struct InertialMethod {
    convention: Convention,
    process: Strapdown,
    fix: PositionFix,
    prior: Prior,
}

/// A prior in one convention's state.
#[derive(Clone, Debug)]
enum Prior {
    ErrorState(ManifoldGaussian<ErrorState, NAVIGATION_DIM>),
    LeftInvariant(ManifoldGaussian<LeftInvariant, NAVIGATION_DIM>),
    RightInvariant(ManifoldGaussian<RightInvariant, NAVIGATION_DIM>),
}

impl InertialMethod {
    /// The EKF of `convention` for `scenario`, assuming the scenario's IMU noise and fix σ.
    ///
    /// # Errors
    /// When the prior's moments are not a valid covariance.
    pub fn new(convention: Convention, scenario: &InertialScenario) -> Result<Self, FilterError> {
        let config: &InertialConfig = scenario.config();
        let prior = match convention {
            Convention::ErrorState => Prior::ErrorState(scenario.prior()?),
            Convention::LeftInvariant => Prior::LeftInvariant(scenario.prior()?),
            Convention::RightInvariant => Prior::RightInvariant(scenario.prior()?),
        };
        Ok(Self {
            convention,
            process: Strapdown::new(config.imu)?,
            fix: PositionFix::new(config.fix_sigma)?,
            prior,
        })
    }

    /// The filter, ready to run.
    pub fn filter(&self) -> InertialFilter {
        match &self.prior {
            Prior::ErrorState(prior) => self.boxed(prior.clone()),
            Prior::LeftInvariant(prior) => self.boxed(prior.clone()),
            Prior::RightInvariant(prior) => self.boxed(prior.clone()),
        }
    }

    /// The EKF on S from `prior`, boxed.
    fn boxed<S: NavigationState + 'static>(
        &self,
        prior: ManifoldGaussian<S, NAVIGATION_DIM>,
    ) -> InertialFilter {
        Box::new(InertialEkf::with_estimator(
            prior,
            Ekf(self.process),
            Ekf(self.fix),
            ToNavigation(self.convention),
        ))
    }
}

impl liebayes_experiments::Method for InertialMethod {
    type Filter = InertialFilter;

    fn label(&self) -> String {
        self.convention.label().to_owned()
    }

    fn validate(&self) -> Result<(), OperatorError> {
        Ok(())
    }

    fn build(&self, _: &mut ChaCha8Rng) -> Result<InertialFilter, OperatorError> {
        Ok(self.filter())
    }
}
