//! The manifolds area of the package (`liebayes.manifolds`): SO(3) as rotation matrices, unit
//! quaternions (SU(2), scalar first), the sphere S² and SE(3) as homogeneous matrices, each a class
//! of static methods over numpy arrays.
//!
//! Every method takes one element (a rotation matrix `(3, 3)`, a rotation vector `(3,)`, ...) or a
//! batch of them (a leading axis of any length `n`) and returns the same: a single element in gives
//! a single element out, a batch gives a batch. Methods of two arguments broadcast a single element
//! against a batch; two batches must have the same length. The arrays are read in place when they
//! are C-contiguous `float64` (anything else real-valued is converted once by
//! `numpy.asarray`), every element is validated by the library's own constructors, and
//! the loop over the elements runs without the GIL. A bad element raises `ValueError` with the
//! argument's name, the element's index and the library's message.
//!
//! The maths is the library's (`liebayes_manifolds`); this file only moves numbers in and out.

use crate::arrays::{self, put_matrix, put_vector, shape_text};
use crate::errors::value_error;
use liebayes_manifolds::{GroupAction, LieGroup, Manifold, ManifoldError, S2, Se3, So3, Su2};
use nalgebra::{Matrix3, Matrix4, SVector, Vector2, Vector3, Vector6};
use numpy::{PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyFloat;

/// Adds the area's classes to the extension module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<So3Ops>()?;
    m.add_class::<UnitQuaternionOps>()?;
    m.add_class::<S2Ops>()?;
    m.add_class::<Se3Ops>()?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Arrays in and out
// ---------------------------------------------------------------------------------------------

/// Shape of a scalar result (a distance).
const SCALAR: &[usize] = &[];
/// Shape of a tangent vector of S².
const VEC2: &[usize] = &[2];
/// Shape of a rotation vector, a point of R³ or of S².
const VEC3: &[usize] = &[3];
/// Shape of a quaternion `[w, x, y, z]`.
const VEC4: &[usize] = &[4];
/// Shape of an SE(3) tangent `[ρ; φ]`.
const VEC6: &[usize] = &[6];
/// Shape of a 3×3 matrix.
const MAT3: &[usize] = &[3, 3];
/// Shape of the tangent basis of S².
const MAT3X2: &[usize] = &[3, 2];
/// Shape of a 3×6 matrix (the Jacobian of the SE(3) action in the motion).
const MAT3X6: &[usize] = &[3, 6];
/// Shape of a homogeneous 4×4 matrix.
const MAT4: &[usize] = &[4, 4];
/// Shape of a 6×6 matrix.
const MAT6: &[usize] = &[6, 6];

/// `numpy.zeros`, looked up once.
static ZEROS: PyOnceLock<Py<PyAny>> = PyOnceLock::new();

/// One argument: a single element of a fixed shape or a batch of them, read in place.
struct Elements<'py> {
    /// The argument's name, for the error messages.
    name: &'static str,
    /// The array, borrowed read-only for the duration of the call.
    array: PyReadonlyArrayDyn<'py, f64>,
    /// `None` for a single element, `Some(n)` for a batch of `n`.
    count: Option<usize>,
    /// Numbers per element.
    width: usize,
}

impl<'py> Elements<'py> {
    /// Reads `obj` as one element of shape `shape` or a batch `(n, *shape)`, checking the shape
    /// before anything is read.
    fn read(name: &'static str, obj: &Bound<'py, PyAny>, shape: &[usize]) -> PyResult<Self> {
        let classify = |got: &[usize]| -> PyResult<Option<usize>> {
            if got == shape {
                Ok(None)
            } else if got.len() == shape.len() + 1 && &got[1..] == shape {
                Ok(Some(got[0]))
            } else {
                Err(PyValueError::new_err(format!(
                    "{name}: expected shape {} for one element or {} for n elements, got {}",
                    shape_text(shape, false),
                    shape_text(shape, true),
                    shape_text(got, false)
                )))
            }
        };
        // Checked before a numpy array is converted or copied, then on the array read.
        let array = arrays::shaped_float_array(name, obj, |got| classify(got).map(|_| ()))?;
        let count = classify(array.shape())?;
        Ok(Self {
            name,
            array,
            count,
            width: shape.iter().product(),
        })
    }
}

/// Why one element could not be used: which argument (its position) and the library's message.
struct Failure {
    /// Position of the argument in the call's inputs.
    arg: usize,
    /// The library's message.
    message: String,
}

/// Turns a library error about argument `arg` into a [`Failure`].
fn fail(arg: usize) -> impl Fn(ManifoldError) -> Failure {
    move |e| Failure {
        arg,
        message: e.to_string(),
    }
}

/// The common length of the batches among `inputs` (`None` when every one is a single element).
fn broadcast_count(inputs: &[&Elements<'_>]) -> PyResult<Option<usize>> {
    let mut common: Option<(usize, &str)> = None;
    for input in inputs {
        if let Some(n) = input.count {
            match common {
                Some((m, first)) if m != n => {
                    return Err(PyValueError::new_err(format!(
                        "{first} has {m} elements and {} has {n}: batches must have the same \
                         length, or one of the arguments must be a single element",
                        input.name
                    )));
                }
                Some(_) => {}
                None => common = Some((n, input.name)),
            }
        }
    }
    Ok(common.map(|(n, _)| n))
}

/// Applies `f` element by element (a single element broadcast against a batch), without the GIL,
/// and returns the results as a new array: one element of shape `out_shape` for single inputs, a
/// batch `(n, *out_shape)` otherwise (a Python float for a single scalar).
///
/// `f` receives each input's element as a slice of its numbers in C order and writes its result,
/// in C order, into the output slice.
fn map_elements<'py, const N: usize>(
    py: Python<'py>,
    inputs: [&Elements<'py>; N],
    out_shape: &[usize],
    f: impl Fn([&[f64]; N], &mut [f64]) -> Result<(), Failure> + Send + Sync,
) -> PyResult<Bound<'py, PyAny>> {
    let count = broadcast_count(&inputs)?;
    let width: usize = out_shape.iter().product();
    let mut shape = Vec::with_capacity(out_shape.len() + 1);
    if let Some(n) = count {
        shape.push(n);
    }
    shape.extend_from_slice(out_shape);
    // Allocated by numpy (a MemoryError rather than an abort when it does not fit, and numpy's
    // allocator, which asks for huge pages on large arrays) and filled in place below.
    let result = ZEROS
        .import(py, "numpy", "zeros")?
        .call1((shape,))?
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|_| value_error("numpy.zeros did not return an array of float64"))?;
    let mut slices: [&[f64]; N] = [&[]; N];
    for (slot, input) in slices.iter_mut().zip(inputs) {
        *slot = input.array.as_slice().map_err(value_error)?;
    }
    let widths: [usize; N] = std::array::from_fn(|j| inputs[j].width);
    let batched: [bool; N] = std::array::from_fn(|j| inputs[j].count.is_some());
    let mut writer = result.try_readwrite().map_err(value_error)?;
    let out = writer.as_slice_mut().map_err(value_error)?;
    let filled = py.detach(|| -> Result<(), (usize, Failure)> {
        // A zero width (no output numbers) cannot occur: every output has at least one number.
        for (i, chunk) in out.chunks_exact_mut(width).enumerate() {
            let element: [&[f64]; N] = std::array::from_fn(|j| {
                let k = if batched[j] { i } else { 0 };
                &slices[j][k * widths[j]..(k + 1) * widths[j]]
            });
            f(element, chunk).map_err(|failure| (i, failure))?;
        }
        Ok(())
    });
    py.check_signals()?;
    filled.map_err(|(i, failure)| {
        let input = inputs[failure.arg];
        if input.count.is_some() {
            value_error(format!("{}[{i}]: {}", input.name, failure.message))
        } else {
            value_error(format!("{}: {}", input.name, failure.message))
        }
    })?;
    if count.is_none() && out_shape.is_empty() {
        return Ok(PyFloat::new(py, out[0]).into_any());
    }
    drop(writer);
    Ok(result.into_any())
}

/// A vector of finite numbers, as the library reports a non-finite component.
fn finite_vector<const R: usize>(
    arg: usize,
    what: &'static str,
    s: &[f64],
) -> Result<SVector<f64, R>, Failure> {
    match s.iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(fail(arg)(ManifoldError::NonFinite { what, value })),
        None => Ok(SVector::<f64, R>::from_column_slice(s)),
    }
}

/// A rotation vector (the library checks it is finite).
fn rotation_vector(arg: usize, s: &[f64]) -> Result<Vector3<f64>, Failure> {
    finite_vector::<3>(arg, "rotation vector", s)
}

/// A rotation matrix, checked by the library (finite, orthonormal, determinant +1).
fn rotation(arg: usize, s: &[f64]) -> Result<So3<f64>, Failure> {
    arrays::rotation(s).map_err(fail(arg))
}

/// A unit quaternion `[w, x, y, z]`, checked by the library (finite, unit norm).
fn quaternion(arg: usize, s: &[f64]) -> Result<Su2<f64>, Failure> {
    arrays::quaternion(s).map_err(fail(arg))
}

/// A point of S², checked by the library (finite, unit norm).
fn sphere_point(arg: usize, s: &[f64]) -> Result<S2<f64>, Failure> {
    arrays::sphere_point(s).map_err(fail(arg))
}

/// A homogeneous 4×4 matrix of SE(3), checked by the library (finite, bottom row, rotation block).
fn pose(arg: usize, s: &[f64]) -> Result<Se3<f64>, Failure> {
    Se3::from_matrix(&Matrix4::from_row_slice(s)).map_err(fail(arg))
}

/// An SE(3) tangent `[ρ; φ]` of finite numbers.
fn twist(arg: usize, s: &[f64]) -> Result<Vector6<f64>, Failure> {
    finite_vector::<6>(arg, "SE(3) tangent", s)
}

/// A point of R³ of finite numbers.
fn point(arg: usize, s: &[f64]) -> Result<Vector3<f64>, Failure> {
    finite_vector::<3>(arg, "point", s)
}

/// Reads one argument (shorthand for [`Elements::read`]).
fn read<'py>(
    name: &'static str,
    obj: &Bound<'py, PyAny>,
    shape: &[usize],
) -> PyResult<Elements<'py>> {
    Elements::read(name, obj, shape)
}

// ---------------------------------------------------------------------------------------------
// SO(3)
// ---------------------------------------------------------------------------------------------

/// Rotations of space, SO(3), as rotation matrices.
///
/// Elements are rotation matrices of shape (3, 3) or batches (n, 3, 3); tangent vectors are
/// rotation vectors (axis times angle in radians) of shape (3,) or (n, 3). Rotations are active
/// (`R v` turns `v`), `compose(a, b) = a @ b` applies `b` first, perturbations are on the right
/// (`retract(R, w) = R exp(w)`), and the Jacobians are the right ones unless named left.
/// Matrices are checked: finite, `|RᵀR - I|` and `|det R - 1|` at most 1e-9 per entry.
#[pyclass(name = "So3", module = "liebayes._liebayes", frozen)]
struct So3Ops;

#[pymethods]
impl So3Ops {
    /// exp(omega): the rotation matrices of rotation vectors. (3,) -> (3, 3), (n, 3) -> (n, 3, 3).
    #[staticmethod]
    fn exp<'py>(omega: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let v = read("omega", omega, VEC3)?;
        map_elements(omega.py(), [&v], MAT3, |[s], out| {
            let r = So3::from_rotation_vector(&Vector3::from_column_slice(s)).map_err(fail(0))?;
            put_matrix(&r.to_matrix(), out);
            Ok(())
        })
    }

    /// log(r): the rotation vectors of rotation matrices, angle in [0, pi]. (3, 3) -> (3,),
    /// (n, 3, 3) -> (n, 3).
    #[staticmethod]
    fn log<'py>(r: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("r", r, MAT3)?;
        map_elements(r.py(), [&x], VEC3, |[s], out| {
            put_vector(&rotation(0, s)?.log(), out);
            Ok(())
        })
    }

    /// compose(a, b): the products `a @ b` (apply b first). Broadcasts a single rotation against a
    /// batch.
    #[staticmethod]
    fn compose<'py>(a: &Bound<'py, PyAny>, b: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ea, eb) = (read("a", a, MAT3)?, read("b", b, MAT3)?);
        map_elements(a.py(), [&ea, &eb], MAT3, |[sa, sb], out| {
            put_matrix(
                &rotation(0, sa)?.compose(&rotation(1, sb)?).to_matrix(),
                out,
            );
            Ok(())
        })
    }

    /// inverse(r): the inverse rotations (the transposes).
    #[staticmethod]
    fn inverse<'py>(r: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("r", r, MAT3)?;
        map_elements(r.py(), [&x], MAT3, |[s], out| {
            put_matrix(&rotation(0, s)?.inverse().to_matrix(), out);
            Ok(())
        })
    }

    /// act(r, v): the rotated vectors `R v`. R (3, 3) or (n, 3, 3), v (3,) or (n, 3), broadcast.
    #[staticmethod]
    fn act<'py>(r: &Bound<'py, PyAny>, v: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (er, ev) = (read("r", r, MAT3)?, read("v", v, VEC3)?);
        map_elements(r.py(), [&er, &ev], VEC3, |[sr, sv], out| {
            put_vector(&rotation(0, sr)?.act(&point(1, sv)?), out);
            Ok(())
        })
    }

    /// act_jacobian(r, v): `d(R v)/dR = -R hat(v)` for a right perturbation `R exp(w)`, shape
    /// (3, 3) per element (the Jacobian in v is R itself).
    #[staticmethod]
    fn act_jacobian<'py>(
        r: &Bound<'py, PyAny>,
        v: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (er, ev) = (read("r", r, MAT3)?, read("v", v, VEC3)?);
        map_elements(r.py(), [&er, &ev], MAT3, |[sr, sv], out| {
            put_matrix(&rotation(0, sr)?.j_act_self(&point(1, sv)?), out);
            Ok(())
        })
    }

    /// retract(r, omega): `R exp(omega)`, the right perturbation. Broadcasts.
    #[staticmethod]
    fn retract<'py>(
        r: &Bound<'py, PyAny>,
        omega: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (er, ev) = (read("r", r, MAT3)?, read("omega", omega, VEC3)?);
        map_elements(r.py(), [&er, &ev], MAT3, |[sr, sv], out| {
            put_matrix(
                &rotation(0, sr)?
                    .retract(&rotation_vector(1, sv)?)
                    .to_matrix(),
                out,
            );
            Ok(())
        })
    }

    /// local(a, b): `log(aᵀ b)`, the rotation vector at a that leads to b. Broadcasts.
    #[staticmethod]
    fn local<'py>(a: &Bound<'py, PyAny>, b: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ea, eb) = (read("a", a, MAT3)?, read("b", b, MAT3)?);
        map_elements(a.py(), [&ea, &eb], VEC3, |[sa, sb], out| {
            put_vector(&rotation(0, sa)?.local(&rotation(1, sb)?), out);
            Ok(())
        })
    }

    /// distance(a, b): the angle in [0, pi] of `aᵀ b`; a float for two single rotations, shape
    /// (n,) otherwise.
    #[staticmethod]
    fn distance<'py>(a: &Bound<'py, PyAny>, b: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ea, eb) = (read("a", a, MAT3)?, read("b", b, MAT3)?);
        map_elements(a.py(), [&ea, &eb], SCALAR, |[sa, sb], out| {
            out[0] = rotation(0, sa)?.distance(&rotation(1, sb)?);
            Ok(())
        })
    }

    /// adjoint(r): the adjoint matrices `Ad(R)`, which for SO(3) is R itself (validated).
    #[staticmethod]
    fn adjoint<'py>(r: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("r", r, MAT3)?;
        map_elements(r.py(), [&x], MAT3, |[s], out| {
            put_matrix(&rotation(0, s)?.adjoint(), out);
            Ok(())
        })
    }

    /// right_jacobian(omega): `Jr(omega)` with `exp(omega + d) = exp(omega) exp(Jr d + O(d²))`.
    /// (3,) -> (3, 3), (n, 3) -> (n, 3, 3).
    #[staticmethod]
    fn right_jacobian<'py>(omega: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        so3_jacobian(omega, So3::<f64>::right_jacobian)
    }

    /// left_jacobian(omega): `Jl(omega) = Jr(-omega)`, with
    /// `exp(omega + d) = exp(Jl d + O(d²)) exp(omega)`.
    #[staticmethod]
    fn left_jacobian<'py>(omega: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        so3_jacobian(omega, So3::<f64>::left_jacobian)
    }

    /// right_jacobian_inverse(omega): `Jr(omega)⁻¹`, singular at angles 2 pi k (k >= 1).
    #[staticmethod]
    fn right_jacobian_inverse<'py>(omega: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        so3_jacobian(omega, So3::<f64>::right_jacobian_inverse)
    }

    /// left_jacobian_inverse(omega): `Jl(omega)⁻¹ = Jr(-omega)⁻¹`.
    #[staticmethod]
    fn left_jacobian_inverse<'py>(omega: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        so3_jacobian(omega, So3::<f64>::left_jacobian_inverse)
    }

    /// hat(omega): the skew matrices with `hat(omega) v = omega x v`.
    #[staticmethod]
    fn hat<'py>(omega: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        so3_jacobian(omega, So3::<f64>::hat)
    }

    /// vee(a): the vectors of the antisymmetric parts of 3×3 matrices (the inverse of hat on skew
    /// matrices). (3, 3) -> (3,), (n, 3, 3) -> (n, 3).
    #[staticmethod]
    fn vee<'py>(a: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("a", a, MAT3)?;
        map_elements(a.py(), [&x], VEC3, |[s], out| {
            let m = finite_vector::<9>(0, "matrix", s)?;
            put_vector(
                &So3::<f64>::vee(&Matrix3::from_row_slice(m.as_slice())),
                out,
            );
            Ok(())
        })
    }

    /// from_quaternion(q): the rotation matrices of unit quaternions `[w, x, y, z]` (scalar first;
    /// q and -q give the same rotation). Checked: finite, `|norm - 1|` at most 1e-9.
    #[staticmethod]
    fn from_quaternion<'py>(q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("q", q, VEC4)?;
        map_elements(q.py(), [&x], MAT3, |[s], out| {
            put_matrix(&quaternion(0, s)?.to_rotation_matrix(), out);
            Ok(())
        })
    }

    /// to_quaternion(r): the unit quaternions `[w, x, y, z]` of rotation matrices, with `w >= 0`.
    #[staticmethod]
    fn to_quaternion<'py>(r: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("r", r, MAT3)?;
        map_elements(r.py(), [&x], VEC4, |[s], out| {
            out.copy_from_slice(&rotation(0, s)?.to_su2().to_quaternion_wxyz());
            Ok(())
        })
    }

    /// orthonormalize(m): the rotation nearest to each matrix in the Frobenius norm (the polar
    /// factor), for matrices that drifted from orthonormality. Refuses det M <= 0.
    #[staticmethod]
    fn orthonormalize<'py>(m: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("m", m, MAT3)?;
        map_elements(m.py(), [&x], MAT3, |[s], out| {
            let r =
                So3::from_matrix_orthonormalized(&Matrix3::from_row_slice(s)).map_err(fail(0))?;
            put_matrix(&r.to_matrix(), out);
            Ok(())
        })
    }
}

/// A 3×3 matrix function of a rotation vector, element by element.
fn so3_jacobian<'py>(
    omega: &Bound<'py, PyAny>,
    f: impl Fn(&Vector3<f64>) -> Matrix3<f64> + Send + Sync,
) -> PyResult<Bound<'py, PyAny>> {
    let v = read("omega", omega, VEC3)?;
    map_elements(omega.py(), [&v], MAT3, |[s], out| {
        put_matrix(&f(&rotation_vector(0, s)?), out);
        Ok(())
    })
}

// ---------------------------------------------------------------------------------------------
// Unit quaternions
// ---------------------------------------------------------------------------------------------

/// Unit quaternions, SU(2), the double cover of SO(3): Hamilton, scalar first `[w, x, y, z]`.
///
/// Elements have shape (4,) or (n, 4) and are checked: finite, `|norm - 1|` at most 1e-9 (use
/// `normalize` first for quaternions that drifted). q and -q are distinct points here (they are the
/// same rotation). Tangent vectors are rotation vectors, as for `So3`: `exp(v) = (cos(θ/2),
/// sin(θ/2) v/θ)`, θ = |v|, and `log` returns angles in [0, 2 pi] (`w < 0` gives angles above pi).
#[pyclass(name = "UnitQuaternion", module = "liebayes._liebayes", frozen)]
struct UnitQuaternionOps;

#[pymethods]
impl UnitQuaternionOps {
    /// exp(omega): the unit quaternions of rotation vectors. (3,) -> (4,), (n, 3) -> (n, 4).
    #[staticmethod]
    fn exp<'py>(omega: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let v = read("omega", omega, VEC3)?;
        map_elements(omega.py(), [&v], VEC4, |[s], out| {
            let q = Su2::from_rotation_vector(&Vector3::from_column_slice(s)).map_err(fail(0))?;
            out.copy_from_slice(&q.to_quaternion_wxyz());
            Ok(())
        })
    }

    /// log(q): the rotation vectors of unit quaternions, angle 2 atan2(|xyz|, w) in [0, 2 pi].
    #[staticmethod]
    fn log<'py>(q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("q", q, VEC4)?;
        map_elements(q.py(), [&x], VEC3, |[s], out| {
            put_vector(&quaternion(0, s)?.log(), out);
            Ok(())
        })
    }

    /// compose(p, q): the Hamilton products `p q` (the rotation of q first). Broadcasts.
    #[staticmethod]
    fn compose<'py>(p: &Bound<'py, PyAny>, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ep, eq) = (read("p", p, VEC4)?, read("q", q, VEC4)?);
        map_elements(p.py(), [&ep, &eq], VEC4, |[sp, sq], out| {
            let r = quaternion(0, sp)?.compose(&quaternion(1, sq)?);
            out.copy_from_slice(&r.to_quaternion_wxyz());
            Ok(())
        })
    }

    /// inverse(q): the inverses (conjugates) `[w, -x, -y, -z]`.
    #[staticmethod]
    fn inverse<'py>(q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("q", q, VEC4)?;
        map_elements(q.py(), [&x], VEC4, |[s], out| {
            out.copy_from_slice(&quaternion(0, s)?.inverse().to_quaternion_wxyz());
            Ok(())
        })
    }

    /// act(q, v): the rotated vectors `q v q*`. Broadcasts.
    #[staticmethod]
    fn act<'py>(q: &Bound<'py, PyAny>, v: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (eq, ev) = (read("q", q, VEC4)?, read("v", v, VEC3)?);
        map_elements(q.py(), [&eq, &ev], VEC3, |[sq, sv], out| {
            put_vector(&quaternion(0, sq)?.act(&point(1, sv)?), out);
            Ok(())
        })
    }

    /// to_matrix(q): the rotation matrices of `v -> q v q*`. (4,) -> (3, 3), (n, 4) -> (n, 3, 3).
    #[staticmethod]
    fn to_matrix<'py>(q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("q", q, VEC4)?;
        map_elements(q.py(), [&x], MAT3, |[s], out| {
            put_matrix(&quaternion(0, s)?.to_rotation_matrix(), out);
            Ok(())
        })
    }

    /// from_matrix(r): the unit quaternions of rotation matrices, the lift with `w >= 0`.
    #[staticmethod]
    fn from_matrix<'py>(r: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("r", r, MAT3)?;
        map_elements(r.py(), [&x], VEC4, |[s], out| {
            out.copy_from_slice(&rotation(0, s)?.to_su2().to_quaternion_wxyz());
            Ok(())
        })
    }

    /// normalize(q): `q / |q|` for any finite, non-zero quaternions (at least 1e-150 long).
    #[staticmethod]
    fn normalize<'py>(q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("q", q, VEC4)?;
        map_elements(q.py(), [&x], VEC4, |[s], out| {
            let q = nalgebra::Quaternion::new(s[0], s[1], s[2], s[3]);
            let u = Su2::from_quaternion_normalizing(q).map_err(fail(0))?;
            out.copy_from_slice(&u.to_quaternion_wxyz());
            Ok(())
        })
    }
}

// ---------------------------------------------------------------------------------------------
// S²
// ---------------------------------------------------------------------------------------------

/// The unit sphere S² in R³ (directions), a manifold but not a group.
///
/// Points have shape (3,) or (n, 3) and are checked: finite, `|norm - 1|` at most 1e-9 (use
/// `normalize` for other lengths). `exp`/`log` take and return ambient tangent vectors (3
/// numbers, orthogonal to the base point); `retract`/`local` use two coordinates in the tangent
/// basis `B(x) = [b1 b2]` (`b1 x b2 = x`, see `tangent_basis`). Distances are great-circle angles.
#[pyclass(name = "S2", module = "liebayes._liebayes", frozen)]
struct S2Ops;

#[pymethods]
impl S2Ops {
    /// exp(x, w): `cos|w| x + sin|w| w/|w|`, the point reached from x along the ambient tangent w
    /// (its component along x is ignored). Broadcasts.
    #[staticmethod]
    fn exp<'py>(x: &Bound<'py, PyAny>, w: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ex, ew) = (read("x", x, VEC3)?, read("w", w, VEC3)?);
        map_elements(x.py(), [&ex, &ew], VEC3, |[sx, sw], out| {
            let w = finite_vector::<3>(1, "tangent vector", sw)?;
            put_vector(sphere_point(0, sx)?.exp_at(&w).as_vector(), out);
            Ok(())
        })
    }

    /// log(x, y): the ambient tangent at x along the great circle to y, of length the angle
    /// between them (at the antipode, pi b1). Broadcasts.
    #[staticmethod]
    fn log<'py>(x: &Bound<'py, PyAny>, y: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ex, ey) = (read("x", x, VEC3)?, read("y", y, VEC3)?);
        map_elements(x.py(), [&ex, &ey], VEC3, |[sx, sy], out| {
            put_vector(&sphere_point(0, sx)?.log_at(&sphere_point(1, sy)?), out);
            Ok(())
        })
    }

    /// retract(x, u): `exp(x, B(x) u)` for tangent coordinates u of shape (2,) or (n, 2).
    #[staticmethod]
    fn retract<'py>(x: &Bound<'py, PyAny>, u: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ex, eu) = (read("x", x, VEC3)?, read("u", u, VEC2)?);
        map_elements(x.py(), [&ex, &eu], VEC3, |[sx, su], out| {
            let u: Vector2<f64> = finite_vector::<2>(1, "tangent coordinates", su)?;
            put_vector(sphere_point(0, sx)?.retract(&u).as_vector(), out);
            Ok(())
        })
    }

    /// local(x, y): `B(x)ᵀ log(x, y)`, the tangent coordinates at x that lead to y, (2,) or (n, 2).
    #[staticmethod]
    fn local<'py>(x: &Bound<'py, PyAny>, y: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ex, ey) = (read("x", x, VEC3)?, read("y", y, VEC3)?);
        map_elements(x.py(), [&ex, &ey], VEC2, |[sx, sy], out| {
            put_vector(&sphere_point(0, sx)?.local(&sphere_point(1, sy)?), out);
            Ok(())
        })
    }

    /// distance(x, y): the great-circle angle in [0, pi]; a float for two single points, (n,)
    /// otherwise.
    #[staticmethod]
    fn distance<'py>(x: &Bound<'py, PyAny>, y: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ex, ey) = (read("x", x, VEC3)?, read("y", y, VEC3)?);
        map_elements(x.py(), [&ex, &ey], SCALAR, |[sx, sy], out| {
            out[0] = sphere_point(0, sx)?.distance(&sphere_point(1, sy)?);
            Ok(())
        })
    }

    /// tangent_basis(x): the orthonormal basis `[b1 b2]` of the tangent plane at x, shape (3, 2)
    /// or (n, 3, 2), with `b1 x b2 = x`.
    #[staticmethod]
    fn tangent_basis<'py>(x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let ex = read("x", x, VEC3)?;
        map_elements(x.py(), [&ex], MAT3X2, |[sx], out| {
            put_matrix(&sphere_point(0, sx)?.tangent_basis(), out);
            Ok(())
        })
    }

    /// normalize(v): the directions `v / |v|` of finite, non-zero vectors (at least 1e-150 long).
    #[staticmethod]
    fn normalize<'py>(v: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let ev = read("v", v, VEC3)?;
        map_elements(v.py(), [&ev], VEC3, |[sv], out| {
            let p =
                S2::from_vector_normalizing(&Vector3::from_column_slice(sv)).map_err(fail(0))?;
            put_vector(p.as_vector(), out);
            Ok(())
        })
    }
}

// ---------------------------------------------------------------------------------------------
// SE(3)
// ---------------------------------------------------------------------------------------------

/// Rigid motions of space, SE(3), as homogeneous 4×4 matrices `[[R, t], [0, 0, 0, 1]]`.
///
/// Elements have shape (4, 4) or (n, 4, 4), checked: finite, bottom row `[0, 0, 0, 1]` and rotation
/// block as for `So3` (tolerance 1e-9). Tangent vectors have shape (6,) or (n, 6) and put **the
/// translation block first**: `xi = [rho; phi]`, `exp(xi) = (exp(phi), V(phi) rho)` with V the left
/// Jacobian of SO(3). Perturbations are on the right (`retract(T, xi) = x exp(xi)`: rho is a
/// displacement in the body frame) and the Jacobians are right Jacobians unless named left.
#[pyclass(name = "Se3", module = "liebayes._liebayes", frozen)]
struct Se3Ops;

#[pymethods]
impl Se3Ops {
    /// exp(xi): the homogeneous matrices of tangents `[rho; phi]`. (6,) -> (4, 4),
    /// (n, 6) -> (n, 4, 4).
    #[staticmethod]
    fn exp<'py>(xi: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let v = read("xi", xi, VEC6)?;
        map_elements(xi.py(), [&v], MAT4, |[s], out| {
            put_matrix(&Se3::exp(&twist(0, s)?).to_homogeneous(), out);
            Ok(())
        })
    }

    /// log(x): the tangents `[rho; phi]` of homogeneous matrices, rotation angle in [0, pi].
    #[staticmethod]
    fn log<'py>(x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let ex = read("x", x, MAT4)?;
        map_elements(x.py(), [&ex], VEC6, |[s], out| {
            put_vector(&pose(0, s)?.log(), out);
            Ok(())
        })
    }

    /// compose(a, b): the products `a @ b` (apply b first). Broadcasts.
    #[staticmethod]
    fn compose<'py>(a: &Bound<'py, PyAny>, b: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ea, eb) = (read("a", a, MAT4)?, read("b", b, MAT4)?);
        map_elements(a.py(), [&ea, &eb], MAT4, |[sa, sb], out| {
            put_matrix(&pose(0, sa)?.compose(&pose(1, sb)?).to_homogeneous(), out);
            Ok(())
        })
    }

    /// inverse(x): the inverse motions `[[Rᵀ, -Rᵀ t], [0, 1]]`.
    #[staticmethod]
    fn inverse<'py>(x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let ex = read("x", x, MAT4)?;
        map_elements(x.py(), [&ex], MAT4, |[s], out| {
            put_matrix(&pose(0, s)?.inverse().to_homogeneous(), out);
            Ok(())
        })
    }

    /// act(x, p): the transformed points `R p + t`. Broadcasts.
    #[staticmethod]
    fn act<'py>(x: &Bound<'py, PyAny>, p: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (et, ep) = (read("x", x, MAT4)?, read("p", p, VEC3)?);
        map_elements(x.py(), [&et, &ep], VEC3, |[st, sp], out| {
            put_vector(&pose(0, st)?.act(&point(1, sp)?), out);
            Ok(())
        })
    }

    /// act_jacobian(x, p): `d(x p)/dx = [R, -R hat(p)]` for a right perturbation, shape (3, 6) per
    /// element (the Jacobian in p is R).
    #[staticmethod]
    fn act_jacobian<'py>(
        x: &Bound<'py, PyAny>,
        p: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (et, ep) = (read("x", x, MAT4)?, read("p", p, VEC3)?);
        map_elements(x.py(), [&et, &ep], MAT3X6, |[st, sp], out| {
            put_matrix(&pose(0, st)?.j_act_self(&point(1, sp)?), out);
            Ok(())
        })
    }

    /// retract(x, xi): `x exp(xi)`, the right perturbation. Broadcasts.
    #[staticmethod]
    fn retract<'py>(x: &Bound<'py, PyAny>, xi: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (et, ev) = (read("x", x, MAT4)?, read("xi", xi, VEC6)?);
        map_elements(x.py(), [&et, &ev], MAT4, |[st, sv], out| {
            put_matrix(&pose(0, st)?.retract(&twist(1, sv)?).to_homogeneous(), out);
            Ok(())
        })
    }

    /// local(a, b): `log(a⁻¹ b)`, the tangent at a that leads to b. Broadcasts.
    #[staticmethod]
    fn local<'py>(a: &Bound<'py, PyAny>, b: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (ea, eb) = (read("a", a, MAT4)?, read("b", b, MAT4)?);
        map_elements(a.py(), [&ea, &eb], VEC6, |[sa, sb], out| {
            put_vector(&pose(0, sa)?.local(&pose(1, sb)?), out);
            Ok(())
        })
    }

    /// adjoint(x): `Ad(x) = [[R, hat(t) R], [0, R]]`, shape (6, 6) per element.
    #[staticmethod]
    fn adjoint<'py>(x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let ex = read("x", x, MAT4)?;
        map_elements(x.py(), [&ex], MAT6, |[s], out| {
            put_matrix(&pose(0, s)?.adjoint(), out);
            Ok(())
        })
    }

    /// right_jacobian(xi): `Jr(xi)` with `exp(xi + d) = exp(xi) exp(Jr d + O(d²))`, (6, 6) per
    /// element.
    #[staticmethod]
    fn right_jacobian<'py>(xi: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        se3_matrix(xi, MAT6, |v, out| {
            put_matrix(&Se3::<f64>::right_jacobian(v), out);
        })
    }

    /// left_jacobian(xi): `Jl(xi) = Jr(-xi)`, with `exp(xi + d) = exp(Jl d + O(d²)) exp(xi)`.
    #[staticmethod]
    fn left_jacobian<'py>(xi: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        se3_matrix(xi, MAT6, |v, out| {
            put_matrix(&Se3::<f64>::left_jacobian(v), out);
        })
    }

    /// right_jacobian_inverse(xi): `Jr(xi)⁻¹`, singular at rotation angles 2 pi k (k >= 1).
    #[staticmethod]
    fn right_jacobian_inverse<'py>(xi: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        se3_matrix(xi, MAT6, |v, out| {
            put_matrix(&Se3::<f64>::right_jacobian_inverse(v), out);
        })
    }

    /// left_jacobian_inverse(xi): `Jl(xi)⁻¹ = Jr(-xi)⁻¹`.
    #[staticmethod]
    fn left_jacobian_inverse<'py>(xi: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        se3_matrix(xi, MAT6, |v, out| {
            put_matrix(&Se3::<f64>::left_jacobian_inverse(v), out);
        })
    }

    /// hat(xi): the Lie-algebra matrices `[[hat(phi), rho], [0, 0]]`, (4, 4) per element.
    #[staticmethod]
    fn hat<'py>(xi: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        se3_matrix(xi, MAT4, |v, out| put_matrix(&Se3::<f64>::hat(v), out))
    }

    /// vee(a): `[A[0:3, 3]; vee(antisymmetric part of A[0:3, 0:3])]` of 4×4 matrices, (6,) per
    /// element (the inverse of hat on the algebra).
    #[staticmethod]
    fn vee<'py>(a: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = read("a", a, MAT4)?;
        map_elements(a.py(), [&x], VEC6, |[s], out| {
            let m = finite_vector::<16>(0, "matrix", s)?;
            put_vector(
                &Se3::<f64>::vee(&Matrix4::from_row_slice(m.as_slice())),
                out,
            );
            Ok(())
        })
    }

    /// from_rotation_translation(r, t): the homogeneous matrices `[[R, t], [0, 1]]` of rotation
    /// matrices (3, 3) and translations (3,), checked like every input. Broadcasts.
    #[staticmethod]
    fn from_rotation_translation<'py>(
        r: &Bound<'py, PyAny>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (er, et) = (read("r", r, MAT3)?, read("t", t, VEC3)?);
        map_elements(r.py(), [&er, &et], MAT4, |[sr, st], out| {
            let translation = finite_vector::<3>(1, "translation", st)?;
            let x = Se3::from_parts(&Matrix3::from_row_slice(sr), &translation).map_err(fail(0))?;
            put_matrix(&x.to_homogeneous(), out);
            Ok(())
        })
    }
}

/// A matrix function of an SE(3) tangent, element by element.
fn se3_matrix<'py>(
    xi: &Bound<'py, PyAny>,
    shape: &[usize],
    f: impl Fn(&Vector6<f64>, &mut [f64]) + Send + Sync,
) -> PyResult<Bound<'py, PyAny>> {
    let v = read("xi", xi, VEC6)?;
    map_elements(xi.py(), [&v], shape, |[s], out| {
        f(&twist(0, s)?, out);
        Ok(())
    })
}
