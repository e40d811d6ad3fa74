//! A study end to end on a filter whose consistency is known: an EKF tracking a heading on SO(2) from
//! unit-vector measurements, driven through `Recursive` (the operator traits), replayed and scored
//! through the manifold. Its NEES and NIS must sit in their χ² bands, and three shards merged must
//! equal one study over all runs, bit for bit.

use liebayes_densities::ManifoldGaussian;
use liebayes_experiments::{
    ExperimentError, ManifoldScorer, Method, Metric, Recursive, RecursiveFilter, Scenario, Scorer,
    Shard, Step, Study, Summary, replay, run_rngs,
};
use liebayes_manifolds::{Manifold, So2};
use liebayes_operators::evaluation::average_nees_band;
use liebayes_operators::{Ekf, MeasurementFn, OperatorError, ProcessFn};
use nalgebra::{Matrix1, Matrix2, Vector1, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Turn rate (rad per step), process variance (rad²), measurement sigma, prior mean and variance.
const RATE: f64 = 0.3;
const Q: f64 = 1e-3;
const SIGMA: f64 = 0.05;
const PRIOR_MEAN: f64 = 3.0;
const PRIOR_VARIANCE: f64 = 0.01;

/// The heading after a step of the turn rate plus process noise; a measurement every other step.
struct Heading {
    steps: usize,
}

impl Scenario for Heading {
    type Truth = So2<f64>;
    type Input = ();
    type Measurement = Vector2<f64>;

    type Steps<'s> = std::vec::IntoIter<Step<So2<f64>, (), Vector2<f64>>>;

    fn epochs(&self) -> usize {
        self.steps / 2
    }

    fn simulate<'s>(&'s self, rng: &'s mut ChaCha8Rng) -> Result<Self::Steps<'s>, ExperimentError> {
        let normal = |rng: &mut ChaCha8Rng| rng.sample::<f64, _>(StandardNormal);
        let mut x = So2::from_angle_unchecked(PRIOR_MEAN + PRIOR_VARIANCE.sqrt() * normal(rng));
        let mut steps = Vec::with_capacity(self.steps);
        for k in 1..=self.steps {
            x = x.retract(&Vector1::new(RATE + Q.sqrt() * normal(rng)));
            let measurement = (k % 2 == 0).then(|| {
                let (s, c) = x.angle().sin_cos();
                Vector2::new(c + SIGMA * normal(rng), s + SIGMA * normal(rng))
            });
            steps.push(Step {
                time: k as f64,
                input: (),
                truth: x,
                measurement,
            });
        }
        Ok(steps.into_iter())
    }
}

/// The EKF of the scenario, with the given assumed measurement sigma.
fn filter(
    sigma: f64,
) -> Result<
    impl RecursiveFilter<
        Input = (),
        Measurement = Vector2<f64>,
        Estimate = ManifoldGaussian<So2<f64>, 1>,
    >,
    OperatorError,
> {
    let process = ProcessFn::new(
        |x: &So2<f64>, (): &()| x.retract(&Vector1::new(RATE)),
        |_, ()| Matrix1::new(Q),
    );
    let measurement = MeasurementFn::new(
        |x: &So2<f64>| {
            let (s, c) = x.angle().sin_cos();
            Vector2::new(c, s)
        },
        move |_| Matrix2::identity() * (sigma * sigma),
    );
    let prior = ManifoldGaussian::new(
        So2::from_angle_unchecked(PRIOR_MEAN),
        Matrix1::new(PRIOR_VARIANCE),
    )
    .map_err(OperatorError::from)?;
    Ok(Recursive::new(prior, Ekf(process), Ekf(measurement)))
}

/// The manifold's scores, with each run's RMS error kept.
struct PerRunError;

impl Scorer<So2<f64>, ManifoldGaussian<So2<f64>, 1>> for PerRunError {
    fn metrics(&self) -> Vec<Metric> {
        let mut metrics =
            <ManifoldScorer as Scorer<So2<f64>, ManifoldGaussian<So2<f64>, 1>>>::metrics(
                &ManifoldScorer,
            );
        metrics[0] = metrics[0].per_run();
        metrics
    }

    fn score(
        &self,
        truth: &So2<f64>,
        estimate: &ManifoldGaussian<So2<f64>, 1>,
        values: &mut [f64],
    ) {
        ManifoldScorer.score(truth, estimate, values);
    }
}

fn study(runs: u64, shard: Shard, sigma: f64) -> Summary {
    Study::new("EKF, heading", runs, 11, shard)
        .unwrap()
        .run(
            &Heading { steps: 40 },
            &|_| filter(sigma),
            &PerRunError,
            &|_| {},
        )
        .unwrap()
}

/// The heading scenario declaring one measurement epoch fewer than it yields.
struct Understated(Heading);

impl Scenario for Understated {
    type Truth = So2<f64>;
    type Input = ();
    type Measurement = Vector2<f64>;

    type Steps<'s> = <Heading as Scenario>::Steps<'s>;

    fn epochs(&self) -> usize {
        self.0.epochs() - 1
    }

    fn simulate<'s>(&'s self, rng: &'s mut ChaCha8Rng) -> Result<Self::Steps<'s>, ExperimentError> {
        self.0.simulate(rng)
    }
}

#[test]
fn a_run_of_more_epochs_than_its_scenario_declares_is_refused() {
    let error = Study::new("EKF, heading", 2, 11, Shard::WHOLE)
        .unwrap()
        .run(
            &Understated(Heading { steps: 40 }),
            &|_| filter(SIGMA),
            &PerRunError,
            &|_| {},
        )
        .unwrap_err();
    assert!(
        matches!(&error, ExperimentError::Scenario(m) if m.contains("the 19 the scenario declares")),
        "{error}"
    );
}

/// The mean of the pooled values is inside the χ² band of their average.
fn in_band(summary: &Summary, metric: &str, dof: usize) -> (f64, (f64, f64)) {
    let pooled = summary.series(metric).unwrap().pooled().unwrap();
    let count = usize::try_from(pooled.count()).unwrap();
    (
        pooled.mean().unwrap(),
        average_nees_band(dof, count).unwrap(),
    )
}

#[test]
fn a_consistent_filter_scores_inside_its_bands() {
    let summary = study(300, Shard::WHOLE, SIGMA);
    assert!(summary.failures().is_empty(), "{:?}", summary.failures());
    // The final epoch's NEES over runs (independent across runs), 1 degree of freedom.
    let last = summary
        .series("nees")
        .unwrap()
        .epochs()
        .last()
        .unwrap()
        .clone();
    let (low, high) = average_nees_band(1, 300).unwrap();
    let nees = last.mean().unwrap();
    assert!(
        (low..=high).contains(&nees),
        "final NEES {nees} outside [{low}, {high}]"
    );
    // The NIS of every update pooled (independent for a consistent filter), 2 degrees of freedom.
    let (nis, (low, high)) = in_band(&summary, "nis", 2);
    assert!(
        (low..=high).contains(&nis),
        "NIS {nis} outside [{low}, {high}]"
    );
    assert_eq!(summary.series("nees").unwrap().epochs().len(), 20);
    // A filter that believes its sensor four times better than it is fails the NIS band.
    let (nis, (_, high)) = in_band(&study(300, Shard::WHOLE, SIGMA / 2.0), "nis", 2);
    assert!(nis > high, "overconfident NIS {nis} inside the band");
}

#[test]
fn three_shards_merged_equal_one_study_bit_for_bit() {
    let whole = study(200, Shard::WHOLE, SIGMA);
    let mut merged = Summary::default();
    for k in [3, 1, 2] {
        let part = study(200, Shard::new(k, 3).unwrap(), SIGMA);
        let text = serde_json::to_string(&part).unwrap();
        merged.merge(&serde_json::from_str(&text).unwrap()).unwrap();
    }
    assert_eq!(merged.runs(), whole.runs());
    assert_eq!(merged.metrics(), whole.metrics());
    assert_eq!(merged.failures(), whole.failures());
    assert_eq!(merged.trace(), whole.trace());
    assert!(whole.trace().is_some());
    let text = |s: &Summary| serde_json::to_string(s.metrics()).unwrap();
    assert_eq!(text(&merged), text(&whole));
    assert_eq!(merged.timing().count(), 200);
    assert_eq!(merged.run_values("error"), whole.run_values("error"));
    assert_eq!(whole.run_values("error").unwrap().len(), 200);
}

#[test]
fn a_study_keeps_each_runs_error_as_its_replay_scores_it() {
    let summary = study(20, Shard::WHOLE, SIGMA);
    // The metrics the layer adds are not kept per run, nor the scorer's unmarked ones.
    for metric in ["log_evidence", "nis", "nees"] {
        assert!(summary.run_values(metric).is_none(), "{metric}");
    }
    let kept = summary.run_values("error").unwrap().values();
    assert_eq!(kept.len(), 20);
    for &(run, value) in kept {
        // Run `run` replayed by hand from its own streams: the RMS of its errors.
        let (mut simulation, _) = run_rngs(11, run);
        let steps = Heading { steps: 40 }.simulate(&mut simulation).unwrap();
        let scores = replay(&mut filter(SIGMA).unwrap(), steps, &PerRunError).unwrap();
        let errors: Vec<f64> = (0..scores.epochs())
            .map(|k| scores.get("error", k).unwrap())
            .collect();
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        assert!(
            (value - rms).abs() <= 1e-14 * rms,
            "run {run}: {value} against {rms}"
        );
    }
}

#[test]
fn failing_runs_are_counted_by_reason_and_left_out() {
    // Runs whose filter cannot be built (here: every one with an odd first draw) are failures.
    let summary = Study::new("EKF, heading", 50, 3, Shard::WHOLE)
        .unwrap()
        .run(
            &Heading { steps: 10 },
            &|rng: &mut ChaCha8Rng| {
                if rng.random::<bool>() {
                    Err(OperatorError::OutOfRange {
                        what: "test setting",
                        value: -1.0,
                        range: "[0, 1]",
                    })
                } else {
                    filter(SIGMA)
                }
            },
            &ManifoldScorer,
            &|_| {},
        )
        .unwrap();
    let failed: u64 = summary.failures().values().sum();
    assert!((10..=40).contains(&failed), "{failed}");
    let scored = summary.series("nees").unwrap().epochs()[0].count();
    assert_eq!(scored + failed, 50);
}

#[test]
fn replay_stops_at_the_first_failure_and_says_where() {
    let mut rng = liebayes_experiments::run_rngs(0, 0).0;
    let mut trajectory: Vec<_> = Heading { steps: 10 }.simulate(&mut rng).unwrap().collect();
    trajectory[5].measurement = Some(Vector2::new(f64::NAN, 0.0));
    let failure = replay(&mut filter(SIGMA).unwrap(), trajectory, &ManifoldScorer).unwrap_err();
    assert_eq!(failure.step, 5);
    assert!(
        failure.to_string().starts_with("step 5 (t = 6 s)"),
        "{failure}"
    );
}

/// The EKF of the scenario as a method, assuming this measurement sigma, its filter boxed.
struct Assumed(f64);

impl Method for Assumed {
    type Filter = Box<
        dyn RecursiveFilter<
                Input = (),
                Measurement = Vector2<f64>,
                Estimate = ManifoldGaussian<So2<f64>, 1>,
            > + Send,
    >;

    fn label(&self) -> String {
        format!("EKF sigma {}", self.0)
    }

    fn validate(&self) -> Result<(), OperatorError> {
        if self.0 > 0.0 {
            Ok(())
        } else {
            Err(OperatorError::OutOfRange {
                what: "measurement sigma",
                value: self.0,
                range: "(0, inf)",
            })
        }
    }

    fn build(&self, _: &mut ChaCha8Rng) -> Result<Self::Filter, OperatorError> {
        Ok(Box::new(filter(self.0)?))
    }
}

#[test]
fn a_method_study_equals_the_study_of_its_built_filter_bit_for_bit() {
    let by_method = Study::new("EKF, heading", 40, 11, Shard::WHOLE)
        .unwrap()
        .run_method(
            &Heading { steps: 40 },
            &Assumed(SIGMA),
            &PerRunError,
            &|_| {},
        )
        .unwrap();
    let by_closure = study(40, Shard::WHOLE, SIGMA);
    // Everything but the timing.
    let text = |s: &Summary| serde_json::to_string(s.metrics()).unwrap();
    assert_eq!(text(&by_method), text(&by_closure));
    assert_eq!(by_method.failures(), by_closure.failures());
    assert_eq!(by_method.trace(), by_closure.trace());
    assert_eq!(
        by_method.run_values("error"),
        by_closure.run_values("error")
    );
    assert_eq!(by_method.runs(), by_closure.runs());
}

#[test]
fn a_refused_method_stops_the_study_before_any_run() {
    let runs = std::sync::atomic::AtomicU64::new(0);
    let error = Study::new("EKF, heading", 40, 11, Shard::WHOLE)
        .unwrap()
        .run_method(
            &Heading { steps: 40 },
            &Assumed(-1.0),
            &PerRunError,
            &|done| {
                runs.store(done, std::sync::atomic::Ordering::Relaxed);
            },
        )
        .unwrap_err();
    assert!(matches!(
        &error,
        ExperimentError::Method { label, source: OperatorError::OutOfRange { .. } }
            if label == "EKF sigma -1"
    ));
    assert!(std::error::Error::source(&error).is_some());
    assert_eq!(runs.load(std::sync::atomic::Ordering::Relaxed), 0);
}

/// A scenario's settings may be valid up to `MAX_EPOCHS` = 2^24 epochs (what a
/// replay scores and a recording keeps) while a study holds 2^14. The study refuses more before
/// any run (the scenario is not simulated), naming both limits and what to change.
#[test]
fn a_study_refuses_more_epochs_than_it_holds_naming_both_limits() {
    let epochs = liebayes_experiments::MAX_STUDY_EPOCHS + 1;
    let error = Study::new("EKF, heading", 2, 11, Shard::WHOLE)
        .unwrap()
        .run(
            &Heading { steps: 2 * epochs },
            &|_| filter(SIGMA),
            &PerRunError,
            &|_| {},
        )
        .unwrap_err();
    let message = error.to_string();
    assert!(
        matches!(error, ExperimentError::OutOfRange { .. })
            && message.contains("is 16385")
            && message.contains("MAX_STUDY_EPOCHS")
            && message.contains("2^24 = MAX_EPOCHS")
            && message.contains("shorten the run"),
        "{message}"
    );
}
