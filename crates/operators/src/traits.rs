//! The two Bayesian operations.

use crate::OperatorError;

/// The result of conditioning: the posterior density and the log evidence `ln p(z)` of the measurement
/// under the prior (the log marginal likelihood, a density value in the measurement's units).
#[derive(Clone, Debug, PartialEq)]
pub struct Conditioned<D> {
    /// `p(x | z)`.
    pub posterior: D,
    /// `ln p(z) = ln ∫ p(z | x) p(x) dx`.
    pub log_evidence: f64,
}

/// Chapman-Kolmogorov: the density of the state after the process `Model` acts with an input.
pub trait Propagate<Model: ?Sized>: Sized {
    /// What drives the process besides the state (a control, a measured velocity and a time step …).
    type Input: ?Sized;

    /// `p(x′) = ∫ p(x′ | x, u) p(x) dx`.
    ///
    /// # Errors
    /// When the model or the input is invalid (non-finite, out of range) or the result is not a valid
    /// density.
    fn propagate(&self, model: &Model, input: &Self::Input) -> Result<Self, OperatorError>;
}

/// Bayes: the density of the state given a measurement under the measurement `Model`.
pub trait Condition<Model: ?Sized>: Sized {
    /// The measurement's type.
    type Measurement: ?Sized;

    /// `p(x | z) = p(z | x) p(x) / p(z)`, with `ln p(z)`.
    ///
    /// # Errors
    /// When the model or the measurement is invalid or the posterior is not a valid density.
    fn condition(
        &self,
        model: &Model,
        z: &Self::Measurement,
    ) -> Result<Conditioned<Self>, OperatorError>;
}
