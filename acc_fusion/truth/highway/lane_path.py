r"""The road ahead as a map gives it, on highway-env's road network: the centreline of each
ego's lane and of the lanes it continues into, in the ego frame (:attr:`ObjectFrame.road_path
<acc_fusion.truth.objects.ObjectFrame.road_path>`), for the ``"map"`` path of
:mod:`acc_fusion.warning.selection`.

The lanes ahead
    From the ego's lane (its ``lane_index``), the sequence follows highway-env's own rule for
    the lane after a lane's end, ``RoadNetwork.next_lane`` without a route: the next road's
    lane nearest the end of this one (every supported network has a single next road per
    road, so no route is needed to choose).  It goes on while the next lane starts where the
    last one ends (within :data:`JOIN`).  A lane that ends instead (``merge-v0``'s
    acceleration lane, whose nearest successor starts a lane width aside) ends the sequence,
    as a SUMO lane with no link into the next edge does, and so does the network's end; the
    path beyond continues along the last segment's direction.  The sequence covers
    :data:`~acc_fusion.truth.sumo.lane_path.REACH` metres past the end of the ego's lane and
    is made once per lane of an episode's network.

In the ego frame
    Each lane is a polyline of highway-env's centreline points ``lane.position(s, 0)``: a
    straight lane its two ends, any other lane a point every :data:`SPACING` metres (on
    ``merge-v0``'s sine ramp, curvature at most 0.005 1/m, a chord then strays under 3 mm).
    The polylines are laid into the ego frame and sampled at
    :data:`~acc_fusion.truth.objects.PATH_STATIONS` exactly as SUMO's lane shapes are
    (:func:`acc_fusion.truth.road.sample_lanes`), from the ego's front bumper
    projected on its lane.  highway-env's vehicles leave the centreline while they change
    lanes, so there the path starts aside of the ego, by the bumper's offset from its lane's
    centre.

This is the ground truth of the map; the localisation error of an ego that matches itself to
the map is added by the pipeline (:class:`~acc_fusion.sensors.localization.MapLocalization`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from acc_fusion.truth.highway.lanes import LaneRows
from acc_fusion.truth.objects import PATH_STATIONS
from acc_fusion.truth.road import sample_lanes
from acc_fusion.truth.sumo.lane_path import REACH

#: Largest gap [m] between a lane's end and the next lane's start for the path to go on.
JOIN = 0.5
#: Spacing [m] of the points of a lane that is not straight.
SPACING = 2.0


class NetworkPaths:
    """The map path of egos on one highway-env road network (module docstring).

    Args:
        lanes: the network's :class:`~acc_fusion.truth.highway.lanes.LaneRows`.
    """

    def __init__(self, lanes: LaneRows) -> None:
        self._lanes, self._network = lanes, lanes.network
        self._polyline_of: dict[Any, int] = {}
        self._points: list[np.ndarray] = []  # per polyline: (K, 3) x, y, lane position
        self._sequences: dict[Any, np.ndarray] = {}
        self._table: tuple[np.ndarray, ...] | None = None  # start, vx, vy, vs

    def _polyline(self, index: Any) -> int:
        """The polyline of lane ``index`` (made on first use)."""
        k = self._polyline_of.get(index)
        if k is None:
            lane = self._network.get_lane(index)
            n = 2 if self._lanes.straight(lane) else max(2, math.ceil(lane.length / SPACING) + 1)
            s = np.linspace(0.0, lane.length, n)
            xy = np.array([lane.position(v, 0.0) for v in s], dtype=float)
            k = self._polyline_of[index] = len(self._points)
            self._points.append(np.column_stack([xy, s]))
            self._table = None
        return k

    def _sequence(self, index: Any) -> np.ndarray:
        """The polylines from lane ``index`` on, to :data:`REACH` past its end (module
        docstring)."""
        seq = self._sequences.get(index)
        if seq is None:
            net, first = self._network, index
            lane = net.get_lane(index)
            out, length, end = [self._polyline(index)], 0.0, lane.position(lane.length, 0.0)
            while length < REACH:
                nxt = net.next_lane(index, position=end)
                lane = net.get_lane(nxt)
                if nxt == index or np.hypot(*(lane.position(0.0, 0.0) - end)) > JOIN:
                    break  # the network's end, or a lane that ends
                out.append(self._polyline(nxt))
                index, length, end = nxt, length + lane.length, lane.position(lane.length, 0.0)
            seq = self._sequences[first] = np.asarray(out, dtype=np.int64)
        return seq

    def paths(
        self,
        lane_index: list,
        pos: np.ndarray,
        front_x: np.ndarray,
        front_y: np.ndarray,
        heading: np.ndarray,
    ) -> np.ndarray:
        """``(E, len(PATH_STATIONS))`` the map path of each ego (module docstring):
        ``lane_index`` the egos' highway-env lane indices, ``pos`` their front bumpers'
        positions along those lanes [m], ``front_x``, ``front_y`` the bumpers in the road's
        axes [m] and ``heading`` [rad]."""
        sequences = [self._sequence(index) for index in lane_index]
        if self._table is None:
            pts = np.concatenate(self._points) if self._points else np.zeros((0, 3))
            sizes = [len(p) for p in self._points]
            start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
            self._table = (start, *(np.ascontiguousarray(pts[:, j]) for j in range(3)))
        counts = np.array([s.size for s in sequences], dtype=np.int64)
        flat = np.concatenate(sequences) if sequences else np.zeros(0, np.int64)
        out = np.full((len(sequences), PATH_STATIONS.size), np.nan)
        sample_lanes(flat, counts, np.asarray(pos, float), np.asarray(front_x, float),
                     np.asarray(front_y, float), np.asarray(heading, float), *self._table,
                     PATH_STATIONS, out)  # fmt: skip
        return out
