//! Smoothers on the layer: a filter that also gives, for each of its steps, an estimate from later
//! measurements too. [`replay`](crate::replay()), [`record`](crate::record()) and
//! [`Study`](crate::Study) run it exactly as a filter (the forward pass is the filter, scored at
//! each measurement epoch) and score each step's smoothed estimate, when the filter releases it,
//! against that step's truth under the scorer's metric names prefixed `smoothed_`.
//!
//! * [`Smoothing`]: what the layer asks of a smoother, the smoothed estimates that are final,
//!   in step order; a [`RecursiveFilter`] offers it through
//!   [`RecursiveFilter::smoothing`].
//! * [`Smoothed`]: a [`Smoother`] (the operators' [`RtsSmoother`], [`FixedLagSmoother`] and
//!   [`IteratedSmoother`]) with its
//!   process and measurement models and its [`Estimator`], the smoothing counterpart of
//!   [`Recursive`](crate::Recursive).
//!
//! When a step's smoothed estimate is final depends on the smoother: the RTS and the iterated
//! smoothers release every step's at the end of the run (each given every measurement of the run); the fixed-lag
//! smoother of lag L releases step k − L's after step k (given the measurements up to step k), and
//! the last L steps' at the end of the run (given every measurement).

use crate::filter::{AsIs, Estimator, RecursiveFilter, StepReport, Update};
use crate::score::Scorer;
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use liebayes_operators::fixed_lag::FixedLagSmoother;
use liebayes_operators::iterated_smoother::IteratedSmoother;
use liebayes_operators::smoother::{GaussianTransition, RtsSmoother};
use liebayes_operators::{Condition, Innovation, MeasurementModel, OperatorError, ProcessModel};
use nalgebra::SVector;
use std::collections::{BTreeMap, VecDeque};
use std::sync::{Mutex, PoisonError};

/// What the layer asks of a smoother besides its filter's steps: the smoothed estimates that have
/// become final.
pub trait Smoothing {
    /// The smoothed estimate's type (the filter's estimate type).
    type Estimate;

    /// Appends to `out`, in order, the smoothed estimates that are final now of the steps after
    /// those already released: step i is the filter's i-th prediction since it was built (its
    /// prior's epoch is not a step). `end`: no step follows, so every step's estimate is final. The
    /// layer calls it after every step (a prediction, and the update where there is a
    /// measurement) and once with `end` after the last.
    ///
    /// # Errors
    /// When the smoothing fails (a smoothed covariance that lost positive definiteness), or when
    /// a step's estimate was lost (a fixed-lag smoother's window passed it before it was released).
    /// The steps that call was to release are then skipped, with what it appended to `out` before
    /// the error: the next call releases from the step after them, so that one failed backward
    /// pass does not stop the smoothing.
    fn release(&mut self, end: bool, out: &mut Vec<Self::Estimate>) -> Result<(), OperatorError>;
}

/// A smoother's forward record as [`Smoothed`] steps it, with process model `P` and measurement
/// model `M` (given again at every call, so that a smoother whose backward pass needs the models,
/// an iterated smoother, can implement it).
pub trait Smoother<P, M> {
    /// What drives the process.
    type Input: ?Sized;
    /// A measurement.
    type Measurement: ?Sized;
    /// The density of an epoch.
    type Density;
    /// The conditioning step's report.
    type Report: StepReport;

    /// Propagates to a new epoch, recording the transition.
    ///
    /// # Errors
    /// The prediction's; the record is then unchanged.
    fn propagate(&mut self, process: &P, input: &Self::Input) -> Result<(), OperatorError>;

    /// Conditions the current epoch on a measurement: its log evidence and report.
    ///
    /// # Errors
    /// The conditioning's; the record is then unchanged.
    fn condition(
        &mut self,
        measurement: &M,
        z: &Self::Measurement,
    ) -> Result<(f64, Self::Report), OperatorError>;

    /// The current epoch's filtered density.
    fn current(&self) -> &Self::Density;

    /// The current epoch's index: 0 for the prior's, then one more per propagation.
    fn epoch(&self) -> u64;

    /// Calls `each` with the smoothed density of every epoch from `first` on whose smoothed
    /// density is final (all of them when `end`), in order, and returns the next epoch to release.
    /// Epoch 0 is the prior's; epoch k follows the k-th propagation.
    ///
    /// # Errors
    /// The backward pass's, or `each`'s; [`OperatorError::OutOfRange`] when epoch `first` is no
    /// longer held.
    fn release(
        &mut self,
        process: &P,
        measurement: &M,
        first: u64,
        end: bool,
        each: &mut dyn FnMut(&Self::Density) -> Result<(), OperatorError>,
    ) -> Result<u64, OperatorError>;

    /// The epoch after those a release from `first` would give now (at least `first`): where the
    /// next release starts when this one fails. The default is for smoothers that release only at
    /// the end: every epoch then, none before.
    fn released_through(&self, first: u64, end: bool) -> u64 {
        if end {
            first.max(self.epoch().saturating_add(1))
        } else {
            first
        }
    }
}

impl<X, const D: usize, P, M> Smoother<P, M> for RtsSmoother<X, D>
where
    X: Manifold<D, Scalar = f64>,
    P: GaussianTransition<X, D>,
    ManifoldGaussian<X, D>: Condition<M>,
    <ManifoldGaussian<X, D> as Condition<M>>::Report: StepReport,
{
    type Input = P::Input;
    type Measurement = <ManifoldGaussian<X, D> as Condition<M>>::Measurement;
    type Density = ManifoldGaussian<X, D>;
    type Report = <ManifoldGaussian<X, D> as Condition<M>>::Report;

    fn propagate(&mut self, process: &P, input: &P::Input) -> Result<(), OperatorError> {
        RtsSmoother::propagate(self, process, input)
    }

    fn condition(
        &mut self,
        measurement: &M,
        z: &Self::Measurement,
    ) -> Result<(f64, Self::Report), OperatorError> {
        let step = RtsSmoother::condition(self, measurement, z)?;
        Ok((step.log_evidence, step.report))
    }

    fn current(&self) -> &Self::Density {
        RtsSmoother::current(self)
    }

    fn epoch(&self) -> u64 {
        self.filtered().len() as u64 - 1
    }

    fn release(
        &mut self,
        _: &P,
        _: &M,
        first: u64,
        end: bool,
        each: &mut dyn FnMut(&Self::Density) -> Result<(), OperatorError>,
    ) -> Result<u64, OperatorError> {
        if !end {
            return Ok(first);
        }
        release_from(&self.smooth()?, first, each)
    }
}

/// Calls `each` with the smoothed densities of a whole run from epoch `first` on, and returns the
/// next epoch to release.
fn release_from<Density>(
    smoothed: &[Density],
    first: u64,
    each: &mut dyn FnMut(&Density) -> Result<(), OperatorError>,
) -> Result<u64, OperatorError> {
    let skip = usize::try_from(first).unwrap_or(usize::MAX);
    for density in smoothed.iter().skip(skip) {
        each(density)?;
    }
    Ok(first.max(smoothed.len() as u64))
}

/// The iterated smoother: the EKF forward pass, and at the end of the run the MAP trajectory by
/// Gauss-Newton with the default settings, given the raw models (not wrapped in `Ekf`).
impl<X, U, P, H, const D: usize, const M: usize> Smoother<P, H> for IteratedSmoother<X, U, D, M>
where
    X: Manifold<D, Scalar = f64>,
    U: Clone,
    P: ProcessModel<X, D, Input = U>,
    H: MeasurementModel<X, D, M>,
{
    type Input = U;
    type Measurement = SVector<f64, M>;
    type Density = ManifoldGaussian<X, D>;
    type Report = Innovation<D, M>;

    fn propagate(&mut self, process: &P, input: &U) -> Result<(), OperatorError> {
        IteratedSmoother::propagate(self, process, input)
    }

    fn condition(
        &mut self,
        measurement: &H,
        z: &SVector<f64, M>,
    ) -> Result<(f64, Innovation<D, M>), OperatorError> {
        let step = IteratedSmoother::condition(self, measurement, z)?;
        Ok((step.log_evidence, step.report))
    }

    fn current(&self) -> &Self::Density {
        self.forward().current()
    }

    fn epoch(&self) -> u64 {
        self.forward().filtered().len() as u64 - 1
    }

    fn release(
        &mut self,
        process: &P,
        measurement: &H,
        first: u64,
        end: bool,
        each: &mut dyn FnMut(&Self::Density) -> Result<(), OperatorError>,
    ) -> Result<u64, OperatorError> {
        if !end {
            return Ok(first);
        }
        release_from(&self.smooth(process, measurement)?.densities, first, each)
    }
}

impl<X, const D: usize, P, M> Smoother<P, M> for FixedLagSmoother<X, D>
where
    X: Manifold<D, Scalar = f64>,
    P: GaussianTransition<X, D>,
    ManifoldGaussian<X, D>: Condition<M>,
    <ManifoldGaussian<X, D> as Condition<M>>::Report: StepReport,
{
    type Input = P::Input;
    type Measurement = <ManifoldGaussian<X, D> as Condition<M>>::Measurement;
    type Density = ManifoldGaussian<X, D>;
    type Report = <ManifoldGaussian<X, D> as Condition<M>>::Report;

    fn propagate(&mut self, process: &P, input: &P::Input) -> Result<(), OperatorError> {
        FixedLagSmoother::propagate(self, process, input)
    }

    fn condition(
        &mut self,
        measurement: &M,
        z: &Self::Measurement,
    ) -> Result<(f64, Self::Report), OperatorError> {
        let step = FixedLagSmoother::condition(self, measurement, z)?;
        Ok((step.log_evidence, step.report))
    }

    fn current(&self) -> &Self::Density {
        FixedLagSmoother::current(self)
    }

    fn epoch(&self) -> u64 {
        FixedLagSmoother::epoch(self)
    }

    fn release(
        &mut self,
        _: &P,
        _: &M,
        first: u64,
        end: bool,
        each: &mut dyn FnMut(&Self::Density) -> Result<(), OperatorError>,
    ) -> Result<u64, OperatorError> {
        let next = Smoother::<P, M>::released_through(self, first, end);
        if next == first {
            return Ok(first);
        }
        let window = self.smooth()?;
        if first < window.first_epoch() {
            return Err(OperatorError::OutOfRange {
                what: "first epoch to release from a fixed-lag smoother (its window has passed \
                       it: release after every step)",
                value: first as f64,
                range: "the epochs of the window",
            });
        }
        for k in first..next {
            if let Some(density) = window.get(k) {
                each(density)?;
            }
        }
        Ok(next)
    }

    /// Final now: the epochs up to k − L, or every epoch at the end.
    fn released_through(&self, first: u64, end: bool) -> u64 {
        let (epoch, lag) = (self.epoch(), self.lag() as u64);
        let last = if end {
            Some(epoch)
        } else {
            epoch.checked_sub(lag)
        };
        last.map_or(first, |last| first.max(last.saturating_add(1)))
    }
}

/// A [`Smoother`] `S` with its process model `P`, its measurement model `M` and its
/// [`Estimator`] `E`: a [`RecursiveFilter`] whose steps are the smoother's forward pass and whose
/// estimate is the current filtered one, and a [`Smoothing`] that releases each step's smoothed
/// estimate when it is final. The smoothing counterpart of [`Recursive`](crate::Recursive).
///
/// # Example
/// The RTS smoother of a random walk on the line, replayed: the smoothed errors are scored beside
/// the filtered ones.
/// ```
/// use liebayes_experiments::{ManifoldScorer, Smoothed, Step, replay};
/// use liebayes_operators::densities::ManifoldGaussian;
/// use liebayes_operators::manifolds::Rn;
/// use liebayes_operators::smoother::RtsSmoother;
/// use liebayes_operators::{Ekf, MeasurementFn, ProcessFn};
/// use nalgebra::{Matrix1, Vector1};
///
/// let walk = ProcessFn::new(|x: &Rn<f64, 1>, (): &()| *x, |_, ()| Matrix1::new(0.1));
/// let sensor = MeasurementFn::new(|x: &Rn<f64, 1>| *x.coords(), |_| Matrix1::new(1.0));
/// let prior = ManifoldGaussian::new(Rn::new(Vector1::new(0.0)).unwrap(), Matrix1::new(1.0)).unwrap();
/// let mut smoother = Smoothed::new(RtsSmoother::new(prior), Ekf(&walk), Ekf(&sensor));
/// let truth = Rn::new(Vector1::new(0.5)).unwrap();
/// let steps = [0.9, 0.2, 0.6].map(|z| Step {
///     time: 1.0,
///     input: (),
///     truth,
///     measurement: Some(Vector1::new(z)),
/// });
/// let scores = replay(&mut smoother, steps.into_iter().enumerate().map(|(k, mut s)| {
///     s.time = k as f64;
///     s
/// }), &ManifoldScorer)
/// .unwrap();
/// let names: Vec<_> = scores.metrics.iter().map(|m| m.name).collect();
/// assert_eq!(names, ["error", "nees", "log_evidence", "nis", "smoothed_error", "smoothed_nees"]);
/// // The last epoch's smoothed estimate is its filtered one; the first's has seen all readings.
/// assert_eq!(scores.get("smoothed_error", 2), scores.get("error", 2));
/// assert_ne!(scores.get("smoothed_error", 0), scores.get("error", 0));
/// ```
///
/// A run is checkpointed by its smoother (the operators' smoothers are serde): `Smoothed::new` on
/// the smoother read back continues the run, releasing the steps after the checkpoint's epoch.
#[derive(Clone, Debug, PartialEq)]
pub struct Smoothed<S, P, M, E = AsIs> {
    smoother: S,
    process: P,
    measurement: M,
    estimator: E,
    /// The next epoch to release (epoch 0, the prior's, is not a step).
    next: u64,
}

impl<S: Smoother<P, M>, P, M> Smoothed<S, P, M> {
    /// The smoother `smoother` stepped with these models, its own estimate ([`AsIs`]); its steps
    /// are those after its current epoch (its prior's, or the epoch a checkpoint was taken at).
    pub fn new(smoother: S, process: P, measurement: M) -> Self {
        Self::with_estimator(smoother, process, measurement, AsIs)
    }
}

impl<S: Smoother<P, M>, P, M, E> Smoothed<S, P, M, E> {
    /// The smoother estimated by `estimator`; its steps are those after its current epoch.
    pub fn with_estimator(smoother: S, process: P, measurement: M, estimator: E) -> Self {
        let next = smoother.epoch().saturating_add(1);
        Self {
            smoother,
            process,
            measurement,
            estimator,
            next,
        }
    }
}

impl<S, P, M, E> Smoothed<S, P, M, E> {
    /// The smoother.
    pub fn smoother(&self) -> &S {
        &self.smoother
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

impl<S, P, M, E> RecursiveFilter for Smoothed<S, P, M, E>
where
    S: Smoother<P, M>,
    E: Estimator<S::Density>,
{
    type Input = S::Input;
    type Measurement = S::Measurement;
    type Estimate = E::Estimate;

    fn predict(&mut self, input: &Self::Input) -> Result<(), OperatorError> {
        self.smoother.propagate(&self.process, input)
    }

    fn update(&mut self, z: &Self::Measurement) -> Result<Update, OperatorError> {
        let (log_evidence, report) = self.smoother.condition(&self.measurement, z)?;
        Ok(Update {
            log_evidence,
            nis: report.nis(),
        })
    }

    fn estimate(&self) -> Result<Self::Estimate, OperatorError> {
        self.estimator.estimate(self.smoother.current())
    }

    fn smoothing(&mut self) -> Option<&mut dyn Smoothing<Estimate = Self::Estimate>> {
        Some(self)
    }
}

impl<S, P, M, E> Smoothing for Smoothed<S, P, M, E>
where
    S: Smoother<P, M>,
    E: Estimator<S::Density>,
{
    type Estimate = E::Estimate;

    fn release(&mut self, end: bool, out: &mut Vec<E::Estimate>) -> Result<(), OperatorError> {
        let estimator = &self.estimator;
        let mut each = |density: &S::Density| {
            out.push(estimator.estimate(density)?);
            Ok(())
        };
        let released =
            self.smoother
                .release(&self.process, &self.measurement, self.next, end, &mut each);
        self.next = match released {
            Ok(next) => next,
            Err(error) => {
                // Skip the epochs this release was to give: their error is reported now, and the
                // next release goes on from the epochs after them.
                self.next = self.smoother.released_through(self.next, end);
                return Err(error);
            }
        };
        Ok(())
    }
}

/// The smoothed estimates of a run as its filter releases them, each with its step's index
/// (the replay and the recorder's one way of asking).
pub(crate) struct Releases<E> {
    /// The step index of the next estimate released.
    next: usize,
    /// Reused between steps.
    buffer: Vec<E>,
}

impl<E> Releases<E> {
    pub(crate) fn new() -> Self {
        Self {
            next: 0,
            buffer: Vec::new(),
        }
    }

    /// Asks `filter` for the smoothed estimates final now (`end`: all of them) and calls `each`
    /// with each one's step index and the estimate. Nothing for a filter that does not smooth.
    pub(crate) fn poll<F>(
        &mut self,
        filter: &mut F,
        end: bool,
        mut each: impl FnMut(usize, E),
    ) -> Result<(), OperatorError>
    where
        F: RecursiveFilter<Estimate = E> + ?Sized,
    {
        let Some(smoothing) = filter.smoothing() else {
            return Ok(());
        };
        self.buffer.clear();
        smoothing.release(end, &mut self.buffer)?;
        for estimate in self.buffer.drain(..) {
            each(self.next, estimate);
            self.next += 1;
        }
        Ok(())
    }
}

/// The truths of the scored steps whose smoothed estimates are not released yet, and where in a
/// run's score rows their smoothed scores go.
pub(crate) struct Pending<T> {
    /// (step index, score row, truth), in step order.
    queue: VecDeque<(usize, usize, T)>,
    /// Values per row.
    width: usize,
    /// The first smoothed column.
    offset: usize,
}

impl<T> Pending<T> {
    /// Nothing pending, in rows of `width` values whose smoothed scores start at `offset`.
    pub(crate) fn new(width: usize, offset: usize) -> Self {
        Self {
            queue: VecDeque::new(),
            width,
            offset,
        }
    }

    /// Holds the truth of step `step`, scored in row `row`, until its smoothed estimate comes.
    pub(crate) fn push(&mut self, step: usize, row: usize, truth: T) {
        self.queue.push_back((step, row, truth));
    }

    /// Scores the smoothed `estimate` of step `step` into its row of `values`, if the step is
    /// waiting for it (a step without a measurement, or beyond the scored epochs, is not).
    pub(crate) fn score<E, Sc>(
        &mut self,
        scorer: &Sc,
        values: &mut [f64],
        step: usize,
        estimate: &E,
    ) where
        Sc: Scorer<T, E> + ?Sized,
    {
        while self.queue.front().is_some_and(|p| p.0 < step) {
            self.queue.pop_front();
        }
        if self.queue.front().is_some_and(|p| p.0 == step) {
            if let Some((_, row, truth)) = self.queue.pop_front() {
                let at = row * self.width + self.offset;
                let scored = self.width - self.offset;
                scorer.score(&truth, estimate, &mut values[at..at + scored]);
            }
        }
    }
}

/// The name `smoothed_<name>`, made once per distinct name for the life of the program (a metric's
/// name is `&'static str`; the names a program's scorers use are finitely many, so this holds at
/// most one string per metric name the program has).
pub(crate) fn smoothed_name(name: &'static str) -> &'static str {
    static NAMES: Mutex<BTreeMap<&'static str, &'static str>> = Mutex::new(BTreeMap::new());
    let mut names = NAMES.lock().unwrap_or_else(PoisonError::into_inner);
    names
        .entry(name)
        .or_insert_with(|| Box::leak(format!("smoothed_{name}").into_boxed_str()))
}
