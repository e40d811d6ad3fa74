//! The one interface every filter of a study implements: predict with an input, update with a
//! measurement (returning its log evidence and, where the algorithm has it, the NIS), and an
//! estimate with its uncertainty.
//!
//! Densities that step through the operator traits reach it through [`Recursive`], which holds a
//! density with its process and measurement models and steps it with
//! [`Propagate`] and [`Condition`]: no second stepping API.

use liebayes_densities::{Gaussian, ManifoldGaussian};
use liebayes_manifolds::Manifold;
use liebayes_operators::{Condition, Innovation, OperatorError, Propagate};

/// The normalised innovation squared of one update, with its degrees of freedom (the measurement's
/// dimension): χ² with `dof` degrees of freedom for a consistent filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nis {
    /// `νᵀ S⁻¹ ν`.
    pub value: f64,
    /// The measurement dimension M.
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
            dof: M,
        })
    }
}

/// A density's point estimate with its uncertainty, as a study scores it.
pub trait PointEstimate {
    /// The estimate's type.
    type Estimate;

    /// The estimate.
    ///
    /// # Errors
    /// When the density has no representable estimate.
    fn point_estimate(&self) -> Result<Self::Estimate, OperatorError>;
}

impl<X: Manifold<D, Scalar = f64> + Clone, const D: usize> PointEstimate
    for ManifoldGaussian<X, D>
{
    type Estimate = Self;

    /// The Gaussian itself: mean on the manifold, covariance in its tangent space.
    fn point_estimate(&self) -> Result<Self, OperatorError> {
        Ok(self.clone())
    }
}

impl<const N: usize> PointEstimate for Gaussian<N> {
    type Estimate = Self;

    /// The Gaussian itself.
    fn point_estimate(&self) -> Result<Self, OperatorError> {
        Ok(self.clone())
    }
}

/// A density with its process model `P` and measurement model `M`, stepped by the operator traits:
/// `predict` is [`Propagate::propagate`], `update` is [`Condition::condition`].
#[derive(Clone, Debug, PartialEq)]
pub struct Recursive<Density, P, M> {
    density: Density,
    process: P,
    measurement: M,
}

impl<Density, P, M> Recursive<Density, P, M> {
    /// The filter starting from the prior `density`.
    pub fn new(density: Density, process: P, measurement: M) -> Self {
        Self {
            density,
            process,
            measurement,
        }
    }

    /// The current density.
    pub fn density(&self) -> &Density {
        &self.density
    }
}

impl<Density, P, M> RecursiveFilter for Recursive<Density, P, M>
where
    Density: Propagate<P> + Condition<M> + PointEstimate,
    <Density as Condition<M>>::Report: StepReport,
{
    type Input = <Density as Propagate<P>>::Input;
    type Measurement = <Density as Condition<M>>::Measurement;
    type Estimate = <Density as PointEstimate>::Estimate;

    fn predict(&mut self, input: &Self::Input) -> Result<(), OperatorError> {
        self.density = self.density.propagate(&self.process, input)?;
        Ok(())
    }

    fn update(&mut self, z: &Self::Measurement) -> Result<Update, OperatorError> {
        let step = self.density.condition(&self.measurement, z)?;
        let update = Update {
            log_evidence: step.log_evidence,
            nis: step.report.nis(),
        };
        self.density = step.posterior;
        Ok(update)
    }

    fn estimate(&self) -> Result<Self::Estimate, OperatorError> {
        self.density.point_estimate()
    }
}
