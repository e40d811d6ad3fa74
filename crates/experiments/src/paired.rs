//! Two filters on the same data, stepped together: to compare an approximation with a reference
//! at every epoch (its estimate holds both estimates and both running log evidences).

use crate::filter::{RecursiveFilter, Update};
use liebayes_operators::OperatorError;

/// Two filters driven by the same inputs and measurements. A scorer of [`PairedEstimate`]s
/// compares them at every epoch of a replay (the per-epoch difference of their estimates, of
/// their log evidence).
///
/// Every step is all or nothing, as the trait demands: the first filter is copied before each
/// step and restored if the second fails, so a pair costs a clone of the first filter per step:
/// a tool for comparisons and tests, not for production loops.
#[derive(Clone, Debug, PartialEq)]
pub struct Paired<A, B> {
    first: A,
    second: B,
    log_evidence: [f64; 2],
}

/// The estimates of a [`Paired`] filter after an update.
#[derive(Clone, Debug, PartialEq)]
pub struct PairedEstimate<EA, EB> {
    /// The first filter's estimate.
    pub first: EA,
    /// The second filter's estimate.
    pub second: EB,
    /// Each filter's `ln p(z₁..ₖ)`, the sum of its updates' log evidence so far: −∞ once that
    /// exact sum is below −f64::MAX (measurements each some 1e153 standard deviations from their
    /// prediction), as the sum is; every update's own evidence is finite.
    pub log_evidence: [f64; 2],
}

impl<A, B> Paired<A, B> {
    /// The two filters, from their priors.
    pub fn new(first: A, second: B) -> Self {
        Self {
            first,
            second,
            log_evidence: [0.0; 2],
        }
    }

    /// The first filter.
    pub fn first(&self) -> &A {
        &self.first
    }

    /// The second filter.
    pub fn second(&self) -> &B {
        &self.second
    }
}

impl<A, B> RecursiveFilter for Paired<A, B>
where
    A: RecursiveFilter + Clone,
    B: RecursiveFilter<Input = A::Input, Measurement = A::Measurement>,
{
    type Input = A::Input;
    type Measurement = A::Measurement;
    type Estimate = PairedEstimate<A::Estimate, B::Estimate>;

    fn predict(&mut self, input: &Self::Input) -> Result<(), OperatorError> {
        let saved = self.first.clone();
        self.first.predict(input)?;
        self.second
            .predict(input)
            .inspect_err(|_| self.first = saved)
    }

    /// Both updates; the first filter's log evidence and NIS are the pair's.
    fn update(&mut self, z: &Self::Measurement) -> Result<Update, OperatorError> {
        let saved = self.first.clone();
        let first = self.first.update(z)?;
        let second = self.second.update(z).inspect_err(|_| self.first = saved)?;
        self.log_evidence[0] += first.log_evidence;
        self.log_evidence[1] += second.log_evidence;
        Ok(first)
    }

    fn estimate(&self) -> Result<Self::Estimate, OperatorError> {
        Ok(PairedEstimate {
            first: self.first.estimate()?,
            second: self.second.estimate()?,
            log_evidence: self.log_evidence,
        })
    }
}
