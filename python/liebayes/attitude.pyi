"""IMU attitude: the production filter with a batch API like VQF's, its offline estimate, and the
BROAD reader."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Union, final

import numpy as np
import numpy.typing as npt

_Array = npt.NDArray[np.float64]

@final
class AttitudeFilter:
    """The production attitude filter: orientation of the IMU frame w.r.t. East-North-Up as unit
    quaternions [w, x, y, z], with the heading and tilt sigma.

    Give the sampling interval ``dt`` (s) or the ``rate`` (Hz), exactly one. ``sensors`` is
    ``"9d"``, ``"6d"``, or ``None`` to decide at the first update (9D when it has a magnetometer).
    ``params`` are keyword parameters (``parameter_names()``; SI units, angles in rad).
    Raises ``ValueError`` for a parameter out of its range or an unknown name, ``TypeError`` for a
    number that is not a Python or numpy integer or float (a bool, a complex number, an array), for
    a flag (``estimate_bias``, ``rest_detection``, ``mag_offset``, ``mag_disturbance_rejection``)
    that is not ``True`` or ``False`` (or a ``numpy.bool_``), and for a ``propagation`` that is
    not a string.

    Threads: a filter is used by one thread at a time. While ``update_batch`` runs (without the
    GIL), another thread's ``update_batch``, ``update`` or ``reset`` of the same filter raises
    ``ValueError`` ("in use by another call"), and reading it (properties, ``params``, ``repr``)
    raises pyo3's ``RuntimeError`` ("Already borrowed"): give each thread its own filter.
    """

    def __init__(
        self,
        dt: Optional[float] = None,
        *,
        rate: Optional[float] = None,
        sensors: Optional[str] = None,
        **params: Union[float, bool, str],
    ) -> None: ...
    @staticmethod
    def parameter_names() -> List[str]:
        """The keyword parameters the constructor accepts."""
    @staticmethod
    def default_params() -> Dict[str, Any]:
        """The default parameters."""
    def params(self) -> Dict[str, Any]:
        """This filter's parameters."""
    @property
    def rate(self) -> float:
        """The sampling rate (Hz)."""
    @property
    def sensors(self) -> Optional[str]:
        """``"9d"``, ``"6d"``, or ``None`` before the first update when not given."""
    def update_batch(
        self, gyr: _Array, acc: _Array, mag: Optional[_Array] = None
    ) -> Dict[str, npt.NDArray[Any]]:
        """Filters (n, 3) arrays of gyroscope (rad/s), accelerometer (m/s^2) and magnetometer
        readings; returns ``quat`` (n, 4), ``heading_sigma``, ``tilt_sigma`` (n,) (rad), ``bias``
        (n, 3) (rad/s), ``rest``, ``mag_disturbance`` (n,) (bool). All or nothing: a refused
        sample raises ``ValueError`` naming it and leaves the filter as before the call (a refused
        first batch, or one of no samples, decides no ``sensors``). At most 2^24 samples; the
        shapes and that size are checked before the arrays are read, and results that do not fit
        in memory raise ``ValueError`` before any sample is filtered. The GIL is released while
        filtering; a Ctrl-C meanwhile raises ``KeyboardInterrupt`` once the batch is done, the
        filter as before the call."""
    def update(
        self,
        gyr: Sequence[float],
        acc: Sequence[float],
        mag: Optional[Sequence[float]] = None,
    ) -> None:
        """Filters one sample (streaming): three real numbers each (a bool or a complex number
        raises ``TypeError``). A refused sample raises and leaves the state unchanged (a refused
        first sample decides no ``sensors``)."""
    @property
    def quat(self) -> _Array:
        """The orientation [w, x, y, z] after the last sample."""
    @property
    def covariance(self) -> _Array:
        """The world-frame attitude error covariance (3, 3) (rad^2)."""
    @property
    def heading_sigma(self) -> float:
        """The heading sigma (rad)."""
    @property
    def tilt_sigma(self) -> float:
        """The tilt sigma (rad)."""
    @property
    def bias(self) -> _Array:
        """The estimated gyroscope bias (3,) (rad/s)."""
    @property
    def rest(self) -> bool:
        """Whether the last sample was detected as rest."""
    @property
    def mag_disturbance(self) -> bool:
        """Whether the last magnetometer update was refused as disturbed."""
    def reset(self) -> None:
        """Forgets every sample."""

def offline_attitude(
    gyr: npt.ArrayLike,
    acc: npt.ArrayLike,
    mag: Optional[npt.ArrayLike] = None,
    *,
    dt: Optional[float] = None,
    rate: Optional[float] = None,
    **params: Any,
) -> Dict[str, _Array]:
    """The offline estimate of a whole recording (the production filter's RTS smoother: every
    sample given every sample), like VQF's ``offlineVQF``: ``quat`` (n, 4) scalar first, IMU frame
    w.r.t. East-North-Up, ``heading_sigma`` and ``tilt_sigma`` (n,) rad. Without ``mag``, 6D.
    Exactly one of ``dt`` (s) and ``rate`` (Hz); ``params`` as ``AttitudeFilter``'s, the rest at
    ``offline_default_params()``. At most 2^24 samples (checked before the arrays are read; results
    that do not fit in memory raise ``ValueError`` before any work) and 2^20 epochs of the record
    (a block each, 0.04 s by default: about 11.6 hours; at a low rate a block is a sample, and the
    sample past the limit raises ``ValueError``). Raises ``ValueError`` naming a refused sample."""

def offline_default_params() -> Dict[str, Any]:
    """The default keyword parameters of ``offline_attitude``."""

def read_broad(path: Union[str, "PathLike[str]"]) -> Dict[str, Any]:
    """Reads a BROAD trial (.mat): ``rate`` (Hz), ``gyr``, ``acc``, ``mag`` (n, 3) or None,
    ``quat`` (n, 4) reference (NaN rows where lost) or None, ``movement`` (n,) bool or None."""
