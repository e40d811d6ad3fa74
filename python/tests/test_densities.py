"""Tests of liebayes.densities against independent references: scipy.stats, mpmath at 50 digits,
and quadratures written here in numpy. Every random stream has a fixed seed, and every statistical
check also runs on a wrong model, which must be rejected."""

import math

import mpmath
import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from liebayes.densities import (
    Bingham,
    HeatKernelSo3,
    ManifoldGaussianS2,
    ManifoldGaussianSo3,
    VonMises,
    VonMisesFisher,
    bingham_log_normaliser,
)


def wrap(a):
    """Angles into [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def random_rotation(seed):
    return Rotation.random(random_state=seed).as_matrix()


def random_orthogonal4(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((4, 4)))
    return q * np.sign(np.diag(r))


# ------------------------------------------------------------------------------------------------
# Von Mises
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("mu, kappa", [(0.7, 0.0), (0.7, 1e-4), (-2.0, 2.5), (3.0, 40.0), (1.0, 700.0)])
def test_von_mises_log_pdf_matches_scipy(mu, kappa):
    x = np.linspace(-np.pi, np.pi, 257)
    ours = VonMises(mu, kappa).log_pdf(x)
    ref = stats.vonmises.logpdf(x, kappa, loc=mu) if kappa > 0 else np.full_like(x, -np.log(2 * np.pi))
    # scipy folds x - mu onto [-pi, pi) itself; both are densities on the circle.
    np.testing.assert_allclose(ours, ref, rtol=1e-13, atol=1e-13)
    assert ours.shape == x.shape
    # Batch shapes are kept, a scalar gives a float.
    assert VonMises(mu, kappa).log_pdf(x.reshape(1, 257)).shape == (1, 257)
    assert isinstance(VonMises(mu, kappa).log_pdf(0.25), float)


def ulp_errors(values, exact):
    return np.array([abs(float((mpmath.mpf(v) - e) / np.spacing(abs(float(e))))) for v, e in zip(values, exact)])


def test_von_mises_log_density_at_kappa_800_within_4_ulp_of_mpmath():
    mpmath.mp.dps = 50
    kappa = 800.0
    # Angles where the value is well conditioned (|d ln p/d theta * theta / ln p| <= 3: near the
    # zero crossing of ln p, at theta ~ 0.078, no one can promise a few ulp of a value near 0).
    angles = np.array([0.0, 0.005, 0.01, 0.02, 0.03, 0.04, 0.15, 0.2, 0.25, 0.5, 1.0, 2.0, 3.0])
    log_z = mpmath.log(2 * mpmath.pi * mpmath.besseli(0, mpmath.mpf(kappa)))
    exact = [mpmath.mpf(kappa) * mpmath.cos(mpmath.mpf(t)) - log_z for t in angles]
    ours = ulp_errors(VonMises(0.0, kappa).log_pdf(angles), exact)
    assert ours.max() <= 4.0, ours
    # The plain form kappa cos(theta) - ln(2 pi I0(kappa)) (I0 through its scaled form, so that it
    # does not overflow) cancels two numbers of size kappa: it is off by far more than 4 ulp.
    from scipy.special import i0e

    plain = kappa * np.cos(angles) - (np.log(2 * np.pi) + np.log(i0e(kappa)) + kappa)
    plain_errors = ulp_errors(plain, exact)
    assert plain_errors.max() > 4.0 * 10, plain_errors
    # scipy >= 1.x evaluates kappa cosm1(x) - ln 2 pi - ln i0e(kappa), the stable form too; its
    # error is measured here for the record (reported in docs/python/densities.md), not asserted.
    scipy_errors = ulp_errors(stats.vonmises.logpdf(angles, kappa), exact)
    assert np.isfinite(scipy_errors).all()


@pytest.mark.parametrize("kappa", [5e-4, 2.5, 60.0])
def test_von_mises_sampler_ks_against_scipy(kappa):
    mu = 0.7
    draws = VonMises(mu, kappa).sample(20000, np.random.default_rng(11))
    assert draws.shape == (20000,)
    assert np.all((draws > -np.pi) & (draws <= np.pi))
    offsets = wrap(draws - mu)
    assert stats.kstest(offsets, stats.vonmises(kappa).cdf).pvalue > 1e-3
    # Wrong model: the same draws against a concentration 30 % off (or against the uniform
    # distribution's offset) are rejected.
    wrong = stats.vonmises(kappa * 1.3 + 0.5).cdf
    assert stats.kstest(offsets, wrong).pvalue < 1e-6


def test_von_mises_sampler_large_kappa_is_the_wrapped_normal_limit():
    kappa = 1e9
    d = VonMises(0.0, kappa).sample(20000, np.random.default_rng(5)) * math.sqrt(kappa)
    assert stats.kstest(d, "norm").pvalue > 1e-3
    assert stats.kstest(d / 1.1, "norm").pvalue < 1e-6


def test_sample_is_reproducible_from_generator_state():
    p = VonMises(0.1, 3.0)
    a = p.sample(50, np.random.default_rng(123))
    b = p.sample(50, np.random.default_rng(123))
    np.testing.assert_array_equal(a, b)
    rng = np.random.default_rng(123)
    first, second = p.sample(50, rng), p.sample(50, rng)
    assert not np.array_equal(first, second)  # the generator advanced
    np.testing.assert_array_equal(first, a)
    assert p.sample(0, rng).shape == (0,)


def test_von_mises_product_log_evidence_against_quadrature():
    p, q = VonMises(0.3, 2.0), VonMises(2.0, 5.0)
    joint, log_evidence = p.product(q)
    theta = np.linspace(-np.pi, np.pi, 4096, endpoint=False)
    integrand = np.exp(p.log_pdf(theta) + q.log_pdf(theta))
    integral = integrand.sum() * (2 * np.pi / theta.size)  # trapezoid: spectral for periodic
    assert abs(log_evidence - np.log(integral)) < 1e-13
    np.testing.assert_allclose(joint.log_pdf(theta), np.log(integrand) - log_evidence, atol=1e-12)
    np.testing.assert_allclose(joint.natural, p.natural + q.natural, rtol=1e-15)
    # Wrong value: the evidence of a different likelihood differs.
    assert abs(p.product(VonMises(2.0, 5.5))[1] - np.log(integral)) > 1e-3


def test_von_mises_accessors_normaliser_and_gradient():
    p = VonMises(-1.2, 3.5)
    assert p.mean == pytest.approx(-1.2, abs=1e-15)
    assert p.concentration == pytest.approx(3.5, rel=1e-15)
    assert VonMises.uniform().mean is None
    from scipy.special import i0

    assert p.log_normaliser() == pytest.approx(np.log(2 * np.pi * i0(3.5)), rel=1e-14)
    eta = p.natural
    h = 1e-6

    def log_z(e):
        return VonMises.from_natural(e).log_normaliser()

    numeric = [(log_z(eta + h * np.eye(2)[i]) - log_z(eta - h * np.eye(2)[i])) / (2 * h) for i in range(2)]
    np.testing.assert_allclose(p.log_normaliser_gradient(), numeric, atol=1e-8)
    assert p.mean_resultant_length() == pytest.approx(np.linalg.norm(numeric), abs=1e-8)
    assert p.circular_variance() == pytest.approx(1 - p.mean_resultant_length(), abs=1e-15)
    assert p.entropy() == pytest.approx(stats.vonmises(3.5).entropy(), rel=1e-10)
    assert p.kl_divergence(p) == 0.0
    assert "VonMises(mu=-1.2" in repr(p)


def test_von_mises_fit_matches_scipy_mle():
    data = VonMises(1.1, 4.0).sample(500, np.random.default_rng(3))
    fitted = VonMises.fit(data)
    kappa, loc, _ = stats.vonmises.fit(data, fscale=1)
    assert fitted.concentration == pytest.approx(kappa, rel=1e-6)
    assert wrap(fitted.mean - loc) == pytest.approx(0.0, abs=1e-9)
    # Integer weights are duplicated samples.
    w = np.arange(500) % 3
    dup = np.repeat(data, w)
    np.testing.assert_allclose(VonMises.fit(data, w).natural, VonMises.fit(dup).natural, rtol=1e-10)
    # A fit to other data is not this fit.
    assert abs(VonMises.fit(data[:250]).concentration - fitted.concentration) > 1e-3
    # Only the weights' ratios count, however large (weights summing past the largest float gave
    # a uniform fit).
    huge = np.full(500, 1e308)
    np.testing.assert_allclose(VonMises.fit(data, huge).natural, fitted.natural, rtol=1e-12)


# ------------------------------------------------------------------------------------------------
# Von Mises-Fisher
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kappa", [0.5, 20.0, 3000.0])
def test_von_mises_fisher_fit_matches_scipy_mle(kappa):
    mu = np.array([0.6, -0.48, 0.64])
    data = VonMisesFisher(mu, kappa).sample(2000, np.random.default_rng(5))
    fitted = VonMisesFisher.fit(data)
    loc, k = stats.vonmises_fisher.fit(data)
    assert fitted.concentration == pytest.approx(k, rel=1e-6)
    np.testing.assert_allclose(fitted.mean, loc, atol=1e-9)
    # The estimate is near the truth (2000 samples: κ within 10 %, the mean within 5 σ).
    assert fitted.concentration == pytest.approx(kappa, rel=0.1)
    assert np.degrees(np.arccos(min(1.0, fitted.mean @ mu))) < 5 * np.degrees(1 / np.sqrt(2000 * kappa)) + 1
    # Integer weights are duplicated samples; a fit to other data is not this fit.
    w = np.arange(2000) % 3
    np.testing.assert_allclose(VonMisesFisher.fit(data, w).natural,
                               VonMisesFisher.fit(np.repeat(data, w, axis=0)).natural, rtol=1e-10)
    assert abs(VonMisesFisher.fit(data[:100]).concentration / fitted.concentration - 1) > 1e-4
    with pytest.raises(ValueError, match="samples"):
        VonMisesFisher.fit(np.zeros((3, 3)))
    with pytest.raises(ValueError):
        VonMisesFisher.fit(np.tile(mu, (5, 1)))  # all equal: infinite concentration


@pytest.mark.parametrize("kappa", [0.1, 5.0, 500.0])
def test_von_mises_fisher_log_pdf_matches_scipy(kappa):
    mu = np.array([0.3, -0.4, np.sqrt(1 - 0.25)])
    x = stats.vonmises_fisher(mu, kappa).rvs(200, random_state=1)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    x = np.vstack([x, -mu, Rotation.random(50, random_state=2).apply([1.0, 0.0, 0.0])])
    ours = VonMisesFisher(mu, kappa).log_pdf(x)
    np.testing.assert_allclose(ours, stats.vonmises_fisher(mu, kappa).logpdf(x), rtol=1e-12, atol=1e-12)


def test_von_mises_fisher_sampler_moments_and_cosine_law():
    mu, kappa = np.array([0.0, 0.6, 0.8]), 7.0
    x = VonMisesFisher(mu, kappa).sample(20000, np.random.default_rng(9))
    assert x.shape == (20000, 3)
    np.testing.assert_allclose(np.linalg.norm(x, axis=1), 1.0, atol=1e-14)
    expected = (1 / np.tanh(kappa) - 1 / kappa) * mu
    se = x.std(axis=0) / np.sqrt(len(x))
    assert np.all(np.abs(x.mean(axis=0) - expected) < 5 * se)
    # Same first moment as scipy's sampler, within both standard errors.
    y = stats.vonmises_fisher(mu, kappa).rvs(20000, random_state=4)
    assert np.all(np.abs(x.mean(axis=0) - y.mean(axis=0)) < 5 * np.hypot(se, y.std(axis=0) / np.sqrt(len(y))))
    # The cosine w = mu . x has CDF (e^(k w) - e^(-k)) / (e^k - e^(-k)).
    w = x @ mu

    def cdf(t, k=kappa):
        return np.expm1(k * (t + 1)) / np.expm1(2 * k)

    assert stats.kstest(w, cdf).pvalue > 1e-3
    assert stats.kstest(w, lambda t: cdf(t, 1.3 * kappa)).pvalue < 1e-6


def sphere_grid(n_theta=96, n_phi=192):
    c, wc = np.polynomial.legendre.leggauss(n_theta)
    phi = np.arange(n_phi) * 2 * np.pi / n_phi
    s = np.sqrt(1 - c**2)
    pts = np.stack(
        [np.outer(s, np.cos(phi)), np.outer(s, np.sin(phi)), np.outer(c, np.ones_like(phi))], axis=-1
    ).reshape(-1, 3)
    weights = np.outer(wc, np.full(n_phi, 2 * np.pi / n_phi)).ravel()
    return pts, weights


def test_von_mises_fisher_product_evidence_and_normaliser_gradient():
    p = VonMisesFisher([1.0, 0.0, 0.0], 3.0)
    q = VonMisesFisher([0.0, 0.0, 1.0], 8.0)
    joint, log_evidence = p.product(q)
    pts, w = sphere_grid()
    integral = np.sum(w * np.exp(p.log_pdf(pts) + q.log_pdf(pts)))
    assert abs(log_evidence - np.log(integral)) < 1e-12
    assert np.sum(w * np.exp(joint.log_pdf(pts))) == pytest.approx(1.0, abs=1e-12)
    assert p.log_normaliser() == pytest.approx(np.log(4 * np.pi * np.sinh(3.0) / 3.0), rel=1e-14)
    eta, h = p.natural, 1e-6
    numeric = [
        (VonMisesFisher.from_natural(eta + h * e).log_normaliser() - VonMisesFisher.from_natural(eta - h * e).log_normaliser())
        / (2 * h)
        for e in np.eye(3)
    ]
    np.testing.assert_allclose(p.log_normaliser_gradient(), numeric, atol=1e-8)
    np.testing.assert_allclose(p.mean, [1.0, 0.0, 0.0])
    assert VonMisesFisher.uniform().mean is None
    assert p.entropy() == pytest.approx(stats.vonmises_fisher([1.0, 0, 0], 3.0).entropy(), rel=1e-12)
    assert "VonMisesFisher(mean=[1.0, 0.0, 0.0], kappa=3.0)" == repr(p)


# ------------------------------------------------------------------------------------------------
# Bingham
# ------------------------------------------------------------------------------------------------


def s3_grid(n_eta=48, n_angle=64):
    """Hopf coordinates u = (cos e cos a, cos e sin a, sin e cos b, sin e sin b) with the uniform
    probability measure: Gauss-Legendre in e on [0, pi/2], trapezoid (spectral) in a and b."""
    x, wx = np.polynomial.legendre.leggauss(n_eta)
    eta = (x + 1) * np.pi / 4
    w_eta = wx * np.pi / 4 * np.sin(eta) * np.cos(eta)
    a = np.arange(n_angle) * 2 * np.pi / n_angle
    E, A, B = np.meshgrid(eta, a, a, indexing="ij")
    u = np.stack([np.cos(E) * np.cos(A), np.cos(E) * np.sin(A), np.sin(E) * np.cos(B), np.sin(E) * np.sin(B)], axis=-1)
    w = np.broadcast_to(w_eta[:, None, None], E.shape) * (2 * np.pi / n_angle) ** 2 / (2 * np.pi**2)
    return u.reshape(-1, 4), w.ravel()


Z = np.array([0.0, -1.5, -4.0, -9.0])


def test_bingham_normaliser_against_quadrature_on_s3():
    u, w = s3_grid()
    assert w.sum() == pytest.approx(1.0, abs=1e-13)
    brute = np.log(np.sum(w * np.exp((u**2) @ Z)))
    log_k, grad = bingham_log_normaliser(Z)
    assert abs(log_k - brute) < 1e-11
    # The gradient is the second moment along each axis.
    moments = np.sum(w[:, None] * u**2 * np.exp((u**2) @ Z - brute)[:, None], axis=0)
    np.testing.assert_allclose(grad, moments, atol=1e-11)
    # Wrong value: one eigenvalue 1 % off is visible.
    assert abs(bingham_log_normaliser(Z * np.array([1, 1, 1, 1.01]))[0] - brute) > 1e-3
    # The density with a random orientation integrates to one over S^3.
    v = random_orthogonal4(0)
    p = Bingham(v, Z + 3.0)
    assert np.sum(w * np.exp(p.log_pdf(u @ v.T))) == pytest.approx(1.0, abs=1e-11)
    assert p.log_normaliser() == pytest.approx(log_k + 3.0, abs=1e-12)
    assert p.log_normaliser_surface() == pytest.approx(p.log_normaliser() + np.log(2 * np.pi**2), abs=1e-14)


def test_bingham_gradient_against_finite_differences():
    z = np.array([0.0, -2.0, -7.0, -30.0])
    _, grad = bingham_log_normaliser(z)
    h = 1e-5
    numeric = [(bingham_log_normaliser(z + h * e)[0] - bingham_log_normaliser(z - h * e)[0]) / (2 * h) for e in np.eye(4)]
    np.testing.assert_allclose(grad, numeric, atol=1e-8)
    assert grad.sum() == pytest.approx(1.0, abs=1e-13)
    p = Bingham(np.eye(4), z[::-1])  # any order: sorted descending with the columns
    np.testing.assert_array_equal(p.eigenvalues, z)
    np.testing.assert_allclose(p.log_normaliser_gradient(), grad, atol=1e-15)
    np.testing.assert_allclose(p.orientation, np.eye(4)[:, ::-1])


def test_bingham_sampler_second_moment_and_fit():
    v = random_orthogonal4(1)
    p = Bingham(v, Z)
    q = p.sample(20000, np.random.default_rng(2))
    assert q.shape == (20000, 4)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-14)
    scatter = q.T @ q / len(q)
    m = p.second_moment()
    # Monte Carlo standard error of each entry, from the draws themselves.
    outer = q[:, :, None] * q[:, None, :]
    se = outer.std(axis=0) / np.sqrt(len(q))
    assert np.all(np.abs(scatter - m) < 5 * se + 1e-12)
    wrong = Bingham(v, Z * 1.3).second_moment()
    assert np.any(np.abs(scatter - wrong) > 5 * se)
    # The MLE from the exact second moment (eigenvectors weighted by their moments) recovers z.
    exact = Bingham.fit(v.T, p.log_normaliser_gradient())
    np.testing.assert_allclose(exact.eigenvalues, Z, atol=1e-8)
    fitted = Bingham.fit(q)
    np.testing.assert_allclose(fitted.eigenvalues, Z, atol=0.35)
    assert abs(np.abs(fitted.orientation[:, 0] @ v[:, 0]) - 1) < 1e-2


def test_bingham_product_and_accessors():
    a = Bingham(random_orthogonal4(3), [0.0, -1.0, -2.0, -3.0])
    b = Bingham(random_orthogonal4(4), [0.0, -4.0, -4.0, -5.0])
    joint, log_evidence = a.product(b)
    np.testing.assert_allclose(joint.natural, a.natural + b.natural, atol=1e-12)
    u, w = s3_grid(40, 48)
    assert log_evidence == pytest.approx(np.log(np.sum(w * np.exp(a.log_pdf(u) + b.log_pdf(u)))), abs=1e-11)
    mode = Bingham(np.eye(4), [0.0, -1, -1, -1]).mode
    np.testing.assert_array_equal(mode, [1.0, 0.0, 0.0, 0.0])
    assert Bingham.uniform().mode is None
    assert Bingham.from_natural(a.natural).log_normaliser() == pytest.approx(a.log_normaliser(), abs=1e-12)
    assert a.kl_divergence(a) == pytest.approx(0.0, abs=1e-12)
    assert a.log_pdf(mode) == a.log_pdf(-mode)
    assert repr(Bingham.uniform()) == "Bingham(eigenvalues=[0.0, 0.0, 0.0, 0.0])"


# ------------------------------------------------------------------------------------------------
# Heat kernel on SO(3)
# ------------------------------------------------------------------------------------------------


def so3_grid(center, n_t=48, n_c=16, n_phi=32):
    """Rotations center * exp(t n) with the normalised Haar measure (1 - cos t)/pi dt dn/(4 pi)."""
    x, wx = np.polynomial.legendre.leggauss(n_t)
    t = (x + 1) * np.pi / 2
    wt = wx * np.pi / 2 * (1 - np.cos(t)) / np.pi
    axes, wa = sphere_grid(n_c, n_phi)
    rotvec = (t[:, None, None] * axes[None, :, :]).reshape(-1, 3)
    weights = (wt[:, None] * wa[None, :] / (4 * np.pi)).ravel()
    return center @ Rotation.from_rotvec(rotvec).as_matrix(), weights


@pytest.mark.parametrize("s", [0.05, 0.6, 3.0])
def test_heat_kernel_integrates_to_one_over_so3(s):
    c = random_rotation(7)
    p = HeatKernelSo3(c, s)
    r, w = so3_grid(c)
    assert w.sum() == pytest.approx(1.0, abs=1e-13)
    assert np.sum(w * np.exp(p.log_pdf(r))) == pytest.approx(1.0, abs=1e-9)
    # Wrong model: another variance's kernel is not this one's density on the same grid.
    other = HeatKernelSo3(c, s * 1.5)
    assert np.max(np.abs(other.log_pdf(r) - p.log_pdf(r))) > 1e-2
    # The angle density integrates to one and its CDF agrees with its integral.
    x, wx = np.polynomial.legendre.leggauss(64)
    t = (x + 1) * np.pi / 2
    assert np.sum(wx * np.pi / 2 * p.angle_pdf(t)) == pytest.approx(1.0, abs=1e-9)
    assert p.angle_cdf(np.pi) == pytest.approx(1.0, abs=1e-12)


def test_heat_kernel_sampler_angle_law_and_moments():
    c = random_rotation(8)
    p = HeatKernelSo3(c, 0.2)
    r = p.sample(5000, np.random.default_rng(10))
    assert r.shape == (5000, 3, 3)
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", r, r), np.broadcast_to(np.eye(3), r.shape), atol=1e-13)
    angles = np.linalg.norm(Rotation.from_matrix(np.einsum("ji,njk->nik", c, r)).as_rotvec(), axis=1)
    assert stats.kstest(angles, p.angle_cdf).pvalue > 1e-3
    assert stats.kstest(angles, HeatKernelSo3(c, 0.26).angle_cdf).pvalue < 1e-6
    np.testing.assert_allclose(p.first_moment(), np.exp(-0.2) * c, atol=1e-14)
    np.testing.assert_allclose(p.mean, c, atol=1e-14)
    assert p.convolve(p).variance == pytest.approx(0.4, rel=1e-15)
    assert p.log_normaliser() == 0.0
    assert p.kl_divergence(p) == pytest.approx(0.0, abs=1e-12)


# ------------------------------------------------------------------------------------------------
# Manifold Gaussians
# ------------------------------------------------------------------------------------------------

P3 = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, -0.02], [0.0, -0.02, 0.02]])


def test_manifold_gaussian_so3_against_numpy_and_scipy():
    m = random_rotation(12)
    g = ManifoldGaussianSo3(m, P3)
    r = Rotation.random(100, random_state=13).as_matrix()
    r = np.concatenate([m @ Rotation.from_rotvec(np.random.default_rng(1).normal(scale=0.2, size=(100, 3))).as_matrix(), r])
    delta = Rotation.from_matrix(np.einsum("ji,njk->nik", m, r)).as_rotvec()
    ref = stats.multivariate_normal(np.zeros(3), P3).logpdf(delta)
    np.testing.assert_allclose(g.log_pdf(r), ref, rtol=1e-11, atol=1e-11)
    d2 = np.einsum("ni,ij,nj->n", delta, np.linalg.inv(P3), delta)
    np.testing.assert_allclose(g.mahalanobis_squared(r), d2, rtol=1e-10)
    x = g.sample(20000, np.random.default_rng(14))
    d = Rotation.from_matrix(np.einsum("ji,njk->nik", m, x)).as_rotvec()
    cov = d.T @ d / len(d)
    assert np.max(np.abs(cov - P3)) < 0.003
    assert np.max(np.abs(cov - 1.2 * P3)) > 0.006
    assert g.log_normaliser() == pytest.approx(0.5 * (3 * np.log(2 * np.pi) + np.log(np.linalg.det(P3))), rel=1e-13)
    np.testing.assert_allclose(g.covariance, P3)
    assert g.kl_divergence(g) == pytest.approx(0.0, abs=1e-14)
    assert g.compose(g).covariance.shape == (3, 3)


def test_manifold_gaussian_fits_against_scipy_residuals():
    m = random_rotation(15)
    x = ManifoldGaussianSo3(m, P3).sample(20000, np.random.default_rng(16))
    fit = ManifoldGaussianSo3.fit(x)
    # scipy's residuals at the fitted mean average to zero, and their scatter is the covariance.
    d = Rotation.from_matrix(np.einsum("ji,njk->nik", fit.mean, x)).as_rotvec()
    np.testing.assert_allclose(d.mean(axis=0), 0.0, atol=1e-10)
    np.testing.assert_allclose(fit.covariance, d.T @ d / len(d), rtol=1e-9, atol=1e-14)
    assert np.max(np.abs(fit.covariance - P3)) < 0.003
    assert np.max(np.abs(fit.covariance - 1.2 * P3)) > 0.006
    w = np.arange(200) % 3
    a = ManifoldGaussianSo3.fit(x[:200], w)
    b = ManifoldGaussianSo3.fit(np.repeat(x[:200], w, axis=0))
    np.testing.assert_allclose(a.covariance, b.covariance, rtol=1e-9)
    with pytest.raises(ValueError, match="samples"):
        ManifoldGaussianSo3.fit(x[:, :2])
    with pytest.raises(ValueError):
        ManifoldGaussianSo3.fit(x[:2])  # two rotations: a singular covariance
    mu = np.array([0.0, 0.6, 0.8])
    s2 = ManifoldGaussianS2(mu, np.array([[0.02, 0.005], [0.005, 0.01]]))
    y = s2.sample(20000, np.random.default_rng(17))
    fit2 = ManifoldGaussianS2.fit(y)
    assert np.degrees(np.arccos(min(1.0, fit2.mean @ mu))) < 0.2
    np.testing.assert_allclose(fit2.covariance, s2.covariance, atol=0.001)


def test_manifold_gaussian_s2_against_numpy():
    mu = np.array([0.6, 0.0, -0.8])
    p2 = np.array([[0.02, 0.005], [0.005, 0.01]])
    g = ManifoldGaussianS2(mu, p2)
    b = g.tangent_basis()
    np.testing.assert_allclose(np.cross(b[:, 0], b[:, 1]), mu, atol=1e-15)
    x = stats.vonmises_fisher(mu, 30.0).rvs(200, random_state=3)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    cos = np.clip(x @ mu, -1, 1)
    perp = x - cos[:, None] * mu
    log_map = perp / np.linalg.norm(perp, axis=1, keepdims=True) * np.arccos(cos)[:, None]
    delta = log_map @ b
    ref = stats.multivariate_normal(np.zeros(2), p2).logpdf(delta)
    np.testing.assert_allclose(g.log_pdf(x), ref, rtol=1e-9, atol=1e-9)
    draws = g.sample(20000, np.random.default_rng(15))
    np.testing.assert_allclose(np.linalg.norm(draws, axis=1), 1.0, atol=1e-14)
    cos = np.clip(draws @ mu, -1, 1)
    perp = draws - cos[:, None] * mu
    d = (perp / np.linalg.norm(perp, axis=1, keepdims=True) * np.arccos(cos)[:, None]) @ b
    cov = d.T @ d / len(d)
    assert np.max(np.abs(cov - p2)) < 1e-3
    assert np.max(np.abs(cov - 1.3 * p2)) > 2e-3


# ------------------------------------------------------------------------------------------------
# Bad input: every case raises, none crashes
# ------------------------------------------------------------------------------------------------

ROT = np.eye(3)
GEN = np.random.default_rng(0)

BAD = [
    lambda: VonMises(0.0, -1.0),
    lambda: VonMises(0.0, float("nan")),
    lambda: VonMises(float("nan"), 1.0),
    lambda: VonMises(0.0, float("inf")),
    lambda: VonMises(0.0, 2e300),
    lambda: VonMises.from_natural([1.0, 2.0, 3.0]),
    lambda: VonMises(0, 1).log_pdf([0.0, float("nan")]),
    lambda: VonMises(0, 1).sample(-1, GEN),
    # Found by tools/python_fuzz.py: 2^31 draws ran for minutes and wrote 16 GB; refused now.
    lambda: VonMises(0, 1).sample(2**31, GEN),
    lambda: HeatKernelSo3(ROT, 0.1).sample(2**28 // 9 + 1, GEN),
    lambda: VonMises.fit([]),
    lambda: VonMises.fit([0.0, 1.0], [1.0, -1.0]),
    lambda: VonMises.fit([0.0, 1.0], [1.0, 1.0, 1.0]),
    lambda: VonMises.fit([0.0, 1.0], [0.0, 0.0]),
    lambda: VonMisesFisher([0.0, 0.0, 2.0], 1.0),
    lambda: VonMisesFisher([0.0, 0.0, 1.0], -1.0),
    lambda: VonMisesFisher([0.0, 1.0], 1.0),
    lambda: VonMisesFisher([float("nan"), 0.0, 1.0], 1.0),
    lambda: VonMisesFisher([0, 0, 1.0], 1.0).log_pdf(np.zeros((5, 2))),
    lambda: VonMisesFisher([0, 0, 1.0], 1.0).log_pdf([[0, 0, 1.0], [0, 0, 1.1]]),
    lambda: Bingham(2 * np.eye(4), Z),
    lambda: Bingham(np.eye(4), [0.0, 0.0, 0.0, -2e12]),
    lambda: Bingham(np.eye(3), Z),
    lambda: Bingham(np.eye(4), [0.0, 0.0, float("nan"), 0.0]),
    lambda: Bingham.from_natural(np.arange(16.0).reshape(4, 4)),
    lambda: Bingham(np.eye(4), [0.0, 0, 0, -6e11]).product(Bingham(np.eye(4), [0.0, 0, 0, -6e11])),
    lambda: Bingham(np.eye(4), Z).log_pdf([1.0, 0.0, 0.0, 0.5]),
    lambda: Bingham.fit(np.zeros((0, 4))),
    lambda: Bingham.fit(np.tile([1.0, 0, 0, 0], (5, 1))),
    lambda: bingham_log_normaliser([0.0, 0.0, 0.0, float("nan")]),
    lambda: bingham_log_normaliser([0.0, 0.0, 0.0]),
    lambda: HeatKernelSo3(2 * ROT, 0.1),
    lambda: HeatKernelSo3(np.diag([1.0, 1.0, -1.0]), 0.1),
    lambda: HeatKernelSo3(ROT, 0.0),
    lambda: HeatKernelSo3(ROT, float("nan")),
    lambda: HeatKernelSo3(ROT, 0.1).angle_pdf([0.5, 4.0]),
    lambda: HeatKernelSo3(ROT, 0.1).log_pdf(np.zeros((2, 3, 3))),
    lambda: HeatKernelSo3(ROT, 0.1).log_pdf(np.eye(4)),
    lambda: ManifoldGaussianSo3(ROT, -np.eye(3)),
    lambda: ManifoldGaussianSo3(ROT, np.array([[1.0, 0.5, 0], [0, 1, 0], [0, 0, 1]])),
    lambda: ManifoldGaussianSo3(ROT, np.eye(2)),
    lambda: ManifoldGaussianS2([0.0, 0.0, 0.9], np.eye(2)),
    lambda: ManifoldGaussianS2([0.0, 0.0, 1.0], np.full((2, 2), float("nan"))),
]


@pytest.mark.parametrize("case", range(len(BAD)))
def test_bad_input_raises_value_error(case):
    with pytest.raises(ValueError):
        BAD[case]()


def test_error_messages_carry_the_library_message_and_the_index():
    with pytest.raises(ValueError, match="unit norm"):
        VonMisesFisher([0.0, 0.0, 2.0], 1.0)
    with pytest.raises(ValueError, match=r"x\[1\].*unit norm"):
        VonMisesFisher([0, 0, 1.0], 1.0).log_pdf([[0, 0, 1.0], [0, 0, 1.1]])
    with pytest.raises(ValueError, match="concentration"):
        VonMises(0.0, -1.0)
    with pytest.raises(ValueError, match="spread"):
        Bingham(np.eye(4), [0.0, 0.0, 0.0, -2e12])
    with pytest.raises(ValueError, match=r"expected an array of shape \(3, 3\) or \(\.\.\., 3, 3\)"):
        HeatKernelSo3(ROT, 0.1).log_pdf(np.eye(4))


def test_values_that_are_not_real_numbers_raise_type_error():
    # Strings, booleans and complex numbers are refused, not cast (a complex array lost its
    # imaginary part in the filters before tools/python_fuzz.py found it).
    for bad in ("a string", ["0.5", "1"], [True, False], np.array([1.0 + 0j, 2.0])):
        with pytest.raises(TypeError, match="real numbers"):
            VonMises(0, 1).log_pdf(bad)
    from liebayes import filters

    azimuth = filters.ExactAzimuthFilter(0.1, 1.0)
    for bad in (np.array([1.0 + 1j, 2.0]), ["1", "2"], np.array([True, False])):
        with pytest.raises(TypeError, match="real numbers"):
            azimuth.update(bad)
    with pytest.raises(TypeError, match="real numbers"):
        filters.score_aoa(np.zeros((1, 2, 3)), np.zeros((1, 2, 3)) + 0j, np.zeros((1, 2, 3, 3)))


def test_bools_complex_and_one_element_arrays_are_not_real_numbers():
    # pyo3 read anything with __float__ or __index__ as a float: True as a concentration of 1, a
    # numpy complex with its imaginary part dropped, an array of one element as its element.
    for bad in (True, np.bool_(False), np.complex128(0.1 + 1j), 1 + 0j, np.array([1.0]),
                np.array(True), "1.0", None):
        with pytest.raises(TypeError, match="real number"):
            VonMises(0.0, bad)
        with pytest.raises(TypeError, match="real number"):
            VonMises(bad, 1.0)
    with pytest.raises(TypeError, match="real number"):
        VonMisesFisher([0.0, 0.0, 1.0], True)
    with pytest.raises(TypeError, match="real number"):
        HeatKernelSo3(ROT, np.array([0.1]))
    with pytest.raises(TypeError, match="real number"):
        Bingham.from_direction([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], np.complex128(0.1))
    # Python and numpy integers and floats, and 0-d arrays of them, are real numbers.
    reference = VonMises(0.5, 2.0).log_pdf(0.3)
    for mu, kappa in ((np.float32(0.5), np.int64(2)), (np.float64(0.5), 2), (np.array(0.5),
                      np.array(2, dtype=np.uint8))):
        assert VonMises(mu, kappa).log_pdf(0.3) == reference
    assert HeatKernelSo3(ROT, np.float32(0.25)).variance == 0.25


def test_a_refused_sample_call_draws_nothing_from_the_generator():
    # The seed used to be drawn before n was checked: a refused call advanced the generator.
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="2\\^28"):
        VonMisesFisher.uniform().sample(100_000_000, rng)
    with pytest.raises(ValueError, match="non-negative"):
        VonMises(0.0, 1.0).sample(-1, rng)
    assert rng.integers(0, 2**63) == np.random.default_rng(0).integers(0, 2**63)


def test_rng_must_be_a_numpy_generator():
    for rng in (42, np.random.RandomState(0), None):
        with pytest.raises(TypeError, match="numpy.random.Generator"):
            VonMises(0.0, 1.0).sample(3, rng)


def test_inputs_numpy_converts_and_strided_views_are_accepted():
    p = VonMisesFisher([0, 0, 1.0], 2.0)
    x = np.array([[0, 0, 1], [1, 0, 0]])  # integers
    np.testing.assert_allclose(p.log_pdf(x), p.log_pdf(x.astype(float)))
    wide = np.zeros((4, 6))
    wide[:, ::2] = [0, 0, 1.0]
    np.testing.assert_allclose(p.log_pdf(wide[:, ::2]), p.log_pdf(np.tile([0, 0, 1.0], (4, 1))))
    assert p.log_pdf(np.zeros((0, 3))).shape == (0,)


def test_read_only_fortran_and_byte_swapped_arrays_give_the_same_values():
    p = HeatKernelSo3(random_rotation(20), 0.3)
    r = p.sample(50, np.random.default_rng(21))
    ref = p.log_pdf(r)
    np.testing.assert_array_equal(p.log_pdf(np.asfortranarray(r)), ref)
    np.testing.assert_array_equal(p.log_pdf(r.astype(">f8")), ref)
    frozen = r.copy()
    frozen.flags.writeable = False
    np.testing.assert_array_equal(p.log_pdf(frozen), ref)
    # A broadcast view (stride 0) of one point.
    np.testing.assert_array_equal(p.log_pdf(np.broadcast_to(r[0], (7, 3, 3))), np.full(7, ref[0]))


def test_log_pdf_from_several_threads_matches_the_serial_values():
    from concurrent.futures import ThreadPoolExecutor

    p = VonMisesFisher([0.0, 0.0, 1.0], 4.0)
    chunks = [p.sample(50_000, np.random.default_rng(s)) for s in range(4)]
    serial = [p.log_pdf(c) for c in chunks]
    with ThreadPoolExecutor(4) as pool:
        parallel = list(pool.map(p.log_pdf, chunks))
    for a, b in zip(serial, parallel):
        np.testing.assert_array_equal(a, b)
