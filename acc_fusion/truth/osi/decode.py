r"""One ``osi3.GroundTruth`` (OSI 3.8, any producer) as the host's row of an
:class:`~acc_fusion.truth.objects.ObjectFrame` (:func:`decode`): the inverse of
:mod:`~acc_fusion.truth.osi.ground_truth` for this project's traces, and a documented reading of
anyone else's.

The host
    ``host_vehicle_id`` names it among ``moving_object``.  Its front-bumper centre is
    ``base.position`` :math:`+ (L/2)u` (the bounding-box centre plus half its
    ``base.dimension.length`` along ``base.orientation.yaw`` :math:`\psi`); its wheels stand at
    ``position.z`` :math:`- H/2`.  ``ego_speed``: the horizontal norm of ``base.velocity``;
    ``ego_accel``: ``base.acceleration`` along :math:`u` where the trace has it, else the
    speed difference over the step (0 at the first message; the scripted sources' definition,
    :attr:`~acc_fusion.truth.frame.TruthFrame.ego_accel`); ``ego_yaw_rate``:
    ``base.orientation_rate.yaw``, else the wrapped heading change over the step (SUMO's rule,
    :mod:`acc_fusion.truth.sumo.objects`); ``ego_shift``: the extension's, else 0 (another
    producer's host that jumps sideways between two messages is not told apart from one
    that drives; assumption).  Sizes missing from a trace (zero) are
    :data:`~acc_fusion.truth.osi.convention.HOST_SIZE` for the host and the scenes'
    :data:`~acc_fusion.truth.scenes.SIGNATURES` for objects (assumption).

Objects (every ``moving_object`` but the host, then every ``stationary_object``)
    Moved into the host's frame (origin its front bumper, :math:`x` along :math:`u`), the
    nearest face's centre of the box (:func:`~acc_fusion.truth.osi.convention.centre_to_face`),
    ``heading`` the wrapped yaw difference, ``elevation`` the box's lower edge above the host's
    wheels, relative velocity the ground velocity in the host frame minus the host's
    :math:`(v, 0)` (stationary objects: ground velocity 0), ``speed`` the ground velocity's
    horizontal norm, ``accel`` ``base.acceleration`` along the object's heading.
    An object that carries this project's extension was in the frame the trace was written
    from and is kept; any other enters the forward field as the scenes' objects do:
    :math:`0 < x \le` :data:`~acc_fusion.truth.scenes.FIELD_RANGE`, :math:`|y| \le`
    :data:`~acc_fusion.truth.scenes.FIELD_HALF_WIDTH`.  Objects of the extension come in the
    order of its ``index``, then the others in the message's order.

Kind, signature, lateral speed: the extension's where present.  Otherwise a moving object is a
    ``VEHICLE`` (OSI cannot tell a parked car from a stopped one) and a stationary one's kind
    is :data:`~acc_fusion.truth.osi.convention.KIND_OF_STATIONARY` of its type (others:
    ``GUARDRAIL``, roadside); rcs and thermal contrast those of the sources: a vehicle's by
    its class (:data:`~acc_fusion.truth.osi.convention.VCLASS_OF_OSI` into SUMO's
    :data:`~acc_fusion.truth.sumo.objects.VCLASS_SIGNATURE`; a pedestrian's
    ``"pedestrian"``), any other kind's the scenes' :data:`~acc_fusion.truth.scenes.SIGNATURES`;
    the lateral speed is the ground velocity across a lane parallel to the host's path of
    curvature :math:`\kappa` at the object's :math:`x` (rotated by :math:`\kappa x`).

Lanes
    The host's lane is its ``assigned_lane_id`` (``moving_object_classification``'s, else the
    deprecated ``MovingObject.assigned_lane_id``), and the other lanes are numbered from it by
    walking ``left_adjacent_lane_id`` (+1) and ``right_adjacent_lane_id`` (-1).  An object's
    lane is that of its ``assigned_lane_id``; without one it is
    :data:`~acc_fusion.truth.objects.OFF_ROAD`.  Where the host has no lane, or an object's
    lane is not reached from it, the lane comes from geometry, SUMO's rule off the ego's
    edge: the nearest face's offset from the host's path
    (:func:`~acc_fusion.truth.sumo.object_kernels._path_offset`) in lane widths
    :data:`~acc_fusion.truth.manoeuvre_params.LANE_WIDTH` (3.5 m, assumption), rounded — for
    vehicles and plates; other stationary kinds without a lane are off the road.
    ``road_curvature``: the circle through the host lane's ``centerline`` vertex nearest the
    host and the next two ahead; without one the host's path curvature ``ego_yaw_rate /
    ego_speed`` (0 below 1 m/s; assumption: the host follows its lane).

The lead: the object the extension marks ``lead`` in this project's traces; in others the
    nearest ``VEHICLE`` ahead in the host's lane (smallest :math:`x > 0` with lane 0), the
    definition of :attr:`~acc_fusion.truth.objects.ObjectFrame.lead`.

A collision: the host's box overlaps a vehicle's (in the host's frame, the boxes taken
    aligned with its axes: :math:`|c_x + L/2| < (L + \ell)/2`, :math:`|c_y| < (W + w)/2`);
    its speed is the closing speed :math:`-v_x`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.truth.manoeuvre_params import LANE_WIDTH
from acc_fusion.truth.objects import OFF_ROAD, ObjectKind
from acc_fusion.truth.osi.convention import (
    HOST_SIZE,
    KIND_OF_STATIONARY,
    VCLASS_OF_OSI,
    centre_to_face,
    osi,
    read_extension,
    seconds,
    wrap,
)
from acc_fusion.truth.scenes import FIELD_HALF_WIDTH, FIELD_RANGE, SIGNATURES
from acc_fusion.truth.sumo.object_kernels import _path_offset
from acc_fusion.truth.sumo.objects import VCLASS_SIGNATURE

#: Speed [m/s] below which the host's path curvature is taken as 0.
MIN_CURVATURE_SPEED = 1.0
_ON_LANE = (ObjectKind.VEHICLE, ObjectKind.PLATE)


@dataclass
class HostRow:
    """The host's row of an object frame at one message (module docstring): ``floats`` the
    per-object fields :data:`~acc_fusion.truth.sumo.object_arrays.OBJECT_FLOATS`, ``(14, M)``;
    ``lead`` a slot or -1 (``marked``: the extension marks it); ``collision_speed`` NaN
    without a collision."""

    t: float
    ego_speed: float
    ego_accel: float
    ego_yaw_rate: float
    road_curvature: float
    ego_shift: float
    heading: float
    floats: np.ndarray  # (len(OBJECT_FLOATS), M)
    object_id: np.ndarray
    kind: np.ndarray
    lane: np.ndarray
    lead: int
    collision_speed: float
    marked: bool


def decode(gt, index: int, previous: HostRow | None = None) -> HostRow:
    """The host's row of the GroundTruth ``gt``, message ``index`` of its trace; ``previous``
    the row of the message before (for the differences over the step).

    Raises:
        InputError: ``gt`` has no host vehicle id, or no moving object of that id
            (:func:`host_of`).
    """
    t = seconds(gt.timestamp)
    host = host_of(gt, index)
    host_id = host.id.value
    b = host.base
    psi = b.orientation.yaw
    c, s = math.cos(psi), math.sin(psi)
    length = b.dimension.length or HOST_SIZE[0]
    width = b.dimension.width or HOST_SIZE[1]
    height = b.dimension.height or HOST_SIZE[2]
    px, py = b.position.x + 0.5 * length * c, b.position.y + 0.5 * length * s
    ground = b.position.z - 0.5 * height
    v = math.hypot(b.velocity.x, b.velocity.y)
    dt = t - previous.t if previous is not None else math.nan
    if b.HasField("acceleration"):
        accel = b.acceleration.x * c + b.acceleration.y * s
    else:
        accel = (v - previous.ego_speed) / dt if previous is not None else 0.0
    if b.HasField("orientation_rate"):
        yaw_rate = b.orientation_rate.yaw
    else:
        yaw_rate = float(wrap(psi - previous.heading)) / dt if previous is not None else 0.0
    lanes, host_lane = _lane_numbers(gt, host)
    kappa = _curvature(gt, host_lane, (px, py, c, s))
    if kappa is None:
        kappa = yaw_rate / v if v >= MIN_CURVATURE_SPEED else 0.0
    objects = [(m, True) for m in gt.moving_object if m.id.value != host_id]
    objects += [(m, False) for m in gt.stationary_object]
    rows = [_raw(m, moving) for m, moving in objects]
    n = len(rows)
    raw = np.array([r.floats for r in rows], dtype=float).reshape(n, 11).T
    cx0, cy0, cz, yaw, gvx, gvy, ax, ay, ln, wd, ht = raw
    dx, dy = cx0 - px, cy0 - py
    cx, cy = c * dx + s * dy, -s * dx + c * dy
    heading = wrap(yaw - psi)
    x, y = centre_to_face(cx, cy, heading, ln)
    keep = np.array([r.ext is not None for r in rows], dtype=bool)
    keep |= (x > 0.0) & (x <= FIELD_RANGE) & (np.abs(y) <= FIELD_HALF_WIDTH)
    k = np.array(sorted(np.flatnonzero(keep).tolist(), key=lambda i: rows[i].rank(i)), np.int64)
    everyone, rows = rows, [rows[i] for i in k.tolist()]
    gx, gy = c * gvx + s * gvy, -s * gvx + c * gvy  # ground velocity in the host frame
    lateral = -np.sin(kappa * x) * gx + np.cos(kappa * x) * gy
    floats = np.stack([x, y, cz - 0.5 * ht - ground, gx - v, gy, np.hypot(gvx, gvy),
                       ax * np.cos(yaw) + ay * np.sin(yaw), heading, ln, wd, ht,
                       np.zeros(n), np.zeros(n), lateral])[:, k]  # fmt: skip
    for j, r in enumerate(rows):
        floats[11, j], floats[12, j] = r.signature
        if r.ext is not None:
            floats[13, j] = float(r.ext.get("lateral_speed", floats[13, j]))
    kind = np.array([r.kind for r in rows], dtype=np.int8)
    lane = np.array([_lane(r, lanes, host_lane, floats[0, j], floats[1, j], kappa)
                     for j, r in enumerate(rows)], dtype=np.int64)  # fmt: skip
    marked = any(r.ext is not None for r in rows)
    if marked:  # this project's: the lead it marked
        lead = next((j for j, r in enumerate(rows) if r.ext and r.ext.get("lead") == "1"), -1)
    else:
        lead = _nearest_in_lane(floats[0], kind, lane)
    # a collision: any vehicle's box (in the field or not) overlapping the host's
    vehicle = np.array([r.kind == ObjectKind.VEHICLE for r in everyone], dtype=bool)
    hit = vehicle & (np.abs(cx + 0.5 * length) < 0.5 * (length + ln))
    hit &= np.abs(cy) < 0.5 * (width + wd)
    closing = v - gx[hit]
    shift = float((read_extension(host.source_reference) or {}).get("ego_shift", 0.0))
    return HostRow(t, v, accel, yaw_rate, kappa, shift, psi, floats,
                   np.array([r.object_id for r in rows], dtype=np.int64), kind, lane, lead,
                   float(closing.max()) if closing.size else math.nan, marked)  # fmt: skip


def host_of(gt, index: int):
    """The host's ``osi3.MovingObject`` of the GroundTruth ``gt``, message ``index``.

    Raises:
        InputError: ``gt`` has no host vehicle id, or no moving object of that id.
    """
    t = seconds(gt.timestamp)
    if not gt.HasField("host_vehicle_id"):
        raise InputError(f"OSI message {index} (t = {t:.9g} s) names no host_vehicle_id")
    host_id = gt.host_vehicle_id.value
    host = next((m for m in gt.moving_object if m.id.value == host_id), None)
    if host is None:
        raise InputError(
            f"OSI message {index} (t = {t:.9g} s) has no moving object of its host's id {host_id}"
        )
    return host


@dataclass
class _Object:
    """What :func:`decode` reads of one OSI object: its 11 floats (centre x, y, z, yaw, ground
    velocity x, y, acceleration x, y, length, width, height), the extension, the kind, rcs
    and thermal contrast, the assigned lane id (``None``: none) and its id."""

    floats: tuple
    ext: dict[str, str] | None
    kind: int
    signature: tuple[float, float]
    lane_id: int | None
    object_id: int

    def rank(self, i: int) -> tuple[int, int]:
        """Sort key: the extension's index first, then the message's order ``i``."""
        if self.ext is not None and "index" in self.ext:
            return 0, int(self.ext["index"])
        return 1, i


def _raw(obj, moving: bool) -> _Object:
    """An ``osi3.MovingObject`` (``moving``) or ``osi3.StationaryObject`` as :class:`_Object`
    (module docstring)."""
    o = osi()
    ext = read_extension(obj.source_reference)
    b = obj.base
    if moving:
        kind = ObjectKind.VEHICLE
        assigned = obj.moving_object_classification.assigned_lane_id or obj.assigned_lane_id
        vel, acc = (b.velocity.x, b.velocity.y), (b.acceleration.x, b.acceleration.y)
    else:
        name = o.StationaryObject.Classification.Type.Name(obj.classification.type)
        kind = KIND_OF_STATIONARY.get(name, ObjectKind.GUARDRAIL)
        assigned = obj.classification.assigned_lane_id
        vel = acc = (0.0, 0.0)
    if ext is not None and "kind" in ext:
        kind = ObjectKind[ext["kind"]]
    default = SIGNATURES[kind]
    if ext is not None and "rcs" in ext and "thermal_contrast" in ext:
        signature = (float(ext["rcs"]), float(ext["thermal_contrast"]))
    elif moving and kind == ObjectKind.VEHICLE:
        signature = VCLASS_SIGNATURE[_vclass(obj, o)]
    else:
        signature = default[3:]
    d = b.dimension
    size = (d.length or default[0], d.width or default[1], d.height or default[2])
    floats = (b.position.x, b.position.y, b.position.z, b.orientation.yaw, *vel, *acc, *size)
    lane = assigned[0].value if len(assigned) else None
    return _Object(floats, ext, int(kind), signature, lane, obj.id.value)


def _vclass(obj, o) -> str:
    """The SUMO vehicle class of a moving object (module docstring)."""
    if obj.type == o.MovingObject.TYPE_PEDESTRIAN:
        return "pedestrian"
    name = o.MovingObject.VehicleClassification.Type.Name(obj.vehicle_classification.type)
    return VCLASS_OF_OSI.get(name, "passenger")


def _lane_numbers(gt, host) -> tuple[dict[int, int], int | None]:
    """Every lane reached from the host's by adjacency, numbered relative to it (left +1), and
    the host's lane id (``None``: it has none the message describes)."""
    assigned = host.moving_object_classification.assigned_lane_id or host.assigned_lane_id
    by_id = {lane.id.value: lane.classification for lane in gt.lane}
    if not assigned or assigned[0].value not in by_id:
        return {}, None
    start = assigned[0].value
    numbers, todo = {start: 0}, [start]
    while todo:
        lane = todo.pop()
        cls = by_id.get(lane)
        if cls is None:
            continue
        for side, step in ((cls.left_adjacent_lane_id, 1), (cls.right_adjacent_lane_id, -1)):
            for ident in side:
                if ident.value not in numbers:
                    numbers[ident.value] = numbers[lane] + step
                    todo.append(ident.value)
    return numbers, start


def _curvature(gt, host_lane: int | None, pose) -> float | None:
    """The curvature [1/m] of the host lane's centre line at the host (module docstring;
    ``None`` without three vertices)."""
    if host_lane is None:
        return None
    line = next(lane.classification.centerline for lane in gt.lane if lane.id.value == host_lane)
    if len(line) < 3:
        return None
    px, py, c, s = pose
    pts = np.array([(p.x, p.y) for p in line]) - (px, py)
    x, y = c * pts[:, 0] + s * pts[:, 1], -s * pts[:, 0] + c * pts[:, 1]
    i = int(np.argmin(np.hypot(x, y)))
    step = 1 if i + 1 < x.size and x[i + 1] > x[i] else -1
    j = np.arange(i, i + 3 * step, step)
    if j.min() < 0 or j.max() >= x.size:
        return None
    (ax, bx, cx), (ay, by, cy) = x[j], y[j]
    cross = (bx - ax) * (cy - by) - (by - ay) * (cx - bx)
    sides = (
        math.hypot(bx - ax, by - ay) * math.hypot(cx - bx, cy - by) * math.hypot(cx - ax, cy - ay)
    )
    return 2.0 * cross / sides if sides > 0.0 else None


def _lane(obj: _Object, lanes: dict[int, int], host_lane, x: float, y: float, kappa: float):
    """An object's lane relative to the host's (module docstring)."""
    if obj.lane_id is not None and obj.lane_id in lanes:
        return lanes[obj.lane_id]
    if host_lane is not None and obj.lane_id is None:
        return OFF_ROAD
    if obj.kind not in _ON_LANE:
        return OFF_ROAD
    return int(np.round(_path_offset(x, y, kappa) / LANE_WIDTH))


def _nearest_in_lane(x: np.ndarray, kind: np.ndarray, lane: np.ndarray) -> int:
    """The slot of the nearest vehicle ahead in the host's lane, -1 if none."""
    ahead = (kind == ObjectKind.VEHICLE) & (lane == 0) & (x > 0.0)
    return int(np.flatnonzero(ahead)[np.argmin(x[ahead])]) if ahead.any() else -1
