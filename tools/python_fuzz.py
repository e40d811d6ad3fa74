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
valid huge count is hours of work, not a finding). Instances are built from a fuzzed constructor call when it succeeds, then every
method and property is fuzzed on them; a refused call to a stateful filter must leave its state
as it was.

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

    # name -> (callable, {argument: valid value maker}); instances' methods below.
    so3 = {"omega": vec, "r": rot, "a": rot, "b": rot, "v": vec, "q": quat, "m": rot}
    quaternion = {"omega": vec, "q": quat, "p": quat, "v": vec, "r": rot}
    s2 = {"x": unit, "y": unit, "w": vec, "u": lambda: vec(2), "v": vec}
    se3 = {
        "xi": lambda: vec(6), "x": pose, "a": pose, "b": pose, "p": vec,
        "r": rot, "t": vec, "m": pose,
    }
    entries = {}
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
        }),
        "aoa_runs": (filters.aoa_runs, {
            "data": lambda: str(rng.choice(["model1", "model2"])), "runs": lambda: 2,
            "seed": lambda: 3, "start": lambda: 1, "steps": lambda: 4, "sigma_deg": lambda: 10.0,
        }),
        "azimuth_study": (filters.azimuth_study, {
            "scenario": lambda: str(rng.choice(["static", "circle", "line"])),
            "methods": lambda: [str(rng.choice(["exact", "EKF", "UKF"]))], "runs": lambda: 2,
            "seed": lambda: 3, "duration": lambda: 5.0, "measure_every": lambda: 5,
        }),
        "aoa_study": (filters.aoa_study, {
            "data": lambda: str(rng.choice(["model1", "model2"])),
            "filters": lambda: [str(rng.choice(["EKF-VMF", "UKF-AE", "EKF-AE-adaptive", "IEKF-VMF"]))],
            "runs": lambda: 2, "seed": lambda: 3, "steps": lambda: 4, "sigma_deg": lambda: 10.0,
        }),
        "square_track": (filters.square_track, {}),
        "offline_attitude": (attitude.offline_attitude, {
            "gyr": lambda: rng.normal(size=(50, 3)) * 0.1,
            "acc": lambda: np.tile([0, 0, 9.81], (50, 1)) + rng.normal(size=(50, 3)) * 0.1,
            "dt": lambda: 0.01,
        }),
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
        "ExactAzimuthFilter": (filters.ExactAzimuthFilter, {"q": lambda: 0.1, "sigma_m": lambda: 1.0}),
        "AoaFilter": (filters.AoaFilter, {
            "name": lambda: str(rng.choice(["EKF-VMF", "UKF-AE", "PF-VMF", "EKF-AE-adaptive", "IEKF-VMF", "IEKF-AE"])),
            "anchors": lambda: rng.normal(size=(3, 3)) * 5, "kappa": lambda: 50.0,
            "sigma_az": lambda: 0.1, "sigma_el": lambda: 0.1, "particles": lambda: 200,
        }),
        "AttitudeFilter": (attitude.AttitudeFilter, {"dt": lambda: 0.01}),
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
            "gyr": lambda: vec(3, 0.1), "acc": lambda: np.array([0, 0, 9.81]), "mag": None,
        },
        "update_batch": {
            "gyr": lambda: rng.normal(size=(20, 3)) * 0.1,
            "acc": lambda: np.tile([0, 0, 9.81], (20, 1)) + rng.normal(size=(20, 3)) * 0.1,
            "mag": None,
        },
        "run": {"velocity": lambda: rng.normal(size=(5, 2)), "dt": lambda: 0.1, "z": lambda: rng.normal(size=(5, 2))},
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
            return [s, "", "x" * 1000, "nonsense", None][rng.integers(5)]
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
        return {k: m() for k, m in makers.items() if m is not None}

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

    def state(obj):
        out = []
        for name in ("natural", "mean", "covariance", "estimate", "quat", "bias"):
            try:
                out.append(repr(getattr(obj, name)))
            except Exception:  # noqa: BLE001
                pass
        return out

    for _ in range(cases):
        if rng.random() < 0.5:
            entry = sorted(entries)[rng.integers(len(entries))]
            fn, makers = entries[entry]
            args = draw(makers)
            call(entry, fn, mutate(args, entry) if rng.random() < 0.9 else args)
            continue
        cname = sorted(classes)[rng.integers(len(classes))]
        cls, makers = classes[cname]
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
                params = []
            table = methods.get(name, {})
            margs = {}
            for p in params:
                if p in ("args", "kwargs", "params"):
                    continue
                if p == "other":
                    margs[p] = obj
                elif p in table and table[p] is not None:
                    margs[p] = table[p]()
            before = state(obj)
            _, err = call(entry, fn, mutate(margs) if rng.random() < 0.8 else margs)
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
    seed, findings, crashes = args.seed, 0, 0
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
