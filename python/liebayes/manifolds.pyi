"""Manifolds and Lie groups over numpy arrays: SO(3), unit quaternions, the sphere S², SE(3).

Every method takes one element or a batch of them (a leading axis of length n) and returns the
same; methods of two arguments broadcast a single element against a batch (two batches must have
the same length). Inputs are float64 arrays; other real-valued array-likes (lists, integer or
float32 arrays, strided views) are converted once. A bad element raises ``ValueError`` naming the
argument and the element's index (``"R[3]: the rotation matrix is not orthonormal: ..."``); a wrong
shape raises ``ValueError``; an array of complex, bool, object or string dtype raises ``TypeError``.

Conventions: rotations are active (``R v`` turns ``v``); ``compose(a, b)`` applies ``b`` first;
perturbations are on the right (``retract(x, v) = x exp(v)``, ``local(x, y) = log(x⁻¹ y)``);
Jacobians are right Jacobians unless named left, with
``exp(v + d) = exp(v) exp(Jr(v) d + O(d²))`` and ``Jl(v) = Jr(-v)``.
"""

from typing import Union, final

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
Array = npt.NDArray[np.float64]
FloatOrArray = Union[float, Array]

__all__ = ["So3", "UnitQuaternion", "S2", "Se3"]

@final
class So3:
    """Rotations of space, SO(3), as rotation matrices.

    Elements: rotation matrices, shape (3, 3) or (n, 3, 3), checked to be finite with
    ``|RᵀR - I|`` and ``|det R - 1|`` at most 1e-9 per entry (use ``orthonormalize`` for matrices
    that drifted). Tangents: rotation vectors (axis times angle, radians), shape (3,) or (n, 3).
    """

    @staticmethod
    def exp(omega: ArrayLike) -> Array:
        """Rotation matrices of rotation vectors: (3,) -> (3, 3), (n, 3) -> (n, 3, 3)."""
    @staticmethod
    def log(r: ArrayLike) -> Array:
        """Rotation vectors of rotation matrices, angle in [0, pi]: (3, 3) -> (3,), (n, 3, 3) -> (n, 3).

        At an angle of exactly pi both signs of the axis are logarithms; one of them is returned.
        """
    @staticmethod
    def compose(a: ArrayLike, b: ArrayLike) -> Array:
        """The products ``a @ b`` (b applied first); broadcasts a single rotation against a batch."""
    @staticmethod
    def inverse(r: ArrayLike) -> Array:
        """The inverse rotations (transposes)."""
    @staticmethod
    def act(r: ArrayLike, v: ArrayLike) -> Array:
        """The rotated vectors ``R v``: R (3, 3) or (n, 3, 3), v (3,) or (n, 3), broadcast; (3,) or (n, 3)."""
    @staticmethod
    def act_jacobian(r: ArrayLike, v: ArrayLike) -> Array:
        """``d(R v)/dR = -R hat(v)`` for the right perturbation ``R exp(w)``: (3, 3) per element.

        The Jacobian in v is R itself.
        """
    @staticmethod
    def retract(r: ArrayLike, omega: ArrayLike) -> Array:
        """``R exp(omega)``, the right perturbation; broadcasts."""
    @staticmethod
    def local(a: ArrayLike, b: ArrayLike) -> Array:
        """``log(aᵀ b)``: the rotation vector at a that leads to b; broadcasts."""
    @staticmethod
    def distance(a: ArrayLike, b: ArrayLike) -> FloatOrArray:
        """The angle in [0, pi] of ``aᵀ b``: a float for two single rotations, shape (n,) otherwise."""
    @staticmethod
    def adjoint(r: ArrayLike) -> Array:
        """``Ad(R)`` with ``R exp(v) Rᵀ = exp(Ad(R) v)``; for SO(3) it is R itself: (3, 3) per element."""
    @staticmethod
    def right_jacobian(omega: ArrayLike) -> Array:
        """``Jr(omega)``, with ``exp(omega + d) = exp(omega) exp(Jr d + O(d²))``: (3, 3) per element."""
    @staticmethod
    def left_jacobian(omega: ArrayLike) -> Array:
        """``Jl(omega) = Jr(-omega)``, with ``exp(omega + d) = exp(Jl d + O(d²)) exp(omega)``."""
    @staticmethod
    def right_jacobian_inverse(omega: ArrayLike) -> Array:
        """``Jr(omega)⁻¹``, with ``log(exp(omega) exp(d)) = omega + Jr⁻¹ d + O(d²)``; singular at 2 pi k."""
    @staticmethod
    def left_jacobian_inverse(omega: ArrayLike) -> Array:
        """``Jl(omega)⁻¹ = Jr(-omega)⁻¹``, with ``log(exp(d) exp(omega)) = omega + Jl⁻¹ d + O(d²)``."""
    @staticmethod
    def hat(omega: ArrayLike) -> Array:
        """Skew matrices with ``hat(omega) v = omega x v``: (3,) -> (3, 3), (n, 3) -> (n, 3, 3)."""
    @staticmethod
    def vee(a: ArrayLike) -> Array:
        """Vectors of the antisymmetric parts of 3x3 matrices (the inverse of hat on skew matrices)."""
    @staticmethod
    def from_quaternion(q: ArrayLike) -> Array:
        """Rotation matrices of unit quaternions ``[w, x, y, z]`` (scalar first); q and -q agree.

        Quaternions are checked: finite, ``|norm - 1|`` at most 1e-9.
        """
    @staticmethod
    def to_quaternion(r: ArrayLike) -> Array:
        """Unit quaternions ``[w, x, y, z]`` of rotation matrices, the representative with ``w >= 0``."""
    @staticmethod
    def orthonormalize(m: ArrayLike) -> Array:
        """The rotation nearest to each matrix in the Frobenius norm (polar factor); refuses det M <= 0."""

@final
class UnitQuaternion:
    """Unit quaternions, SU(2), the double cover of SO(3): Hamilton, scalar first ``[w, x, y, z]``.

    Elements: shape (4,) or (n, 4), checked to be finite with ``|norm - 1|`` at most 1e-9 (use
    ``normalize`` first). q and -q are different points (the same rotation). Tangents are rotation
    vectors: ``exp(v) = (cos(θ/2), sin(θ/2) v/θ)``, and ``log`` returns angles in [0, 2 pi].
    """

    @staticmethod
    def exp(omega: ArrayLike) -> Array:
        """Unit quaternions of rotation vectors: (3,) -> (4,), (n, 3) -> (n, 4)."""
    @staticmethod
    def log(q: ArrayLike) -> Array:
        """Rotation vectors with angle ``2 atan2(|xyz|, w)`` in [0, 2 pi]: (4,) -> (3,), (n, 4) -> (n, 3)."""
    @staticmethod
    def compose(p: ArrayLike, q: ArrayLike) -> Array:
        """Hamilton products ``p q`` (q's rotation applied first); broadcasts."""
    @staticmethod
    def inverse(q: ArrayLike) -> Array:
        """Inverses (conjugates) ``[w, -x, -y, -z]``."""
    @staticmethod
    def act(q: ArrayLike, v: ArrayLike) -> Array:
        """Rotated vectors ``q v q*``: q (4,) or (n, 4), v (3,) or (n, 3), broadcast."""
    @staticmethod
    def to_matrix(q: ArrayLike) -> Array:
        """Rotation matrices of ``v -> q v q*``: (4,) -> (3, 3), (n, 4) -> (n, 3, 3)."""
    @staticmethod
    def from_matrix(r: ArrayLike) -> Array:
        """Unit quaternions of rotation matrices, the lift with ``w >= 0``."""
    @staticmethod
    def normalize(q: ArrayLike) -> Array:
        """``q / |q|`` for finite quaternions at least 1e-150 long."""

@final
class S2:
    """The unit sphere in R³ (directions), a manifold but not a group.

    Points: shape (3,) or (n, 3), checked to be finite with ``|norm - 1|`` at most 1e-9 (use
    ``normalize`` for other lengths). ``exp``/``log`` use ambient tangent vectors (3 numbers);
    ``retract``/``local`` use 2 coordinates in the tangent basis ``B(x) = [b1 b2]``, ``b1 x b2 = x``.
    """

    @staticmethod
    def exp(x: ArrayLike, w: ArrayLike) -> Array:
        """``cos|w| x + sin|w| w/|w|``: the point reached from x along the ambient tangent w.

        The component of w along x is ignored. Broadcasts; (3,) or (n, 3).
        """
    @staticmethod
    def log(x: ArrayLike, y: ArrayLike) -> Array:
        """The ambient tangent at x along the great circle to y, of length the angle between them.

        At the antipode, ``pi b1``. Broadcasts; (3,) or (n, 3).
        """
    @staticmethod
    def retract(x: ArrayLike, u: ArrayLike) -> Array:
        """``exp(x, B(x) u)`` for tangent coordinates u of shape (2,) or (n, 2); broadcasts."""
    @staticmethod
    def local(x: ArrayLike, y: ArrayLike) -> Array:
        """``B(x)ᵀ log(x, y)``: tangent coordinates at x that lead to y, (2,) or (n, 2)."""
    @staticmethod
    def distance(x: ArrayLike, y: ArrayLike) -> FloatOrArray:
        """Great-circle angle in [0, pi]: a float for two single points, shape (n,) otherwise."""
    @staticmethod
    def tangent_basis(x: ArrayLike) -> Array:
        """The orthonormal tangent basis ``[b1 b2]`` at x: (3, 2) or (n, 3, 2), ``b1 x b2 = x``.

        Continuous except across the plane z = 0, where it switches charts.
        """
    @staticmethod
    def normalize(v: ArrayLike) -> Array:
        """Directions ``v / |v|`` of finite vectors at least 1e-150 long."""

@final
class Se3:
    """Rigid motions of space, SE(3), as homogeneous matrices ``[[R, t], [0, 0, 0, 1]]``.

    Elements: shape (4, 4) or (n, 4, 4), checked: finite, bottom row ``[0, 0, 0, 1]`` and rotation
    block as for ``So3`` (tolerance 1e-9). Tangents: shape (6,) or (n, 6) with **the translation
    block first**, ``xi = [rho; phi]``, ``exp(xi) = (exp(phi), V(phi) rho)`` (V the left Jacobian
    of SO(3)). Perturbations are on the right, so rho is a displacement in the body frame.
    """

    @staticmethod
    def exp(xi: ArrayLike) -> Array:
        """Homogeneous matrices of tangents ``[rho; phi]``: (6,) -> (4, 4), (n, 6) -> (n, 4, 4)."""
    @staticmethod
    def log(x: ArrayLike) -> Array:
        """Tangents ``[rho; phi]`` of homogeneous matrices, rotation angle in [0, pi]."""
    @staticmethod
    def compose(a: ArrayLike, b: ArrayLike) -> Array:
        """Products ``a @ b`` (b applied first); broadcasts."""
    @staticmethod
    def inverse(x: ArrayLike) -> Array:
        """Inverse motions ``[[Rᵀ, -Rᵀ t], [0, 1]]``."""
    @staticmethod
    def act(x: ArrayLike, p: ArrayLike) -> Array:
        """Transformed points ``R p + t``: T (4, 4) or (n, 4, 4), p (3,) or (n, 3), broadcast."""
    @staticmethod
    def act_jacobian(x: ArrayLike, p: ArrayLike) -> Array:
        """``d(x p)/dx = [R, -R hat(p)]`` for the right perturbation: (3, 6) per element."""
    @staticmethod
    def retract(x: ArrayLike, xi: ArrayLike) -> Array:
        """``x exp(xi)``, the right perturbation; broadcasts."""
    @staticmethod
    def local(a: ArrayLike, b: ArrayLike) -> Array:
        """``log(a⁻¹ b)``: the tangent at a that leads to b; broadcasts."""
    @staticmethod
    def adjoint(x: ArrayLike) -> Array:
        """``Ad(x) = [[R, hat(t) R], [0, R]]``: (6, 6) per element."""
    @staticmethod
    def right_jacobian(xi: ArrayLike) -> Array:
        """``Jr(xi)``, with ``exp(xi + d) = exp(xi) exp(Jr d + O(d²))``: (6, 6) per element."""
    @staticmethod
    def left_jacobian(xi: ArrayLike) -> Array:
        """``Jl(xi) = Jr(-xi)``, with ``exp(xi + d) = exp(Jl d + O(d²)) exp(xi)``."""
    @staticmethod
    def right_jacobian_inverse(xi: ArrayLike) -> Array:
        """``Jr(xi)⁻¹``; singular at rotation angles 2 pi k (k >= 1)."""
    @staticmethod
    def left_jacobian_inverse(xi: ArrayLike) -> Array:
        """``Jl(xi)⁻¹ = Jr(-xi)⁻¹``."""
    @staticmethod
    def hat(xi: ArrayLike) -> Array:
        """Lie-algebra matrices ``[[hat(phi), rho], [0, 0]]``: (6,) -> (4, 4), (n, 6) -> (n, 4, 4)."""
    @staticmethod
    def vee(a: ArrayLike) -> Array:
        """``[A[:3, 3]; vee(antisymmetric part of A[:3, :3])]`` of 4x4 matrices: (6,) per element."""
    @staticmethod
    def from_rotation_translation(r: ArrayLike, t: ArrayLike) -> Array:
        """Homogeneous matrices ``[[R, t], [0, 1]]`` of rotations (3, 3) and translations (3,); broadcasts."""
