"""Tests of liebayes.manifolds against independent references.

References: scipy.spatial.transform.Rotation (SO(3), quaternions), scipy.linalg.expm/logm of the 4x4
algebra matrix (SE(3)), Hamilton products and sphere geometry written out in numpy, and central
differences for every Jacobian. Seeds are fixed; tolerances are stated against the size of the
quantities compared.
"""

import numpy as np
import pytest
from scipy.linalg import expm, logm
from scipy.spatial.transform import Rotation

from liebayes.manifolds import S2, Se3, So3, UnitQuaternion

EPS = np.finfo(float).eps


def rotation_vectors(n, seed, max_angle=3.0):
    """Random rotation vectors with angles spread over (0, max_angle), plus edge sizes."""
    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = rng.uniform(0.0, max_angle, size=n)
    # Tiny angles, both sides of the library's series threshold 1e-2, and near pi.
    edge = np.array([0.0, 1e-12, 1e-6, 9.99e-3, 1.001e-2, 0.5, max_angle])
    angles[: len(edge)] = edge[: min(len(edge), n)]
    return axes * angles[:, None]


def random_rotations(n, seed):
    return Rotation.from_rotvec(rotation_vectors(n, seed)).as_matrix()


def random_poses(n, seed):
    rng = np.random.default_rng(seed)
    t = np.tile(np.eye(4), (n, 1, 1))
    t[:, :3, :3] = random_rotations(n, seed + 1)
    t[:, :3, 3] = rng.normal(scale=2.0, size=(n, 3))
    return t


def skew(w):
    """Cross-product matrices written out (independent of the library's hat)."""
    w = np.asarray(w)
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -w[..., 2], w[..., 1]
    out[..., 1, 0], out[..., 1, 2] = w[..., 2], -w[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -w[..., 1], w[..., 0]
    return out


def twist_matrix(xi):
    """The se(3) matrix [[hat(phi), rho], [0, 0]] of xi = [rho; phi]."""
    m = np.zeros((4, 4))
    m[:3, :3] = skew(xi[3:])
    m[:3, 3] = xi[:3]
    return m


def twist_vector(m):
    return np.concatenate([m[:3, 3], [m[2, 1], m[0, 2], m[1, 0]]])


def central_difference(f, x, h=1e-6):
    """Jacobian of f at x (columns: derivative along each coordinate of x)."""
    cols = []
    for j in range(len(x)):
        e = np.zeros(len(x))
        e[j] = h
        cols.append((f(x + e) - f(x - e)) / (2 * h))
    return np.stack(cols, axis=1)


def hamilton(p, q):
    """Hamilton product of scalar-first quaternions, written out."""
    w1, x1, y1, z1 = np.moveaxis(p, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=-1,
    )


def canonical(q):
    """Quaternions with w >= 0 (the representative of a rotation)."""
    return np.where(q[..., :1] < 0, -q, q)


# ----------------------------------------------------------------------------------------------
# SO(3) against scipy's Rotation
# ----------------------------------------------------------------------------------------------


def test_so3_exp_log_match_scipy_rotvec():
    w = rotation_vectors(500, 1)
    r = So3.exp(w)
    assert r.shape == (500, 3, 3) and r.dtype == np.float64
    np.testing.assert_allclose(r, Rotation.from_rotvec(w).as_matrix(), rtol=0, atol=8 * EPS)
    back = So3.log(r)
    np.testing.assert_allclose(back, w, rtol=0, atol=1e-13)
    np.testing.assert_allclose(back, Rotation.from_matrix(r).as_rotvec(), rtol=0, atol=1e-13)


def test_so3_single_element_shapes_and_lists():
    w = [0.1, -0.2, 0.3]
    r = So3.exp(w)
    assert r.shape == (3, 3)
    assert So3.log(r).shape == (3,)
    assert isinstance(So3.distance(r, np.eye(3)), float)
    np.testing.assert_allclose(So3.distance(r, np.eye(3)), np.linalg.norm(w), rtol=1e-14)
    assert So3.exp(np.zeros((0, 3))).shape == (0, 3, 3)
    # Integer, Fortran-ordered and strided inputs read as the same numbers.
    np.testing.assert_array_equal(So3.exp(np.array([1, 0, 0])), So3.exp([1.0, 0.0, 0.0]))
    big = rotation_vectors(10, 2)
    np.testing.assert_array_equal(So3.exp(big[::2]), So3.exp(big)[::2])
    np.testing.assert_array_equal(So3.exp(np.asfortranarray(big)), So3.exp(big))
    np.testing.assert_array_equal(So3.exp(big.astype(">f8")), So3.exp(big))
    np.testing.assert_array_equal(So3.exp(big.astype(np.float32)), So3.exp(big.astype(np.float32).astype(float)))
    raw = np.zeros(big.size * 8 + 1, dtype=np.uint8)
    misaligned = np.frombuffer(raw.data, dtype=np.float64, offset=1, count=big.size).reshape(big.shape)
    misaligned[...] = big
    assert not misaligned.flags.aligned
    np.testing.assert_array_equal(So3.exp(misaligned), So3.exp(big))
    frozen = big.copy()
    frozen.flags.writeable = False
    np.testing.assert_array_equal(So3.exp(frozen), So3.exp(big))
    mats = So3.exp(big)
    np.testing.assert_array_equal(So3.log(mats.transpose(0, 2, 1)), So3.log(np.ascontiguousarray(mats.transpose(0, 2, 1))))


def test_so3_near_pi_log_is_accurate():
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    for angle in [np.pi - 1e-9, np.pi - 1e-6, np.pi]:
        r = Rotation.from_rotvec(axis * angle).as_matrix()
        w = So3.log(r)
        assert abs(np.linalg.norm(w) - angle) < 1e-12
        # At pi both signs are logarithms: compare the rotations.
        np.testing.assert_allclose(So3.exp(w), r, atol=1e-14)


def test_so3_quaternions_match_scipy_scalar_first():
    r = random_rotations(300, 3)
    q = So3.to_quaternion(r)
    expected = canonical(Rotation.from_matrix(r).as_quat(scalar_first=True))
    np.testing.assert_allclose(q, expected, rtol=0, atol=1e-15)
    assert np.all(q[:, 0] >= 0)
    qs = Rotation.random(300, random_state=4).as_quat(scalar_first=True)
    np.testing.assert_allclose(
        So3.from_quaternion(qs), Rotation.from_quat(qs, scalar_first=True).as_matrix(), atol=1e-15
    )
    # q and -q are one rotation.
    np.testing.assert_array_equal(So3.from_quaternion(-qs), So3.from_quaternion(qs))


def test_so3_compose_inverse_act_match_scipy():
    a, b = random_rotations(200, 5), random_rotations(200, 6)
    ra, rb = Rotation.from_matrix(a), Rotation.from_matrix(b)
    np.testing.assert_allclose(So3.compose(a, b), (ra * rb).as_matrix(), atol=1e-15)
    np.testing.assert_allclose(So3.compose(a, b), a @ b, atol=1e-15)
    np.testing.assert_allclose(So3.inverse(a), ra.inv().as_matrix(), atol=1e-15)
    v = np.random.default_rng(7).normal(size=(200, 3)) * 10
    np.testing.assert_allclose(So3.act(a, v), ra.apply(v), atol=1e-13)
    # Broadcasting a single element against a batch, either side.
    np.testing.assert_allclose(So3.compose(a[0], b), a[0] @ b, atol=1e-15)
    np.testing.assert_allclose(So3.compose(a, b[0]), a @ b[0], atol=1e-15)
    np.testing.assert_allclose(So3.act(a, v[0]), ra.apply(v[0]), atol=1e-13)
    np.testing.assert_allclose(So3.act(a[3], v), Rotation.from_matrix(a[3]).apply(v), atol=1e-13)
    # Group laws on the batch.
    np.testing.assert_allclose(So3.compose(a, So3.inverse(a)), np.tile(np.eye(3), (200, 1, 1)), atol=1e-15)
    c = random_rotations(200, 8)
    np.testing.assert_allclose(
        So3.compose(So3.compose(a, b), c), So3.compose(a, So3.compose(b, c)), atol=1e-14
    )


def test_so3_retract_local_distance():
    a, b = random_rotations(100, 9), random_rotations(100, 10)
    d = So3.local(a, b)
    np.testing.assert_allclose(d, (Rotation.from_matrix(a).inv() * Rotation.from_matrix(b)).as_rotvec(), atol=1e-13)
    np.testing.assert_allclose(So3.retract(a, d), b, atol=1e-14)
    np.testing.assert_allclose(So3.distance(a, b), np.linalg.norm(d, axis=1), atol=1e-13)
    np.testing.assert_allclose(
        So3.distance(a, b), (Rotation.from_matrix(a).inv() * Rotation.from_matrix(b)).magnitude(), atol=1e-13
    )


def test_so3_orthonormalize_projects_drifted_matrices():
    r = random_rotations(50, 11)
    noisy = r + 1e-6 * np.random.default_rng(12).normal(size=r.shape)
    with pytest.raises(ValueError, match=r"r\[0\]: the rotation matrix is not orthonormal"):
        So3.log(noisy)
    fixed = So3.orthonormalize(noisy)
    # The polar factor U V^T of the SVD, computed by numpy.
    u, _, vt = np.linalg.svd(noisy)
    np.testing.assert_allclose(fixed, u @ vt, atol=1e-14)
    with pytest.raises(ValueError, match=r"m\[0\]: .*determinant"):
        So3.orthonormalize(-r)


# ----------------------------------------------------------------------------------------------
# SO(3) Jacobians against central differences
# ----------------------------------------------------------------------------------------------


def exp_ref(w):
    return Rotation.from_rotvec(w).as_matrix()


def log_ref(r):
    return Rotation.from_matrix(r).as_rotvec()


def test_so3_jacobians_match_central_differences():
    for w in rotation_vectors(8, 13, max_angle=2.8):
        r = exp_ref(w)
        jr = central_difference(lambda x: log_ref(r.T @ exp_ref(x)), w)
        jl = central_difference(lambda x: log_ref(exp_ref(x) @ r.T), w)
        np.testing.assert_allclose(So3.right_jacobian(w), jr, atol=1e-8)
        np.testing.assert_allclose(So3.left_jacobian(w), jl, atol=1e-8)
        # Inverses: log(exp(w) exp(d)) = w + Jr^-1 d, log(exp(d) exp(w)) = w + Jl^-1 d.
        jri = central_difference(lambda d: log_ref(r @ exp_ref(d)), np.zeros(3))
        jli = central_difference(lambda d: log_ref(exp_ref(d) @ r), np.zeros(3))
        np.testing.assert_allclose(So3.right_jacobian_inverse(w), jri, atol=1e-8)
        np.testing.assert_allclose(So3.left_jacobian_inverse(w), jli, atol=1e-8)
    w = rotation_vectors(100, 14)
    np.testing.assert_allclose(
        So3.right_jacobian(w) @ So3.right_jacobian_inverse(w), np.tile(np.eye(3), (100, 1, 1)), atol=1e-12
    )
    np.testing.assert_allclose(So3.left_jacobian(w), So3.right_jacobian(-w), atol=1e-15)


def test_so3_adjoint_hat_vee_and_action_jacobian():
    r = random_rotations(20, 15)
    w = rotation_vectors(20, 16)
    ad = So3.adjoint(r)
    # R exp(w) R^T = exp(Ad w)
    lhs = r @ exp_ref(w) @ r.transpose(0, 2, 1)
    np.testing.assert_allclose(exp_ref(np.einsum("nij,nj->ni", ad, w)), lhs, atol=1e-14)
    v = np.random.default_rng(17).normal(size=(20, 3))
    np.testing.assert_allclose(So3.hat(w) @ v[..., None], np.cross(w, v)[..., None], atol=1e-15)
    np.testing.assert_allclose(So3.vee(So3.hat(w)), w, atol=0)
    j = So3.act_jacobian(r, v)
    for k in range(5):
        num = central_difference(lambda d: r[k] @ exp_ref(d) @ v[k], np.zeros(3))
        np.testing.assert_allclose(j[k], num, atol=1e-8)


# ----------------------------------------------------------------------------------------------
# Unit quaternions
# ----------------------------------------------------------------------------------------------


def test_quaternion_exp_log_compose_act_match_scipy():
    w = rotation_vectors(300, 18)
    q = UnitQuaternion.exp(w)
    # Below pi, w = cos(theta/2) > 0: scipy's from_rotvec gives the same representative.
    np.testing.assert_allclose(q, Rotation.from_rotvec(w).as_quat(scalar_first=True), atol=2 * EPS)
    np.testing.assert_allclose(UnitQuaternion.log(q), w, atol=1e-13)
    p = UnitQuaternion.exp(rotation_vectors(300, 19))
    np.testing.assert_allclose(UnitQuaternion.compose(p, q), hamilton(p, q), atol=4 * EPS)
    rp, rq = Rotation.from_quat(p, scalar_first=True), Rotation.from_quat(q, scalar_first=True)
    np.testing.assert_allclose(
        canonical(UnitQuaternion.compose(p, q)), canonical((rp * rq).as_quat(scalar_first=True)), atol=1e-15
    )
    np.testing.assert_allclose(UnitQuaternion.inverse(q), q * [1, -1, -1, -1], atol=0)
    v = np.random.default_rng(20).normal(size=(300, 3))
    np.testing.assert_allclose(UnitQuaternion.act(q, v), rq.apply(v), atol=1e-14)
    np.testing.assert_allclose(UnitQuaternion.to_matrix(q), rq.as_matrix(), atol=1e-15)
    np.testing.assert_allclose(UnitQuaternion.from_matrix(rq.as_matrix()), canonical(q), atol=1e-15)


def test_quaternion_log_covers_angles_up_to_two_pi():
    # SU(2) is the double cover: exp is injective up to 2 pi, and -q is a different point.
    w = rotation_vectors(200, 21, max_angle=6.2)
    q = UnitQuaternion.exp(w)
    np.testing.assert_allclose(UnitQuaternion.log(q), w, atol=1e-12)
    angles = np.linalg.norm(UnitQuaternion.log(-q), axis=1)
    np.testing.assert_allclose(angles, 2 * np.pi - np.linalg.norm(w, axis=1), atol=1e-12)


def test_quaternion_normalize_and_tolerance():
    q = np.array([[2.0, 0.0, 0.0, 0.0], [1.0, 2.0, -3.0, 4.0]])
    np.testing.assert_allclose(UnitQuaternion.normalize(q), q / np.linalg.norm(q, axis=1, keepdims=True), rtol=2 * EPS)
    # Within the library's tolerance (|norm - 1| <= 1e-9) is accepted, beyond is refused by index.
    ok = np.array([[1.0 + 1e-12, 0, 0, 0]])
    UnitQuaternion.log(ok)
    bad = np.tile([1.0, 0.0, 0.0, 0.0], (4, 1))
    bad[3, 0] = 1.0 + 1e-8
    with pytest.raises(ValueError, match=r"q\[3\]: quaternion must have unit norm"):
        UnitQuaternion.log(bad)
    with pytest.raises(ValueError, match=r"q: .*too close to zero"):
        UnitQuaternion.normalize([0.0, 0.0, 0.0, 0.0])


# ----------------------------------------------------------------------------------------------
# S2
# ----------------------------------------------------------------------------------------------


def unit_vectors(n, seed):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_s2_exp_log_distance_against_sphere_geometry():
    x, y = unit_vectors(300, 22), unit_vectors(300, 23)
    w = S2.log(x, y)
    cos = np.sum(x * y, axis=1)
    angle = np.arctan2(np.linalg.norm(np.cross(x, y), axis=1), cos)
    np.testing.assert_allclose(np.linalg.norm(w, axis=1), angle, atol=1e-14)
    np.testing.assert_allclose(np.sum(w * x, axis=1), 0, atol=1e-14)
    np.testing.assert_allclose(S2.exp(x, w), y, atol=1e-14)
    np.testing.assert_allclose(S2.distance(x, y), angle, atol=1e-14)
    # exp written out: cos|w| x + sin|w| w/|w| for tangent w.
    rng = np.random.default_rng(24)
    t = rng.normal(size=(300, 3))
    t -= np.sum(t * x, axis=1, keepdims=True) * x
    n = np.linalg.norm(t, axis=1, keepdims=True)
    np.testing.assert_allclose(S2.exp(x, t), np.cos(n) * x + np.sin(n) * t / n, atol=1e-14)
    assert isinstance(S2.distance(x[0], y[0]), float)


def test_s2_basis_retract_local():
    x = unit_vectors(300, 25)
    b = S2.tangent_basis(x)
    assert b.shape == (300, 3, 2)
    np.testing.assert_allclose(b.transpose(0, 2, 1) @ b, np.tile(np.eye(2), (300, 1, 1)), atol=1e-15)
    np.testing.assert_allclose(np.cross(b[:, :, 0], b[:, :, 1]), x, atol=1e-15)
    u = np.random.default_rng(26).uniform(-2, 2, size=(300, 2))
    y = S2.retract(x, u)
    np.testing.assert_allclose(y, S2.exp(x, np.einsum("nij,nj->ni", b, u)), atol=1e-15)
    np.testing.assert_allclose(S2.local(x, y), u, atol=1e-13)
    np.testing.assert_allclose(S2.local(x, y), np.einsum("nji,nj->ni", b, S2.log(x, y)), atol=1e-14)
    np.testing.assert_allclose(S2.normalize(3.0 * x), x, atol=1e-15)


# ----------------------------------------------------------------------------------------------
# SE(3)
# ----------------------------------------------------------------------------------------------


def twists(n, seed):
    rng = np.random.default_rng(seed)
    return np.concatenate([rng.normal(scale=2.0, size=(n, 3)), rotation_vectors(n, seed)], axis=1)


def test_se3_exp_matches_expm_of_the_algebra_matrix():
    xi = twists(100, 27)
    t = Se3.exp(xi)
    assert t.shape == (100, 4, 4)
    expected = np.stack([expm(twist_matrix(v)) for v in xi])
    np.testing.assert_allclose(t, expected, atol=1e-13)
    np.testing.assert_allclose(Se3.hat(xi), np.stack([twist_matrix(v) for v in xi]), atol=0)
    np.testing.assert_allclose(Se3.vee(Se3.hat(xi)), xi, atol=0)
    np.testing.assert_allclose(Se3.log(t), xi, atol=1e-12)
    # A single element.
    np.testing.assert_allclose(Se3.exp(xi[0]), expected[0], atol=1e-13)


def test_se3_group_operations_and_action():
    a, b = random_poses(100, 28), random_poses(100, 29)
    np.testing.assert_allclose(Se3.compose(a, b), a @ b, atol=1e-13)
    np.testing.assert_allclose(Se3.inverse(a), np.linalg.inv(a), atol=1e-13)
    p = np.random.default_rng(30).normal(size=(100, 3))
    expected = np.einsum("nij,nj->ni", a[:, :3, :3], p) + a[:, :3, 3]
    np.testing.assert_allclose(Se3.act(a, p), expected, atol=1e-13)
    np.testing.assert_allclose(Se3.from_rotation_translation(a[:, :3, :3], a[:, :3, 3]), a, atol=0)
    d = Se3.local(a, b)
    np.testing.assert_allclose(Se3.retract(a, d), b, atol=1e-12)
    np.testing.assert_allclose(d, Se3.log(np.linalg.inv(a) @ b), atol=1e-12)


def test_se3_adjoint_and_jacobians_match_numerics():
    xi = twists(6, 31)
    for v in xi:
        t = expm(twist_matrix(v))
        t_inv = np.linalg.inv(t)
        jr = central_difference(lambda x: twist_vector(np.real(logm(t_inv @ expm(twist_matrix(x))))), v)
        jl = central_difference(lambda x: twist_vector(np.real(logm(expm(twist_matrix(x)) @ t_inv))), v)
        np.testing.assert_allclose(Se3.right_jacobian(v), jr, atol=1e-7)
        np.testing.assert_allclose(Se3.left_jacobian(v), jl, atol=1e-7)
    np.testing.assert_allclose(
        Se3.right_jacobian(xi) @ Se3.right_jacobian_inverse(xi), np.tile(np.eye(6), (6, 1, 1)), atol=1e-12
    )
    np.testing.assert_allclose(
        Se3.left_jacobian(xi) @ Se3.left_jacobian_inverse(xi), np.tile(np.eye(6), (6, 1, 1)), atol=1e-12
    )
    poses = random_poses(6, 32)
    ad = Se3.adjoint(poses)
    w = twists(6, 33) * 0.3
    for k in range(6):
        lhs = poses[k] @ twist_matrix(w[k]) @ np.linalg.inv(poses[k])
        np.testing.assert_allclose(twist_vector(lhs), ad[k] @ w[k], atol=1e-13)
        np.testing.assert_allclose(lhs[3], 0, atol=1e-15)
    p = np.random.default_rng(34).normal(size=(6, 3))
    j = Se3.act_jacobian(poses, p)
    assert j.shape == (6, 3, 6)
    for k in range(6):
        num = central_difference(lambda d: (poses[k] @ expm(twist_matrix(d)) @ np.append(p[k], 1.0))[:3], np.zeros(6))
        np.testing.assert_allclose(j[k], num, atol=1e-8)


# ----------------------------------------------------------------------------------------------
# Wrong references must not match (the checks above can fail)
# ----------------------------------------------------------------------------------------------


def test_wrong_conventions_are_detected():
    w = rotation_vectors(50, 35)[7:]  # angles well away from zero
    # Passive rotations (the transpose) are not what exp returns.
    assert not np.allclose(So3.exp(w), Rotation.from_rotvec(w).as_matrix().transpose(0, 2, 1), atol=1e-6)
    # Scalar-last quaternions are not the library's order.
    assert not np.allclose(UnitQuaternion.exp(w), Rotation.from_rotvec(w).as_quat(), atol=1e-6)
    # Composition applies the right factor first: b @ a differs.
    a, b = random_rotations(50, 36), random_rotations(50, 37)
    assert not np.allclose(So3.compose(a, b), b @ a, atol=1e-6)
    # SE(3) tangents put the translation first: a rotation-first reading gives other matrices.
    xi = twists(20, 38)
    swapped = np.stack([expm(twist_matrix(np.concatenate([v[3:], v[:3]]))) for v in xi])
    assert not np.allclose(Se3.exp(xi), swapped, atol=1e-6)
    # Right and left Jacobians differ away from zero.
    assert not np.allclose(So3.right_jacobian(w), So3.left_jacobian(w), atol=1e-6)


# ----------------------------------------------------------------------------------------------
# Bad input raises (never crashes)
# ----------------------------------------------------------------------------------------------


def test_bad_elements_raise_value_error_naming_the_index():
    w = rotation_vectors(5, 39)
    w[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"omega\[2\]: rotation vector has a non-finite component \(NaN\)"):
        So3.exp(w)
    with pytest.raises(ValueError, match=r"omega: .*non-finite"):
        So3.right_jacobian([np.inf, 0.0, 0.0])
    r = random_rotations(4, 40)
    r[1] *= 1.01
    with pytest.raises(ValueError, match=r"r\[1\]: the rotation matrix is not orthonormal"):
        So3.log(r)
    with pytest.raises(ValueError, match=r"r: the matrix has determinant -1"):
        So3.log(np.diag([1.0, 1.0, -1.0]))
    good = random_rotations(3, 41)
    bad = good.copy()
    bad[2, 0, 0] = np.nan
    with pytest.raises(ValueError, match=r"b\[2\]: rotation matrix has a non-finite"):
        So3.compose(good, bad)
    with pytest.raises(ValueError, match=r"v\[1\]: point has a non-finite"):
        So3.act(good, [[0, 0, 0], [np.inf, 0, 0], [0, 0, 0]])
    with pytest.raises(ValueError, match=r"x\[0\]: unit vector must have unit norm"):
        S2.log([[1.0, 1.0, 0.0]], [0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match=r"u\[1\]: tangent coordinates has a non-finite"):
        S2.retract([0.0, 0.0, 1.0], [[0.0, 0.0], [np.nan, 0.0]])
    t = random_poses(3, 42)
    t[1, 3, 0] = 0.5
    with pytest.raises(ValueError, match=r"x\[1\]: the bottom rows of a homogeneous matrix"):
        Se3.log(t)
    with pytest.raises(ValueError, match=r"xi\[0\]: SE\(3\) tangent has a non-finite"):
        Se3.exp([[np.nan, 0, 0, 0, 0, 0]])
    with pytest.raises(ValueError, match=r"t: translation has a non-finite"):
        Se3.from_rotation_translation(np.eye(3), [np.nan, 0, 0])


def test_bad_shapes_and_dtypes_raise():
    with pytest.raises(ValueError, match=r"omega: expected shape \(3,\) for one element or \(n, 3\) for n elements, got \(4,\)"):
        So3.exp([1.0, 2.0, 3.0, 4.0])
    with pytest.raises(ValueError, match=r"r: expected shape \(3, 3\)"):
        So3.log(np.zeros((2, 2, 3, 3)))
    with pytest.raises(ValueError, match=r"got \(\)"):
        So3.exp(1.0)
    with pytest.raises(ValueError, match="batches must have the same length"):
        So3.compose(random_rotations(2, 43), random_rotations(3, 44))
    with pytest.raises(TypeError, match="dtype complex128"):
        So3.exp(np.ones(3, dtype=complex))
    with pytest.raises(TypeError, match="dtype bool"):
        So3.exp(np.ones(3, dtype=bool))
    with pytest.raises((TypeError, ValueError)):
        So3.exp(["a", "b", "c"])
    with pytest.raises((TypeError, ValueError)):
        So3.exp(None)
    with pytest.raises(TypeError):
        So3.exp()  # pylint: disable=no-value-for-parameter


def test_extreme_finite_inputs_give_finite_results():
    huge = np.array([[1e300, -1e300, 1e300], [1e-300, 0.0, 0.0], [np.pi, 0.0, 0.0]])
    for out in [So3.exp(huge), So3.right_jacobian(huge), UnitQuaternion.exp(huge), So3.log(So3.exp(huge))]:
        assert np.all(np.isfinite(out))
    np.testing.assert_allclose(So3.exp(huge) @ So3.exp(huge).transpose(0, 2, 1), np.tile(np.eye(3), (3, 1, 1)), atol=1e-15)
    xi = np.array([[1e300, 1e300, -1e300, 0.1, 0.2, 0.3], [1.0, 2.0, 3.0, 1e300, 0.0, 0.0]])
    assert np.all(np.isfinite(Se3.exp(xi)))
    assert np.all(np.isfinite(Se3.right_jacobian(xi)))
    x = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(np.linalg.norm(S2.exp(x, [1e300, 0.0, 0.0])), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(S2.retract(x, [1e-300, 1e300])), 1.0, atol=1e-15)
