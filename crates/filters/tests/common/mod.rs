//! What the filters' long-run tests share: the run loop and the covariance check.

use liebayes_experiments::{RecursiveFilter, Scenario};
use nalgebra::{DMatrix, SMatrix};
use rand_chacha::ChaCha8Rng;
use std::fmt::Debug;

/// Steps `filter` through `steps` steps of `scenarios`' runs, one after another without resetting
/// it (so the truth jumps at every new run), each measurement first passed to `corrupt` with the
/// number of measurements before it; returns the refused steps. After every step, refused or not,
/// the estimate must satisfy `valid`, and a refused predict or update must leave it as it was.
pub fn run<S, F>(
    filter: &mut F,
    scenarios: &[S],
    steps: u64,
    rng: &mut ChaCha8Rng,
    mut corrupt: impl FnMut(&mut S::Measurement, u64),
    valid: impl Fn(&F::Estimate) -> bool,
) -> u64
where
    S: Scenario,
    F: RecursiveFilter<Input = S::Input, Measurement = S::Measurement> + ?Sized,
    F::Estimate: PartialEq + Debug,
{
    let (mut done, mut refused, mut measured) = (0_u64, 0_u64, 0_u64);
    for scenario in scenarios.iter().cycle() {
        for step in scenario.simulate(rng).expect("a run of the scenario") {
            if done == steps {
                return refused;
            }
            let before = filter.estimate().ok();
            if filter.predict(&step.input).is_err() {
                refused += 1;
                assert_eq!(
                    filter.estimate().ok(),
                    before,
                    "step {done}: a refused predict"
                );
            }
            if let Some(mut z) = step.measurement {
                corrupt(&mut z, measured);
                measured += 1;
                let before = filter.estimate().ok();
                if filter.update(&z).is_err() {
                    refused += 1;
                    assert_eq!(
                        filter.estimate().ok(),
                        before,
                        "step {done}: a refused update"
                    );
                }
            }
            let estimate = filter.estimate().expect("an estimate");
            assert!(valid(&estimate), "step {done}: {estimate:?}");
            done += 1;
        }
    }
    refused
}

/// A covariance is valid: finite, symmetric, with no negative eigenvalue beyond rounding (relative
/// to its largest entry, and absolute below f64::MIN_POSITIVE: particles collapsed onto one point
/// give a covariance of subnormal entries, whose eigenvalues carry rounding of that size), and
/// positive definite when `definite`.
pub fn valid_covariance<const D: usize>(p: &SMatrix<f64, D, D>, definite: bool) -> bool {
    let p = DMatrix::from_column_slice(D, D, p.as_slice());
    let scale = p.amax();
    p.iter().all(|x| x.is_finite())
        && (&p - p.transpose()).amax() <= 1e-12 * scale
        && p.clone().symmetric_eigenvalues().min() >= -(1e-12 * scale).max(f64::MIN_POSITIVE)
        && (!definite || p.cholesky().is_some())
}

/// The steps of a long run: `LIEBAYES_LONG_RUN_STEPS`, 10⁸ when it is not set.
pub fn long_run_steps() -> u64 {
    std::env::var("LIEBAYES_LONG_RUN_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000_000)
}
