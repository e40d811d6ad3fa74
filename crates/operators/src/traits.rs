//! The two Bayesian operations.

use crate::OperatorError;

/// The result of conditioning: the posterior density, the log evidence `ln p(z)` of the measurement
/// under the prior (the log marginal likelihood, a density value in the measurement's units), and
/// what else the algorithm computed on the way (its [`Condition::Report`]).
///
/// The report is where a step gives what a user checks a filter with: the Kalman filters (linear,
/// extended, unscented) report their [`Innovation`](crate::Innovation) (ν, S, K and the NIS); steps
/// without such quantities (particles, grids, the exact composites) report `()`.
#[derive(Clone, Debug, PartialEq)]
pub struct Conditioned<D, R = ()> {
    /// `p(x | z)`.
    pub posterior: D,
    /// `ln p(z) = ln ∫ p(z | x) p(x) dx`.
    pub log_evidence: f64,
    /// The algorithm's by-products (see [`Condition::Report`]).
    pub report: R,
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

    /// What the step reports besides the posterior and the log evidence: an
    /// [`Innovation`](crate::Innovation) for the Kalman filters, `()` where the algorithm has nothing
    /// more to say.
    type Report;

    /// `p(x | z) = p(z | x) p(x) / p(z)`, with `ln p(z)` and the report. All or nothing: on an error
    /// nothing has changed (the method takes `&self`), and no partial result is returned.
    ///
    /// # Errors
    /// When the model or the measurement is invalid or the posterior is not a valid density.
    fn condition(
        &self,
        model: &Model,
        z: &Self::Measurement,
    ) -> Result<Conditioned<Self, Self::Report>, OperatorError>;
}
