//! Python bindings of liebayes, built by maturin into the extension module `liebayes._liebayes`
//! (the Python package `liebayes` re-exports it by area: `liebayes.manifolds`,
//! `liebayes.densities`, `liebayes.attitude`, `liebayes.filters`).
//!
//! Arrays cross as numpy arrays of `float64` (read in place, no copy per element; results are new
//! arrays); long calls release the GIL; every library error is raised as a Python `ValueError`
//! carrying the library's message, and no input ends in a crash.

mod arrays;
mod attitude;
mod densities;
mod errors;
mod filters;
mod manifolds;

use pyo3::prelude::*;

/// The extension module: every class and function of the package, registered by area.
#[pymodule]
fn _liebayes(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // numpy's C API is loaded now, at import: loaded lazily, by the first array a call creates,
    // it would run Python code right after a section without the GIL, where a pending Ctrl-C
    // made the numpy crate panic (PanicException) instead of raising KeyboardInterrupt. Every
    // such section is followed by `py.check_signals()`, which raises the KeyboardInterrupt.
    numpy::PyArray1::<f64>::zeros(m.py(), 0, false);
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    manifolds::register(m)?;
    densities::register(m)?;
    attitude::register(m)?;
    filters::register(m)?;
    Ok(())
}
