#!/usr/bin/env python3
"""Calls every public entry of the Python package with extreme and malformed arguments and reports
each call that breaks the input contract: a crash of the interpreter, a hang, an exception other
than ValueError or TypeError (a Rust panic surfaces as PanicException; an OverflowError, which
`except ValueError` misses, is a finding too), an empty error message, or a result holding NaN or
an infinity.

Each entry starts from a valid call (the arguments below); a case replaces one or all of its
arguments by extreme numbers (NaN, infinities, f64::MAX, subnormals, ±0, 1e±300, large integers,
bools and numpy integers where an integer goes), arrays of the right shape scaled by or holding one
such number, the same values as strided, reversed, Fortran-ordered or zero-stride views, lists
holding a bool, wrong shapes, empty batches, other types. The studies and the scenarios' runs are
fuzzed with valid scenario names, their counts drawn from values that are refused or small (a
valid huge count is hours of work, not a finding), their method and filter names drawn from valid
ones (small sizes) and malformed ones (BAD_STRINGS). Instances are built from a fuzzed constructor
call when it succeeds (the densities now and then from extreme valid arguments), then every
method and property is fuzzed on them: a pair method (product, kl_divergence, convolve, compose)
with a second instance built from extreme valid arguments half of the time, the points of S² and
SO(3) and the magnetometer readings also by hand-made hard values (the antipode or cut locus of
the mean, a field parallel to gravity); a refused call to a stateful filter must leave its state
as it was. A returned instance is checked through its parameters. Entries whose signature
`inspect` cannot read, and public entries with no fuzzing, are listed (SKIPPED, UNCOVERED).

Run: `python3 tools/python_fuzz.py [--cases N] [--seed S]` with the package installed
(`pip install ./python`); it runs the cases in a child interpreter, restarts it after a crash, and
exits non-zero when it found anything. Documented outputs that are not finite (an azimuth of NaN
while the azimuth is uniform, a log evidence or a measurement row of NaN at a step without a
measurement, the circular variance +inf of a uniform density, a log density of -inf, BROAD's
reference quaternion where the capture lost it) are listed in ALLOWED.
"""

import argparse
import inspect
import math
import os
import subprocess
import sys
import time

HUGE = 1.7976931348623157e308
SCALARS = [
    math.nan, math.inf, -math.inf, 0.0, -0.0, 5e-324, 1e-310, 2.2250738585072014e-308, 1e-300,
    1e-150, 1e-20, 1e-9, 0.5, 1.0, -1.0, math.pi, -math.pi, 2 * math.pi, 1e4, 1e9, 1e20, 1e100,
    1e154, 1e200, 1e300, HUGE, -HUGE, -1e300,
]
INTEGERS = [
    0, 1, 2, 3, -1, 10, 1000, 2**31, 2**32, 2**53, 2**63 - 1, 2**64, -(2**63), 10**12, 10**400,
    -(10**400), True, False,
]
# Counts of the studies and runs: refused values and small valid ones only (a valid huge count is
# hours of work).
COUNTS = [0, 1, 2, 3, -1, 2**64, -(2**64), 10**400, True, False, 2.0, "3", None]

# Malformed (and odd but valid) names for the string arguments of these keys: a case that fuzzes
# such an argument draws half of its values from here.
BAD_STRINGS = {
    "methods": [
        "pf +5", "pf 1 2", "grid 0", "PF 99999999999999999999", "PF 18446744073709551615",
        "grid 1073741825", "MPF 0", "PF -1", "PF 1e3", "EKF 3", "exact:", ":", " ", "PF\t4",
        "pf:3", "MPF:2", "gRiD 4", "PF 0x10", "ekf-ukf", "PF \u0664", "PF 4 ", "mpf 1", "grid 1",
    ],
    "filters": [
        "PF-", "-VMF", "PF-VMF-", "pf-vmf", "IEKF", "UKF-AE-FITTED", "ekf-ae-nominal",
        "PF-AE-ADAPTIVE", "XKF-VMF", "EKF--AE", " EKF-VMF ", "EKF-\uff21\uff25", "PF-AE-fitted-",
    ],
    "truth": ["random_walk", "RANDOM-WALK", "square ", "random", "Square"],
    "scenario": ["STATIC", "Circle", " line", "lines"],
    "data": ["Model I", "model ii", "model3", "MODEL1 "],
    "sensors": ["9D", "6D", "6d ", "3d", "", "9d\x00"],
    "propagation": ["UKF", "Ekf", "ukf ", "", "ekf\x00"],
}
BAD_STRINGS["name"] = BAD_STRINGS["filters"]
# Valid but extreme concentrations and variances of the densities' second instances.
KAPPAS = [0.0, 5e-324, 1e-300, 1e-9, 1.0, 700.0, 1e9, 1e150, 1e300]
VARIANCES = [1e-300, 1e-150, 1e-20, 1e-9, 1.0, 1e9, 1e100, 1e300, HUGE]

# Entries whose non-finite outputs are documented: (entry, output key or None) -> values allowed.
ALLOWED = {
    ("ExactAzimuthFilter.estimate", "azimuth"): "nan",
    ("ExactAzimuthFilter.estimate", "circular_variance"): "inf",
    ("ExactAzimuthFilter.run", "azimuth"): "nan",
    ("ExactAzimuthFilter.run", "circular_variance"): "inf",
    ("ExactAzimuthFilter.run", "log_evidence"): "nan",
    # A step without a measurement has a row of NaN; the reference quaternion is NaN where the
    # optical capture lost it.
    ("azimuth_runs", "z"): "nan",
    ("read_broad", "quat"): "nan",
}
# Summaries mark an epoch without a finite value by NaN in these fields.
SUMMARY_FIELDS = {"metrics", "bands"}
# The counts of these entries are drawn from COUNTS when fuzzed (valid huge values are long work).
COUNTED = {
    "azimuth_runs": {"runs", "start", "measure_every"},
    "aoa_runs": {"runs", "start", "steps"},
    "azimuth_study": {"runs", "measure_every"},
    "aoa_study": {"runs", "steps", "particles", "fit_samples"},
    "AoaFilter": {"particles"},
}
BROAD_TRIAL = os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
    "data", "broad", "01_undisturbed_slow_rotation_A.mat",
)


def child(cases, seed):
    """Runs the cases, printing one line per call before it is made and one per finding."""
    import numpy as np

    import liebayes
    from liebayes import attitude, densities, filters, manifolds

    import warnings

    # The fuzzer's own overflow is expected; a conversion that drops an imaginary part is a finding.
    np.seterr(all="ignore")
    warnings.simplefilter("error", np.exceptions.ComplexWarning)
    rng = np.random.default_rng(seed)
    def rot(k=None):
        q = rng.normal(size=4 if k is None else (k, 4))
        return manifolds.UnitQuaternion.to_matrix(manifolds.UnitQuaternion.normalize(q))

    def quat():
        return manifolds.UnitQuaternion.normalize(rng.normal(size=4))

    def unit(k=3):
        v = rng.normal(size=k)
        return v / np.linalg.norm(v)

    def vec(k=3, scale=0.5):
        return rng.normal(size=k) * scale

    def pose():
        return manifolds.Se3.from_rotation_translation(rot(), vec())

    def spd(k):
        a = rng.normal(size=(k, k)) * 0.1
        return a @ a.T + 0.01 * np.eye(k)

    def gen():
        return np.random.default_rng(int(rng.integers(1 << 30)))

    def pick(options):
        return options[rng.integers(len(options))]

    omit = object()  # a maker's value for "leave this argument out"

    def rx(angle):
        c, s = math.cos(angle), math.sin(angle)
        return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])

    def spheres():
        """Unit vectors, shape (3,) or a batch (..., 3)."""
        shape = pick([(), (1,), (5,), (2, 2)])
        v = rng.normal(size=shape + (3,))
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    def sphere_bad(obj):
        """A point of S² that is malformed, or valid but hard against the density's mean."""
        m = getattr(obj, "mean", None)
        m = np.array([0.0, 0, 1]) if m is None else np.asarray(m, dtype=float)
        near = -m + rng.normal(size=3) * 1e-12
        return pick([
            np.array([math.nan, 0, 0]), np.array([[0, 0, 1.0], [math.nan, 0, 0]]),
            unit() * (1 + 1e-6), unit() * 2, np.zeros(3), -m, np.stack([m, -m]),
            near / np.linalg.norm(near), -m * (1 + 5e-10), m.copy(), m * (1 + 5e-10),
            np.zeros((0, 3)), np.zeros((2, 0, 3)), np.zeros(0), np.array([1e300, 0, 0]),
            np.array([5e-324, 0, 0]),
        ])

    def so3_bad(obj):
        """A rotation at or near the cut locus of the density's mean, or malformed."""
        m = np.asarray(getattr(obj, "mean", np.eye(3)), dtype=float)
        return pick([
            m @ rx(math.pi), m @ rx(math.pi - 1e-12), m @ rx(-math.pi + 1e-9), m.copy(),
            np.stack([m, m @ rx(math.pi)]), m * (1 + 1e-6), np.zeros((0, 3, 3)),
            np.where(np.eye(3) > 0, math.nan, m),
        ])

    MAG = np.array([20.0, 0, -45])

    def mag_bad():
        """A magnetometer reading: vertical (parallel to the gravity of a level IMU), tiny, huge,
        zero or not finite."""
        return pick([
            np.array([0, 0, -45.0]), np.array([0, 0, 45.0]), np.full(3, 5e-324),
            np.array([1e9, 0, 0]), np.array([math.nan, 0, 0]), np.zeros(3),
            np.array([math.inf, 0, 0]), np.array([1e-300, 0, 0]), np.array([1e300, 0, 0]),
            np.array([0, 0, -45.0]) + 1e-12, MAG * 1e-9,
        ])

    def mags(n, scale=0.5):
        return np.tile(MAG, (n, 1)) + rng.normal(size=(n, 3)) * scale

    def mags_bad(n):
        out = mags(n)
        bad = mag_bad()
        if rng.random() < 0.5:
            out[:] = bad
        else:
            out[rng.integers(n)] = bad
        return out

    def steps_dt_bad(n=5):
        """A per-step dt of the wrong length, or holding a bad entry."""
        dt = np.full(n, 0.1)
        k = rng.integers(n)
        bad = dt.copy()
        bad[k] = pick([math.nan, 1e300, -0.1, math.inf, HUGE, 5e-324, -0.0])
        return pick([
            np.full(n - 1, 0.1), np.full(n + 1, 0.1), bad, dt.reshape(n, 1), np.array([0.1]),
            np.zeros(n), dt.tolist(), [0.1] * (n - 1) + [True], np.array(0.1), np.full(n, 1e300),
            np.full(n, 5e-324), np.zeros(0),
        ])

    attitude_defaults = attitude.AttitudeFilter.default_params()
    offline_defaults = attitude.offline_default_params()

    def attitude_settings(defaults):
        """dt or rate (now and then both or neither: refused) and up to three parameters at a
        valid value (propagation often "ukf"), now and then an unknown one."""
        out = {}
        r = rng.random()
        if r < 0.45:
            out["dt"] = 0.01
        elif r < 0.9:
            out["rate"] = 100.0
        elif r < 0.93:
            out["dt"], out["rate"] = 0.01, 100.0
        names = sorted(defaults)
        for name in rng.choice(names, size=rng.integers(0, 4), replace=False):
            d = defaults[str(name)]
            if isinstance(d, bool):
                out[str(name)] = bool(rng.integers(2))
            elif isinstance(d, str):
                out[str(name)] = pick(["ekf", "ukf"])
            else:
                out[str(name)] = d * pick([1.0, 0.5, 2.0])
        if rng.random() < 0.3:
            out["propagation"] = "ukf"
        if rng.random() < 0.03:
            out["no_such_parameter"] = 1.0
        return out

    def attitude_args():
        out = attitude_settings(attitude_defaults)
        sensors = pick([omit, None, "9d", "6d"])
        if sensors is not omit:
            out["sensors"] = sensors
        return out

    def offline_args():
        n = 50
        out = {
            "gyr": rng.normal(size=(n, 3)) * 0.1,
            "acc": np.tile([0, 0, 9.81], (n, 1)) + rng.normal(size=(n, 3)) * 0.1,
        }
        if rng.random() < 0.5:
            out["mag"] = mags(n)
        out.update(attitude_settings(offline_defaults))
        return out

    def azimuth_method_name():
        return pick(["exact", "EKF", "UKF", "PF 20", "pf 3", "grid 36", "Grid:8", "MPF 10", "mpf 2"])

    def aoa_filter_name():
        return pick([
            "EKF-VMF", "UKF-AE", "EKF-AE-adaptive", "IEKF-VMF", "PF-VMF", "PF-AE", "UKF-VMF",
            "EKF-AE", "IEKF-AE", "PF-AE-adaptive", "EKF-AE-fitted", "UKF-AE-fitted",
            "PF-AE-fitted", "IEKF-AE-nominal",
        ])

    # name -> (callable, {argument: valid value maker}); instances' methods below.
    so3 = {"omega": vec, "r": rot, "a": rot, "b": rot, "v": vec, "q": quat, "m": rot}
    quaternion = {"omega": vec, "q": quat, "p": quat, "v": vec, "r": rot}
    s2 = {"x": unit, "y": unit, "w": vec, "u": lambda: vec(2), "v": vec}
    se3 = {
        "xi": lambda: vec(6), "x": pose, "a": pose, "b": pose, "p": vec,
        "r": rot, "t": vec, "m": pose,
    }
    entries = {}
    skipped = []  # entries whose signature inspect cannot read: listed, never dropped silently
    for cls, makers in [
        (manifolds.So3, so3), (manifolds.UnitQuaternion, quaternion),
        (manifolds.S2, s2), (manifolds.Se3, se3),
    ]:
        for name in dir(cls):
            if name.startswith("_"):
                continue
            fn = getattr(cls, name)
            try:
                params = list(inspect.signature(fn).parameters)
            except (TypeError, ValueError):
                skipped.append(f"{cls.__name__}.{name}")
                continue
            if cls is manifolds.So3 and name == "vee":
                entries[f"{cls.__name__}.{name}"] = (fn, {"a": lambda: manifolds.So3.hat(vec())})
            elif cls is manifolds.Se3 and name == "vee":
                entries[f"{cls.__name__}.{name}"] = (fn, {"a": lambda: manifolds.Se3.hat(vec(6))})
            else:
                entries[f"{cls.__name__}.{name}"] = (fn, {p: makers[p] for p in params})

    def samples_circle():
        return rng.uniform(-3, 3, size=20)

    def samples_sphere():
        return np.array([unit() for _ in range(20)])

    def samples_quat():
        return np.array([quat() for _ in range(20)])

    entries.update({
        "bingham_log_normaliser": (densities.bingham_log_normaliser, {"z": lambda: -np.array([0, 1.0, 2.0, 5.0])}),
        "VonMises.from_natural": (densities.VonMises.from_natural, {"eta": lambda: vec(2)}),
        "VonMises.fit": (densities.VonMises.fit, {"samples": samples_circle, "weights": lambda: np.ones(20)}),
        "VonMisesFisher.from_natural": (densities.VonMisesFisher.from_natural, {"eta": vec}),
        "VonMisesFisher.fit": (densities.VonMisesFisher.fit, {"samples": samples_sphere, "weights": lambda: np.ones(20)}),
        "Bingham.from_natural": (densities.Bingham.from_natural, {"m": lambda: -spd(4)}),
        "Bingham.from_direction": (densities.Bingham.from_direction, {"measured": unit, "reference": unit, "sigma": lambda: 0.1}),
        "Bingham.fit": (densities.Bingham.fit, {"samples": samples_quat, "weights": lambda: np.ones(20)}),
        "ManifoldGaussianSo3.fit": (densities.ManifoldGaussianSo3.fit, {"samples": lambda: rot(20), "weights": lambda: np.ones(20)}),
        "ManifoldGaussianS2.fit": (densities.ManifoldGaussianS2.fit, {"samples": samples_sphere, "weights": lambda: np.ones(20)}),
        "score_aoa": (filters.score_aoa, {
            "truth": lambda: rng.normal(size=(2, 5, 3)), "mean": lambda: rng.normal(size=(2, 5, 3)),
            "covariance": lambda: np.broadcast_to(np.eye(3), (2, 5, 3, 3)).copy(),
        }),
        "score_azimuth": (filters.score_azimuth, {
            "truth_r": lambda: rng.normal(size=(2, 5, 2)), "truth_azimuth": lambda: rng.normal(size=(2, 5)),
            "azimuth": lambda: rng.normal(size=(2, 5)), "rho": lambda: np.full((2, 5), 0.5),
            "mean_r": lambda: rng.normal(size=(2, 5, 2)),
            "cov_r": lambda: np.broadcast_to(np.eye(2), (2, 5, 2, 2)).copy(),
        }),
        "azimuth_runs": (filters.azimuth_runs, {
            "scenario": lambda: str(rng.choice(["static", "circle", "line"])), "runs": lambda: 2,
            "seed": lambda: 3, "start": lambda: 1, "duration": lambda: 5.0, "measure_every": lambda: 5,
            "dt": lambda: 0.1, "sigma0": lambda: 1.0, "sigma_m": lambda: 1.0, "q": lambda: 0.1,
        }),
        "aoa_runs": (filters.aoa_runs, {
            "data": lambda: str(rng.choice(["model1", "model2"])), "runs": lambda: 2,
            "seed": lambda: 3, "start": lambda: 1, "steps": lambda: 4, "sigma_deg": lambda: 10.0,
            "truth": lambda: pick(["square", "random-walk"]),
        }),
        "azimuth_study": (filters.azimuth_study, {
            "scenario": lambda: str(rng.choice(["static", "circle", "line"])),
            "methods": lambda: [azimuth_method_name() for _ in range(rng.integers(1, 3))],
            "runs": lambda: 2, "seed": lambda: 3, "duration": lambda: 5.0, "measure_every": lambda: 5,
            "dt": lambda: 0.1, "sigma0": lambda: 1.0, "sigma_m": lambda: 1.0, "q": lambda: 0.1,
            "filter_sigma_m": lambda: pick([omit, None, 1.0, 0.5]),
            "filter_q": lambda: pick([omit, None, 0.1, 0.0]),
            "filter_sigma0": lambda: pick([omit, None, 1.0, 2.0]),
        }),
        "aoa_study": (filters.aoa_study, {
            "data": lambda: str(rng.choice(["model1", "model2"])),
            "filters": lambda: [aoa_filter_name() for _ in range(rng.integers(1, 3))],
            "runs": lambda: 2, "seed": lambda: 3, "steps": lambda: 4, "sigma_deg": lambda: 10.0,
            "particles": lambda: 50, "fit_samples": lambda: 200,
            "truth": lambda: pick(["square", "random-walk"]),
        }),
        "square_track": (filters.square_track, {}),
        # A callable instead of a table: its arguments depend on each other (dt or rate).
        "offline_attitude": (attitude.offline_attitude, offline_args),
        "offline_default_params": (attitude.offline_default_params, {}),
        "read_broad": (attitude.read_broad, {
            "path": lambda: str(rng.choice(["/nonexistent.mat", BROAD_TRIAL])),
        }),
    })

    # class -> (constructor, {argument: maker}, {method: {argument: maker}}, state probe)
    classes = {
        "VonMises": (densities.VonMises, {"mu": lambda: 0.3, "kappa": lambda: 2.0}),
        "VonMisesFisher": (densities.VonMisesFisher, {"mean": unit, "kappa": lambda: 2.0}),
        "Bingham": (densities.Bingham, {"orientation": lambda: np.linalg.qr(rng.normal(size=(4, 4)))[0], "eigenvalues": lambda: np.array([0, -1.0, -2.0, -5.0])}),
        "HeatKernelSo3": (densities.HeatKernelSo3, {"mean": rot, "variance": lambda: 0.2}),
        "ManifoldGaussianSo3": (densities.ManifoldGaussianSo3, {"mean": rot, "cov": lambda: spd(3)}),
        "ManifoldGaussianS2": (densities.ManifoldGaussianS2, {"mean": unit, "cov": lambda: spd(2)}),
        "ExactAzimuthFilter": (filters.ExactAzimuthFilter, {
            "q": lambda: 0.1, "sigma_m": lambda: 1.0, "r0": lambda: pick([omit, None, vec(2)]),
            "sigma0": lambda: 1.0,
        }),
        "AoaFilter": (filters.AoaFilter, {
            "name": aoa_filter_name,
            "anchors": lambda: rng.normal(size=(3, 3)) * 5,
            "rotations": lambda: pick([omit, None, rot(3)]), "kappa": lambda: 50.0,
            "sigma_az": lambda: 0.1, "sigma_el": lambda: 0.1, "q_xy": lambda: 0.5, "q_z": lambda: 0.1,
            "prior_mean": lambda: pick([omit, None, vec(3)]), "prior_std": lambda: 0.5,
            "particles": lambda: 200, "seed": lambda: int(rng.integers(100)),
        }),
        "AttitudeFilter": (attitude.AttitudeFilter, attitude_args),
    }
    methods = {
        "log_pdf": {"x": lambda: rng.uniform(-3, 3, 5), "q": quat, "r": rot},
        "sample": {"n": lambda: 5, "rng": gen},
        "angle_pdf": {"t": lambda: rng.uniform(0, 3, 5)},
        "angle_cdf": {"t": lambda: rng.uniform(0, 3, 5)},
        "mahalanobis_squared": {"r": rot},
        "conditional_mean": {"azimuth": lambda: 0.4},
        "predict": {"velocity": lambda: vec(2), "dt": lambda: 0.1, "delta": lambda: 0.1},
        "update": {
            "z": lambda: vec(2), "readings": lambda: rng.normal(size=(3, 2)) * 0.3,
            "gyr": lambda: vec(3, 0.1), "acc": lambda: np.array([0, 0, 9.81]),
            "mag": lambda: MAG + vec(3),  # left out for a 6D filter (see the loop)
        },
        "update_batch": {
            "gyr": lambda: rng.normal(size=(20, 3)) * 0.1,
            "acc": lambda: np.tile([0, 0, 9.81], (20, 1)) + rng.normal(size=(20, 3)) * 0.1,
            "mag": lambda: mags(20),
        },
        "run": {
            "velocity": lambda: rng.normal(size=(5, 2)),
            "dt": lambda: pick([0.1, rng.uniform(0, 0.2, 5)]), "z": lambda: rng.normal(size=(5, 2)),
        },
    }
    # Methods whose argument differs from the shared table's: (class, method) -> arguments.
    class_methods = {
        ("VonMisesFisher", "log_pdf"): {"x": spheres},
        ("ManifoldGaussianS2", "log_pdf"): {"x": spheres},
        ("ManifoldGaussianS2", "mahalanobis_squared"): {"x": spheres},
    }
    # Hand-made bad values of an argument, given the instance (None for a function): a case of
    # these entries replaces one such argument by one of them a quarter of the time.
    special = {
        "VonMisesFisher.log_pdf": {"x": sphere_bad},
        "ManifoldGaussianS2.log_pdf": {"x": sphere_bad},
        "ManifoldGaussianS2.mahalanobis_squared": {"x": sphere_bad},
        "ManifoldGaussianSo3.log_pdf": {"r": so3_bad},
        "ManifoldGaussianSo3.mahalanobis_squared": {"r": so3_bad},
        "HeatKernelSo3.log_pdf": {"r": so3_bad},
        "AttitudeFilter.update": {"mag": lambda obj: mag_bad()},
        "AttitudeFilter.update_batch": {"mag": lambda obj: mags_bad(20)},
        "offline_attitude": {"mag": lambda obj: mags_bad(50)},
        "ExactAzimuthFilter.run": {"dt": lambda obj: steps_dt_bad()},
    }

    def directions():
        d = pick([[1.0, 0, 0], [-1.0, 0, 0], [0, 0, 1.0], [0, 0, -1.0], [1.0, 1e-9, 0], unit()])
        d = np.array(d, dtype=float)
        return d / np.linalg.norm(d)

    def opposite(obj, key="mean"):
        """The antipode of obj's mean direction (None for a uniform obj or none)."""
        m = None if obj is None else getattr(obj, key, None)
        return None if m is None else -np.asarray(m, dtype=float)

    def ext_von_mises(obj):
        mu = pick([0.0, math.pi, -math.pi, math.pi / 2, 1e-300, 1e300, -1e300, 2 * math.pi, 3.0])
        if obj is not None and obj.mean is not None and rng.random() < 0.5:
            mu = obj.mean + math.pi
        kappa = obj.concentration if obj is not None and rng.random() < 0.3 else pick(KAPPAS)
        return {"mu": mu, "kappa": kappa}

    def ext_von_mises_fisher(obj):
        mean = opposite(obj) if rng.random() < 0.5 else None
        kappa = obj.concentration if obj is not None and rng.random() < 0.3 else pick(KAPPAS)
        return {"mean": directions() if mean is None else mean, "kappa": kappa}

    def ext_bingham(obj):
        v = pick([np.eye(4), np.linalg.qr(rng.normal(size=(4, 4)))[0], np.eye(4)[:, [3, 1, 0, 2]]])
        if obj is not None and rng.random() < 0.5:
            v = obj.orientation[:, [1, 2, 3, 0]]
        z = pick([
            [0, 0, 0, 0], [0, -1e12, -1e12, -1e12], [0, 0, 0, -1e12], [0, -5e-324, -1e-300, -1e-9],
            [1e300] * 4, [1e12, 0, 0, 0], [0, -1, -2, -5], [1e15, 1e15, 1e15, 1e15 - 1e12],
            [-1e300, -1e300, -1e300, -1e300], [0, -1e12, -1e12 + 1e-3, -1e12 + 2e-3],
        ])
        return {"orientation": v, "eigenvalues": np.array(z, dtype=float)}

    def ext_heat_kernel(obj):
        mean = pick([np.eye(3), rx(math.pi), rot()])
        if obj is not None and rng.random() < 0.5:
            mean = obj.mean @ pick([rx(math.pi), np.eye(3), rx(1e-9)])
        return {"mean": mean, "variance": pick(VARIANCES)}

    def ext_gaussian_so3(obj):
        mean = pick([np.eye(3), rx(math.pi), rot()])
        if obj is not None and rng.random() < 0.6:  # the same mean: kl_divergence is defined
            mean = obj.mean @ pick([np.eye(3), np.eye(3), rx(math.pi)])
        near = np.array([[1, 1 - 1e-9, 0], [1 - 1e-9, 1, 0], [0, 0, 1.0]])
        cov = pick([
            1e100 * np.eye(3), 1e-99 * np.eye(3), 1e-100 * np.eye(3), np.diag([1e-100, 1.0, 1e100]), np.eye(3), near,
            1e300 * np.eye(3), 5e-324 * np.eye(3), spd(3) * 1e50, np.diag([1e-300, 1e-300, 1e300]),
        ])
        return {"mean": mean, "cov": cov}

    def ext_gaussian_s2(obj):
        mean = directions()
        if obj is not None and rng.random() < 0.6:
            mean = obj.mean if rng.random() < 0.7 else -obj.mean
        near = np.array([[1, 1 - 1e-9], [1 - 1e-9, 1.0]])
        cov = pick([
            1e100 * np.eye(2), 1e-99 * np.eye(2), 1e-100 * np.eye(2), np.diag([1e-100, 1e100]), np.eye(2), near,
            1e300 * np.eye(2), 5e-324 * np.eye(2), spd(2) * 1e50,
        ])
        return {"mean": mean, "cov": cov}

    # class -> valid constructor arguments at the extremes, given an instance to pair with (or
    # None): the instance of a case now and then, and the `other` of its pair methods (product,
    # kl_divergence, convolve, compose) half of the time.
    extremes = {
        "VonMises": ext_von_mises, "VonMisesFisher": ext_von_mises_fisher, "Bingham": ext_bingham,
        "HeatKernelSo3": ext_heat_kernel, "ManifoldGaussianSo3": ext_gaussian_so3,
        "ManifoldGaussianS2": ext_gaussian_s2,
    }

    def view_of(a):
        """The values of `a` as a view numpy does not hand over as it is: strided, reversed,
        Fortran-ordered or zero-stride (same shape and values, so the call must give what `a`
        gives), or a list holding a bool."""
        k = rng.integers(5)
        if k == 0:
            wide = np.repeat(a[..., None], 2, axis=-1)
            return wide[..., 0]
        if k == 1 and a.ndim:
            return a[::-1].copy()[::-1]
        if k == 2:
            return np.asfortranarray(a)
        if k == 3 and a.size:
            return np.broadcast_to(a.flat[0], a.shape)
        listed = a.tolist()
        if a.ndim == 1 and a.size:
            listed[rng.integers(a.size)] = True
        return listed

    def extreme_like(value, key=None, entry=None):
        """An extreme or malformed version of a valid argument."""
        k = rng.integers(11)
        s = SCALARS[rng.integers(len(SCALARS))]
        if isinstance(value, str):
            if key in BAD_STRINGS and rng.random() < 0.5:
                return pick(BAD_STRINGS[key])
            return [s, "", "x" * 1000, "nonsense", None][rng.integers(5)]
        if isinstance(value, list) and value and all(isinstance(v, str) for v in value):
            bad = pick(BAD_STRINGS.get(key, ["nonsense"]))
            return pick([[], value * 2, [bad], value + [bad], value[0], [value[0], None], s])
        if isinstance(value, bool) or value is None:
            return [s, None, True, -1, "x"][rng.integers(5)]
        if isinstance(value, int) and entry in COUNTED and key in COUNTED[entry]:
            return COUNTS[rng.integers(len(COUNTS))]
        if isinstance(value, int):
            i = INTEGERS[rng.integers(len(INTEGERS))]
            return [i, s, np.int64(min(max(i, -(2**63)), 2**63 - 1)), np.True_][rng.integers(4)]
        if isinstance(value, float):
            return s
        if isinstance(value, np.ndarray):
            a = np.array(value, dtype=float)
            if k == 0:
                return a * s
            if k == 1 and a.size:
                a.flat[rng.integers(a.size)] = s
                return a
            if k == 2:
                return np.full_like(a, s)
            if k == 3:
                return a.reshape(-1)[: max(a.size - 1, 0)]
            if k == 4:
                return np.zeros((0,) + a.shape)
            if k == 5:
                return np.stack([a, a * s])
            if k == 6:
                return [None, "text", a.astype(complex), a.astype(bool), []][rng.integers(5)]
            if k == 7 and a.size:
                return a + rng.normal(size=a.shape) * [1e-12, 1e-9, 1e-6, 1e-3][rng.integers(4)]
            if k in (8, 9):
                return view_of(a)
            return np.full(a.shape[:-1] + (a.shape[-1] + 1,) if a.ndim else (2,), s)
        if isinstance(value, np.random.Generator):
            return [None, 3, "rng"][rng.integers(3)]
        return s

    def draw(makers):
        if callable(makers):
            return makers()
        drawn = {k: m() for k, m in makers.items() if m is not None}
        return {k: v for k, v in drawn.items() if v is not omit}

    def mutate(args, entry=None):
        args = dict(args)
        if not args:
            return args
        keys = list(args)
        chosen = keys if rng.random() < 0.3 else [keys[rng.integers(len(keys))]]
        for key in chosen:
            args[key] = extreme_like(args[key], key, entry)
        return args

    def nonfinite(value, path=""):
        """The first non-finite number in a result, as (path, value), or None."""
        if isinstance(value, float):
            return None if math.isfinite(value) else (path, value)
        if isinstance(value, np.ndarray):
            if value.dtype.kind == "f" and value.size and not np.all(np.isfinite(value)):
                return (path, value[~np.isfinite(value)].flat[0])
            return None
        if isinstance(value, dict):
            for k, v in value.items():
                found = nonfinite(v, f"{path}/{k}")
                if found:
                    return found
        if isinstance(value, (tuple, list)):
            for v in value:
                found = nonfinite(v, path)
                if found:
                    return found
        if type(value).__module__.startswith("liebayes"):
            # An instance returned (a constructor's, a product's, a fit's): its parameters.
            for name in ("natural", "mean", "covariance", "concentration", "variance", "eigenvalues", "orientation"):
                if name not in type(value).__dict__:
                    continue
                try:
                    attr = getattr(value, name)
                except (ValueError, TypeError):  # a filter without a sample has no estimate
                    continue
                found = nonfinite(attr, f"{path}/{type(value).__name__}.{name}")
                if found:
                    return found
        return None

    findings = 0

    def shown(args):
        return {
            k: (v if not isinstance(v, np.ndarray) else f"array{v.shape}:{np.array2string(v.ravel()[:6], precision=3)}")
            for k, v in args.items()
        }

    def report(kind, entry, args, detail):
        nonlocal findings
        findings += 1
        print(f"FINDING {kind} {entry} {shown(args)} -> {detail}", flush=True)

    def call(entry, fn, args):
        print(f"CALL {entry} {shown(args)}"[:400], flush=True)
        try:
            result = fn(**args)
        except (ValueError, TypeError) as e:
            if not str(e):
                report("empty-message", entry, args, type(e).__name__)
            return None, e
        except BaseException as e:  # noqa: BLE001: a Rust panic is a BaseException (PanicException)
            if isinstance(e, KeyboardInterrupt):
                raise
            kind = "panic" if type(e).__name__ == "PanicException" else "exception"
            report(kind, entry, args, f"{type(e).__name__}: {e}")
            return None, e
        found = nonfinite(result)
        if found:
            parts = found[0].split("/")
            allowed = ALLOWED.get((entry, parts[-1]))
            ok = allowed == "nan" and math.isnan(found[1]) or allowed == "inf" and found[1] == math.inf
            ok = ok or (entry.endswith("log_pdf") and found[1] == -math.inf)
            ok = ok or (SUMMARY_FIELDS.intersection(parts) and math.isnan(found[1]))
            if not ok:
                report("non-finite", entry, args, f"{found[0]}={found[1]}")
        return result, None

    def vary(entry, args, obj, p_mutate, counted=None):
        """The arguments of a case: a hand-made bad value of one argument a quarter of the time
        when the entry has them, else mutated with probability p_mutate, else as they are."""
        r = rng.random()
        bads = special.get(entry, {})
        if bads and r < 0.25:
            key = pick(sorted(bads))
            return {**args, key: bads[key](obj)}
        # A pair method's `other` stays an instance most of the time (the pair is the point).
        kept = {"other": args["other"]} if "other" in args and rng.random() < 0.8 else {}
        rest = {k: v for k, v in args.items() if k not in kept}
        return {**(mutate(rest, counted) if rng.random() < p_mutate else rest), **kept}

    def partner(cname, cls, obj, from_extremes):
        """The `other` of a pair method: obj itself half of the time, else an instance built from
        extreme valid arguments (obj when that constructor call is refused)."""
        if rng.random() < (0.3 if from_extremes else 0.5):
            return obj
        try:
            kwargs = extremes[cname](obj) if cname in extremes else draw(classes[cname][1])
        except Exception as e:  # noqa: BLE001: reading obj's properties failed
            report("exception", f"{cname} (properties)", {}, f"{type(e).__name__}: {e}")
            return obj
        other, _ = call(cname, cls, kwargs)
        return obj if other is None else other

    def state(obj):
        out = []
        for name in ("natural", "mean", "covariance", "estimate", "quat", "bias"):
            try:
                out.append(repr(getattr(obj, name)))
            except Exception:  # noqa: BLE001
                pass
        return out

    # Every public entry of the package is fuzzed or listed here (none drops out silently).
    for cname, (cls, _) in classes.items():
        for name in dir(cls):
            attr = getattr(cls, name)
            if name.startswith("_") or type(attr).__name__ == "getset_descriptor":
                continue
            try:
                inspect.signature(attr)
            except (TypeError, ValueError):
                skipped.append(f"{cname}.{name} (called without arguments)")
    print(f"SKIPPED {len(skipped)} entries without a readable signature: {', '.join(skipped) or '-'}", flush=True)
    covered = set(entries) | set(classes) | {"So3", "UnitQuaternion", "S2", "Se3"}
    public = [n for mod in (manifolds, densities, filters, attitude) for n in mod.__all__]
    uncovered = sorted(set(public) - covered)
    if uncovered:
        print(f"UNCOVERED {', '.join(uncovered)}", flush=True)

    for _ in range(cases):
        if rng.random() < 0.5:
            entry = sorted(entries)[rng.integers(len(entries))]
            fn, makers = entries[entry]
            args = draw(makers)
            call(entry, fn, vary(entry, args, None, 0.9, entry))
            continue
        cname = sorted(classes)[rng.integers(len(classes))]
        cls, makers = classes[cname]
        from_extremes = cname in extremes and rng.random() < 0.25
        if from_extremes:
            obj, _ = call(cname, cls, extremes[cname](None))
        else:
            args = draw(makers)
            obj, _ = call(cname, cls, mutate(args, cname) if rng.random() < 0.5 else args)
        if obj is None:
            continue
        names = [n for n in dir(obj) if not n.startswith("_")]
        for _ in range(6):
            name = names[rng.integers(len(names))]
            attr = getattr(type(obj), name, None)
            entry = f"{cname}.{name}"
            if isinstance(attr, property) or type(attr).__name__ == "getset_descriptor":
                call(entry, lambda: getattr(obj, name), {})
                continue
            fn = getattr(obj, name)
            if not callable(fn):
                continue
            try:
                params = list(inspect.signature(fn).parameters)
            except (TypeError, ValueError):
                params = []  # listed in the SKIPPED line
            table = class_methods.get((cname, name), methods.get(name, {}))
            margs = {}
            for p in params:
                if p in ("args", "kwargs", "params"):
                    continue
                if p == "other":
                    margs[p] = partner(cname, cls, obj, from_extremes)
                elif p == "mag" and rng.random() < 0.9 and (
                    obj.sensors == "6d" or obj.sensors is None and rng.random() < 0.5
                ):
                    continue  # no magnetometer for a 6D filter (but now and then one)
                elif p in table and table[p] is not None:
                    value = table[p]()
                    if value is not omit:
                        margs[p] = value
            before = state(obj)
            margs = vary(entry, margs, obj, 0.8)
            _, err = call(entry, fn, margs)
            if err is not None and name in ("update", "predict", "update_batch") and state(obj) != before:
                report("state-changed", entry, margs, f"{type(err).__name__}: {err}")
    print(f"DONE {cases} cases, {findings} findings", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--timeout", type=float, default=60.0,
        help="seconds without progress reported as a hang; 0 waits for ever (for tests, whose "
        "verdict must not depend on the machine's speed)",
    )
    args = parser.parse_args()
    if os.environ.get("LIEBAYES_FUZZ_CHILD"):
        child(args.cases, args.seed)
        return 0
    seed, findings, crashes, shown = args.seed, 0, 0, set()
    remaining = args.cases
    while remaining > 0:
        env = dict(os.environ, LIEBAYES_FUZZ_CHILD="1")
        proc = subprocess.Popen(
            [sys.executable, __file__, "--cases", str(remaining), "--seed", str(seed)],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
        )
        last, count, stamp = "", 0, time.monotonic()
        import selectors

        sel = selectors.DefaultSelector()
        sel.register(proc.stdout, selectors.EVENT_READ)
        done = False
        while True:
            if not sel.select(timeout=args.timeout or None):
                print(f"HANG after {args.timeout} s in {last}")
                proc.kill()
                findings += 1
                break
            line = proc.stdout.readline()
            if not line:
                break
            if line.startswith("CALL "):
                last, count = line[5:].strip(), count + 1
            elif line.startswith("DONE"):
                done = True
            elif line.startswith(("SKIPPED", "UNCOVERED")):
                # The child's coverage lines, once however often the child is restarted.
                if line not in shown:
                    shown.add(line)
                    print(line, end="")
            else:
                print(line, end="")
                findings += line.startswith("FINDING")
        proc.wait()
        if done:
            break
        if proc.returncode not in (0, None):
            print(f"CRASH (exit {proc.returncode}) in {last}")
            crashes += 1
            findings += 1
        remaining -= max(count // 2, 1)
        seed += 1000
    print(f"{args.cases} cases: {findings} findings ({crashes} crashes)")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
