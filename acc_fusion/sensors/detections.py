"""What a 2-D sensor reports at one frame: a flat list of detections over all egos.

A detection is a polar measurement — range, azimuth, range-rate — of one return, with the noise
standard deviations the sensor declares for it (what a tracker uses as its measurement noise).
Detections of all egos sit in one flat array sorted by ego, so a frame costs a few array
operations whatever the number of egos (ragged rows: ``ego`` names the row).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from acc_fusion.core.errors import InputError

#: ``origin`` of a detection that no object caused: a multipath ghost.
GHOST = -1
#: ``origin`` of a clutter (false) detection.
CLUTTER = -2

_FLOATS = ("range", "azimuth", "range_rate", "range_std", "azimuth_std", "range_rate_std")


@dataclass(frozen=True)
class Detections:
    r"""One sensor's detections of E egos at time ``t`` (``K`` detections in all).

    Attributes:
        t: frame time [s].
        sensor: the sensor's name.
        n_egos: number of egos E.
        online: the sensor delivered a frame at this time (it sampled and is not in a dropout),
            whether or not it detected anything; ``False`` between sample times (then ``K`` is 0).
        ego: ``(K,)`` int64, the ego each detection belongs to, sorted ascending.
        range: ``(K,)`` measured range [m].
        azimuth: ``(K,)`` measured bearing [rad], left positive.
        range_rate: ``(K,)`` measured range-rate [m/s] (negative when closing).
        range_std: ``(K,)`` declared range noise std [m].
        azimuth_std: ``(K,)`` declared azimuth noise std [rad].
        range_rate_std: ``(K,)`` declared range-rate noise std [m/s].
        object_id: ``(K,)`` int64, the true object that caused the detection, ``-1`` for
            ghosts and clutter.  Truth for diagnostics and metrics: trackers must not read it.
        origin: ``(K,)`` int8, the :class:`~acc_fusion.truth.objects.ObjectKind` of that
            object, or :data:`GHOST` / :data:`CLUTTER`.  Truth, like ``object_id``.
        range_std_growth, range_rate_std_growth: :math:`q` [1/m, 1/(m s)] of the sensor's
            noise model :math:`\sigma(r) = \sigma_0 + q r^2` (0: a constant std).  The
            declared stds are the model at the measured range :math:`\hat r`; a consumer with
            a prediction :math:`r^-` of the range evaluates it there, :math:`\sigma(r^-) =
            \sigma(\hat r) + q\,((r^-)^2 - \hat r^2)`: a std taken at the measured range is
            correlated with the measurement's error, and weighting by it biases the estimate
            (short, as :math:`\hat r^{-4}` favours short measurements: Bordonaro, Willett &
            Bar-Shalom, "Decorrelated unbiased converted measurement Kalman filter", *IEEE
            Trans. AES* 50(2), 2014).
    """

    t: float
    sensor: str
    n_egos: int
    online: bool
    ego: np.ndarray
    range: np.ndarray
    azimuth: np.ndarray
    range_rate: np.ndarray
    range_std: np.ndarray
    azimuth_std: np.ndarray
    range_rate_std: np.ndarray
    object_id: np.ndarray
    origin: np.ndarray
    range_std_growth: float = 0.0
    range_rate_std_growth: float = 0.0

    def __post_init__(self) -> None:
        ego = np.asarray(self.ego)
        if ego.ndim != 1 or not np.issubdtype(ego.dtype, np.integer):
            raise InputError(f"ego must be an integer array of shape (K,), got {ego.shape}")
        k = ego.shape[0]
        if k and (ego[0] < 0 or ego[-1] >= self.n_egos or np.any(np.diff(ego) < 0)):
            raise InputError(f"ego must be sorted and in [0, {self.n_egos}) ")
        for name in _FLOATS:
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (k,) or not np.all(np.isfinite(value)):
                raise InputError(f"{self.sensor}.{name} must be a finite array of shape ({k},)")
            object.__setattr__(self, name, value)
        for name, dtype in (("object_id", np.int64), ("origin", np.int8)):
            value = np.asarray(getattr(self, name))
            if value.shape != (k,) or not np.issubdtype(value.dtype, np.integer):
                raise InputError(f"{self.sensor}.{name} must be an integer array of shape ({k},)")
            object.__setattr__(self, name, value.astype(dtype, copy=False))
        object.__setattr__(self, "ego", ego.astype(np.int64, copy=False))
        for name in ("range_std_growth", "range_rate_std_growth"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise InputError(f"{self.sensor}.{name} must be a finite number >= 0")
            object.__setattr__(self, name, float(value))

    @property
    def count(self) -> int:
        """Number of detections K."""
        return int(self.ego.shape[0])

    def rows(self) -> np.ndarray:
        """``(E + 1,)`` offsets: the detections of ego ``e`` are ``[rows[e], rows[e + 1])``."""
        return np.searchsorted(self.ego, np.arange(self.n_egos + 1))

    @property
    def x(self) -> np.ndarray:
        """``(K,)`` longitudinal position in the ego frame [m], ``range * cos(azimuth)``."""
        return self.range * np.cos(self.azimuth)

    @property
    def y(self) -> np.ndarray:
        """``(K,)`` lateral position in the ego frame [m], ``range * sin(azimuth)``."""
        return self.range * np.sin(self.azimuth)


#: The fields of a :class:`Detections`, in order.
DETECTION_FIELDS = tuple(f.name for f in fields(Detections))
