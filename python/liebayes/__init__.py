"""liebayes: Bayesian state estimation on Lie groups (Rust, with numpy in and out).

Areas:

* ``liebayes.manifolds``: SO(3), unit quaternions, the sphere S², SE(3): exp/log, composition,
  Jacobians, vectorised over arrays of elements;
* ``liebayes.densities``: von Mises, von Mises-Fisher, Bingham, the SO(3) heat kernel and the
  Gaussian on a manifold, with their stable normalisers;
* ``liebayes.attitude``: the production IMU attitude filter with a batch API like VQF's, and the
  BROAD reader;
* ``liebayes.filters``: the exact azimuth filter, the angle-of-arrival filters, and studies over
  the built-in scenarios.

Every library error is raised as ``ValueError`` with the library's message.
"""

from . import attitude, densities, filters, manifolds
from ._liebayes import __version__

__all__ = ["__version__", "attitude", "densities", "filters", "manifolds"]
