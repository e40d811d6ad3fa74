//! Library errors as Python exceptions: every one is a `ValueError` carrying the library's own
//! message (which names the argument and what it should be).

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Any library error (anything that displays) as a Python `ValueError` with its message.
pub(crate) fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The error of a call on a filter that another call is using: a call that runs without the GIL
/// (a batch, a run, a particle filter's step) holds its filter until it returns, and another
/// thread's call on the same filter, or a callback of the call's own arguments, meanwhile gets
/// this `ValueError` rather than pyo3's untyped `RuntimeError("Already borrowed")`.
pub(crate) fn in_use(class: &str) -> PyErr {
    PyValueError::new_err(format!(
        "{class}: this filter is in use by another call (another thread's, or a callback of this \
         call); a filter is used by one thread at a time: give each thread its own filter (or \
         a copy), or wait for the call to return"
    ))
}

/// Steps of a long loop without the GIL between two checks for a pending signal (a Ctrl-C): a
/// few milliseconds of work at most, a negligible cost.
pub(crate) const SIGNAL_CHECK_EVERY: usize = 1 << 16;

/// Why a long loop without the GIL stopped: its own failure, or a signal whose handler raised (a
/// Ctrl-C: `KeyboardInterrupt`), raised when the call returns, nothing kept.
pub(crate) enum Stopped<E> {
    /// The loop's failure.
    Failed(E),
    /// The exception of a signal handler.
    Interrupted(PyErr),
}

/// From a loop running without the GIL, at step `k`: every [`SIGNAL_CHECK_EVERY`] steps, takes the
/// GIL for a moment and runs the pending signal handlers; `Err` with the exception one raised.
pub(crate) fn check_signals_at<E>(k: usize) -> Result<(), Stopped<E>> {
    if k == 0 || k % SIGNAL_CHECK_EVERY != 0 {
        return Ok(());
    }
    // A closure, not the method's path: attach's callback must take a Python of any lifetime.
    #[allow(clippy::redundant_closure_for_method_calls)]
    Python::attach(|py| py.check_signals()).map_err(Stopped::Interrupted)
}
