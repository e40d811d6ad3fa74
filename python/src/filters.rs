//! The filters area of the package (`liebayes.filters`): the exact azimuth filter, the
//! angle-of-arrival filters, and the library's studies of the built-in scenarios with the
//! scenarios' simulated runs exposed, so that a Python filter can be scored on the same data.
//!
//! Everything here wraps the library: the filters are the library's [`RecursiveFilter`]s, the
//! batch run is the library's [`record`], the studies are [`Study::run_method`] with the
//! library's methods and scorers, the simulated runs are the scenarios' own simulations from
//! [`run_rngs`], and the scores of a user's estimates go through the same scorers into the same
//! [`Summary`].

// pyo3 extracts every argument of a Python function by value (an array borrow, a list of names):
// the signatures cannot take references.
#![allow(clippy::needless_pass_by_value)]

use crate::arrays::{MAX_VALUES, arg, real_number, shaped_float_array};
use crate::errors::{Stopped, check_signals_at, in_use, value_error};
use liebayes_densities::MAX_SCALE;
use liebayes_experiments::{
    Figure, MAX_EPOCHS, MAX_STUDY_EPOCHS, Method as _, RecursiveFilter, Reduction, RunFailure,
    RunScores, Scenario, Scorer, Shard, Step, Study, StudyLabel, Summary, run_rngs,
};
use liebayes_filters::aoa::AdaptiveSigmas;
use liebayes_filters::aoa::{
    Algorithm, Anchor, AngleNoise, AzEl, AzElModel, DataModel, KAPPA_RANGE, ModelChoice,
    PositionEstimate, PositionScorer, Prior, RandomWalk, Readings, SIGMA_RANGE, SquareTrack,
    TrackConfig, TrackFilter, TrackReadings, TruthModel, UnitVectorModel, angle_ekf,
    angle_iterated_ekf, angle_particle_filter, angle_ukf, fit_angle_sigmas, square_track_anchors,
    vmf_ekf, vmf_iterated_ekf, vmf_particle_filter, vmf_ukf,
};
use liebayes_filters::azimuth::{
    AzimuthDensity, AzimuthEstimate, AzimuthExact, AzimuthScenario, AzimuthScorer, Config, Method,
    Motion, PositionAzimuth, PositionMeasurement, VelocityInput, VelocityProcess, exact,
};
use liebayes_manifolds::{Rn, So2, So3};
use liebayes_operators::OperatorError;
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn};
use numpy::{PyUntypedArray, PyUntypedArrayMethods, ndarray::ArrayViewD};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PySequence};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::sync::Mutex;

/// The most anchors of an [`AoaFilter`] (the Kalman filters stack 3 values per anchor).
const MAX_ANCHORS: usize = 8;

/// Adds the area's classes and functions to the extension module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<ExactAzimuthFilter>()?;
    m.add_class::<AoaFilter>()?;
    m.add_function(wrap_pyfunction!(azimuth_study, m)?)?;
    m.add_function(wrap_pyfunction!(azimuth_runs, m)?)?;
    m.add_function(wrap_pyfunction!(score_azimuth, m)?)?;
    m.add_function(wrap_pyfunction!(aoa_study, m)?)?;
    m.add_function(wrap_pyfunction!(aoa_runs, m)?)?;
    m.add_function(wrap_pyfunction!(score_aoa, m)?)?;
    m.add_function(wrap_pyfunction!(square_track, m)?)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Arrays in and out.

/// A `ValueError` with this message.
fn bad(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// A new float64 array of `shape` holding `data` (row-major; its length is the shape's product).
fn array<'py>(py: Python<'py>, data: Vec<f64>, shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, data)
        .reshape(shape.to_vec())?
        .into_any())
}

/// The shape of `a` checked against `expected` (`None`: any size on that axis), naming `name`.
fn check_shape(name: &str, shape: &[usize], expected: &[Option<usize>]) -> PyResult<()> {
    let fits = shape.len() == expected.len()
        && shape
            .iter()
            .zip(expected)
            .all(|(s, e)| e.is_none_or(|e| e == *s));
    if fits {
        return Ok(());
    }
    let wanted: Vec<String> = expected
        .iter()
        .map(|e| e.map_or_else(|| "n".to_owned(), |v| v.to_string()))
        .collect();
    Err(bad(format!(
        "{name}: expected an array of shape ({}), got {shape:?}",
        wanted.join(", ")
    )))
}

/// An array argument of real numbers, read in place (see [`shaped`]).
type Real<'py> = PyReadonlyArrayDyn<'py, f64>;

/// The array argument `name` as float64, its shape checked against `expected` ([`check_shape`])
/// before anything is converted or copied.
fn shaped<'py>(
    name: &str,
    obj: &Bound<'py, PyAny>,
    expected: &[Option<usize>],
) -> PyResult<Real<'py>> {
    shaped_float_array(name, obj, |shape| check_shape(name, shape, expected))
}

/// An optional array argument read by [`shaped`].
fn optional_shaped<'py>(
    name: &str,
    obj: Option<&Bound<'py, PyAny>>,
    expected: &[Option<usize>],
) -> PyResult<Option<Real<'py>>> {
    obj.map(|o| shaped(name, o, expected)).transpose()
}

/// Refuses an array of positions, their errors or covariances holding a value that is not finite
/// or beyond the library's limit for such values ([`MAX_SCALE`], 1e100), naming the first one's
/// index: beyond it the squares that scores sum would overflow.
fn check_scale(name: &str, array: &Real<'_>) -> PyResult<()> {
    let view = array.as_array();
    match view
        .indexed_iter()
        .find(|(_, v)| !(-MAX_SCALE..=MAX_SCALE).contains(*v))
    {
        Some((index, value)) => Err(bad(format!(
            "{name}{:?}: {value} is not a finite value of magnitude at most 1e100",
            numpy::ndarray::Dimension::slice(&index)
        ))),
        None => Ok(()),
    }
}

/// Refuses an array holding a value for which `fits` is false, naming its index and `what` the
/// values must be.
fn check_each(
    name: &str,
    array: &Real<'_>,
    what: &str,
    fits: impl Fn(f64) -> bool,
) -> PyResult<()> {
    let view = array.as_array();
    match view.indexed_iter().find(|(_, v)| !fits(**v)) {
        Some((index, value)) => Err(bad(format!(
            "{name}{:?}: {value} is not {what}",
            numpy::ndarray::Dimension::slice(&index)
        ))),
        None => Ok(()),
    }
}

/// A 1-d array-like of exactly `n` floats.
fn fixed<const N: usize>(name: &str, a: &Bound<'_, PyAny>) -> PyResult<[f64; N]> {
    let a = shaped(name, a, &[Some(N)])?;
    let view = a.as_array();
    Ok(std::array::from_fn(|i| view[i]))
}

/// A value per step, as a vector of length `n` (for per-step time steps): one real number for
/// every step ([`real_number`]: a Python or numpy scalar, or a 0-d array), or a 1-d array-like of
/// `n` real numbers. A sequence or an array of at least one axis is always read as the latter: an
/// array of one element is one step's value, not a scalar.
fn per_step(name: &str, value: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<f64>> {
    let scalar = match value.cast::<PyUntypedArray>() {
        Ok(array) => array.ndim() == 0,
        Err(_) => value.cast::<PySequence>().is_err(),
    };
    let mut values = reserved(name, n)?;
    if scalar {
        values.resize(n, real_number(name, value)?);
        return Ok(values);
    }
    let a = shaped(name, value, &[Some(n)])?;
    values.extend(a.as_array().iter().copied());
    Ok(values)
}

/// `[f(0), …, f(n−1)]` flattened, each `f(i)` of `k` values.
fn flat(n: usize, k: usize, f: impl Fn(usize, &mut [f64])) -> Vec<f64> {
    let mut data = vec![0.0; n * k];
    for (i, chunk) in data.chunks_exact_mut(k.max(1)).enumerate().take(n) {
        f(i, chunk);
    }
    data
}

/// Checks a request for the runs `start..start + runs`: at least one, and the end representable.
fn check_runs(start: u64, runs: usize) -> PyResult<()> {
    if runs == 0 {
        return Err(bad("runs is 0: it must be at least 1"));
    }
    start
        .checked_add(runs as u64)
        .map(|_| ())
        .ok_or_else(|| bad("start + runs overflows"))
}

/// Checks that `count` values fit [`MAX_VALUES`].
fn check_size(what: &str, count: Option<usize>) -> PyResult<usize> {
    match count {
        Some(c) if c <= MAX_VALUES => Ok(c),
        _ => Err(bad(format!(
            "{what}: more than 2^28 values; ask for fewer runs or a shorter scenario"
        ))),
    }
}

/// The study `name` of `runs` runs from `seed`, run by `run` shard after shard without the GIL
/// (each shard's runs in parallel), the shards' summaries merged: merging is exact, so the result
/// is the whole study's. Between two shards the pending signals are handled, so a Ctrl-C stops a
/// long study within a shard (about four runs per thread) and raises `KeyboardInterrupt`.
fn in_shards(
    py: Python<'_>,
    name: &str,
    runs: u64,
    seed: u64,
    run: impl Fn(&Study) -> Result<Summary, liebayes_experiments::ExperimentError> + Sync,
) -> PyResult<Summary> {
    // The study's own checks (runs from 1 to MAX_RUNS) and message, before any shard.
    Study::new(name, runs, seed, Shard::WHOLE).map_err(value_error)?;
    let threads = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let per_shard = u64::try_from(threads.saturating_mul(4).max(16)).unwrap_or(u64::MAX);
    let shards = runs.div_ceil(per_shard).max(1);
    let mut total = Summary::default();
    for index in 1..=shards {
        let shard = Shard::new(index, shards).map_err(value_error)?;
        let study = Study::new(name, runs, seed, shard).map_err(value_error)?;
        let summary = py.detach(|| run(&study));
        py.check_signals()?;
        total
            .merge(&summary.map_err(value_error)?)
            .map_err(value_error)?;
    }
    Ok(total)
}

// ---------------------------------------------------------------------------------------------
// Summaries as dicts.

/// The name of a reduction as the result dicts give it.
fn reduction_name(r: Reduction) -> String {
    match r {
        Reduction::RootMeanSquare => "rms".into(),
        Reduction::Mean => "mean".into(),
        Reduction::ChiSquare { dof } => format!("chi2({dof})"),
        Reduction::Rate => "rate".into(),
    }
}

/// Each method's summary as [`summary_dict`] writes it, keyed by its label.
fn summaries_dict<'py>(
    py: Python<'py>,
    summaries: &[(String, Summary)],
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    for (label, summary) in summaries {
        out.set_item(label, summary_dict(py, summary)?)?;
    }
    Ok(out)
}

/// A library summary as the dict a study returns per method: its label, runs and failures, the
/// epoch times, each metric's figure per epoch (its reduction over the runs, [`Reduction::figure`]),
/// the 95 % bands where the figure has one, the count of finite values, units and reductions.
fn summary_dict<'py>(py: Python<'py>, summary: &Summary) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    out.set_item("label", &summary.label().name)?;
    out.set_item("runs", summary.run_count())?;
    let failures = PyDict::new(py);
    for (reason, count) in summary.failures() {
        failures.set_item(reason, count)?;
    }
    out.set_item("failures", failures)?;
    let times: Vec<f64> = summary
        .times()
        .epochs()
        .iter()
        .map(|s| s.mean().unwrap_or(f64::NAN))
        .collect();
    let epochs = times.len();
    out.set_item("times", array(py, times, &[epochs])?)?;
    let (metrics, bands, counts) = (PyDict::new(py), PyDict::new(py), PyDict::new(py));
    let (units, reductions) = (PyDict::new(py), PyDict::new(py));
    for m in summary.metrics() {
        let stats = m.series.epochs();
        let mut values = vec![f64::NAN; epochs];
        let mut band = vec![f64::NAN; 2 * epochs];
        let mut has_band = false;
        for (k, s) in stats.iter().enumerate().take(epochs) {
            match m.reduction.figure(s) {
                Figure::Empty => {}
                Figure::Rms(v) | Figure::Percent(v) => values[k] = v,
                Figure::Mean(v, b) => {
                    values[k] = v;
                    if let Some((lo, hi)) = b {
                        band[2 * k] = lo;
                        band[2 * k + 1] = hi;
                    }
                    has_band = true;
                }
            }
        }
        let count: Vec<f64> = (0..epochs)
            .map(|k| stats.get(k).map_or(0.0, |s| s.count() as f64))
            .collect();
        metrics.set_item(&m.name, array(py, values, &[epochs])?)?;
        if has_band {
            bands.set_item(&m.name, array(py, band, &[epochs, 2])?)?;
        }
        counts.set_item(&m.name, array(py, count, &[epochs])?)?;
        units.set_item(&m.name, &m.unit)?;
        reductions.set_item(&m.name, reduction_name(m.reduction))?;
    }
    out.set_item("metrics", metrics)?;
    out.set_item("bands", bands)?;
    out.set_item("counts", counts)?;
    out.set_item("units", units)?;
    out.set_item("reductions", reductions)?;
    Ok(out)
}

/// Checks the runs and epochs of the estimates to score (`truth` names the array giving them)
/// before anything is read or built: at least one of each, at most [`MAX_STUDY_EPOCHS`] epochs
/// (the core's limit of a study: a summary holds about 1 KB of exact statistics per metric and
/// epoch), and at most [`MAX_VALUES`] run-epochs, the scoring loop's length (so at most 2^28 runs,
/// well within a study's [`MAX_RUNS`](liebayes_experiments::MAX_RUNS)).
fn check_scored(truth: &str, runs: usize, epochs: usize) -> PyResult<()> {
    if runs == 0 {
        return Err(bad(format!("{truth}: no runs; at least one is needed")));
    }
    if epochs == 0 || epochs > MAX_STUDY_EPOCHS {
        return Err(bad(format!(
            "{truth}: {epochs} epochs; from 1 to {MAX_STUDY_EPOCHS} epochs (a study's limit) are \
             scored at once"
        )));
    }
    if runs.checked_mul(epochs).is_none_or(|v| v > MAX_VALUES) {
        return Err(bad(format!(
            "{truth}: {runs} runs of {epochs} epochs; at most 2^28 run-epochs are scored at once"
        )));
    }
    Ok(())
}

/// The summary of runs scored outside a study (their runs and epochs checked by [`check_scored`]):
/// run k's per-epoch scores (by `scorer`) added as the study adds them, so the figures are those a
/// study of the same runs gives.
fn scored_summary<T, E, Sc: Scorer<T, E>>(
    name: &str,
    runs: usize,
    epochs: usize,
    times: &[f64],
    scorer: &Sc,
    at: impl Fn(usize, usize) -> (T, E),
) -> Result<Summary, liebayes_experiments::ExperimentError> {
    let metrics = scorer.metrics();
    let width = metrics.len();
    let label = StudyLabel {
        name: name.to_owned(),
        seed: 0,
        runs: runs as u64,
    };
    let mut summary = Summary::new(label, 0..runs as u64)?;
    for run in 0..runs {
        let mut values = vec![f64::NAN; epochs * width];
        for k in 0..epochs {
            let (truth, estimate) = at(run, k);
            scorer.score(&truth, &estimate, &mut values[k * width..(k + 1) * width]);
        }
        let scores = RunScores {
            metrics: metrics.clone(),
            times: times.to_vec(),
            values,
            seconds_per_step: 0.0,
        };
        summary.add_run(run as u64, &scores)?;
    }
    Ok(summary)
}

/// Epoch times: given (checked to have `epochs` finite, strictly increasing values, the first bad
/// one named by its index) or 0, 1, 2, ….
fn epoch_times(times: Option<&Bound<'_, PyAny>>, epochs: usize) -> PyResult<Vec<f64>> {
    let Some(times) = times else {
        return Ok((0..epochs).map(|k| k as f64).collect());
    };
    let t = shaped("times", times, &[Some(epochs)])?;
    let values: Vec<f64> = t.as_array().iter().copied().collect();
    for (k, &v) in values.iter().enumerate() {
        if !v.is_finite() {
            return Err(bad(format!(
                "times[{k}] is {v}: every epoch time must be finite"
            )));
        }
        if k > 0 && v <= values[k - 1] {
            return Err(bad(format!(
                "times[{k}] is {v}, not after times[{}] = {}: epoch times must be strictly \
                 increasing",
                k - 1,
                values[k - 1]
            )));
        }
    }
    Ok(values)
}

// ---------------------------------------------------------------------------------------------
// The exact azimuth filter.

/// The exact azimuth-alignment filter: the seven-number posterior `p(r, A)` of a platform whose
/// position r (platform axes) is driven by a known velocity and measured in world axes turned by
/// an unknown azimuth A.
///
/// A filter is used by one thread at a time: while `run` runs (without the GIL), another thread's
/// `run`, `predict` or `update` of it raises `ValueError` ("in use by another call") and reading
/// it raises `RuntimeError`; give each thread its own filter (`copy()`).
#[pyclass(module = "liebayes._liebayes", name = "ExactAzimuthFilter")]
#[derive(Clone)]
pub(crate) struct ExactAzimuthFilter {
    /// The library's filter.
    filter: AzimuthExact,
}

/// The estimate of the exact filter as a dict (see the stub for the keys).
fn azimuth_estimate_dict<'py>(
    py: Python<'py>,
    density: &AzimuthDensity,
    estimate: &AzimuthEstimate,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("azimuth", estimate.azimuth.map_or(f64::NAN, |a| a.angle()))?;
    d.set_item("concentration", density.azimuth().concentration())?;
    d.set_item("rho", estimate.rho)?;
    d.set_item("circular_variance", estimate.circular_variance)?;
    d.set_item(
        "mean_r",
        array(py, estimate.mean_r.iter().copied().collect(), &[2])?,
    )?;
    d.set_item("cov_r", array(py, row_major2(&estimate.cov_r), &[2, 2])?)?;
    d.set_item("a", array(py, density.a().iter().copied().collect(), &[2])?)?;
    d.set_item("c", array(py, density.c().iter().copied().collect(), &[2])?)?;
    d.set_item("sigma2", density.sigma2())?;
    let eta = density.eta();
    d.set_item("eta", array(py, vec![eta.x, eta.y], &[2])?)?;
    Ok(d)
}

/// A 2×2 matrix row by row.
fn row_major2(m: &Matrix2<f64>) -> Vec<f64> {
    vec![m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]]
}

/// A 3×3 matrix row by row.
fn row_major3(m: &Matrix3<f64>) -> Vec<f64> {
    (0..9).map(|i| m[(i / 3, i % 3)]).collect()
}

#[pymethods]
impl ExactAzimuthFilter {
    /// The filter with velocity noise density `q` (m/√s), position noise `sigma_m` (m) and the
    /// prior `r ~ N(r0, sigma0² I)`, A uniform.
    #[new]
    #[pyo3(signature = (q, sigma_m, r0 = None, sigma0 = 1.0))]
    fn new(
        #[pyo3(from_py_with = arg::q)] q: f64,
        #[pyo3(from_py_with = arg::sigma_m)] sigma_m: f64,
        r0: Option<&Bound<'_, PyAny>>,
        #[pyo3(from_py_with = arg::sigma0)] sigma0: f64,
    ) -> PyResult<Self> {
        let r0 = match r0 {
            Some(a) => Vector2::from(fixed::<2>("r0", a)?),
            None => Vector2::zeros(),
        };
        let process = VelocityProcess::new(q).map_err(value_error)?;
        let measurement = PositionMeasurement::new(sigma_m).map_err(value_error)?;
        Ok(Self {
            filter: exact(process, measurement, r0, sigma0).map_err(value_error)?,
        })
    }

    /// Propagates over `dt` seconds with the velocity `velocity` (2,) in platform axes.
    fn predict(
        slf: &Bound<'_, Self>,
        velocity: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = arg::dt)] dt: f64,
    ) -> PyResult<()> {
        let velocity = Vector2::from(fixed::<2>("velocity", velocity)?);
        let mut this = slf
            .try_borrow_mut()
            .map_err(|_| in_use("ExactAzimuthFilter"))?;
        this.filter
            .predict(&VelocityInput { velocity, dt })
            .map_err(value_error)
    }

    /// Conditions on the world-axes position measurement `z` (2,); returns its log evidence.
    fn update(slf: &Bound<'_, Self>, z: &Bound<'_, PyAny>) -> PyResult<f64> {
        let z = Vector2::from(fixed::<2>("z", z)?);
        let mut this = slf
            .try_borrow_mut()
            .map_err(|_| in_use("ExactAzimuthFilter"))?;
        Ok(this.filter.update(&z).map_err(value_error)?.log_evidence)
    }

    /// The current estimate (a dict).
    #[getter]
    fn estimate<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let estimate = self.filter.estimate().map_err(value_error)?;
        azimuth_estimate_dict(py, self.filter.density(), &estimate)
    }

    /// `E[r | A]` at the azimuth `azimuth` (rad), shape (2,).
    fn conditional_mean<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = arg::azimuth)] azimuth: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        if !azimuth.is_finite() {
            return Err(bad(format!("azimuth is {azimuth}: it must be finite")));
        }
        let m = self
            .filter
            .density()
            .conditional_mean(&So2::from_angle_unchecked(azimuth));
        array(py, vec![m.x, m.y], &[2])
    }

    /// Runs the steps `velocity` (n, 2), `dt` (float or (n,)) and `z` (n, 2), a row of NaN where a
    /// step has no measurement; returns each step's estimate as arrays. At most [`MAX_EPOCHS`]
    /// (2^24) steps in one call, checked, with the memory of the steps and of the results reserved,
    /// before any step is run. All or nothing.
    fn run<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        velocity: &Bound<'py, PyAny>,
        dt: &Bound<'py, PyAny>,
        z: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let velocity = shaped_float_array("velocity", velocity, |shape| {
            check_shape("velocity", shape, &[None, Some(2)])?;
            if shape[0] > MAX_EPOCHS {
                return Err(bad(format!(
                    "velocity: {} steps; at most {MAX_EPOCHS} (2^24) are run in one call: split \
                     the run (the filter carries over from one call to the next)",
                    shape[0]
                )));
            }
            Ok(())
        })?;
        let n = velocity.shape()[0];
        let z = shaped("z", z, &[Some(n), Some(2)])?;
        let dts = per_step("dt", dt, n)?;
        let steps = azimuth_steps(&velocity.as_array(), &dts, &z.as_array())?;
        let mut out = ExactRun::reserve(n)?;
        // Held until the call returns (see `in_use`), taken after the arguments are read.
        let mut this = slf
            .try_borrow_mut()
            .map_err(|_| in_use("ExactAzimuthFilter"))?;
        let mut filter = this.filter.clone();
        let ran = py.detach(|| -> Result<(), Stopped<RunFailure>> {
            for (index, step) in steps.iter().enumerate() {
                check_signals_at(index)?;
                let fail = |error| {
                    Stopped::Failed(RunFailure {
                        step: index,
                        time: step.time,
                        error,
                    })
                };
                filter.predict(&step.input).map_err(fail)?;
                let update = match &step.measurement {
                    Some(z) => Some(filter.update(z).map_err(fail)?),
                    None => None,
                };
                let estimate = filter.estimate().map_err(fail)?;
                out.push(
                    filter.density(),
                    &estimate,
                    update.map_or(f64::NAN, |u| u.log_evidence),
                );
            }
            Ok(())
        });
        py.check_signals()?;
        ran.map_err(|stop| match stop {
            Stopped::Interrupted(e) => e,
            Stopped::Failed(f) => value_error(f),
        })?;
        this.filter = filter;
        out.into_dict(py, n)
    }

    /// An independent copy of the filter.
    fn copy(&self) -> Self {
        self.clone()
    }

    fn __repr__(&self) -> String {
        let d = self.filter.density();
        format!(
            "ExactAzimuthFilter(kappa={}, a={:?}, c={:?}, sigma2={})",
            d.azimuth().concentration(),
            [d.a().x, d.a().y],
            [d.c().x, d.c().y],
            d.sigma2()
        )
    }
}

/// The results of [`ExactAzimuthFilter::run`], a value (or a row) per step, reserved before the
/// run so that memory the system cannot give raises `ValueError` instead of aborting.
struct ExactRun {
    /// The circular mean of A (NaN where A is uniform).
    azimuth: Vec<f64>,
    /// The von Mises concentration of A's marginal.
    concentration: Vec<f64>,
    /// The mean resultant length of A.
    rho: Vec<f64>,
    /// The circular variance of A.
    circular_variance: Vec<f64>,
    /// E[r], 2 per step.
    mean_r: Vec<f64>,
    /// Cov[r], 4 per step, row-major.
    cov_r: Vec<f64>,
    /// The density's a, 2 per step.
    a: Vec<f64>,
    /// The density's c, 2 per step.
    c: Vec<f64>,
    /// The density's σ².
    sigma2: Vec<f64>,
    /// The update's log evidence (NaN at a step without a measurement).
    log_evidence: Vec<f64>,
}

/// An empty vector with room for `n` values, or `ValueError` naming `what` when the memory cannot
/// be had (rather than the abort of an infallible allocation).
pub(crate) fn reserved<T>(what: &str, n: usize) -> PyResult<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n)
        .map_err(|e| bad(format!("{what}: {n} values do not fit in memory ({e})")))?;
    Ok(v)
}

impl ExactRun {
    /// Room for `n` steps.
    fn reserve(n: usize) -> PyResult<Self> {
        let what = "ExactAzimuthFilter.run: the results";
        let rows = |k: usize| reserved(what, n.saturating_mul(k));
        Ok(Self {
            azimuth: rows(1)?,
            concentration: rows(1)?,
            rho: rows(1)?,
            circular_variance: rows(1)?,
            mean_r: rows(2)?,
            cov_r: rows(4)?,
            a: rows(2)?,
            c: rows(2)?,
            sigma2: rows(1)?,
            log_evidence: rows(1)?,
        })
    }

    /// One step's density, estimate and log evidence (within the reserved room).
    fn push(&mut self, density: &AzimuthDensity, estimate: &AzimuthEstimate, log_evidence: f64) {
        self.azimuth
            .push(estimate.azimuth.map_or(f64::NAN, |a| a.angle()));
        self.concentration.push(density.azimuth().concentration());
        self.rho.push(estimate.rho);
        self.circular_variance.push(estimate.circular_variance);
        self.mean_r.extend_from_slice(estimate.mean_r.as_slice());
        self.cov_r.extend_from_slice(&row_major2(&estimate.cov_r));
        self.a.extend_from_slice(density.a().as_slice());
        self.c.extend_from_slice(density.c().as_slice());
        self.sigma2.push(density.sigma2());
        self.log_evidence.push(log_evidence);
    }

    /// The results as the dict `run` returns (arrays of `n` steps, without a copy).
    fn into_dict(self, py: Python<'_>, n: usize) -> PyResult<Bound<'_, PyDict>> {
        let out = PyDict::new(py);
        out.set_item("azimuth", array(py, self.azimuth, &[n])?)?;
        out.set_item("concentration", array(py, self.concentration, &[n])?)?;
        out.set_item("rho", array(py, self.rho, &[n])?)?;
        out.set_item(
            "circular_variance",
            array(py, self.circular_variance, &[n])?,
        )?;
        out.set_item("mean_r", array(py, self.mean_r, &[n, 2])?)?;
        out.set_item("cov_r", array(py, self.cov_r, &[n, 2, 2])?)?;
        out.set_item("a", array(py, self.a, &[n, 2])?)?;
        out.set_item("c", array(py, self.c, &[n, 2])?)?;
        out.set_item("sigma2", array(py, self.sigma2, &[n])?)?;
        out.set_item("log_evidence", array(py, self.log_evidence, &[n])?)?;
        Ok(out)
    }
}

/// The steps of a batch run of the azimuth filter (truth `()`), time the running sum of dt. A
/// measurement row of two NaN is no measurement; a row with one NaN is refused.
fn azimuth_steps(
    velocity: &ArrayViewD<'_, f64>,
    dts: &[f64],
    z: &ArrayViewD<'_, f64>,
) -> PyResult<Vec<Step<(), VelocityInput, Vector2<f64>>>> {
    let mut time = 0.0;
    let mut steps = reserved("ExactAzimuthFilter.run: the steps", dts.len())?;
    for (i, &dt) in dts.iter().enumerate() {
        time += dt;
        let (zx, zy) = (z[[i, 0]], z[[i, 1]]);
        let measurement = match (zx.is_nan(), zy.is_nan()) {
            (true, true) => None,
            (false, false) => Some(Vector2::new(zx, zy)),
            _ => {
                return Err(bad(format!(
                    "z: row {i} has one NaN component; a step without a measurement has both NaN"
                )));
            }
        };
        steps.push(Step {
            time,
            input: VelocityInput {
                velocity: Vector2::new(velocity[[i, 0]], velocity[[i, 1]]),
                dt,
            },
            truth: (),
            measurement,
        });
    }
    Ok(steps)
}

// ---------------------------------------------------------------------------------------------
// Azimuth studies and runs.

/// The library's motion of a scenario name.
fn motion(name: &str) -> PyResult<Motion> {
    Motion::ALL
        .into_iter()
        .find(|m| m.name().eq_ignore_ascii_case(name))
        .ok_or_else(|| {
            bad(format!(
                "scenario {name:?}: expected one of \"static\", \"circle\", \"line\""
            ))
        })
}

/// The scenario of a name and settings, as `liebayes azimuth` builds it (steps = duration / dt).
fn azimuth_scenario(
    name: &str,
    duration: f64,
    dt: f64,
    measure_every: usize,
    sigma0: f64,
    sigma_m: f64,
    q: f64,
) -> PyResult<AzimuthScenario> {
    let config = Config {
        sigma0,
        sigma_m,
        q,
        dt,
        measure_every,
        steps: Config::steps_for(duration, dt).map_err(value_error)?,
    };
    AzimuthScenario::new(motion(name)?, config).map_err(value_error)
}

/// A method of a name: `exact`, `EKF`, `UKF`, `PF <n>`, `grid <n>`, `MPF <n>` (case-insensitive,
/// a space or a colon before the size).
fn azimuth_method(name: &str) -> PyResult<Method> {
    let lower = name.trim().to_ascii_lowercase();
    let mut parts = lower.split([' ', ':']).filter(|p| !p.is_empty());
    let (kind, size) = (parts.next().unwrap_or(""), parts.next());
    let count = |default: usize| -> PyResult<usize> {
        size.map_or(Ok(default), |s| {
            s.parse::<usize>()
                .map_err(|_| bad(format!("method {name:?}: {s:?} is not a count")))
        })
    };
    let method = match kind {
        "exact" => Method::Exact,
        "ekf" => Method::Ekf,
        "ukf" => Method::Ukf,
        "pf" => Method::Particle(count(1000)?),
        "grid" => Method::Grid(count(360)?),
        "mpf" => Method::Marginalized(count(360)?),
        _ => {
            return Err(bad(format!(
                "method {name:?}: expected \"exact\", \"EKF\", \"UKF\", \"PF <n>\", \
                 \"grid <n>\" or \"MPF <n>\""
            )));
        }
    };
    if parts.next().is_some() || (size.is_some() && matches!(kind, "exact" | "ekf" | "ukf")) {
        return Err(bad(format!(
            "method {name:?}: unexpected text after the name"
        )));
    }
    method.validate().map_err(value_error)?;
    Ok(method)
}

/// Runs the library's study of each method on a built-in azimuth scenario.
#[pyfunction]
#[pyo3(signature = (scenario, methods, runs, seed = 1, *, duration = 500.0, dt = 0.1,
    measure_every = 10, sigma0 = 1.0, sigma_m = 1.0, q = 0.1, filter_sigma_m = None,
    filter_q = None, filter_sigma0 = None))]
#[allow(clippy::too_many_arguments)]
fn azimuth_study<'py>(
    py: Python<'py>,
    scenario: &str,
    methods: Vec<String>,
    #[pyo3(from_py_with = arg::runs)] runs: u64,
    #[pyo3(from_py_with = arg::seed)] seed: u64,
    #[pyo3(from_py_with = arg::duration)] duration: f64,
    #[pyo3(from_py_with = arg::dt)] dt: f64,
    #[pyo3(from_py_with = arg::measure_every)] measure_every: usize,
    #[pyo3(from_py_with = arg::sigma0)] sigma0: f64,
    #[pyo3(from_py_with = arg::sigma_m)] sigma_m: f64,
    #[pyo3(from_py_with = arg::q)] q: f64,
    #[pyo3(from_py_with = arg::filter_sigma_m_or_none)] filter_sigma_m: Option<f64>,
    #[pyo3(from_py_with = arg::filter_q_or_none)] filter_q: Option<f64>,
    #[pyo3(from_py_with = arg::filter_sigma0_or_none)] filter_sigma0: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let scenario = azimuth_scenario(scenario, duration, dt, measure_every, sigma0, sigma_m, q)?;
    let mut plans = Vec::with_capacity(methods.len());
    for name in &methods {
        let mut on = azimuth_method(name)?.on(&scenario).map_err(value_error)?;
        if let Some(s) = filter_sigma_m {
            on.measurement = PositionMeasurement::new(s).map_err(value_error)?;
        }
        if let Some(v) = filter_q {
            on.process = VelocityProcess::new(v).map_err(value_error)?;
        }
        if let Some(s) = filter_sigma0 {
            on.sigma0 = s;
        }
        // The settings as every azimuth filter checks them, before any run.
        liebayes_experiments::Method::validate(&on).map_err(value_error)?;
        let label = on.label();
        if plans.iter().any(|(l, _): &(String, _)| *l == label) {
            return Err(bad(format!("methods: {label:?} is given twice")));
        }
        plans.push((label, on));
    }
    let name = scenario.motion().name();
    let mut summaries = Vec::with_capacity(plans.len());
    for (label, on) in &plans {
        let summary = in_shards(py, &format!("{label}, {name}"), runs, seed, |study| {
            study.run_method(&scenario, on, &AzimuthScorer, &|_| {})
        })?;
        summaries.push((label.clone(), summary));
    }
    summaries_dict(py, &summaries)
}

/// The simulated runs of a built-in azimuth scenario, as a study draws them.
#[pyfunction]
#[pyo3(signature = (scenario, runs, seed = 1, *, start = 0, duration = 500.0, dt = 0.1,
    measure_every = 10, sigma0 = 1.0, sigma_m = 1.0, q = 0.1))]
#[allow(clippy::too_many_arguments)]
fn azimuth_runs<'py>(
    py: Python<'py>,
    scenario: &str,
    #[pyo3(from_py_with = arg::runs_size)] runs: usize,
    #[pyo3(from_py_with = arg::seed)] seed: u64,
    #[pyo3(from_py_with = arg::start)] start: u64,
    #[pyo3(from_py_with = arg::duration)] duration: f64,
    #[pyo3(from_py_with = arg::dt)] dt: f64,
    #[pyo3(from_py_with = arg::measure_every)] measure_every: usize,
    #[pyo3(from_py_with = arg::sigma0)] sigma0: f64,
    #[pyo3(from_py_with = arg::sigma_m)] sigma_m: f64,
    #[pyo3(from_py_with = arg::q)] q: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let scenario = azimuth_scenario(scenario, duration, dt, measure_every, sigma0, sigma_m, q)?;
    let steps = scenario.config().steps;
    check_runs(start, runs)?;
    // Truth, velocity and measurements: six values per step.
    let per_array = check_size(
        "the runs",
        runs.checked_mul(steps).and_then(|v| v.checked_mul(6)),
    )? / 3;
    let simulated = py.detach(|| -> Result<_, liebayes_experiments::ExperimentError> {
        let mut truth = Vec::with_capacity(per_array);
        let mut z = Vec::with_capacity(per_array);
        let mut velocity = Vec::with_capacity(per_array);
        let mut azimuths = Vec::with_capacity(runs);
        let (mut times, mut dts, mut measured) = (Vec::new(), Vec::new(), Vec::new());
        for run in 0..runs as u64 {
            let (mut rng, _) = run_rngs(seed, start + run);
            for (k, step) in scenario.simulate(&mut rng)?.enumerate() {
                let step: Step<PositionAzimuth, VelocityInput, Vector2<f64>> = step;
                if k == 0 {
                    azimuths.push(step.truth.second().angle());
                }
                if run == 0 {
                    times.push(step.time);
                    dts.push(step.input.dt);
                    measured.push(step.measurement.is_some());
                }
                truth.extend_from_slice(step.truth.first().coords().as_slice());
                velocity.extend_from_slice(step.input.velocity.as_slice());
                match step.measurement {
                    Some(m) => z.extend_from_slice(m.as_slice()),
                    None => z.extend_from_slice(&[f64::NAN, f64::NAN]),
                }
            }
        }
        Ok((truth, z, velocity, azimuths, times, dts, measured))
    });
    py.check_signals()?;
    let (truth, z, velocity, azimuths, times, dts, measured) = simulated.map_err(value_error)?;
    let out = PyDict::new(py);
    out.set_item("time", array(py, times, &[steps])?)?;
    out.set_item("dt", array(py, dts, &[steps])?)?;
    out.set_item("measured", PyArray1::from_vec(py, measured))?;
    out.set_item("velocity", array(py, velocity, &[runs, steps, 2])?)?;
    out.set_item("truth_r", array(py, truth, &[runs, steps, 2])?)?;
    out.set_item("truth_azimuth", array(py, azimuths, &[runs])?)?;
    out.set_item("z", array(py, z, &[runs, steps, 2])?)?;
    out.set_item("seed", seed)?;
    out.set_item("start", start)?;
    Ok(out)
}

/// Scores a user's azimuth estimates (per run and measurement epoch) with the library's scorer
/// into the summary a study would give, with the GIL released.
#[pyfunction]
#[pyo3(signature = (truth_r, truth_azimuth, azimuth, rho, mean_r, cov_r,
    circular_variance = None, times = None, label = "user"))]
#[allow(clippy::too_many_arguments)]
fn score_azimuth<'py>(
    py: Python<'py>,
    truth_r: &Bound<'py, PyAny>,
    truth_azimuth: &Bound<'py, PyAny>,
    azimuth: &Bound<'py, PyAny>,
    rho: &Bound<'py, PyAny>,
    mean_r: &Bound<'py, PyAny>,
    cov_r: &Bound<'py, PyAny>,
    circular_variance: Option<&Bound<'py, PyAny>>,
    times: Option<&Bound<'py, PyAny>>,
    label: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let truth_r = shaped_float_array("truth_r", truth_r, |shape| {
        check_shape("truth_r", shape, &[None, None, Some(2)])?;
        check_scored("truth_r", shape[0], shape[1])
    })?;
    let (runs, epochs) = (truth_r.shape()[0], truth_r.shape()[1]);
    let (r, e) = (Some(runs), Some(epochs));
    let truth_azimuth = shaped("truth_azimuth", truth_azimuth, &[r])?;
    let azimuth = shaped("azimuth", azimuth, &[r, e])?;
    let rho = shaped("rho", rho, &[r, e])?;
    let mean_r = shaped("mean_r", mean_r, &[r, e, Some(2)])?;
    let cov_r = shaped("cov_r", cov_r, &[r, e, Some(2), Some(2)])?;
    let circular_variance = optional_shaped("circular_variance", circular_variance, &[r, e])?;
    let times = epoch_times(times, epochs)?;
    let (tr, ta, az, rh, mr, cr) = (
        truth_r.as_array(),
        truth_azimuth.as_array(),
        azimuth.as_array(),
        rho.as_array(),
        mean_r.as_array(),
        cov_r.as_array(),
    );
    for (name, array) in [
        ("truth_r", &truth_r),
        ("truth_azimuth", &truth_azimuth),
        ("rho", &rho),
        ("mean_r", &mean_r),
        ("cov_r", &cov_r),
    ] {
        check_scale(name, array)?;
    }
    // The documented ranges: a mean resultant length rho in [0, 1], a circular variance in
    // [0, inf] (inf for a uniform estimate); outside them every circular metric would be NaN.
    check_each("rho", &rho, "a mean resultant length in [0, 1]", |v| {
        (0.0..=1.0).contains(&v)
    })?;
    if let Some(v) = &circular_variance {
        check_each(
            "circular_variance",
            v,
            "a circular variance in [0, inf]",
            |v| v >= 0.0,
        )?;
    }
    let cv = circular_variance.as_ref().map(|v| v.as_array());
    let summary = py.detach(|| {
        scored_summary(label, runs, epochs, &times, &AzimuthScorer, |run, k| {
            let truth = PositionAzimuth::new(
                Rn::new_unchecked(Vector2::new(tr[[run, k, 0]], tr[[run, k, 1]])),
                So2::from_angle_unchecked(ta[[run]]),
            );
            let a = az[[run, k]];
            let r = rh[[run, k]];
            let variance = cv.as_ref().map_or_else(
                || {
                    if r > 0.0 {
                        -2.0 * r.ln()
                    } else {
                        f64::INFINITY
                    }
                },
                |v| v[[run, k]],
            );
            let estimate = AzimuthEstimate {
                azimuth: a.is_finite().then(|| So2::from_angle_unchecked(a)),
                rho: r,
                circular_variance: variance,
                mean_r: Vector2::new(mr[[run, k, 0]], mr[[run, k, 1]]),
                cov_r: Matrix2::new(
                    cr[[run, k, 0, 0]],
                    cr[[run, k, 0, 1]],
                    cr[[run, k, 1, 0]],
                    cr[[run, k, 1, 1]],
                ),
            };
            (truth, estimate)
        })
    });
    py.check_signals()?;
    summary_dict(py, &summary.map_err(value_error)?)
}

// ---------------------------------------------------------------------------------------------
// Angle-of-arrival filters.

/// An angle-of-arrival filter of any number of anchors, stepped with readings as a slice.
trait AoaStep: Send {
    /// Propagates over `delta` seconds.
    fn predict(&mut self, delta: f64) -> Result<(), OperatorError>;
    /// Conditions on the readings (one per anchor, checked by the caller).
    fn update(&mut self, readings: &[AzEl]) -> Result<liebayes_experiments::Update, OperatorError>;
    /// The estimate.
    fn estimate(&self) -> Result<PositionEstimate, OperatorError>;
}

/// The library's filter of N anchors.
struct Anchored<const N: usize>(
    Box<
        dyn RecursiveFilter<Input = f64, Measurement = Readings<N>, Estimate = PositionEstimate>
            + Send,
    >,
);

impl<const N: usize> AoaStep for Anchored<N> {
    fn predict(&mut self, delta: f64) -> Result<(), OperatorError> {
        self.0.predict(&delta)
    }

    fn update(&mut self, readings: &[AzEl]) -> Result<liebayes_experiments::Update, OperatorError> {
        let readings: Readings<N> = std::array::from_fn(|j| readings[j]);
        self.0.update(&readings)
    }

    fn estimate(&self) -> Result<PositionEstimate, OperatorError> {
        self.0.estimate()
    }
}

/// A filter's measurement model by name, with its parameters.
#[derive(Clone)]
enum AoaModel {
    /// Von Mises-Fisher with κ.
    Vmf(f64),
    /// Azimuth-elevation with its noise.
    Angles(AngleNoise),
}

/// The filter of N anchors, as the library builds it (the constructors a track study calls).
fn build_anchored<const N: usize, const M3: usize, const M2: usize>(
    anchors: &[Anchor],
    model: &AoaModel,
    algorithm: Algorithm,
    process: RandomWalk,
    prior: &Prior,
    rng: ChaCha8Rng,
) -> Result<Box<dyn AoaStep>, OperatorError> {
    let anchors: [Anchor; N] = std::array::from_fn(|j| anchors[j]);
    Ok(match (model, algorithm) {
        (AoaModel::Vmf(kappa), algorithm) => {
            let model = UnitVectorModel::new(anchors, *kappa)?;
            match algorithm {
                Algorithm::Particle(n) => Box::new(Anchored::<N>(Box::new(vmf_particle_filter(
                    model, process, prior, n, rng,
                )?))),
                Algorithm::Ekf => Box::new(Anchored::<N>(Box::new(vmf_ekf::<N, M3>(
                    model, process, prior,
                )?))),
                Algorithm::Ukf => Box::new(Anchored::<N>(Box::new(vmf_ukf::<N, M3>(
                    model, process, prior,
                )?))),
                Algorithm::IteratedEkf => {
                    Box::new(Anchored::<N>(Box::new(vmf_iterated_ekf::<N, M3>(
                        model, process, prior,
                    )?)))
                }
            }
        }
        (AoaModel::Angles(noise), algorithm) => {
            let model = AzElModel::new(anchors, noise.clone())?;
            match algorithm {
                Algorithm::Particle(n) => Box::new(Anchored::<N>(Box::new(angle_particle_filter(
                    model, process, prior, n, rng,
                )?))),
                Algorithm::Ekf => Box::new(Anchored::<N>(Box::new(angle_ekf::<N, M2>(
                    model, process, prior,
                )?))),
                Algorithm::Ukf => Box::new(Anchored::<N>(Box::new(angle_ukf::<N, M2>(
                    model, process, prior,
                )?))),
                Algorithm::IteratedEkf => {
                    Box::new(Anchored::<N>(Box::new(angle_iterated_ekf::<N, M2>(
                        model, process, prior,
                    )?)))
                }
            }
        }
    })
}

/// The filter of `anchors.len()` anchors (1 to [`MAX_ANCHORS`]).
fn build_aoa(
    anchors: &[Anchor],
    model: &AoaModel,
    algorithm: Algorithm,
    process: RandomWalk,
    prior: &Prior,
    rng: ChaCha8Rng,
) -> PyResult<Box<dyn AoaStep>> {
    let built = match anchors.len() {
        1 => build_anchored::<1, 3, 2>(anchors, model, algorithm, process, prior, rng),
        2 => build_anchored::<2, 6, 4>(anchors, model, algorithm, process, prior, rng),
        3 => build_anchored::<3, 9, 6>(anchors, model, algorithm, process, prior, rng),
        4 => build_anchored::<4, 12, 8>(anchors, model, algorithm, process, prior, rng),
        5 => build_anchored::<5, 15, 10>(anchors, model, algorithm, process, prior, rng),
        6 => build_anchored::<6, 18, 12>(anchors, model, algorithm, process, prior, rng),
        7 => build_anchored::<7, 21, 14>(anchors, model, algorithm, process, prior, rng),
        8 => build_anchored::<8, 24, 16>(anchors, model, algorithm, process, prior, rng),
        k => {
            return Err(bad(format!(
                "anchors: {k} anchors; from 1 to {MAX_ANCHORS} are supported"
            )));
        }
    };
    built.map_err(value_error)
}

/// `(algorithm, model kind)` of a filter name `PF-VMF`, `EKF-AE`, `UKF-AE-adaptive`, …
fn parse_aoa_name(name: &str, particles: usize) -> PyResult<(Algorithm, String)> {
    let upper = name.trim().to_ascii_uppercase();
    let (algorithm, model) = upper.split_once('-').ok_or_else(|| {
        bad(format!(
            "filter {name:?}: expected <PF|EKF|UKF|IEKF>-<VMF|AE|AE-nominal|AE-fitted|AE-adaptive>"
        ))
    })?;
    let algorithm = match algorithm {
        "PF" => Algorithm::Particle(particles),
        "EKF" => Algorithm::Ekf,
        "UKF" => Algorithm::Ukf,
        "IEKF" => Algorithm::IteratedEkf,
        _ => {
            return Err(bad(format!(
                "filter {name:?}: the algorithm must be PF, EKF, UKF or IEKF"
            )));
        }
    };
    match model {
        "VMF" | "AE" | "AE-NOMINAL" | "AE-FITTED" | "AE-ADAPTIVE" => Ok((algorithm, model.into())),
        _ => Err(bad(format!(
            "filter {name:?}: the model must be VMF, AE, AE-nominal, AE-fitted or AE-adaptive"
        ))),
    }
}

/// Anchors from positions (k, 3) and optional world-to-anchor rotations (k, 3, 3).
fn anchors_of(
    positions: &Bound<'_, PyAny>,
    rotations: Option<&Bound<'_, PyAny>>,
) -> PyResult<Vec<Anchor>> {
    let positions = shaped("anchors", positions, &[None, Some(3)])?;
    let points = crate::arrays::vectors3("anchors", &positions)?;
    let k = points.len();
    if k == 0 || k > MAX_ANCHORS {
        return Err(bad(format!(
            "anchors: {k} anchors; from 1 to {MAX_ANCHORS} are supported"
        )));
    }
    let rotations = optional_shaped("rotations", rotations, &[Some(k), Some(3), Some(3)])?;
    let r = rotations.as_ref().map(|r| r.as_array());
    (0..k)
        .map(|j| {
            let position = points[j];
            match &r {
                Some(r) => {
                    let m = Matrix3::from_fn(|a, b| r[[j, a, b]]);
                    let rotation = So3::from_matrix(&m).map_err(value_error)?;
                    Anchor::new(position, rotation).map_err(value_error)
                }
                None => Anchor::at(position).map_err(value_error),
            }
        })
        .collect()
}

/// An angle-of-arrival filter (particle filter, EKF, UKF or iterated EKF with the von Mises-Fisher
/// or the azimuth-elevation model) of the position θ ∈ R³ from k anchors' azimuth-elevation readings.
///
/// A filter is used by one thread at a time: while `predict` or `update` runs (without the GIL),
/// another thread's `predict` or `update` of it raises `ValueError` ("in use by another call") and
/// reading it raises `RuntimeError`; give each thread its own filter.
#[pyclass(module = "liebayes._liebayes", name = "AoaFilter")]
pub(crate) struct AoaFilter {
    /// The library's filter (behind a mutex so that the class is `Sync`; only `&mut self` steps it).
    filter: Mutex<Box<dyn AoaStep>>,
    /// Its name as given.
    name: String,
    /// The number of anchors.
    anchors: usize,
    /// The last update's NIS and its degrees of freedom, if the filter reported one.
    nis: Option<(f64, usize)>,
}

impl AoaFilter {
    /// The filter, for a step.
    fn inner(&mut self) -> &mut Box<dyn AoaStep> {
        self.filter
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The current estimate (the lock is only contended if another thread steps the filter).
    fn current(&self) -> PyResult<PositionEstimate> {
        self.filter
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .estimate()
            .map_err(value_error)
    }
}

#[pymethods]
impl AoaFilter {
    /// The filter `name` on anchors at `anchors` (k, 3) with `rotations` (k, 3, 3) (world to
    /// anchor axes; identity if omitted), from the prior `N(prior_mean, prior_std² I)`.
    #[new]
    #[pyo3(signature = (name, anchors, rotations = None, *, kappa = None, sigma_az = None,
        sigma_el = None, q_xy = 0.5, q_z = 0.1, prior_mean = None, prior_std = 0.5,
        particles = 10000, seed = 0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        name: &str,
        anchors: &Bound<'_, PyAny>,
        rotations: Option<&Bound<'_, PyAny>>,
        #[pyo3(from_py_with = arg::kappa_or_none)] kappa: Option<f64>,
        #[pyo3(from_py_with = arg::sigma_az_or_none)] sigma_az: Option<f64>,
        #[pyo3(from_py_with = arg::sigma_el_or_none)] sigma_el: Option<f64>,
        #[pyo3(from_py_with = arg::q_xy)] q_xy: f64,
        #[pyo3(from_py_with = arg::q_z)] q_z: f64,
        prior_mean: Option<&Bound<'_, PyAny>>,
        #[pyo3(from_py_with = arg::prior_std)] prior_std: f64,
        #[pyo3(from_py_with = arg::particles)] particles: usize,
        #[pyo3(from_py_with = arg::seed)] seed: u64,
    ) -> PyResult<Self> {
        let (algorithm, kind) = parse_aoa_name(name, particles)?;
        let anchors = anchors_of(anchors, rotations)?;
        let sigmas = || -> PyResult<(f64, f64)> {
            match (sigma_az, sigma_el) {
                (Some(a), Some(e)) => Ok((a, e)),
                _ => Err(bad(format!(
                    "filter {name:?}: the azimuth-elevation model needs sigma_az and sigma_el"
                ))),
            }
        };
        let model = match kind.as_str() {
            "VMF" => AoaModel::Vmf(kappa.ok_or_else(|| {
                bad(format!(
                    "filter {name:?}: the von Mises-Fisher model needs kappa"
                ))
            })?),
            "AE-ADAPTIVE" => {
                let (a, e) = sigmas()?;
                AoaModel::Angles(AngleNoise::Adaptive(
                    AdaptiveSigmas::model_one(a, e).map_err(value_error)?,
                ))
            }
            _ => {
                let (sigma_az, sigma_el) = sigmas()?;
                AoaModel::Angles(AngleNoise::Fixed { sigma_az, sigma_el })
            }
        };
        if matches!(algorithm, Algorithm::Particle(0)) {
            return Err(bad("particles is 0: it must be at least 1"));
        }
        let mean = match prior_mean {
            Some(m) => Vector3::from(fixed::<3>("prior_mean", m)?),
            None => Vector3::zeros(),
        };
        let prior = Prior::new(mean, prior_std).map_err(value_error)?;
        let process = RandomWalk::new(q_xy, q_z).map_err(value_error)?;
        let count = anchors.len();
        // A particle filter draws its particles here (up to 2^30): without the GIL.
        let filter = py.detach(|| {
            build_aoa(
                &anchors,
                &model,
                algorithm,
                process,
                &prior,
                ChaCha8Rng::seed_from_u64(seed),
            )
        });
        py.check_signals()?;
        let filter = filter?;
        Ok(Self {
            filter: Mutex::new(filter),
            name: name.to_owned(),
            anchors: count,
            nis: None,
        })
    }

    /// Propagates over `delta` seconds (the random walk's time step).
    fn predict(
        slf: &Bound<'_, Self>,
        py: Python<'_>,
        #[pyo3(from_py_with = arg::delta)] delta: f64,
    ) -> PyResult<()> {
        // The Kalman filters' random walk takes any step; the library's check of it gives the
        // message (the particle filters check it themselves).
        RandomWalk::check_step(delta).map_err(value_error)?;
        // Held until the call returns (see `in_use`). The step is made in place: a Ctrl-C
        // meanwhile is raised by Python once the call has returned.
        let mut this = slf.try_borrow_mut().map_err(|_| in_use("AoaFilter"))?;
        let filter = this.inner();
        py.detach(|| filter.predict(delta)).map_err(value_error)
    }

    /// Conditions on the readings `readings` (k, 2): azimuth and elevation (rad) per anchor, in
    /// the anchors' order. Returns the log evidence.
    fn update(slf: &Bound<'_, Self>, py: Python<'_>, readings: &Bound<'_, PyAny>) -> PyResult<f64> {
        let anchors = slf.try_borrow().map_err(|_| in_use("AoaFilter"))?.anchors;
        let readings = shaped("readings", readings, &[Some(anchors), Some(2)])?;
        let view = readings.as_array();
        let readings: Vec<AzEl> = (0..anchors)
            .map(|j| AzEl::new(view[[j, 0]], view[[j, 1]]))
            .collect();
        // Held until the call returns (see `in_use`), taken after the arguments are read. The
        // step is made in place: a Ctrl-C meanwhile is raised by Python once the call returned.
        let mut this = slf.try_borrow_mut().map_err(|_| in_use("AoaFilter"))?;
        let filter = this.inner();
        let update = py
            .detach(|| filter.update(&readings))
            .map_err(value_error)?;
        this.nis = update.nis.map(|n| (n.value, n.dof));
        Ok(update.log_evidence)
    }

    /// The posterior mean (3,).
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let e = self.current()?;
        array(py, e.mean.iter().copied().collect(), &[3])
    }

    /// The posterior covariance (3, 3).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let e = self.current()?;
        array(py, row_major3(&e.covariance), &[3, 3])
    }

    /// The last update's normalised innovation squared and its degrees of freedom, `None` for
    /// the particle filters (and before any update).
    #[getter]
    fn nis(&self) -> Option<(f64, usize)> {
        self.nis
    }

    /// The filter's name as given.
    #[getter]
    fn name(&self) -> String {
        self.name.clone()
    }

    fn __repr__(&self) -> String {
        format!("AoaFilter({:?}, {} anchors)", self.name, self.anchors)
    }
}

// ---------------------------------------------------------------------------------------------
// Angle-of-arrival studies and runs.

/// The square track as `liebayes aoa track` builds it: its data model from `data` and `sigma_deg`.
fn aoa_track(data: &str, sigma_deg: f64, steps: usize, truth: &str) -> PyResult<SquareTrack<4>> {
    // The data model's noise is derived from sigma_deg (model1: sigma_az = sigma_el = sigma,
    // model2: kappa = 1/sigma²): its range is checked here, under its own name, with the
    // library's ranges of the derived values.
    let sigma = sigma_deg.to_radians();
    let (data, fits, (lo, hi)) = match data.to_ascii_lowercase().as_str() {
        "model1" | "model i" => (
            DataModel::NormalWithFlip {
                sigma_az: sigma,
                sigma_el: sigma,
            },
            (SIGMA_RANGE.0..=SIGMA_RANGE.1).contains(&sigma),
            SIGMA_RANGE,
        ),
        "model2" | "model ii" => {
            let kappa = 1.0 / (sigma * sigma);
            (
                DataModel::VonMisesFisher { kappa },
                sigma > 0.0 && (KAPPA_RANGE.0..=KAPPA_RANGE.1).contains(&kappa),
                (1.0 / KAPPA_RANGE.1.sqrt(), 1.0 / KAPPA_RANGE.0.sqrt()),
            )
        }
        _ => {
            return Err(bad(format!(
                "data {data:?}: expected \"model1\" (normal angles) or \"model2\" (von \
                 Mises-Fisher)"
            )));
        }
    };
    if !fits {
        return Err(bad(format!(
            "sigma_deg is {sigma_deg}: with data {:?} it must be from about {:.3e} to {:.3e} \
             degrees ({lo:e} to {hi:e} rad)",
            data.name(),
            lo.to_degrees(),
            hi.to_degrees()
        )));
    }
    let truth = match truth.to_ascii_lowercase().as_str() {
        "square" => TruthModel::Square,
        "random-walk" | "random_walk" => TruthModel::RandomWalk,
        _ => {
            return Err(bad(format!(
                "truth {truth:?}: expected \"square\" or \"random-walk\""
            )));
        }
    };
    let config = TrackConfig {
        epochs: steps,
        truth,
        ..TrackConfig::default()
    };
    SquareTrack::new(square_track_anchors(), data, config).map_err(value_error)
}

/// Runs the library's square-track study of each named filter.
#[pyfunction]
#[pyo3(signature = (data, filters, runs, seed = 1, *, particles = 10000, sigma_deg = 10.0,
    steps = 64, truth = "square", fit_samples = 100_000))]
#[allow(clippy::too_many_arguments)]
fn aoa_study<'py>(
    py: Python<'py>,
    data: &str,
    filters: Vec<String>,
    #[pyo3(from_py_with = arg::runs)] runs: u64,
    #[pyo3(from_py_with = arg::seed)] seed: u64,
    #[pyo3(from_py_with = arg::particles)] particles: usize,
    #[pyo3(from_py_with = arg::sigma_deg)] sigma_deg: f64,
    #[pyo3(from_py_with = arg::steps)] steps: usize,
    truth: &str,
    #[pyo3(from_py_with = arg::fit_samples)] fit_samples: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let track = aoa_track(data, sigma_deg, steps, truth)?;
    let parsed = filters
        .iter()
        .map(|f| parse_aoa_name(f, particles))
        .collect::<PyResult<Vec<_>>>()?;
    let fitted = if parsed.iter().any(|(_, m)| m == "AE-FITTED") {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let fit = py.detach(|| fit_angle_sigmas(track.data(), fit_samples, &mut rng));
        py.check_signals()?;
        let fit = fit.map_err(value_error)?;
        (fit.sigma_az, fit.sigma_el)
    } else {
        (f64::NAN, f64::NAN)
    };
    let [vmf, nominal, fitted, adaptive] =
        ModelChoice::paper(track.data(), fitted).map_err(value_error)?;
    let mut plans: Vec<(String, TrackFilter)> = Vec::with_capacity(parsed.len());
    for (algorithm, kind) in parsed {
        let model = match kind.as_str() {
            "VMF" => vmf.clone(),
            "AE-FITTED" => fitted.clone(),
            "AE-ADAPTIVE" => adaptive.clone(),
            _ => nominal.clone(),
        };
        let filter = TrackFilter { algorithm, model };
        let label = filter.label();
        if plans.iter().any(|(l, _)| *l == label) {
            return Err(bad(format!("filters: {label:?} is given twice")));
        }
        plans.push((label, filter));
    }
    let mut summaries = Vec::with_capacity(plans.len());
    for (label, filter) in &plans {
        let summary = in_shards(py, label, runs, seed, |study| {
            filter.study(&track, study, &|_| {})
        })?;
        summaries.push((label.clone(), summary));
    }
    summaries_dict(py, &summaries)
}

/// The simulated runs of the square track, with each run's prior mean, as a study draws them.
#[pyfunction]
#[pyo3(signature = (data, runs, seed = 1, *, start = 0, sigma_deg = 10.0, steps = 64,
    truth = "square"))]
#[allow(clippy::too_many_arguments)]
fn aoa_runs<'py>(
    py: Python<'py>,
    data: &str,
    #[pyo3(from_py_with = arg::runs_size)] runs: usize,
    #[pyo3(from_py_with = arg::seed)] seed: u64,
    #[pyo3(from_py_with = arg::start)] start: u64,
    #[pyo3(from_py_with = arg::sigma_deg)] sigma_deg: f64,
    #[pyo3(from_py_with = arg::steps)] steps: usize,
    truth: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let track = aoa_track(data, sigma_deg, steps, truth)?;
    check_runs(start, runs)?;
    // Truth and four readings: eleven values per step.
    let size = check_size(
        "the runs",
        runs.checked_mul(steps).and_then(|v| v.checked_mul(11)),
    )? / 11;
    let config = *track.config();
    let simulated = py.detach(|| -> Result<_, String> {
        let mut truths = Vec::with_capacity(size * 3);
        let mut readings = Vec::with_capacity(size * 8);
        let mut priors = Vec::with_capacity(runs * 3);
        let (mut times, mut deltas) = (Vec::new(), Vec::new());
        for run in 0..runs as u64 {
            let (mut simulation, mut filter_stream) = run_rngs(seed, start + run);
            let prior = config
                .prior(&mut filter_stream)
                .map_err(|e| e.to_string())?;
            priors.extend_from_slice(prior.mean().as_slice());
            for step in track.simulate(&mut simulation).map_err(|e| e.to_string())? {
                if run == 0 {
                    times.push(step.time);
                    deltas.push(step.input);
                }
                truths.extend_from_slice(step.truth.coords().as_slice());
                match &step.measurement {
                    Some(TrackReadings::Readings(ys)) => {
                        for y in ys {
                            readings.extend_from_slice(&[y.azimuth, y.elevation]);
                        }
                    }
                    // No readings at that epoch (the true position at an anchor): NaN rows.
                    None | Some(TrackReadings::AtAnchor) => {
                        readings.extend_from_slice(&[f64::NAN; 8]);
                    }
                    Some(TrackReadings::Failed(e)) => {
                        return Err(format!("run {}: {e}", start + run));
                    }
                }
            }
        }
        Ok((truths, readings, priors, times, deltas))
    });
    py.check_signals()?;
    let (truths, readings, priors, times, deltas) = simulated.map_err(bad)?;
    let out = PyDict::new(py);
    out.set_item("time", array(py, times, &[steps])?)?;
    out.set_item("delta", array(py, deltas, &[steps])?)?;
    out.set_item("truth", array(py, truths, &[runs, steps, 3])?)?;
    out.set_item("readings", array(py, readings, &[runs, steps, 4, 2])?)?;
    out.set_item("prior_mean", array(py, priors, &[runs, 3])?)?;
    out.set_item("prior_std", config.prior_std)?;
    out.set_item("q_xy", config.q_xy)?;
    out.set_item("q_z", config.q_z)?;
    let (positions, rotations) = track_arrays(py)?;
    out.set_item("anchors", positions)?;
    out.set_item("rotations", rotations)?;
    out.set_item("seed", seed)?;
    out.set_item("start", start)?;
    Ok(out)
}

/// The square track's anchors: positions (4, 3) and world-to-anchor rotations (4, 3, 3).
fn track_arrays(py: Python<'_>) -> PyResult<(Bound<'_, PyAny>, Bound<'_, PyAny>)> {
    let anchors = square_track_anchors();
    let positions = flat(4, 3, |j, o| {
        o.copy_from_slice(anchors[j].position().as_slice());
    });
    let rotations = flat(4, 9, |j, o| {
        o.copy_from_slice(&row_major3(anchors[j].rotation_matrix()));
    });
    Ok((
        array(py, positions, &[4, 3])?,
        array(py, rotations, &[4, 3, 3])?,
    ))
}

/// The anchors of the square-track scenario: `(positions (4, 3), rotations (4, 3, 3))`.
#[pyfunction]
fn square_track(py: Python<'_>) -> PyResult<(Bound<'_, PyAny>, Bound<'_, PyAny>)> {
    track_arrays(py)
}

/// Scores a user's position estimates with the library's angle-of-arrival scorer into the summary
/// a study would give, with the GIL released.
#[pyfunction]
#[pyo3(signature = (truth, mean, covariance, times = None, label = "user"))]
fn score_aoa<'py>(
    py: Python<'py>,
    truth: &Bound<'py, PyAny>,
    mean: &Bound<'py, PyAny>,
    covariance: &Bound<'py, PyAny>,
    times: Option<&Bound<'py, PyAny>>,
    label: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let truth = shaped_float_array("truth", truth, |shape| {
        check_shape("truth", shape, &[None, None, Some(3)])?;
        check_scored("truth", shape[0], shape[1])
    })?;
    let (runs, epochs) = (truth.shape()[0], truth.shape()[1]);
    let (r, e) = (Some(runs), Some(epochs));
    let mean = shaped("mean", mean, &[r, e, Some(3)])?;
    let covariance = shaped("covariance", covariance, &[r, e, Some(3), Some(3)])?;
    for (name, array) in [
        ("truth", &truth),
        ("mean", &mean),
        ("covariance", &covariance),
    ] {
        check_scale(name, array)?;
    }
    let times = epoch_times(times, epochs)?;
    let (t, m, c) = (truth.as_array(), mean.as_array(), covariance.as_array());
    let summary = py.detach(|| {
        scored_summary(label, runs, epochs, &times, &PositionScorer, |run, k| {
            let truth = Rn::new_unchecked(Vector3::from_fn(|i, _| t[[run, k, i]]));
            let estimate = PositionEstimate {
                mean: Vector3::from_fn(|i, _| m[[run, k, i]]),
                covariance: Matrix3::from_fn(|a, b| c[[run, k, a, b]]),
            };
            (truth, estimate)
        })
    });
    py.check_signals()?;
    summary_dict(py, &summary.map_err(value_error)?)
}
