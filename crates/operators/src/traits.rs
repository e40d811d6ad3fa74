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

/// What an in-place conditioning step returns beside the posterior it wrote into the density: the
/// log evidence `ln p(z)` and the algorithm's report (see [`Conditioned`], the by-value form).
#[derive(Clone, Debug, PartialEq)]
pub struct Evidence<R = ()> {
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

    /// [`propagate`](Self::propagate) written into `self`: the form a filter loop calls at every
    /// step. All or nothing: on an error `self` is unchanged. The default replaces `self` by the
    /// by-value result; containers whose by-value step would clone their buffers (the particle set,
    /// the grid) override it to step in place without allocating, and implement the by-value form
    /// as a clone followed by this.
    ///
    /// # Errors
    /// As [`propagate`](Self::propagate).
    fn propagate_in_place(
        &mut self,
        model: &Model,
        input: &Self::Input,
    ) -> Result<(), OperatorError> {
        *self = self.propagate(model, input)?;
        Ok(())
    }
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

    /// [`condition`](Self::condition) written into `self`: `self` becomes `p(x | z)`, and the log
    /// evidence and the report are returned. All or nothing: on an error `self` is unchanged. The
    /// default replaces `self` by the by-value posterior; the particle set and the grid override it
    /// to reweight in place without allocating.
    ///
    /// # Errors
    /// As [`condition`](Self::condition).
    fn condition_in_place(
        &mut self,
        model: &Model,
        z: &Self::Measurement,
    ) -> Result<Evidence<Self::Report>, OperatorError> {
        let Conditioned {
            posterior,
            log_evidence,
            report,
        } = self.condition(model, z)?;
        *self = posterior;
        Ok(Evidence {
            log_evidence,
            report,
        })
    }
}

/// The by-value propagation of a container that steps in place: a clone, propagated in place.
pub(crate) fn propagate_clone<D, M>(
    density: &D,
    model: &M,
    input: &D::Input,
) -> Result<D, OperatorError>
where
    D: Clone + Propagate<M>,
    M: ?Sized,
{
    let mut next = density.clone();
    next.propagate_in_place(model, input)?;
    Ok(next)
}

/// The by-value conditioning of a container that steps in place: a clone, conditioned in place.
pub(crate) fn condition_clone<D, M>(
    density: &D,
    model: &M,
    z: &D::Measurement,
) -> Result<Conditioned<D, D::Report>, OperatorError>
where
    D: Clone + Condition<M>,
    M: ?Sized,
{
    let mut posterior = density.clone();
    let Evidence {
        log_evidence,
        report,
    } = posterior.condition_in_place(model, z)?;
    Ok(Conditioned {
        posterior,
        log_evidence,
        report,
    })
}
