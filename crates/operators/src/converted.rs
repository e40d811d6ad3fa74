//! [`Converted`]: a measurement model whose readings arrive in another form than the one its
//! conditioning step takes, converted once per step.
//!
//! Filters that share one data stream but model it differently need this: an angle-of-arrival
//! receiver reports an azimuth and an elevation per anchor, which an EKF with a unit-vector model
//! stacks as unit vectors, one with an azimuth-elevation model as angles, and a particle filter
//! rotates into world axes once per update rather than once per particle. The conversion is checked
//! (a reading it cannot convert is an error, and the density is untouched) and runs before the
//! step, so a particle set or a grid still conditions in place without allocating.

use crate::{Condition, Conditioned, Evidence, OperatorError};

/// How a reading becomes the measurement a model's step takes.
pub trait Conversion {
    /// The reading, as the sensor gives it.
    type Reading: ?Sized;
    /// The measurement the model conditions on.
    type Measurement;

    /// The measurement of `reading`.
    ///
    /// # Errors
    /// When the reading is not one the model can use (non-finite, out of range), saying why.
    fn convert(&self, reading: &Self::Reading) -> Result<Self::Measurement, OperatorError>;
}

/// The model `model` conditioned on readings converted by `conversion`:
/// `density.condition(&Converted { model, conversion }, &reading)` is
/// `density.condition(&model, &conversion.convert(&reading)?)`.
///
/// # Example
/// A Kalman filter on a position measured in centimetres:
/// ```
/// use liebayes_operators::converted::{Conversion, Converted};
/// use liebayes_operators::densities::ManifoldGaussian;
/// use liebayes_operators::manifolds::Rn;
/// use liebayes_operators::{Condition, Ekf, MeasurementFn, OperatorError};
/// use nalgebra::{Matrix1, Vector1};
///
/// struct Centimetres;
/// impl Conversion for Centimetres {
///     type Reading = f64;
///     type Measurement = Vector1<f64>;
///     fn convert(&self, cm: &f64) -> Result<Vector1<f64>, OperatorError> {
///         Ok(Vector1::new(cm / 100.0))
///     }
/// }
///
/// let position = MeasurementFn::new(|x: &Rn<f64, 1>| *x.coords(), |_| Matrix1::new(1.0));
/// let model = Converted { model: Ekf(position), conversion: Centimetres };
/// let prior = ManifoldGaussian::new(Rn::new(Vector1::new(0.0))?, Matrix1::new(1.0))?;
/// let posterior = prior.condition(&model, &200.0)?.posterior;
/// assert!((posterior.mean().coords()[0] - 1.0).abs() < 1e-12);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Converted<Model, C> {
    /// The model the converted measurement is conditioned on.
    pub model: Model,
    /// How a reading becomes its measurement.
    pub conversion: C,
}

/// The step of a [`Converted`] model: convert, then condition on the inner model (in place when
/// the density steps in place). Written for each inner model kind, not as a blanket impl over
/// every model (which would recurse through `Converted<Converted<…>>` and defeat type inference).
macro_rules! impl_converted {
    ($density:ty, $inner:ty, [$($generics:tt)*], [$($bounds:tt)*]) => {
        impl<C, $($generics)*> Condition<Converted<$inner, C>> for $density
        where
            C: Conversion,
            $density: Condition<$inner, Measurement = C::Measurement>,
            $($bounds)*
        {
            type Measurement = C::Reading;
            type Report = <$density as Condition<$inner>>::Report;

            /// # Errors
            /// The conversion's error, or the model's step's.
            fn condition(
                &self,
                model: &Converted<$inner, C>,
                reading: &C::Reading,
            ) -> Result<Conditioned<Self, Self::Report>, OperatorError> {
                let z = model.conversion.convert(reading)?;
                self.condition(&model.model, &z)
            }

            /// # Errors
            /// The conversion's error (the density untouched), or the model's step's.
            fn condition_in_place(
                &mut self,
                model: &Converted<$inner, C>,
                reading: &C::Reading,
            ) -> Result<Evidence<Self::Report>, OperatorError> {
                let z = model.conversion.convert(reading)?;
                self.condition_in_place(&model.model, &z)
            }
        }
    };
}

impl_converted!(
    liebayes_densities::ManifoldGaussian<X, D>,
    crate::Ekf<H, M>,
    [X, H, const D: usize, const M: usize],
    [X: liebayes_manifolds::Manifold<D, Scalar = f64>]
);
impl_converted!(
    liebayes_densities::ManifoldGaussian<X, D>,
    crate::Ukf<H, M>,
    [X, H, const D: usize, const M: usize],
    [X: liebayes_manifolds::Manifold<D, Scalar = f64>]
);
impl_converted!(
    liebayes_densities::ManifoldGaussian<X, D>,
    crate::iterated::IteratedEkf<H, M>,
    [X, H, const D: usize, const M: usize],
    [X: liebayes_manifolds::Manifold<D, Scalar = f64>]
);
impl_converted!(
    liebayes_densities::ManifoldGaussian<X, D>,
    crate::iterated::IteratedUkf<H, M>,
    [X, H, const D: usize, const M: usize],
    [X: liebayes_manifolds::Manifold<D, Scalar = f64>]
);
impl_converted!(
    crate::particle::ParticleSet<X>,
    crate::particle::Reweight<L>,
    [X, L],
    []
);
#[cfg(feature = "rayon")]
impl_converted!(
    crate::particle::ParticleSet<X>,
    crate::particle::ReweightInParallel<L>,
    [X, L],
    []
);
