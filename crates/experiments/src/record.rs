//! The recorder: a replay that keeps every step's estimate (what filterpy's `Saver` keeps), for
//! evaluations that score a whole recorded log, plot a run, or write its estimates to a file.

use crate::MAX_EPOCHS;
use crate::filter::{RecursiveFilter, Update};
use crate::replay::{RunFailure, Step};
use crate::smoothing::Releases;
use liebayes_operators::OperatorError;
use std::time::Instant;

/// One step of a [`Recording`]: its time and truth as the steps gave them, the estimate after the
/// step (after its update, where it had a measurement) and what the update reported (a smoother's
/// smoothed estimates are kept apart, in [`Recording::smoothed`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Recorded<T, E> {
    /// Time (s) at the end of the step.
    pub time: f64,
    /// The step's truth (for a recorded log without ground truth, the unit type or an `Option`).
    pub truth: T,
    /// The filter's estimate after the step.
    pub estimate: E,
    /// The update's report, `None` for a step without a measurement.
    pub update: Option<Update>,
}

/// Every step of a run, in order, with the filter's time.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording<T, E> {
    /// The steps.
    pub steps: Vec<Recorded<T, E>>,
    /// For a smoother ([`RecursiveFilter::smoothing`]), `smoothed[k]` is step k's smoothed estimate
    /// as it released it (from the whole run for the RTS smoother, from the L steps after it for
    /// the fixed-lag one): one per step at the end of a run. Empty for a filter, so that a filter's
    /// recording does not carry a second estimate per step.
    pub smoothed: Vec<E>,
    /// Wall-clock time of the filter's steps and estimates (s), the steps' drawing excluded.
    pub seconds: f64,
}

impl<T, E> Recording<T, E> {
    /// The number of steps recorded.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// Whether no step was recorded.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// Steps per second of filter time: 0 without steps, `+∞` for a run too short to time (a time
    /// that is not positive; the fields are public).
    pub fn steps_per_second(&self) -> f64 {
        rate(self.steps.len() as f64, self.seconds)
    }
}

/// `count / seconds`: 0 for no count, `+∞` for a time that is not a positive number, so that the
/// rate is never NaN.
pub fn rate(count: f64, seconds: f64) -> f64 {
    if count == 0.0 {
        0.0
    } else if seconds > 0.0 {
        count / seconds
    } else {
        f64::INFINITY
    }
}

/// Runs `filter` through `steps` as [`replay`](crate::replay()) does (a predict with each step's
/// input, then an update where it has a measurement) and keeps every step: its time, its truth,
/// the estimate after it and the update's report, and for a smoother its smoothed estimate.
/// Memory grows with the number of steps, at most [`MAX_EPOCHS`]: the capacity is reserved from
/// the iterator's lower size bound (up to that limit), so a log's steps are reserved once.
///
/// # Errors
/// [`RunFailure`] at the first step, update or estimate that fails, and with
/// [`OperatorError::TooLarge`] at a step past [`MAX_EPOCHS`]; the steps before it are lost with
/// the recording (the filter is left as it was after the last good step).
///
/// # Example
/// A constant on the line measured three times: the recording keeps the three posteriors.
/// ```
/// use liebayes_densities::Gaussian;
/// use liebayes_experiments::{Recursive, Step, record};
/// use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
/// use nalgebra::{Matrix1, Vector1};
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let prior = Gaussian::new(Vector1::new(0.0), Matrix1::new(1.0))?;
/// let process = LinearProcess::new(Matrix1::new(1.0), Matrix1::new(0.0))?;
/// let measurement = LinearMeasurement::new(Matrix1::new(1.0), Matrix1::new(1.0))?;
/// let mut filter = Recursive::new(prior, process, measurement);
/// let steps = (1..=3).map(|k| Step {
///     time: f64::from(k),
///     input: Vector1::new(0.0),
///     truth: 2.0,
///     measurement: Some(Vector1::new(2.0)),
/// });
/// let recording = record(&mut filter, steps)?;
/// assert_eq!(recording.len(), 3);
/// // After n unit-variance readings of 2 from a N(0, 1) prior: mean 2n/(n+1), variance 1/(n+1).
/// let last = &recording.steps[2].estimate;
/// assert!((last.mean()[0] - 1.5).abs() < 1e-12);
/// assert!((last.covariance()[(0, 0)] - 0.25).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
pub fn record<F, T>(
    filter: &mut F,
    steps: impl IntoIterator<Item = Step<T, F::Input, F::Measurement>>,
) -> Result<Recording<T, F::Estimate>, RunFailure>
where
    F: RecursiveFilter,
    F::Input: Sized,
    F::Measurement: Sized,
{
    let steps = steps.into_iter();
    let mut kept: Vec<Recorded<T, F::Estimate>> = Vec::new();
    // A reservation the system refuses is left to the vector's growth.
    let _ = kept.try_reserve_exact(steps.size_hint().0.min(MAX_EPOCHS));
    let mut smoothed: Vec<F::Estimate> = Vec::new();
    let mut releases = Releases::new();
    // A smoother releases its estimates in step order, from step 0.
    let keep = |smoothed: &mut Vec<F::Estimate>, i: usize, e| {
        if i == smoothed.len() {
            smoothed.push(e);
        }
    };
    let start = Instant::now();
    for (index, step) in steps.enumerate() {
        let fail = |error| RunFailure {
            step: index,
            time: step.time,
            error,
        };
        if index >= MAX_EPOCHS {
            return Err(fail(OperatorError::TooLarge {
                what: "steps of a recording",
                value: index.saturating_add(1),
                max: MAX_EPOCHS,
            }));
        }
        filter.predict(&step.input).map_err(fail)?;
        let update = match &step.measurement {
            Some(z) => Some(filter.update(z).map_err(fail)?),
            None => None,
        };
        let estimate = filter.estimate().map_err(fail)?;
        kept.push(Recorded {
            time: step.time,
            truth: step.truth,
            estimate,
            update,
        });
        releases
            .poll(filter, false, |i, e| keep(&mut smoothed, i, e))
            .map_err(fail)?;
    }
    releases
        .poll(filter, true, |i, e| keep(&mut smoothed, i, e))
        .map_err(|error| RunFailure {
            step: kept.len().saturating_sub(1),
            time: kept.last().map_or(f64::NAN, |s| s.time),
            error,
        })?;
    Ok(Recording {
        steps: kept,
        smoothed,
        seconds: start.elapsed().as_secs_f64(),
    })
}
