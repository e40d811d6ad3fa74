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

use crate::arrays::{MAX_VALUES, RealArray, float_array, optional_real, real, real_number};
use crate::errors::value_error;
use liebayes_densities::MAX_SCALE;
use liebayes_experiments::{
    AsIs, Estimator, Figure, MAX_STUDY_EPOCHS, Method as _, RecursiveFilter, Reduction, RunScores,
    Scenario, Scorer, Shard, Step, Study, StudyLabel, Summary, record, run_rngs,
};
use liebayes_filters::aoa::AdaptiveSigmas;
use liebayes_filters::aoa::{
    Algorithm, Anchor, AngleNoise, AzEl, AzElModel, DataModel, ModelChoice, PositionEstimate,
    PositionScorer, Prior, RandomWalk, Readings, SquareTrack, TrackConfig, TrackFilter, TruthModel,
    UnitVectorModel, angle_ekf, angle_particle_filter, angle_ukf, fit_angle_sigmas,
    square_track_anchors, vmf_ekf, vmf_particle_filter, vmf_ukf,
};
use liebayes_filters::azimuth::{
    AzimuthDensity, AzimuthEstimate, AzimuthExact, AzimuthMoments, AzimuthScenario, AzimuthScorer,
    Config, Method, Motion, PositionAzimuth, PositionMeasurement, VelocityInput, VelocityProcess,
    exact,
};
use liebayes_manifolds::{Rn, So2, So3};
use liebayes_operators::OperatorError;
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use numpy::{PyArray1, PyArrayMethods};
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

/// Refuses an array of positions, their errors or covariances holding a value that is not finite
/// or beyond the library's limit for such values ([`MAX_SCALE`], 1e100), naming the first one's
/// index: beyond it the squares that scores sum would overflow.
fn check_scale(name: &str, array: &RealArray<'_>) -> PyResult<()> {
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

/// A 1-d array-like of exactly `n` floats.
fn fixed<const N: usize>(name: &str, a: &RealArray<'_>) -> PyResult<[f64; N]> {
    check_shape(name, a.shape(), &[Some(N)])?;
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
    if scalar {
        return Ok(vec![real_number(name, value)?; n]);
    }
    let a = float_array(name, value)?;
    check_shape(name, a.shape(), &[Some(n)])?;
    Ok(a.as_array().iter().copied().collect())
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

/// Epoch times: given (checked to have `epochs` values) or 0, 1, 2, ….
fn epoch_times(times: Option<RealArray<'_>>, epochs: usize) -> PyResult<Vec<f64>> {
    match times {
        Some(t) => {
            check_shape("times", t.shape(), &[Some(epochs)])?;
            Ok(t.as_array().iter().copied().collect())
        }
        None => Ok((0..epochs).map(|k| k as f64).collect()),
    }
}

// ---------------------------------------------------------------------------------------------
// The exact azimuth filter.

/// The exact azimuth-alignment filter: the seven-number posterior `p(r, A)` of a platform whose
/// position r (platform axes) is driven by a known velocity and measured in world axes turned by
/// an unknown azimuth A.
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
        #[pyo3(from_py_with = real)] q: f64,
        #[pyo3(from_py_with = real)] sigma_m: f64,
        r0: Option<RealArray<'_>>,
        #[pyo3(from_py_with = real)] sigma0: f64,
    ) -> PyResult<Self> {
        let r0 = match r0 {
            Some(a) => Vector2::from(fixed::<2>("r0", &a)?),
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
        &mut self,
        velocity: RealArray<'_>,
        #[pyo3(from_py_with = real)] dt: f64,
    ) -> PyResult<()> {
        let velocity = Vector2::from(fixed::<2>("velocity", &velocity)?);
        self.filter
            .predict(&VelocityInput { velocity, dt })
            .map_err(value_error)
    }

    /// Conditions on the world-axes position measurement `z` (2,); returns its log evidence.
    fn update(&mut self, z: RealArray<'_>) -> PyResult<f64> {
        let z = Vector2::from(fixed::<2>("z", &z)?);
        Ok(self.filter.update(&z).map_err(value_error)?.log_evidence)
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
        #[pyo3(from_py_with = real)] azimuth: f64,
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
    /// step has no measurement; returns each step's estimate as arrays. All or nothing.
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        velocity: RealArray<'py>,
        dt: &Bound<'py, PyAny>,
        z: RealArray<'py>,
    ) -> PyResult<Bound<'py, PyDict>> {
        check_shape("velocity", velocity.shape(), &[None, Some(2)])?;
        let n = velocity.shape()[0];
        check_shape("z", z.shape(), &[Some(n), Some(2)])?;
        let dts = per_step("dt", dt, n)?;
        let steps = azimuth_steps(&velocity.as_array(), &dts, &z.as_array())?;
        let mut filter = self.filter.clone().estimated_by(AsIs);
        let recording = py
            .detach(|| record(&mut filter, steps))
            .map_err(value_error)?;
        let mut estimates = Vec::with_capacity(n);
        for step in &recording.steps {
            estimates.push(
                AzimuthMoments
                    .estimate(&step.estimate)
                    .map_err(value_error)?,
            );
        }
        self.filter = filter.estimated_by(AzimuthMoments);
        let densities: Vec<&AzimuthDensity> = recording.steps.iter().map(|s| &s.estimate).collect();
        let out = PyDict::new(py);
        let scalar = |f: &dyn Fn(usize) -> f64| (0..n).map(f).collect::<Vec<f64>>();
        out.set_item(
            "azimuth",
            array(
                py,
                scalar(&|i| estimates[i].azimuth.map_or(f64::NAN, |a| a.angle())),
                &[n],
            )?,
        )?;
        out.set_item(
            "concentration",
            array(
                py,
                scalar(&|i| densities[i].azimuth().concentration()),
                &[n],
            )?,
        )?;
        out.set_item("rho", array(py, scalar(&|i| estimates[i].rho), &[n])?)?;
        out.set_item(
            "circular_variance",
            array(py, scalar(&|i| estimates[i].circular_variance), &[n])?,
        )?;
        out.set_item(
            "mean_r",
            crate::arrays::rows(py, n, 2, |i, o| {
                o.copy_from_slice(estimates[i].mean_r.as_slice());
            })?,
        )?;
        out.set_item(
            "cov_r",
            array(
                py,
                flat(n, 4, |i, o| {
                    o.copy_from_slice(&row_major2(&estimates[i].cov_r));
                }),
                &[n, 2, 2],
            )?,
        )?;
        out.set_item(
            "a",
            array(
                py,
                flat(n, 2, |i, o| o.copy_from_slice(densities[i].a().as_slice())),
                &[n, 2],
            )?,
        )?;
        out.set_item(
            "c",
            array(
                py,
                flat(n, 2, |i, o| o.copy_from_slice(densities[i].c().as_slice())),
                &[n, 2],
            )?,
        )?;
        out.set_item(
            "sigma2",
            array(py, scalar(&|i| densities[i].sigma2()), &[n])?,
        )?;
        out.set_item(
            "log_evidence",
            array(
                py,
                scalar(&|i| {
                    recording.steps[i]
                        .update
                        .map_or(f64::NAN, |u| u.log_evidence)
                }),
                &[n],
            )?,
        )?;
        Ok(out)
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

/// The steps of a batch run of the azimuth filter (truth `()`), time the running sum of dt. A
/// measurement row of two NaN is no measurement; a row with one NaN is refused.
fn azimuth_steps(
    velocity: &ArrayViewD<'_, f64>,
    dts: &[f64],
    z: &ArrayViewD<'_, f64>,
) -> PyResult<Vec<Step<(), VelocityInput, Vector2<f64>>>> {
    let mut time = 0.0;
    let mut steps = Vec::with_capacity(dts.len());
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
    runs: u64,
    seed: u64,
    #[pyo3(from_py_with = real)] duration: f64,
    #[pyo3(from_py_with = real)] dt: f64,
    measure_every: usize,
    #[pyo3(from_py_with = real)] sigma0: f64,
    #[pyo3(from_py_with = real)] sigma_m: f64,
    #[pyo3(from_py_with = real)] q: f64,
    #[pyo3(from_py_with = optional_real)] filter_sigma_m: Option<f64>,
    #[pyo3(from_py_with = optional_real)] filter_q: Option<f64>,
    #[pyo3(from_py_with = optional_real)] filter_sigma0: Option<f64>,
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
            // The prior's check, before any run.
            AzimuthDensity::new(Vector2::zeros(), s).map_err(value_error)?;
            on.sigma0 = s;
        }
        let label = on.label();
        if plans.iter().any(|(l, _): &(String, _)| *l == label) {
            return Err(bad(format!("methods: {label:?} is given twice")));
        }
        plans.push((label, on));
    }
    let name = scenario.motion().name();
    let mut summaries = Vec::with_capacity(plans.len());
    for (label, on) in &plans {
        let study = Study::new(format!("{label}, {name}"), runs, seed, Shard::WHOLE)
            .map_err(value_error)?;
        let summary = py
            .detach(|| study.run_method(&scenario, on, &AzimuthScorer, &|_| {}))
            .map_err(value_error)?;
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
    runs: usize,
    seed: u64,
    start: u64,
    #[pyo3(from_py_with = real)] duration: f64,
    #[pyo3(from_py_with = real)] dt: f64,
    measure_every: usize,
    #[pyo3(from_py_with = real)] sigma0: f64,
    #[pyo3(from_py_with = real)] sigma_m: f64,
    #[pyo3(from_py_with = real)] q: f64,
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
    truth_r: RealArray<'py>,
    truth_azimuth: RealArray<'py>,
    azimuth: RealArray<'py>,
    rho: RealArray<'py>,
    mean_r: RealArray<'py>,
    cov_r: RealArray<'py>,
    circular_variance: Option<RealArray<'py>>,
    times: Option<RealArray<'py>>,
    label: &str,
) -> PyResult<Bound<'py, PyDict>> {
    check_shape("truth_r", truth_r.shape(), &[None, None, Some(2)])?;
    let (runs, epochs) = (truth_r.shape()[0], truth_r.shape()[1]);
    check_scored("truth_r", runs, epochs)?;
    check_shape("truth_azimuth", truth_azimuth.shape(), &[Some(runs)])?;
    check_shape("azimuth", azimuth.shape(), &[Some(runs), Some(epochs)])?;
    check_shape("rho", rho.shape(), &[Some(runs), Some(epochs)])?;
    check_shape(
        "mean_r",
        mean_r.shape(),
        &[Some(runs), Some(epochs), Some(2)],
    )?;
    check_shape(
        "cov_r",
        cov_r.shape(),
        &[Some(runs), Some(epochs), Some(2), Some(2)],
    )?;
    if let Some(v) = &circular_variance {
        check_shape("circular_variance", v.shape(), &[Some(runs), Some(epochs)])?;
    }
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
    let cv = circular_variance.as_ref().map(|v| v.as_array());
    let summary = py
        .detach(|| {
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
        })
        .map_err(value_error)?;
    summary_dict(py, &summary)
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
            "filter {name:?}: expected <PF|EKF|UKF>-<VMF|AE|AE-nominal|AE-fitted|AE-adaptive>"
        ))
    })?;
    let algorithm = match algorithm {
        "PF" => Algorithm::Particle(particles),
        "EKF" => Algorithm::Ekf,
        "UKF" => Algorithm::Ukf,
        _ => {
            return Err(bad(format!(
                "filter {name:?}: the algorithm must be PF, EKF or UKF"
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
    positions: &RealArray<'_>,
    rotations: Option<&RealArray<'_>>,
) -> PyResult<Vec<Anchor>> {
    let points = crate::arrays::vectors3("anchors", positions)?;
    let k = points.len();
    if k == 0 || k > MAX_ANCHORS {
        return Err(bad(format!(
            "anchors: {k} anchors; from 1 to {MAX_ANCHORS} are supported"
        )));
    }
    let r = match rotations {
        Some(r) => {
            check_shape("rotations", r.shape(), &[Some(k), Some(3), Some(3)])?;
            Some(r.as_array())
        }
        None => None,
    };
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

/// An angle-of-arrival filter (particle filter, EKF or UKF with the von Mises-Fisher or the
/// azimuth-elevation model) of the position θ ∈ R³ from k anchors' azimuth-elevation readings.
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
        name: &str,
        anchors: RealArray<'_>,
        rotations: Option<RealArray<'_>>,
        #[pyo3(from_py_with = optional_real)] kappa: Option<f64>,
        #[pyo3(from_py_with = optional_real)] sigma_az: Option<f64>,
        #[pyo3(from_py_with = optional_real)] sigma_el: Option<f64>,
        #[pyo3(from_py_with = real)] q_xy: f64,
        #[pyo3(from_py_with = real)] q_z: f64,
        prior_mean: Option<RealArray<'_>>,
        #[pyo3(from_py_with = real)] prior_std: f64,
        particles: usize,
        seed: u64,
    ) -> PyResult<Self> {
        let (algorithm, kind) = parse_aoa_name(name, particles)?;
        let anchors = anchors_of(&anchors, rotations.as_ref())?;
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
            Some(m) => Vector3::from(fixed::<3>("prior_mean", &m)?),
            None => Vector3::zeros(),
        };
        let prior = Prior::new(mean, prior_std).map_err(value_error)?;
        let process = RandomWalk::new(q_xy, q_z).map_err(value_error)?;
        let count = anchors.len();
        let filter = build_aoa(
            &anchors,
            &model,
            algorithm,
            process,
            &prior,
            ChaCha8Rng::seed_from_u64(seed),
        )?;
        Ok(Self {
            filter: Mutex::new(filter),
            name: name.to_owned(),
            anchors: count,
            nis: None,
        })
    }

    /// Propagates over `delta` seconds (the random walk's time step).
    fn predict(&mut self, py: Python<'_>, #[pyo3(from_py_with = real)] delta: f64) -> PyResult<()> {
        // The Kalman filters' random walk takes any step; the library's check of it gives the
        // message (the particle filters check it themselves).
        RandomWalk::check_step(delta).map_err(value_error)?;
        let filter = self.inner();
        py.detach(|| filter.predict(delta)).map_err(value_error)
    }

    /// Conditions on the readings `readings` (k, 2): azimuth and elevation (rad) per anchor, in
    /// the anchors' order. Returns the log evidence.
    fn update(&mut self, py: Python<'_>, readings: RealArray<'_>) -> PyResult<f64> {
        check_shape("readings", readings.shape(), &[Some(self.anchors), Some(2)])?;
        let view = readings.as_array();
        let readings: Vec<AzEl> = (0..self.anchors)
            .map(|j| AzEl::new(view[[j, 0]], view[[j, 1]]))
            .collect();
        let filter = self.inner();
        let update = py
            .detach(|| filter.update(&readings))
            .map_err(value_error)?;
        self.nis = update.nis.map(|n| (n.value, n.dof));
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
    let sigma = sigma_deg.to_radians();
    let data = match data.to_ascii_lowercase().as_str() {
        "model1" | "model i" => DataModel::NormalWithFlip {
            sigma_az: sigma,
            sigma_el: sigma,
        },
        "model2" | "model ii" => DataModel::VonMisesFisher {
            kappa: 1.0 / (sigma * sigma),
        },
        _ => {
            return Err(bad(format!(
                "data {data:?}: expected \"model1\" (normal angles) or \"model2\" (von \
                 Mises-Fisher)"
            )));
        }
    };
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
    runs: u64,
    seed: u64,
    particles: usize,
    #[pyo3(from_py_with = real)] sigma_deg: f64,
    steps: usize,
    truth: &str,
    fit_samples: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let track = aoa_track(data, sigma_deg, steps, truth)?;
    let parsed = filters
        .iter()
        .map(|f| parse_aoa_name(f, particles))
        .collect::<PyResult<Vec<_>>>()?;
    let fitted = if parsed.iter().any(|(_, m)| m == "AE-FITTED") {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let fit = py
            .detach(|| fit_angle_sigmas(track.data(), fit_samples, &mut rng))
            .map_err(value_error)?;
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
        let study = Study::new(label.clone(), runs, seed, Shard::WHOLE).map_err(value_error)?;
        let summary = py
            .detach(|| filter.study(&track, &study, &|_| {}))
            .map_err(value_error)?;
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
    runs: usize,
    seed: u64,
    start: u64,
    #[pyo3(from_py_with = real)] sigma_deg: f64,
    steps: usize,
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
                for y in step.measurement.iter().flatten() {
                    readings.extend_from_slice(&[y.azimuth, y.elevation]);
                }
            }
        }
        Ok((truths, readings, priors, times, deltas))
    });
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
    truth: RealArray<'py>,
    mean: RealArray<'py>,
    covariance: RealArray<'py>,
    times: Option<RealArray<'py>>,
    label: &str,
) -> PyResult<Bound<'py, PyDict>> {
    check_shape("truth", truth.shape(), &[None, None, Some(3)])?;
    let (runs, epochs) = (truth.shape()[0], truth.shape()[1]);
    check_scored("truth", runs, epochs)?;
    check_shape("mean", mean.shape(), &[Some(runs), Some(epochs), Some(3)])?;
    check_shape(
        "covariance",
        covariance.shape(),
        &[Some(runs), Some(epochs), Some(3), Some(3)],
    )?;
    for (name, array) in [
        ("truth", &truth),
        ("mean", &mean),
        ("covariance", &covariance),
    ] {
        check_scale(name, array)?;
    }
    let times = epoch_times(times, epochs)?;
    let (t, m, c) = (truth.as_array(), mean.as_array(), covariance.as_array());
    let summary = py
        .detach(|| {
            scored_summary(label, runs, epochs, &times, &PositionScorer, |run, k| {
                let truth = Rn::new_unchecked(Vector3::from_fn(|i, _| t[[run, k, i]]));
                let estimate = PositionEstimate {
                    mean: Vector3::from_fn(|i, _| m[[run, k, i]]),
                    covariance: Matrix3::from_fn(|a, b| c[[run, k, a, b]]),
                };
                (truth, estimate)
            })
        })
        .map_err(value_error)?;
    summary_dict(py, &summary)
}
