//! numpy arrays to and from the library's types: shapes checked before anything is read or
//! allocated, with errors that name the argument and the shape expected.

use crate::errors::value_error;
use nalgebra::Vector3;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The rows of an `(n, 3)` array as 3-vectors (one pass over the array, read in place).
///
/// # Errors
/// `ValueError` naming `name` when the array is not `(n, 3)`.
pub(crate) fn vectors3(
    name: &str,
    array: &PyReadonlyArray2<'_, f64>,
) -> PyResult<Vec<Vector3<f64>>> {
    let shape = array.shape();
    if shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape (n, 3), got {shape:?}"
        )));
    }
    let view = array.as_array();
    Ok(view
        .rows()
        .into_iter()
        .map(|r| Vector3::new(r[0], r[1], r[2]))
        .collect())
}

/// An `(n, k)` array of rows given by `row(i, out)`, filled in place.
pub(crate) fn rows<'py>(
    py: Python<'py>,
    n: usize,
    k: usize,
    mut row: impl FnMut(usize, &mut [f64]),
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let mut data = vec![
        0.0;
        n.checked_mul(k)
            .ok_or_else(|| value_error("array too large"))?
    ];
    for (i, chunk) in data.chunks_exact_mut(k).enumerate() {
        row(i, chunk);
    }
    PyArray1::from_vec(py, data).reshape([n, k])
}

/// Any array-like (a numpy array of any dtype and layout, a list of lists) as a read-only
/// float64 2-D numpy array: a float64 array is taken as it is (no copy), anything else is converted
/// once by `numpy.asarray(x, dtype=float64)`.
///
/// # Errors
/// `ValueError` naming `name` when it cannot be converted or is not 2-D.
pub(crate) fn float_array2<'py>(
    name: &str,
    value: &Bound<'py, PyAny>,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    if let Ok(array) = value.extract::<PyReadonlyArray2<'py, f64>>() {
        return Ok(array);
    }
    let py = value.py();
    let converted = py
        .import("numpy")?
        .call_method1("asarray", (value, "float64"))
        .map_err(|e| PyValueError::new_err(format!("{name}: not an array of numbers ({e})")))?;
    converted
        .extract::<PyReadonlyArray2<'py, f64>>()
        .map_err(|_| {
            let ndim = converted
                .getattr("ndim")
                .and_then(|d| d.extract::<usize>())
                .unwrap_or(0);
            PyValueError::new_err(format!(
                "{name}: expected a 2-D array (one row per element), got {ndim} dimension(s)"
            ))
        })
}
