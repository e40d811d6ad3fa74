//! The filter law suite: the laws every recursive filter obeys, each a function usable on its own,
//! and all of them at once through [`filter_laws!`](crate::filter_laws) (feature `proptest`).
//!
//! | law | function | what fails it |
//! |---|---|---|
//! | a step is all or nothing: an input or a measurement with an extreme value (NaN, ±∞, ±`f64::MAX`, 1e300, subnormals, ±0) is refused with the estimate unchanged, or accepted with a valid estimate | [`check_all_or_nothing`] | a NaN estimate returned as Ok, a half-applied step |
//! | consistency: the NEES (and the NIS, where the filter reports it) at the last measurement epoch of independent simulated runs lies in the two-sided 99.9 % band of the mean of χ² values | [`check_consistent`] | an over-confident or a uselessly cautious filter |
//! | a mis-specified measurement noise (its standard deviation 10 times too small, and 10 times too large) is caught by the same band | [`check_misspecified_caught`] | a band too wide to see anything |
//! | for a filter known to be inconsistent: a measurement noise assumed 10 times too small raises the median NEES (NIS) at least 2 times | [`check_misspecified_moves`] | a filter that ignores the measurement noise it is told |
//!
//! A filter takes part by implementing [`FilterLawSubject`]: its scenario, how to build it with a
//! scaled measurement noise, its NEES, what a valid estimate is, and how to put an extreme value
//! into an input and a measurement.
//!
//! **The band** is the one for independent runs: the sum of R values χ²(d) is χ²(R d), so their mean
//! per degree of freedom lies in `[q(0.0005), q(0.9995)] / (R d)` for a consistent filter (q the
//! exact χ²(R d) quantile, [`chi_square_quantile`]). The last epoch of each run is taken (epochs of one run are correlated;
//! runs are not).
//!
//! **Other seeds, more runs.** A law's verdict is that of its seed and its run count. A filter
//! that passes at [`SEED`] only by luck, or whose deviation is smaller than the band at its run
//! count can see, shows at other seeds ([`SEED_VARIABLE`]) and with more runs
//! ([`RUN_FACTOR_VARIABLE`]): check a new line both ways before calling it consistent, at many
//! seeds (a statistic near its band's edge leaves it at a few seeds in a hundred; a consistent
//! line's two-sided 99.9 % band, at about one in a thousand).

use crate::filter::{Nis, RecursiveFilter};
use crate::replay::{Scenario, StepOf};
use crate::run_rngs;
use liebayes_operators::evaluation::chi_square_quantile;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use rand_chacha::ChaCha8Rng;
use std::fmt::Debug;

#[doc(hidden)]
pub use proptest as __proptest;

/// The seed of every run of the laws (run k draws from [`run_rngs`]`(SEED, k)`), unless
/// [`SEED_VARIABLE`] gives another.
pub const SEED: u64 = 2026;

/// The environment variable that replaces [`SEED`] (a decimal `u64`): the laws' verdicts on data
/// they were not written on, `LIEBAYES_LAW_SEED=7 cargo test --test filter_laws`.
pub const SEED_VARIABLE: &str = "LIEBAYES_LAW_SEED";

/// The environment variable whose value (a decimal integer ≥ 1) multiplies every subject's
/// [`FilterLawSubject::runs`]: a more decisive band (ten times the runs narrow it about three
/// times) for a check by hand, `LIEBAYES_LAW_RUN_FACTOR=10 cargo test --test filter_laws`.
pub const RUN_FACTOR_VARIABLE: &str = "LIEBAYES_LAW_RUN_FACTOR";

/// The value of the environment variable `name` as a `u64`, `default` when it is not set.
///
/// # Errors
/// When it is set but is not a decimal `u64`.
fn setting(name: &str, default: u64) -> Result<u64, String> {
    parse_setting(name, std::env::var(name), default)
}

/// [`setting`] of the variable's value as read.
fn parse_setting(
    name: &str,
    value: Result<String, std::env::VarError>,
    default: u64,
) -> Result<u64, String> {
    match value {
        Err(std::env::VarError::NotPresent) => Ok(default),
        Ok(text) => text
            .trim()
            .parse()
            .map_err(|_| format!("{name}={text:?}: expected a decimal integer")),
        Err(std::env::VarError::NotUnicode(text)) => {
            Err(format!("{name}={text:?}: expected a decimal integer"))
        }
    }
}

/// Cases of the all-or-nothing law in [`filter_laws!`](crate::filter_laws).
pub const CASES: u32 = 32;

/// The standard normal quantile of the band's ends (99.95 %: a two-sided 99.9 % band).
const Z: f64 = 3.290_526_731_491_926;

/// The factor the mis-specified filters scale the measurement noise's standard deviation by (and
/// divide it by).
pub const MISSPECIFIED: f64 = 10.0;

/// A filter as the laws exercise it.
pub trait FilterLawSubject: Sync {
    /// The scenario the filter is run on.
    type Scenario: Scenario;
    /// The filter.
    type Filter: RecursiveFilter<
            Input = <Self::Scenario as Scenario>::Input,
            Measurement = <Self::Scenario as Scenario>::Measurement,
            Estimate: Debug + PartialEq,
        >;

    /// The scenario (its simulated runs are the laws' data).
    fn scenario(&self) -> &Self::Scenario;

    /// The filter for one run, assuming a measurement noise whose standard deviation is `noise`
    /// times the scenario's (1: the true model); `rng` is the run's filter stream.
    ///
    /// # Errors
    /// When the filter cannot be built (its settings out of range).
    fn filter(
        &self,
        noise: f64,
        rng: &mut ChaCha8Rng,
    ) -> Result<Self::Filter, Box<dyn std::error::Error + Send + Sync>>;

    /// The NEES of `estimate` against the truth, with its degrees of freedom (`None` for an
    /// estimate that reports no uncertainty: the consistency laws then do not apply).
    fn nees(
        &self,
        truth: &<Self::Scenario as Scenario>::Truth,
        estimate: &<Self::Filter as RecursiveFilter>::Estimate,
    ) -> Option<Nis>;

    /// Whether an estimate is valid: finite, on its manifold, a positive definite covariance.
    fn valid(&self, estimate: &<Self::Filter as RecursiveFilter>::Estimate) -> bool;

    /// `input` with the extreme `value` put into it (into one of its components).
    fn corrupt_input(
        &self,
        input: &<Self::Scenario as Scenario>::Input,
        value: f64,
    ) -> <Self::Scenario as Scenario>::Input;

    /// `z` with the extreme `value` put into it.
    fn corrupt_measurement(
        &self,
        z: &<Self::Scenario as Scenario>::Measurement,
        value: f64,
    ) -> <Self::Scenario as Scenario>::Measurement;

    /// Independent runs of the consistency laws, 1 to [`MAX_LAW_RUNS`] (checked when the laws
    /// run: none would pass them without looking at any data).
    fn runs(&self) -> u64 {
        100
    }
}

/// Extreme values for the all-or-nothing law: NaN, ±∞, ±`f64::MAX`, 1e300, −1e200, the smallest
/// subnormal, a subnormal, ±0, and ordinary magnitudes from 1e-300 to 1e30.
pub fn extreme_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(f64::MAX),
        Just(-f64::MAX),
        Just(1e300),
        Just(-1e200),
        Just(5e-324),
        Just(1e-310),
        Just(0.0),
        Just(-0.0),
        (-300.0..30.0_f64).prop_map(|e| 10f64.powf(e)),
    ]
}

/// A run's steps and its filter.
type Run<S> = (
    Vec<StepOf<<S as FilterLawSubject>::Scenario>>,
    <S as FilterLawSubject>::Filter,
);

/// The steps of run `run` and its filter (assuming `noise` times the measurement noise).
fn start<S: FilterLawSubject>(subject: &S, run: u64, noise: f64) -> Result<Run<S>, String> {
    let (mut simulation, mut randomness) = run_rngs(setting(SEED_VARIABLE, SEED)?, run);
    let steps: Vec<_> = subject
        .scenario()
        .simulate(&mut simulation)
        .map_err(|e| format!("run {run}: the scenario: {e}"))?
        .collect();
    let filter = subject
        .filter(noise, &mut randomness)
        .map_err(|e| format!("run {run}: building the filter: {e}"))?;
    Ok((steps, filter))
}

/// A step is all or nothing: run `run` is stepped to its step `at` (modulo its length); then the
/// next input, or (`measurement`) the next measurement, gets the extreme `value`. The filter must
/// either refuse it, its estimate then bitwise the one before, or accept it with a valid estimate.
///
/// # Errors
/// A [`TestCaseError`] naming the step, the value and what went wrong.
pub fn check_all_or_nothing<S: FilterLawSubject>(
    subject: &S,
    run: u64,
    at: usize,
    measurement: bool,
    value: f64,
) -> Result<(), TestCaseError> {
    let (steps, mut filter) = start(subject, run, 1.0).map_err(TestCaseError::fail)?;
    if steps.is_empty() {
        return Err(TestCaseError::fail("the scenario has no step"));
    }
    let at = at % steps.len();
    for step in &steps[..at] {
        step_through(&mut filter, step).map_err(TestCaseError::fail)?;
    }
    let step = &steps[at];
    let case = format!("step {at}, value {value:e}");
    let before = filter.estimate().ok();
    let outcome = if measurement {
        filter
            .predict(&step.input)
            .map_err(|e| TestCaseError::fail(format!("{case}: a genuine input refused: {e}")))?;
        let Some(z) = &step.measurement else {
            return Ok(());
        };
        let before = filter.estimate().ok();
        let bad = subject.corrupt_measurement(z, value);
        (filter.update(&bad).map(|_| ()), before)
    } else {
        let bad = subject.corrupt_input(&step.input, value);
        (filter.predict(&bad), before)
    };
    match outcome {
        (Err(_), before) => {
            let after = filter.estimate().ok();
            prop_assert_eq!(after, before, "{}: refused, but the estimate changed", case);
        }
        (Ok(()), _) => {
            let estimate = filter
                .estimate()
                .map_err(|e| TestCaseError::fail(format!("{case}: accepted, no estimate: {e}")))?;
            prop_assert!(
                subject.valid(&estimate),
                "{}: accepted with an invalid estimate {:?}",
                case,
                estimate
            );
        }
    }
    Ok(())
}

/// One step of the scenario through the filter.
fn step_through<F: RecursiveFilter>(
    filter: &mut F,
    step: &crate::Step<impl Sized, F::Input, F::Measurement>,
) -> Result<(), String>
where
    F::Input: Sized,
    F::Measurement: Sized,
{
    filter
        .predict(&step.input)
        .map_err(|e| format!("t = {}: predict: {e}", step.time))?;
    if let Some(z) = &step.measurement {
        filter
            .update(z)
            .map_err(|e| format!("t = {}: update: {e}", step.time))?;
    }
    Ok(())
}

/// A consistency statistic over independent runs: its mean per degree of freedom and the two-sided
/// 99.9 % band a consistent filter's mean lies in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Band {
    /// Mean of the statistic over the runs, divided by its degrees of freedom.
    pub mean: f64,
    /// The band's ends, per degree of freedom.
    pub band: (f64, f64),
    /// The statistic's degrees of freedom.
    pub dof: usize,
    /// The runs summed.
    pub runs: u64,
}

impl Band {
    /// Whether the mean lies in the band.
    pub fn holds(&self) -> bool {
        self.band.0 <= self.mean && self.mean <= self.band.1
    }

    /// The band of `runs` values of χ²(`dof`) summing to `sum`.
    fn of(sum: f64, dof: usize, runs: u64) -> Result<Self, String> {
        let total = (dof as f64) * runs as f64;
        let quantile = |z: f64| chi_square_quantile(z, total).map_err(|e| e.to_string());
        Ok(Self {
            mean: sum / total,
            band: (quantile(-Z)? / total, quantile(Z)? / total),
            dof,
            runs,
        })
    }
}

/// The most runs [`FilterLawSubject::runs`] may ask of the consistency laws (each simulates and
/// filters a whole scenario).
pub const MAX_LAW_RUNS: u64 = 1_000_000;

/// The NEES and, where the filter reports it, the NIS at the last measurement epoch of each of
/// the subject's runs (in run order), with the filter assuming `noise` times the measurement
/// noise's standard deviation. The NEES is empty when the estimate reports no uncertainty.
///
/// The runs are `runs()` times [`RUN_FACTOR_VARIABLE`]'s value (1 when it is not set), drawn from
/// [`SEED`] or [`SEED_VARIABLE`]'s value.
///
/// # Errors
/// When `runs()` (or its product with the factor) is outside 1 to [`MAX_LAW_RUNS`], either
/// variable is set to anything but a decimal integer, a run cannot be simulated or built, or a
/// step fails (a consistent filter's runs all complete).
pub fn last_epoch_statistics<S: FilterLawSubject>(
    subject: &S,
    noise: f64,
) -> Result<(Vec<Nis>, Vec<Nis>), String> {
    let runs = subject.runs();
    if !(1..=MAX_LAW_RUNS).contains(&runs) {
        return Err(format!(
            "runs() is {runs}: the consistency laws take 1 to {MAX_LAW_RUNS} runs"
        ));
    }
    let factor = setting(RUN_FACTOR_VARIABLE, 1)?;
    let runs = runs
        .checked_mul(factor)
        .filter(|r| (1..=MAX_LAW_RUNS).contains(r))
        .ok_or_else(|| {
            format!(
                "{RUN_FACTOR_VARIABLE}={factor} times runs() ({runs}): the consistency laws take \
                 1 to {MAX_LAW_RUNS} runs"
            )
        })?;
    let (mut nees, mut nis) = (Vec::new(), Vec::new());
    for run in 0..runs {
        let (steps, mut filter) = start(subject, run, noise)?;
        let mut last = None;
        for step in &steps {
            filter
                .predict(&step.input)
                .map_err(|e| format!("run {run}, t = {}: predict: {e}", step.time))?;
            if let Some(z) = &step.measurement {
                let update = filter
                    .update(z)
                    .map_err(|e| format!("run {run}, t = {}: update: {e}", step.time))?;
                let estimate = filter
                    .estimate()
                    .map_err(|e| format!("run {run}, t = {}: estimate: {e}", step.time))?;
                last = Some((step, estimate, update.nis));
            }
        }
        let Some((step, estimate, last_nis)) = last else {
            return Err(format!("run {run}: the scenario has no measurement"));
        };
        nees.extend(subject.nees(&step.truth, &estimate));
        nis.extend(last_nis);
    }
    Ok((nees, nis))
}

/// The band of the mean of these statistics (`None` for none).
fn band_of(values: &[Nis]) -> Result<Option<Band>, String> {
    let Some(first) = values.first() else {
        return Ok(None);
    };
    let sum: f64 = values.iter().map(|n| n.value).sum();
    Band::of(sum, first.dof, values.len() as u64).map(Some)
}

/// The NEES and, where the filter reports it, the NIS at the last measurement epoch of each of
/// the subject's runs ([`last_epoch_statistics`]), as the mean per degree of freedom with its
/// two-sided 99.9 % band. `None` for the NEES when the estimate reports no uncertainty.
///
/// # Errors
/// As [`last_epoch_statistics`].
pub fn consistency<S: FilterLawSubject>(
    subject: &S,
    noise: f64,
) -> Result<(Option<Band>, Option<Band>), String> {
    let (nees, nis) = last_epoch_statistics(subject, noise)?;
    Ok((band_of(&nees)?, band_of(&nis)?))
}

/// Consistency: with the true measurement noise, the NEES and the NIS (where there are) lie in
/// their bands.
///
/// # Panics
/// When a band does not hold or a run fails (a test's failure, with the figures).
pub fn check_consistent<S: FilterLawSubject>(subject: &S) {
    let (nees, nis) = consistency(subject, 1.0).unwrap_or_else(|e| panic!("{e}"));
    for (what, band) in [("NEES", nees), ("NIS", nis)] {
        if let Some(b) = band {
            assert!(
                b.holds(),
                "{what} per degree of freedom {b:?} outside its band"
            );
        }
    }
}

/// A mis-specified measurement noise is caught: with its standard deviation [`MISSPECIFIED`] times
/// too small (an over-confident filter) and too large (a cautious one), the NEES (or, for a filter
/// without one, the NIS) falls outside its band, or a run fails.
///
/// # Panics
/// When a mis-specified filter passes the band (a test's failure, with the figures).
pub fn check_misspecified_caught<S: FilterLawSubject>(subject: &S) {
    for noise in [1.0 / MISSPECIFIED, MISSPECIFIED] {
        match consistency(subject, noise) {
            // A run that fails is caught too.
            Err(_) => {}
            Ok((nees, nis)) => {
                let band = nees.or(nis).expect("a NEES or a NIS to check");
                assert!(
                    !band.holds(),
                    "the measurement noise scaled by {noise} passes: {band:?}"
                );
            }
        }
    }
}

/// How far the median statistic must rise when the measurement noise is assumed
/// [`MISSPECIFIED`] times too small, for a filter known to be inconsistent
/// ([`check_misspecified_moves`]).
pub const MOVES_BY: f64 = 2.0;

/// A mis-specified measurement noise moves the statistic the right way, for a filter whose
/// consistency is already known to fail (so that the band cannot tell): with the noise's standard
/// deviation [`MISSPECIFIED`] times too small, the median over the runs of the NEES (or, without
/// one, the NIS) at the last epoch is at least [`MOVES_BY`] times the true model's: the filter is
/// more over-confident; a run that fails counts as caught. A filter that ignores the noise it is
/// told to assume fails this law.
///
/// Only the over-confident side is a law here: an approximate filter told that the noise is 10
/// times larger than it is may leave the region where its approximation holds (a von Mises-Fisher
/// concentration of 4, a normal angle model of 30°) and report anything. The median, not the mean:
/// a filter known to be inconsistent may report a NEES of +∞ in a few runs.
///
/// # Panics
/// When the true model's runs fail, or the over-confident filter's median does not rise by
/// [`MOVES_BY`] (a test's failure, with the figures).
pub fn check_misspecified_moves<S: FilterLawSubject>(subject: &S) {
    let median = |noise: f64| -> Result<f64, String> {
        let (nees, nis) = last_epoch_statistics(subject, noise)?;
        let mut values: Vec<f64> = if nees.is_empty() { nis } else { nees }
            .iter()
            .map(|n| n.value)
            .collect();
        assert!(!values.is_empty(), "a NEES or a NIS to check");
        values.sort_by(f64::total_cmp);
        Ok(values[values.len() / 2])
    };
    let truth = median(1.0).unwrap_or_else(|e| panic!("the true model: {e}"));
    if let Ok(small) = median(1.0 / MISSPECIFIED) {
        assert!(
            small >= MOVES_BY * truth,
            "the noise scaled by {}: median {small}, not {MOVES_BY} times the true model's {truth}",
            1.0 / MISSPECIFIED
        );
    }
}

/// The filter law suite in one line: `filter_laws!(name, subject)` defines a test module `name`
/// running [`check_all_or_nothing`] ([`CASES`] cases of run, step, input or measurement, and an
/// [`extreme_f64`]), [`check_consistent`] and [`check_misspecified_caught`] on `subject` (an
/// expression of a type implementing [`FilterLawSubject`]). Add `no_uncertainty` after the subject
/// for a filter that reports none (the consistency laws then do not apply), or
/// `known_inconsistent("why, measured")` for an approximation known to fail the consistency law on
/// the subject's scenario: its consistency test is then ignored with that reason (run it with
/// `--ignored` to see the figures), the band cannot tell a mis-specified noise from the true one,
/// so [`check_misspecified_moves`] replaces [`check_misspecified_caught`], and the other laws run.
#[macro_export]
macro_rules! filter_laws {
    ($name:ident, $subject:expr) => {
        $crate::filter_laws!(@module $name, $subject, {
            #[test]
            fn consistent() {
                $crate::testing::check_consistent(&$subject);
            }

            #[test]
            fn misspecified_noise_is_caught() {
                $crate::testing::check_misspecified_caught(&$subject);
            }
        });
    };
    ($name:ident, $subject:expr, no_uncertainty) => {
        $crate::filter_laws!(@module $name, $subject, {});
    };
    ($name:ident, $subject:expr, known_inconsistent($why:literal)) => {
        $crate::filter_laws!(@module $name, $subject, {
            #[test]
            #[ignore = $why]
            fn consistent() {
                $crate::testing::check_consistent(&$subject);
            }

            #[test]
            fn misspecified_noise_moves_the_statistic() {
                $crate::testing::check_misspecified_moves(&$subject);
            }
        });
    };
    (@module $name:ident, $subject:expr, { $($laws:tt)* }) => {
        mod $name {
            #[allow(unused_imports)]
            use super::*;
            use $crate::testing::__proptest::prelude::*;

            $crate::testing::__proptest::proptest! {
                #![proptest_config(ProptestConfig::with_cases($crate::testing::CASES))]

                #[test]
                fn all_or_nothing(
                    run in 0_u64..4,
                    at in 0_usize..10_000,
                    measurement in any::<bool>(),
                    value in $crate::testing::extreme_f64(),
                ) {
                    $crate::testing::check_all_or_nothing(&$subject, run, at, measurement, value)?;
                }
            }

            $($laws)*
        }
    };
}

#[cfg(test)]
mod tests {
    use super::parse_setting;
    use std::env::VarError;

    #[test]
    fn a_setting_is_its_default_when_unset_and_refused_unless_an_integer() {
        let parse = |value| parse_setting("LIEBAYES_LAW_SEED", value, 2026);
        assert_eq!(parse(Err(VarError::NotPresent)), Ok(2026));
        assert_eq!(parse(Ok("7".into())), Ok(7));
        assert_eq!(parse(Ok(" 10\n".into())), Ok(10));
        for bad in ["", "-1", "1.5", "ten", "18446744073709551616"] {
            let message = parse(Ok(bad.into())).unwrap_err();
            assert!(message.contains("LIEBAYES_LAW_SEED"), "{message}");
        }
    }
}
