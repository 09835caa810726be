r"""2-D object truth from SUMO: an :class:`~acc_fusion.truth.objects.ObjectFrame` per step for
the equipped vehicles of a running :class:`~acc_fusion.truth.sumo.source.SumoSource`.

Egos
    The source's slots (``E = n_pairs``): an inactive slot has no objects and ``lead = -1``.
    Ego speed and acceleration are the source frame's (SUMO's).  The yaw rate is the heading
    change since the previous frame of the same vehicle in the slot,
    :math:`\dot\psi = \operatorname{wrap}(\psi_k - \psi_{k-1}) / (t_k - t_{k-1})` (0 at the
    slot's first frame), so :meth:`SumoObjects.frame` is meant to be called after every step.
    The road curvature is the ego lane's at the ego's lane position
    (:class:`~acc_fusion.truth.sumo.roadside.LaneTable`).

SUMO's conventions, converted
    SUMO gives a vehicle's position as the centre of its *front bumper* and its angle
    :math:`\alpha` in degrees *clockwise from north*; the heading used here is
    :math:`\psi = \pi/2 - \alpha\,\pi/180` (counter-clockwise from east, the network's x
    axis), the unit vector :math:`u = (\cos\psi, \sin\psi) = (\sin\alpha, \cos\alpha)`, and the
    footprint's centre :math:`c = p_{\text{front}} - (\ell/2)\,u`.  A vehicle is a box of
    SUMO's length, width and height.

The ego frame
    Origin at the ego's front bumper centre :math:`p_e`, :math:`x` along :math:`u_e`,
    :math:`y` along :math:`n_e = (-\sin\psi_e, \cos\psi_e)` (left).  An object's position is
    the centre of its *nearest face*: of its rear face :math:`c - (\ell/2)u` and front face
    :math:`c + (\ell/2)u`, the one closer to :math:`p_e` (the rear face of a vehicle ahead, the
    front face of an oncoming one, the near side of a gantry):
    :math:`x = (q - p_e)\cdot u_e,\ y = (q - p_e)\cdot n_e`.  Relative velocity is ground
    velocity minus the ego's, in the ego frame (no rotation term):
    :math:`v_x = v\cos(\psi - \psi_e) - v_e,\ v_y = v\sin(\psi - \psi_e)` — exactly
    :math:`(-v_e, 0)` for a stationary object.

The field
    Every object whose nearest face lies at :math:`0 \le x \le` ``ahead`` and
    :math:`|y| \le` ``lateral`` (defaults 200 m, the reach of a long-range radar, and 15 m,
    four lanes either side), other than the ego itself.  The search runs compiled: object
    centres are sorted by their cell of a uniform grid (``GRID_CELL`` of
    :mod:`~acc_fusion.truth.sumo.object_kernels`), and each ego
    visits the cells under its field's bounding box widened by the longest object's half
    length (a binary search in the sorted keys per grid column); the hits are then written
    into the frame's ``(E, M)`` arrays, ``M`` the largest count.

The lead and the 1-D truth
    ``lead`` is the slot of SUMO's leader of the ego — the ``leader_id`` of the source's
    :class:`~acc_fusion.truth.frame.TruthFrame` (``getLeader`` within ``lookahead``), whose
    integer ids are the vehicles' ``object_id`` here — when it lies in the field, else ``-1``.
    On a straight lane its ``x`` is the frame's gap (rear bumper minus front bumper along the
    lane), so :meth:`~acc_fusion.truth.objects.ObjectFrame.lead_frame` reproduces the 1-D frame.

Relative lane
    On the ego's edge: the difference of SUMO's lane indices (index 0 is the rightmost lane,
    so left is positive).  Elsewhere (the next edge, a junction, a ramp) an approximation:
    the object's lateral offset from the ego lane's centreline extrapolated on a circle of the
    ego's road curvature :math:`\kappa` (``_path_offset`` of the kernels, :math:`\approx y - \kappa
    x^2/2`), in lane widths :math:`w` of the ego lane, rounded (the ego is taken on its
    lane's centreline: SUMO's default lane-based model).  On the bends of an interchange a
    vehicle on another road far from the ego's path gets a large :math:`|lane|`.  Roadside
    objects are :data:`~acc_fusion.truth.objects.OFF_ROAD`.

Reading SUMO
    Every vehicle's position, angle, speed, acceleration, lane position, edge and lane index
    are read at each step in one call to the compiled reader of
    :mod:`acc_fusion.truth.sumo.native` (its ``state``: libsumo's C++ getters for every
    vehicle, the edge looked up in a C++ table) where the source reads with it, else with
    libsumo's raw SWIG getters mapped over the ids; length, width, height and class once per
    vehicle.  Measured on the bundled motorway with 495 vehicles (SUMO 1.28, shared 2-core
    VM, two runs): ``state`` 0.83-0.86 ms per step, the SWIG getters 2.5-3.7 ms, subscribing
    the same variables (``vehicle.subscribe`` at departure) 2.7-3.6 ms more in
    ``simulationStep`` plus 2.9 ms for ``getAllSubscriptionResults`` and the conversion.
    The lane geometry and the roadside objects are read and placed once, at construction.

Lateral speed (a lane change)
    SUMO's default lane-change model moves a vehicle into the next lane within one step (no
    lateral motion to read: ``vehicle.getLateralSpeed`` is 0 outside the sublane model and
    costs one more call per vehicle and step).  So it is derived: when a vehicle's lane index
    on the same edge changes, it moves across its lane at :math:`\pm w / T_{lc}` (``w`` its
    new lane's width, sign left positive) for the :data:`LANE_CHANGE_DURATION` :math:`T_{lc}`
    that follows, else 0: a cut-in or cut-out is seen as one while the real manoeuvre would
    still be under way.

The ego's lane change
    The same jump moves an ego's frame sideways by the distance between its old and new
    lanes' centrelines, :math:`\pm (w_{old} + w_{new}) / 2`, within one step and without a
    turn: every object it sees moves the other way at once, which no odometry of a real car
    would leave unexplained (a real lane change is a turn left and back over seconds, which
    the gyro follows).  So the frame says it: :attr:`ObjectFrame.ego_shift
    <acc_fusion.truth.objects.ObjectFrame.ego_shift>` is that distance at the step the ego's
    lane index changes on its edge, else 0, and the trackers carry their tracks across it as
    the ego's odometry would have (:mod:`acc_fusion.fusion.tracking.tracker`).  Taken as
    exact: the dead reckoning of a 3.5 m lane change is off by centimetres, within a track's
    lateral spread at any range (assumption).  A simulation whose vehicles move across lanes
    continuously (SUMO's ``lateral-resolution`` or ``lanechange.duration`` set above 0, read
    with ``simulation.getOption``) has no jump, and no shift.

Radar cross-section and thermal contrast of vehicles: :data:`VCLASS_SIGNATURE`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import chain, repeat
from operator import itemgetter

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_range
from acc_fusion.truth.objects import ObjectKind
from acc_fusion.truth.sumo.lane_path import RoutePaths
from acc_fusion.truth.sumo.object_arrays import (
    ObjectArrays,
    ObjectFrames,
    check_prefix,
    object_outputs,
)
from acc_fusion.truth.sumo.object_kernels import _fill, _grid, _search
from acc_fusion.truth.sumo.reading import raw_function
from acc_fusion.truth.sumo.roadside import (
    LaneTable,
    RoadsideConfig,
    curvature_at,
    place_roadside,
)
from acc_fusion.truth.sumo.source import SumoSource

#: Per SUMO vehicle class: (radar cross-section [dBsm], thermal contrast [K]) of the vehicle's
#: rear.  RCS: a passenger car's rear about 10 dBsm at 76-79 GHz, of the order measured by
#: H. Suzuki, "Measurement results of radar cross section of automobiles for millimeter wave
#: band", 7th ITS World Congress, 2000, and I. Matsunami, R. Nakamura, A. Kajiwara, "RCS
#: measurements for vehicles and pedestrian at 26 and 79 GHz", ICSPCS 2012; trucks and buses
#: 20-25 dBsm (a large flat rear: assumption scaled from the car), two-wheelers and
#: pedestrians below 5 dBsm.  Thermal contrast (LWIR, rear of a running vehicle: exhaust,
#: tyres, engine bay against the road): assumption.  Classes not listed count as passenger.
VCLASS_SIGNATURE = {
    "passenger": (10.0, 8.0),
    "taxi": (10.0, 8.0),
    "private": (10.0, 8.0),
    "evehicle": (10.0, 4.0),
    "emergency": (12.0, 8.0),
    "authority": (12.0, 8.0),
    "delivery": (15.0, 10.0),
    "truck": (20.0, 12.0),
    "trailer": (25.0, 12.0),
    "bus": (20.0, 12.0),
    "coach": (20.0, 12.0),
    "motorcycle": (3.0, 10.0),
    "moped": (0.0, 8.0),
    "bicycle": (-5.0, 5.0),
    "pedestrian": (-8.0, 6.0),
}

#: Duration [s] of a lane change over which a vehicle's jump to the next lane is spread as
#: lateral speed (module docstring): the mean of 4.6 s measured on US freeways by T. Toledo,
#: D. Zohar, "Modeling duration of lane changes", Transportation Research Record 1999, 2007.
LANE_CHANGE_DURATION = 4.6


@dataclass(frozen=True)
class ObjectFieldConfig:
    """The forward field of each ego (validated on construction; SI units).

    Attributes:
        ahead: farthest ``x`` of an object's nearest face [m]; 200 (long-range radar).
        lateral: largest ``|y|`` [m]; 15 (four 3.5 m lanes either side).
        roadside: the stationary objects placed along the network, a :class:`RoadsideConfig`.
        map_path: give each ego's lane ahead along its route as a map would
            (:attr:`~acc_fusion.truth.objects.ObjectFrame.road_path`,
            :mod:`~acc_fusion.truth.sumo.lane_path`); False.
    """

    ahead: float = 200.0
    lateral: float = 15.0
    roadside: RoadsideConfig = RoadsideConfig()
    map_path: bool = False

    def __post_init__(self) -> None:
        check_range("field.ahead", self.ahead, 0.0, 5000.0, lo_open=True)
        check_range("field.lateral", self.lateral, 0.0, 1000.0, lo_open=True)
        if not isinstance(self.map_path, bool):
            raise ConfigError(f"field.map_path must be true or false, got {self.map_path!r}")
        if not isinstance(self.roadside, RoadsideConfig):
            raise ConfigError(
                f"field.roadside must be a RoadsideConfig, got {type(self.roadside).__name__}"
            )


class SumoObjects(ObjectFrames):
    """The object truth of a running SUMO source (module docstring).

    Args:
        source: an open :class:`~acc_fusion.truth.sumo.source.SumoSource` (SUMO in this
            process: not the background source, whose SUMO runs in a child process).
        config: the :class:`ObjectFieldConfig`.

    Attributes:
        lanes: the network's :class:`LaneTable`.
        roadside: the stationary objects, placed once here (:class:`Roadside`).

    Call :meth:`frame` once after every step of the source::

        objects = SumoObjects(src)
        while not src.done:
            src.advance()
            world = objects.frame()
    """

    def __init__(self, source: SumoSource, config: ObjectFieldConfig | None = None) -> None:
        config = ObjectFieldConfig() if config is None else config
        if not isinstance(config, ObjectFieldConfig):
            raise ConfigError(f"config must be an ObjectFieldConfig, got {type(config).__name__}")
        if not isinstance(source, SumoSource):  # e.g. a background source: SUMO elsewhere
            raise ConfigError(
                f"source must be an in-process SumoSource, got {type(source).__name__}"
            )
        if source.closed:
            raise ConfigError("the SUMO source is closed; give an open one")
        self.config, self._source = config, source
        api = self._api = source._api
        self.lanes = LaneTable.read(api)
        self.roadside = place_roadside(self.lanes, config.roadside)
        self._paths = RoutePaths(api, self.lanes) if config.map_path else None
        veh = api.vehicle
        self._get = {name: raw_function(api, f"vehicle_{name}", getattr(veh, name))
                     for name in _GETTERS}  # fmt: skip
        self._native = source._native  # the compiled reader where the source reads with it
        if self._native is not None:
            self._edges = self._native.Codes()
            for edge, row in self.lanes.edge_code.items():
                self._edges[edge] = row
        road = self.roadside
        self._road_props = np.stack(
            [road.elevation, np.zeros(len(road)), np.zeros(len(road)), road.length, road.width,
             road.height, road.rcs, road.thermal_contrast, np.zeros(len(road))]
        )  # fmt: skip
        self._static_rows = np.full((5, 0), np.nan)  # _statics by object id (_statics_of)
        self._room = 4096  # hits (ego, object) the search can hold, grown as needed
        n = source.n_pairs
        # Headings and vehicle ids of the slots, with their time: at the previous step and
        # at the current one (see _yaw_rate).
        self._prev = self._now = (np.zeros(n), np.full(n, -1, dtype=np.int64), math.nan)
        # Per vehicle (by object id): edge row and lane index at the last frame, time of its
        # last lane change, the lateral speed given it and the jump [m] between the two
        # lanes' centrelines (module docstring).
        self._last_lane = np.full((2, 0), -1, dtype=np.int64)
        self._lane_change = np.zeros((3, 0))
        self._jumps = not _continuous_lane_changes(api)

    def _statics(self, vid: str) -> tuple[float, float, float, float, float]:
        """Length, width, height [m], rcs [dBsm] and thermal contrast [K] of a vehicle, from
        SUMO (:meth:`_statics_of` reads them once per object id)."""
        veh = self._api.vehicle
        rcs, thermal = VCLASS_SIGNATURE.get(veh.getVehicleClass(vid), VCLASS_SIGNATURE["passenger"])
        return veh.getLength(vid), veh.getWidth(vid), veh.getHeight(vid), rcs, thermal

    def _statics_of(self, ids: list[str], oid: np.ndarray) -> np.ndarray:
        """``(5, n)`` :meth:`_statics` of the vehicles ``ids`` of object ids ``oid``, from a
        table by object id (the ids only grow; a vehicle's row is filled at its first
        frame)."""
        table = self._static_rows
        if oid.size and oid.max() >= table.shape[1]:  # room for the new ids
            grown = np.full((5, 2 * int(oid.max()) + 64), np.nan)
            grown[:, : table.shape[1]] = table
            table = self._static_rows = grown
        for i in np.flatnonzero(np.isnan(table[0, oid])).tolist():
            table[:, oid[i]] = self._statics(ids[i])
        return table[:, oid]

    def _read(self, ids: list[str]) -> tuple[np.ndarray, np.ndarray]:
        """Every vehicle's ``(6, n)`` position x, y, angle, speed, acceleration, lane position
        and ``(2, n)`` edge row and lane index: the compiled reader's ``state``, else the
        SWIG getters (module docstring)."""
        n = len(ids)
        f, k = np.empty((6, n)), np.empty((2, n), dtype=np.int64)
        if self._native is not None:
            self._native.state(ids, self._edges, f, k)
            return f, k
        g = self._get
        xy = np.fromiter(chain.from_iterable(map(g["getPosition"], ids)), float, 2 * n)
        f[0], f[1] = xy[0::2], xy[1::2]
        for row, name in enumerate(_ROW_GETTERS, start=2):
            f[row] = np.fromiter(map(g[name], ids), float, n)
        k[0] = np.fromiter(map(self.lanes.edge_code.get, map(g["getRoadID"], ids), repeat(-1)),
                           np.int64, n)  # fmt: skip
        k[1] = np.fromiter(map(g["getLaneIndex"], ids), np.int64, n)
        return f, k

    def _lateral_speed(self, t: float, oid: np.ndarray, edge: np.ndarray, lane: np.ndarray):
        """``(n,)`` lateral speed [m/s] of the vehicles ``oid`` now on ``lane`` of ``edge``
        (module docstring)."""
        if oid.size and oid.max() >= self._lane_change.shape[1]:  # room for the new ids
            room = 2 * int(oid.max()) + 64
            grown = np.full((2, room), -1, dtype=np.int64)
            grown[:, : self._last_lane.shape[1]] = self._last_lane
            times = np.zeros((3, room))
            times[0] = -math.inf
            times[:, : self._lane_change.shape[1]] = self._lane_change
            self._last_lane, self._lane_change = grown, times
        lanes = self.lanes
        last_edge, last_lane = self._last_lane[:, oid]
        changed = np.flatnonzero((edge >= 0) & (edge == last_edge) & (lane != last_lane))
        if changed.size:
            first = lanes.first_lane[edge[changed]]
            width, before = (
                lanes.width[first + lane[changed]],
                lanes.width[first + last_lane[changed]],
            )
            side = np.sign(lane[changed] - last_lane[changed])
            self._lane_change[0, oid[changed]] = t
            self._lane_change[1, oid[changed]] = side * width / LANE_CHANGE_DURATION
            self._lane_change[2, oid[changed]] = side * 0.5 * (width + before)
        self._last_lane[0, oid], self._last_lane[1, oid] = edge, lane
        recent = t - self._lane_change[0, oid] < LANE_CHANGE_DURATION
        return np.where(recent, self._lane_change[1, oid], 0.0)

    def _vehicles(self, t: float) -> tuple[list[str], dict[str, np.ndarray]]:
        """The state of every vehicle the source knows at time ``t``, ``(n,)`` arrays in the
        network frame (module docstring), and their ids."""
        ids = list(self._get["getIDList"]())
        info = self._source._info
        oid = np.fromiter(map(itemgetter(0), map(info.get, ids, repeat(_NO_INFO))), np.int64)
        if np.any(oid < 0):  # not (or no longer) known to the source: not an object
            ids, oid = [v for v, i in zip(ids, oid.tolist(), strict=True) if i >= 0], oid[oid >= 0]
        n = len(ids)
        f, k = self._read(ids)
        heading = np.radians(90.0 - f[2])
        statics = self._statics_of(ids, oid)
        half = statics[0] / 2
        state = {
            "x": f[0] - half * np.cos(heading),
            "y": f[1] - half * np.sin(heading),
            "heading": heading,
            "length": statics[0],
            "object_id": oid,
            "edge": k[0],
            "lane": k[1],
            "lane_pos": f[5],
            # The pass-through properties, in the order of object_kernels._PROPS.
            "props": np.vstack(
                [np.zeros(n), f[3], f[4], statics, self._lateral_speed(t, oid, k[0], k[1])]
            ),  # fmt: skip
        }
        return ids, state

    def arrays(self, egos: int) -> ObjectArrays:
        """The arrays of ``frame(egos)`` (made anew; what SUMO's background process sends,
        :class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource`).

        Raises:
            InputError: ``egos`` is out of range or leaves out an active slot.
        """
        truth, active = self._current()
        return self._arrays(truth, check_prefix(egos, active))

    def _current(self):
        """The source's frame of the current step and its active slots (the source must be
        open)."""
        if self._source.closed:
            raise ConfigError("the SUMO source is closed")
        return self._source.frame(), self._source.active

    def _arrays(self, truth, n: int) -> ObjectArrays:
        """The object arrays of the first ``n`` slots at ``truth``'s step."""
        src, cfg = self._source, self.config
        ids, veh = self._vehicles(truth.t)
        road, nv = self.roadside, len(ids)
        nr = len(road)
        obj = {
            name: np.concatenate([veh[name], getattr(road, name)])
            for name in ("x", "y", "heading", "length", "object_id")
        }
        obj["edge"] = np.concatenate([veh["edge"], np.full(nr, -1, np.int64)])
        obj["lane"] = np.concatenate([veh["lane"], np.full(nr, -1, np.int64)])
        kind = np.concatenate([np.full(nv, _VEHICLE, np.int8), road.kind])
        props = np.concatenate([veh["props"], self._road_props], axis=1)
        # The egos: each slot's row among the objects (-1: none).
        row_of = dict(zip(ids, range(nv), strict=True))
        ego = np.fromiter(map(row_of.get, src.vehicle_ids[:n], repeat(-1)), np.int64, n)
        ego[~src.active[:n]] = -1
        has = ego >= 0
        heading, ego_id = np.zeros(n), np.full(n, -1, np.int64)
        heading[has], ego_id[has] = obj["heading"][ego[has]], obj["object_id"][ego[has]]
        curvature, lane_width, path = self._ego_lane(ego, veh, src.vehicle_ids[:n], ego_id)
        keys, order = _grid(obj["x"], obj["y"])
        cos_h, sin_h = np.cos(obj["heading"]), np.sin(obj["heading"])
        counts = np.zeros(n, dtype=np.int64)
        while True:  # the hits of every ego; once more with room for all when they overflow
            hits = (np.empty(self._room, np.int64), np.empty(self._room), np.empty(self._room))
            total = _search(ego, obj["x"], obj["y"], cos_h, sin_h, obj["length"], keys, order,
                            cfg.ahead, cfg.lateral, counts, *hits)  # fmt: skip
            if total <= self._room:
                break
            self._room = 2 * total
        out = object_outputs(n, int(counts.max()) if n else 0)
        _fill(ego, counts, *hits, truth.leader_id[:n], truth.ego_speed[:n], curvature,
              lane_width, cos_h, sin_h, kind, obj["object_id"], obj["edge"], obj["lane"], props,
              *out)  # fmt: skip
        yaw_rate = self._yaw_rate(truth.t, heading, ego_id, has)
        return ObjectArrays(*out, yaw_rate, curvature, self._shift(truth.t, ego_id), path)

    def _shift(self, t: float, ego_id: np.ndarray) -> np.ndarray:
        """``(E,)`` the sideways jump [m] of the egos ``ego_id`` (-1: none) that changed
        lanes at time ``t`` (module docstring, "The ego's lane change"), else 0."""
        shift, has = np.zeros(ego_id.size), (ego_id >= 0) & self._jumps
        when, jump = self._lane_change[0, ego_id[has]], self._lane_change[2, ego_id[has]]
        shift[has] = np.where(when == t, jump, 0.0)
        return shift

    def _ego_lane(
        self, ego: np.ndarray, veh: dict, vids: list[str | None], ego_id: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Road curvature [1/m] and lane width [m] at each ego (0 and 1 for empty slots), and
        the egos' map paths (``(E, 0)`` without ``map_path``) given their vehicle ids
        ``vids`` and object ids ``ego_id``."""
        lanes, has = self.lanes, ego >= 0
        curvature, width = np.zeros(len(ego)), np.ones(len(ego))
        rows = ego[has]  # vehicles come first among the objects
        edge, index = veh["edge"][rows], veh["lane"][rows]
        on_net = (edge >= 0) & (index >= 0)
        lane = np.where(on_net, lanes.first_lane[np.maximum(edge, 0)] + index, -1)
        pos = veh["lane_pos"][rows]
        curvature[has] = curvature_at(lane, pos, lanes.start, lanes.vs, lanes.vh)
        width[has] = np.where(on_net, lanes.width[np.maximum(lane, 0)], 1.0)
        if self._paths is None:
            return curvature, width, np.zeros((len(ego), 0))
        every = np.full(len(ego), -1, np.int64)
        every[has] = lane
        front, at = np.zeros((3, len(ego))), np.zeros(len(ego))
        heading = veh["heading"][rows]
        half = veh["length"][rows] / 2
        front[:, has] = (veh["x"][rows] + half * np.cos(heading),
                         veh["y"][rows] + half * np.sin(heading), heading)  # fmt: skip
        at[has] = pos
        ids = [v if h else None for v, h in zip(vids, has.tolist(), strict=True)]
        return curvature, width, self._paths.paths(ids, ego_id, every, at, *front)

    def _yaw_rate(self, t: float, heading: np.ndarray, ids: np.ndarray, has: np.ndarray):
        """``(E,)`` heading change per second since the last frame of the same vehicle (the
        slots beyond ``E`` hold no vehicle now)."""
        if t != self._now[2]:  # the step's first frame: the last step's become the previous
            self._prev = self._now
        (prev_heading, prev_id, prev_t), e = self._prev, ids.size
        same = has & (ids == prev_id[:e]) & (t > prev_t)
        dt = t - prev_t if same.any() else 1.0
        yaw = np.where(same, np.angle(np.exp(1j * (heading - prev_heading[:e]))) / dt, 0.0)
        rest = prev_id.size - e
        self._now = (np.concatenate([heading, np.zeros(rest)]),
                     np.concatenate([ids, np.full(rest, -1, np.int64)]), t)  # fmt: skip
        return yaw


def _continuous_lane_changes(api) -> bool:
    """Whether the running simulation moves its vehicles across lanes over time (the
    sublane model, or a lane-change duration) rather than within one step."""
    options = ("lateral-resolution", "lanechange.duration")
    return any(float(api.simulation.getOption(name)) > 0.0 for name in options)


#: The getters of the float rows 2-5 of :meth:`SumoObjects._read` (rows 0-1: getPosition).
_ROW_GETTERS = ("getAngle", "getSpeed", "getAcceleration", "getLanePosition")
#: Every libsumo getter :class:`SumoObjects` calls per step (the SWIG fallback).
_GETTERS = ("getIDList", "getPosition", "getRoadID", "getLaneIndex", *_ROW_GETTERS)
#: ``_info`` entry of a vehicle the source does not know.
_NO_INFO = (-1, False, False)
_VEHICLE = int(ObjectKind.VEHICLE)
