"""Tests of liebayes.filters: the exact azimuth filter against the library's own study and a
numpy bank of Kalman filters, the studies' figures against scipy's chi-square bands, the exposed
simulated runs replayed and scored by numpy, the angle-of-arrival filters against the study and a
numpy quadrature, and bad input refused with the state unchanged."""

import math

import numpy as np
import pytest
from scipy import stats

from liebayes import filters as lf

SCORED = [
    "azimuth_error",
    "azimuth_sigma",
    "x_error",
    "x_sigma",
    "y_error",
    "y_sigma",
    "nees_position",
    "circular_consistency",
    "diverged",
]


def rotation(a):
    """R(A) for an array of angles, shape (..., 2, 2)."""
    c, s = np.cos(a), np.sin(a)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def exact_on_runs(runs, q=0.1, sigma_m=1.0, sigma0=1.0):
    """The Python exact filter run over every exposed run: its estimates at the measured steps."""
    measured = runs["measured"]
    out = {k: [] for k in ("azimuth", "rho", "circular_variance", "mean_r", "cov_r", "log_evidence")}
    for r in range(runs["z"].shape[0]):
        f = lf.ExactAzimuthFilter(q, sigma_m, sigma0=sigma0)
        est = f.run(runs["velocity"][r], runs["dt"], runs["z"][r])
        for k in out:
            out[k].append(est[k][measured])
    return {k: np.array(v) for k, v in out.items()}


# ------------------------------------------------------------------------------------------
# The exact azimuth filter.


def test_python_filter_scored_equals_the_study_bit_for_bit():
    settings = dict(duration=30.0)
    runs = lf.azimuth_runs("circle", 6, seed=3, **settings)
    est = exact_on_runs(runs)
    measured = runs["measured"]
    mine = lf.score_azimuth(
        runs["truth_r"][:, measured],
        runs["truth_azimuth"],
        est["azimuth"],
        est["rho"],
        est["mean_r"],
        est["cov_r"],
        circular_variance=est["circular_variance"],
        times=runs["time"][measured],
    )
    study = lf.azimuth_study("circle", ["exact"], 6, seed=3, **settings)["exact"]
    assert study["runs"] == 6 and study["failures"] == {}
    np.testing.assert_array_equal(mine["times"], study["times"])
    for name in SCORED:
        if name.startswith(("x_", "y_", "nees")):
            # Positions cross as floats unchanged: bit for bit.
            np.testing.assert_array_equal(mine["metrics"][name], study["metrics"][name], name)
        else:
            # Azimuths cross as angles (the library holds cos and sin): to the last bits.
            np.testing.assert_allclose(
                mine["metrics"][name], study["metrics"][name], rtol=1e-12, atol=1e-12, err_msg=name
            )
    np.testing.assert_array_equal(mine["bands"]["nees_position"], study["bands"]["nees_position"])
    np.testing.assert_allclose(
        mine["bands"]["circular_consistency"], study["bands"]["circular_consistency"], rtol=1e-12
    )
    # The study's log evidence is the mean over runs of what update reports.
    np.testing.assert_allclose(
        study["metrics"]["log_evidence"], est["log_evidence"].mean(axis=0), rtol=1e-12, atol=1e-12
    )
    # A different filter (another sigma_m) does not reproduce the study.
    wrong = exact_on_runs(runs, sigma_m=1.3)
    other = lf.score_azimuth(
        runs["truth_r"][:, measured], runs["truth_azimuth"], wrong["azimuth"], wrong["rho"],
        wrong["mean_r"], wrong["cov_r"], circular_variance=wrong["circular_variance"],
    )
    assert not np.allclose(other["metrics"]["x_error"], study["metrics"]["x_error"], rtol=1e-6)


def test_step_by_step_equals_batch_run():
    runs = lf.azimuth_runs("line", 1, seed=5, duration=5.0)
    batch = lf.ExactAzimuthFilter(0.1, 1.0).run(runs["velocity"][0], runs["dt"], runs["z"][0])
    f = lf.ExactAzimuthFilter(0.1, 1.0)
    for k in range(runs["time"].size):
        f.predict(runs["velocity"][0, k], runs["dt"][k])
        if runs["measured"][k]:
            assert f.update(runs["z"][0, k]) == batch["log_evidence"][k]
        e = f.estimate
        for key in ("mean_r", "cov_r", "a", "c"):
            np.testing.assert_array_equal(e[key], batch[key][k])
        assert e["rho"] == batch["rho"][k] and e["sigma2"] == batch["sigma2"][k]
        assert e["concentration"] == batch["concentration"][k]
    assert np.isnan(batch["log_evidence"][~runs["measured"]]).all()


def kalman_bank(runs, r, cells, sigma_m, q=0.1, sigma0=1.0):
    """A Kalman filter at each of `cells` azimuths (the brute-force posterior), run r."""
    a = (np.arange(cells) + 0.5) * 2 * np.pi / cells
    rot = rotation(a)
    m = np.zeros((cells, 2))
    p = sigma0**2
    logw = np.zeros(cells)
    rows = []
    for k in range(runs["time"].size):
        dt = runs["dt"][k]
        m = m + runs["velocity"][r, k] * dt
        p = p + q * q * dt
        if not runs["measured"][k]:
            continue
        z = runs["z"][r, k]
        s = p + sigma_m**2
        nu = z - np.einsum("cij,cj->ci", rot, m)
        loglik = -np.log(2 * np.pi * s) - (nu**2).sum(1) / (2 * s)
        prior = logw - np.logaddexp.reduce(logw)
        evidence = np.logaddexp.reduce(prior + loglik)
        logw = prior + loglik
        m = m + (p / s) * np.einsum("cji,cj->ci", rot, nu)
        p = p * sigma_m**2 / s
        w = np.exp(logw - np.logaddexp.reduce(logw))
        mean = w @ m
        cov = p * np.eye(2) + np.einsum("c,ci,cj->ij", w, m, m) - np.outer(mean, mean)
        moment = np.array([w @ np.cos(a), w @ np.sin(a)])
        rows.append((mean, cov, np.hypot(*moment), math.atan2(moment[1], moment[0]), evidence))
    return rows


def test_exact_filter_against_a_bank_of_kalman_filters():
    runs = lf.azimuth_runs("circle", 2, seed=11, duration=12.0)
    for r in range(2):
        est = lf.ExactAzimuthFilter(0.1, 1.0).run(runs["velocity"][r], runs["dt"], runs["z"][r])
        idx = np.flatnonzero(runs["measured"])
        bank = kalman_bank(runs, r, 4096, sigma_m=1.0)
        for j, (mean, cov, rho, az, evidence) in enumerate(bank):
            k = idx[j]
            np.testing.assert_allclose(est["mean_r"][k], mean, atol=1e-9)
            np.testing.assert_allclose(est["cov_r"][k], cov, atol=1e-9)
            assert abs(est["rho"][k] - rho) < 1e-9
            if est["rho"][k] > 1e-6:
                assert abs(math.remainder(est["azimuth"][k] - az, 2 * math.pi)) < 1e-7
            else:  # The first measurement at r0 = 0 says nothing of A: uniform, no mean.
                assert np.isnan(est["azimuth"][k]) and est["concentration"][k] == 0.0
            assert abs(est["log_evidence"][k] - evidence) < 1e-9
        # The bank of a wrong noise level must disagree: the comparison can fail.
        wrong = kalman_bank(runs, r, 4096, sigma_m=1.3)
        assert max(abs(est["log_evidence"][idx[j]] - w[4]) for j, w in enumerate(wrong)) > 1e-2


def test_conditional_mean_is_a_plus_rotated_c():
    f = lf.ExactAzimuthFilter(0.1, 0.5, r0=[10.0, 0.0])
    f.update([0.0, 10.0])
    e = f.estimate
    for a in (0.0, 1.0, -2.5):
        expected = e["a"] + rotation(-a) @ e["c"]
        np.testing.assert_allclose(f.conditional_mean(a), expected, rtol=1e-14, atol=1e-14)
    # A quarter turn: world (0, 10) is platform (10, 0) turned by +90 degrees.
    assert abs(e["azimuth"] - math.pi / 2) < 0.05
    assert abs(e["concentration"] - np.hypot(*e["eta"])) < 1e-12


# ------------------------------------------------------------------------------------------
# Studies.


def chi2_mean_band(dof, n):
    """The two-sided 95 % band of the mean of n chi-square(dof) values (scipy)."""
    g = stats.gamma(a=n * dof / 2, scale=2 / n)
    return g.ppf(0.025), g.ppf(0.975)


def test_study_shapes_bands_and_a_misspecified_filter():
    runs, settings = 60, dict(duration=40.0, measure_every=10)
    result = lf.azimuth_study("circle", ["exact", "EKF"], runs, seed=2, **settings)
    assert set(result) == {"exact", "EKF"}
    epochs = math.ceil(400 / 10)
    exact = result["exact"]
    for name, values in exact["metrics"].items():
        assert values.shape == (epochs,), name
    assert exact["bands"]["nees_position"].shape == (epochs, 2)
    assert exact["reductions"]["nees_position"] == "chi2(2)"
    assert exact["units"]["azimuth_error"] == "deg"
    np.testing.assert_allclose(exact["times"], np.arange(epochs) * 1.0, atol=1e-12)
    assert (exact["counts"]["nees_position"] == runs).all()
    # The EKF reports an innovation, so its NIS is summarised; the exact filter's is not.
    assert "nis" in result["EKF"]["metrics"] and "nis" not in exact["metrics"]
    # The library's band is the exact chi-square band.
    lo, hi = chi2_mean_band(2, runs)
    np.testing.assert_allclose(exact["bands"]["nees_position"][-1], [lo, hi], rtol=1e-6)
    nees = exact["metrics"]["nees_position"]
    # 95 % of the epochs are expected in the band; the epochs of a run are correlated, so over
    # seeds 1 to 6 the fraction ranged from 0.75 to 1.
    inside = (nees >= lo) & (nees <= hi)
    assert inside.mean() >= 0.7
    # A filter told the measurements are four times more precise than they are is inconsistent.
    wrong = lf.azimuth_study(
        "circle", ["exact"], runs, seed=2, filter_sigma_m=0.25, **settings
    )["exact"]["metrics"]["nees_position"]
    outside = (wrong < lo) | (wrong > hi)
    assert outside.mean() >= 0.9 and wrong[-1] > hi
    # The same runs through the Python filter: numpy's NEES averages to the study's at every
    # epoch, and each run's mean NEES (independent over runs) averages to 2, E NEES of the exact
    # posterior, two-sided; the mis-specified filter's does not.
    data = lf.azimuth_runs("circle", runs, seed=2, **settings)
    m = data["measured"]
    for sigma_m, study_nees in ((1.0, nees), (0.25, wrong)):
        est = exact_on_runs(data, sigma_m=sigma_m)
        e = est["mean_r"] - data["truth_r"][:, m]
        per_epoch = np.einsum("rki,rkij,rkj->rk", e, np.linalg.inv(est["cov_r"]), e)
        np.testing.assert_allclose(per_epoch.mean(0), study_nees, rtol=1e-10)
        per_run = per_epoch.mean(1)
        t = (per_run.mean() - 2.0) / (per_run.std(ddof=1) / math.sqrt(runs))
        assert (abs(t) < 4) == (sigma_m == 1.0), (sigma_m, t)


def test_exposed_runs_are_the_study_runs():
    whole = lf.azimuth_runs("line", 4, seed=9, duration=20.0)
    part = lf.azimuth_runs("line", 2, seed=9, start=2, duration=20.0)
    for key in ("truth_r", "z", "velocity", "truth_azimuth"):
        np.testing.assert_array_equal(whole[key][2:], part[key])
    assert (whole["measured"] == (np.arange(200) % 10 == 0)).all()
    assert np.isnan(whole["z"][:, ~whole["measured"]]).all()
    # Measurements are R(A) r + N(0, sigma_m^2), the motion v dt + N(0, q^2 dt): two-sided.
    many = lf.azimuth_runs("circle", 40, seed=1, duration=50.0, sigma_m=0.7, q=0.3)
    m = many["measured"]
    rot = rotation(many["truth_azimuth"])
    noise = many["z"][:, m] - np.einsum("rij,rkj->rki", rot, many["truth_r"][:, m])
    assert 0.66 < noise.std() < 0.74 and abs(noise.mean()) < 0.03
    steps = np.diff(many["truth_r"], axis=1) - many["velocity"][:, 1:] * 0.1
    assert 0.3 * math.sqrt(0.1) * 0.97 < steps.std() < 0.3 * math.sqrt(0.1) * 1.03
    # A different seed gives different runs.
    other = lf.azimuth_runs("line", 4, seed=10, duration=20.0)
    assert not np.array_equal(other["truth_azimuth"], whole["truth_azimuth"])


def test_a_users_numpy_filter_is_scored_as_numpy_scores_it():
    runs = lf.azimuth_runs("line", 20, seed=4, duration=30.0)
    m = runs["measured"]
    # Dead reckoning from the origin, and the azimuth from the measured and reckoned bearings.
    reckoned = np.cumsum(runs["velocity"] * runs["dt"][None, :, None], axis=1)[:, m]
    t = runs["time"][m]
    var = 1.0 + 0.01 * t
    cov = var[None, :, None, None] * np.eye(2)
    cov = np.broadcast_to(cov, reckoned.shape[:2] + (2, 2)).copy()
    z = runs["z"][:, m]
    azimuth = np.arctan2(z[..., 1], z[..., 0]) - np.arctan2(reckoned[..., 1], reckoned[..., 0])
    rho = np.full(azimuth.shape, 0.6)
    s = lf.score_azimuth(runs["truth_r"][:, m], runs["truth_azimuth"], azimuth, rho, reckoned, cov)
    e = reckoned - runs["truth_r"][:, m]
    np.testing.assert_allclose(s["metrics"]["x_error"], np.sqrt((e[..., 0] ** 2).mean(0)), rtol=1e-12)
    np.testing.assert_allclose(s["metrics"]["y_sigma"], np.sqrt(var), rtol=1e-12)
    nees = (e**2).sum(-1) / var
    np.testing.assert_allclose(s["metrics"]["nees_position"], nees.mean(0), rtol=1e-12)
    err = np.remainder(azimuth - runs["truth_azimuth"][:, None] + np.pi, 2 * np.pi) - np.pi
    np.testing.assert_allclose(
        s["metrics"]["azimuth_error"], np.degrees(np.sqrt((err**2).mean(0))), rtol=1e-9
    )
    np.testing.assert_allclose(
        s["metrics"]["azimuth_sigma"], np.degrees(np.sqrt(-2 * np.log(0.6))), rtol=1e-12
    )
    np.testing.assert_allclose(
        s["metrics"]["diverged"], 100 * (np.abs(err) > np.radians(10)).mean(0), rtol=1e-12
    )
    np.testing.assert_allclose(s["times"], np.arange(t.size), atol=0)
    # The dead-reckoning filter ignores the measurements: the exact filter beats it.
    exact = lf.azimuth_study("line", ["exact"], 20, seed=4, duration=30.0)["exact"]["metrics"]
    assert exact["x_error"][-1] < s["metrics"]["x_error"][-1]


# ------------------------------------------------------------------------------------------
# Angle-of-arrival filters.


def test_aoa_filters_on_the_exposed_runs_equal_the_study():
    settings = dict(steps=12)
    runs = lf.aoa_runs("model2", 3, seed=7, **settings)
    kappa = 1 / np.radians(10.0) ** 2
    sigma = 1 / math.sqrt(kappa)
    names = ["EKF-VMF", "IEKF-VMF", "UKF-AE-nominal"]
    study = lf.aoa_study("model2", names, 3, seed=7, **settings)
    assert set(study) == set(names)
    vmf, angles = dict(kappa=kappa), dict(sigma_az=sigma, sigma_el=sigma)
    for name, params in zip(names, (vmf, vmf, angles)):
        means, covs = [], []
        for r in range(3):
            f = lf.AoaFilter(
                name, runs["anchors"], runs["rotations"], prior_mean=runs["prior_mean"][r],
                prior_std=runs["prior_std"], q_xy=runs["q_xy"], q_z=runs["q_z"], **params,
            )
            mr, cr = [], []
            for k in range(12):
                f.predict(runs["delta"][k])
                f.update(runs["readings"][r, k])
                mr.append(f.mean)
                cr.append(f.covariance)
            means.append(mr)
            covs.append(cr)
        mine = lf.score_aoa(runs["truth"], np.array(means), np.array(covs), times=runs["time"])
        for metric, values in mine["metrics"].items():
            np.testing.assert_allclose(values, study[name]["metrics"][metric], rtol=1e-9, err_msg=metric)
    assert study["EKF-VMF"]["metrics"]["position_error"].shape == (12,)
    assert study["EKF-VMF"]["bands"]["nees_position"].shape == (12, 2)


def quadrature(positions, rotations, readings, kappa, prior_mean, prior_std):
    """Posterior mean and covariance of prior x von Mises-Fisher likelihood on a grid of 81^3."""
    g = np.linspace(-4, 4, 81) * prior_std
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3) + prior_mean
    logp = -0.5 * ((x - prior_mean) ** 2).sum(1) / prior_std**2
    az, el = readings[:, 0], readings[:, 1]
    u = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], 1)
    v = np.einsum("jba,jb->ja", rotations, u)  # the readings in world axes
    for j in range(len(positions)):
        off = x - positions[j]
        logp += kappa * (off @ v[j]) / np.linalg.norm(off, axis=1)
    w = np.exp(logp - logp.max())
    w /= w.sum()
    mean = w @ x
    return mean, np.einsum("n,ni,nj->ij", w, x - mean, x - mean)


def test_aoa_particle_filter_against_numpy_quadrature():
    positions, rotations = lf.square_track()
    kappa, prior_mean, prior_std = 30.0, np.array([1.0, 0.5, 0.0]), 0.5
    truth = np.array([1.4, 0.2, 0.1])
    d = (truth - positions) / np.linalg.norm(truth - positions, axis=1)[:, None]
    local = np.einsum("jab,jb->ja", rotations, d)
    readings = np.stack([np.arctan2(local[:, 1], local[:, 0]), np.arcsin(local[:, 2])], 1)
    f = lf.AoaFilter("PF-VMF", positions, rotations, kappa=kappa, prior_mean=prior_mean,
                     prior_std=prior_std, particles=200_000, seed=1)
    f.update(readings)
    mean, cov = quadrature(positions, rotations, readings, kappa, prior_mean, prior_std)
    # 200 000 particles: a Monte Carlo error of about 1e-3 m on the mean (measured over seeds).
    assert np.abs(f.mean - mean).max() < 0.006
    assert np.abs(f.covariance - cov).max() < 0.02 * np.abs(cov).max()
    # The posterior of a wrong concentration is told apart by the same tolerances.
    wrong_mean, wrong_cov = quadrature(positions, rotations, readings, 20.0, prior_mean, prior_std)
    assert np.abs(f.mean - wrong_mean).max() > 0.006
    assert np.abs(f.covariance - wrong_cov).max() > 0.02 * np.abs(cov).max()
    assert f.nis is None


# ------------------------------------------------------------------------------------------
# Bad input: refused with the library's message, the state unchanged.


def snapshot(f):
    e = f.estimate
    return {k: np.array(v, copy=True) for k, v in e.items()}


def assert_same(a, b):
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])


def test_bad_input_to_the_azimuth_filter():
    with pytest.raises(ValueError, match="velocity noise density q"):
        lf.ExactAzimuthFilter(-1.0, 1.0)
    with pytest.raises(ValueError, match="sigma_m"):
        lf.ExactAzimuthFilter(0.1, 0.0)
    with pytest.raises(ValueError, match="r0"):
        lf.ExactAzimuthFilter(0.1, 1.0, r0=[1.0, 2.0, 3.0])
    f = lf.ExactAzimuthFilter(0.1, 1.0)
    f.predict([1.0, 0.5], 1.0)
    f.update([0.3, 1.0])
    before = snapshot(f)
    with pytest.raises(ValueError, match="velocity input"):
        f.predict([np.nan, 0.0], 1.0)
    with pytest.raises(ValueError, match="time step dt"):
        f.predict([1.0, 0.0], -1.0)
    with pytest.raises(ValueError, match="position measurement z"):
        f.update([np.inf, 0.0])
    with pytest.raises(ValueError, match="shape"):
        f.update([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="overflows"):
        f.update([1e200, 1e200])
    with pytest.raises((TypeError, ValueError)):
        f.update(["a", "b"])
    assert_same(before, snapshot(f))
    # A batch run that fails at step 3 leaves the filter as it was, and says where.
    v = np.zeros((6, 2))
    v[3, 0] = np.nan
    z = np.full((6, 2), np.nan)
    z[0] = [1.0, 0.0]
    with pytest.raises(ValueError, match=r"step 3 .*velocity input"):
        f.run(v, 0.1, z)
    with pytest.raises(ValueError, match="one NaN"):
        f.run(np.zeros((2, 2)), 0.1, [[1.0, np.nan], [np.nan, np.nan]])
    with pytest.raises(ValueError, match="shape"):
        f.run(np.zeros((3, 2)), 0.1, np.zeros((4, 2)))
    with pytest.raises(ValueError, match="dt"):
        f.run(np.zeros((3, 2)), np.zeros(2), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="finite"):
        f.conditional_mean(np.nan)
    assert_same(before, snapshot(f))
    # A copy is independent.
    g = f.copy()
    g.predict([1.0, 0.0], 1.0)
    assert_same(before, snapshot(f))


def test_bad_input_to_studies_and_scoring():
    with pytest.raises(ValueError, match="scenario"):
        lf.azimuth_study("spiral", ["exact"], 2)
    with pytest.raises(ValueError, match="method"):
        lf.azimuth_study("circle", ["kalman"], 2, duration=5.0)
    with pytest.raises(ValueError, match="number of particles"):
        lf.azimuth_study("circle", ["PF 0"], 2, duration=5.0)
    with pytest.raises(ValueError, match="number of runs"):
        lf.azimuth_study("circle", ["exact"], 0, duration=5.0)
    with pytest.raises(ValueError, match="twice"):
        lf.azimuth_study("circle", ["exact", "EXACT"], 2, duration=5.0)
    with pytest.raises(ValueError, match="sigma_m"):
        lf.azimuth_study("circle", ["exact"], 2, duration=5.0, filter_sigma_m=-1.0)
    with pytest.raises(ValueError, match="duration"):
        lf.azimuth_runs("circle", 2, duration=np.nan)
    with pytest.raises(ValueError, match="2\\^28"):
        lf.azimuth_runs("circle", 10**9, duration=500.0)
    with pytest.raises(ValueError, match="runs"):
        lf.azimuth_runs("circle", 0, duration=5.0)
    with pytest.raises(ValueError, match="rho"):
        lf.score_azimuth(np.zeros((2, 3, 2)), np.zeros(2), np.zeros((2, 3)), np.zeros((2, 4)),
                         np.zeros((2, 3, 2)), np.zeros((2, 3, 2, 2)))
    with pytest.raises(ValueError, match="truth_azimuth"):
        lf.score_azimuth(np.zeros((1, 1, 2)), [np.nan], [[0.0]], [[0.5]], np.zeros((1, 1, 2)),
                         np.eye(2)[None, None])
    with pytest.raises(ValueError, match="covariance"):
        lf.score_aoa(np.zeros((1, 2, 3)), np.zeros((1, 2, 3)), np.zeros((1, 2, 3)))
    with pytest.raises(ValueError, match="data"):
        lf.aoa_study("model3", ["EKF-VMF"], 2)
    with pytest.raises(ValueError, match="algorithm"):
        lf.aoa_study("model1", ["KF-VMF"], 2, steps=5)
    with pytest.raises(ValueError, match="number of track steps"):
        lf.aoa_runs("model1", 2, steps=0)


def test_scores_need_epochs_and_at_most_as_many_as_a_study():
    # A summary keeps about 1 KB of exact statistics per metric and epoch: 2^24 epochs asked for
    # 170 GB, and no epochs at all with 2^40 runs looped 2^40 times.
    for epochs in (0, 2**14 + 1):
        with pytest.raises(ValueError, match="epochs"):
            lf.score_aoa(np.zeros((1, epochs, 3)), np.zeros((1, epochs, 3)),
                         np.zeros((1, epochs, 3, 3)))
        with pytest.raises(ValueError, match="epochs"):
            lf.score_azimuth(np.zeros((1, epochs, 2)), np.zeros(1), np.zeros((1, epochs)),
                             np.ones((1, epochs)), np.zeros((1, epochs, 2)),
                             np.zeros((1, epochs, 2, 2)))
    with pytest.raises(ValueError, match="epochs"):
        lf.score_aoa(np.empty((2**40, 0, 3)), np.empty((2**40, 0, 3)), np.empty((2**40, 0, 3, 3)))
    with pytest.raises(ValueError, match="runs"):
        lf.score_aoa(np.zeros((0, 2, 3)), np.zeros((0, 2, 3)), np.zeros((0, 2, 3, 3)))
    # The limit itself is scored.
    epochs = 2**14
    cov = np.broadcast_to(np.eye(3), (1, epochs, 3, 3))
    scored = lf.score_aoa(np.zeros((1, epochs, 3)), np.zeros((1, epochs, 3)), cov)
    assert scored["times"].shape == (epochs,)


def test_bools_complex_and_one_element_arrays_are_not_real_numbers():
    for bad in (True, np.bool_(True), np.complex128(0.1 + 1j), np.array([1.0]), "1.0"):
        with pytest.raises(TypeError, match="real number"):
            lf.ExactAzimuthFilter(bad, 1.0)
        with pytest.raises(TypeError, match="real number"):
            lf.azimuth_runs("circle", 1, duration=5.0, dt=bad)
    f = lf.ExactAzimuthFilter(0.1, 1.0)
    with pytest.raises(TypeError, match="real number"):
        f.predict([1.0, 0.0], True)
    with pytest.raises(TypeError, match="real number"):
        f.conditional_mean(np.complex128(0.5))
    positions, rotations = lf.square_track()
    with pytest.raises(TypeError, match="real number"):
        lf.AoaFilter("EKF-VMF", positions, rotations, kappa=True)
    # A time step per step: one number, or one per step; an array of one is one step's.
    v, z = np.zeros((3, 2)), np.full((3, 2), np.nan)
    z[2] = [1.0, 0.5]
    with pytest.raises(TypeError, match="real number"):
        f.run(v, True, z)
    with pytest.raises(TypeError, match="real numbers"):
        f.run(v, [True, False, True], z)
    with pytest.raises(ValueError, match="dt"):
        f.run(v, np.array([0.1]), z)
    reference = f.copy().run(v, 0.1, z)
    for dt in (np.float64(0.1), np.array(0.1), [0.1, 0.1, 0.1]):
        assert_same(reference, f.copy().run(v, dt, z))
    assert_same(f.copy().run(v, float(np.float32(0.1)), z), f.copy().run(v, np.float32(0.1), z))
    assert_same(f.copy().run(v[:1], 0.1, z[:1]), f.copy().run(v[:1], np.array([0.1]), z[:1]))
    # Integers are numbers.
    g = lf.ExactAzimuthFilter(np.int64(0), 1, sigma0=np.float32(2.0))
    g.predict([1, 0], np.int64(2))
    h = lf.ExactAzimuthFilter(0.0, 1.0, sigma0=2.0)
    h.predict([1.0, 0.0], 2.0)
    assert_same(snapshot(g), snapshot(h))


def test_bad_input_to_the_aoa_filter():
    positions, rotations = lf.square_track()
    with pytest.raises(ValueError, match="kappa"):
        lf.AoaFilter("EKF-VMF", positions, rotations)
    with pytest.raises(ValueError, match="concentration"):
        lf.AoaFilter("EKF-VMF", positions, rotations, kappa=-1.0)
    with pytest.raises(ValueError, match="sigma_az"):
        lf.AoaFilter("EKF-AE", positions, rotations, sigma_az=0.1)
    with pytest.raises(ValueError, match="anchors"):
        lf.AoaFilter("EKF-VMF", np.zeros((9, 3)), kappa=10.0)
    with pytest.raises(ValueError, match="shape"):
        lf.AoaFilter("EKF-VMF", np.zeros((4, 2)), kappa=10.0)
    bent = rotations.copy()
    bent[0, 0, 0] = 2.0
    with pytest.raises(ValueError):
        lf.AoaFilter("EKF-VMF", positions, bent, kappa=10.0)
    with pytest.raises(ValueError, match="particles"):
        lf.AoaFilter("PF-VMF", positions, rotations, kappa=10.0, particles=0)
    with pytest.raises(ValueError, match="prior standard deviation"):
        lf.AoaFilter("UKF-VMF", positions, rotations, kappa=10.0, prior_std=0.0)
    f = lf.AoaFilter("EKF-AE", positions, rotations, sigma_az=0.2, sigma_el=0.2,
                     prior_mean=[1.0, 1.0, 0.0])
    f.predict(0.25)
    f.update(np.zeros((4, 2)) + [0.1, 0.2])
    mean, cov = f.mean, f.covariance
    with pytest.raises(ValueError, match="elevation"):
        f.update(np.full((4, 2), 2.0))
    with pytest.raises(ValueError, match="shape"):
        f.update(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="time step"):
        f.predict(-1.0)
    with pytest.raises(ValueError, match="azimuth"):
        f.update(np.full((4, 2), np.nan))
    np.testing.assert_array_equal(mean, f.mean)
    np.testing.assert_array_equal(cov, f.covariance)
    assert f.nis is not None and f.nis[1] == 8
    # One anchor at the origin with world axes works too.
    g = lf.AoaFilter("UKF-VMF", [[0.0, 0.0, 0.0]], kappa=50.0, prior_mean=[1.0, 0.0, 0.0])
    g.update([[0.0, 0.0]])
    assert g.mean.shape == (3,) and g.covariance.shape == (3, 3)


def test_scores_of_non_finite_estimates_are_refused_naming_the_index():
    truth, mean = np.zeros((1, 2, 3)), np.zeros((1, 2, 3))
    cov = np.broadcast_to(np.eye(3), (1, 2, 3, 3)).copy()
    mean[0, 1, 2] = np.nan
    with pytest.raises(ValueError, match=r"mean\[0, 1, 2\]: NaN is not a finite value"):
        lf.score_aoa(truth, mean, cov)
    cov[0, 0, 1, 1] = np.inf
    with pytest.raises(ValueError, match=r"covariance\[0, 0, 1, 1\]"):
        lf.score_aoa(truth, np.zeros((1, 2, 3)), cov)
