//! A bad-input harness any crate's tests can use: an input generator that draws the floating-point
//! values libraries get wrong (NaN, ±∞, ±f64::MAX, ±MIN_POSITIVE, subnormals, ±0, 1e±300, ordinary
//! numbers), a per-call wrapper that runs each call on its own thread (a panic is reported with
//! the call's name), and the checks a result must pass (an error, or a finite value).
//!
//! Every crate's `bad_input` tests use it, so one command runs the whole library's harness (see
//! the reliability page of the docs). Environment:
//!
//! * `LIEBAYES_FUZZ_CASES`: proptest cases per test (default 64, sized for CI);
//! * `LIEBAYES_FUZZ_SEED`: the seed of the input generator (default 0, so CI runs are reproducible);
//! * `LIEBAYES_FUZZ_TIMEOUT_MS`: a time limit per call, for a speed audit run by hand (unset by
//!   default: then no outcome depends on the machine's speed or load, and the clock is not read).
//!
//! The work of every entry point is bounded by construction (term and iteration caps, sizes
//! refused before allocation), so a call cannot hang; a regression that loops shows as a test
//! that does not end, not as one that fails on a busy machine.
//!
//! [`summary`] prints the counts of calls and of errors returned; panics and non-finite results
//! fail the test at the call that produced them, so a passing run has none.

use nalgebra::{SMatrix, Scalar};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Calls made through [`call`].
static CALLS: AtomicU64 = AtomicU64::new(0);
/// Calls that returned an error.
static ERRORS: AtomicU64 = AtomicU64::new(0);
/// The slowest call, in microseconds (measured only under a [`time_limit`]).
static SLOWEST_MICROS: AtomicU64 = AtomicU64::new(0);

/// The values every numeric argument is drawn from most of the time.
pub const SPECIAL: [f64; 22] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::MAX,
    -f64::MAX,
    f64::MIN_POSITIVE,
    -f64::MIN_POSITIVE,
    5e-324,
    -5e-324,
    1e-310,
    -1e-310,
    0.0,
    -0.0,
    1e300,
    -1e300,
    1e-300,
    -1e-300,
    1.0,
    -1.0,
    0.5,
    std::f64::consts::PI,
    -std::f64::consts::PI,
];

/// Proptest cases per test: `LIEBAYES_FUZZ_CASES`, default 64.
pub fn cases() -> u32 {
    std::env::var("LIEBAYES_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(64)
}

/// The generator's seed: `LIEBAYES_FUZZ_SEED`, default 0.
pub fn seed() -> u64 {
    std::env::var("LIEBAYES_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// The time limit per call: `LIEBAYES_FUZZ_TIMEOUT_MS`, none unless it is set.
pub fn time_limit() -> Option<Duration> {
    std::env::var("LIEBAYES_FUZZ_TIMEOUT_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .map(Duration::from_millis)
}

/// One number: a special value (half the time), an ordinary one in [−10, 10], or ± a log-uniform
/// magnitude from 1e-320 to 1e308.
pub fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => proptest::sample::select(&SPECIAL[..]),
        2 => -10.0..10.0_f64,
        2 => (-320.0..308.0_f64, any::<bool>())
            .prop_map(|(e, negative)| if negative { -(10f64.powf(e)) } else { 10f64.powf(e) }),
    ]
}

/// A non-negative number drawn like [`value`] (magnitudes of the same values).
pub fn magnitude() -> impl Strategy<Value = f64> {
    value().prop_map(f64::abs)
}

/// A size a user might pass to a constructor whose largest accepted size is `maximum`: small ones
/// (built for real), `maximum + 1`, huge ones and `usize::MAX` (to be refused before any
/// allocation). Sizes just below `maximum` are not drawn: accepting them is correct and allocates
/// gigabytes.
pub fn size(maximum: usize) -> impl Strategy<Value = usize> {
    prop_oneof![
        4 => 0..40_usize,
        1 => Just(maximum.saturating_add(1)),
        1 => Just(1_usize << 40),
        1 => Just(usize::MAX / 2),
        1 => Just(usize::MAX),
    ]
}

/// Runs a property over `strategy` for [`cases`] cases (no persistence, no forking), then prints the
/// [`summary`] under `name`.
///
/// # Panics
/// Where the property fails (a call panicked, hung or returned a non-finite value).
pub fn run<S: Strategy>(name: &str, strategy: S, property: impl Fn(S::Value))
where
    S::Value: std::fmt::Debug,
{
    let mut seed = [0u8; 32];
    seed[..8].copy_from_slice(&self::seed().to_le_bytes());
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: cases(),
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &seed),
    );
    let result = runner.run(&strategy, |input| {
        property(input);
        Ok(())
    });
    if let Err(failure) = result {
        panic!("{name}: {failure}");
    }
    summary(name);
}

/// Prints the calls made so far, the errors among them and, under a [`time_limit`], the slowest
/// call.
pub fn summary(name: &str) {
    let slowest = if time_limit().is_some() {
        format!(
            ", slowest call {} us",
            SLOWEST_MICROS.load(Ordering::Relaxed)
        )
    } else {
        String::new()
    };
    eprintln!(
        "{name}: {} calls, {} errors returned{slowest}; 0 panics, 0 non-finite results",
        CALLS.load(Ordering::Relaxed),
        ERRORS.load(Ordering::Relaxed),
    );
}

/// Runs `f` on its own thread and returns its result.
///
/// # Panics
/// If `f` panics (the panic is reported with `name`), or, under a [`time_limit`], has not returned
/// within it (the thread is left behind).
pub fn call<T: Send + 'static>(name: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    CALLS.fetch_add(1, Ordering::Relaxed);
    let (sender, receiver) = mpsc::channel();
    let limit = time_limit();
    let start = limit.map(|_| Instant::now());
    let handle = std::thread::spawn(move || {
        let _ = sender.send(f());
    });
    let received = match limit {
        Some(limit) => receiver.recv_timeout(limit).map_err(|e| match e {
            mpsc::RecvTimeoutError::Timeout => {
                panic!("{name} did not return within {limit:?} (LIEBAYES_FUZZ_TIMEOUT_MS)")
            }
            mpsc::RecvTimeoutError::Disconnected => (),
        }),
        None => receiver.recv().map_err(|_| ()),
    };
    if let Ok(value) = received {
        if let Some(start) = start {
            let micros = u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX);
            SLOWEST_MICROS.fetch_max(micros, Ordering::Relaxed);
        }
        let _ = handle.join();
        return value;
    }
    let message = handle
        .join()
        .err()
        .and_then(|p| {
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| (*s).to_owned()))
        })
        .unwrap_or_default();
    panic!("{name} panicked: {message}");
}

/// Runs `f` on this thread and returns its result: for the fixed reproductions of a suite, which
/// must return at once. Their work is bounded by construction; for a speed audit by hand, run the
/// suites in release with `LIEBAYES_FUZZ_TIMEOUT_MS=1` to hold every reproduction to a
/// millisecond (without it the clock is not read).
///
/// # Panics
/// Under a [`time_limit`], if `f` returned later than the limit.
pub fn quick<T>(name: &str, f: impl FnOnce() -> T) -> T {
    let Some(limit) = time_limit() else {
        return f();
    };
    let start = Instant::now();
    let value = f();
    let elapsed = start.elapsed();
    assert!(
        elapsed <= limit,
        "{name} took {elapsed:?}, more than {limit:?} (LIEBAYES_FUZZ_TIMEOUT_MS)"
    );
    value
}

/// What a returned value must satisfy: finite numbers, points on their manifold, densities with a
/// finite normaliser. Returns a description of the violation.
pub trait Valid {
    /// Whether the value is acceptable.
    ///
    /// # Errors
    /// A description of the violation where it is not.
    fn valid(&self) -> Result<(), String>;
}

impl Valid for f64 {
    fn valid(&self) -> Result<(), String> {
        if self.is_finite() {
            Ok(())
        } else {
            Err(format!("non-finite value {self}"))
        }
    }
}

impl Valid for () {
    fn valid(&self) -> Result<(), String> {
        Ok(())
    }
}

impl<T: Scalar + Valid, const R: usize, const C: usize> Valid for SMatrix<T, R, C> {
    fn valid(&self) -> Result<(), String> {
        self.iter().try_for_each(Valid::valid)
    }
}

impl<T: Valid, const N: usize> Valid for [T; N] {
    fn valid(&self) -> Result<(), String> {
        self.iter().try_for_each(Valid::valid)
    }
}

impl<A: Valid, B: Valid> Valid for (A, B) {
    fn valid(&self) -> Result<(), String> {
        self.0.valid()?;
        self.1.valid()
    }
}

impl<T: Valid> Valid for Option<T> {
    fn valid(&self) -> Result<(), String> {
        self.as_ref().map_or(Ok(()), Valid::valid)
    }
}

/// Checks a returned value.
///
/// # Panics
/// Where it is not [`Valid`].
pub fn check<T: Valid>(name: &str, value: &T) {
    if let Err(problem) = value.valid() {
        panic!("{name}: {problem}");
    }
}

/// Checks a fallible result: an error is counted (its message must say something), a value must be
/// [`Valid`]. Returns the value.
///
/// # Panics
/// Where the value is not valid or the error message is empty.
pub fn checked<T: Valid, E: std::fmt::Display>(name: &str, result: Result<T, E>) -> Option<T> {
    match result {
        Ok(value) => {
            check(name, &value);
            Some(value)
        }
        Err(error) => {
            ERRORS.fetch_add(1, Ordering::Relaxed);
            assert!(!error.to_string().is_empty(), "{name}: empty error message");
            None
        }
    }
}

/// Runs one case of a property through [`call`] (own thread, time limit), for properties written
/// with proptest's `prop_assert!`: a panic, a hang or a failed assertion fails the test, named.
///
/// # Panics
/// Where the case panics, hangs or returns a failed assertion.
pub fn case(
    name: &'static str,
    case: impl FnOnce() -> Result<(), proptest::test_runner::TestCaseError> + Send + 'static,
) {
    if let Err(failure) = call(name, case) {
        panic!("{name}: {failure}");
    }
}

/// The value of a fallible call whose value the caller checks itself (state unchanged, weights
/// normalised, …): an error is counted like in [`checked`] (its message must say something) and
/// gives `None`.
///
/// # Panics
/// Where the error message is empty.
pub fn counted<T, E: std::fmt::Display>(result: Result<T, E>) -> Option<T> {
    match result {
        Ok(value) => Some(value),
        Err(error) => checked::<(), E>("a call", Err(error)).and(None),
    }
}
