"""The attitude filter's Python API: equal to the Rust binary bit for bit, streaming equal to
batch, all-or-nothing batches, bad input raising, and no copy per element."""

import csv
import pathlib
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import liebayes.attitude as att


def read_estimates(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["t", "w", "x", "y", "z"]
    return np.array([[float(v) for v in row[1:]] for row in rows[1:]])


@pytest.fixture(scope="module")
def log(broad_trial):
    return att.read_broad(broad_trial)


def test_read_broad_arrays(log):
    n = log["gyr"].shape[0]
    assert n > 10_000 and log["rate"] == pytest.approx(285.714, abs=1e-3)
    for key in ("gyr", "acc", "mag"):
        assert log[key].shape == (n, 3) and log[key].dtype == np.float64
    assert log["quat"].shape == (n, 4) and log["movement"].shape == (n,)
    known = ~np.isnan(log["quat"][:, 0])
    assert known.sum() > n // 2
    np.testing.assert_allclose(np.linalg.norm(log["quat"][known], axis=1), 1.0, atol=1e-9)


def run_binary(liebayes_bin, broad_trial, tmp_path, *flags):
    """`liebayes attitude --broad` on the one trial with `flags`; the estimates' folder."""
    trials = tmp_path / "trials"
    trials.mkdir()
    (trials / broad_trial.name).symlink_to(broad_trial)
    out = tmp_path / "out"
    subprocess.run(
        [liebayes_bin, "attitude", "--broad", str(trials), *flags, "--out", str(out)],
        check=True, capture_output=True,
    )
    return out


def test_batch_equals_binary_bit_for_bit(log, broad_trial, liebayes_bin, tmp_path):
    out = run_binary(liebayes_bin, broad_trial, tmp_path, "--method", "ekf-9d", "--method", "ekf-6d")
    stem = broad_trial.stem
    nine = att.AttitudeFilter(rate=log["rate"]).update_batch(log["gyr"], log["acc"], log["mag"])
    six = att.AttitudeFilter(rate=log["rate"]).update_batch(log["gyr"], log["acc"])
    for ours, name in ((nine, "ekf-9d"), (six, "ekf-6d")):
        theirs = read_estimates(out / f"{stem}.{name}.csv")
        assert theirs.shape == ours["quat"].shape
        # Bit for bit: the CSV holds each float's shortest round-trip text.
        assert np.array_equal(ours["quat"], theirs), name
    # The 6D and 9D runs differ (the test can tell filters apart).
    assert not np.array_equal(nine["quat"], six["quat"])


def test_offline_equals_binary_bit_for_bit(log, broad_trial, liebayes_bin, tmp_path):
    out = run_binary(liebayes_bin, broad_trial, tmp_path, "--offline")
    stem = broad_trial.stem
    nine = att.offline_attitude(log["gyr"], log["acc"], log["mag"], rate=log["rate"])
    six = att.offline_attitude(log["gyr"], log["acc"], rate=log["rate"])
    for ours, name in ((nine, "ekf-offline-9d"), (six, "ekf-offline-6d")):
        theirs = read_estimates(out / f"{stem}.{name}.csv")
        assert np.array_equal(ours["quat"], theirs), name
    n = log["gyr"].shape[0]
    assert nine["heading_sigma"].shape == (n,) and np.all(nine["tilt_sigma"] > 0)
    # The smoothed estimate is not the filter's.
    causal = att.AttitudeFilter(rate=log["rate"]).update_batch(log["gyr"], log["acc"], log["mag"])
    assert not np.array_equal(causal["quat"], nine["quat"])


def test_offline_refuses_bad_input(log):
    gyr = log["gyr"][:2000].copy()
    gyr[123, 0] = 1e200
    with pytest.raises(ValueError, match="sample 123"):
        att.offline_attitude(gyr, log["acc"][:2000], log["mag"][:2000], rate=log["rate"])
    with pytest.raises(ValueError, match="dt"):
        att.offline_attitude(log["gyr"], log["acc"], dt=-1.0)
    with pytest.raises(ValueError):
        att.offline_attitude(log["gyr"], log["acc"], rate=log["rate"], gyro_noise=-1.0)
    assert att.offline_default_params()["gyro_noise"] == pytest.approx(1e-4)


def test_offline_defaults_passed_back_change_nothing(log):
    # A flag that switches a part on (the field offset) takes the offline settings' own values
    # (σ_c 4°), not the causal filter's (1°).
    n = 3000
    gyr, acc, mag = log["gyr"][:n], log["acc"][:n], log["mag"][:n]
    plain = att.offline_attitude(gyr, acc, mag, rate=log["rate"])
    again = att.offline_attitude(gyr, acc, mag, rate=log["rate"], **att.offline_default_params())
    assert np.array_equal(plain["quat"], again["quat"])
    assert np.array_equal(plain["heading_sigma"], again["heading_sigma"])


def test_outputs_and_accuracy(log):
    out = att.AttitudeFilter(rate=log["rate"]).update_batch(log["gyr"], log["acc"], log["mag"])
    n = log["gyr"].shape[0]
    assert out["quat"].shape == (n, 4) and out["bias"].shape == (n, 3)
    assert out["rest"].dtype == np.bool_ and out["rest"].any()
    np.testing.assert_allclose(np.linalg.norm(out["quat"], axis=1), 1.0, atol=1e-12)
    assert np.all(out["heading_sigma"] > 0) and np.all(out["tilt_sigma"] > 0)
    # BROAD's total error over the movement samples: the filter tracks the reference (the Rust
    # tests hold its figure; this checks the arrays are the orientation, scalar first).
    ok = log["movement"] & ~np.isnan(log["quat"][:, 0])
    dot = np.abs(np.sum(out["quat"][ok] * log["quat"][ok], axis=1))
    rmse = np.degrees(np.sqrt(np.mean((2 * np.arccos(np.minimum(dot, 1.0))) ** 2)))
    assert 0.1 < rmse < 5.0
    # A vector-first reading of the same output is far off (the check can fail).
    swapped = np.roll(out["quat"], -1, axis=1)
    dot = np.abs(np.sum(swapped[ok] * log["quat"][ok], axis=1))
    assert np.degrees(np.sqrt(np.mean((2 * np.arccos(np.minimum(dot, 1.0))) ** 2))) > 20


def test_streaming_equals_batch(log):
    k = 2000
    batch = att.AttitudeFilter(rate=log["rate"]).update_batch(
        log["gyr"][:k], log["acc"][:k], log["mag"][:k])
    f = att.AttitudeFilter(rate=log["rate"])
    for i in range(k):
        f.update(log["gyr"][i], log["acc"][i], log["mag"][i])
    assert np.array_equal(f.quat, batch["quat"][-1])
    assert f.heading_sigma == batch["heading_sigma"][-1]
    assert np.array_equal(f.bias, batch["bias"][-1])
    # Two batches continue where the first stopped: equal to one.
    g = att.AttitudeFilter(rate=log["rate"])
    g.update_batch(log["gyr"][:k // 2], log["acc"][:k // 2], log["mag"][:k // 2])
    rest = g.update_batch(log["gyr"][k // 2:k], log["acc"][k // 2:k], log["mag"][k // 2:k])
    assert np.array_equal(rest["quat"], batch["quat"][k // 2:])


def test_refused_sample_leaves_the_filter_as_it_was(log):
    k = 1000
    f = att.AttitudeFilter(rate=log["rate"])
    f.update_batch(log["gyr"][:k], log["acc"][:k], log["mag"][:k])
    before = f.quat.copy()
    gyr = log["gyr"][k:2 * k].copy()
    gyr[123, 1] = np.nan
    with pytest.raises(ValueError, match="sample 123"):
        f.update_batch(gyr, log["acc"][k:2 * k], log["mag"][k:2 * k])
    assert np.array_equal(f.quat, before)
    gyr[123, 1] = 1e9  # beyond the gyroscope's range
    with pytest.raises(ValueError, match="sample 123"):
        f.update_batch(gyr, log["acc"][k:2 * k], log["mag"][k:2 * k])
    with pytest.raises(ValueError):
        f.update([0.0, np.inf, 0.0], [0.0, 0.0, 9.81], [20.0, 0.0, -40.0])
    assert np.array_equal(f.quat, before)
    # After the refusals the filter continues exactly as one that never saw them.
    fresh = att.AttitudeFilter(rate=log["rate"]).update_batch(
        log["gyr"][:2 * k], log["acc"][:2 * k], log["mag"][:2 * k])
    cont = f.update_batch(log["gyr"][k:2 * k], log["acc"][k:2 * k], log["mag"][k:2 * k])
    assert np.array_equal(cont["quat"], fresh["quat"][k:])


def test_a_refused_first_sample_decides_nothing():
    # The sensors were decided (6D without a magnetometer) before the step that failed: the filter
    # then refused every 9D sample.
    gyr, acc, mag = [0.01, -0.02, 0.03], [0.1, 0.2, 9.8], [20.0, 0.0, -40.0]
    refusals = (
        lambda f: f.update([float("nan"), 0.0, 0.0], [0.0, 0.0, 9.81]),
        lambda f: f.update_batch([[float("nan"), 0.0, 0.0]], [[0.0, 0.0, 9.81]]),
    )
    for refuse in refusals:
        f = att.AttitudeFilter(dt=0.01)
        with pytest.raises(ValueError):
            refuse(f)
        assert f.sensors is None
        f.update(gyr, acc, mag)
        fresh = att.AttitudeFilter(dt=0.01)
        fresh.update(gyr, acc, mag)
        assert f.sensors == fresh.sensors == "9d"
        np.testing.assert_array_equal(f.quat, fresh.quat)
        np.testing.assert_array_equal(f.covariance, fresh.covariance)
        np.testing.assert_array_equal(f.bias, fresh.bias)


def test_bools_and_complex_values_are_not_real_numbers():
    with pytest.raises(TypeError, match="real number"):
        att.AttitudeFilter(dt=True)
    with pytest.raises(TypeError, match="real number"):
        att.AttitudeFilter(rate=np.complex128(100.0 + 1j))
    with pytest.raises(TypeError, match="real number"):
        att.AttitudeFilter(dt=np.array([0.01]))
    with pytest.raises(TypeError, match="gyro_noise"):
        att.AttitudeFilter(dt=0.01, gyro_noise=True)
    f = att.AttitudeFilter(dt=0.01)
    # update_batch refuses a bool array; update refused a list of bools no less.
    with pytest.raises(TypeError, match="real number"):
        f.update([True, False, True], [0.0, 0.0, 9.81])
    with pytest.raises(TypeError, match="real number"):
        f.update([0.0, 0.0, 0.0], [0.0, 0.0, np.complex128(9.81)])
    with pytest.raises(TypeError, match="real number"):
        f.update([[0.0], [0.0], [0.0]], [0.0, 0.0, 9.81])
    assert f.sensors is None
    # Numpy scalars and integers are numbers.
    g = att.AttitudeFilter(dt=np.float32(0.01), gyro_noise=np.float64(0.01))
    assert g.rate == pytest.approx(100.0, rel=1e-6)
    g.update([np.float32(0.0), np.int64(0), 0], np.array([0, 0, 10], dtype=np.int64))
    h = att.AttitudeFilter(rate=100, gyro_noise=0.01)
    h.update([0.0, 0.0, 0.0], [0.0, 0.0, 10.0])
    assert g.sensors == h.sensors == "6d"
    assert att.AttitudeFilter(dt=np.array(0.01)).rate == 100.0


@pytest.mark.parametrize("kwargs", [
    {}, {"dt": 0.0}, {"dt": float("nan")}, {"dt": 0.01, "rate": 100.0}, {"rate": -1.0},
    {"dt": 0.01, "gyro_noise": -1.0}, {"dt": 0.01, "no_such_parameter": 1.0},
    {"dt": 0.01, "propagation": "kalman"}, {"dt": 0.01, "sensors": "7d"},
    {"dt": 0.01, "mag_delay": 2.0}, {"dt": 0.01, "imu_delay": 0.5},
])
def test_bad_settings_raise(kwargs):
    with pytest.raises(ValueError):
        att.AttitudeFilter(**kwargs)


def test_a_flag_of_another_type_raises_type_error():
    # A flag is True or False: another type is a TypeError, as for the numbers.
    with pytest.raises(TypeError, match="estimate_bias must be True or False"):
        att.AttitudeFilter(dt=0.01, estimate_bias="yes")


def test_bad_arrays_raise():
    f = att.AttitudeFilter(0.01)
    z = np.zeros((10, 3))
    acc = np.tile([0.0, 0.0, 9.81], (10, 1))
    for gyr, a in ((np.zeros((10, 2)), acc), (z, acc[:9]), (np.zeros(3), acc)):
        with pytest.raises(ValueError):
            f.update_batch(gyr, a)
    with pytest.raises(TypeError, match="real numbers"):
        f.update_batch("abc", acc)
    with pytest.raises(TypeError, match="real numbers"):
        f.update([0.0, 0.0, 0.0], np.array([0.0, 0.0, 9.81 + 1j]))
    with pytest.raises(ValueError, match="sample 0"):
        f.update_batch(z, np.zeros((10, 3)))  # no gravity: no tilt
    # Lists and integer arrays are converted; a 6D filter then refuses a magnetometer.
    out = f.update_batch(z.tolist(), acc.astype(np.int64) + 0)
    assert out["quat"].shape == (10, 4) and f.sensors == "6d"
    with pytest.raises(ValueError, match="6D"):
        f.update_batch(z, acc, z)
    with pytest.raises(ValueError, match="no sample"):
        att.AttitudeFilter(0.01).quat
    with pytest.raises(ValueError):
        att.read_broad("/nonexistent/trial.mat")


def test_parameters_round_trip():
    names = att.AttitudeFilter.parameter_names()
    defaults = att.AttitudeFilter.default_params()
    assert list(defaults) == names
    f = att.AttitudeFilter(0.01, gyro_noise=0.01, rest_detection=False, propagation="ukf")
    p = f.params()
    assert p["gyro_noise"] == 0.01 and p["rest_detection"] is False and p["propagation"] == "ukf"
    assert att.AttitudeFilter(0.01, **defaults).params() == defaults


def test_a_million_samples_are_not_copied_per_element():
    # Peak resident memory of a 1e6-sample 6D batch, in a fresh process: the inputs and the
    # outputs, not an object per element (which would cost over 100 bytes a sample).
    code = textwrap.dedent("""
        import resource, numpy as np, liebayes.attitude as att
        n = 1_000_000
        gyr = np.zeros((n, 3)); acc = np.tile([0.0, 0.0, 9.81], (n, 1))
        f = att.AttitudeFilter(0.01, rest_detection=False)
        f.update_batch(gyr[:10], acc[:10])
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        out = f.update_batch(gyr, acc)
        after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        print((after - before) * 1024)
    """)
    grown = int(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                               text=True).stdout)
    outputs = 1_000_000 * (4 + 1 + 1 + 3) * 8 + 2 * 1_000_000
    assert grown < 1.5 * outputs, f"grew {grown} bytes for {outputs} bytes of outputs"
