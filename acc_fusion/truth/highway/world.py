r"""highway-env as the truth source of the 2-D world (:class:`HighwayWorld`): an
:class:`~acc_fusion.truth.objects.ObjectFrame` per step for the slots of a running
:class:`~acc_fusion.truth.highway.source.HighwaySource`, with the geometry of
:mod:`acc_fusion.truth.sumo.objects` on highway-env's road, vehicles and road objects.

highway-env's frame, read as right-handed
    A vehicle's ``position`` is the centre of its ``LENGTH`` x ``WIDTH`` box in the road's
    axes :math:`(x, y)` [m], its ``heading`` :math:`\psi` the direction of its velocity
    there (:math:`\operatorname{atan2}`).  highway-env's renderer draws :math:`y` downward;
    here :math:`(x, y, \psi)` is a mathematical right-handed frame (:math:`y` left of
    :math:`+x`, :math:`\psi` counter-clockwise), so every picture highway-env renders is this
    world's mirror image.  A lane's ``direction_lateral`` (its direction turned by +90°) then
    points left, and in every supported environment lane ids grow to the left (lane ``k`` at
    :math:`y = 4k`): lane 0 is the rightmost, as SUMO's index 0, and ``merge-v0``'s ramp
    (lane 2 of ``b→c``) joins from the left.  highway-env means the other hand (its
    ``LANE_RIGHT`` action moves to lane id + 1, its ``right_lane_reward`` rewards the highest
    id, ``merge-v0``'s ramp is a right-hand on-ramp): in this world all of them are on the
    left.  Its IDM and MOBIL have no side preference and the sensors none either, so the
    mirror changes which side the ramp, the shoulder and its roadside objects are on, not
    the traffic.

The ego frame and the field
    Ego :math:`e` (a slot's vehicle) has heading :math:`u_e = (\cos\psi_e, \sin\psi_e)`, left
    normal :math:`n_e = (-\sin\psi_e, \cos\psi_e)` and origin its front bumper centre
    :math:`p_e = c_e + \tfrac12\ell_e u_e`.  An object's position is its nearest face, of
    :math:`c \mp \tfrac12\ell u` the one closer to :math:`p_e`:
    :math:`x = (q - p_e)\cdot u_e,\ y = (q - p_e)\cdot n_e`.  Ground velocity is
    :math:`v(\cos\psi, \sin\psi)` (highway-env's ``velocity``: no slip angle, as the source),
    so :math:`v_x = v\cos(\psi - \psi_e) - v_e,\ v_y = v\sin(\psi - \psi_e)`, ``heading``
    :math:`\operatorname{wrap}(\psi - \psi_e)`, ``ego_speed`` the ego's ground speed
    :math:`v_e` (a stationary object moves at exactly :math:`(-v_e, 0)`); accelerations
    :math:`(v_k - v_{k-1}) / \Delta t`, the source's (0 at an episode's first frame).  The
    field: :math:`0 \le x \le` ``ahead``, :math:`|y| \le` ``lateral`` (200 m, 15 m).

Vehicles
    Every vehicle of ``road.vehicles`` but the ego, crashed ones included (they stop in their
    lane); object id the source's integer id (its ``leader_id``).  Size ``LENGTH`` x
    ``WIDTH``; height, radar cross-section and thermal contrast the ``VEHICLE`` row of
    :data:`acc_fusion.truth.scenes.SIGNATURES`, the only table with every field of a car
    (SUMO's ``VCLASS_SIGNATURE`` leaves the height to SUMO's vehicle types).

Relative lane (``lane``, left positive)
    highway-env's ``lane_index`` is ``(from, to, id)``.  On the ego's segment (same
    ``from, to``): :math:`\sigma(i - i_e)`, :math:`\sigma = +1` where lane 1 lies left of
    lane 0 (every supported segment), else -1.  Elsewhere (the next segment, the ramp): the
    offset from the ego's lane in that lane's coordinates,
    :math:`\operatorname{round}((r - r_e) / w_e)` — as ``SumoObjects`` rounds its offset from
    the ego's path — with each lane extended along its base beyond its ends (exact for
    ``merge-v0``'s sine ramp, whose ends are parallel to its base).  Roadside objects:
    :data:`~acc_fusion.truth.objects.OFF_ROAD`.

Lateral speed, lead, ego motion
    ``lateral_speed`` is :math:`v\sin(\psi - \psi_{\text{lane}})`, :math:`\psi_{\text{lane}}`
    the heading of the object's own lane at its position (left positive).  ``lead`` is the
    slot of the source's leader (its :class:`~acc_fusion.truth.frame.TruthFrame`'s
    ``leader_id``: ``Road.neighbour_vehicles``' rule within ``lookahead``) when it is in the
    field, else -1; on a straight lane its ``x`` is the source's gap, so
    :meth:`~acc_fusion.truth.objects.ObjectFrame.lead_frame` reproduces the 1-D frame.
    ``ego_yaw_rate`` is :math:`\operatorname{wrap}(\psi_k - \psi_{k-1}) / (t_k - t_{k-1})` of
    the same vehicle in the slot (0 at its first frame: a new episode), so
    :meth:`HighwayWorld.frame` is meant to be called after every step.  ``road_curvature``
    is the ego lane's at the ego's lane coordinate :math:`s`
    (:meth:`~acc_fusion.truth.highway.lanes.LaneRows.curvature`: 0 on a ``StraightLane``,
    the curvature of the sine graph on a ``SineLane``, ``direction / radius`` on a
    ``CircularLane``, left positive in this frame).  Lane coordinates are highway-env's, a
    lane extended along its base beyond its ends (``clip``).

The map
    With ``map_path`` in the field (the selection's ``"map"`` path), each ego's lane and the
    lanes it continues into, laid into its frame (:mod:`acc_fusion.truth.highway.lane_path`),
    are the frame's ``road_path``; NaN in the rows of empty slots.

Road objects
    highway-env's solid ``road.objects`` (``merge-v0``'s ``Obstacle`` closing the
    acceleration lane) are stationary ``GUARDRAIL`` objects, "other roadside metal": a real
    lane end is closed by a barrier terminal or crash cushion, low metal, neither a vehicle
    nor an overhead structure.  Size highway-env's, height and signature the ``GUARDRAIL``
    row of ``SIGNATURES``; it stands on a lane, so its ``lane`` is relative as a vehicle's.

Roadside objects
    At each episode's start, :func:`~acc_fusion.truth.sumo.roadside.place_roadside` of the
    field's :class:`~acc_fusion.truth.sumo.roadside.RoadsideConfig` on every segment whose
    lanes are all ``StraightLane`` (a :class:`~acc_fusion.truth.sumo.roadside.LaneTable` of
    two-vertex lanes, right to left): gantries and bridges across the carriageway, guardrail
    posts and parked vehicles on the right; then on each segment seen from its left edge
    (lanes reversed) for posts only: a median barrier at the same ``shoulder_width``
    (assumption).  Posts and parked vehicles standing on a lane (the ramp beside the
    carriageway) are removed.  Seeded by ``(roadside.seed, source seed, episode)``.
    :data:`DEFAULT_FIELD` drops the speed-limit filter: every supported road is a motorway,
    though ``merge-v0`` posts 20 m/s.  Ids count up from
    :data:`~acc_fusion.truth.sumo.roadside.ROADSIDE_ID_BASE`, never reused in a run.

Limitations
    highway-env is flat (elevations 0, no bridges) and has one vehicle size; the sine ramp
    gets no roadside objects; slip angles are ignored; ``highway-fast-v0`` steps at 5 Hz (the
    sensors sample at the step); ``road.objects`` are read at an episode's start only.
"""

from __future__ import annotations

import math
from dataclasses import fields, replace
from typing import Any

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.truth.highway.lane_path import NetworkPaths
from acc_fusion.truth.highway.lanes import LaneRows, wrap_angle
from acc_fusion.truth.highway.source import HighwaySource
from acc_fusion.truth.objects import OFF_ROAD, PATH_STATIONS, ObjectFrame, ObjectKind, SlotWorld
from acc_fusion.truth.scenes import SIGNATURES
from acc_fusion.truth.sumo.objects import ObjectFieldConfig
from acc_fusion.truth.sumo.roadside import (
    ROADSIDE_ID_BASE,
    LaneTable,
    Roadside,
    RoadsideConfig,
    place_roadside,
)

#: The default field: :class:`ObjectFieldConfig`'s reach, roadside objects on every straight
#: segment whatever its speed limit (module docstring).
DEFAULT_FIELD = ObjectFieldConfig(roadside=RoadsideConfig(min_speed=0.0))

#: Segment code of roadside objects (``lane`` OFF_ROAD) and of objects on no lane.
_ROADSIDE, _NO_LANE = -2, -1
#: Height [m], RCS [dBsm], thermal contrast [K] of vehicles and road objects (docstring).
_CAR, _RAIL = (SIGNATURES[k][2:] for k in (ObjectKind.VEHICLE, ObjectKind.GUARDRAIL))
#: Roadside kinds that stand on the ground beside the lanes.
_ON_GROUND = np.array([ObjectKind.GUARDRAIL, ObjectKind.PARKED], dtype=np.int8)
#: Object arrays copied into the frame as they are.
_PASS = ("speed", "accel", "length", "width", "height", "elevation", "rcs", "thermal_contrast",
         "lateral_speed")  # fmt: skip


class HighwayWorld(SlotWorld):
    """A :class:`HighwaySource` as the truth source of
    :func:`acc_fusion.sim.world.simulate_world`: its slots are the egos, their objects this
    module's frame; a new episode reassigns every slot.  It drives as the source does:
    :meth:`advance` passes the drivers' brake requests on, so the 2-D pipeline's warnings
    can close the loop.

    Args:
        source: an open :class:`~acc_fusion.truth.highway.source.HighwaySource`.
        config: the :class:`~acc_fusion.truth.sumo.objects.ObjectFieldConfig` (``None``:
            :data:`DEFAULT_FIELD`).

    Attributes:
        source: the source.  config: the field.  roadside: the current episode's placed
            :class:`~acc_fusion.truth.sumo.roadside.Roadside` objects.

    Raises:
        ConfigError: not a HighwaySource, a closed one, or not an ObjectFieldConfig.
    """

    #: It takes brake requests and holds a distracted driver's vehicle.
    accepts_brakes, accepts_hold = True, True

    def __init__(self, source: HighwaySource, config: ObjectFieldConfig | None = None) -> None:
        config = DEFAULT_FIELD if config is None else config
        if not isinstance(config, ObjectFieldConfig):
            raise ConfigError(f"config must be an ObjectFieldConfig, got {type(config).__name__}")
        if not isinstance(source, HighwaySource):
            raise ConfigError(f"source must be a HighwaySource, got {type(source).__name__}")
        if source.closed:
            raise ConfigError("the highway-env source is closed; give an open one")
        self.source, self.config = source, config
        n = source.n_pairs
        self._prev = self._now = (np.zeros(n), np.full(n, -1, np.int64), math.nan)
        self._truth: object = None  # the source's frame the object frame was made of
        self._frame: ObjectFrame | None = None
        self._next_id = 0  # ids of fixed objects used so far (ROADSIDE_ID_BASE + k)
        self._start(source.env.road)

    def advance(self, ego_brake: np.ndarray | None = None, hold: np.ndarray | None = None) -> None:
        """Run one highway-env step with the drivers' brake requests and held vehicles
        (:meth:`HighwaySource.advance <acc_fusion.truth.highway.source.HighwaySource.advance>`)."""
        self.source.advance(ego_brake, hold)

    def frame(self) -> ObjectFrame:
        """The object frame of the current step (made once per step; module docstring)."""
        src = self.source
        truth = src.frame()
        if truth is self._truth:  # the source's frame of this step (new at every step, reset)
            return self._frame
        self._truth = truth
        road = src.env.road
        if road is not self._road:
            self._start(road)
        vs, n, nv = road.vehicles, src.n_pairs, len(road.vehicles)
        st = np.array([(*v.position, v.heading, v.speed, v.LENGTH, v.WIDTH) for v in vs])
        seg, lid, row = np.array([self._lane_of(v.lane_index) for v in vs], np.int64).T
        s, _ = self._lanes.local(row, st[:, 0], st[:, 1], clip=True)
        speed = st[:, 3]
        accel = np.zeros(nv)
        if self._speed is not None and truth.t > self._speed[1]:
            accel = (speed - self._speed[0]) / (truth.t - self._speed[1])
        self._speed = (speed, truth.t)
        veh = {"x": st[:, 0], "y": st[:, 1], "psi": st[:, 2], "speed": speed, "accel": accel,
               "length": st[:, 4], "width": st[:, 5], "height": np.full(nv, _CAR[0]),
               "elevation": np.zeros(nv), "rcs": np.full(nv, _CAR[1]),
               "thermal_contrast": np.full(nv, _CAR[2]), "seg": seg, "lid": lid, "row": row,
               "lateral_speed": speed * np.sin(st[:, 2] - self._lanes.heading(row, s)),
               "id": src.road_ids,
               "kind": np.full(nv, int(ObjectKind.VEHICLE), np.int8)}  # fmt: skip
        obj = {k: np.concatenate([v, self._fixed[k]]) for k, v in veh.items()}
        slots = np.flatnonzero(src.active)
        vi = src.slot_vehicle_index[slots]
        psi_e, half_e = obj["psi"][vi], 0.5 * obj["length"][vi]
        front = (obj["x"][vi] + half_e * np.cos(psi_e), obj["y"][vi] + half_e * np.sin(psi_e))
        out = self._objects(obj, vi, slots, n, truth.leader_id[slots], front)
        if self._paths is not None:  # the map: each ego's lanes ahead
            pos, _ = self._lanes.local(row[vi], *front)
            out["road_path"] = np.full((n, PATH_STATIONS.size), np.nan)
            out["road_path"][slots] = self._paths.paths(
                [vs[i].lane_index for i in vi], pos, *front, psi_e
            )
        ego = np.zeros((3, n))  # heading, speed, curvature
        ids = np.full(n, -1, np.int64)
        ids[slots] = obj["id"][vi]
        ego[0, slots], ego[1, slots] = obj["psi"][vi], np.maximum(speed[vi], 0.0)
        ego[2, slots] = self._lanes.curvature(row[vi], s[vi])
        self._frame = ObjectFrame(
            t=truth.t, ego_speed=ego[1], ego_accel=truth.ego_accel, road_curvature=ego[2],
            ego_yaw_rate=self._yaw_rate(truth.t, ego[0], ids), **out,
        )  # fmt: skip
        return self._frame

    def _objects(
        self, obj: dict, vi: np.ndarray, slots: np.ndarray, n: int, leader: np.ndarray, front
    ) -> dict:
        """The ``(n, M)`` object arrays and ``lead`` of the egos of ``slots`` (vehicle indices
        ``vi``, leader ids ``leader``, front bumpers ``front = (x, y)``), over egos x
        candidate objects (module docstring)."""
        cfg = self.config
        psi_e, (px, py) = obj["psi"][vi], front
        c_e, s_e = np.cos(psi_e)[:, None], np.sin(psi_e)[:, None]
        # Candidates: within reach of some ego's bumper (a bound of every field).
        reach = math.hypot(cfg.ahead, cfg.lateral) + 0.5 * float(obj["length"].max())
        lo = np.array([px.min(initial=np.inf), py.min(initial=np.inf)]) - reach
        hi = np.array([px.max(initial=-np.inf), py.max(initial=-np.inf)]) + reach
        xy = np.stack([obj["x"], obj["y"]], axis=1)
        cand = np.flatnonzero(np.all((xy >= lo) & (xy <= hi), axis=1))
        o = {k: v[cand] for k, v in obj.items()}
        hx, hy = 0.5 * o["length"] * np.cos(o["psi"]), 0.5 * o["length"] * np.sin(o["psi"])
        rx, ry = o["x"] - hx - px[:, None], o["y"] - hy - py[:, None]
        fx, fy = o["x"] + hx - px[:, None], o["y"] + hy - py[:, None]
        front = fx * fx + fy * fy < rx * rx + ry * ry
        dx, dy = np.where(front, fx, rx), np.where(front, fy, ry)
        x, y = dx * c_e + dy * s_e, dy * c_e - dx * s_e
        mask = (x >= 0.0) & (x <= cfg.ahead) & (np.abs(y) <= cfg.lateral)
        mask &= cand[None, :] != vi[:, None]
        # Relative lane: lane ids on the ego's segment, else the offset in the ego's lane.
        erow = obj["row"][vi]
        _, r_o = self._lanes.local(erow[:, None], o["x"], o["y"], clip=True)
        _, r_e = self._lanes.local(erow, obj["x"][vi], obj["y"][vi], clip=True)
        offset = np.rint((r_o - r_e[:, None]) / self._lanes.width(erow)[:, None]).astype(np.int64)
        same = (o["seg"] >= 0) & (o["seg"] == obj["seg"][vi][:, None])
        lane = np.where(same, o["lid"] - obj["lid"][vi][:, None], offset)
        lane = np.where(o["seg"] == _ROADSIDE, OFF_ROAD, lane)
        dpsi = o["psi"] - psi_e[:, None]
        v_e = np.maximum(obj["speed"][vi], 0.0)[:, None]
        per = {"x": x, "y": y, "vx": o["speed"] * np.cos(dpsi) - v_e,
               "vy": o["speed"] * np.sin(dpsi), "heading": wrap_angle(dpsi)}  # fmt: skip
        per.update({name: np.broadcast_to(o[name], x.shape) for name in _PASS})
        # Each ego's objects first; M the largest count.
        m = int(mask.sum(axis=1).max(initial=0))
        order = np.argsort(~mask, axis=1, kind="stable")[:, :m]
        valid = np.take_along_axis(mask, order, axis=1)

        def put(a: np.ndarray, empty, dtype=float) -> np.ndarray:
            full = np.full((n, m), empty, dtype=dtype)
            picked = np.take_along_axis(np.broadcast_to(a, mask.shape), order, axis=1)
            full[slots] = np.where(valid, picked, empty)
            return full

        out = {name: put(a, np.nan) for name, a in per.items()}
        out["valid"] = put(mask, False, bool)
        out["object_id"] = put(o["id"], -1, np.int64)
        out["kind"] = put(o["kind"], 0, np.int8)
        out["lane"] = put(lane, OFF_ROAD, np.int64)
        hit = valid & (out["object_id"][slots] == leader[:, None]) & (leader[:, None] >= 0)
        out["lead"] = np.full(n, -1, np.int64)
        if m:
            out["lead"][slots] = np.where(hit.any(axis=1), hit.argmax(axis=1), -1)
        return out

    def _yaw_rate(self, t: float, heading: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """``(E,)`` heading change per second since the last frame of the same vehicle."""
        if t != self._now[2]:  # the step's first frame: the last step's become the previous
            self._prev = self._now
        prev_heading, prev_id, prev_t = self._prev
        same = (ids >= 0) & (ids == prev_id) & (t > prev_t)
        dt = t - prev_t if same.any() else 1.0
        self._now = (heading, ids, t)
        return np.where(same, wrap_angle(heading - prev_heading) / dt, 0.0)

    # ---------------------------------------------------------------- lanes
    def _lane_of(self, index: Any) -> tuple[int, int, int]:
        """Segment code, oriented lane id (larger to the left) and lane row of a
        ``lane_index`` (``None``: no segment, row 0)."""
        if index is None:
            return _NO_LANE, 0, 0
        f, t, i = index
        if (f, t) not in self._segments:
            lanes = self._road.network.graph[f][t]
            left = len(lanes) < 2 or lanes[0].local_coordinates(lanes[1].position(0, 0))[1] > 0
            self._segments[f, t] = (len(self._segments), 1 if left else -1)
        code, sign = self._segments[f, t]
        return code, sign * int(i), self._lanes.row(index)

    # ---------------------------------------------------------------- per episode
    def _start(self, road: Any) -> None:
        """A new episode's road: its lanes, road objects and roadside objects."""
        self._road, self._speed = road, None
        self._segments: dict[tuple[str, str], tuple[int, int]] = {}
        self._lanes = LaneRows(road.network)  # row 0: objects on no lane
        self._paths = NetworkPaths(self._lanes) if self.config.map_path else None
        obs = [o for o in road.objects if getattr(o, "solid", True)]
        self.roadside = side = self._place(road)
        nr, no = len(side), len(obs)
        lanes = np.array([self._lane_of(o.lane_index) for o in obs], np.int64).reshape(-1, 3)
        zeros = np.zeros(no + nr)
        self._fixed = {
            "x": np.r_[[o.position[0] for o in obs], side.x],
            "y": np.r_[[o.position[1] for o in obs], side.y],
            "psi": np.r_[[o.heading for o in obs], side.heading],
            "speed": zeros, "accel": zeros, "lateral_speed": zeros,
            "length": np.r_[[o.LENGTH for o in obs], side.length],
            "width": np.r_[[o.WIDTH for o in obs], side.width],
            "height": np.r_[np.full(no, _RAIL[0]), side.height],
            "elevation": np.r_[np.zeros(no), side.elevation],
            "rcs": np.r_[np.full(no, _RAIL[1]), side.rcs],
            "thermal_contrast": np.r_[np.full(no, _RAIL[2]), side.thermal_contrast],
            "seg": np.r_[lanes[:, 0], np.full(nr, _ROADSIDE)].astype(np.int64),
            "lid": np.r_[lanes[:, 1], np.zeros(nr)].astype(np.int64),
            "row": np.r_[lanes[:, 2], np.zeros(nr)].astype(np.int64),
            "kind": np.r_[np.full(no, int(ObjectKind.GUARDRAIL)), side.kind].astype(np.int8),
            "id": ROADSIDE_ID_BASE + self._next_id + np.arange(no + nr, dtype=np.int64),
        }  # fmt: skip
        self._next_id += no + nr

    def _place(self, road: Any) -> Roadside:
        """The roadside objects of the episode's road (module docstring)."""
        src, cfg = self.source, self.config.roadside
        seq = np.random.SeedSequence((cfg.seed, src.config.seed, src.episode))
        right_seed, left_seed = (int(s) for s in seq.generate_state(2))
        segments = []
        for f, tos in road.network.graph.items():
            for t, ls in tos.items():
                if ls and all(self._lanes.straight(x) for x in ls):
                    lat = [(x.start - ls[0].start) @ ls[0].direction_lateral for x in ls]
                    segments.append((f"{f}>{t}", [ls[k] for k in np.argsort(lat)]))
        right = place_roadside(_table(segments, False), replace(cfg, seed=right_seed))
        median = replace(cfg, seed=left_seed, gantry_spacing=0.0, bridge_spacing=0.0,
                         parked_per_km=0.0)  # fmt: skip
        left = place_roadside(_table(segments, True), median)
        parts = {f.name: np.concatenate([getattr(right, f.name), getattr(left, f.name)])
                 for f in fields(Roadside)}  # fmt: skip
        parts["heading"][len(right) :] = wrap_angle(parts["heading"][len(right) :] + np.pi)
        keep = np.ones(len(parts["x"]), dtype=bool)  # no post or parked car on a lane
        lanes = [x for tos in road.network.graph.values() for ls in tos.values() for x in ls]
        for j in np.flatnonzero(np.isin(parts["kind"], _ON_GROUND)):
            p = np.array([parts["x"][j], parts["y"][j]])
            for lane in lanes:
                s, r = lane.local_coordinates(p)
                keep[j] &= not (abs(r) <= 0.5 * lane.width_at(s) and 0.0 <= s <= lane.length)
        return Roadside(**{k: v[keep] for k, v in parts.items()})


def _table(segments: list[tuple[str, list]], mirrored: bool) -> LaneTable:
    """A :class:`~acc_fusion.truth.sumo.roadside.LaneTable` of straight segments (lanes
    ordered right to left) for :func:`place_roadside`; ``mirrored``: each seen from its left
    edge, driven the other way (lanes reversed, ends swapped), so its right is the left."""
    shapes, widths, speeds, counts = [], [], [], []
    for _, lanes in segments:
        for lane in lanes[::-1] if mirrored else lanes:
            shapes.append((lane.end, lane.start) if mirrored else (lane.start, lane.end))
            widths.append(lane.width)
            speeds.append(math.inf if lane.speed_limit is None else lane.speed_limit)
        counts.append(len(lanes))
    pts = np.array(shapes, dtype=float).reshape(-1, 2, 2)
    d = pts[:, 1] - pts[:, 0]
    return LaneTable(
        edge_code={name: i for i, (name, _) in enumerate(segments)},
        edge_ids=tuple(name for name, _ in segments),
        first_lane=np.cumsum([0, *counts])[:-1].astype(np.int64),
        n_lanes=np.array(counts, dtype=np.int64),
        internal=np.zeros(len(segments), dtype=bool),
        width=np.array(widths, dtype=float),
        speed=np.array(speeds, dtype=float),
        start=np.arange(0, 2 * len(pts) + 1, 2, dtype=np.int64),
        vx=pts[:, :, 0].ravel(),
        vy=pts[:, :, 1].ravel(),
        vs=np.stack([np.zeros(len(pts)), np.hypot(d[:, 0], d[:, 1])], axis=1).ravel(),
        vh=np.repeat(np.arctan2(d[:, 1], d[:, 0]), 2),
    )
