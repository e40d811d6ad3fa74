"""Probability densities on the circle, the sphere, unit quaternions and SO(3).

Re-exports the density classes of the extension module:

* :class:`VonMises` on the circle (angles in radians), against dθ;
* :class:`VonMisesFisher` on the sphere S² (unit 3-vectors), against the surface measure;
* :class:`Bingham` on unit quaternions ``(w, x, y, z)``, against the uniform probability measure
  on S³, with :func:`bingham_log_normaliser` (the normaliser and its gradient);
* :class:`HeatKernelSo3` on SO(3) (3×3 rotation matrices), against the normalised Haar measure;
* :class:`ManifoldGaussianSo3` and :class:`ManifoldGaussianS2`, Gaussians in the tangent space
  at the mean.

Points go in as ``float64`` arrays whose trailing dimensions are one point (``()``, ``(3,)``,
``(4,)`` or ``(3, 3)``) and whose leading dimensions are any batch shape; ``log_pdf`` returns one
value per point with the batch shape (a float for a single point). ``sample(n, rng)`` draws one
integer ``rng.integers(0, 2**63)`` from the ``numpy.random.Generator`` ``rng`` and seeds the
library's ChaCha8 stream with it: the same generator state gives the same draws. Every invalid
argument raises ``ValueError`` with the library's message.
"""

from ._liebayes import (
    Bingham,
    HeatKernelSo3,
    ManifoldGaussianS2,
    ManifoldGaussianSo3,
    VonMises,
    VonMisesFisher,
    bingham_log_normaliser,
)

__all__ = [
    "Bingham",
    "HeatKernelSo3",
    "ManifoldGaussianS2",
    "ManifoldGaussianSo3",
    "VonMises",
    "VonMisesFisher",
    "bingham_log_normaliser",
]
