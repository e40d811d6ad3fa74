//! The densities area of the package (`liebayes.densities`): the von Mises, von Mises-Fisher and
//! Bingham distributions, the SO(3) heat kernel and the Gaussian in the tangent space of SO(3) and
//! of S², wrapped from `liebayes_densities`.
//!
//! Points cross as numpy `float64` arrays with a trailing point shape (an angle `()`, a unit vector
//! `(3,)`, a unit quaternion `(4,)` scalar first, a rotation matrix `(3, 3)`) and any leading batch
//! shape; one value per point comes back with the leading shape (a Python float for a single point).
//! Each point is validated by the library's constructor (finite, unit norm, orthonormal) and a
//! failure is a `ValueError` naming the point's flat index and carrying the library's message.
//! Draws come from the library's ChaCha8 stream, seeded by one 63-bit integer drawn from the caller's
//! `numpy.random.Generator`, so the same generator state gives the same draws.

use crate::arrays::{
    MAX_VALUES, arg, float_array, put_matrix, put_vector, quaternion, rotation, shape_text,
    shaped_float_array, sphere_point,
};
use crate::errors::{Stopped, check_signals_at, value_error};
use liebayes_densities::manifolds::{ManifoldError, S2, So2, So3, Su2};
use liebayes_densities::special::bingham_log_normalizer_and_moments;
use liebayes_densities::{
    Bingham, Convolve, Density, DensityError, Entropy, HeatKernelSo3, KlDivergence,
    ManifoldGaussian, Product, VonMises, VonMisesFisher,
};
use nalgebra::{Matrix2, Matrix3, Matrix4, SMatrix, Vector2, Vector3, Vector4};
use numpy::ndarray::ArrayViewD;
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyFloat;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::borrow::Cow;

/// Adds the area's classes and functions to the extension module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyVonMises>()?;
    m.add_class::<PyVonMisesFisher>()?;
    m.add_class::<PyBingham>()?;
    m.add_class::<PyHeatKernelSo3>()?;
    m.add_class::<PyManifoldGaussianSo3>()?;
    m.add_class::<PyManifoldGaussianS2>()?;
    m.add_function(wrap_pyfunction!(bingham_log_normaliser, m)?)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Arrays in and out.
// ---------------------------------------------------------------------------------------------

/// The components of a fixed-size parameter (a mean vector, a matrix) in row-major order, with
/// the shape checked exactly; every component must be finite.
fn parameter(name: &str, obj: &Bound<'_, PyAny>, shape: &[usize]) -> PyResult<Vec<f64>> {
    let array = shaped_float_array(name, obj, |got| {
        if got == shape {
            return Ok(());
        }
        Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape {}, got {}",
            shape_text(shape, false),
            shape_text(got, false)
        )))
    })?;
    let values: Vec<f64> = array.as_array().iter().copied().collect();
    if let Some(v) = values.iter().find(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{name}: every entry must be a finite number, got {v}"
        )));
    }
    Ok(values)
}

/// A batch of points read in place: the leading (batch) shape and the components, contiguous and
/// row-major (a copy only when the caller's array is not C-contiguous).
struct Points<'a> {
    /// The leading shape, one value per point is returned with it.
    leading: Vec<usize>,
    /// Every point's components, `width` per point.
    data: Cow<'a, [f64]>,
    /// Components per point.
    width: usize,
}

/// The points of `view`, whose trailing dimensions must be `point_shape`.
fn points<'a>(
    name: &str,
    view: &ArrayViewD<'a, f64>,
    point_shape: &[usize],
) -> PyResult<Points<'a>> {
    let shape = view.shape().to_vec();
    let k = point_shape.len();
    check_points_shape(name, &shape, point_shape)?;
    let leading = shape[..shape.len() - k].to_vec();
    let width = point_shape.iter().product::<usize>();
    let data = match view.to_slice() {
        Some(slice) => Cow::Borrowed(slice),
        None => Cow::Owned(view.iter().copied().collect()),
    };
    Ok(Points {
        leading,
        data,
        width,
    })
}

/// Refuses a `shape` whose trailing dimensions are not `point_shape`.
fn check_points_shape(name: &str, shape: &[usize], point_shape: &[usize]) -> PyResult<()> {
    let k = point_shape.len();
    if shape.len() >= k && shape[shape.len() - k..] == *point_shape {
        return Ok(());
    }
    let expected = if k == 0 {
        "an array of any shape".to_string()
    } else {
        let trailing = point_shape
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(", ");
        format!("an array of shape ({trailing}) or (..., {trailing})")
    };
    Err(PyValueError::new_err(format!(
        "{name}: expected {expected}, got {}",
        shape_text(shape, false)
    )))
}

/// Why one point of a batch failed: its flat index and the library's message.
struct PointError {
    /// Flat index of the point in the batch.
    index: usize,
    /// The library's message.
    message: String,
}

/// `f` over every point of `x` (validated by `parse`), with the GIL released; one value per point,
/// returned with the leading shape of `x` (a Python float for a single point).
fn map_points<'py, P, E: std::fmt::Display>(
    py: Python<'py>,
    name: &str,
    x: &Bound<'py, PyAny>,
    point_shape: &[usize],
    parse: impl Fn(&[f64]) -> Result<P, E> + Sync,
    f: impl Fn(&P) -> f64 + Sync,
) -> PyResult<Bound<'py, PyAny>> {
    let array = shaped_float_array(name, x, |shape| {
        check_points_shape(name, shape, point_shape)
    })?;
    let Points {
        leading,
        data,
        width,
    } = points(name, &array.as_array(), point_shape)?;
    let n = leading.iter().product::<usize>();
    let data: &[f64] = &data;
    let result = py.detach(|| -> Result<Vec<f64>, PointError> {
        let mut out = Vec::new();
        out.try_reserve_exact(n).map_err(|e| PointError {
            index: 0,
            message: e.to_string(),
        })?;
        for (index, chunk) in data.chunks_exact(width.max(1)).take(n).enumerate() {
            let point = parse(chunk).map_err(|e| PointError {
                index,
                message: e.to_string(),
            })?;
            out.push(f(&point));
        }
        Ok(out)
    });
    py.check_signals()?;
    let values = result.map_err(|e| {
        PyValueError::new_err(format!("{name}[{}] (flat index): {}", e.index, e.message))
    })?;
    if leading.is_empty() {
        return Ok(PyFloat::new(py, values.first().copied().unwrap_or(f64::NAN)).into_any());
    }
    Ok(PyArray1::from_vec(py, values).reshape(leading)?.into_any())
}

/// Refuses an `rng` that is not a `numpy.random.Generator` with a `TypeError`.
fn check_generator(rng: &Bound<'_, PyAny>) -> PyResult<()> {
    let generator = PyModule::import(rng.py(), "numpy.random")?.getattr("Generator")?;
    if rng.is_instance(&generator)? {
        return Ok(());
    }
    Err(PyTypeError::new_err(format!(
        "rng must be a numpy.random.Generator (for example numpy.random.default_rng(seed)), got {}",
        rng.get_type().name()?
    )))
}

/// `n` draws of `density` written by `put` (`width` numbers each) from the ChaCha8 stream seeded by
/// one draw `rng.integers(0, 2**63)` from the caller's generator, with the GIL released; returned
/// with shape `(n,) + point_shape`. Every check, and the allocation, comes before the seed is drawn:
/// a refused call leaves the generator as it was.
fn draw<'py, D: Density + Sync>(
    py: Python<'py>,
    density: &D,
    n: usize,
    rng: &Bound<'py, PyAny>,
    point_shape: &[usize],
    put: impl Fn(&D::Point, &mut [f64]) + Sync,
) -> PyResult<Bound<'py, PyAny>> {
    let width = point_shape.iter().product::<usize>();
    let total = n
        .checked_mul(width)
        .filter(|&total| total <= MAX_VALUES)
        .ok_or_else(|| {
            value_error(format!(
                "n = {n} draws of {width} values each exceed the limit of 2^28 values in one call; \
                 draw them in several calls"
            ))
        })?;
    check_generator(rng)?;
    let data = py.detach(|| -> Result<Vec<f64>, String> {
        let mut data = Vec::new();
        data.try_reserve_exact(total)
            .map_err(|e| format!("n = {n} draws do not fit in memory: {e}"))?;
        data.resize(total, 0.0);
        Ok(data)
    });
    py.check_signals()?;
    let mut data = data.map_err(PyValueError::new_err)?;
    let seed = rng
        .call_method1("integers", (0_u64, 1_u64 << 63))?
        .extract::<u64>()?;
    let drawn = py.detach(|| -> Result<(), Stopped<()>> {
        let mut stream = ChaCha8Rng::seed_from_u64(seed);
        for (k, chunk) in data.chunks_exact_mut(width).enumerate() {
            check_signals_at(k)?;
            put(&density.sample(&mut stream), chunk);
        }
        Ok(())
    });
    py.check_signals()?;
    if let Err(Stopped::Interrupted(e)) = drawn {
        return Err(e);
    }
    let mut shape = vec![n];
    shape.extend_from_slice(point_shape);
    Ok(PyArray1::from_vec(py, data).reshape(shape)?.into_any())
}

/// A new `float64` array of `shape` from row-major values.
fn array_of<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, values)
        .reshape(shape.to_vec())?
        .into_any())
}

/// A matrix as a row-major `(R, C)` array.
fn matrix_array<'py, const R: usize, const C: usize>(
    py: Python<'py>,
    m: &SMatrix<f64, R, C>,
) -> PyResult<Bound<'py, PyAny>> {
    let values = (0..R)
        .flat_map(|i| (0..C).map(move |j| m[(i, j)]))
        .collect();
    array_of(py, values, &[R, C])
}

/// A vector as an `(N,)` array.
fn vector_array<'py, const N: usize>(
    py: Python<'py>,
    v: &SMatrix<f64, N, 1>,
) -> PyResult<Bound<'py, PyAny>> {
    array_of(py, v.iter().copied().collect(), &[N])
}

/// Weights for a fit: `None` gives equal weights; otherwise an array of `shape` (one weight per
/// sample) of finite, non-negative numbers with a positive sum, returned divided by the largest.
fn fit_weights(weights: Option<&Bound<'_, PyAny>>, shape: &[usize]) -> PyResult<Vec<f64>> {
    let Some(weights) = weights else {
        return Ok(vec![1.0; shape.iter().product()]);
    };
    let array = shaped_float_array("weights", weights, |got| {
        if got == shape {
            return Ok(());
        }
        Err(PyValueError::new_err(format!(
            "weights: expected an array of shape {}, one per sample, got {}",
            shape_text(shape, false),
            shape_text(got, false)
        )))
    })?;
    let values: Vec<f64> = array.as_array().iter().copied().collect();
    if let Some((i, w)) = values
        .iter()
        .enumerate()
        .find(|(_, w)| !w.is_finite() || **w < 0.0)
    {
        return Err(PyValueError::new_err(format!(
            "weights[{i}] is {w}: every weight must be a finite non-negative number"
        )));
    }
    // A fit depends on the weights' ratios only: divided by the largest, they sum to at most n,
    // however large they are (weights of 1e308 summed to inf, and every sample's share to 0).
    let largest = values.iter().copied().fold(0.0, f64::max);
    if largest <= 0.0 {
        return Err(PyValueError::new_err("weights: their sum must be positive"));
    }
    Ok(values.into_iter().map(|w| w / largest).collect())
}

/// The samples of a fit, `(n, *point_shape)`, each validated by `parse` with the GIL released (a
/// bad one raises `ValueError` naming its index), and their weights ([`fit_weights`]).
fn fit_samples<P: Send>(
    py: Python<'_>,
    samples: &Bound<'_, PyAny>,
    weights: Option<&Bound<'_, PyAny>>,
    point_shape: &[usize],
    parse: fn(&[f64]) -> Result<P, ManifoldError>,
) -> PyResult<(Vec<P>, Vec<f64>)> {
    let array = shaped_float_array("samples", samples, |got| {
        if got.len() == point_shape.len() + 1 && got[1..] == *point_shape {
            return Ok(());
        }
        Err(PyValueError::new_err(format!(
            "samples: expected an array of shape {}, got {}",
            shape_text(point_shape, true),
            shape_text(got, false)
        )))
    })?;
    let width: usize = point_shape.iter().product();
    let pts = points("samples", &array.as_array(), point_shape)?;
    let n = pts.leading[0];
    if n == 0 {
        return Err(PyValueError::new_err(
            "samples: at least one sample is needed",
        ));
    }
    let w = fit_weights(weights, &[n])?;
    let data: &[f64] = &pts.data;
    let parsed = py.detach(|| {
        data.chunks_exact(width)
            .enumerate()
            .map(|(index, chunk)| {
                parse(chunk).map_err(|e| PointError {
                    index,
                    message: e.to_string(),
                })
            })
            .collect::<Result<Vec<P>, PointError>>()
    });
    py.check_signals()?;
    let xs = parsed
        .map_err(|e| PyValueError::new_err(format!("samples[{}]: {}", e.index, e.message)))?;
    Ok((xs, w))
}

/// The normalised product of two densities of a family and its log evidence `ln ∫ p q`.
fn product_with_evidence<D: Product>(p: &D, q: &D) -> PyResult<(D, f64)> {
    let joint = p.product(q).map_err(value_error)?;
    let evidence = p.log_product_integral(q).map_err(value_error)?;
    Ok((joint, evidence))
}

// ---------------------------------------------------------------------------------------------
// Points of each space.
// ---------------------------------------------------------------------------------------------

/// An angle (radians), checked for finiteness.
fn angle(s: &[f64]) -> Result<So2<f64>, DensityError> {
    Ok(So2::from_angle(s[0])?)
}

/// A rotation written as its row-major matrix.
fn put_rotation(r: &So3<f64>, out: &mut [f64]) {
    put_matrix(&r.to_matrix(), out);
}

/// A point of S² written as its unit vector.
fn put_sphere_point(x: &S2<f64>, out: &mut [f64]) {
    put_vector(x.as_vector(), out);
}

/// A unit quaternion written scalar first.
fn put_quaternion(q: &Su2<f64>, out: &mut [f64]) {
    out.copy_from_slice(&q.to_quaternion_wxyz());
}

/// The mean parameter of a constructor: a single point of the given shape.
fn single_point<P>(
    name: &str,
    obj: &Bound<'_, PyAny>,
    shape: &[usize],
    parse: impl Fn(&[f64]) -> Result<P, ManifoldError>,
) -> PyResult<P> {
    let values = parameter(name, obj, shape)?;
    parse(&values).map_err(|e| PyValueError::new_err(format!("{name}: {e}")))
}

/// A short float for `__repr__` (Python's shortest round-trip form).
fn short(v: f64) -> String {
    format!("{v:?}")
}

// ---------------------------------------------------------------------------------------------
// Von Mises.
// ---------------------------------------------------------------------------------------------

/// The von Mises distribution on the circle, `p(θ) = exp(κ cos(θ − μ)) / (2π I₀(κ))` with respect
/// to dθ; κ from 0 (uniform) to 1e300.
#[pyclass(name = "VonMises", module = "liebayes._liebayes", frozen)]
pub(crate) struct PyVonMises {
    /// The wrapped density.
    inner: VonMises,
}

#[pymethods]
impl PyVonMises {
    /// The distribution with mean direction `mu` (radians) and concentration `kappa ≥ 0`.
    #[new]
    fn new(
        #[pyo3(from_py_with = arg::mu)] mu: f64,
        #[pyo3(from_py_with = arg::kappa)] kappa: f64,
    ) -> PyResult<Self> {
        let mean = So2::from_angle(mu).map_err(|e| value_error(format!("mu: {e}")))?;
        VonMises::new(mean, kappa)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The distribution with natural parameter `eta = κ (cos μ, sin μ)`, shape `(2,)`.
    #[staticmethod]
    fn from_natural(eta: &Bound<'_, PyAny>) -> PyResult<Self> {
        let v = parameter("eta", eta, &[2])?;
        VonMises::from_natural(Vector2::new(v[0], v[1]))
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The uniform distribution on the circle (κ = 0).
    #[staticmethod]
    fn uniform() -> Self {
        Self {
            inner: VonMises::uniform(),
        }
    }

    /// The maximum-likelihood fit to angles `samples` (any shape, radians) with optional
    /// non-negative `weights` of the same shape: the library's `from_first_moment` of the weighted
    /// mean of `(cos θ, sin θ)`.
    #[staticmethod]
    #[pyo3(signature = (samples, weights = None))]
    fn fit(
        py: Python<'_>,
        samples: &Bound<'_, PyAny>,
        weights: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let array = float_array("samples", samples)?;
        let angles: Vec<f64> = array.as_array().iter().copied().collect();
        if angles.is_empty() {
            return Err(PyValueError::new_err(
                "samples: at least one sample is needed",
            ));
        }
        if let Some((i, a)) = angles.iter().enumerate().find(|(_, a)| !a.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "samples[{i}] (flat index) is {a}: every angle must be a finite number"
            )));
        }
        let w = fit_weights(weights, array.shape())?;
        // The moment's sums without the GIL (10^7 angles are a noticeable fraction of a second).
        let moment = py.detach(|| {
            let total: f64 = w.iter().sum();
            angles
                .iter()
                .zip(&w)
                .fold(Vector2::zeros(), |acc, (a, wi)| {
                    acc + Vector2::new(a.cos(), a.sin()) * (wi / total)
                })
        });
        py.check_signals()?;
        VonMises::from_first_moment(moment)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// `ln p(θ)` for angles `x` (any shape, radians): an array of the same shape (a float for a
    /// scalar).
    fn log_pdf<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        map_points(py, "x", x, &[], angle, |p| self.inner.log_pdf(p))
    }

    /// `n` draws (angles in (−π, π]) from the ChaCha8 stream seeded by `rng.integers(0, 2**63)`.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = arg::n)] n: usize,
        rng: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        draw(py, &self.inner, n, rng, &[], |p, out| out[0] = p.angle())
    }

    /// The normalised product `p q / ∫ p q` and the log evidence `ln ∫ p q dθ`.
    fn product(&self, other: &Bound<'_, Self>) -> PyResult<(Self, f64)> {
        let (inner, evidence) = product_with_evidence(&self.inner, &other.get().inner)?;
        Ok((Self { inner }, evidence))
    }

    /// `ln Z = ln(2π I₀(κ))`.
    fn log_normaliser(&self) -> f64 {
        self.inner.log_normalizer()
    }

    /// The gradient of `ln Z` with respect to the natural parameter η: the mean resultant vector
    /// `E[(cos θ, sin θ)] = A(κ) (cos μ, sin μ)`, shape `(2,)`.
    fn log_normaliser_gradient<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let m = self.inner.trigonometric_moment(1).map_err(value_error)?;
        vector_array(py, &m)
    }

    /// The natural parameter η = κ (cos μ, sin μ), shape `(2,)`.
    #[getter]
    fn natural<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        vector_array(py, &self.inner.natural())
    }

    /// The mean direction μ in (−π, π], or `None` for the uniform distribution.
    #[getter]
    fn mean(&self) -> Option<f64> {
        self.inner.mean().map(|m| m.angle())
    }

    /// The concentration κ.
    #[getter]
    fn concentration(&self) -> f64 {
        self.inner.concentration()
    }

    /// The mean resultant length `A(κ) = I₁(κ)/I₀(κ)`.
    fn mean_resultant_length(&self) -> f64 {
        self.inner.mean_resultant_length()
    }

    /// The circular variance `1 − A(κ)`.
    fn circular_variance(&self) -> f64 {
        self.inner.circular_variance()
    }

    /// The differential entropy with respect to dθ.
    fn entropy(&self) -> f64 {
        self.inner.entropy()
    }

    /// `KL(self ‖ other)`.
    fn kl_divergence(&self, other: &Bound<'_, Self>) -> f64 {
        self.inner.kl_divergence(&other.get().inner)
    }

    /// `VonMises(mu=…, kappa=…)`.
    fn __repr__(&self) -> String {
        format!(
            "VonMises(mu={}, kappa={})",
            short(self.inner.mean().map_or(0.0, |m| m.angle())),
            short(self.inner.concentration())
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Von Mises-Fisher.
// ---------------------------------------------------------------------------------------------

/// The von Mises-Fisher distribution on S², `p(x) = κ/(4π sinh κ) exp(κ μ·x)` with respect to
/// the surface measure; κ from 0 (uniform) to 1e300.
#[pyclass(name = "VonMisesFisher", module = "liebayes._liebayes", frozen)]
pub(crate) struct PyVonMisesFisher {
    /// The wrapped density.
    inner: VonMisesFisher,
}

#[pymethods]
impl PyVonMisesFisher {
    /// The distribution with unit mean direction `mean` (shape `(3,)`, norm 1 to 1e-9) and
    /// concentration `kappa ≥ 0`.
    #[new]
    fn new(
        mean: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = arg::kappa)] kappa: f64,
    ) -> PyResult<Self> {
        let mean = single_point("mean", mean, &[3], sphere_point)?;
        VonMisesFisher::new(mean, kappa)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The distribution with natural parameter `eta = κ μ`, shape `(3,)`.
    #[staticmethod]
    fn from_natural(eta: &Bound<'_, PyAny>) -> PyResult<Self> {
        let v = parameter("eta", eta, &[3])?;
        VonMisesFisher::from_natural(Vector3::new(v[0], v[1], v[2]))
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The uniform distribution on the sphere.
    #[staticmethod]
    fn uniform() -> Self {
        Self {
            inner: VonMisesFisher::uniform(),
        }
    }

    /// The maximum-likelihood fit to unit vectors `samples` (shape `(n, 3)`) with optional
    /// non-negative `weights` (n,): the library's `from_first_moment` of the weighted mean
    /// `Σ wᵢ xᵢ / Σ wᵢ` (`μ` its direction, `κ = A₃⁻¹(|mean|)`).
    #[staticmethod]
    #[pyo3(signature = (samples, weights = None))]
    fn fit(
        py: Python<'_>,
        samples: &Bound<'_, PyAny>,
        weights: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (xs, w) = fit_samples(py, samples, weights, &[3], sphere_point)?;
        let total: f64 = w.iter().sum();
        let m = xs.iter().zip(&w).fold(Vector3::zeros(), |m, (x, wi)| {
            m + x.as_vector() * (wi / total)
        });
        VonMisesFisher::from_first_moment(m)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// `ln p(x)` for unit vectors `x` of shape `(3,)` or `(..., 3)`.
    fn log_pdf<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        map_points(py, "x", x, &[3], sphere_point, |p| self.inner.log_pdf(p))
    }

    /// `n` draws, shape `(n, 3)`, from the ChaCha8 stream seeded by `rng.integers(0, 2**63)`.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = arg::n)] n: usize,
        rng: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        draw(py, &self.inner, n, rng, &[3], put_sphere_point)
    }

    /// The normalised product and the log evidence `ln ∫ p q dS`.
    fn product(&self, other: &Bound<'_, Self>) -> PyResult<(Self, f64)> {
        let (inner, evidence) = product_with_evidence(&self.inner, &other.get().inner)?;
        Ok((Self { inner }, evidence))
    }

    /// `ln Z = ln(4π sinh κ / κ)`.
    fn log_normaliser(&self) -> f64 {
        self.inner.log_normalizer()
    }

    /// The gradient of `ln Z` with respect to η: the first moment `E[x] = (coth κ − 1/κ) μ`,
    /// shape `(3,)`.
    fn log_normaliser_gradient<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        vector_array(py, &self.inner.first_moment())
    }

    /// The natural parameter η = κ μ, shape `(3,)`.
    #[getter]
    fn natural<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        vector_array(py, &self.inner.natural())
    }

    /// The mean direction μ, shape `(3,)`, or `None` for the uniform distribution.
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .mean()
            .map(|m| vector_array(py, m.as_vector()))
            .transpose()
    }

    /// The concentration κ.
    #[getter]
    fn concentration(&self) -> f64 {
        self.inner.concentration()
    }

    /// The first moment `E[x]`, shape `(3,)`.
    fn first_moment<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        vector_array(py, &self.inner.first_moment())
    }

    /// The differential entropy with respect to the surface measure.
    fn entropy(&self) -> f64 {
        self.inner.entropy()
    }

    /// `KL(self ‖ other)`.
    fn kl_divergence(&self, other: &Bound<'_, Self>) -> f64 {
        self.inner.kl_divergence(&other.get().inner)
    }

    /// `VonMisesFisher(mean=[…], kappa=…)`.
    fn __repr__(&self) -> String {
        let m = self
            .inner
            .mean()
            .map_or(Vector3::zeros(), |m| *m.as_vector());
        format!(
            "VonMisesFisher(mean=[{}, {}, {}], kappa={})",
            short(m[0]),
            short(m[1]),
            short(m[2]),
            short(self.inner.concentration())
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Bingham.
// ---------------------------------------------------------------------------------------------

/// The Bingham distribution on unit quaternions `q = (w, x, y, z)`,
/// `p(q) = exp(qᵀ M q) / K(M)` with respect to the uniform probability measure on S³,
/// `M = V diag(z) Vᵀ`; eigenvalue spread `max z − min z` at most 1e12 (`Bingham::MAX_SPREAD`).
#[pyclass(name = "Bingham", module = "liebayes._liebayes", frozen)]
pub(crate) struct PyBingham {
    /// The wrapped density.
    inner: Bingham,
}

/// A 4×4 matrix parameter, row-major.
fn matrix4(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Matrix4<f64>> {
    Ok(Matrix4::from_row_slice(&parameter(name, obj, &[4, 4])?))
}

#[pymethods]
impl PyBingham {
    /// The distribution `V diag(z) Vᵀ` from an orthogonal `orientation` V (4×4, columns the
    /// eigenvectors in (w, x, y, z) coordinates) and `eigenvalues` z (4,), in any order (sorted
    /// descending with their columns).
    #[new]
    fn new(orientation: &Bound<'_, PyAny>, eigenvalues: &Bound<'_, PyAny>) -> PyResult<Self> {
        let v = matrix4("orientation", orientation)?;
        let z = parameter("eigenvalues", eigenvalues, &[4])?;
        Bingham::new(v, Vector4::from_row_slice(&z))
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The distribution with symmetric parameter matrix `m` (4×4), the natural parameter.
    #[staticmethod]
    fn from_natural(m: &Bound<'_, PyAny>) -> PyResult<Self> {
        Bingham::from_natural(matrix4("m", m)?)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The likelihood of a `measured` body-frame direction of a world `reference` direction with
    /// isotropic noise `sigma`, as a Bingham density of the orientation.
    #[staticmethod]
    fn from_direction(
        measured: &Bound<'_, PyAny>,
        reference: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = arg::sigma)] sigma: f64,
    ) -> PyResult<Self> {
        let v = parameter("measured", measured, &[3])?;
        let h = parameter("reference", reference, &[3])?;
        Bingham::from_direction(
            &Vector3::from_row_slice(&v),
            &Vector3::from_row_slice(&h),
            sigma,
        )
        .map(|inner| Self { inner })
        .map_err(value_error)
    }

    /// The uniform distribution on S³.
    #[staticmethod]
    fn uniform() -> Self {
        Self {
            inner: Bingham::uniform(),
        }
    }

    /// The maximum-likelihood fit to unit quaternions `samples` (shape `(n, 4)`) with optional
    /// non-negative `weights` (n,): the library's `from_second_moment` of the weighted scatter
    /// matrix `Σ wᵢ qᵢ qᵢᵀ / Σ wᵢ`.
    #[staticmethod]
    #[pyo3(signature = (samples, weights = None))]
    fn fit(
        py: Python<'_>,
        samples: &Bound<'_, PyAny>,
        weights: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (qs, w) = fit_samples(py, samples, weights, &[4], quaternion)?;
        let total: f64 = w.iter().sum();
        let scatter = qs.iter().zip(&w).fold(Matrix4::zeros(), |s, (q, wi)| {
            let v = Vector4::from(q.to_quaternion_wxyz());
            s + v * v.transpose() * (wi / total)
        });
        Bingham::from_second_moment(scatter)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// `ln p(q)` for unit quaternions `q` (w, x, y, z) of shape `(4,)` or `(..., 4)`.
    fn log_pdf<'py>(&self, py: Python<'py>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        map_points(py, "q", q, &[4], quaternion, |p| self.inner.log_pdf(p))
    }

    /// `n` draws, unit quaternions of shape `(n, 4)`, from the ChaCha8 stream seeded by
    /// `rng.integers(0, 2**63)`.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = arg::n)] n: usize,
        rng: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        draw(py, &self.inner, n, rng, &[4], put_quaternion)
    }

    /// The normalised product (`M₁ + M₂`) and the log evidence `ln ∫ p q`.
    fn product(&self, other: &Bound<'_, Self>) -> PyResult<(Self, f64)> {
        let (inner, evidence) = product_with_evidence(&self.inner, &other.get().inner)?;
        Ok((Self { inner }, evidence))
    }

    /// `ln K(z)` against the uniform probability measure on S³.
    fn log_normaliser(&self) -> f64 {
        self.inner.log_normalizer()
    }

    /// `ln K` against the raw surface measure of S³ (`log_normaliser() + ln 2π²`).
    fn log_normaliser_surface(&self) -> f64 {
        self.inner.log_normalizer_surface()
    }

    /// The gradient `∂ ln K / ∂zₖ = E[(vₖ · q)²]`, in the order of `eigenvalues`, shape `(4,)`.
    fn log_normaliser_gradient<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        vector_array(py, &self.inner.eigen_moments())
    }

    /// The eigenvalues z, descending, shape `(4,)`.
    #[getter]
    fn eigenvalues<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        vector_array(py, &self.inner.eigenvalues())
    }

    /// The orthogonal matrix V of eigenvectors (column k belongs to eigenvalue k), shape `(4, 4)`.
    #[getter]
    fn orientation<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix_array(py, self.inner.orientation())
    }

    /// The natural parameter `M = V diag(z) Vᵀ`, shape `(4, 4)`.
    #[getter]
    fn natural<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix_array(py, &self.inner.natural())
    }

    /// The mode (eigenvector of the largest eigenvalue, w ≥ 0), shape `(4,)`, or `None` where
    /// the largest eigenvalue is repeated.
    #[getter]
    fn mode<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.inner
            .mode()
            .map(|q| array_of(py, q.to_quaternion_wxyz().to_vec(), &[4]))
            .transpose()
    }

    /// The second-moment matrix `E[q qᵀ]`, shape `(4, 4)`.
    fn second_moment<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix_array(py, &self.inner.second_moment())
    }

    /// The differential entropy with respect to the uniform probability measure.
    fn entropy(&self) -> f64 {
        self.inner.entropy()
    }

    /// `KL(self ‖ other)`.
    fn kl_divergence(&self, other: &Bound<'_, Self>) -> f64 {
        self.inner.kl_divergence(&other.get().inner)
    }

    /// `Bingham(eigenvalues=[…])`.
    fn __repr__(&self) -> String {
        let z = self.inner.eigenvalues();
        format!(
            "Bingham(eigenvalues=[{}, {}, {}, {}])",
            short(z[0]),
            short(z[1]),
            short(z[2]),
            short(z[3])
        )
    }
}

/// The Bingham normaliser `ln K(z)` (uniform probability measure on S³) and its gradient
/// `∂ ln K/∂zₖ`, for eigenvalues `z` of shape `(4,)` in any order (spread at most 1e12).
#[pyfunction]
fn bingham_log_normaliser<'py>(
    py: Python<'py>,
    z: &Bound<'py, PyAny>,
) -> PyResult<(f64, Bound<'py, PyAny>)> {
    let z = parameter("z", z, &[4])?;
    let z = [z[0], z[1], z[2], z[3]];
    let (value, gradient) = bingham_log_normalizer_and_moments(&z).map_err(value_error)?;
    Ok((value, array_of(py, gradient.to_vec(), &[4])?))
}

// ---------------------------------------------------------------------------------------------
// Heat kernel on SO(3).
// ---------------------------------------------------------------------------------------------

/// The heat kernel (isotropic Brownian motion) on SO(3) with centre `mean` and per-axis variance
/// s, with respect to the normalised Haar measure; s from 1e-300.
#[pyclass(name = "HeatKernelSo3", module = "liebayes._liebayes", frozen)]
pub(crate) struct PyHeatKernelSo3 {
    /// The wrapped density.
    inner: HeatKernelSo3,
}

/// `f` over rotation angles `t` (any shape) that the library checks to lie in [0, π].
fn map_angles<'py>(
    py: Python<'py>,
    t: &Bound<'py, PyAny>,
    f: impl Fn(f64) -> Result<f64, DensityError> + Sync,
) -> PyResult<Bound<'py, PyAny>> {
    map_points(py, "t", t, &[], |s: &[f64]| f(s[0]), |v: &f64| *v)
}

#[pymethods]
impl PyHeatKernelSo3 {
    /// The heat kernel centred at the rotation matrix `mean` (3×3) with variance `variance` (rad²).
    #[new]
    fn new(
        mean: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = arg::variance)] variance: f64,
    ) -> PyResult<Self> {
        let mean = single_point("mean", mean, &[3, 3], rotation)?;
        HeatKernelSo3::new(mean, variance)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// `ln p(R)` for rotation matrices `r` of shape `(3, 3)` or `(..., 3, 3)`.
    fn log_pdf<'py>(&self, py: Python<'py>, r: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        map_points(py, "r", r, &[3, 3], rotation, |p| self.inner.log_pdf(p))
    }

    /// `n` draws, rotation matrices of shape `(n, 3, 3)`, from the ChaCha8 stream seeded by
    /// `rng.integers(0, 2**63)`.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = arg::n)] n: usize,
        rng: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        draw(py, &self.inner, n, rng, &[3, 3], put_rotation)
    }

    /// `ln Z`: 0, the kernel is normalised.
    fn log_normaliser(&self) -> f64 {
        self.inner.log_normalizer()
    }

    /// The density of the rotation angle of `mean⁻¹ R` at angles `t` in [0, π] (any shape).
    fn angle_pdf<'py>(
        &self,
        py: Python<'py>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        map_angles(py, t, |a| self.inner.angle_pdf(a))
    }

    /// The CDF of the rotation angle at angles `t` in [0, π] (any shape).
    fn angle_cdf<'py>(
        &self,
        py: Python<'py>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        map_angles(py, t, |a| self.inner.angle_cdf(a))
    }

    /// The exact convolution (distribution of `A B`): centres multiply, variances add.
    fn convolve(&self, other: &Bound<'_, Self>) -> PyResult<Self> {
        self.inner
            .convolve(&other.get().inner)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The centre (mode and mean rotation), shape `(3, 3)`.
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix_array(py, &self.inner.mean().to_matrix())
    }

    /// The per-axis variance s (rad²).
    #[getter]
    fn variance(&self) -> f64 {
        self.inner.variance()
    }

    /// `E[R] = e^(−s) · mean`, shape `(3, 3)`.
    fn first_moment<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix_array(py, &self.inner.first_moment())
    }

    /// The differential entropy with respect to the normalised Haar measure (by quadrature).
    fn entropy(&self) -> f64 {
        self.inner.entropy()
    }

    /// `KL(self ‖ other)` (by quadrature).
    fn kl_divergence(&self, other: &Bound<'_, Self>) -> f64 {
        self.inner.kl_divergence(&other.get().inner)
    }

    /// `HeatKernelSo3(angle=…, variance=…)`: the rotation angle of the centre.
    fn __repr__(&self) -> String {
        format!(
            "HeatKernelSo3(mean_angle={}, variance={})",
            short(self.inner.mean().angle()),
            short(self.inner.variance())
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Manifold Gaussians.
// ---------------------------------------------------------------------------------------------

/// The Gaussian `R = mean · exp(δ)`, `δ ~ N(0, P)` on SO(3) (body-frame tangent errors); the log
/// density is with respect to the Lebesgue measure in the tangent coordinates at the mean.
#[pyclass(name = "ManifoldGaussianSo3", module = "liebayes._liebayes", frozen)]
pub(crate) struct PyManifoldGaussianSo3 {
    /// The wrapped density.
    inner: ManifoldGaussian<So3<f64>, 3>,
}

#[pymethods]
impl PyManifoldGaussianSo3 {
    /// The Gaussian with mean rotation matrix `mean` (3×3) and tangent covariance `cov` (3×3,
    /// symmetric positive definite).
    #[new]
    fn new(mean: &Bound<'_, PyAny>, cov: &Bound<'_, PyAny>) -> PyResult<Self> {
        let mean = single_point("mean", mean, &[3, 3], rotation)?;
        let p = Matrix3::from_row_slice(&parameter("cov", cov, &[3, 3])?);
        ManifoldGaussian::new(mean, p)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The moment fit to rotation matrices `samples` (shape `(n, 3, 3)`) with optional non-negative `weights` (n,): the library's
    /// `ManifoldGaussian::fit`, the weighted mean on the manifold and the weighted scatter of the
    /// tangent residuals (the maximum-likelihood fit as the spread goes to zero).
    #[staticmethod]
    #[pyo3(signature = (samples, weights = None))]
    fn fit(
        py: Python<'_>,
        samples: &Bound<'_, PyAny>,
        weights: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (xs, w) = fit_samples(py, samples, weights, &[3, 3], rotation)?;
        let fitted = py.detach(|| ManifoldGaussian::fit(&xs, &w));
        py.check_signals()?;
        fitted.map(|inner| Self { inner }).map_err(value_error)
    }

    /// `ln p(R)` for rotation matrices `r` of shape `(3, 3)` or `(..., 3, 3)`.
    fn log_pdf<'py>(&self, py: Python<'py>, r: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        map_points(py, "r", r, &[3, 3], rotation, |p| self.inner.log_pdf(p))
    }

    /// The squared Mahalanobis distance `δᵀ P⁻¹ δ`, `δ = log(mean⁻¹ R)`, per rotation matrix.
    fn mahalanobis_squared<'py>(
        &self,
        py: Python<'py>,
        r: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        map_points(py, "r", r, &[3, 3], rotation, |p| {
            self.inner.mahalanobis_squared(p)
        })
    }

    /// `n` draws, rotation matrices of shape `(n, 3, 3)`, from the ChaCha8 stream seeded by
    /// `rng.integers(0, 2**63)`.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = arg::n)] n: usize,
        rng: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        draw(py, &self.inner, n, rng, &[3, 3], put_rotation)
    }

    /// `ln Z = ½ (3 ln 2π + ln det P)`.
    fn log_normaliser(&self) -> f64 {
        self.inner.log_normalizer()
    }

    /// First-order distribution of `A B` for independent `A ~ self`, `B ~ other`.
    fn compose(&self, other: &Bound<'_, Self>) -> PyResult<Self> {
        self.inner
            .compose(&other.get().inner)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The mean rotation, shape `(3, 3)`.
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix_array(py, &self.inner.mean().to_matrix())
    }

    /// The tangent covariance P, shape `(3, 3)`.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix_array(py, self.inner.covariance())
    }

    /// The entropy with respect to the tangent Lebesgue measure.
    fn entropy(&self) -> f64 {
        self.inner.entropy()
    }

    /// `KL(self ‖ other)` for two Gaussians with the same mean.
    fn kl_divergence(&self, other: &Bound<'_, Self>) -> PyResult<f64> {
        self.inner
            .kl_divergence(&other.get().inner)
            .map_err(value_error)
    }

    /// `ManifoldGaussianSo3(mean_angle=…, cov_diagonal=[…])`.
    fn __repr__(&self) -> String {
        let d = self.inner.covariance().diagonal();
        format!(
            "ManifoldGaussianSo3(mean_angle={}, cov_diagonal=[{}, {}, {}])",
            short(self.inner.mean().angle()),
            short(d[0]),
            short(d[1]),
            short(d[2])
        )
    }
}

/// The Gaussian `x = exp_μ(B(μ) δ)`, `δ ~ N(0, P)` on S² (2-dimensional tangent coordinates in the
/// library's basis `B(μ)`, see `tangent_basis`); the log density is with respect to the Lebesgue
/// measure in those coordinates.
#[pyclass(name = "ManifoldGaussianS2", module = "liebayes._liebayes", frozen)]
pub(crate) struct PyManifoldGaussianS2 {
    /// The wrapped density.
    inner: ManifoldGaussian<S2<f64>, 2>,
}

#[pymethods]
impl PyManifoldGaussianS2 {
    /// The Gaussian with unit mean `mean` (3,) and tangent covariance `cov` (2×2, symmetric
    /// positive definite) in the basis `tangent_basis()`.
    #[new]
    fn new(mean: &Bound<'_, PyAny>, cov: &Bound<'_, PyAny>) -> PyResult<Self> {
        let mean = single_point("mean", mean, &[3], sphere_point)?;
        let p = Matrix2::from_row_slice(&parameter("cov", cov, &[2, 2])?);
        ManifoldGaussian::new(mean, p)
            .map(|inner| Self { inner })
            .map_err(value_error)
    }

    /// The moment fit to unit vectors `samples` (shape `(n, 3)`) with optional non-negative `weights` (n,): the library's
    /// `ManifoldGaussian::fit`, the weighted mean on the manifold and the weighted scatter of the
    /// tangent residuals (the maximum-likelihood fit as the spread goes to zero).
    #[staticmethod]
    #[pyo3(signature = (samples, weights = None))]
    fn fit(
        py: Python<'_>,
        samples: &Bound<'_, PyAny>,
        weights: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (xs, w) = fit_samples(py, samples, weights, &[3], sphere_point)?;
        let fitted = py.detach(|| ManifoldGaussian::fit(&xs, &w));
        py.check_signals()?;
        fitted.map(|inner| Self { inner }).map_err(value_error)
    }

    /// `ln p(x)` for unit vectors `x` of shape `(3,)` or `(..., 3)`.
    fn log_pdf<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        map_points(py, "x", x, &[3], sphere_point, |p| self.inner.log_pdf(p))
    }

    /// The squared Mahalanobis distance of each unit vector `x`.
    fn mahalanobis_squared<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        map_points(py, "x", x, &[3], sphere_point, |p| {
            self.inner.mahalanobis_squared(p)
        })
    }

    /// `n` draws, unit vectors of shape `(n, 3)`, from the ChaCha8 stream seeded by
    /// `rng.integers(0, 2**63)`.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = arg::n)] n: usize,
        rng: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        draw(py, &self.inner, n, rng, &[3], put_sphere_point)
    }

    /// `ln Z = ½ (2 ln 2π + ln det P)`.
    fn log_normaliser(&self) -> f64 {
        self.inner.log_normalizer()
    }

    /// The mean direction, shape `(3,)`.
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        vector_array(py, self.inner.mean().as_vector())
    }

    /// The tangent covariance P, shape `(2, 2)`.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix_array(py, self.inner.covariance())
    }

    /// The orthonormal tangent basis `B(μ) = [b1 b2]` at the mean (`b1 × b2 = μ`), shape `(3, 2)`:
    /// the tangent coordinates δ of a point are `B(μ)ᵀ log_μ(x)`.
    fn tangent_basis<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix_array(py, &self.inner.mean().tangent_basis())
    }

    /// The entropy with respect to the tangent Lebesgue measure.
    fn entropy(&self) -> f64 {
        self.inner.entropy()
    }

    /// `KL(self ‖ other)` for two Gaussians with the same mean.
    fn kl_divergence(&self, other: &Bound<'_, Self>) -> PyResult<f64> {
        self.inner
            .kl_divergence(&other.get().inner)
            .map_err(value_error)
    }

    /// `ManifoldGaussianS2(mean=[…], cov_diagonal=[…])`.
    fn __repr__(&self) -> String {
        let m = self.inner.mean().as_vector();
        let d = self.inner.covariance().diagonal();
        format!(
            "ManifoldGaussianS2(mean=[{}, {}, {}], cov_diagonal=[{}, {}])",
            short(m[0]),
            short(m[1]),
            short(m[2]),
            short(d[0]),
            short(d[1])
        )
    }
}
