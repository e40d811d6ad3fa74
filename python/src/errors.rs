//! Library errors as Python exceptions: every one is a `ValueError` carrying the library's own
//! message (which names the argument and what it should be).

use pyo3::PyErr;
use pyo3::exceptions::PyValueError;

/// Any library error (anything that displays) as a Python `ValueError` with its message.
pub(crate) fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}
