r"""A driver-monitoring camera: whether each driver's eyes are on the road, as an
eyes-off-road detector reports it, for a driver-state-adaptive warning
(:class:`acc_fusion.warning.logic.AdaptiveConfig`).

The truth is each simulated driver's eyes-off-road state
(:attr:`acc_fusion.truth.driver.Driver.eyes_off`).  The monitor reports a driver
*attentive* at time :math:`t` when it has not seen his eyes off the road for at least the
recovery time :math:`T_r`, and does not see them off now:

.. math::

    \text{seen}(t) = \text{off}(t) \wedge t - t_\text{off} \ge L, \qquad
    \text{attentive}(t) = \neg\,\text{seen}(t) \wedge t - t_\text{seen} \ge T_r

with :math:`t_\text{off}` the start of the current episode, :math:`L` the detection latency
and :math:`t_\text{seen}` the last time it saw the eyes off.  So a glance shorter than
:math:`L` goes unseen (the warning keeps the attentive timing through it), and after an
episode the driver counts as distracted for :math:`T_r` more: he looks back but has yet to
take in the road.  A driver the monitor has just met (a new vehicle in a slot) counts as
distracted for :math:`T_r` (the camera acquires his face).  A run whose drivers never look
away (no driver model, or no eyes-off-road episodes) has no monitor: the warning keeps its
standard timing there.

Where the figures come from (assumptions; no published detection-latency distribution of
production monitors was found here):

- Latency :math:`L` = 0.2 s, five frames of a camera at 25 frames/s.  Eyes-off-road
  detectors of that frame rate classify single frames with over 90 % accuracy (F. Vicente,
  Z. Huang, X. Xiong, F. De la Torre, W. Zhang, D. Levi, "Driver gaze tracking and
  eyes off the road detection system", *IEEE Trans. Intelligent Transportation Systems*
  16(4), 2015); a few frames of filtering make the assumption here.  (Euro NCAP's
  driver-state requirements judge the *warning* of a long distraction, 3 s, not the
  detection.)
- Recovery :math:`T_r` = 1.0 s.  Situation awareness after a glance back is not instant;
  the value is an assumption of the order of one brake reaction time (Green, "How long does
  it take to stop?", *Transportation Human Factors* 2(3):195-216, 2000).
- Every glance longer than :math:`L` is seen, and every driver is tracked (no sunglasses, no
  lost face): an idealisation, see docs/limitations.md.
"""

from __future__ import annotations

import numpy as np

from acc_fusion.core.slots import PairState, pair_mask
from acc_fusion.core.units import TIME_TOL
from acc_fusion.core.validation import check_mask


class DriverMonitor(PairState):
    """The eyes-off-road detector of N drivers (rules in the module docstring).

    Args:
        n: number of drivers N.
        latency: detection latency :math:`L` [s].
        recovery: recovery time :math:`T_r` [s].
    """

    _PAIR_AXES = {"_off_since": 0, "_seen_at": 0}

    def __init__(self, n: int, latency: float, recovery: float) -> None:
        self.n, self.latency, self.recovery = n, float(latency), float(recovery)
        self._off_since = np.full(n, np.nan)  # start of the current episode; NaN: eyes on
        self._seen_at = np.full(n, -np.inf)  # last time the monitor saw the eyes off

    def _resized(self, m: int) -> None:
        self.n = m

    def reset(self, drivers: np.ndarray, t: float) -> None:
        """New drivers in ``drivers`` (mask or indices) at time ``t``: the camera acquires
        their faces, so they count as distracted until ``t`` + recovery."""
        mask = pair_mask(drivers, self.n)
        self._off_since[mask] = np.nan
        self._seen_at[mask] = t

    def step(self, t: float, eyes_off: np.ndarray) -> np.ndarray:
        """``(N,)`` bool: the drivers the monitor reports attentive at ``t``, given their true
        eyes-off-road state ``eyes_off (N,)``."""
        off = check_mask("eyes_off", eyes_off, self.n)
        started = off & np.isnan(self._off_since)
        self._off_since[started] = t
        self._off_since[~off] = np.nan
        seen = off & (t - self._off_since >= self.latency - TIME_TOL)
        self._seen_at[seen] = t
        return ~seen & (t - self._seen_at >= self.recovery - TIME_TOL)

    def watch(self, t: float, eyes_off: np.ndarray, new: np.ndarray | None = None) -> np.ndarray:
        """:meth:`step`, after meeting the drivers of the slots ``new`` (a mask, or ``None``),
        whose ``eyes_off`` may still be their predecessors': they count as distracted."""
        if new is not None and new.any():
            self.reset(new, t)
            eyes_off = eyes_off & ~new
        return self.step(t, eyes_off)
