"""The input contract at its edges: Ctrl-C during a call without the GIL, memory the system cannot
give, integers out of range or given as bools, score ranges, shapes checked before a copy, bools
inside lists, messages that name the argument, and a filter used by two threads at once."""

import os
import resource
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import liebayes.attitude as att
import liebayes.densities as ld
import liebayes.filters as lf
import liebayes.manifolds as lm

GEN = np.random.default_rng(0)


def run_python(code, env=None, timeout=120):
    """Runs `code` in a fresh interpreter; returns (exit code, stdout, stderr)."""
    run = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=dict(os.environ, **(env or {})),
        check=False,
    )
    return run.returncode, run.stdout, run.stderr


# ---------------------------------------------------------------------------------------------
# Ctrl-C during a call that released the GIL.

# Each script first installs Python's own Ctrl-C handler: a shell starts a background job with
# SIGINT ignored, and Python leaves an ignored SIGINT ignored, so a suite run that way would see no
# Ctrl-C at all.
SIGINT_DURING = """
import os, signal, threading, time
signal.signal(signal.SIGINT, signal.default_int_handler)
import numpy as np
import liebayes.densities as D
import liebayes.filters as F
threading.Timer(0.05, lambda: os.kill(os.getpid(), signal.SIGINT)).start()   # = Ctrl-C
try:
    {call}
    time.sleep(3)   # the signal arrives during the call, or here at the latest
    print("no interrupt")
except KeyboardInterrupt:
    print("KeyboardInterrupt")
except BaseException as e:
    print("raised", type(e).__name__, str(e)[:200])
"""


@pytest.mark.parametrize(
    "call, env",
    [
        ("D.VonMises(0.0, 1.0).sample(20_000_000, np.random.default_rng(0))", {}),
        (
            'F.azimuth_study("circle", ["PF 2000"], 20, duration=100.0)',
            {"RAYON_NUM_THREADS": "1"},
        ),
    ],
    ids=["sample", "study"],
)
def test_ctrl_c_during_a_call_without_the_gil_raises_keyboard_interrupt(call, env):
    # The first liebayes call of a fresh interpreter: numpy's C API used to be loaded right after
    # the GIL-released section, where the pending Ctrl-C made it panic (PanicException).
    code, out, err = run_python(SIGINT_DURING.format(call=call), env=env)
    assert "PanicException" not in out + err and "panicked" not in err, out + err
    assert out.strip() == "KeyboardInterrupt", out + err
    assert code == 0, err


INTERRUPTED_BATCH = """
import os, signal, threading
signal.signal(signal.SIGINT, signal.default_int_handler)
import numpy as np
import liebayes.attitude as A
import liebayes.densities as D
import liebayes.filters as F
n = 4_000_000
f = A.AttitudeFilter(0.01)
f.update([0, 0, 0], [0, 0, 9.81])
before = f.quat.copy()
calls = {
    "batch": lambda: f.update_batch(np.zeros((n, 3)), np.tile([0, 0, 9.81], (n, 1))),
    "study": lambda: F.azimuth_study("circle", ["PF 500"], 400, duration=100.0),
    "sample": lambda: D.Bingham(np.eye(4), [0, -1.0, -2.0, -3.0]).sample(
        10_000_000, np.random.default_rng(0)),
}
for name, call in calls.items():
    returned = threading.Event()
    threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    try:
        call()
        returned.set()
        threading.Event().wait(2)
        print(name, "no interrupt")
    except KeyboardInterrupt:
        print(name, "interrupted", "after the call" if returned.is_set() else "during the call")
print("unchanged", bool(np.array_equal(f.quat, before)), f.sensors)
"""


def test_ctrl_c_stops_a_long_call_before_it_ends_and_keeps_nothing():
    # Each call takes seconds (a batch of 4e6 steps, a study of 400 runs, 1e7 draws), and Ctrl-C
    # comes 0.3 s in: the call is stopped (every 65536 steps, or between shards of a study, it
    # checks for a signal) and raises KeyboardInterrupt, keeping nothing of its work.
    code, out, err = run_python(INTERRUPTED_BATCH)
    assert code == 0, err
    lines = out.strip().splitlines()
    assert lines == [
        "batch interrupted during the call",
        "study interrupted during the call",
        "sample interrupted during the call",
        "unchanged True 6d",
    ], out


def test_a_study_run_shard_by_shard_equals_the_scored_runs():
    # Enough runs for several shards (a study runs shard after shard, to stop on Ctrl-C between
    # two): the merged summary is the whole study's, the scores of the same runs.
    n, settings = 70, dict(duration=10.0, measure_every=5)
    runs = lf.azimuth_runs("line", n, seed=5, **settings)
    measured = runs["measured"]
    est = {k: [] for k in ("azimuth", "rho", "circular_variance", "mean_r", "cov_r")}
    for r in range(n):
        out = lf.ExactAzimuthFilter(0.1, 1.0).run(runs["velocity"][r], runs["dt"], runs["z"][r])
        for k in est:
            est[k].append(out[k][measured])
    est = {k: np.array(v) for k, v in est.items()}
    mine = lf.score_azimuth(
        runs["truth_r"][:, measured], runs["truth_azimuth"], est["azimuth"], est["rho"],
        est["mean_r"], est["cov_r"], circular_variance=est["circular_variance"],
        times=runs["time"][measured],
    )
    study = lf.azimuth_study("line", ["exact"], n, seed=5, **settings)["exact"]
    assert study["runs"] == n and study["failures"] == {}
    for name in ("x_error", "y_error", "x_sigma", "y_sigma", "nees_position"):
        np.testing.assert_array_equal(mine["metrics"][name], study["metrics"][name], name)
        np.testing.assert_array_equal(mine["counts"][name], study["counts"][name], name)
    for name in ("azimuth_error", "azimuth_sigma"):
        np.testing.assert_allclose(
            mine["metrics"][name], study["metrics"][name], rtol=1e-12, atol=1e-12, err_msg=name
        )


# ---------------------------------------------------------------------------------------------
# Sizes beyond the documented limits, and memory the system cannot give.


def test_sizes_beyond_the_limits_are_refused_before_any_work():
    # Zero-stride inputs cost nothing to make; refused on their shape alone, without a copy.
    n = 2**24 + 1
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(ValueError, match=r"update_batch: 16777217 samples, at most 16777216"):
        att.AttitudeFilter(0.01).update_batch(
            np.broadcast_to(np.zeros(3), (n, 3)), np.broadcast_to([0, 0, 9.81], (n, 3))
        )
    m = 2**24 + 1
    with pytest.raises(ValueError, match=r"offline_attitude: 16777217 samples, at most 16777216"):
        att.offline_attitude(
            np.broadcast_to(np.zeros(3), (m, 3)), np.broadcast_to([0, 0, 9.81], (m, 3)), dt=0.01
        )
    f = lf.ExactAzimuthFilter(0.1, 1.0)
    before = f.estimate
    with pytest.raises(ValueError, match=r"velocity: 16777217 steps; at most 16777216"):
        f.run(np.broadcast_to(np.zeros(2), (m, 2)), 0.01, np.broadcast_to([np.nan] * 2, (m, 2)))
    assert repr(f.estimate) == repr(before)
    # No copy was made: a copy of the first input alone would take 6.4 GB (ru_maxrss is in KiB).
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - peak < 512 * 1024


ABORT_UNDER_LIMIT = """
import resource
import numpy as np
import liebayes.attitude as A
import liebayes.filters as F
# 1.2 GB of address space beyond what the interpreter already holds: room for the inputs' copies,
# not for the results of 2^24 samples or steps.
with open("/proc/self/status") as status:
    held = next(int(line.split()[1]) for line in status if line.startswith("VmSize:")) * 1024
limit = held + 1_200_000_000
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
n = 2**24
def batch():
    A.AttitudeFilter(0.01).update_batch(np.broadcast_to(np.zeros(3), (n, 3)),
                                        np.broadcast_to([0, 0, 9.81], (n, 3)))
def run():
    F.ExactAzimuthFilter(0.1, 1.0).run(np.broadcast_to(np.zeros(2), (n, 2)), 0.01,
                                       np.broadcast_to([np.nan, np.nan], (n, 2)))
def offline():
    A.offline_attitude(np.broadcast_to(np.zeros(3), (n, 3)),
                       np.broadcast_to([0, 0, 9.81], (n, 3)), dt=0.01)
for call in (batch, run, offline):
    try:
        call()
        print(call.__name__, "ran")
    except (ValueError, MemoryError) as e:
        print(call.__name__, type(e).__name__, str(e)[:300])
"""


@pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_AS as Linux counts it")
def test_memory_the_system_cannot_give_raises_instead_of_aborting():
    code, out, err = run_python(
        ABORT_UNDER_LIMIT, env={"RAYON_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    )
    assert code == 0, f"exit {code}: {out}{err[-2000:]}"
    assert "memory allocation" not in err, err[-2000:]
    lines = out.strip().splitlines()
    assert [line.split()[0] for line in lines] == ["batch", "run", "offline"], out
    for line in lines:
        # The results' (or the steps') reservation fails, as a ValueError saying so; numpy's own
        # copy of the inputs may fail first, as numpy's MemoryError.
        assert line.split()[1] in ("ValueError", "MemoryError", "ran"), line
        if line.split()[1] == "ValueError":
            assert "do not fit in memory" in line, line


# ---------------------------------------------------------------------------------------------
# Integers: out of range is a ValueError naming the argument; a bool is a TypeError.

ROT = np.eye(3)


def test_out_of_range_integers_raise_value_error_naming_the_argument():
    cases = [
        ("runs", lambda: lf.azimuth_runs("circle", -1)),
        ("seed", lambda: lf.azimuth_runs("circle", 1, -1)),
        ("seed", lambda: lf.azimuth_runs("circle", 1, 2**64)),
        ("start", lambda: lf.aoa_runs("model1", 1, start=-(2**70))),
        ("particles", lambda: lf.AoaFilter("PF-VMF", np.eye(3), kappa=50.0, particles=2**64)),
        ("seed", lambda: lf.AoaFilter("PF-VMF", np.eye(3), kappa=50.0, seed=10**400)),
        ("n", lambda: ld.VonMises(0, 1).sample(2**64, GEN)),
        ("n", lambda: ld.VonMises(0, 1).sample(-1, GEN)),
        ("runs", lambda: lf.azimuth_study("circle", ["exact"], 2**64)),
        ("measure_every", lambda: lf.azimuth_study("circle", ["exact"], 1, measure_every=-3)),
        ("steps", lambda: lf.aoa_study("model1", ["EKF-VMF"], 1, steps=-1)),
        ("fit_samples", lambda: lf.aoa_study("model1", ["EKF-AE-fitted"], 1, fit_samples=-1)),
    ]
    for name, call in cases:
        with pytest.raises(ValueError, match=rf"^{name}\b") as info:
            call()
        assert not isinstance(info.value, OverflowError)
    # A float beyond the float range, given as an int, is a value out of range too.
    with pytest.raises(ValueError, match="kappa: the integer is beyond the range of a float"):
        ld.VonMises(0, 10**400)
    with pytest.raises(ValueError, match="sigma_m: the integer is beyond the range of a float"):
        lf.ExactAzimuthFilter(0.1, -(10**400))
    # numpy integers are integers.
    assert ld.VonMises(0, 1).sample(np.int64(3), GEN).shape == (3,)
    assert lf.azimuth_runs("static", np.uint8(1), np.int32(4), duration=1.0)["seed"] == 4


BOOL_SLOTS = [
    *[
        (f"{cls}.sample n", lambda d=d: d.sample(True, GEN))
        for cls, d in [
            ("VonMises", ld.VonMises(0, 1)),
            ("VonMisesFisher", ld.VonMisesFisher([0, 0, 1.0], 1.0)),
            ("Bingham", ld.Bingham(np.eye(4), [0, -1.0, -2.0, -3.0])),
            ("HeatKernelSo3", ld.HeatKernelSo3(ROT, 0.1)),
            ("ManifoldGaussianSo3", ld.ManifoldGaussianSo3(ROT, 0.01 * np.eye(3))),
            ("ManifoldGaussianS2", ld.ManifoldGaussianS2([0, 0, 1.0], 0.01 * np.eye(2))),
        ]
    ],
    ("AoaFilter particles", lambda: lf.AoaFilter("PF-VMF", np.eye(3), kappa=50.0, particles=True)),
    ("AoaFilter seed", lambda: lf.AoaFilter("PF-VMF", np.eye(3), kappa=50.0, seed=False)),
    ("azimuth_study runs", lambda: lf.azimuth_study("circle", ["exact"], True)),
    ("azimuth_study seed", lambda: lf.azimuth_study("circle", ["exact"], 1, True)),
    ("azimuth_study measure_every", lambda: lf.azimuth_study("circle", ["exact"], 1, measure_every=True)),
    ("azimuth_runs runs", lambda: lf.azimuth_runs("circle", True)),
    ("azimuth_runs seed", lambda: lf.azimuth_runs("circle", 1, False)),
    ("azimuth_runs start", lambda: lf.azimuth_runs("circle", 1, start=True)),
    ("azimuth_runs measure_every", lambda: lf.azimuth_runs("circle", 1, measure_every=True)),
    ("aoa_study runs", lambda: lf.aoa_study("model1", ["EKF-VMF"], True)),
    ("aoa_study seed", lambda: lf.aoa_study("model1", ["EKF-VMF"], 1, True)),
    ("aoa_study particles", lambda: lf.aoa_study("model1", ["EKF-VMF"], 1, particles=True)),
    ("aoa_study steps", lambda: lf.aoa_study("model1", ["EKF-VMF"], 1, steps=True)),
    ("aoa_study fit_samples", lambda: lf.aoa_study("model1", ["EKF-VMF"], 1, fit_samples=True)),
    ("aoa_runs runs", lambda: lf.aoa_runs("model1", True)),
    ("aoa_runs seed", lambda: lf.aoa_runs("model1", 1, np.True_)),
    ("aoa_runs start", lambda: lf.aoa_runs("model1", 1, start=True)),
    ("aoa_runs steps", lambda: lf.aoa_runs("model1", 1, steps=True)),
]


@pytest.mark.parametrize("slot, call", BOOL_SLOTS, ids=[s for s, _ in BOOL_SLOTS])
def test_integer_arguments_refuse_bools(slot, call):
    # The audit's list of slots (it counts 23; listed one by one they are 24).
    assert len(BOOL_SLOTS) == 24
    name = slot.split()[-1]
    with pytest.raises(TypeError, match=rf"^{name}: expected an integer, got the bool"):
        call()


def test_attitude_flags_take_bools_only():
    for flag in ("estimate_bias", "rest_detection", "mag_offset", "mag_disturbance_rejection"):
        att.AttitudeFilter(0.01, **{flag: True})
        att.AttitudeFilter(0.01, **{flag: np.False_})
        for wrong in (1, None, "yes", 0.0):
            with pytest.raises(TypeError, match=f"{flag} must be True or False"):
                att.AttitudeFilter(0.01, **{flag: wrong})
    with pytest.raises(TypeError, match="propagation"):
        att.AttitudeFilter(0.01, propagation=1)
    with pytest.raises(ValueError, match="propagation"):
        att.AttitudeFilter(0.01, propagation="kalman")


# ---------------------------------------------------------------------------------------------
# Scores: the documented ranges, no silent NaN.


def score_args():
    rng = np.random.default_rng(0)
    r, e = 2, 3
    return dict(
        truth_r=rng.normal(size=(r, e, 2)),
        truth_azimuth=rng.normal(size=r),
        azimuth=rng.normal(size=(r, e)),
        rho=np.full((r, e), 0.5),
        mean_r=rng.normal(size=(r, e, 2)),
        cov_r=np.broadcast_to(np.eye(2), (r, e, 2, 2)).copy(),
    )


def test_score_azimuth_enforces_rho_circular_variance_and_times():
    a = score_args()
    good = lf.score_azimuth(**a)
    assert np.all(np.isfinite(good["metrics"]["azimuth_sigma"]))
    for bad in (2.0, -1.0, 1.0 + 1e-12):
        rho = a["rho"].copy()
        rho[1, 2] = bad
        with pytest.raises(ValueError, match=r"^rho\[1, 2\]: .* mean resultant length in \[0, 1\]"):
            lf.score_azimuth(**{**a, "rho": rho})
    for bad in (np.nan, -5.0, -np.inf):
        cv = np.full((2, 3), 0.3)
        cv[0, 1] = bad
        with pytest.raises(ValueError, match=r"^circular_variance\[0, 1\]"):
            lf.score_azimuth(**a, circular_variance=cv)
    # inf is the circular variance of a uniform estimate.
    lf.score_azimuth(**{**a, "rho": np.zeros((2, 3))}, circular_variance=np.full((2, 3), np.inf))
    with pytest.raises(ValueError, match=r"^times\[0\] is NaN"):
        lf.score_azimuth(**a, times=np.array([np.nan, 1, 2]))
    with pytest.raises(ValueError, match=r"^times\[2\] is 1, not after times\[1\]"):
        lf.score_azimuth(**a, times=np.array([0.0, 1, 1]))
    with pytest.raises(ValueError, match=r"^times\[1\] is inf"):
        lf.score_aoa(np.zeros((1, 2, 3)), np.zeros((1, 2, 3)),
                     np.broadcast_to(np.eye(3), (1, 2, 3, 3)), times=[0.0, np.inf])


# ---------------------------------------------------------------------------------------------
# Arrays: shapes before copies, bools inside lists, messages naming the argument.


def test_a_wrong_shape_is_refused_before_the_array_is_copied():
    code, out, err = run_python("""
        import resource
        import numpy as np
        import liebayes.manifolds as M
        import liebayes.attitude as A
        import liebayes.filters as F
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        bad = np.broadcast_to(np.zeros(4), (2**24, 3, 4))    # 1.5 GB once copied
        for call in (lambda: M.So3.log(bad),
                     lambda: A.AttitudeFilter(0.01).update_batch(bad, bad),
                     lambda: F.score_aoa(bad, bad, bad)):
            try:
                call()
            except ValueError as e:
                print(str(e)[:80])
        print("grew", (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) // 1024)
    """)
    assert code == 0, err
    lines = out.strip().splitlines()
    assert lines[0].startswith("r: expected shape (3, 3)"), out
    assert lines[1].startswith("update_batch: gyr has shape"), out
    assert lines[2].startswith("truth: expected an array of shape"), out
    assert int(lines[-1].split()[1]) < 200, out   # MB of peak memory


def test_a_bool_inside_a_list_is_refused_like_update_does():
    with pytest.raises(TypeError, match=r"^omega: expected real numbers, got the bool True"):
        lm.So3.exp([True, False, 0])
    with pytest.raises(TypeError, match=r"^x: .*bool"):
        ld.VonMises(0, 1).log_pdf([True, 0.5])
    with pytest.raises(TypeError, match=r"^x: .*bool"):
        ld.VonMises(0, 1).log_pdf([[0.1, 0.2], [np.True_, 0.5]])
    with pytest.raises(TypeError, match=r"^gyr: .*bool"):
        att.AttitudeFilter(0.01).update_batch([[True, 0, 0]], [[0, 0, 9.81]])
    with pytest.raises(TypeError, match=r"^velocity: .*bool"):
        lf.ExactAzimuthFilter(0.1, 1.0).run([[True, 0]], 0.1, [[0.0, 0.0]])
    with pytest.raises(TypeError, match=r"^gyr\[0\]: .*bool"):
        att.AttitudeFilter(0.01).update([True, 0, 0], [0, 0, 9.81])
    # Numbers in lists are still read as before.
    assert np.allclose(lm.So3.exp([1, 0, 0.0]), lm.So3.exp(np.array([1.0, 0, 0])))


def test_a_masked_array_with_masked_values_is_refused():
    # numpy hands over a masked array's data with the masked values in it: read as numbers, a
    # masked reading of 1e300 would have been a rotation of 1e300 rad.
    masked = np.ma.masked_array([1e300, 0.0, 0.0], mask=[True, False, False])
    with pytest.raises(TypeError, match=r"^omega: a masked array with masked values"):
        lm.So3.exp(masked)
    with pytest.raises(TypeError, match=r"^gyr: a masked array"):
        att.AttitudeFilter(0.01).update_batch(
            np.ma.masked_array(np.zeros((2, 3)), mask=[[0, 0, 0], [1, 0, 0]]), np.ones((2, 3))
        )
    # One that masks nothing is read as its data.
    clear = np.ma.masked_array([0.1, 0.2, 0.3], mask=False)
    assert np.allclose(lm.So3.exp(clear), lm.So3.exp(np.array([0.1, 0.2, 0.3])))


def test_messages_name_the_argument_and_the_call():
    with pytest.raises(ValueError, match=r"^offline_attitude: acc has shape \[4, 3\], expected \(5, 3\)"):
        att.offline_attitude(np.zeros((5, 3)), np.zeros((4, 3)), dt=0.01)
    with pytest.raises(ValueError, match=r"^offline_attitude: gyr has shape \[\]"):
        att.offline_attitude(np.float64(0.0), np.zeros((4, 3)), dt=0.01)
    for data in ("model1", "model2"):
        for bad in (0.0, -10.0, 1e-300, np.nan, 1e300):
            with pytest.raises(ValueError, match=r"^sigma_deg is"):
                lf.aoa_runs(data, 1, sigma_deg=bad)
    with pytest.raises(ValueError, match=r"^sigma_deg is"):
        lf.aoa_study("model2", ["EKF-VMF"], 1, sigma_deg=1e-300)
    with pytest.raises(TypeError, match=r"^r0: expected an array of real numbers"):
        lf.ExactAzimuthFilter(0.1, 1.0, r0="ab")
    with pytest.raises(TypeError, match=r"^kappa: expected a real number"):
        ld.VonMises(0.0, True)
    with pytest.raises(ValueError, match=r"^x: could not read it as an array of numbers"):
        ld.VonMises(0, 1).log_pdf([[0.1, 0.2], [0.3]])
    with pytest.raises(TypeError, match=r"^omega: .*integer beyond 64 bits"):
        lm.So3.exp([0.1, 0, 2**64])


def test_an_empty_batch_decides_nothing():
    f = att.AttitudeFilter(0.01)
    out = f.update_batch(np.zeros((0, 3)), np.zeros((0, 3)))
    assert out["quat"].shape == (0, 4) and out["bias"].shape == (0, 3)
    assert f.sensors is None
    rng = np.random.default_rng(1)
    n = 20
    gyr = rng.normal(size=(n, 3)) * 0.01
    acc = np.tile([0, 0, 9.81], (n, 1))
    mag = np.tile([0, 20.0, -40.0], (n, 1))
    f.update_batch(gyr, acc, mag)
    assert f.sensors == "9d"


# ---------------------------------------------------------------------------------------------
# One filter, two threads.


def test_a_filter_in_use_by_another_thread_raises_a_value_error():
    n = 3_000_000
    f = att.AttitudeFilter(0.01)
    f.update([0, 0, 0], [0, 0, 9.81])
    gyr, acc = np.zeros((n, 3)), np.tile([0, 0, 9.81], (n, 1))
    t = threading.Thread(target=f.update_batch, args=(gyr, acc))
    t.start()
    time.sleep(0.3)
    busy = t.is_alive()
    refused = []
    for call in (lambda: f.update_batch(gyr[:5], acc[:5]),
                 lambda: f.update([0, 0, 0], [0, 0, 9.81]),
                 f.reset):
        try:
            call()
        except ValueError as e:
            refused.append(str(e))
    still_busy = t.is_alive()
    t.join()
    if not (busy and still_busy):
        pytest.skip("the batch ended before the other calls")
    assert len(refused) == 3, refused
    for message in refused:
        assert message.startswith("AttitudeFilter: this filter is in use by another call"), message
    # The batch's own result is kept: the refused calls changed nothing.
    assert f.sensors == "6d"


# ---------------------------------------------------------------------------------------------
# Long parts of calls without the GIL.


def test_particle_drawing_and_a_fit_release_the_gil():
    # While the main thread is in a long Rust call (a few hundred ms or more), another thread
    # wakes every millisecond and counts: it can run only while the call has released the GIL.
    # With the GIL held it would count at most a step or two, before the call and after it.
    angles = np.random.default_rng(2).vonmises(0.3, 2.0, size=8_000_000)
    calls = {
        "AoaFilter particles": lambda: lf.AoaFilter(
            "PF-VMF", np.eye(3), kappa=50.0, particles=8_000_000),
        "VonMises.fit": lambda: ld.VonMises.fit(angles),
    }
    for name, call in calls.items():
        returned, steps = threading.Event(), [0]

        def other():
            while not returned.wait(0.001):
                steps[0] += 1

        t = threading.Thread(target=other)
        t.start()
        call()
        returned.set()
        t.join()
        assert steps[0] >= 20, f"{name}: {steps[0]} steps of the other thread during the call"


def test_a_studys_filter_settings_are_checked_as_every_azimuth_filter_checks_them():
    # A filter's sigma0 of 1e-100 passed the exact density's wider check and then failed every run
    # of the Gaussian filters; it is refused before any run, naming the setting.
    for name, value in (("filter_sigma0", 1e-100), ("filter_sigma_m", 1e60), ("filter_q", 1e60)):
        with pytest.raises(ValueError, match=r"sigma_0|sigma_m|q \(m/sqrt\(s\)\)"):
            lf.azimuth_study("circle", ["EKF"], 2, duration=2.0, **{name: value})
