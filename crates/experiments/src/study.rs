//! A study: many runs of one scenario and one filter, each seeded from its own stream, scored and
//! summarised in constant memory, in parallel with the `rayon` feature, over one shard of the runs.

use crate::filter::RecursiveFilter;
use crate::replay::{Scenario, replay};
use crate::score::Scorer;
use crate::summary::StudyLabel;
use crate::{ExperimentError, Method, Shard, Summary, run_rngs};
use liebayes_operators::OperatorError;
use rand_chacha::ChaCha8Rng;

/// The most runs a study may have.
pub const MAX_RUNS: u64 = 1 << 40;

/// The most measurement epochs of a study's scenario: a summary keeps exact statistics (about
/// 1 KB) per metric and epoch, so 16 384 epochs of a dozen metrics take about 200 MB per summary in
/// flight. Longer runs are replayed with [`replay`] directly, or scored at fewer epochs.
///
/// This is the limit for a study, lower than the [`MAX_EPOCHS`](crate::MAX_EPOCHS) = 2²⁴ up to
/// which a scenario's settings may be valid (an application's configuration checks the latter,
/// which a replay or a recording of one run can take): a study refuses a scenario of more epochs
/// in [`Study::run`] (and so [`Study::run_method`]), before any run, with both limits named.
pub const MAX_STUDY_EPOCHS: usize = 1 << 14;

/// The most runs handed to a worker at a time: each such block is summarised on its own, and the
/// blocks' summaries merged (exactly, so the block size does not change any figure).
const BLOCK: u64 = 64;

/// A study is cut into at least this many blocks when it has the runs (so that a short study of
/// costly runs, ten runs of a 10⁶-particle filter, still uses every core).
const MIN_BLOCKS: u64 = 16;

/// What a study runs: how many runs, from which seed, and which shard of them here.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Study {
    name: String,
    runs: u64,
    seed: u64,
    shard: Shard,
}

impl Study {
    /// The study `name` (the filter and scenario, as the summary is to be labelled) of `runs` runs
    /// from `seed`, of which this process runs `shard`.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] for no runs or more than [`MAX_RUNS`].
    pub fn new(
        name: impl Into<String>,
        runs: u64,
        seed: u64,
        shard: Shard,
    ) -> Result<Self, ExperimentError> {
        if runs == 0 || runs > MAX_RUNS {
            return Err(ExperimentError::OutOfRange {
                what: "number of runs",
                value: runs.to_string(),
                range: "[1, 2^40]",
            });
        }
        Ok(Self {
            name: name.into(),
            runs,
            seed,
            shard,
        })
    }

    /// The total number of runs (all shards).
    pub fn runs(&self) -> u64 {
        self.runs
    }

    /// The seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The shard run here.
    pub fn shard(&self) -> Shard {
        self.shard
    }

    /// The label its summaries carry.
    pub fn label(&self) -> StudyLabel {
        StudyLabel {
            name: self.name.clone(),
            seed: self.seed,
            runs: self.runs,
        }
    }

    /// Runs this shard: run k simulates `scenario` from its simulation stream and builds its filter
    /// with `build` from its filter stream ([`run_rngs`]`(seed, k)`), replays it, and records its
    /// scores in the summary: per measurement epoch, every metric of `scorer`, the log evidence and
    /// the NIS (where the filter reports one); per run, the filter time. A run that fails is
    /// counted under its reason and contributes nothing else. `progress` is called with the number
    /// of runs done so far after each block of runs. Memory does not grow with the number of runs.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] for a scenario of more than [`MAX_STUDY_EPOCHS`] epochs
    /// (before any run), [`ExperimentError::Scenario`] for a run with more measurement epochs
    /// than the scenario's [`epochs`](Scenario::epochs) (stopped at the first one beyond, so its
    /// scores take no more memory than declared), [`ExperimentError`] when the scenario cannot be
    /// simulated; filter failures are recorded in the summary instead.
    ///
    /// # Example
    /// ```
    /// use liebayes_experiments::{
    ///     ExperimentError, ManifoldScorer, Recursive, Scenario, Shard, Step, StepOf, Study,
    /// };
    /// use liebayes_operators::manifolds::{Manifold, Rn};
    /// use liebayes_operators::densities::ManifoldGaussian;
    /// use liebayes_operators::{Ekf, MeasurementFn, ProcessFn};
    /// use nalgebra::{Matrix1, Vector1};
    /// use rand::Rng;
    /// use rand_chacha::ChaCha8Rng;
    ///
    /// /// A point at rest at 0, measured five times with uniform noise.
    /// struct AtRest;
    /// impl Scenario for AtRest {
    ///     type Truth = Rn<f64, 1>;
    ///     type Input = ();
    ///     type Measurement = Vector1<f64>;
    ///     type Steps<'s> = std::vec::IntoIter<StepOf<Self>>;
    ///     fn epochs(&self) -> usize {
    ///         5
    ///     }
    ///     fn simulate<'s>(&'s self, rng: &'s mut ChaCha8Rng) -> Result<Self::Steps<'s>, ExperimentError> {
    ///         let truth = Rn::new(Vector1::new(0.0)).unwrap();
    ///         let steps: Vec<StepOf<Self>> = (1..=5)
    ///             .map(|k| Step {
    ///                 time: f64::from(k),
    ///                 input: (),
    ///                 truth,
    ///                 measurement: Some(Vector1::new(rng.random::<f64>() - 0.5)),
    ///             })
    ///             .collect();
    ///         Ok(steps.into_iter())
    ///     }
    /// }
    ///
    /// let still = ProcessFn::new(|x: &Rn<f64, 1>, _: &()| *x, |_, _| Matrix1::new(1e-6));
    /// let sensor = MeasurementFn::new(|x: &Rn<f64, 1>| *x.coords(), |_| Matrix1::new(1.0 / 12.0));
    /// let study = Study::new("at rest", 8, 42, Shard::WHOLE)?;
    /// let summary = study.run(
    ///     &AtRest,
    ///     &|_| {
    ///         let prior = ManifoldGaussian::new(Rn::new(Vector1::new(0.0)).unwrap(), Matrix1::new(1.0))?;
    ///         Ok(Recursive::new(prior, Ekf(&still), Ekf(&sensor)))
    ///     },
    ///     &ManifoldScorer,
    ///     &|_| {},
    /// )?;
    /// assert_eq!(summary.run_count(), 8);
    /// assert_eq!(summary.failure_count(), 0);
    /// assert_eq!(summary.series("error").unwrap().epochs().len(), 5);
    /// # Ok::<(), ExperimentError>(())
    /// ```
    pub fn run<S, F, Sc>(
        &self,
        scenario: &S,
        build: &(dyn Fn(&mut ChaCha8Rng) -> Result<F, OperatorError> + Sync),
        scorer: &Sc,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Summary, ExperimentError>
    where
        S: Scenario,
        F: RecursiveFilter<Input = S::Input, Measurement = S::Measurement>,
        Sc: Scorer<S::Truth, F::Estimate>,
    {
        if scenario.epochs() > MAX_STUDY_EPOCHS {
            return Err(ExperimentError::OutOfRange {
                what: "number of measurement epochs of the scenario",
                value: scenario.epochs().to_string(),
                range: "[0, 16384] = [0, MAX_STUDY_EPOCHS] in a study, which keeps exact \
                        statistics per epoch (a scenario's settings may allow up to 2^24 = \
                        MAX_EPOCHS for a replay or a recording, not for a study: shorten the run \
                        or measure less often)",
            });
        }
        let range = self.shard.runs(self.runs);
        let size = (range.end - range.start)
            .div_ceil(MIN_BLOCKS)
            .clamp(1, BLOCK);
        let blocks = (range.end - range.start).div_ceil(size);
        let done = std::sync::atomic::AtomicU64::new(0);
        let block = |b: u64| -> Result<Summary, ExperimentError> {
            let start = range.start + b * size;
            let end = (start + size).min(range.end);
            let mut summary = Summary::new(self.label(), start..end)?;
            for run in start..end {
                self.record(run, scenario, build, scorer, &mut summary)?;
            }
            let so_far = done.fetch_add(end - start, std::sync::atomic::Ordering::Relaxed);
            progress(so_far + end - start);
            Ok(summary)
        };
        // Merging is exact, so the blocks may be combined in any order: memory stays at a few
        // summaries whatever the number of runs.
        let empty = Summary::new(self.label(), range.start..range.start)?;
        reduce_blocks(blocks, &block, &|| empty.clone())
    }

    /// Runs this shard of `method` on `scenario`, as [`Study::run`] with the method's
    /// [`build`](Method::build), after checking the method's settings once.
    ///
    /// # Errors
    /// [`ExperimentError::Method`] when [`Method::validate`] refuses the method (before any run);
    /// as [`Study::run`] otherwise.
    pub fn run_method<S, M, Sc>(
        &self,
        scenario: &S,
        method: &M,
        scorer: &Sc,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Summary, ExperimentError>
    where
        S: Scenario,
        M: Method + Sync,
        M::Filter: RecursiveFilter<Input = S::Input, Measurement = S::Measurement>,
        Sc: Scorer<S::Truth, <M::Filter as RecursiveFilter>::Estimate>,
    {
        method
            .validate()
            .map_err(|source| ExperimentError::Method {
                label: method.label(),
                source,
            })?;
        self.run(
            scenario,
            &|rng: &mut ChaCha8Rng| method.build(rng),
            scorer,
            progress,
        )
    }

    /// One run into `summary`.
    fn record<S, F, Sc>(
        &self,
        run: u64,
        scenario: &S,
        build: &(dyn Fn(&mut ChaCha8Rng) -> Result<F, OperatorError> + Sync),
        scorer: &Sc,
        summary: &mut Summary,
    ) -> Result<(), ExperimentError>
    where
        S: Scenario,
        F: RecursiveFilter<Input = S::Input, Measurement = S::Measurement>,
        Sc: Scorer<S::Truth, F::Estimate>,
    {
        let (mut simulation, mut randomness) = run_rngs(self.seed, run);
        let steps = scenario.simulate(&mut simulation)?;
        let mut filter = match build(&mut randomness) {
            Ok(filter) => filter,
            Err(error) => return summary.add_failure(&format!("building the filter: {error}")),
        };
        // The run is cut at its first measurement beyond the scenario's epochs, and refused, so
        // that a scenario that yields more than it declares does not grow the scores past them.
        let declared = scenario.epochs();
        let (mut measured, mut beyond) = (0_usize, false);
        let steps = steps.take_while(|step| {
            measured += usize::from(step.measurement.is_some());
            beyond = measured > declared;
            !beyond
        });
        let replayed = replay(&mut filter, steps, scorer);
        if beyond {
            return Err(ExperimentError::Scenario(format!(
                "run {run} has more measurement epochs than the {declared} the scenario declares"
            )));
        }
        match replayed {
            Ok(scores) => summary.add_run(run, &scores),
            Err(failure) => summary.add_failure(&failure.error.to_string()),
        }
    }
}

/// Merges `f` over the blocks `0..blocks`, in parallel with the `rayon` feature: one worker per
/// thread of rayon's pool, each taking the next block from a shared counter and merging it into
/// its own summary, then the workers' summaries merged. So the memory is a few summaries per thread
/// whatever the number of blocks (a divide-and-conquer reduction would hold a summary per level of
/// its tree).
#[cfg(feature = "rayon")]
fn reduce_blocks(
    blocks: u64,
    f: &(impl Fn(u64) -> Result<Summary, ExperimentError> + Sync),
    empty: &(impl Fn() -> Summary + Sync),
) -> Result<Summary, ExperimentError> {
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicU64, Ordering};
    let next = AtomicU64::new(0);
    let workers = u64::try_from(rayon::current_num_threads())
        .unwrap_or(1)
        .clamp(1, blocks.max(1));
    let parts = Mutex::new(Vec::new());
    rayon::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|_| {
                let work = || -> Result<Summary, ExperimentError> {
                    let mut summary = empty();
                    loop {
                        let b = next.fetch_add(1, Ordering::Relaxed);
                        if b >= blocks {
                            return Ok(summary);
                        }
                        summary.merge(&f(b)?)?;
                    }
                };
                let part = work();
                if part.is_err() {
                    // The other workers stop at their next block.
                    next.store(blocks, Ordering::Relaxed);
                }
                parts
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner)
                    .push(part);
            });
        }
    });
    let mut summary = empty();
    for part in parts
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
    {
        summary.merge(&part?)?;
    }
    Ok(summary)
}

/// Merges `f` over the blocks `0..blocks`.
#[cfg(not(feature = "rayon"))]
fn reduce_blocks(
    blocks: u64,
    f: &impl Fn(u64) -> Result<Summary, ExperimentError>,
    empty: &impl Fn() -> Summary,
) -> Result<Summary, ExperimentError> {
    let mut summary = empty();
    for b in 0..blocks {
        summary.merge(&f(b)?)?;
    }
    Ok(summary)
}
