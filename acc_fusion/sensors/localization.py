r"""The ego's pose on a map: the error with which an ego that localises itself on a lane-level
map places the map's lane ahead (:attr:`~acc_fusion.truth.objects.ObjectFrame.road_path`)
into its own frame, for the ``"map"`` path of :mod:`acc_fusion.warning.selection`.

An error of lateral position :math:`e_y` and of heading :math:`e_\psi` moves the map's lane
at distance :math:`x` ahead by

.. math::

    \tilde y_p(x) = y_p(x) + e_y + e_\psi\, x

(small angles).  Each error is a first-order Gauss-Markov process per ego, of standard
deviation :math:`\sigma` and correlation time :math:`\tau`:
:math:`e_{k+1} = \rho\, e_k + \sqrt{1 - \rho^2}\,\sigma\, n_k`, :math:`\rho = e^{-T/\tau}`,
started from its stationary distribution when a vehicle takes the slot.  The standard
deviations are :class:`~acc_fusion.warning.selection.SelectionConfig`'s ``map_lateral_std``
and ``map_heading_std`` (the 95 % accuracies that Reid et al. require of an automated
vehicle's localisation on freeways: 0.20 m lateral, 0.51° of attitude, read as
:math:`2\sigma`; "Localization requirements for autonomous vehicles", *SAE Int. J. of
Connected and Automated Vehicles* 2(3), 2019), and the correlation time ``map_error_time``
(2 s, an assumption: map-matched localisation drifts over seconds, not from step to step).
"""

from __future__ import annotations

import math

import numpy as np

from acc_fusion.core.slots import PairState
from acc_fusion.truth.objects import PATH_STATIONS


class MapLocalization(PairState):
    """The localisation errors of E egos (module docstring), one step at a time.

    Args:
        lateral_std: :math:`\\sigma` of the lateral error [m].
        heading_std: :math:`\\sigma` of the heading error [rad].
        time_constant: correlation time :math:`\\tau` of both [s].
        n: egos.
        rng: the generator of the errors (draws are made for all ``n`` egos at every step
            and cut to the prefix held, :mod:`acc_fusion.core.slots`).
    """

    _PAIR_AXES = {"_error": 1, "_fresh": 0}

    def __init__(
        self, lateral_std: float, heading_std: float, time_constant: float, n: int,
        rng: np.random.Generator,
    ) -> None:  # fmt: skip
        self._std = np.array([[lateral_std], [heading_std]])
        self._tau, self._rng, self._capacity, self.n = float(time_constant), rng, n, n
        self._error = np.zeros((2, n))
        self._fresh = np.ones(n, dtype=bool)

    def _resized(self, m: int) -> None:
        self.n = m

    def forget(self, egos: np.ndarray) -> None:
        """Start the errors of ``egos`` (a boolean mask ``(E,)``) afresh at the next step."""
        self._fresh[egos] = True

    def step(self, road_path: np.ndarray, dt: float) -> np.ndarray:
        """``road_path (E, J)`` as the egos place it: each row moved by its ego's errors,
        advanced by ``dt`` [s] (module docstring)."""
        noise = self._rng.standard_normal((2, self._capacity))[:, : self.n] * self._std
        rho = math.exp(-dt / self._tau) if dt > 0.0 else 1.0
        walked = rho * self._error + math.sqrt(1.0 - rho * rho) * noise
        self._error = np.where(self._fresh, noise, walked)
        self._fresh[:] = False
        return road_path + self._error[0][:, None] + self._error[1][:, None] * PATH_STATIONS
