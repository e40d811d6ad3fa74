//! Smoothers through the layer, on scenarios whose truth is drawn from the filter's own model: a
//! constant-velocity track on R² (linear, the smoothers exact) and a heading on SO(2) measured as a
//! unit vector every other step (nonlinear). Run through `Study` as any filter, the RTS and the
//! fixed-lag smoothers' smoothed NEES must sit in its two-sided χ² band at every epoch, their
//! smoothed RMSE must be below the filtered RMSE at every interior epoch, three shards merged must
//! equal one study bit for bit, and a recorded run must hold what the operators' smoothers give.

use liebayes_densities::ManifoldGaussian;
use liebayes_experiments::{
    ExperimentError, ManifoldScorer, RecursiveFilter, Scenario, Shard, Smoothed, Step, StepOf,
    Study, Summary, record,
};
use liebayes_manifolds::{Manifold, Rn, So2};
use liebayes_operators::evaluation::chi_square_quantile;
use liebayes_operators::fixed_lag::FixedLagSmoother;
use liebayes_operators::iterated_smoother::IteratedSmoother;
use liebayes_operators::smoother::RtsSmoother;
use liebayes_operators::{
    Ekf, MeasurementFn, MeasurementModel, OperatorError, ProcessFn, ProcessModel,
};
use nalgebra::{Matrix1, Matrix2, Vector1, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Runs of each study.
const RUNS: u64 = 400;

/// The two-sided standard normal quantile of 1 − 10⁻⁴/2: each study checks at most 40 epochs'
/// bands, so a consistent smoother fails one with probability below 0.4 %.
const Z: f64 = 3.890_591_886_413_094;

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    rng.sample::<f64, _>(StandardNormal)
}

/// Step 0.5 s, `x = (position, velocity)`, white-acceleration noise, position measured (σ = 0.5).
const DT: f64 = 0.5;
const R: f64 = 0.25;

fn transition() -> Matrix2<f64> {
    Matrix2::new(1.0, DT, 0.0, 1.0)
}

fn process_noise() -> Matrix2<f64> {
    Matrix2::new(DT.powi(3) / 3.0, DT * DT / 2.0, DT * DT / 2.0, DT) * 0.2
}

fn track_prior() -> ManifoldGaussian<Rn<f64, 2>, 2> {
    ManifoldGaussian::new(
        Rn::new_unchecked(Vector2::new(0.0, 1.0)),
        Matrix2::identity(),
    )
    .unwrap()
}

/// A constant-velocity track drawn from the filter's model, measured at every step.
struct Track;

impl Scenario for Track {
    type Truth = Rn<f64, 2>;
    type Input = ();
    type Measurement = Vector1<f64>;
    type Steps<'s> = std::vec::IntoIter<StepOf<Self>>;

    fn epochs(&self) -> usize {
        20
    }

    fn simulate<'s>(&'s self, rng: &'s mut ChaCha8Rng) -> Result<Self::Steps<'s>, ExperimentError> {
        let q = process_noise().cholesky().unwrap().l();
        let prior = track_prior();
        let mut x = prior.mean().coords()
            + prior.cholesky_factor() * Vector2::new(normal(rng), normal(rng));
        let steps: Vec<_> = (1..=20)
            .map(|k| {
                x = transition() * x + q * Vector2::new(normal(rng), normal(rng));
                Step {
                    time: f64::from(k) * DT,
                    input: (),
                    truth: Rn::new_unchecked(x),
                    measurement: Some(Vector1::new(x[0] + R.sqrt() * normal(rng))),
                }
            })
            .collect();
        Ok(steps.into_iter())
    }
}

/// The track's models: EKF steps of linear functions (so the smoothers are exact).
fn track_models() -> (
    Ekf<impl ProcessModel<Rn<f64, 2>, 2, Input = ()>>,
    Ekf<impl MeasurementModel<Rn<f64, 2>, 2, 1>, 1>,
) {
    let process = ProcessFn::new(
        |x: &Rn<f64, 2>, (): &()| Rn::new_unchecked(transition() * x.coords()),
        |_, ()| process_noise(),
    )
    .with_jacobian(|_, ()| transition());
    let sensor = MeasurementFn::new(
        |x: &Rn<f64, 2>| Vector1::new(x.coords()[0]),
        |_| Matrix1::new(R),
    );
    (Ekf(process), Ekf(sensor))
}

/// Turn rate (rad per step), process variance (rad²), measurement sigma, prior mean and variance.
const RATE: f64 = 0.3;
const Q: f64 = 1e-3;
const SIGMA: f64 = 0.05;
const PRIOR_MEAN: f64 = 3.0;
const PRIOR_VARIANCE: f64 = 0.01;

fn heading_prior() -> ManifoldGaussian<So2<f64>, 1> {
    ManifoldGaussian::new(
        So2::from_angle_unchecked(PRIOR_MEAN),
        Matrix1::new(PRIOR_VARIANCE),
    )
    .unwrap()
}

/// A heading turning at a constant rate with process noise, measured as a unit vector every other
/// step (40 steps, 20 measurement epochs), across the ±π cut.
struct Heading;

impl Scenario for Heading {
    type Truth = So2<f64>;
    type Input = ();
    type Measurement = Vector2<f64>;
    type Steps<'s> = std::vec::IntoIter<StepOf<Self>>;

    fn epochs(&self) -> usize {
        20
    }

    fn simulate<'s>(&'s self, rng: &'s mut ChaCha8Rng) -> Result<Self::Steps<'s>, ExperimentError> {
        let mut x = So2::from_angle_unchecked(PRIOR_MEAN + PRIOR_VARIANCE.sqrt() * normal(rng));
        let steps: Vec<_> = (1..=40)
            .map(|k| {
                x = x.retract(&Vector1::new(RATE + Q.sqrt() * normal(rng)));
                let measurement = (k % 2 == 0).then(|| {
                    let (s, c) = x.angle().sin_cos();
                    Vector2::new(c + SIGMA * normal(rng), s + SIGMA * normal(rng))
                });
                Step {
                    time: f64::from(k),
                    input: (),
                    truth: x,
                    measurement,
                }
            })
            .collect();
        Ok(steps.into_iter())
    }
}

/// The heading's models (the unit-vector measurement is nonlinear).
fn heading_models() -> (
    Ekf<impl ProcessModel<So2<f64>, 1, Input = ()>>,
    Ekf<impl MeasurementModel<So2<f64>, 1, 2>, 2>,
) {
    let process = ProcessFn::new(
        |x: &So2<f64>, (): &()| x.retract(&Vector1::new(RATE)),
        |_, ()| Matrix1::new(Q),
    );
    let sensor = MeasurementFn::new(
        |x: &So2<f64>| {
            let (s, c) = x.angle().sin_cos();
            Vector2::new(c, s)
        },
        |_| Matrix2::identity() * (SIGMA * SIGMA),
    );
    (Ekf(process), Ekf(sensor))
}

/// The track's smoother `S` with its models.
macro_rules! track {
    ($smoother:expr) => {{
        let (process, sensor) = track_models();
        Smoothed::new($smoother, process, sensor)
    }};
}

/// The heading's smoother `S` with its models.
macro_rules! heading {
    ($smoother:expr) => {{
        let (process, sensor) = heading_models();
        Smoothed::new($smoother, process, sensor)
    }};
}

/// A study of `RUNS` runs (of `shard`) of `scenario` with the filters `build` makes.
fn study<S, F>(
    scenario: &S,
    shard: Shard,
    build: &(dyn Fn(&mut ChaCha8Rng) -> Result<F, OperatorError> + Sync),
) -> Summary
where
    S: Scenario,
    F: RecursiveFilter<Input = S::Input, Measurement = S::Measurement>,
    ManifoldScorer: liebayes_experiments::Scorer<S::Truth, F::Estimate>,
{
    let summary = Study::new("smoother", RUNS, 7, shard)
        .unwrap()
        .run(scenario, build, &ManifoldScorer, &|_| {})
        .unwrap();
    assert!(summary.failures().is_empty(), "{:?}", summary.failures());
    summary
}

/// At every epoch: the smoothed (and the filtered) mean NEES inside the two-sided band of the mean
/// of `RUNS` χ²(dof) values at level 10⁻⁴, and the smoothed RMSE below the filtered one except at
/// the last epoch, where the two estimates are the same for the RTS and fixed-lag smoothers
/// (`last_is_filtered`; the iterated smoother's last estimate is the MAP's, not the EKF's).
fn check_smoothed(summary: &Summary, dof: usize, last_is_filtered: bool) {
    let total = (dof as f64) * RUNS as f64;
    let band = (
        chi_square_quantile(-Z, total).unwrap() / RUNS as f64,
        chi_square_quantile(Z, total).unwrap() / RUNS as f64,
    );
    let series = |name: &str| summary.series(name).unwrap().epochs().to_vec();
    let (nees, smoothed_nees) = (series("nees"), series("smoothed_nees"));
    let (error, smoothed_error) = (series("error"), series("smoothed_error"));
    assert_eq!(smoothed_nees.len(), 20);
    for k in 0..20 {
        for (name, stats) in [("nees", &nees[k]), ("smoothed_nees", &smoothed_nees[k])] {
            assert_eq!(stats.count(), RUNS, "{name} at epoch {k}");
            let mean = stats.mean().unwrap();
            assert!(
                (band.0..=band.1).contains(&mean),
                "{name} at epoch {k}: {mean} outside [{}, {}]",
                band.0,
                band.1
            );
        }
        let rmse = |s: &liebayes_experiments::RunningStats| s.mean_square().unwrap().sqrt();
        let (filtered, smoothed) = (rmse(&error[k]), rmse(&smoothed_error[k]));
        if k < 19 {
            assert!(
                smoothed < filtered,
                "epoch {k}: smoothed RMSE {smoothed} >= {filtered}"
            );
        } else if last_is_filtered {
            assert_eq!(smoothed, filtered, "last epoch");
        }
    }
}

#[test]
fn rts_and_fixed_lag_smoothers_are_consistent_and_beat_the_filter_on_a_linear_track() {
    let rts = study(&Track, Shard::WHOLE, &|_| {
        Ok(track!(RtsSmoother::new(track_prior())))
    });
    check_smoothed(&rts, 2, true);
    let fixed = study(&Track, Shard::WHOLE, &|_| {
        Ok(track!(FixedLagSmoother::new(track_prior(), 3)?))
    });
    check_smoothed(&fixed, 2, true);
    // Same runs, same forward pass: the filtered figures agree bit for bit.
    assert_eq!(rts.series("nees"), fixed.series("nees"));
    // Three epochs of lag see less than the whole run: the first epoch's smoothed error differs.
    assert_ne!(rts.series("smoothed_error"), fixed.series("smoothed_error"));
}

#[test]
fn rts_and_fixed_lag_smoothers_are_consistent_on_a_nonlinear_heading() {
    let rts = study(&Heading, Shard::WHOLE, &|_| {
        Ok(heading!(RtsSmoother::new(heading_prior())))
    });
    check_smoothed(&rts, 1, true);
    let fixed = study(&Heading, Shard::WHOLE, &|_| {
        Ok(heading!(FixedLagSmoother::with_lag_seconds(
            heading_prior(),
            4.0,
            1.0,
        )?))
    });
    check_smoothed(&fixed, 1, true);
}

#[test]
fn the_iterated_smoother_runs_on_the_layer_and_is_consistent() {
    let iterated = study(&Heading, Shard::WHOLE, &|_| {
        let (process, sensor) = heading_models();
        Ok(Smoothed::new(
            IteratedSmoother::new(heading_prior()),
            process.0,
            sensor.0,
        ))
    });
    check_smoothed(&iterated, 1, false);
    // The same EKF forward pass as the RTS smoother's: the filtered figures agree bit for bit.
    let rts = study(&Heading, Shard::WHOLE, &|_| {
        Ok(heading!(RtsSmoother::new(heading_prior())))
    });
    assert_eq!(rts.series("nees"), iterated.series("nees"));
}

#[test]
fn three_shards_of_a_smoother_study_merge_bit_for_bit() {
    let build = |_: &mut ChaCha8Rng| Ok(heading!(FixedLagSmoother::new(heading_prior(), 2)?));
    let whole = study(&Heading, Shard::WHOLE, &build);
    let mut merged = Summary::default();
    for k in [2, 3, 1] {
        let part = study(&Heading, Shard::new(k, 3).unwrap(), &build);
        let text = serde_json::to_string(&part).unwrap();
        merged.merge(&serde_json::from_str(&text).unwrap()).unwrap();
    }
    let text = |s: &Summary| serde_json::to_string(s.metrics()).unwrap();
    assert_eq!(text(&merged), text(&whole));
    assert_eq!(merged.trace(), whole.trace());
    assert!(whole.series("smoothed_nees").is_some());
}

/// A recorded run holds, for each step, the estimate the operators' smoothers give it: the RTS
/// smoother's over the whole run, and the fixed-lag smoother's output L steps later (its window at
/// the end for the last L steps).
#[test]
fn a_recorded_run_holds_each_steps_smoothed_estimate() {
    let (mut simulation, _) = liebayes_experiments::run_rngs(3, 0);
    let steps: Vec<_> = Heading.simulate(&mut simulation).unwrap().collect();
    let lag = 5;
    let recorded = record(
        &mut heading!(FixedLagSmoother::new(heading_prior(), lag).unwrap()),
        steps.clone(),
    )
    .unwrap();
    let rts = record(
        &mut heading!(RtsSmoother::new(heading_prior())),
        steps.clone(),
    )
    .unwrap();
    // The same run by hand.
    let mut by_hand = heading!(FixedLagSmoother::new(heading_prior(), lag).unwrap());
    let mut lagged = Vec::new();
    for step in &steps {
        by_hand.predict(&step.input).unwrap();
        if let Some(z) = &step.measurement {
            by_hand.update(z).unwrap();
        }
        let mut smoother = by_hand.smoother().clone();
        if let Some(density) = smoother.smooth().unwrap().lagged() {
            lagged.push(density.clone());
        }
    }
    let mut last = by_hand.smoother().clone();
    let window: Vec<_> = last.smooth().unwrap().iter().skip(1).cloned().collect();
    lagged.extend(window);
    // The prior's epoch is not a step: the first lagged output is epoch 0's.
    let outputs = &lagged[1..];
    assert_eq!(outputs.len(), steps.len());
    assert_eq!(recorded.smoothed.len(), steps.len());
    for (k, (smoothed, expected)) in recorded.smoothed.iter().zip(outputs).enumerate() {
        assert_eq!(smoothed, expected, "step {k}");
    }
    let mut whole = RtsSmoother::new(heading_prior());
    let (process, sensor) = heading_models();
    for step in &steps {
        whole.propagate(&process, &step.input).unwrap();
        if let Some(z) = &step.measurement {
            whole.condition(&sensor, z).unwrap();
        }
    }
    let smoothed = whole.smooth().unwrap();
    assert_eq!(rts.smoothed.len(), rts.steps.len());
    for (k, step) in rts.smoothed.iter().enumerate() {
        assert_eq!(step, &smoothed[k + 1], "RTS step {k}");
    }
}

/// A fixed-lag smoother whose backward pass fails at some steps goes on releasing after them: each
/// failed release skips the one step it was to give (its error reports it), and every other step
/// is released once. A random walk whose transition into steps 1, 1001 and 2001 records a noise Ω
/// of −10 P′ (not positive semi-definite, as a user's own `GaussianTransition` might): the backward
/// pass fails on the windows that hold that transition, and only on those.
#[test]
fn a_fixed_lag_release_that_fails_skips_its_step_and_the_next_ones_go_on() {
    use liebayes_experiments::Smoothing;
    use liebayes_operators::smoother::{GaussianTransition, Prediction};
    /// The walk's EKF prediction, its record corrupted when the input says so.
    struct Corrupted<P>(Ekf<P>);
    impl<P: ProcessModel<Rn<f64, 1>, 1, Input = ()>> GaussianTransition<Rn<f64, 1>, 1>
        for Corrupted<P>
    {
        type Input = bool;
        fn predict_with_cross(
            &self,
            prior: &ManifoldGaussian<Rn<f64, 1>, 1>,
            corrupt: &bool,
        ) -> Result<Prediction<Rn<f64, 1>, 1>, OperatorError> {
            let mut prediction = self.0.predict_with_cross(prior, &())?;
            if *corrupt {
                prediction.noise = prediction.density.covariance() * -10.0;
            }
            Ok(prediction)
        }
    }
    let walk = ProcessFn::new(|x: &Rn<f64, 1>, (): &()| *x, |_, ()| Matrix1::new(0.1))
        .with_jacobian(|_, ()| Matrix1::identity());
    let sensor = MeasurementFn::new(|x: &Rn<f64, 1>| *x.coords(), |_| Matrix1::new(1.0));
    let prior =
        ManifoldGaussian::new(Rn::new(Vector1::new(0.0)).unwrap(), Matrix1::new(1.0)).unwrap();
    let (lag, every, steps) = (3, 1000, 3000);
    let mut smoother = Smoothed::new(
        FixedLagSmoother::new(prior, lag).unwrap(),
        Corrupted(Ekf(walk)),
        Ekf(sensor),
    );
    let (mut released, mut failed, mut out) = (0, Vec::new(), Vec::new());
    for k in 1..=steps {
        smoother.predict(&(k % every == 1)).unwrap();
        smoother.update(&Vector1::new(0.5)).unwrap();
        out.clear();
        match smoother.release(false, &mut out) {
            Ok(()) => released += out.len(),
            Err(_) => failed.push(k),
        }
    }
    // The windows that hold a corrupted transition: those of the lag's steps after it (the first,
    // into step 1, leaves the window before any step is due for release).
    assert_eq!(failed, [1001, 1002, 1003, 2001, 2002, 2003]);
    out.clear();
    smoother.release(true, &mut out).unwrap();
    released += out.len();
    assert_eq!(released + failed.len(), steps);
}
