r"""highway-env's lanes as rows of arrays (:class:`LaneRows`), so that the lane coordinates,
heading and curvature of many points on many lanes are array operations: the 1-D source's
leader search (:mod:`acc_fusion.truth.highway.source`) and the 2-D world's objects
(:mod:`acc_fusion.truth.highway.world`) read the same rows.

``StraightLane`` and ``SineLane`` (a sine over a straight base) are computed as arrays, with
highway-env's own formulas (``StraightLane.local_coordinates``,
``SineLane.local_coordinates``): from the start :math:`a`, direction :math:`d` and lateral
direction :math:`n` (``direction_lateral``) of the base,

.. math::

    s = (p - a)\cdot d, \qquad r = (p - a)\cdot n - A \sin(\omega s + \varphi),

:math:`A, \omega, \varphi` the sine's amplitude, pulsation and phase (0 on a straight lane).
Beyond a sine lane's ends highway-env continues the sine; :meth:`LaneRows.local` can instead
extend the lane along its base (``clip``: :math:`s` clipped to :math:`[0, \ell]` in the
sine), as the 2-D world does for vehicles on the next segment.  Any other lane (a
``CircularLane``, say) is left to highway-env's methods, point by point.

Heading and curvature of the graph :math:`r(s)` over the base (e.g. M. P. do Carmo,
*Differential Geometry of Curves and Surfaces*, 1976, ch. 1):
:math:`\psi = \psi_{\text{base}} + \arctan r'` and :math:`\kappa = r''/(1 + r'^2)^{3/2}`,
with :math:`r' = A\omega\cos(\omega s + \varphi)`, :math:`r'' = -A\omega^2\sin(\omega s +
\varphi)` on the lane (0 beyond its ends); a ``CircularLane`` has :math:`\kappa =`
``direction`` / ``radius``; any other lane the change of ``heading_at`` over
:data:`~acc_fusion.truth.sumo.roadside.CURVATURE_WINDOW`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from acc_fusion.truth.sumo.roadside import CURVATURE_WINDOW

#: A row's type (its column 0).
STRAIGHT, SINE, OTHER = 0.0, 1.0, 2.0
#: The columns of a row: type, start (x, y), direction (x, y), lateral direction (x, y),
#: amplitude, pulsation, phase, length, base heading, width.
COLUMNS = ("type", "ax", "ay", "dx", "dy", "nx", "ny", "amplitude", "pulsation", "phase",
           "length", "heading", "width")  # fmt: skip
_LENGTH, _HEADING, _WIDTH = (COLUMNS.index(c) for c in ("length", "heading", "width"))


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles [rad] wrapped to (-pi, pi]."""
    return np.arctan2(np.sin(a), np.cos(a))


class LaneRows:
    """The lanes of one road network, a row each as they are asked for (:data:`COLUMNS`).

    Row 0 stands for *no lane*: the network's x axis, width 1 (``row(None)``).

    Attributes:
        rows: ``(L, 13)`` the rows.  lanes: the highway-env lane of each row (``None`` for
            row 0).
    """

    def __init__(self, network: Any) -> None:
        from highway_env.road.lane import CircularLane, SineLane, StraightLane

        self._straight, self._sine, self._circular = StraightLane, SineLane, CircularLane
        self.network = network
        self.lanes: list = [None]
        self.rows = np.zeros((1, len(COLUMNS)))
        self.rows[0, [3, 6, _WIDTH]] = 1.0
        self._row_of: dict[Any, int] = {}

    def row(self, index: Any) -> int:
        """The row of lane ``index`` (highway-env's ``lane_index``; ``None``: row 0)."""
        if index is None:
            return 0
        k = self._row_of.get(index)
        if k is None:
            lane = self.network.get_lane(index)
            row = np.zeros(len(COLUMNS))
            if isinstance(lane, self._straight):
                row[0] = SINE if isinstance(lane, self._sine) else STRAIGHT
                row[1:7] = (*lane.start, *lane.direction, *lane.direction_lateral)
                row[_HEADING] = lane.heading
            else:
                row[0] = OTHER
            if row[0] == SINE:
                row[7:10] = (lane.amplitude, lane.pulsation, lane.phase)
            row[_LENGTH], row[_WIDTH] = lane.length, lane.width_at(0.0)
            k = self._row_of[index] = len(self.lanes)
            self.lanes.append(lane)
            self.rows = np.vstack([self.rows, row])
        return k

    def straight(self, lane: Any) -> bool:
        """``lane`` is a ``StraightLane`` (not a ``SineLane``)."""
        return isinstance(lane, self._straight) and not isinstance(lane, self._sine)

    def length(self, row: np.ndarray) -> np.ndarray:
        """Length [m] of the lanes of ``row``."""
        return self.rows[row, _LENGTH]

    def width(self, row: np.ndarray) -> np.ndarray:
        """Width [m] at their start of the lanes of ``row``."""
        return self.rows[row, _WIDTH]

    def base_heading(self, row: np.ndarray) -> np.ndarray:
        """Heading [rad] of the base line of straight and sine rows (0 on other rows)."""
        return self.rows[row, _HEADING]

    def other(self, row: np.ndarray) -> np.ndarray:
        """Which of ``row`` are lanes that highway-env's methods compute."""
        return self.rows[row, 0] == OTHER

    def local(
        self, row: np.ndarray, px: np.ndarray, py: np.ndarray, clip: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """Lane coordinates ``s, r`` [m] of points ``(px, py)`` on the lanes of ``row``
        (broadcast together; module docstring; ``clip``: beyond a sine lane's ends, along
        its base)."""
        row, px, py = np.broadcast_arrays(row, px, py)
        q = self.rows[row]
        dx, dy = px - q[..., 1], py - q[..., 2]
        s = dx * q[..., 3] + dy * q[..., 4]
        at = np.clip(s, 0.0, q[..., _LENGTH]) if clip else s
        r = dx * q[..., 5] + dy * q[..., 6] - q[..., 7] * np.sin(q[..., 8] * at + q[..., 9])
        for k in zip(*np.nonzero(q[..., 0] == OTHER), strict=True):
            s[k], r[k] = self.lanes[row[k]].local_coordinates(np.array([px[k], py[k]]))
        return s, r

    def _slope(self, row: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:math:`r'` and :math:`r''` of the rows at ``s`` (0 beyond the ends and on
        straight rows)."""
        q = self.rows[row]
        on = (s >= 0.0) & (s <= q[..., _LENGTH])
        amp, w, phase = q[..., 7], q[..., 8], q[..., 8] * s + q[..., 9]
        slope, bend = amp * w * np.cos(phase), -amp * w * w * np.sin(phase)
        return np.where(on, slope, 0.0), np.where(on, bend, 0.0)

    def heading(self, row: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Heading [rad] of the lanes of ``row`` at ``s`` (paired, 1-D)."""
        out = self.base_heading(row) + np.arctan(self._slope(row, s)[0])
        for k in np.flatnonzero(self.other(row)):
            out[k] = self.lanes[row[k]].heading_at(s[k])
        return out

    def curvature(self, row: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Curvature [1/m] of the lanes of ``row`` at ``s``, left positive (paired, 1-D)."""
        slope, bend = self._slope(row, s)
        out = bend / (1.0 + slope**2) ** 1.5
        h = 0.5 * CURVATURE_WINDOW
        for k in np.flatnonzero(self.other(row)):
            lane = self.lanes[row[k]]
            if isinstance(lane, self._circular):
                out[k] = lane.direction / lane.radius
            else:
                out[k] = wrap_angle(lane.heading_at(s[k] + h) - lane.heading_at(s[k] - h)) / (2 * h)
        return out
