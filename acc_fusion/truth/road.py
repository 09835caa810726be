"""The road of a scripted scene (:mod:`acc_fusion.truth.scenes`): the ego lane's centreline as
plan and vertical curvature pieces (:class:`Road`), sampled for the scene's kinematics and
laid into an ego's frame as a map would give it (:class:`RoadGeometry`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acc_fusion.truth.objects import PATH_STATIONS

#: Grid step of the road geometry [m].
_DS = 0.5
#: Arc lengths ahead of an ego [m] at which :meth:`RoadGeometry.lane_ahead` samples the lane
#: (a 2 m chord strays under 2 mm from a 250 m radius).
_AHEAD = np.arange(0.0, PATH_STATIONS[-1] + 50.0, 2.0)


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
        :data:`~acc_fusion.truth.objects.PATH_STATIONS`: the scene's road as a map
        (:attr:`~acc_fusion.truth.objects.ObjectFrame.road_path`)."""
        arc = s[:, None] + _AHEAD
        qx, qy = self.point(arc, np.zeros_like(arc))
        c, sn = np.cos(heading)[:, None], np.sin(heading)[:, None]
        dx, dy = qx - ex[:, None], qy - ey[:, None]
        x, y = c * dx + sn * dy, -sn * dx + c * dy
        return np.stack([np.interp(PATH_STATIONS, xr, yr) for xr, yr in zip(x, y, strict=True)])
