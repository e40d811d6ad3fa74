//! The attitude area (`liebayes.attitude`): the production IMU attitude filter with a batch API in
//! the shape of VQF's (`AttitudeFilter(dt, **params).update_batch(gyr, acc, mag=None)`), its
//! per-sample `update` for streaming, and the BROAD reader.
//!
//! The filter is the library's `AttitudeEkf`, stepped exactly as the library's `record` loop steps
//! it (predict with the gyroscope and accelerometer, then the magnetometer reading, then the
//! estimate), so its output equals the `liebayes attitude` binary's bit for bit.

use crate::arrays::{MAX_VALUES, Real3, arg, real_number, shaped_float_array};
use crate::errors::{Stopped, check_signals_at, in_use, value_error};
use liebayes_experiments::{RecursiveFilter, Smoothing};
use liebayes_filters::attitude::{
    AttitudeEkf, AttitudeEstimate, AttitudeParams, ImuSample, MAX_OFFLINE_SAMPLES, Propagation,
    Sensors, read_broad as read_broad_log,
};
use nalgebra::{UnitQuaternion, Vector3};
use numpy::ndarray::{ArrayView2, Ix2};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Adds the attitude filter and the BROAD reader to the extension module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<AttitudeFilter>()?;
    m.add_function(wrap_pyfunction!(offline_attitude, m)?)?;
    m.add_function(wrap_pyfunction!(offline_default_params, m)?)?;
    m.add_function(wrap_pyfunction!(read_broad, m)?)?;
    Ok(())
}

/// The keyword parameters `AttitudeFilter` accepts, in the order `params()` lists them.
const PARAMETER_NAMES: [&str; 21] = [
    "gyro_noise",
    "rate_noise",
    "bias_walk",
    "estimate_bias",
    "imu_delay",
    "initial_bias_sigma",
    "initial_tilt_sigma",
    "initial_heading_sigma",
    "velocity_bound",
    "velocity_walk",
    "position_bound",
    "velocity_interval",
    "block",
    "propagation",
    "rest_detection",
    "mag_heading_sigma",
    "mag_interval",
    "mag_delay",
    "mag_offset",
    "mag_disturbance_rejection",
    "tilt_variance_scale",
];

/// The production attitude filter (an error-state EKF on SO(3) × gyro bias × velocity, with rest
/// detection and magnetic-disturbance rejection): orientation of the IMU frame with respect to
/// East-North-Up as unit quaternions `[w, x, y, z]` (scalar first), with the heading and tilt σ.
///
/// `AttitudeFilter(dt=None, *, rate=None, sensors=None, **params)`: give the sampling interval
/// `dt` (s) or the `rate` (Hz), exactly one; `sensors` is `"9d"` (gyroscope, accelerometer,
/// magnetometer) or `"6d"`, or `None` to decide at the first update (9D when it has a
/// magnetometer); `params` are the keyword parameters listed by `AttitudeFilter.parameter_names()`
/// (SI units, angles in rad), the rest at their defaults (`AttitudeFilter.default_params()`).
///
/// A filter is used by one thread at a time: while `update_batch` runs (without the GIL), another
/// thread's `update_batch`, `update` or `reset` of it raises `ValueError` ("in use by another
/// call") and reading it raises `RuntimeError`; give each thread its own filter.
#[pyclass(module = "liebayes._liebayes")]
pub struct AttitudeFilter {
    params: AttitudeParams,
    rate: f64,
    sensors: Option<Sensors>,
    filter: Option<AttitudeEkf>,
}

/// The outputs of a batch, filled sample by sample (each a flat row-major buffer).
struct Outputs {
    quat: Vec<f64>,
    heading_sigma: Vec<f64>,
    tilt_sigma: Vec<f64>,
    bias: Vec<f64>,
    rest: Vec<bool>,
    mag_disturbance: Vec<bool>,
}

impl Outputs {
    /// Room for `n` samples' outputs, or `ValueError` when the memory cannot be had (rather than
    /// the abort of an infallible allocation).
    fn reserve(origin: &str, n: usize) -> PyResult<Self> {
        Ok(Self {
            quat: reserved(origin, n, 4)?,
            heading_sigma: reserved(origin, n, 1)?,
            tilt_sigma: reserved(origin, n, 1)?,
            bias: reserved(origin, n, 3)?,
            rest: reserved(origin, n, 1)?,
            mag_disturbance: reserved(origin, n, 1)?,
        })
    }
}

/// The most samples `update_batch` filters in one call: 2²⁴ (about 16 hours at 286 Hz), so that
/// its outputs (four quaternion components, two sigmas, three biases and two flags a sample) stay
/// within [`MAX_VALUES`] all together.
const MAX_BATCH_SAMPLES: usize = 1 << 24;
const _: () = assert!(MAX_BATCH_SAMPLES * 11 <= MAX_VALUES);

/// An empty vector with room for `n` samples of `k` values each, or `ValueError` from `origin`
/// saying that they do not fit in memory.
fn reserved<T>(origin: &str, n: usize, k: usize) -> PyResult<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n.saturating_mul(k)).map_err(|e| {
        PyValueError::new_err(format!(
            "{origin}: the results of {n} samples do not fit in memory ({e}); give fewer samples \
             in one call"
        ))
    })?;
    Ok(v)
}

/// A batch's arrays, each (n, 3) float64 (`mag` absent for 6D), checked before any work.
struct Batch<'py> {
    gyr: PyReadonlyArrayDyn<'py, f64>,
    acc: PyReadonlyArrayDyn<'py, f64>,
    mag: Option<PyReadonlyArrayDyn<'py, f64>>,
    n: usize,
}

impl<'py> Batch<'py> {
    /// The arrays of a call from `origin`: every one (n, 3) with the same n, at most `max` rows
    /// ([`MAX_BATCH_SAMPLES`] for a batch, [`MAX_OFFLINE_SAMPLES`] offline); a `mag` of `None` is
    /// 6D.
    /// Shapes and the size are checked before any array is converted or copied.
    fn read(
        origin: &str,
        max: usize,
        gyr: &Bound<'py, PyAny>,
        acc: &Bound<'py, PyAny>,
        mag: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Self> {
        let gyr = shaped_float_array("gyr", gyr, |shape| {
            let n = shape.first().copied().unwrap_or(0);
            check_rows(origin, "gyr", shape, n)?;
            if n > max {
                return Err(PyValueError::new_err(format!(
                    "{origin}: {n} samples, at most {max} in one call"
                )));
            }
            Ok(())
        })?;
        let n = gyr.shape()[0];
        let acc = shaped_float_array("acc", acc, |shape| check_rows(origin, "acc", shape, n))?;
        let mag = mag
            .filter(|m| !m.is_none())
            .map(|m| shaped_float_array("mag", m, |shape| check_rows(origin, "mag", shape, n)))
            .transpose()?;
        Ok(Self { gyr, acc, mag, n })
    }
}

/// A sample's failure: its index and the library's message.
struct Failure {
    sample: usize,
    message: String,
}

#[pymethods]
impl AttitudeFilter {
    #[new]
    #[pyo3(signature = (dt = None, *, rate = None, sensors = None, **params))]
    fn new(
        #[pyo3(from_py_with = arg::dt_or_none)] dt: Option<f64>,
        #[pyo3(from_py_with = arg::rate_or_none)] rate: Option<f64>,
        sensors: Option<&str>,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let rate = rate_of("AttitudeFilter", dt, rate)?;
        let sensors = sensors.map(parse_sensors).transpose()?;
        let p = with_params(&AttitudeParams::default(), params)?;
        // Checks every setting and the rate now, not at the first sample.
        AttitudeEkf::new(p.clone(), sensors.unwrap_or(Sensors::NineD), rate)
            .map_err(value_error)?;
        let filter = sensors
            .map(|s| AttitudeEkf::new(p.clone(), s, rate).map_err(value_error))
            .transpose()?;
        Ok(Self {
            params: p,
            rate,
            sensors,
            filter,
        })
    }

    /// The keyword parameters the constructor accepts.
    #[staticmethod]
    fn parameter_names() -> Vec<&'static str> {
        PARAMETER_NAMES.to_vec()
    }

    /// The default parameters, as a dict of keyword parameters.
    #[staticmethod]
    fn default_params(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        params_dict(py, &AttitudeParams::default())
    }

    /// This filter's parameters, as a dict of keyword parameters.
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        params_dict(py, &self.params)
    }

    /// The sampling rate (Hz).
    #[getter]
    fn rate(&self) -> f64 {
        self.rate
    }

    /// `"9d"`, `"6d"`, or `None` before the first update when it was not given.
    #[getter]
    fn sensors(&self) -> Option<&'static str> {
        self.sensors.map(|s| match s {
            Sensors::NineD => "9d",
            Sensors::SixD => "6d",
        })
    }

    /// Filters a batch of samples and returns, per sample, a dict of arrays: `quat` (n, 4)
    /// (scalar first), `heading_sigma` and `tilt_sigma` (n,) (rad), `bias` (n, 3) (rad/s),
    /// `rest` and `mag_disturbance` (n,) (bool). `gyr` (rad/s), `acc` (m/s²) and `mag` (any
    /// unit, e.g. µT) are (n, 3) float64 arrays in the IMU's axes; without `mag` the filter is
    /// 6D. The state carries over to the next call. All or nothing: on a refused sample the call
    /// raises `ValueError` naming it and the filter is as it was before the call. The GIL is
    /// released while filtering.
    #[pyo3(signature = (gyr, acc, mag = None))]
    fn update_batch<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        gyr: &Bound<'py, PyAny>,
        acc: &Bound<'py, PyAny>,
        mag: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        const ORIGIN: &str = "update_batch";
        let Batch { gyr, acc, mag, n } = Batch::read(ORIGIN, MAX_BATCH_SAMPLES, gyr, acc, mag)?;
        // Held until the call returns (see `in_use`), taken after the arguments are read.
        let mut this = slf.try_borrow_mut().map_err(|_| in_use("AttitudeFilter"))?;
        let (sensors, mut filter) = this.filter_for(mag.is_some())?;
        let (g, a) = (matrix(&gyr)?, matrix(&acc)?);
        let m = mag.as_ref().map(matrix).transpose()?;
        let mut outputs = Outputs::reserve(ORIGIN, n)?;
        let ran = py.detach(|| run_batch(&mut filter, &g, &a, m.as_ref(), &mut outputs));
        // A Ctrl-C during the batch is raised here, the filter as it was.
        py.check_signals()?;
        ran.map_err(|stop| match stop {
            Stopped::Interrupted(e) => e,
            Stopped::Failed(f) => PyValueError::new_err(format!(
                "update_batch: sample {}: {} (the filter is as it was before the call)",
                f.sample, f.message
            )),
        })?;
        // A batch without samples decides nothing (not the sensors of a filter built without
        // them): the filter stays as it was.
        if n > 0 {
            this.commit(sensors, filter);
        }
        let dict = PyDict::new(py);
        dict.set_item(
            "quat",
            PyArray1::from_vec(py, outputs.quat).reshape([n, 4])?,
        )?;
        dict.set_item(
            "heading_sigma",
            PyArray1::from_vec(py, outputs.heading_sigma),
        )?;
        dict.set_item("tilt_sigma", PyArray1::from_vec(py, outputs.tilt_sigma))?;
        dict.set_item(
            "bias",
            PyArray1::from_vec(py, outputs.bias).reshape([n, 3])?,
        )?;
        dict.set_item("rest", PyArray1::from_vec(py, outputs.rest))?;
        dict.set_item(
            "mag_disturbance",
            PyArray1::from_vec(py, outputs.mag_disturbance),
        )?;
        Ok(dict)
    }

    /// Filters one sample (for streaming use): `gyr` (rad/s), `acc` (m/s²) and `mag` as
    /// 3-sequences. Read the result from `quat`, `heading_sigma`, `tilt_sigma`, `bias`, `rest`,
    /// `mag_disturbance`. On a refused sample it raises `ValueError` and the state is unchanged.
    #[pyo3(signature = (gyr, acc, mag = None))]
    fn update(
        slf: &Bound<'_, Self>,
        gyr: &Bound<'_, PyAny>,
        acc: &Bound<'_, PyAny>,
        mag: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let gyr = Real3::read("gyr", gyr)?.0;
        let acc = Real3::read("acc", acc)?.0;
        let mag = mag
            .map(|m| Real3::read("mag", m).map(|m| m.0))
            .transpose()?;
        let mut this = slf.try_borrow_mut().map_err(|_| in_use("AttitudeFilter"))?;
        let (sensors, mut filter) = this.filter_for(mag.is_some())?;
        step(
            &mut filter,
            &ImuSample {
                gyro: Vector3::from(gyr),
                acc: Vector3::from(acc),
            },
            mag.map(Vector3::from).as_ref(),
        )
        .map_err(value_error)?;
        this.commit(sensors, filter);
        Ok(())
    }

    /// The orientation `[w, x, y, z]` after the last sample.
    #[getter]
    fn quat<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let q = self.estimate()?.0;
        Ok(PyArray1::from_slice(py, &[q.w, q.i, q.j, q.k]))
    }

    /// The world-frame attitude error covariance (3, 3) (rad²) after the last sample.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = self.estimate()?.1;
        let rows: Vec<Vec<f64>> = (0..3)
            .map(|i| (0..3).map(|j| p[(i, j)]).collect())
            .collect();
        PyArray2::from_vec2(py, &rows).map_err(value_error)
    }

    /// The heading σ (rad) after the last sample.
    #[getter]
    fn heading_sigma(&self) -> PyResult<f64> {
        Ok(sigmas(&self.estimate()?.1).0)
    }

    /// The tilt σ (rad) after the last sample.
    #[getter]
    fn tilt_sigma(&self) -> PyResult<f64> {
        Ok(sigmas(&self.estimate()?.1).1)
    }

    /// The estimated gyroscope bias (3,) (rad/s) after the last sample.
    #[getter]
    fn bias<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let b = self.running()?.bias().unwrap_or_else(Vector3::zeros);
        Ok(PyArray1::from_slice(py, b.as_slice()))
    }

    /// Whether the last sample was detected as rest.
    #[getter]
    fn rest(&self) -> PyResult<bool> {
        Ok(self.running()?.at_rest())
    }

    /// Whether the last magnetometer update was refused as magnetically disturbed (9D).
    #[getter]
    fn mag_disturbance(&self) -> PyResult<bool> {
        Ok(self.running()?.magnetic_disturbance())
    }

    /// Forgets every sample: the next update starts the filter anew.
    fn reset(slf: &Bound<'_, Self>) -> PyResult<()> {
        let mut this = slf.try_borrow_mut().map_err(|_| in_use("AttitudeFilter"))?;
        let this = &mut *this;
        this.filter = this
            .sensors
            .map(|s| AttitudeEkf::new(this.params.clone(), s, this.rate).map_err(value_error))
            .transpose()?;
        Ok(())
    }

    fn __repr__(&self) -> String {
        format!(
            "AttitudeFilter(rate={}, sensors={:?}, samples={})",
            self.rate,
            self.sensors().unwrap_or("undecided"),
            if self
                .filter
                .as_ref()
                .is_some_and(AttitudeEkf::is_initialised)
            {
                "some"
            } else {
                "none"
            }
        )
    }
}

impl AttitudeFilter {
    /// The sensors of a call with or without a magnetometer and a copy of the filter to step for
    /// it (a new one, with the sensors the call implies, before the first update); refuses a
    /// magnetometer given to a 6D filter or missing for a 9D one. Nothing is changed here: the
    /// caller keeps both by [`Self::commit`] once the step has succeeded, so that a refused first
    /// sample decides nothing.
    fn filter_for(&self, has_mag: bool) -> PyResult<(Sensors, AttitudeEkf)> {
        let wanted = if has_mag {
            Sensors::NineD
        } else {
            Sensors::SixD
        };
        let sensors = self.sensors.unwrap_or(wanted);
        if sensors != wanted {
            return Err(PyValueError::new_err(if has_mag {
                "AttitudeFilter: this filter is 6D and takes no magnetometer (build one with sensors=\"9d\")"
            } else {
                "AttitudeFilter: this filter is 9D and needs the magnetometer (mag=...)"
            }));
        }
        let filter = match &self.filter {
            Some(filter) => filter.clone(),
            None => {
                AttitudeEkf::new(self.params.clone(), sensors, self.rate).map_err(value_error)?
            }
        };
        Ok((sensors, filter))
    }

    /// Keeps a filter stepped without error (from [`Self::filter_for`]) and its sensors.
    fn commit(&mut self, sensors: Sensors, filter: AttitudeEkf) {
        self.sensors = Some(sensors);
        self.filter = Some(filter);
    }

    /// The filter once it has a sample.
    fn running(&self) -> PyResult<&AttitudeEkf> {
        self.filter
            .as_ref()
            .filter(|f| f.is_initialised())
            .ok_or_else(|| {
                PyValueError::new_err("AttitudeFilter: no sample yet (call update first)")
            })
    }

    /// The orientation and world-frame covariance after the last sample.
    fn estimate(&self) -> PyResult<(UnitQuaternion<f64>, nalgebra::Matrix3<f64>)> {
        let e = self.running()?.estimate().map_err(value_error)?;
        Ok((
            e.orientation,
            e.covariance.unwrap_or_else(nalgebra::Matrix3::zeros),
        ))
    }
}

/// The sampling rate (Hz) from exactly one of `dt` (s) and `rate`; `origin` names the caller.
fn rate_of(origin: &str, dt: Option<f64>, rate: Option<f64>) -> PyResult<f64> {
    match (dt, rate) {
        (Some(dt), None) if dt.is_finite() && dt > 0.0 => Ok(1.0 / dt),
        (None, Some(rate)) => Ok(rate),
        (Some(dt), None) => Err(PyValueError::new_err(format!(
            "{origin}: dt is {dt}, expected a finite positive sampling interval (s)"
        ))),
        _ => Err(PyValueError::new_err(format!(
            "{origin}: give exactly one of dt (s) and rate (Hz)"
        ))),
    }
}

/// `base` with the keyword parameters set (`AttitudeFilter.parameter_names()`); a part switched
/// on by a flag takes its settings from `base`.
fn with_params(
    base: &AttitudeParams,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<AttitudeParams> {
    let mut p = base.clone();
    if let Some(params) = params {
        for (key, value) in params.iter() {
            set_param(&mut p, base, &key.extract::<String>()?, &value)?;
        }
    }
    Ok(p)
}

/// The offline attitude estimate of a whole recording (the production filter's RTS smoother,
/// every sample given every sample; the library's `AttitudeEkf::offline`, equal to
/// `liebayes attitude --offline` bit for bit), in the shape of VQF's `offlineVQF`:
/// `offline_attitude(gyr, acc, mag=None, *, dt=None, rate=None, **params)` returns a dict of
/// arrays, `quat` (n, 4) (scalar first, the IMU frame w.r.t. East-North-Up), `heading_sigma` and
/// `tilt_sigma` (n,) (rad). `gyr` (rad/s), `acc` (m/s²) and `mag` are (n, 3) float64 arrays;
/// without `mag` it is 6D. Give exactly one of `dt` (s) and `rate` (Hz); `params` as
/// `AttitudeFilter`'s, the rest at the offline defaults (`offline_default_params()`: the filter's,
/// but for a magnetometer trusted twice as much and 0.04 s blocks, chosen by cross-validation on
/// BROAD). A refused sample raises `ValueError` naming it. The GIL is released while filtering.
#[pyfunction]
#[pyo3(signature = (gyr, acc, mag = None, *, dt = None, rate = None, **params))]
fn offline_attitude<'py>(
    py: Python<'py>,
    gyr: &Bound<'py, PyAny>,
    acc: &Bound<'py, PyAny>,
    mag: Option<&Bound<'py, PyAny>>,
    #[pyo3(from_py_with = arg::dt_or_none)] dt: Option<f64>,
    #[pyo3(from_py_with = arg::rate_or_none)] rate: Option<f64>,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    const ORIGIN: &str = "offline_attitude";
    let rate = rate_of(ORIGIN, dt, rate)?;
    let p = with_params(&AttitudeParams::offline(), params)?;
    let Batch { gyr, acc, mag, n } = Batch::read(ORIGIN, MAX_OFFLINE_SAMPLES, gyr, acc, mag)?;
    let sensors = if mag.is_some() {
        Sensors::NineD
    } else {
        Sensors::SixD
    };
    let mut filter = AttitudeEkf::offline(p, sensors, rate).map_err(value_error)?;
    let (g, a) = (matrix(&gyr)?, matrix(&acc)?);
    let m = mag.as_ref().map(matrix).transpose()?;
    let mut smoothed = reserved(ORIGIN, n, 1)?;
    let mut quat = reserved(ORIGIN, n, 4)?;
    let (mut heading_sigma, mut tilt_sigma) = (reserved(ORIGIN, n, 1)?, reserved(ORIGIN, n, 1)?);
    let ran = py.detach(|| smooth_batch(&mut filter, &g, &a, m.as_ref(), &mut smoothed));
    py.check_signals()?;
    ran.map_err(|stop| match stop {
        Stopped::Interrupted(e) => e,
        Stopped::Failed(f) => {
            PyValueError::new_err(format!("{ORIGIN}: sample {}: {}", f.sample, f.message))
        }
    })?;
    for e in &smoothed {
        let q = e.orientation;
        quat.extend_from_slice(&[q.w, q.i, q.j, q.k]);
        let (heading, tilt) = sigmas(&e.covariance.unwrap_or_else(nalgebra::Matrix3::zeros));
        heading_sigma.push(heading);
        tilt_sigma.push(tilt);
    }
    let dict = PyDict::new(py);
    dict.set_item("quat", PyArray1::from_vec(py, quat).reshape([n, 4])?)?;
    dict.set_item("heading_sigma", PyArray1::from_vec(py, heading_sigma))?;
    dict.set_item("tilt_sigma", PyArray1::from_vec(py, tilt_sigma))?;
    Ok(dict)
}

/// The default keyword parameters of `offline_attitude`, as a dict.
#[pyfunction]
fn offline_default_params(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    params_dict(py, &AttitudeParams::offline())
}

/// Steps the offline filter over every sample, then releases every sample's smoothed estimate.
fn smooth_batch(
    filter: &mut AttitudeEkf,
    gyr: &ArrayView2<'_, f64>,
    acc: &ArrayView2<'_, f64>,
    mag: Option<&ArrayView2<'_, f64>>,
    out: &mut Vec<AttitudeEstimate>,
) -> Result<(), Stopped<Failure>> {
    let row = |a: &ArrayView2<'_, f64>, k: usize| Vector3::new(a[[k, 0]], a[[k, 1]], a[[k, 2]]);
    let n = gyr.nrows();
    for k in 0..n {
        check_signals_at(k)?;
        let sample = ImuSample {
            gyro: row(gyr, k),
            acc: row(acc, k),
        };
        let z = mag.map(|m| row(m, k));
        step(filter, &sample, z.as_ref()).map_err(|e| {
            Stopped::Failed(Failure {
                sample: k,
                message: e.to_string(),
            })
        })?;
    }
    filter.release(true, out).map_err(|e| {
        Stopped::Failed(Failure {
            sample: n.saturating_sub(1),
            message: e.to_string(),
        })
    })
}

/// One sample as the library's `record` loop steps it: predict, then the magnetometer reading.
fn step(
    filter: &mut AttitudeEkf,
    sample: &ImuSample,
    mag: Option<&Vector3<f64>>,
) -> Result<(), liebayes_operators::OperatorError> {
    filter.predict(sample)?;
    if let Some(z) = mag {
        filter.update(z)?;
    }
    Ok(())
}

/// `(heading σ, tilt σ)` (rad) of a world-frame covariance: `√P_zz`, `√(P_xx + P_yy)`.
fn sigmas(p: &nalgebra::Matrix3<f64>) -> (f64, f64) {
    let d = p.diagonal().map(|v| v.max(0.0));
    (d[2].sqrt(), (d[0] + d[1]).sqrt())
}

/// Runs the filter over every sample, keeping each estimate; stops at the first refused sample.
fn run_batch(
    filter: &mut AttitudeEkf,
    gyr: &ArrayView2<'_, f64>,
    acc: &ArrayView2<'_, f64>,
    mag: Option<&ArrayView2<'_, f64>>,
    out: &mut Outputs,
) -> Result<(), Stopped<Failure>> {
    let n = gyr.nrows();
    let row = |a: &ArrayView2<'_, f64>, k: usize| Vector3::new(a[[k, 0]], a[[k, 1]], a[[k, 2]]);
    for k in 0..n {
        check_signals_at(k)?;
        let fail = |e: liebayes_operators::OperatorError| {
            Stopped::Failed(Failure {
                sample: k,
                message: e.to_string(),
            })
        };
        let sample = ImuSample {
            gyro: row(gyr, k),
            acc: row(acc, k),
        };
        let z = mag.map(|m| row(m, k));
        step(filter, &sample, z.as_ref()).map_err(fail)?;
        let e = filter.estimate().map_err(fail)?;
        let q = e.orientation;
        out.quat.extend_from_slice(&[q.w, q.i, q.j, q.k]);
        let (heading, tilt) = sigmas(&e.covariance.unwrap_or_else(nalgebra::Matrix3::zeros));
        out.heading_sigma.push(heading);
        out.tilt_sigma.push(tilt);
        out.bias
            .extend_from_slice(filter.bias().unwrap_or_else(Vector3::zeros).as_slice());
        out.rest.push(filter.at_rest());
        out.mag_disturbance.push(filter.magnetic_disturbance());
    }
    Ok(())
}

/// A 2-D array's view (its shape checked by [`check_rows`] before).
fn matrix<'a>(array: &'a PyReadonlyArrayDyn<'_, f64>) -> PyResult<ArrayView2<'a, f64>> {
    array
        .as_array()
        .into_dimensionality::<Ix2>()
        .map_err(value_error)
}

/// Refuses a shape that is not `(n, 3)` with the batch's `n`, in a call from `origin`.
fn check_rows(origin: &str, name: &str, shape: &[usize], n: usize) -> PyResult<()> {
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{origin}: {name} has shape {shape:?}, expected (n, 3) (one row per sample)"
        )));
    }
    if shape[0] != n {
        return Err(PyValueError::new_err(format!(
            "{origin}: {name} has shape {shape:?}, expected ({n}, 3) (one row per sample, as gyr)"
        )));
    }
    Ok(())
}

fn parse_sensors(name: &str) -> PyResult<Sensors> {
    match name {
        "9d" | "9D" => Ok(Sensors::NineD),
        "6d" | "6D" => Ok(Sensors::SixD),
        _ => Err(PyValueError::new_err(format!(
            "AttitudeFilter: sensors is {name:?}, expected \"9d\", \"6d\" or None"
        ))),
    }
}

/// Sets one keyword parameter (a value's range is checked when the filter is built); a flag that
/// switches a part on takes its settings from `defaults`.
fn set_param(
    p: &mut AttitudeParams,
    defaults: &AttitudeParams,
    key: &str,
    value: &Bound<'_, PyAny>,
) -> PyResult<()> {
    let number = || real_number(&format!("AttitudeFilter: {key}"), value);
    // A flag is a bool (or numpy.bool_), nothing else: another type is a TypeError.
    let flag = || -> PyResult<bool> {
        value.extract::<bool>().map_err(|_| {
            PyTypeError::new_err(format!(
                "AttitudeFilter: {key} must be True or False, got {}",
                value.get_type().name().map_or_else(
                    |_| "another type".to_owned(),
                    |n| { format!("an object of type {n}") }
                )
            ))
        })
    };
    match key {
        "gyro_noise" => p.gyro_noise = number()?,
        "rate_noise" => p.rate_noise = number()?,
        "bias_walk" => p.bias_walk = number()?,
        "estimate_bias" => p.estimate_bias = flag()?,
        "imu_delay" => p.imu_delay = number()?,
        "initial_bias_sigma" => p.initial_bias_sigma = number()?,
        "initial_tilt_sigma" => p.initial_tilt_sigma = number()?,
        "initial_heading_sigma" => p.initial_heading_sigma = number()?,
        "velocity_bound" => p.velocity_bound = number()?,
        "velocity_walk" => p.velocity_walk = number()?,
        "position_bound" => p.position_bound = number()?,
        "velocity_interval" => p.velocity_interval = number()?,
        "block" => p.block = number()?,
        "propagation" => {
            p.propagation = match value.extract::<String>().as_deref() {
                Ok("ekf") => Propagation::Ekf,
                Ok("ukf") => Propagation::Ukf,
                Ok(other) => {
                    return Err(PyValueError::new_err(format!(
                        "AttitudeFilter: propagation is {other:?}, expected \"ekf\" or \"ukf\""
                    )));
                }
                Err(_) => {
                    return Err(PyTypeError::new_err(
                        "AttitudeFilter: propagation must be the string \"ekf\" or \"ukf\"",
                    ));
                }
            }
        }
        "rest_detection" => p.rest = flag()?.then(|| defaults.rest.clone()).flatten(),
        "mag_heading_sigma" => p.magnetometer.heading_sigma = number()?,
        "mag_interval" => p.magnetometer.interval = number()?,
        "mag_delay" => p.magnetometer.delay = number()?,
        "mag_offset" => {
            p.magnetometer.offset = flag()?.then_some(defaults.magnetometer.offset).flatten();
        }
        "mag_disturbance_rejection" => {
            p.magnetometer.disturbance = flag()?
                .then_some(defaults.magnetometer.disturbance)
                .flatten();
        }
        "tilt_variance_scale" => p.tilt_variance_scale = number()?,
        _ => {
            return Err(PyValueError::new_err(format!(
                "AttitudeFilter: unknown parameter {key:?}; the parameters are {}",
                PARAMETER_NAMES.join(", ")
            )));
        }
    }
    Ok(())
}

/// The parameters as a dict of keyword parameters.
fn params_dict<'py>(py: Python<'py>, p: &AttitudeParams) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("gyro_noise", p.gyro_noise)?;
    d.set_item("rate_noise", p.rate_noise)?;
    d.set_item("bias_walk", p.bias_walk)?;
    d.set_item("estimate_bias", p.estimate_bias)?;
    d.set_item("imu_delay", p.imu_delay)?;
    d.set_item("initial_bias_sigma", p.initial_bias_sigma)?;
    d.set_item("initial_tilt_sigma", p.initial_tilt_sigma)?;
    d.set_item("initial_heading_sigma", p.initial_heading_sigma)?;
    d.set_item("velocity_bound", p.velocity_bound)?;
    d.set_item("velocity_walk", p.velocity_walk)?;
    d.set_item("position_bound", p.position_bound)?;
    d.set_item("velocity_interval", p.velocity_interval)?;
    d.set_item("block", p.block)?;
    d.set_item(
        "propagation",
        match p.propagation {
            Propagation::Ekf => "ekf",
            Propagation::Ukf => "ukf",
        },
    )?;
    d.set_item("rest_detection", p.rest.is_some())?;
    d.set_item("mag_heading_sigma", p.magnetometer.heading_sigma)?;
    d.set_item("mag_interval", p.magnetometer.interval)?;
    d.set_item("mag_delay", p.magnetometer.delay)?;
    d.set_item("mag_offset", p.magnetometer.offset.is_some())?;
    d.set_item(
        "mag_disturbance_rejection",
        p.magnetometer.disturbance.is_some(),
    )?;
    d.set_item("tilt_variance_scale", p.tilt_variance_scale)?;
    Ok(d)
}

/// Reads a BROAD trial (`.mat`) into a dict of numpy arrays: `rate` (Hz), `gyr` (n, 3) (rad/s),
/// `acc` (n, 3) (m/s²), `mag` (n, 3) (µT) or `None`, `quat` (n, 4) the reference orientation
/// (scalar first; rows of NaN where the capture lost it) or `None`, `movement` (n,) (bool) or
/// `None`. Raises `ValueError` with the reader's message for a file it cannot use.
#[pyfunction]
// pyo3 extracts `str` and `os.PathLike` arguments as an owned `PathBuf`.
#[allow(clippy::needless_pass_by_value)]
fn read_broad<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let log = py.detach(|| read_broad_log(&path));
    py.check_signals()?;
    let log = log.map_err(value_error)?;
    let n = log.len();
    let vectors = |v: &[Vector3<f64>]| -> PyResult<Bound<'py, PyArray2<f64>>> {
        let flat: Vec<f64> = v.iter().flat_map(|x| [x[0], x[1], x[2]]).collect();
        PyArray1::from_vec(py, flat).reshape([n, 3])
    };
    let d = PyDict::new(py);
    d.set_item("rate", log.rate())?;
    d.set_item("gyr", vectors(log.gyroscope())?)?;
    d.set_item("acc", vectors(log.accelerometer())?)?;
    d.set_item("mag", log.magnetometer().map(vectors).transpose()?)?;
    let quat = log
        .reference()
        .map(|r| {
            let flat: Vec<f64> = r
                .iter()
                .flat_map(|q| q.map_or([f64::NAN; 4], |q| [q.w, q.i, q.j, q.k]))
                .collect();
            PyArray1::from_vec(py, flat).reshape([n, 4])
        })
        .transpose()?;
    d.set_item("quat", quat)?;
    d.set_item(
        "movement",
        log.movement().map(|m| PyArray1::from_slice(py, m)),
    )?;
    Ok(d)
}
