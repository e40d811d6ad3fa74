//! [`InertialMethod`]: an inertial filter a study compares, built for an [`InertialScenario`].

use super::estimate::{Convention, NavigationEstimate, ToNavigation};
use super::scenario::{InertialConfig, InertialScenario};
use super::state::{ErrorState, LeftInvariant, NAVIGATION_DIM, NavigationState, RightInvariant};
use super::strapdown::{ImuStep, PositionFix, Strapdown};
use crate::FilterError;
use liebayes_densities::ManifoldGaussian;
use liebayes_experiments::{Recursive, RecursiveFilter};
use liebayes_operators::iterated::IteratedEkf;
use liebayes_operators::{Ekf, OperatorError};
use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;

/// An inertial filter, whatever its convention: IMU steps in, position fixes measured, a
/// [`NavigationEstimate`] out.
pub type InertialFilter = Box<
    dyn RecursiveFilter<Input = ImuStep, Measurement = Vector3<f64>, Estimate = NavigationEstimate>
        + Send,
>;

/// The EKF on the state S with the strapdown process and the position fix, the fix's update `U`
/// (`Ekf<PositionFix, 3>` or `IteratedEkf<PositionFix, 3>`).
pub type InertialEkf<S, U = Ekf<PositionFix, 3>> =
    Recursive<ManifoldGaussian<S, NAVIGATION_DIM>, Ekf<Strapdown>, U, ToNavigation>;

/// How a filter conditions on a position fix.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FixUpdate {
    /// The one-pass EKF update, linearised at the predicted mean.
    OnePass,
    /// The iterated EKF update (Gauss-Newton to the MAP, the covariance transported to it), with
    /// the default settings.
    Iterated,
}

/// The EKF of a convention on a scenario: its models and its prior
/// ([`InertialScenario::prior`]), computed once and cloned into each run's filter.
#[derive(Clone, Debug)]
pub struct InertialMethod {
    convention: Convention,
    update: FixUpdate,
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
    /// The EKF of `convention` for `scenario` with the fix's `update`, assuming the scenario's IMU
    /// noise and fix σ.
    ///
    /// # Errors
    /// When the prior's moments are not a valid covariance.
    pub fn new(
        convention: Convention,
        update: FixUpdate,
        scenario: &InertialScenario,
    ) -> Result<Self, FilterError> {
        let config: &InertialConfig = scenario.config();
        let prior = match convention {
            Convention::ErrorState => Prior::ErrorState(scenario.prior()?),
            Convention::LeftInvariant => Prior::LeftInvariant(scenario.prior()?),
            Convention::RightInvariant => Prior::RightInvariant(scenario.prior()?),
        };
        Ok(Self {
            convention,
            update,
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
        let (process, estimator) = (Ekf(self.process), ToNavigation(self.convention));
        match self.update {
            FixUpdate::OnePass => Box::new(InertialEkf::with_estimator(
                prior,
                process,
                Ekf(self.fix),
                estimator,
            )),
            FixUpdate::Iterated => Box::new(InertialEkf::with_estimator(
                prior,
                process,
                IteratedEkf::<_, 3>::new(self.fix),
                estimator,
            )),
        }
    }
}

impl liebayes_experiments::Method for InertialMethod {
    type Filter = InertialFilter;

    fn label(&self) -> String {
        match self.update {
            FixUpdate::OnePass => self.convention.label().to_owned(),
            FixUpdate::Iterated => format!("{}, iterated fix", self.convention.label()),
        }
    }

    fn validate(&self) -> Result<(), OperatorError> {
        Ok(())
    }

    fn build(&self, _: &mut ChaCha8Rng) -> Result<InertialFilter, OperatorError> {
        Ok(self.filter())
    }
}
