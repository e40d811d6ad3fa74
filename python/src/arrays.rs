//! numpy arrays to and from the library's types: shapes checked before anything is read or
//! allocated, with errors that name the argument and the shape expected.

use crate::errors::value_error;
use liebayes_manifolds::{ManifoldError, S2, So3, Su2};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use numpy::{
    PyArrayDescr, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn,
    PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyOverflowError;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyTuple, PyType};

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

/// `numpy.ma.MaskedArray`, looked up once.
static MASKED_ARRAY: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// Refuses a masked array that masks any value with a `TypeError`: numpy hands its data over
/// with the masked values in it, which would be read as numbers. One without a masked value is
/// read as its data.
fn refuse_masked(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<()> {
    let py = obj.py();
    let masked_array = MASKED_ARRAY.import(py, "numpy.ma", "MaskedArray")?;
    if !obj.is_instance(masked_array)? {
        return Ok(());
    }
    let any_masked: bool = py
        .import("numpy.ma")?
        .call_method1("is_masked", (obj,))?
        .extract()?;
    if any_masked {
        return Err(PyTypeError::new_err(named(
            name,
            "a masked array with masked values: numpy would hand over the values under the mask \
             as numbers; pass a.filled(x) or a.compressed(), or drop the masked rows"
                .to_owned(),
        )));
    }
    Ok(())
}

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

/// [`float_array`] with its shape checked by `check` before anything is converted or copied when
/// `obj` is already a numpy array (a wrongly shaped zero-stride view is refused without being
/// expanded), and again once converted (a list's shape is only known then).
pub(crate) fn shaped_float_array<'py>(
    name: &str,
    obj: &Bound<'py, PyAny>,
    check: impl Fn(&[usize]) -> PyResult<()>,
) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    if let Ok(array) = obj.cast::<PyUntypedArray>() {
        refuse_masked(name, obj)?;
        check_real_dtype(name, &array.dtype())?;
        check(array.shape())?;
    }
    let array = float_array(name, obj)?;
    check(array.shape())?;
    Ok(array)
}

/// Refuses an array whose values are not real numbers ([`is_real`]) with a `TypeError`.
fn check_real_dtype(name: &str, dtype: &Bound<'_, PyArrayDescr>) -> PyResult<()> {
    if is_real(dtype) {
        return Ok(());
    }
    Err(PyTypeError::new_err(named(
        name,
        format!("expected an array of real numbers (float64), got dtype {dtype}"),
    )))
}

/// Refuses a list or tuple holding a bool (`True`, `numpy.True_`) or a bool array anywhere in it:
/// numpy reads `[True, 0.5]` as the numbers `[1.0, 0.5]`, but a bool is not a real number here.
/// `depth` bounds the walk (numpy refuses more than 64 dimensions before this is called).
fn refuse_bools(name: &str, obj: &Bound<'_, PyAny>, depth: usize) -> PyResult<()> {
    let refuse = |what: String| {
        Err(PyTypeError::new_err(named(
            name,
            format!("expected real numbers, got {what} in the list"),
        )))
    };
    if depth > 64 {
        return Ok(());
    }
    let items = if let Ok(list) = obj.cast::<PyList>() {
        list.iter().collect::<Vec<_>>()
    } else if let Ok(tuple) = obj.cast::<PyTuple>() {
        tuple.iter().collect::<Vec<_>>()
    } else {
        return Ok(());
    };
    for item in &items {
        if item.is_instance_of::<PyBool>() {
            return refuse(format!("the bool {item}"));
        }
        if let Ok(array) = item.cast::<PyUntypedArray>() {
            let dtype = array.dtype();
            if dtype.kind() == b'b' {
                return refuse(format!("an array of dtype {dtype}"));
            }
        } else if item.is_instance(NUMPY_SCALAR.import(item.py(), "numpy", "generic")?)? {
            let dtype = item.getattr("dtype")?.cast_into::<PyArrayDescr>()?;
            if dtype.kind() == b'b' {
                return refuse(format!("the numpy bool {item}"));
            }
        } else {
            refuse_bools(name, item, depth + 1)?;
        }
    }
    Ok(())
}

/// Three real numbers given as a sequence (a list, a tuple, a numpy array): an array whose values
/// are not real numbers (complex, bool, object, strings) raises `TypeError` as in [`float_array`],
/// rather than being cast element by element, and each element of a list must be a real number
/// as [`real_number`] reads one (a bool, a complex number or a one-element list is refused).
#[derive(Clone, Copy)]
pub(crate) struct Real3(pub(crate) [f64; 3]);

impl Real3 {
    /// The argument `name` as three real numbers (its errors name it, and the element).
    pub(crate) fn read(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Self> {
        if let Ok(array) = obj.cast::<PyUntypedArray>() {
            let dtype = array.dtype();
            if !is_real(&dtype) {
                return Err(PyTypeError::new_err(format!(
                    "{name}: expected three real numbers, got an array of dtype {dtype}"
                )));
            }
        }
        let elements = obj.extract::<[Bound<'_, PyAny>; 3]>().map_err(|e| {
            // A sequence of another length, or not a sequence (a number, a string, a sequence
            // whose __len__ and items disagree): a TypeError naming the argument.
            PyTypeError::new_err(format!("{name}: expected three real numbers ({e})"))
        })?;
        let mut values = [0.0; 3];
        for (i, (value, element)) in values.iter_mut().zip(&elements).enumerate() {
            *value = real_number(&format!("{name}[{i}]"), element)?;
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
        return obj.extract().map_err(|e: PyErr| {
            if e.is_instance_of::<PyOverflowError>(obj.py()) {
                // An int beyond the float range (about 1.8e308) is a value out of range.
                PyValueError::new_err(named(
                    name,
                    "the integer is beyond the range of a float (about 1.8e308)".to_owned(),
                ))
            } else {
                e
            }
        });
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

/// An optional `float` argument `name`: `None`, or a number read by [`real_number`].
pub(crate) fn optional_real(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Option<f64>> {
    if obj.is_none() {
        Ok(None)
    } else {
        real_number(name, obj).map(Some)
    }
}

/// `numpy.bool_`, looked up once.
static NUMPY_BOOL: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// An integer argument `name` (a count, a size, a seed, an index) from 0 to `max`: a Python
/// `int` or a numpy integer (anything with `__index__`). A bool (`True`, `numpy.True_`) raises
/// `TypeError`, as for the float arguments: in a count's place it is almost always a slip. A value
/// out of the range, however large, raises `ValueError` naming the argument and the range
/// (Python's own conversion would raise `OverflowError`, which `except ValueError` misses).
pub(crate) fn integer(name: &str, obj: &Bound<'_, PyAny>, max: u64) -> PyResult<u64> {
    let py = obj.py();
    if obj.is_instance_of::<PyBool>()
        || obj.is_instance(NUMPY_BOOL.import(py, "numpy", "bool_")?)?
    {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected an integer, got the bool {obj}"
        )));
    }
    let range = || format!("a non-negative integer of at most {max}");
    match obj.extract::<i128>() {
        Ok(v) => u64::try_from(v)
            .ok()
            .filter(|&v| v <= max)
            .ok_or_else(|| PyValueError::new_err(format!("{name} is {v}: expected {}", range()))),
        Err(e) if e.is_instance_of::<PyOverflowError>(py) => {
            let sign = if obj.lt(0_i32).unwrap_or(false) {
                "a negative integer"
            } else {
                "an integer"
            };
            Err(PyValueError::new_err(format!(
                "{name}: {sign} beyond 2^127, expected {}",
                range()
            )))
        }
        Err(e) if e.is_instance_of::<PyTypeError>(py) => Err(PyTypeError::new_err(format!(
            "{name}: expected an integer, got an object of type {}",
            obj.get_type().name()?
        ))),
        Err(e) => Err(e),
    }
}

/// [`integer`] as a `usize`, up to `max`.
pub(crate) fn size(name: &str, obj: &Bound<'_, PyAny>, max: usize) -> PyResult<usize> {
    let max = u64::try_from(max).unwrap_or(u64::MAX);
    integer(name, obj, max).map(|v| usize::try_from(v).unwrap_or(usize::MAX))
}

/// Readers of named arguments for `#[pyo3(from_py_with = arg::name)]`: pyo3 names an argument
/// whose extraction failed only in a note (Python 3.11 and later; nowhere on 3.9 and 3.10), so
/// each reader puts the name into the message itself.
pub(crate) mod arg {
    use pyo3::prelude::*;

    /// A float argument read by [`super::real_number`] under its own name.
    macro_rules! reals {
        ($($name:ident),* $(,)?) => {$(
            #[doc = concat!("The float argument `", stringify!($name), "`.")]
            pub(crate) fn $name(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
                super::real_number(stringify!($name), obj)
            }
        )*};
    }

    /// An optional float argument (`None` or a number) under its own name.
    macro_rules! optional_reals {
        ($($fn_name:ident => $name:ident),* $(,)?) => {$(
            #[doc = concat!("The optional float argument `", stringify!($name), "`.")]
            pub(crate) fn $fn_name(obj: &Bound<'_, PyAny>) -> PyResult<Option<f64>> {
                super::optional_real(stringify!($name), obj)
            }
        )*};
    }

    /// An integer argument from 0 to its type's largest value, under its own name.
    macro_rules! integers {
        ($($name:ident: $t:ty),* $(,)?) => {$(
            #[doc = concat!("The integer argument `", stringify!($name), "`.")]
            pub(crate) fn $name(obj: &Bound<'_, PyAny>) -> PyResult<$t> {
                let max = u64::try_from(<$t>::MAX).unwrap_or(u64::MAX);
                super::integer(stringify!($name), obj, max)
                    .map(|v| <$t>::try_from(v).unwrap_or(<$t>::MAX))
            }
        )*};
    }

    reals!(
        azimuth, delta, dt, duration, kappa, mu, prior_std, q, q_xy, q_z, sigma, sigma0, sigma_deg,
        sigma_m, variance,
    );
    optional_reals!(
        dt_or_none => dt,
        filter_q_or_none => filter_q,
        filter_sigma0_or_none => filter_sigma0,
        filter_sigma_m_or_none => filter_sigma_m,
        kappa_or_none => kappa,
        rate_or_none => rate,
        sigma_az_or_none => sigma_az,
        sigma_el_or_none => sigma_el,
    );
    integers!(
        runs: u64, seed: u64, start: u64, particles: usize, steps: usize,
        measure_every: usize, fit_samples: usize, n: usize,
    );

    /// `runs` of a function that returns every run's arrays (a `usize`).
    pub(crate) fn runs_size(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
        super::size("runs", obj, usize::MAX)
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
    refuse_masked(name, obj)?;
    if let Ok(array) = obj.cast::<PyArrayDyn<f64>>() {
        if array.is_c_contiguous() && array.is_aligned() {
            return Ok(array.clone());
        }
    }
    let asarray = ASARRAY.import(py, "numpy", "asarray")?;
    // Anything but an array is read by numpy as it is first, so that its kind can be checked
    // before a cast to float64 could turn strings, booleans or complex numbers into numbers.
    let (array, listed) = if let Ok(array) = obj.cast::<PyUntypedArray>() {
        (array.clone(), false)
    } else {
        let read = asarray.call1((obj,)).map_err(|e| {
            // numpy's message for a ragged list ("setting an array element with a
            // sequence…"), with the argument's name; other errors keep their type.
            if e.is_instance_of::<PyValueError>(py) {
                PyValueError::new_err(named(
                    name,
                    format!("could not read it as an array of numbers: {e}"),
                ))
            } else {
                e
            }
        })?;
        let array = read.cast_into::<PyUntypedArray>().map_err(|_| {
            PyTypeError::new_err(named(name, "could not read it as an array".to_owned()))
        })?;
        (array, true)
    };
    let dtype = array.dtype();
    if listed && dtype.kind() == b'O' {
        return Err(PyTypeError::new_err(named(
            name,
            format!(
                "expected real numbers, got an object of type {} that numpy reads as dtype \
                 object (it is or holds something that is not a number, or an integer beyond 64 \
                 bits)",
                obj.get_type().name()?
            ),
        )));
    }
    check_real_dtype(name, &dtype)?;
    if listed {
        refuse_bools(name, obj, 0)?;
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
