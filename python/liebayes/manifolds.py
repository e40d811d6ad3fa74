"""Manifolds and Lie groups over numpy arrays: SO(3), unit quaternions, the sphere S², SE(3).

Each class holds static methods only (no instances): ``So3`` (rotation matrices), ``UnitQuaternion``
(Hamilton, scalar first ``[w, x, y, z]``), ``S2`` (unit vectors) and ``Se3`` (homogeneous 4x4
matrices, tangents ``[rho; phi]`` with the translation block first).

Every method takes one element (for instance a rotation matrix of shape ``(3, 3)``) or a batch of
them (``(n, 3, 3)``) and returns the same; methods of two arguments broadcast a single element
against a batch. Inputs are float64 arrays (other real-valued array-likes are converted once), every
element is validated, and a bad one raises ``ValueError`` naming the argument and the element's
index, with the library's message. Conventions: rotations are active, ``compose(a, b)`` applies
``b`` first, perturbations are on the right (``retract(x, v) = x exp(v)``) and Jacobians are right
Jacobians unless named left. See ``docs/python/manifolds.md``.
"""

from ._liebayes import S2, Se3, So3, UnitQuaternion

__all__ = ["So3", "UnitQuaternion", "S2", "Se3"]
