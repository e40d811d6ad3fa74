//! A method: one filter a study compares, by label, checked before any run and built afresh for
//! each run from that run's filter stream.

use crate::filter::RecursiveFilter;
use liebayes_operators::OperatorError;
use rand_chacha::ChaCha8Rng;

/// One filter of an application as a study runs it: its label, a check of its settings made
/// once before any run ([`Study::run_method`](crate::Study::run_method)), and the filter of a
/// run built from that run's filter stream (the particle filters draw their particles from it).
///
/// An application whose methods build different filter types gives [`Method::Filter`] one type
/// for all of them: an enum that implements [`RecursiveFilter`] by dispatch, or a
/// `Box<dyn RecursiveFilter<...> + Send>` (a box of a filter is a filter).
///
/// # Example
/// A heading on SO(2) measured as a unit vector, by a Kalman filter assuming this measurement
/// variance; a negative variance is refused before any run:
/// ```
/// use liebayes_densities::ManifoldGaussian;
/// use liebayes_experiments::{Method, Recursive, RecursiveFilter};
/// use liebayes_manifolds::So2;
/// use liebayes_operators::{Ekf, MeasurementFn, OperatorError, ProcessFn};
/// use nalgebra::{Matrix1, Matrix2, Vector2};
/// use rand_chacha::ChaCha8Rng;
///
/// /// An EKF assuming this measurement variance.
/// struct Assumed(f64);
///
/// impl Method for Assumed {
///     type Filter = Box<
///         dyn RecursiveFilter<
///                 Input = (),
///                 Measurement = Vector2<f64>,
///                 Estimate = ManifoldGaussian<So2<f64>, 1>,
///             > + Send,
///     >;
///
///     fn label(&self) -> String {
///         format!("EKF r = {}", self.0)
///     }
///
///     fn validate(&self) -> Result<(), OperatorError> {
///         if self.0 > 0.0 {
///             Ok(())
///         } else {
///             let range = "(0, inf)";
///             Err(OperatorError::OutOfRange { what: "variance", value: self.0, range })
///         }
///     }
///
///     fn build(&self, _: &mut ChaCha8Rng) -> Result<Self::Filter, OperatorError> {
///         let r = self.0;
///         let process = ProcessFn::new(|x: &So2<f64>, (): &()| *x, |_, ()| Matrix1::new(1e-3));
///         let measurement = MeasurementFn::new(
///             |x: &So2<f64>| Vector2::new(x.angle().cos(), x.angle().sin()),
///             move |_| Matrix2::identity() * r,
///         );
///         let prior = ManifoldGaussian::new(So2::from_angle_unchecked(0.0), Matrix1::new(0.1))
///             .map_err(OperatorError::from)?;
///         Ok(Box::new(Recursive::new(prior, Ekf(process), Ekf(measurement))))
///     }
/// }
///
/// let mut rng = liebayes_experiments::run_rngs(0, 0).1;
/// assert!(Assumed(-1.0).validate().is_err());
/// let mut filter = Assumed(0.01).build(&mut rng)?;
/// filter.predict(&())?;
/// filter.update(&Vector2::new(1.0, 0.1))?;
/// # Ok::<(), OperatorError>(())
/// ```
pub trait Method {
    /// The filter it builds.
    type Filter: RecursiveFilter;

    /// A short label for tables and summaries (`EKF`, `PF 1000`).
    fn label(&self) -> String;

    /// Checks its settings (a particle count, a grid size) before any run allocates them.
    ///
    /// # Errors
    /// What is wrong with the settings.
    fn validate(&self) -> Result<(), OperatorError>;

    /// The filter of one run, from that run's filter stream.
    ///
    /// # Errors
    /// When the filter cannot be built; a study counts the run as failed under this reason.
    fn build(&self, rng: &mut ChaCha8Rng) -> Result<Self::Filter, OperatorError>;
}
