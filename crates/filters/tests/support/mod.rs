//! The pieces of the bad-input harness: the generator of nasty numbers and the time-limited call.
//!
//! `LIEBAYES_FUZZ_CASES=<n>` sets the number of cases of every property (default 64, sized for CI);
//! `LIEBAYES_FUZZ_CASES=100000 cargo test --release --test bad_input` runs it long.

use proptest::prelude::*;
use proptest::test_runner::Config;
use std::sync::mpsc;
use std::time::Duration;

/// How long one call may take before it counts as a hang. A single filter step takes microseconds;
/// the limit is loose because the tests share two cores with other jobs, and a hang is unbounded.
pub const TIME_LIMIT: Duration = Duration::from_millis(500);

/// The proptest configuration: `LIEBAYES_FUZZ_CASES` cases (64 by default).
pub fn config() -> Config {
    let cases = std::env::var("LIEBAYES_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(64);
    Config {
        cases,
        ..Config::default()
    }
}

/// Numbers a user might pass, good and bad: NaN, ±∞, ±MAX, ±MIN_POSITIVE, subnormals, ±0, ±1e±300,
/// ±1e±150 (whose squares overflow or underflow) and ordinary values.
pub fn nasty_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => -10.0..10.0_f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(f64::MAX),
        1 => Just(-f64::MAX),
        1 => Just(f64::MIN_POSITIVE),
        1 => Just(-f64::MIN_POSITIVE),
        1 => prop::num::f64::SUBNORMAL,
        2 => Just(0.0),
        1 => Just(-0.0),
        2 => Just(1.0),
        1 => Just(1e300),
        1 => Just(-1e300),
        1 => Just(1e-300),
        1 => Just(1e160),
        1 => Just(1e-160),
        1 => Just(-1e-160),
    ]
}

/// Sizes a user might pass: small ones (built for real) and huge ones (to be refused before any
/// allocation). Sizes just below the crate's maximum are not generated: accepting them is correct
/// and allocates gigabytes.
pub fn nasty_size() -> impl Strategy<Value = usize> {
    prop_oneof![
        4 => 0..40_usize,
        1 => Just(usize::MAX),
        1 => Just(usize::MAX / 2),
        1 => Just(liebayes_operators::MAX_ELEMENTS + 1),
        1 => Just(1_usize << 40),
    ]
}

/// Runs `f` on its own thread and returns its result, failing the test if it panics or is not back
/// within [`TIME_LIMIT`] (a hang).
pub fn within_time_limit<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    let (sender, receiver) = mpsc::channel();
    std::thread::spawn(move || {
        // A send fails only when the receiver timed out and is gone.
        let _ = sender.send(f());
    });
    match receiver.recv_timeout(TIME_LIMIT) {
        Ok(value) => value,
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("the call did not return within {TIME_LIMIT:?}: it hangs")
        }
        Err(mpsc::RecvTimeoutError::Disconnected) => panic!("the call panicked"),
    }
}
