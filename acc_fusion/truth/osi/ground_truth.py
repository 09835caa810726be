r"""The 2-D world's object frames as ASAM OSI ground truth: one ``osi3.GroundTruth`` (OSI 3.8)
per ego per step (:class:`GroundTruthEncoder`).  Conventions shared with the reader: ids,
faces and centres, the extension: :mod:`~acc_fusion.truth.osi.convention`.

The ego's global pose
    An :class:`~acc_fusion.truth.objects.ObjectFrame` knows no global position, so each ego's
    pose — the front-bumper centre :math:`p` and heading :math:`\psi` — is dead-reckoned from
    its speed :math:`v` and yaw rate :math:`\omega` with the trapezoidal rule between two
    frames :math:`t_0 < t_1` (:math:`\Delta t = t_1 - t_0`):

    .. math::

        \psi_1 = \psi_0 + \tfrac12(\omega_0 + \omega_1)\Delta t, \qquad
        p_1 = p_0 + \tfrac12(v_0 + v_1)\Delta t\,(\cos\bar\psi, \sin\bar\psi),\ \
        \bar\psi = \tfrac12(\psi_0 + \psi_1),

    starting at the origin with heading 0 at the ego's first frame (and after
    :meth:`GroundTruthEncoder.reset`), plus the frame's sideways jump
    :attr:`~acc_fusion.truth.objects.ObjectFrame.ego_shift` :math:`\delta` along the left
    normal of :math:`\psi_0` (SUMO's lane change within one step): :math:`p_1 \mathrel{+}=
    \delta\,(-\sin\psi_0, \cos\psi_0)`.  The road is taken flat: the ego's wheels at
    ``z = 0``.

The host (``GroundTruth.host_vehicle_id``; one ``osi3.MovingObject`` of type vehicle)
    ``base.position``: the bounding-box centre :math:`p - (L/2)u` at height :math:`H/2`
    (:math:`u = (\cos\psi, \sin\psi)`); ``base.orientation.yaw`` :math:`\psi`;
    ``base.velocity`` :math:`v u`; ``base.acceleration`` :math:`a u + v\omega n` (``ego_accel``
    along the heading, the centripetal part along the left normal :math:`n`);
    ``base.orientation_rate.yaw`` :math:`\omega`; ``base.dimension`` :math:`(L, W, H)`
    (``host_length``, ``host_width``, ``host_height``; default
    :data:`~acc_fusion.truth.osi.convention.HOST_SIZE`); a jump :math:`\delta \ne 0` also in
    the extension (``ego_shift``), for the reader.

Objects (every valid slot of the ego's row)
    ``VEHICLE`` and ``PARKED`` as ``osi3.MovingObject`` of type vehicle, the others as
    ``osi3.StationaryObject`` (:data:`~acc_fusion.truth.osi.convention.STATIONARY_TYPE`).
    ``base.position``: the bounding-box centre (the nearest face's centre moved to it,
    :func:`~acc_fusion.truth.osi.convention.face_to_centre`, rotated by :math:`\psi` and moved
    by :math:`p`), its height ``elevation + height/2``; ``base.orientation.yaw``:
    :math:`\psi` + ``heading`` (wrapped); ``base.dimension``: length, width, height.  A
    moving object's ``base.velocity`` is its ground velocity (the relative one plus the
    ego's), its ``base.acceleration`` ``accel`` along its heading.  ``assigned_lane_id`` (of
    ``moving_object_classification`` or ``classification``): the lane of its ``lane``, none
    for :data:`~acc_fusion.truth.objects.OFF_ROAD`.  The rest goes in the extension.

Lanes (``osi3.Lane``, type driving)
    The host's lane and every lane from the rightmost to the leftmost an object of the row is
    on (at least one either side), ids :func:`~acc_fusion.truth.osi.convention.lane_id`,
    ``left_adjacent_lane_id``/``right_adjacent_lane_id`` the neighbours written,
    ``is_host_vehicle_lane`` on the host's; ``centerline``: the circle of the ego's road
    curvature :math:`\kappa` through the ego, tangent to its heading, offset by :math:`k w`
    (:data:`~acc_fusion.truth.manoeuvre_params.LANE_WIDTH`; the ego taken on its lane's centre
    line), a vertex every :data:`~acc_fusion.truth.osi.convention.CENTRELINE_STEP` from the
    ego over :data:`~acc_fusion.truth.osi.convention.CENTRELINE_RANGE`.
"""

from __future__ import annotations

import math

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.truth.manoeuvre_params import LANE_WIDTH
from acc_fusion.truth.objects import OFF_ROAD, ObjectFrame, ObjectKind
from acc_fusion.truth.osi.convention import (
    CENTRELINE_RANGE,
    CENTRELINE_STEP,
    EXTENSION_TYPE,
    HOST_ID_BASE,
    HOST_SIZE,
    MATERIAL,
    STATIONARY_TYPE,
    extension_identifiers,
    face_to_centre,
    lane_id,
    osi,
    set_timestamp,
    wrap,
)

_MOVING = (ObjectKind.VEHICLE, ObjectKind.PARKED)


class GroundTruthEncoder:
    """One OSI GroundTruth per ego per step from the 2-D world's ObjectFrames (module
    docstring).

    Args:
        n_egos: the egos E of the frames to come.
        host_ids: ``(E,)`` the OSI id of each ego's host vehicle where the source knows it
            (e.g. its vehicles' object ids), default :data:`HOST_ID_BASE` ``+ e``; it must not
            be the id of an object the ego sees.
        host_length, host_width, host_height: the host's size [m].
    """

    def __init__(
        self,
        n_egos: int,
        host_ids: np.ndarray | None = None,
        host_length: float = HOST_SIZE[0],
        host_width: float = HOST_SIZE[1],
        host_height: float = HOST_SIZE[2],
    ) -> None:
        if isinstance(n_egos, bool) or not isinstance(n_egos, (int, np.integer)) or n_egos < 1:
            raise InputError(f"n_egos must be an integer >= 1, got {n_egos!r}")
        ids = HOST_ID_BASE + np.arange(n_egos) if host_ids is None else np.asarray(host_ids)
        if ids.shape != (n_egos,) or not np.issubdtype(ids.dtype, np.integer) or ids.min() < 0:
            raise InputError(f"host_ids must be {n_egos} integers >= 0")
        for name, value in (("host_length", host_length), ("host_width", host_width),
                            ("host_height", host_height)):  # fmt: skip
            if not (math.isfinite(value) and value > 0.0):
                raise InputError(f"{name} must be a finite size > 0 m, got {value!r}")
        self._osi = osi()
        self.host_ids = ids.astype(np.int64)
        self.host_size = (float(host_length), float(host_width), float(host_height))
        # Per ego: front-bumper position, heading, and the speed and yaw rate of the last frame.
        self._pose = np.zeros((3, n_egos))
        self._last = np.zeros((2, n_egos))
        self._started = np.zeros(n_egos, dtype=bool)
        self._t: float | None = None

    def reset(self, egos: np.ndarray) -> None:
        """``egos`` (a boolean mask ``(E,)``) took a new vehicle: its pose restarts at the
        origin at its next frame."""
        self._started[np.asarray(egos, dtype=bool)] = False

    def _advance(self, frame: ObjectFrame) -> None:
        """Every ego's pose at ``frame.t`` (module docstring)."""
        n = frame.n_egos
        v1, w1 = frame.ego_speed, frame.ego_yaw_rate
        go = self._started[:n]
        if self._t is not None and np.any(go):
            dt = frame.t - self._t
            if not dt > 0.0:
                raise InputError(f"frame times must increase, got {frame.t!r} after {self._t!r}")
            x, y, psi = self._pose[:, :n]
            v0, w0 = self._last[:, :n]
            psi1 = psi + 0.5 * (w0 + w1) * dt
            mid, step, jump = 0.5 * (psi + psi1), 0.5 * (v0 + v1) * dt, frame.ego_shift
            moved = np.stack([x + step * np.cos(mid) - jump * np.sin(psi),
                              y + step * np.sin(mid) + jump * np.cos(psi), psi1])  # fmt: skip
            self._pose[:, :n] = np.where(go, moved, self._pose[:, :n])
        self._pose[:, :n][:, ~go] = 0.0
        self._last[:, :n] = v1, w1
        self._started[:n] = True
        self._started[n:] = False  # not in this frame: a new vehicle when it comes back
        self._t = frame.t

    def encode(self, frame: ObjectFrame, egos: np.ndarray) -> list:
        """The ``osi3.GroundTruth`` of each ego of ``egos`` (int indices), in that order;
        advances every ego's pose from the previous call's ``frame.t`` to ``frame.t``."""
        if frame.n_egos > self.host_ids.size:
            raise InputError(
                f"the frame has {frame.n_egos} egos, the encoder was made for {self.host_ids.size}"
            )
        self._advance(frame)
        egos = np.asarray(egos, dtype=np.int64).reshape(-1)
        if egos.size and (egos.min() < 0 or egos.max() >= frame.n_egos):
            raise InputError(f"egos must index the frame's {frame.n_egos} egos")
        return [self._message(frame, int(e)) for e in egos]

    def _message(self, frame: ObjectFrame, e: int):
        """The GroundTruth of ego ``e``."""
        o = self._osi
        gt = o.GroundTruth()
        gt.version.CopyFrom(o.version)
        set_timestamp(gt.timestamp, frame.t)
        gt.host_vehicle_id.value = int(self.host_ids[e])
        px, py, psi = self._pose[:, e]
        c, s = math.cos(psi), math.sin(psi)
        length, width, height = self.host_size
        v, a, w = frame.ego_speed[e], frame.ego_accel[e], frame.ego_yaw_rate[e]
        host = gt.moving_object.add()
        host.id.value = int(self.host_ids[e])
        host.type = o.MovingObject.TYPE_VEHICLE
        host.vehicle_classification.type = o.MovingObject.VehicleClassification.TYPE_MEDIUM_CAR
        _base(host.base, (px - 0.5 * length * c, py - 0.5 * length * s, 0.5 * height), psi,
              (length, width, height))  # fmt: skip
        _vector(host.base.velocity, v * c, v * s)
        _vector(host.base.acceleration, a * c - v * w * s, a * s + v * w * c)
        host.base.orientation_rate.yaw = w
        host.moving_object_classification.assigned_lane_id.add().value = lane_id(0)
        if frame.ego_shift[e] != 0.0:
            ref = host.source_reference.add()
            ref.type = EXTENSION_TYPE
            ref.identifier.extend(extension_identifiers({"ego_shift": float(frame.ego_shift[e])}))
        slots = np.flatnonzero(frame.valid[e])
        if np.any(frame.object_id[e, slots] == self.host_ids[e]):
            raise InputError(
                f"host id {self.host_ids[e]} of ego {e} is also the id of an object it sees"
            )
        lanes = frame.lane[e, slots]
        self._lanes(gt, lanes[lanes != OFF_ROAD], frame.road_curvature[e], (px, py, c, s))
        if not slots.size:
            return gt
        f = {name: getattr(frame, name)[e, slots] for name in _PER_OBJECT}
        cx, cy = face_to_centre(f["x"], f["y"], f["heading"], f["length"])
        gx, gy = px + c * cx - s * cy, py + s * cx + c * cy
        vx, vy = f["vx"] + v, f["vy"]  # ground velocity in the ego frame
        for i, j in enumerate(slots.tolist()):
            kind = ObjectKind(int(frame.kind[e, j]))
            yaw = float(wrap(psi + f["heading"][i]))
            size = (f["length"][i], f["width"][i], f["height"][i])
            centre = (gx[i], gy[i], f["elevation"][i] + 0.5 * size[2])
            if kind in _MOVING:
                obj = gt.moving_object.add()
                obj.type = o.MovingObject.TYPE_VEHICLE
                _base(obj.base, centre, yaw, size)
                _vector(obj.base.velocity, c * vx[i] - s * vy[i], s * vx[i] + c * vy[i])
                acc = f["accel"][i]
                _vector(obj.base.acceleration, acc * math.cos(yaw), acc * math.sin(yaw))
                assigned = obj.moving_object_classification.assigned_lane_id
            else:
                obj = gt.stationary_object.add()
                cls = o.StationaryObject.Classification
                obj.classification.type = cls.Type.Value(STATIONARY_TYPE[kind])
                obj.classification.material = cls.Material.Value(
                    MATERIAL.get(kind, "MATERIAL_METAL")
                )
                _base(obj.base, centre, yaw, size)
                assigned = obj.classification.assigned_lane_id
            obj.id.value = int(frame.object_id[e, j])
            if lanes[i] != OFF_ROAD:
                assigned.add().value = lane_id(lanes[i])
            ext = {name: float(f[name][i]) for name in _EXTENDED}
            ext.update(kind=kind.name, index=i)
            if j == frame.lead[e]:
                ext["lead"] = 1
            ref = obj.source_reference.add()
            ref.type = EXTENSION_TYPE
            ref.identifier.extend(extension_identifiers(ext))
        return gt

    def _lanes(self, gt, lanes: np.ndarray, kappa: float, pose) -> None:
        """The lanes of the host's and its objects' (module docstring)."""
        lo = min(-1, int(lanes.min())) if lanes.size else -1
        hi = max(1, int(lanes.max())) if lanes.size else 1
        px, py, c, s = pose
        arc = np.arange(0.0, CENTRELINE_RANGE + 0.5 * CENTRELINE_STEP, CENTRELINE_STEP)
        # The circle of curvature kappa tangent to the x axis at the origin, and its normal.
        ax = arc * np.sinc(kappa * arc / math.pi)
        ay = 0.5 * kappa * arc**2 * np.sinc(kappa * arc / (2 * math.pi)) ** 2
        nx, ny = -np.sin(kappa * arc), np.cos(kappa * arc)
        lane_type = self._osi.Lane.Classification.TYPE_DRIVING
        for k in range(lo, hi + 1):
            lane = gt.lane.add()
            lane.id.value = lane_id(k)
            cls = lane.classification
            cls.type = lane_type
            cls.is_host_vehicle_lane = k == 0
            cls.centerline_is_driving_direction = True
            if k < hi:
                cls.left_adjacent_lane_id.add().value = lane_id(k + 1)
            if k > lo:
                cls.right_adjacent_lane_id.add().value = lane_id(k - 1)
            lx, ly = ax + k * LANE_WIDTH * nx, ay + k * LANE_WIDTH * ny
            for x, y in zip((px + c * lx - s * ly).tolist(), (py + s * lx + c * ly).tolist(),
                            strict=True):  # fmt: skip
                point = cls.centerline.add()
                point.x, point.y = x, y


#: The float fields of the extension.
_EXTENDED = ("rcs", "thermal_contrast", "lateral_speed")
#: The per-object arrays the encoder reads.
_PER_OBJECT = ("x", "y", "heading", "length", "width", "height", "elevation", "vx", "vy",
               "accel", "rcs", "thermal_contrast", "lateral_speed")  # fmt: skip


def _vector(vec, x: float, y: float, z: float = 0.0) -> None:
    """Set an ``osi3.Vector3d``."""
    vec.x, vec.y, vec.z = float(x), float(y), float(z)


def _base(base, centre, yaw: float, size) -> None:
    """Set a ``BaseMoving``/``BaseStationary``'s position (bounding-box centre), yaw and
    dimension."""
    _vector(base.position, *centre)
    base.orientation.roll, base.orientation.pitch, base.orientation.yaw = 0.0, 0.0, float(yaw)
    base.dimension.length, base.dimension.width, base.dimension.height = map(float, size)
