"""The road: a scripted scene's (:mod:`acc_fusion.truth.scenes`) ego lane as plan and vertical
curvature pieces (:class:`Road`), sampled for the scene's kinematics (:class:`RoadGeometry`);
and the lanes ahead of egos laid into their frames as a map gives them
(:func:`sample_lanes`: the scenes', SUMO's and highway-env's
:attr:`~acc_fusion.truth.objects.ObjectFrame.road_path`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.truth.objects import PATH_STATIONS

#: Grid step of the road geometry [m].
_DS = 0.5


@dataclass(frozen=True)
class Road:
    """The ego lane's centreline.

    Attributes:
        curves: ``(start s [m], plan curvature [1/m])`` pieces in increasing ``s``; the road
            is straight before the first; positive curves left.
        vertical: ``(start s, end s, vertical curvature [1/m])`` pieces; negative is a crest.
        length: road length [m] from ``s = -100``.
    """

    curves: tuple[tuple[float, float], ...] = ()
    vertical: tuple[tuple[float, float, float], ...] = ()
    length: float = 1500.0


class RoadGeometry:
    """The road sampled every ``_DS`` metres: position, heading, height and grade."""

    def __init__(self, road: Road) -> None:
        s = np.arange(-100.0, road.length, _DS)
        kappa = np.zeros_like(s)
        for start, k in road.curves:
            kappa[s >= start] = k
        kv = np.zeros_like(s)
        for start, end, k in road.vertical:
            kv[(s >= start) & (s < end)] = k
        theta = np.concatenate([[0.0], np.cumsum(kappa[:-1]) * _DS])
        self.s, self.kappa, self.theta = s, kappa, theta
        self.x = np.concatenate([[0.0], np.cumsum(np.cos(theta[:-1])) * _DS])
        self.y = np.concatenate([[0.0], np.cumsum(np.sin(theta[:-1])) * _DS])
        grade = np.concatenate([[0.0], np.cumsum(kv[:-1]) * _DS])
        self.grade = grade
        self.z = np.concatenate([[0.0], np.cumsum(grade[:-1]) * _DS])

    def at(self, name: str, s: np.ndarray) -> np.ndarray:
        """Geometry quantity ``name`` at arc lengths ``s`` (any shape), linearly interpolated."""
        return np.interp(s, self.s, getattr(self, name))

    def point(self, s: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World position of ``(s, d)``."""
        th = self.at("theta", s)
        return self.at("x", s) - d * np.sin(th), self.at("y", s) + d * np.cos(th)

    def lane_ahead(
        self, s: np.ndarray, ex: np.ndarray, ey: np.ndarray, heading: np.ndarray
    ) -> np.ndarray:
        """``(N, len(PATH_STATIONS))`` the lane's centreline ahead of egos on it at arc
        lengths ``s (N,)``, at ``(ex, ey) (N,)`` with ``heading (N,)`` [rad] (their
        :meth:`point` and the lane's own heading there), in each ego's frame at the stations
        :data:`~acc_fusion.truth.objects.PATH_STATIONS` (:func:`sample_lanes`, the road one
        polyline of its grid): the scene's road as a map
        (:attr:`~acc_fusion.truth.objects.ObjectFrame.road_path`)."""
        n = len(s)
        out = np.full((n, PATH_STATIONS.size), np.nan)
        ego = (np.asarray(a, float) for a in (s, ex, ey, heading))
        lane = (np.array([0, self.s.size]), self.x, self.y, self.s)  # one polyline
        sample_lanes(np.zeros(n, np.int64), np.ones(n, np.int64), *ego, *lane, PATH_STATIONS,
                     out)  # fmt: skip
        return out


@njit(cache=True)
def sample_lanes(
    flat, counts, pos, px, py, heading, start, vx, vy, vs, stations, out
):  # pragma: no cover - compiled
    r"""Write each ego's path at ``stations`` into ``out (E, J)``: its lanes
    ``flat[counts[:e].sum():][:counts[e]]`` (polylines: lane ``g``'s vertices ``vx, vy`` and
    lane positions ``vs`` from ``start[g]`` to ``start[g + 1]``), from lane position
    ``pos[e]`` on the first, in the frame of the front bumper ``(px, py)`` and ``heading``.

    The vertices :math:`q_i` from the ego's own point on its lane on are taken into the ego
    frame (origin the front bumper :math:`p_e`, :math:`x` along the heading :math:`u_e`,
    :math:`y` along :math:`n_e`): :math:`x_i = (q_i - p_e)\cdot u_e,\ y_i = (q_i -
    p_e)\cdot n_e`, and the path's lateral position at each station :math:`X_j` is the
    linear interpolation on the first segment whose :math:`x` crosses :math:`X_j` going
    forward; past the last vertex, straight on along the last segment (along the lane for an
    ego past its last lane's end).  Where the path turns back (a loop tighter than the field)
    the stations it no longer reaches are left as they were (NaN)."""
    first = 0
    for e in range(counts.size):
        k = counts[e]
        c, s = np.cos(heading[e]), np.sin(heading[e])
        j, have = 0, False
        x0, y0, prev_x, prev_y = 0.0, 0.0, -1.0, 0.0
        for i in range(first, first + k):
            if j >= stations.size:
                break  # every station written
            g = flat[i]
            a, b = start[g], start[g + 1]
            for v in range(a, b):
                qx, qy = vx[v], vy[v]
                if i == first and not have and v < b - 1:  # the ego's own point on its lane
                    if vs[v + 1] <= pos[e]:
                        continue  # a segment behind the ego
                    u = 0.0 if vs[v + 1] == vs[v] else (pos[e] - vs[v]) / (vs[v + 1] - vs[v])
                    u = min(max(u, 0.0), 1.0)
                    qx, qy = vx[v] + u * (vx[v + 1] - vx[v]), vy[v] + u * (vy[v + 1] - vy[v])
                dx, dy = qx - px[e], qy - py[e]
                x1, y1 = dx * c + dy * s, -dx * s + dy * c
                if not have:
                    have, x0, y0, prev_x, prev_y = True, x1, y1, x1 - 1.0, y1
                    if i == first and v == b - 1 and v > a:  # past its lane's end: along it
                        dx, dy = vx[v - 1] - px[e], vy[v - 1] - py[e]
                        prev_x, prev_y = dx * c + dy * s, -dx * s + dy * c
                    continue
                if x1 < x0 - 1e-3:  # turning back: the stations left are not reached
                    j = stations.size
                while j < stations.size and stations[j] <= x1:
                    if stations[j] < x0:  # behind the ego's own point
                        out[e, j] = y0
                    elif x1 > x0:
                        out[e, j] = y0 + (stations[j] - x0) * (y1 - y0) / (x1 - x0)
                    else:
                        out[e, j] = y1
                    j += 1
                if x1 > x0:
                    prev_x, prev_y = x0, y0
                x0, y0 = x1, y1
                if j >= stations.size:
                    break
        # past the last vertex: straight on along the last segment
        dx, dy = x0 - prev_x, y0 - prev_y
        while have and j < stations.size and dx > 0.0:
            out[e, j] = y0 + (stations[j] - x0) * dy / dx
            j += 1
        first += k
