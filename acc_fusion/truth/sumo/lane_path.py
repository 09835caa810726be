r"""The road ahead as a map gives it: the centreline of each ego's lane and of the lanes it
continues into along its route, in the ego frame (:attr:`ObjectFrame.road_path
<acc_fusion.truth.objects.ObjectFrame.road_path>`), for the ``"map"`` path of
:mod:`acc_fusion.warning.selection`.

The lanes ahead
    From the ego's lane, the lane sequence follows SUMO's links (libsumo ``lane.getLinks``,
    read once for every lane): from a lane inside a junction its one link; from a lane of an
    edge, of its links into the next edge of the vehicle's route (``vehicle.getRoute`` and
    ``getRouteIndex``, read when the ego's lane changes: a rerouted vehicle's new route) the
    one into the lane of the same index, else the nearest, through the junction's internal
    lanes one by one.  Where the ego's lane has no link into the next edge (the vehicle must
    change lanes first) or the route ends, the sequence ends, and the path beyond continues
    along the last segment's direction.  The sequence covers :data:`REACH` metres past the
    end of the ego's lane, so past the ego wherever it is on it, and is made again only when
    the ego's lane changes.

In the ego frame
    The sequence's shapes are laid into the ego frame and sampled at the stations by
    :func:`acc_fusion.truth.road.sample_lanes` (NaN where the path turns back, and in the
    whole row of an ego on no lane).  SUMO's lane-based vehicles drive on their lane's
    centreline, so the path starts at :math:`y = 0`.

This is the ground truth of the map; the localisation error of an ego that matches itself to
the map is added by the pipeline (:class:`~acc_fusion.warning.selection.SelectionConfig`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from acc_fusion.truth.objects import PATH_STATIONS
from acc_fusion.truth.road import sample_lanes
from acc_fusion.truth.sumo.roadside import LaneTable

#: How far past the ego the lane sequence reaches [m]: the last station of
#: :data:`~acc_fusion.truth.objects.PATH_STATIONS` and a margin for the path's bends.
REACH = float(PATH_STATIONS[-1]) + 50.0


class RoutePaths:
    """The map path of the egos of a running SUMO simulation (module docstring).

    Args:
        api: libsumo (or TraCI) with the simulation running.
        lanes: its :class:`~acc_fusion.truth.sumo.roadside.LaneTable`.
    """

    def __init__(self, api: Any, lanes: LaneTable) -> None:
        self._api, self._lanes = api, lanes
        names = [f"{e}_{i}" for e, n in zip(lanes.edge_ids, lanes.n_lanes.tolist(), strict=True)
                 for i in range(n)]  # fmt: skip
        index = {name: g for g, name in enumerate(names)}
        self._lane_edge = np.repeat(np.arange(len(lanes.edge_ids)), lanes.n_lanes).tolist()
        self._length = [float(lanes.vs[lanes.start[g + 1] - 1]) for g in range(len(names))]
        # per lane: (next lane, the junction's lane on the way or -1)
        self._links = [
            [(index[to], index.get(via, -1)) for to, *_, via, _, _, _ in api.lane.getLinks(name)
             if to in index]
            for name in names
        ]  # fmt: skip
        self._index = [g - int(lanes.first_lane[e]) for g, e in enumerate(self._lane_edge)]
        self._held: dict[int, tuple[int, np.ndarray]] = {}  # by object id: (lane, its lanes)

    def _sequence(self, lane: int, route: list[int], at: int) -> np.ndarray:
        """The global lanes from ``lane`` on along ``route``, the edge rows of the vehicle's
        route, ``at`` the index in it of the edge the vehicle is on (or has just left, in a
        junction; module docstring), until they reach :data:`REACH` past the end of ``lane``:
        past the ego wherever it is on the lane."""
        internal, edge_of, index = self._lanes.internal, self._lane_edge, self._index
        if not internal[edge_of[lane]] and not (
            0 <= at < len(route) and route[at] == edge_of[lane]
        ):
            at = route.index(edge_of[lane]) if edge_of[lane] in route else -1
        out, length = [lane], 0.0
        while length < REACH:
            links = self._links[lane]
            if not internal[edge_of[lane]]:  # into the route's next edge, keeping the lane
                if at < 0 or at + 1 >= len(route):
                    break
                links = sorted((link for link in links if edge_of[link[0]] == route[at + 1]),
                               key=lambda link: abs(index[link[0]] - index[lane]))  # fmt: skip
            if not links:
                break
            to, via = links[0]
            lane = via if via >= 0 else to  # through the junction's lanes, one by one
            out.append(lane)
            length += self._length[lane]
            if (
                not internal[edge_of[lane]]
                and at + 1 < len(route)
                and route[at + 1] == edge_of[lane]
            ):
                at += 1
        return np.asarray(out, dtype=np.int64)

    def paths(
        self,
        ids: list[str],
        oid: np.ndarray,
        lane: np.ndarray,
        pos: np.ndarray,
        front_x: np.ndarray,
        front_y: np.ndarray,
        heading: np.ndarray,
    ) -> np.ndarray:
        """``(E, len(PATH_STATIONS))`` the map path of each ego (module docstring): ``ids``
        the egos' SUMO vehicle ids (``None`` for an empty slot), ``oid`` their object ids,
        ``lane`` their global lanes (-1: on none), ``pos`` their lane positions, ``front_x``,
        ``front_y`` their front bumpers in the network frame [m] and ``heading`` [rad]."""
        n, veh, code = len(ids), self._api.vehicle, self._lanes.edge_code
        sequences, kept = [], {}
        for e in range(n):
            g = int(lane[e])
            if ids[e] is None or g < 0:
                sequences.append(np.zeros(0, np.int64))
                continue
            o = int(oid[e])
            held = self._held.get(o)
            if held is None or held[0] != g:  # a new lane: the route as it is now
                route = [code.get(edge, -1) for edge in veh.getRoute(ids[e])]
                held = (g, self._sequence(g, route, int(veh.getRouteIndex(ids[e]))))
            kept[o] = held
            sequences.append(held[1])
        self._held = kept  # the vehicles gone are forgotten
        counts = np.array([s.size for s in sequences], dtype=np.int64)
        flat = np.concatenate(sequences) if n else np.zeros(0, np.int64)
        out = np.full((n, PATH_STATIONS.size), np.nan)
        lanes = self._lanes
        sample_lanes(flat, counts, pos, front_x, front_y, heading, lanes.start, lanes.vx,
                     lanes.vy, lanes.vs, PATH_STATIONS, out)  # fmt: skip
        return out
