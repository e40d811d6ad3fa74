"""Filters and studies: the exact azimuth filter, the angle-of-arrival filters, and the library's
studies of its built-in scenarios, whose simulated runs are exposed so that a filter written in
Python can be run on exactly the same data and scored by the same rules.

Arrays are float64 numpy arrays (lists and integer arrays are converted); results are new arrays.
A ``float`` argument takes a Python or numpy integer or float, or a 0-d array of one; a bool, a
complex number, a string or an array of one element raises ``TypeError``. An ``int`` argument
(``runs``, ``seed``, ``start``, ``particles``, ``steps``, ``measure_every``, ``fit_samples``) takes
a Python or numpy integer: a bool raises ``TypeError``, a negative or too large value
``ValueError`` naming it (never ``OverflowError``). A list holding a bool raises ``TypeError``.
Every library error is raised as ``ValueError`` with the library's message; a refused step leaves
the filter as it was.

Threads: a filter (``ExactAzimuthFilter``, ``AoaFilter``) is used by one thread at a time. While
a call that releases the GIL (``run``, ``AoaFilter.predict``/``update``) is running, another
thread's ``run``/``predict``/``update`` of the same filter raises ``ValueError`` ("in use by
another call"), and reading it (properties, ``copy``, ``repr``) raises pyo3's ``RuntimeError``
("Already borrowed"): give each thread its own filter (``ExactAzimuthFilter.copy()``).
"""

from typing import Any, Dict, Optional, Sequence, Tuple, TypedDict, Union, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "AoaFilter",
    "ExactAzimuthFilter",
    "aoa_runs",
    "aoa_study",
    "azimuth_runs",
    "azimuth_study",
    "score_aoa",
    "score_azimuth",
    "square_track",
]

ArrayLike = npt.ArrayLike
Array = npt.NDArray[np.float64]

class AzimuthEstimate(TypedDict):
    """The estimate of :class:`ExactAzimuthFilter` (``filter.estimate``)."""

    azimuth: float
    """Circular mean of the azimuth A (rad, in (-pi, pi]); NaN while A is uniform."""
    concentration: float
    """kappa = |eta|, the concentration of the von Mises marginal p(A)."""
    rho: float
    """Mean resultant length |E exp(iA)| in [0, 1]."""
    circular_variance: float
    """-2 ln rho (rad^2), computed from kappa without cancellation; inf while A is uniform."""
    mean_r: Array
    """E r, shape (2,), platform axes (m)."""
    cov_r: Array
    """Cov r, shape (2, 2) (m^2)."""
    a: Array
    """The Gaussian part p(r | A) = N(a + R(-A) c, sigma2 I): a, shape (2,)."""
    c: Array
    """c, shape (2,), the world-fixed part of the conditional mean."""
    sigma2: float
    """sigma^2, the conditional variance of each component of r (m^2)."""
    eta: Array
    """The natural parameter of the von Mises p(A), shape (2,)."""

class AzimuthRun(TypedDict):
    """The estimates of :meth:`ExactAzimuthFilter.run`, one row per step."""

    azimuth: Array
    """(n,), NaN while A is uniform."""
    concentration: Array
    """(n,)"""
    rho: Array
    """(n,)"""
    circular_variance: Array
    """(n,)"""
    mean_r: Array
    """(n, 2)"""
    cov_r: Array
    """(n, 2, 2)"""
    a: Array
    """(n, 2)"""
    c: Array
    """(n, 2)"""
    sigma2: Array
    """(n,)"""
    log_evidence: Array
    """(n,), ln p(z) of each update, NaN at steps without a measurement."""

class StudyResult(TypedDict):
    """One method's study (or a user's scored estimates): per-epoch figures over the runs."""

    label: str
    """The study's label (method and scenario)."""
    runs: int
    """Runs covered (failed runs included)."""
    failures: Dict[str, int]
    """Failed runs by the library's reason (empty when every run succeeded)."""
    times: Array
    """(epochs,) measurement epoch times (s)."""
    metrics: Dict[str, Array]
    """Metric name -> (epochs,) figure over runs: the root mean square for "rms" metrics (an
    RMSE), the mean for "mean" and "chi2(k)" metrics, the percentage for "rate" metrics; NaN at
    an epoch without a finite value."""
    bands: Dict[str, Array]
    """Metric name -> (epochs, 2): for "chi2(k)" metrics the exact two-sided 95 % band of the mean
    of `runs` chi-square(k) values (where a consistent filter's mean falls), for "mean" metrics the
    95 % band of the mean (x +- 1.96 s / sqrt(n)); NaN where there is none."""
    counts: Dict[str, Array]
    """Metric name -> (epochs,) number of finite values averaged."""
    units: Dict[str, str]
    """Metric name -> unit ("deg", "m", "" for a pure number)."""
    reductions: Dict[str, str]
    """Metric name -> "rms", "mean", "chi2(k)" or "rate"."""

@final
class ExactAzimuthFilter:
    """The exact azimuth-alignment filter.

    A platform moves in the plane; its velocity v is known in its own axes, its position r (platform
    axes) is measured in world axes, z = R(A) r + n, n ~ N(0, sigma_m^2 I), and the two frames differ
    by an unknown constant azimuth A. The posterior p(r, A) = p(A) p(r | A) is held exactly in seven
    numbers: p(A) von Mises with natural parameter eta, p(r | A) = N(a + R(-A) c, sigma2 I).
    Both steps are closed form; the estimate is its exact moments.
    """

    def __new__(
        cls, q: float, sigma_m: float, r0: Optional[ArrayLike] = None, sigma0: float = 1.0
    ) -> "ExactAzimuthFilter":
        """The filter with velocity noise density `q` in [0, 1e49] m/sqrt(s), position noise
        `sigma_m` in [1e-49, 1e49] m, and the prior r ~ N(r0, sigma0^2 I) (r0 shape (2,), its
        components within +-1e100 m, default the origin; sigma0 in [1e-49, 1e49] m) with A
        uniform: the settings every azimuth filter accepts, so that each can run them.

        Raises ValueError for a value out of range or r0 not of shape (2,)."""
    def predict(self, velocity: ArrayLike, dt: float) -> None:
        """Propagates over `dt` >= 0 seconds with the velocity (2,) in platform axes:
        a += v dt, sigma2 += q^2 dt. Raises ValueError (state unchanged) for a non-finite velocity,
        a negative or non-finite dt, or a step leaving the valid range."""
    def update(self, z: ArrayLike) -> float:
        """Conditions on the world-axes position measurement z (2,); returns its log evidence
        ln p(z). Raises ValueError (state unchanged) for a non-finite z or a result out of range
        (a measurement too far from the prediction for the noise)."""
    @property
    def estimate(self) -> AzimuthEstimate:
        """The current estimate and density parameters (see :class:`AzimuthEstimate`)."""
    def conditional_mean(self, azimuth: float) -> Array:
        """E[r | A = azimuth] = a + R(-A) c, shape (2,). Raises ValueError for a non-finite angle."""
    def run(self, velocity: ArrayLike, dt: Union[float, ArrayLike], z: ArrayLike) -> AzimuthRun:
        """Runs n steps at once (predict, update, estimate, as the library's record loop steps a filter; GIL released): step i predicts with
        velocity[i] (n, 2) over dt (a float for every step, or (n,): an array of one element is
        one step's, not a float), then updates with z[i] (n, 2) unless that row is NaN in both
        components (no measurement at that step). Returns every step's estimate. At most 2^24 steps
        in one call (the library's limit of a recording; split a longer run, the filter carries
        over): more, or results that do not fit in memory, raise ValueError before any step.

        All or nothing: a step that fails raises ValueError naming the step and the library's
        reason, and the filter is left as it was before the call."""
    def copy(self) -> "ExactAzimuthFilter":
        """An independent copy."""

@final
class AoaFilter:
    """An angle-of-arrival filter of the position theta in R^3 from k anchors' readings.

    Each anchor at a known position s_j with a world-to-anchor rotation R_j reports the azimuth and
    elevation of R_j (theta - s_j). The filter is named "<algorithm>-<model>" as the library names
    them: algorithm PF (bootstrap particle filter, systematic resampling below 10 % effective
    size), EKF, UKF (lambda = 0.5) or IEKF (the iterated EKF: each update Gauss-Newton to the
    posterior's mode, for readings precise against the prior); model VMF (von Mises-Fisher noise on each reading's unit
    vector, concentration `kappa`), AE (alias AE-nominal, AE-fitted: normal azimuth and elevation
    errors with `sigma_az`, `sigma_el`) or AE-adaptive (sigma from the library's table of Model I
    errors at the predicted elevation, built from `sigma_az`, `sigma_el`). The process is the
    random walk theta_k = theta_{k-1} + N(0, delta diag(q_xy^2, q_xy^2, q_z^2)).
    """

    def __new__(
        cls,
        name: str,
        anchors: ArrayLike,
        rotations: Optional[ArrayLike] = None,
        *,
        kappa: Optional[float] = None,
        sigma_az: Optional[float] = None,
        sigma_el: Optional[float] = None,
        q_xy: float = 0.5,
        q_z: float = 0.1,
        prior_mean: Optional[ArrayLike] = None,
        prior_std: float = 0.5,
        particles: int = 10000,
        seed: int = 0,
    ) -> "AoaFilter":
        """The filter `name` on anchors at `anchors` (k, 3), 1 <= k <= 8, with world-to-anchor
        rotations `rotations` (k, 3, 3) (proper rotation matrices; the identity if omitted), from
        the prior N(prior_mean, prior_std^2 I) (prior_mean (3,), each coordinate within 1e100 m,
        default the origin; prior_std in [1e-49, 1e6] m: below, the prior's precision passes the
        library's limit of 1e100). kappa in [1e-12, 1e12]; sigma in [1e-9, 1e3] rad; q_xy, q_z 0
        or in [1e-100, 1e6] m/sqrt(s); the particle filter draws its `particles` from the generator seeded by `seed`.

        Raises ValueError for an unknown name, a missing or out-of-range parameter, or arrays of
        the wrong shape."""
    def predict(self, delta: float) -> None:
        """Propagates over the time step delta in [0, 1e6] s. Raises ValueError (state unchanged)."""
    def update(self, readings: ArrayLike) -> float:
        """Conditions on the readings (k, 2): azimuth and elevation (rad) of each anchor in its own
        axes, in the anchors' order (the AE models need elevations in [-pi/2, pi/2]). Returns the
        log evidence. Raises ValueError (state unchanged) for non-finite or out-of-range readings
        or a failed step (GIL released)."""
    @property
    def mean(self) -> Array:
        """The posterior mean (3,) (m)."""
    @property
    def covariance(self) -> Array:
        """The posterior covariance (3, 3) (m^2)."""
    @property
    def nis(self) -> Optional[Tuple[float, int]]:
        """The last update's normalised innovation squared and its degrees of freedom (EKF, UKF);
        None for the particle filters and before any update."""
    @property
    def name(self) -> str:
        """The name given."""

def azimuth_study(
    scenario: str,
    methods: Sequence[str],
    runs: int,
    seed: int = 1,
    *,
    duration: float = 500.0,
    dt: float = 0.1,
    measure_every: int = 10,
    sigma0: float = 1.0,
    sigma_m: float = 1.0,
    q: float = 0.1,
    filter_sigma_m: Optional[float] = None,
    filter_q: Optional[float] = None,
    filter_sigma0: Optional[float] = None,
) -> Dict[str, StudyResult]:
    """The library's Monte Carlo study of each method on a built-in azimuth scenario, as the
    `liebayes azimuth` command runs it (GIL released; each method's runs run in parallel on the
    library's thread pool, their statistics merged exactly, so the result does not depend on the
    number of threads; the methods one after another).

    scenario: "static" (v = 0, A unobservable), "circle" or "line". methods: "exact", "EKF",
    "UKF", "PF <n>", "grid <n>", "MPF <n>" (case-insensitive; default sizes 1000, 360, 360).
    Run k draws its data from stream k of `seed`, so every method sees the same runs, and
    :func:`azimuth_runs` gives those runs. The scenario has round(duration / dt) steps and a
    measurement every `measure_every` steps (at most 16384 measurement epochs); `filter_*` make
    the filters assume another noise or prior than the data's (a mis-specified model).

    Returns {method label: StudyResult} with the metrics azimuth_error, azimuth_sigma (deg, rms),
    x_error, x_sigma, y_error, y_sigma (m, rms), nees_position (chi2(2)), circular_consistency
    (mean, 1 when consistent), diverged (rate, |error| > 10 deg), log_evidence (mean) and, for the
    Kalman filters, nis (chi2(2)). Raises ValueError for any setting out of range."""

def azimuth_runs(
    scenario: str,
    runs: int,
    seed: int = 1,
    *,
    start: int = 0,
    duration: float = 500.0,
    dt: float = 0.1,
    measure_every: int = 10,
    sigma0: float = 1.0,
    sigma_m: float = 1.0,
    q: float = 0.1,
) -> Dict[str, Any]:
    """The simulated runs start .. start + runs - 1 of a built-in azimuth scenario, drawn exactly
    as :func:`azimuth_study` with the same seed and settings draws them.

    Returns a dict of arrays (R runs, S steps): "time" (S,), "dt" (S,) (step 0 has dt = 0: the
    start), "measured" (S,) bool, "velocity" (R, S, 2), "truth_r" (R, S, 2) (platform axes),
    "truth_azimuth" (R,), "z" (R, S, 2) (NaN rows where there is no measurement), "seed",
    "start". Feed `velocity[r]`, `dt`, `z[r]` to a filter; score its estimates at the measured
    steps with :func:`score_azimuth`. Raises ValueError for settings out of range or more than
    2^28 values."""

def score_azimuth(
    truth_r: ArrayLike,
    truth_azimuth: ArrayLike,
    azimuth: ArrayLike,
    rho: ArrayLike,
    mean_r: ArrayLike,
    cov_r: ArrayLike,
    circular_variance: Optional[ArrayLike] = None,
    times: Optional[ArrayLike] = None,
    label: str = "user",
) -> StudyResult:
    """Scores a user's estimates of R >= 1 runs at E measurement epochs, 1 <= E <= 16384 (a
    study's limit) and R E <= 2^28, with the library's azimuth scorer into the summary a study
    gives (the same metrics, reductions and bands; GIL released).

    truth_r (R, E, 2) and truth_azimuth (R,) from :func:`azimuth_runs` at the measured steps;
    azimuth (R, E) (NaN: no azimuth estimate), rho (R, E) in [0, 1], mean_r (R, E, 2),
    cov_r (R, E, 2, 2); circular_variance (R, E) in [0, inf] (inf: a uniform estimate) defaults
    to -2 ln rho; times (E,), finite and strictly increasing, defaults to 0, 1, 2, .... Raises
    ValueError for R or E out of range, mismatched shapes, a non-finite true azimuth, a rho
    outside [0, 1], a circular variance that is NaN or negative, a bad epoch time, or a position
    or covariance entry that is not finite or above 1e100 in magnitude (each naming its index)."""

def aoa_study(
    data: str,
    filters: Sequence[str],
    runs: int,
    seed: int = 1,
    *,
    particles: int = 10000,
    sigma_deg: float = 10.0,
    steps: int = 64,
    truth: str = "square",
    fit_samples: int = 100000,
) -> Dict[str, StudyResult]:
    """The library's square-track study (four anchors) of each named filter, as
    `liebayes aoa track` runs it: data "model1" (normal angle errors of sigma_deg, flipped over
    the poles; sigma in [1e-9, 1e3] rad) or "model2" (von Mises-Fisher, kappa = 1/sigma^2 in
    [1e-12, 1e12], so sigma in [1e-6, 1e6] rad): another sigma_deg raises ValueError naming it;
    truth "square" or
    "random-walk"; filters named as :class:`AoaFilter` ("PF-VMF", "EKF-AE-nominal",
    "UKF-AE-fitted", "EKF-AE-adaptive", "IEKF-VMF", ...) with the paper's parameters for the data (AE-fitted
    fits its sigma on `fit_samples` readings drawn from `seed`, from 2 to 2^26: a ValueError
    otherwise).

    Returns {filter label: StudyResult} with position_error, x/y/z_error, x/y/z_sigma (m, rms),
    nees_position (chi2(3)), log_evidence and, for the Kalman filters, nis."""

def aoa_runs(
    data: str,
    runs: int,
    seed: int = 1,
    *,
    start: int = 0,
    sigma_deg: float = 10.0,
    steps: int = 64,
    truth: str = "square",
) -> Dict[str, Any]:
    """The simulated square-track runs, as :func:`aoa_study` draws them, with each run's prior.

    Returns "time" (E,), "delta" (E,), "truth" (R, E, 3), "readings" (R, E, 4, 2) (azimuth,
    elevation per anchor), "prior_mean" (R, 3) (drawn from the run's filter stream as the study
    does), "prior_std", "q_xy", "q_z", "anchors" (4, 3), "rotations" (4, 3, 3), "seed", "start".
    At every step: predict(delta[k]) then update(readings[r, k])."""

def score_aoa(
    truth: ArrayLike,
    mean: ArrayLike,
    covariance: ArrayLike,
    times: Optional[ArrayLike] = None,
    label: str = "user",
) -> StudyResult:
    """Scores a user's position estimates, mean (R, E, 3) and covariance (R, E, 3, 3) against
    truth (R, E, 3), with the library's angle-of-arrival scorer into the summary a study gives
    (GIL released): R >= 1 runs, 1 <= E <= 16384 epochs (a study's limit), R E <= 2^28.
    times (E,), finite and strictly increasing, defaults to 0, 1, 2, .... Raises ValueError for
    R or E out of range, mismatched shapes, a bad epoch time or a value that is not finite or
    above 1e100 in magnitude (naming its index); an estimate whose covariance is not positive
    definite scores an infinite NEES, counted as a value that is not finite."""

def square_track() -> Tuple[Array, Array]:
    """The square track's four anchors: positions (4, 3) and world-to-anchor rotations (4, 3, 3)."""
