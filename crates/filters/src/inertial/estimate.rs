//! [`NavigationEstimate`], what every inertial filter reports whatever its state's convention, and
//! [`NavigationScorer`], which scores it against the truth in that convention.

use super::state::{
    ErrorState, LeftInvariant, NAVIGATION_DIM, Navigation, NavigationState, RightInvariant,
};
use liebayes_densities::ManifoldGaussian;
use liebayes_experiments::{Estimator, Metric, Reduction, Scorer};
use liebayes_manifolds::LieGroup;
use liebayes_operators::OperatorError;
use nalgebra::{Cholesky, SMatrix, SVector};

/// How a filter defines its navigation error (its state's manifold), in the order the docs compare
/// them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Convention {
    /// The error-state EKF ([`ErrorState`]): attitude error on the right, additive velocity and
    /// position errors.
    ErrorState,
    /// The left-invariant EKF ([`LeftInvariant`]): the error `X̂⁻¹ X` on SE_2(3), in the body frame.
    LeftInvariant,
    /// The right-invariant EKF ([`RightInvariant`]): the error `X X̂⁻¹` on SE_2(3), in the world
    /// frame.
    RightInvariant,
}

impl Convention {
    /// Every convention.
    pub const ALL: [Self; 3] = [Self::ErrorState, Self::LeftInvariant, Self::RightInvariant];

    /// A short label for tables.
    pub fn label(self) -> &'static str {
        match self {
            Self::ErrorState => "error-state EKF",
            Self::LeftInvariant => "left-invariant EKF",
            Self::RightInvariant => "right-invariant EKF",
        }
    }

    /// The error `x̂ ⊟ x` of the truth x seen from the estimate x̂, in this convention.
    pub fn error(self, estimate: &Navigation, truth: &Navigation) -> SVector<f64, NAVIGATION_DIM> {
        match self {
            Self::ErrorState => error_in::<ErrorState>(estimate, truth),
            Self::LeftInvariant => error_in::<LeftInvariant>(estimate, truth),
            Self::RightInvariant => error_in::<RightInvariant>(estimate, truth),
        }
    }
}

/// `x̂ ⊟ x` on the state S.
fn error_in<S: NavigationState>(
    estimate: &Navigation,
    truth: &Navigation,
) -> SVector<f64, NAVIGATION_DIM> {
    S::from_navigation(estimate).local(&S::from_navigation(truth))
}

/// A filter's estimate: the navigation state, the covariance of its error and the convention that
/// error is defined in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavigationEstimate {
    /// The mean, as its parts.
    pub navigation: Navigation,
    /// The covariance of the error `x̂ ⊟ x`, in the convention's tangent coordinates.
    pub covariance: SMatrix<f64, NAVIGATION_DIM, NAVIGATION_DIM>,
    /// The convention.
    pub convention: Convention,
}

/// The estimator that reads a filter's Gaussian as a [`NavigationEstimate`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ToNavigation(pub Convention);

impl<S: NavigationState> Estimator<ManifoldGaussian<S, NAVIGATION_DIM>> for ToNavigation {
    type Estimate = NavigationEstimate;

    fn estimate(
        &self,
        density: &ManifoldGaussian<S, NAVIGATION_DIM>,
    ) -> Result<NavigationEstimate, OperatorError> {
        Ok(NavigationEstimate {
            navigation: density.mean().navigation(),
            covariance: *density.covariance(),
            convention: self.0,
        })
    }
}

/// The scores of a [`NavigationEstimate`]: `position_error` (m) and `velocity_error` (m/s), the
/// absolute `heading_error` (deg, about the world's vertical), and the NEES of the whole error (15
/// degrees of freedom, `nees`) and of the attitude, velocity and position errors alone (their
/// marginal, 9, `nees_navigation`), each in the estimate's own convention.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NavigationScorer;

impl Scorer<Navigation, NavigationEstimate> for NavigationScorer {
    fn metrics(&self) -> Vec<Metric> {
        vec![
            Metric::new("position_error", Reduction::RootMeanSquare, "m"),
            Metric::new("velocity_error", Reduction::RootMeanSquare, "m/s"),
            Metric::new("heading_error", Reduction::RootMeanSquare, "deg"),
            Metric::new(
                "nees",
                Reduction::ChiSquare {
                    dof: NAVIGATION_DIM,
                },
                "",
            ),
            Metric::new("nees_navigation", Reduction::ChiSquare { dof: 9 }, ""),
        ]
    }

    fn score(&self, truth: &Navigation, estimate: &NavigationEstimate, values: &mut [f64]) {
        let mean = &estimate.navigation;
        values[0] = (mean.position - truth.position).norm();
        values[1] = (mean.velocity - truth.velocity).norm();
        let world_error = truth.rotation.compose(&mean.rotation.inverse()).to_matrix();
        values[2] = world_error[(1, 0)]
            .atan2(world_error[(0, 0)])
            .abs()
            .to_degrees();
        let e = estimate.convention.error(mean, truth);
        values[3] = mahalanobis(&estimate.covariance, &e);
        values[4] = mahalanobis(
            &estimate.covariance.fixed_view::<9, 9>(0, 0).into_owned(),
            &e.fixed_rows::<9>(0).into_owned(),
        );
    }
}

/// `eᵀ P⁻¹ e` by the Cholesky factor of P; NaN if P is not positive definite.
fn mahalanobis<const N: usize>(p: &SMatrix<f64, N, N>, e: &SVector<f64, N>) -> f64 {
    Cholesky::new(*p).map_or(f64::NAN, |c| {
        c.l()
            .solve_lower_triangular(e)
            .map_or(f64::NAN, |y| y.norm_squared())
    })
}
