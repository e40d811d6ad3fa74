//! numpy arrays to and from the library's types: shapes checked before anything is read or
//! allocated, with errors that name the argument and the shape expected.

use crate::errors::value_error;
use liebayes_manifolds::{ManifoldError, S2, So3, Su2};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use numpy::{
    PyArray1, PyArray2, PyArrayDescr, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods,
    PyReadonlyArrayDyn, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyType};

/// The most values an array the package returns may hold (draws × their components, or runs ×
/// steps × components of exposed simulated runs, all arrays together): 2²⁸ doubles, 2 GB. More is
/// refused before anything is allocated or computed.
pub(crate) const MAX_VALUES: usize = 1 << 28;

/// The rows of an `(n, 3)` array as 3-vectors (one pass over the array, read in place).
///
/// # Errors
/// `ValueError` naming `name` when the array is not `(n, 3)`.
pub(crate) fn vectors3(
    name: &str,
    array: &PyReadonlyArrayDyn<'_, f64>,
) -> PyResult<Vec<Vector3<f64>>> {
    let shape = array.shape();
    if shape.len() != 2 || shape[1] != 3 {
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
pub(crate) fn rows(
    py: Python<'_>,
    n: usize,
    k: usize,
    mut row: impl FnMut(usize, &mut [f64]),
) -> PyResult<Bound<'_, PyArray2<f64>>> {
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

/// A shape as Python writes it, with `n` for the batch axis when `batch` is set: `(3,)`, `(n, 3, 3)`.
pub(crate) fn shape_text(shape: &[usize], batch: bool) -> String {
    let mut parts: Vec<String> = shape.iter().map(ToString::to_string).collect();
    if batch {
        parts.insert(0, "n".to_owned());
    }
    if parts.len() == 1 {
        format!("({},)", parts[0])
    } else {
        format!("({})", parts.join(", "))
    }
}

/// `numpy.asarray`, looked up once.
static ASARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();

/// The argument as an aligned C-contiguous `float64` array: the array itself when it already is
/// one, otherwise converted by `numpy.asarray` (lists, integer or `float32` arrays, strided
/// views). Values that are not real numbers (complex, bool, object or string arrays, or lists of
/// them) raise `TypeError` instead of being cast.
pub(crate) fn float_array<'py>(
    name: &str,
    obj: &Bound<'py, PyAny>,
) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    contiguous_float64(name, obj)?
        .try_readonly()
        .map_err(value_error)
}

/// An array argument of real numbers as a read-only `float64` array, converted and checked as
/// [`float_array`] does (its shape is the caller's to check, with the argument's name).
pub(crate) struct RealArray<'py>(PyReadonlyArrayDyn<'py, f64>);

impl<'a, 'py> FromPyObject<'a, 'py> for RealArray<'py> {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        // pyo3 attaches a note naming the argument to the error.
        float_array("", &obj.to_owned()).map(Self)
    }
}

impl<'py> std::ops::Deref for RealArray<'py> {
    type Target = PyReadonlyArrayDyn<'py, f64>;

    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

/// Three real numbers given as a sequence (a list, a tuple, a numpy array): an array whose values
/// are not real numbers (complex, bool, object, strings) raises `TypeError` as in [`float_array`],
/// rather than being cast element by element, and each element of a list must be a real number
/// as [`real_number`] reads one (a bool, a complex number or a one-element list is refused).
#[derive(Clone, Copy)]
pub(crate) struct Real3(pub(crate) [f64; 3]);

impl<'a, 'py> FromPyObject<'a, 'py> for Real3 {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        if let Ok(array) = obj.cast::<PyUntypedArray>() {
            let dtype = array.dtype();
            if !is_real(&dtype) {
                return Err(PyTypeError::new_err(format!(
                    "expected three real numbers, got an array of dtype {dtype}"
                )));
            }
        }
        let elements = obj.extract::<[Bound<'py, PyAny>; 3]>()?;
        let mut values = [0.0; 3];
        for (i, (value, element)) in values.iter_mut().zip(&elements).enumerate() {
            *value = real_number(&format!("element {i}"), element)?;
        }
        Ok(Self(values))
    }
}

/// `numpy.generic`, the class of numpy's scalars, looked up once.
static NUMPY_SCALAR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// A real number given by the user: a Python `int` or `float`, a numpy integer or floating scalar,
/// or a 0-d array of one; anything else raises `TypeError` (its message prefixed by `name` unless
/// it is empty). pyo3's own `f64` argument takes anything with `__float__` or `__index__`: a bool
/// as 0 or 1, a numpy complex scalar with its imaginary part dropped (and a warning), an array of
/// one element as that element. Those, complex numbers, strings and other objects are refused.
pub(crate) fn real_number(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    let refuse = |what: String| {
        PyTypeError::new_err(named(
            name,
            format!("expected a real number (an int or a float), got {what}"),
        ))
    };
    // A bool is an int to Python: it is refused first.
    if obj.is_instance_of::<PyBool>() {
        return Err(refuse(format!("the bool {obj}")));
    }
    if obj.is_instance_of::<PyFloat>() || obj.is_instance_of::<PyInt>() {
        return obj.extract();
    }
    let dtype = if let Ok(array) = obj.cast::<PyUntypedArray>() {
        if array.ndim() != 0 {
            return Err(refuse(format!(
                "an array of shape {}",
                shape_text(array.shape(), false)
            )));
        }
        array.dtype()
    } else if obj.is_instance(NUMPY_SCALAR.import(obj.py(), "numpy", "generic")?)? {
        obj.getattr("dtype")?.cast_into::<PyArrayDescr>()?
    } else {
        return Err(refuse(format!(
            "an object of type {}",
            obj.get_type().name()?
        )));
    };
    if !is_real(&dtype) {
        return Err(refuse(format!("a numpy value of dtype {dtype}")));
    }
    obj.extract()
}

/// A `float` argument, read by [`real_number`] (`#[pyo3(from_py_with = real)]`; pyo3 adds a note
/// naming the argument to the error).
pub(crate) fn real(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    real_number("", obj)
}

/// An optional `float` argument: `None`, or a number read by [`real_number`]
/// (`#[pyo3(from_py_with = optional_real)]`).
pub(crate) fn optional_real(obj: &Bound<'_, PyAny>) -> PyResult<Option<f64>> {
    if obj.is_none() {
        Ok(None)
    } else {
        real(obj).map(Some)
    }
}

/// `text` prefixed by the argument's `name` (`"name: text"`), or as it is when `name` is empty.
fn named(name: &str, text: String) -> String {
    if name.is_empty() {
        text
    } else {
        format!("{name}: {text}")
    }
}

/// Whether an array's values are real numbers: floats or integers, not complex, bool, object or
/// strings (which a cast to float64 would turn into numbers silently or element by element).
fn is_real(dtype: &Bound<'_, PyArrayDescr>) -> bool {
    matches!(dtype.kind(), b'f' | b'i' | b'u')
}

/// [`float_array`] before it is borrowed.
fn contiguous_float64<'py>(
    name: &str,
    obj: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let py = obj.py();
    if let Ok(array) = obj.cast::<PyArrayDyn<f64>>() {
        if array.is_c_contiguous() && array.is_aligned() {
            return Ok(array.clone());
        }
    }
    let asarray = ASARRAY.import(py, "numpy", "asarray")?;
    // Anything but an array is read by numpy as it is first, so that its kind can be checked
    // before a cast to float64 could turn strings, booleans or complex numbers into numbers.
    let array = match obj.cast::<PyUntypedArray>() {
        Ok(array) => array.clone(),
        Err(_) => asarray
            .call1((obj,))?
            .cast_into::<PyUntypedArray>()
            .map_err(|_| {
                PyTypeError::new_err(named(name, "could not read it as an array".to_owned()))
            })?,
    };
    let dtype = array.dtype();
    if !is_real(&dtype) {
        return Err(PyTypeError::new_err(named(
            name,
            format!("expected an array of real numbers (float64), got dtype {dtype}"),
        )));
    }
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    kwargs.set_item("order", "C")?;
    let converted = asarray.call((array,), Some(&kwargs))?;
    let array = converted.cast_into::<PyArrayDyn<f64>>().map_err(|_| {
        PyTypeError::new_err(named(
            name,
            "could not read it as an array of float64".to_owned(),
        ))
    })?;
    if array.is_aligned() {
        return Ok(array);
    }
    // A misaligned buffer (a view into raw bytes at an odd offset) is copied into a fresh array.
    array
        .call_method0("copy")?
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|_| PyTypeError::new_err(named(name, "could not copy it as float64".to_owned())))
}

/// A rotation matrix (row-major, 9 numbers), checked by the library (finite, orthonormal, det +1).
pub(crate) fn rotation(s: &[f64]) -> Result<So3<f64>, ManifoldError> {
    So3::from_matrix(&Matrix3::from_row_slice(s))
}

/// A unit quaternion `[w, x, y, z]`, checked by the library (finite, unit norm).
pub(crate) fn quaternion(s: &[f64]) -> Result<Su2<f64>, ManifoldError> {
    Su2::from_quaternion_wxyz(s[0], s[1], s[2], s[3])
}

/// A point of S² (a unit 3-vector), checked by the library (finite, unit norm).
pub(crate) fn sphere_point(s: &[f64]) -> Result<S2<f64>, ManifoldError> {
    S2::new(Vector3::new(s[0], s[1], s[2]))
}

/// Writes a matrix into `out`, row-major.
pub(crate) fn put_matrix<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>, out: &mut [f64]) {
    for (r, row) in out.chunks_exact_mut(C).enumerate() {
        for (c, value) in row.iter_mut().enumerate() {
            *value = m[(r, c)];
        }
    }
}

/// Writes a vector into `out`.
pub(crate) fn put_vector<const R: usize>(v: &SVector<f64, R>, out: &mut [f64]) {
    out.copy_from_slice(v.as_slice());
}
