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
    centres are sorted by their cell of a uniform grid (:data:`GRID_CELL`), and each ego
    visits the cells under its field's bounding box widened by the longest object's half
    length (a binary search in the sorted keys per grid column), once to count and once to
    fill.

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
    ego's road curvature :math:`\kappa`, in lane widths :math:`w` of the ego lane,
    :math:`\operatorname{round}((y - \kappa x^2/2) / w)` (the ego is taken on its lane's
    centreline: SUMO's default lane-based model).  Roadside objects are
    :data:`~acc_fusion.truth.objects.OFF_ROAD`.

Reading SUMO
    Every vehicle's position, angle, speed, acceleration, edge and lane index are read at each
    step with libsumo's raw SWIG getters mapped over the ids (no Python frame per vehicle);
    length, width, height and class once per vehicle.  Measured on the bundled motorway with
    495 vehicles (SUMO 1.28): the six getters cost 2.1 ms per step; subscribing the same
    variables costs 3.0 ms more in ``simulationStep`` plus 2.4 ms for
    ``getAllSubscriptionResults`` and the conversion — the getters win.

Radar cross-section and thermal contrast of vehicles: :data:`VCLASS_SIGNATURE`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import chain, repeat
from operator import itemgetter
from typing import Any

import numpy as np
from numba import njit

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_range
from acc_fusion.truth.objects import OFF_ROAD, ObjectFrame, ObjectKind
from acc_fusion.truth.sumo.reading import raw_function
from acc_fusion.truth.sumo.roadside import LaneTable, RoadsideConfig, place_roadside

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


@dataclass(frozen=True)
class ObjectFieldConfig:
    """The forward field of each ego (validated on construction; SI units).

    Attributes:
        ahead: farthest ``x`` of an object's nearest face [m]; 200 (long-range radar).
        lateral: largest ``|y|`` [m]; 15 (four 3.5 m lanes either side).
        roadside: the stationary objects placed along the network, a :class:`RoadsideConfig`.
    """

    ahead: float = 200.0
    lateral: float = 15.0
    roadside: RoadsideConfig = RoadsideConfig()

    def __post_init__(self) -> None:
        check_range("field.ahead", self.ahead, 0.0, 5000.0, lo_open=True)
        check_range("field.lateral", self.lateral, 0.0, 1000.0, lo_open=True)
        if not isinstance(self.roadside, RoadsideConfig):
            raise ConfigError(
                f"field.roadside must be a RoadsideConfig, got {type(self.roadside).__name__}"
            )


class SumoObjects:
    """The object truth of a running SUMO source (module docstring).

    Args:
        source: an open :class:`~acc_fusion.truth.sumo.source.SumoSource` (in this process).
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

    def __init__(self, source: Any, config: ObjectFieldConfig | None = None) -> None:
        config = ObjectFieldConfig() if config is None else config
        if not isinstance(config, ObjectFieldConfig):
            raise ConfigError(f"config must be an ObjectFieldConfig, got {type(config).__name__}")
        if source.closed:
            raise ConfigError("the SUMO source is closed; give an open one")
        self.config, self._source = config, source
        api = self._api = source._api
        self.lanes = LaneTable.read(api)
        self.roadside = place_roadside(self.lanes, config.roadside)
        veh = api.vehicle
        self._get = {
            name: raw_function(api, f"vehicle_{name}", getattr(veh, name))
            for name in (
                "getIDList", "getPosition", "getAngle", "getSpeed", "getAcceleration",
                "getRoadID", "getLaneIndex", "getLanePosition",
            )
        }  # fmt: skip
        self._static: dict[str, tuple[float, float, float, float, float]] = {}
        n = source.n_pairs
        self._prev_heading = np.zeros(n)
        self._prev_id = np.full(n, -1, dtype=np.int64)
        self._prev_t = math.nan

    def _statics(self, vid: str) -> tuple[float, float, float, float, float]:
        """Length, width, height [m], rcs [dBsm] and thermal contrast [K] of a vehicle (read
        once per vehicle)."""
        found = self._static.get(vid)
        if found is None:
            veh = self._api.vehicle
            rcs, thermal = VCLASS_SIGNATURE.get(
                veh.getVehicleClass(vid), VCLASS_SIGNATURE["passenger"]
            )
            found = (veh.getLength(vid), veh.getWidth(vid), veh.getHeight(vid), rcs, thermal)
            self._static[vid] = found
        return found

    def _vehicles(self) -> tuple[tuple[str, ...], dict[str, np.ndarray]]:
        """Every vehicle's state, ``(n,)`` arrays in the network frame (module docstring)."""
        g = self._get
        ids = tuple(g["getIDList"]())
        n = len(ids)
        if len(self._static) > 2 * n + 256:  # forget the vehicles that left
            self._static = {v: self._static[v] for v in ids if v in self._static}
        front = np.fromiter(chain.from_iterable(map(g["getPosition"], ids)), float, 2 * n)
        front = front.reshape(n, 2)
        angle = np.fromiter(map(g["getAngle"], ids), float, n)
        heading = np.radians(90.0 - angle)
        statics = np.array(list(map(self._statics, ids)), dtype=float).reshape(n, 5)
        info = self._source._info
        edge_code = self.lanes.edge_code
        state = {
            "heading": heading,
            "speed": np.fromiter(map(g["getSpeed"], ids), float, n),
            "accel": np.fromiter(map(g["getAcceleration"], ids), float, n),
            "edge": np.fromiter(map(edge_code.get, map(g["getRoadID"], ids), repeat(-1)),
                                np.int64, n),  # fmt: skip
            "lane": np.fromiter(map(g["getLaneIndex"], ids), np.int64, n),
            "object_id": np.fromiter(map(itemgetter(0), map(info.get, ids, repeat(_NO_INFO))),
                                     np.int64, n),  # fmt: skip
            "length": statics[:, 0], "width": statics[:, 1], "height": statics[:, 2],
            "rcs": statics[:, 3], "thermal_contrast": statics[:, 4],
        }  # fmt: skip
        half = statics[:, 0] / 2
        state["x"] = front[:, 0] - half * np.cos(heading)
        state["y"] = front[:, 1] - half * np.sin(heading)
        return ids, state

    def frame(self) -> ObjectFrame:
        """The :class:`~acc_fusion.truth.objects.ObjectFrame` of the source's current step."""
        src, cfg = self._source, self.config
        if src.closed:
            raise ConfigError("the SUMO source is closed")
        truth = src.frame()
        ids, veh = self._vehicles()
        road = self.roadside
        known = veh["object_id"] >= 0  # every vehicle the source knows (all but oddities)
        obj = {
            name: np.concatenate([veh[name][known], getattr(road, name)])
            for name in ("x", "y", "heading", "length", "width", "height", "rcs",
                         "thermal_contrast", "object_id")
        }  # fmt: skip
        nv = int(known.sum())
        nr = len(road)
        obj["speed"] = np.concatenate([veh["speed"][known], np.zeros(nr)])
        obj["accel"] = np.concatenate([veh["accel"][known], np.zeros(nr)])
        obj["elevation"] = np.concatenate([np.zeros(nv), road.elevation])
        obj["kind"] = np.concatenate([np.full(nv, int(ObjectKind.VEHICLE), np.int8), road.kind])
        obj["edge"] = np.concatenate([veh["edge"][known], np.full(nr, -1, np.int64)])
        obj["lane"] = np.concatenate([veh["lane"][known], np.full(nr, -1, np.int64)])
        # The egos: each slot's row among the objects (-1: none).
        row_of = dict(zip(np.asarray(ids)[known].tolist(), range(nv), strict=True))
        ego = np.fromiter(map(row_of.get, src.vehicle_ids, repeat(-1)), np.int64, src.n_pairs)
        ego[~src.active] = -1
        has = ego >= 0
        e_rows = np.where(has, ego, 0)
        e_heading = np.where(has, obj["heading"][e_rows], 0.0)
        e_id = np.where(has, obj["object_id"][e_rows], -1)
        curvature, lane_width = self._ego_lane(ids, known, ego, obj)
        keys, order = _grid(obj["x"], obj["y"])
        args = (ego, truth.leader_id, curvature, lane_width, obj["x"], obj["y"], obj["heading"],
                obj["length"], obj["kind"], obj["object_id"], obj["edge"], obj["lane"],
                keys, order, cfg.ahead, cfg.lateral)  # fmt: skip
        counts = np.zeros(len(ego), dtype=np.int64)
        _scan(*args, counts, *_outputs(len(ego), 0))  # count
        out = _outputs(len(ego), int(counts.max()) if len(counts) else 0)
        _scan(*args, counts, *out)  # fill
        rows, x, y, lane, lead = out
        yaw = self._yaw_rate(truth.t, e_heading, e_id, has)
        valid = rows >= 0
        j = np.where(valid, rows, 0)

        def pick(name: str) -> np.ndarray:
            return np.where(valid, obj[name][j], np.nan)

        rel = np.angle(np.exp(1j * (obj["heading"][j] - e_heading[:, None])))
        speed = pick("speed")
        return ObjectFrame(
            t=truth.t,
            ego_speed=truth.ego_speed,
            ego_accel=truth.ego_accel,
            ego_yaw_rate=yaw,
            road_curvature=curvature,
            valid=valid,
            object_id=np.where(valid, obj["object_id"][j], -1),
            kind=np.where(valid, obj["kind"][j], 0).astype(np.int8),
            x=x,
            y=y,
            elevation=pick("elevation"),
            vx=np.where(valid, speed * np.cos(rel) - truth.ego_speed[:, None], np.nan),
            vy=np.where(valid, speed * np.sin(rel), np.nan),
            speed=speed,
            accel=pick("accel"),
            heading=np.where(valid, rel, np.nan),
            length=pick("length"),
            width=pick("width"),
            height=pick("height"),
            rcs=pick("rcs"),
            thermal_contrast=pick("thermal_contrast"),
            lane=lane,
            lead=lead,
        )

    def _ego_lane(
        self, ids: tuple[str, ...], known: np.ndarray, ego: np.ndarray, obj: dict
    ) -> tuple[np.ndarray, np.ndarray]:
        """Road curvature [1/m] and lane width [m] at each ego (0 and 1 for empty slots)."""
        lanes, has = self.lanes, ego >= 0
        curvature, width = np.zeros(len(ego)), np.ones(len(ego))
        rows = ego[has]
        edge, index = obj["edge"][rows], obj["lane"][rows]
        on_net = (edge >= 0) & (index >= 0)
        global_lane = np.where(on_net, lanes.first_lane[np.maximum(edge, 0)] + index, -1)
        vids = np.asarray(ids)[known][rows]
        pos = np.fromiter(map(self._get["getLanePosition"], vids.tolist()), float, len(vids))
        curvature[has] = _curvature_at(global_lane, pos, lanes.start, lanes.vs, lanes.vk)
        width[has] = np.where(on_net, lanes.width[np.maximum(global_lane, 0)], 1.0)
        return curvature, width

    def _yaw_rate(self, t: float, heading: np.ndarray, ids: np.ndarray, has: np.ndarray):
        """``(E,)`` heading change per second since the last frame of the same vehicle."""
        same = has & (ids == self._prev_id) & (t > self._prev_t)
        dt = t - self._prev_t if same.any() else 1.0
        yaw = np.where(same, np.angle(np.exp(1j * (heading - self._prev_heading))) / dt, 0.0)
        self._prev_heading, self._prev_id, self._prev_t = heading, ids, t
        return yaw


#: ``_info`` entry of a vehicle the source does not know.
_NO_INFO = (-1, False, False)
_OFFSET = 1 << 20  # grid cells from the origin a key can hold on either side
_VEHICLE, _OFF_ROAD = int(ObjectKind.VEHICLE), int(OFF_ROAD)


def _outputs(n: int, m: int) -> tuple[np.ndarray, ...]:
    """Empty outputs of :func:`_scan` for ``n`` egos and ``m`` object slots: object rows
    (-1), ``x``, ``y`` (NaN), relative lanes (off-road) and lead slots (-1)."""
    return (
        np.full((n, m), -1, dtype=np.int64),
        np.full((n, m), np.nan),
        np.full((n, m), np.nan),
        np.full((n, m), _OFF_ROAD, dtype=np.int64),
        np.full(n, -1, dtype=np.int64),
    )


#: Side of a cell of the search grid [m]: a field of 200 m x 30 m spans a few cells.
GRID_CELL = 50.0


def _grid(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Grid keys of the object centres (cells of :data:`GRID_CELL`), sorted, and the order."""
    ix = np.floor(x / GRID_CELL).astype(np.int64)
    keys = _cell_key(ix, np.floor(y / GRID_CELL).astype(np.int64))
    order = np.argsort(keys, kind="stable")
    return keys[order], order


@njit(cache=True)
def _cell_key(ix, iy):  # pragma: no cover - compiled
    """One int64 key of grid cell ``(ix, iy)``: the cells of a column ``ix`` are consecutive."""
    return (ix + _OFFSET) * (2 * _OFFSET) + (iy + _OFFSET)


@njit(cache=True)
def _scan(
    ego, lead_id, curvature, lane_width, ox, oy, oh, olen, okind, oid, oedge, olane,
    keys, order, ahead, lateral, counts, rows, out_x, out_y, out_lane, lead,
):  # pragma: no cover - compiled  # fmt: skip
    """Find each ego's objects in the field (module docstring): the grid columns under the
    field's bounding box (widened by the longest object's half length), one key range per
    column.  With ``rows`` of zero width it only counts them into ``counts``; else it fills
    ``rows`` (object index), the near face's ``out_x``, ``out_y``, the relative ``out_lane``
    and ``lead`` (the slot of the vehicle whose id is ``lead_id``)."""
    fill = rows.shape[1] > 0
    cos_h, sin_h = np.cos(oh), np.sin(oh)
    margin = 0.5 * olen.max() if olen.shape[0] else 0.0
    for e in range(ego.shape[0]):
        i = ego[e]
        if i < 0:
            continue
        c, s = cos_h[i], sin_h[i]
        px, py = ox[i] + 0.5 * olen[i] * c, oy[i] + 0.5 * olen[i] * s
        # The field's corners p + a u + b n, a in {0, ahead}, b in {-lateral, lateral}.
        x_lo = px + min(0.0, ahead * c) - lateral * abs(s) - margin
        x_hi = px + max(0.0, ahead * c) + lateral * abs(s) + margin
        y_lo = py + min(0.0, ahead * s) - lateral * abs(c) - margin
        y_hi = py + max(0.0, ahead * s) + lateral * abs(c) + margin
        iy0, iy1 = math.floor(y_lo / GRID_CELL), math.floor(y_hi / GRID_CELL)
        k = 0
        for ix in range(math.floor(x_lo / GRID_CELL), math.floor(x_hi / GRID_CELL) + 1):
            lo = np.searchsorted(keys, _cell_key(ix, iy0), side="left")
            hi = np.searchsorted(keys, _cell_key(ix, iy1), side="right")
            for t in range(lo, hi):
                j = order[t]
                if j == i:
                    continue
                hl = 0.5 * olen[j]
                rx, ry = ox[j] - hl * cos_h[j] - px, oy[j] - hl * sin_h[j] - py
                fx, fy = ox[j] + hl * cos_h[j] - px, oy[j] + hl * sin_h[j] - py
                if fx * fx + fy * fy < rx * rx + ry * ry:
                    rx, ry = fx, fy
                x = rx * c + ry * s
                y = -rx * s + ry * c
                if x < 0.0 or x > ahead or abs(y) > lateral:
                    continue
                if fill:
                    rows[e, k], out_x[e, k], out_y[e, k] = j, x, y
                    if okind[j] != _VEHICLE:  # stationary: on no lane
                        out_lane[e, k] = _OFF_ROAD
                    elif oedge[j] >= 0 and oedge[j] == oedge[i]:
                        out_lane[e, k] = olane[j] - olane[i]
                    else:
                        off = (y - 0.5 * curvature[e] * x * x) / lane_width[e]
                        out_lane[e, k] = np.int64(np.round(off))
                    if oid[j] == lead_id[e] and okind[j] == _VEHICLE:
                        lead[e] = k
                k += 1
        counts[e] = k


@njit(cache=True)
def _curvature_at(lane, pos, start, vs, vk):  # pragma: no cover - compiled
    """Curvature of global lanes ``lane`` at lane positions ``pos``, linear between the
    vertices (0 off the network, ``lane < 0``)."""
    out = np.zeros(lane.shape[0])
    for i in range(lane.shape[0]):
        g = lane[i]
        if g >= 0:
            a, b = start[g], start[g + 1]
            out[i] = np.interp(pos[i], vs[a:b], vk[a:b])
    return out
