//! The one interface every filter of a study implements: predict with an input, update with a
//! measurement (returning its log evidence and, where the algorithm has it, the NIS), and an
//! estimate with its uncertainty.
//!
//! Densities that step through the operator traits reach it through [`Recursive`], which holds a
//! density with its process and measurement models and steps it with
//! [`Propagate`] and [`Condition`]: no second stepping API.

use crate::Smoothing;
use liebayes_operators::iterated::Iterated;
use liebayes_operators::{Condition, Innovation, OperatorError, Propagate};

/// The normalised innovation squared of one update, with its degrees of freedom (the measurement's
/// dimension): χ² with `dof` degrees of freedom for a consistent filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nis {
    /// `νᵀ S⁻¹ ν`.
    pub value: f64,
    /// Its degrees of freedom: the dimension of the measurement's manifold
    /// ([`Innovation::dof`]).
    pub dof: usize,
}

/// What an update reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Update {
    /// `ln p(z)` under the predicted density.
    pub log_evidence: f64,
    /// The NIS, where the algorithm computes an innovation covariance (the Kalman filters).
    pub nis: Option<Nis>,
}

/// A recursive Bayesian filter as a study drives it. Every step is all or nothing: on an error the
/// filter is as it was.
pub trait RecursiveFilter {
    /// What drives the process (a control, a measured rate and a time step …).
    type Input: ?Sized;
    /// A measurement.
    type Measurement: ?Sized;
    /// The estimate with its uncertainty (for the Gaussian filters, the density itself).
    type Estimate;

    /// Propagates over one step.
    ///
    /// # Errors
    /// When the step fails (the filter's state is then unchanged).
    fn predict(&mut self, input: &Self::Input) -> Result<(), OperatorError>;

    /// Conditions on a measurement.
    ///
    /// # Errors
    /// When the step fails (the filter's state is then unchanged).
    fn update(&mut self, z: &Self::Measurement) -> Result<Update, OperatorError>;

    /// The current estimate.
    ///
    /// # Errors
    /// When the state has no representable estimate (for example a covariance that is not
    /// positive definite).
    fn estimate(&self) -> Result<Self::Estimate, OperatorError>;

    /// For a smoother, its [`Smoothing`]: the layer then also scores each step's smoothed
    /// estimate (see [`Smoothed`](crate::Smoothed)). `None`, the default, for a filter.
    fn smoothing(&mut self) -> Option<&mut dyn Smoothing<Estimate = Self::Estimate>> {
        None
    }
}

/// A boxed filter is a filter: an application whose methods build different filter types can
/// give a [`Method`](crate::Method) one filter type, `Box<dyn RecursiveFilter<...> + Send>`.
impl<F: RecursiveFilter + ?Sized> RecursiveFilter for Box<F> {
    type Input = F::Input;
    type Measurement = F::Measurement;
    type Estimate = F::Estimate;

    fn predict(&mut self, input: &Self::Input) -> Result<(), OperatorError> {
        (**self).predict(input)
    }

    fn update(&mut self, z: &Self::Measurement) -> Result<Update, OperatorError> {
        (**self).update(z)
    }

    fn estimate(&self) -> Result<Self::Estimate, OperatorError> {
        (**self).estimate()
    }

    fn smoothing(&mut self) -> Option<&mut dyn Smoothing<Estimate = Self::Estimate>> {
        (**self).smoothing()
    }
}

/// What a conditioning step's report says about consistency: the NIS where there is one.
pub trait StepReport {
    /// The NIS of the update, if the algorithm has an innovation covariance.
    fn nis(&self) -> Option<Nis>;
}

impl StepReport for () {
    fn nis(&self) -> Option<Nis> {
        None
    }
}

impl<const N: usize, const M: usize> StepReport for Innovation<N, M> {
    fn nis(&self) -> Option<Nis> {
        Some(Nis {
            value: Innovation::nis(self),
            dof: self.dof(),
        })
    }
}

/// The NIS of an iterated update's final linearisation.
impl<const N: usize, const M: usize> StepReport for Iterated<N, M> {
    fn nis(&self) -> Option<Nis> {
        StepReport::nis(self.innovation())
    }
}

/// How a filter's density becomes the estimate a study scores: the density itself for a Gaussian
/// ([`AsIs`]), or the moments an application reads off a particle set or a grid (its own type
/// implementing this trait for each density it uses).
pub trait Estimator<Density> {
    /// The estimate's type.
    type Estimate;

    /// The estimate of `density`.
    ///
    /// # Errors
    /// When the density has no representable estimate (a moment that overflows).
    fn estimate(&self, density: &Density) -> Result<Self::Estimate, OperatorError>;
}

/// The density is its own estimate (a Gaussian: its mean and covariance; any density, to inspect
/// it after each update).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct AsIs;

impl<D: Clone> Estimator<D> for AsIs {
    type Estimate = D;

    fn estimate(&self, density: &D) -> Result<D, OperatorError> {
        Ok(density.clone())
    }
}

/// A density with its process model `P`, its measurement model `M` and its [`Estimator`] `E`,
/// stepped by the operator traits: `predict` is [`Propagate::propagate_in_place`], `update` is
/// [`Condition::condition_in_place`] (particle sets and grids step without copying their buffers).
///
/// # Checkpoints
/// With the `serde` feature a `Recursive` serializes as its four parts,
/// `{"density": …, "process": …, "measurement": …, "estimator": …}`, where each part is serde
/// (the densities and the linear models are, each read back through its validated
/// constructor). Models that are closures (`ProcessFn`, `MeasurementFn`) or borrowed
/// (`Ekf(&model)`) are not: checkpoint the [`density`](Self::density) alone, and resume with
/// [`Recursive::with_estimator`] from the density read back and the models built again in code.
/// Either way the resumed filter continues the run bit for bit (the tests check it).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Recursive<Density, P, M, E = AsIs> {
    density: Density,
    process: P,
    measurement: M,
    estimator: E,
}

impl<Density, P, M> Recursive<Density, P, M> {
    /// The filter starting from the prior `density`, its own estimate ([`AsIs`]).
    pub fn new(density: Density, process: P, measurement: M) -> Self {
        Self::with_estimator(density, process, measurement, AsIs)
    }
}

impl<Density, P, M, E> Recursive<Density, P, M, E> {
    /// The filter starting from the prior `density`, estimated by `estimator`.
    pub fn with_estimator(density: Density, process: P, measurement: M, estimator: E) -> Self {
        Self {
            density,
            process,
            measurement,
            estimator,
        }
    }

    /// The same filter with another estimator (to inspect the density itself, say: `AsIs`).
    pub fn estimated_by<E2>(self, estimator: E2) -> Recursive<Density, P, M, E2> {
        Recursive::with_estimator(self.density, self.process, self.measurement, estimator)
    }

    /// The current density.
    pub fn density(&self) -> &Density {
        &self.density
    }

    /// The process model.
    pub fn process(&self) -> &P {
        &self.process
    }

    /// The measurement model.
    pub fn measurement(&self) -> &M {
        &self.measurement
    }
}

impl<Density, P, M, E> RecursiveFilter for Recursive<Density, P, M, E>
where
    Density: Propagate<P> + Condition<M>,
    <Density as Condition<M>>::Report: StepReport,
    E: Estimator<Density>,
{
    type Input = <Density as Propagate<P>>::Input;
    type Measurement = <Density as Condition<M>>::Measurement;
    type Estimate = E::Estimate;

    fn predict(&mut self, input: &Self::Input) -> Result<(), OperatorError> {
        self.density.propagate_in_place(&self.process, input)
    }

    fn update(&mut self, z: &Self::Measurement) -> Result<Update, OperatorError> {
        let step = self.density.condition_in_place(&self.measurement, z)?;
        Ok(Update {
            log_evidence: step.log_evidence,
            nis: step.report.nis(),
        })
    }

    fn estimate(&self) -> Result<Self::Estimate, OperatorError> {
        self.estimator.estimate(&self.density)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use liebayes_densities::ManifoldGaussian;
    use liebayes_manifolds::Rn;
    use liebayes_operators::iterated::IteratedEkf;
    use liebayes_operators::{Ekf, MeasurementFn, ProcessFn};
    use nalgebra::{Matrix1, Vector1};

    /// An iterated update drives `Recursive` as the one-pass EKF does, and reports the NIS of its
    /// final linearisation: on a linear model both give the same NIS and log evidence.
    #[test]
    fn iterated_updates_report_their_nis() {
        let process = ProcessFn::new(|x: &Rn<f64, 1>, (): &()| *x, |_, ()| Matrix1::new(0.1))
            .with_jacobian(|_: &Rn<f64, 1>, (): &()| Matrix1::new(1.0));
        let sensor = MeasurementFn::new(
            |x: &Rn<f64, 1>| Vector1::new(2.0 * x.coords()[0]),
            |_: &Rn<f64, 1>| Matrix1::new(0.5),
        )
        .with_jacobian(|_: &Rn<f64, 1>| Matrix1::new(2.0));
        let prior =
            ManifoldGaussian::new(Rn::new_unchecked(Vector1::new(1.0)), Matrix1::new(2.0)).unwrap();
        let z = Vector1::new(4.0);
        let mut iterated = Recursive::new(prior.clone(), Ekf(&process), IteratedEkf::new(&sensor));
        let mut one_pass = Recursive::new(prior, Ekf(&process), Ekf(&sensor));
        iterated.predict(&()).unwrap();
        one_pass.predict(&()).unwrap();
        let (a, b) = (iterated.update(&z).unwrap(), one_pass.update(&z).unwrap());
        let (nis_a, nis_b) = (a.nis.unwrap(), b.nis.unwrap());
        assert_eq!((nis_a.dof, nis_b.dof), (1, 1));
        // ν = 4 − 2, S = 4 · 2.1 + 0.5: NIS = 4 / 8.9.
        assert!((nis_a.value - 4.0 / 8.9).abs() < 1e-12, "{}", nis_a.value);
        assert!((nis_a.value - nis_b.value).abs() < 1e-12);
        assert!((a.log_evidence - b.log_evidence).abs() < 1e-12);
    }
}
