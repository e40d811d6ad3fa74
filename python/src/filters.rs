//! The filters area of the package (`liebayes.filters`).

use pyo3::prelude::*;

/// Adds the area's classes and functions to the extension module.
pub(crate) fn register(_m: &Bound<'_, PyModule>) -> PyResult<()> {
    Ok(())
}
