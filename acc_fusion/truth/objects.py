"""Ground truth as objects: every vehicle and roadside object in each equipped ego's forward
field, one :class:`ObjectFrame` per step (the 2-D world; the 1-D :class:`TruthFrame` of one
follower→leader pair is its special case, see :meth:`ObjectFrame.lead_frame`).

Conventions (DESIGN.md): SI units; the *ego frame* has its origin at the centre of the ego's
front bumper, ``x`` forward along the ego's heading and ``y`` to the left.  An object's
position ``(x, y)`` is the centre of its face nearest the ego — the rear face of a vehicle
ahead, where a radar's strongest return and a camera's bounding box bottom edge lie — so on a
straight road ``x`` of the lead is the bumper-to-bumper gap of the 1-D pipeline.  Relative
velocity ``(vx, vy)`` is the object's ground velocity minus the ego's, both expressed in the
ego frame (``vx`` of the lead is the range-rate on a straight road).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import IntEnum

import numpy as np
from numba import njit

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import InputError
from acc_fusion.core.validation import unchecked
from acc_fusion.truth.frame import TruthFrame


class ObjectKind(IntEnum):
    """What an object is; sensors see each kind differently (radar cross-section, thermal
    contrast, height) and metrics attribute false alerts to it."""

    VEHICLE = 0
    """A road vehicle in a lane, moving or stopped in traffic."""
    PARKED = 1
    """A vehicle parked on the shoulder."""
    GANTRY = 2
    """An overhead sign gantry (metal, high radar return, no thermal signature)."""
    BRIDGE = 3
    """An overhead bridge deck."""
    GUARDRAIL = 4
    """A guardrail post or other roadside metal."""
    SIGN = 5
    """A roadside sign post."""
    PLATE = 6
    """A flat steel plate lying on the road surface (a trench plate, FMVSS 127's false-activation
    object): stationary, in a lane, driven over (never a collision nor an in-path lead)."""


#: Kinds that never move (radar sees them at range-rate ``-ego_speed``).
STATIONARY_KINDS = (ObjectKind.PARKED, ObjectKind.GANTRY, ObjectKind.BRIDGE,
                    ObjectKind.GUARDRAIL, ObjectKind.SIGN, ObjectKind.PLATE)  # fmt: skip

#: ``lane`` of an object that is on no lane (shoulder, roadside, overhead).
OFF_ROAD = 99

#: Longitudinal distances ahead of the ego [m] at which a source with lane geometry gives the
#: ego lane's centreline along its route (:attr:`ObjectFrame.road_path`): every 10 m to 200 m,
#: the field of a long-range radar (the map path's resolution is an assumption: on a 250 m
#: radius a 10 m chord strays 5 cm from its arc).
PATH_STATIONS = np.arange(0.0, 201.0, 10.0)


_FLOAT_FIELDS = (
    "x", "y", "elevation", "vx", "vy", "speed", "accel", "heading",
    "length", "width", "height", "rcs", "thermal_contrast",
)  # fmt: skip


#: The float fields an :class:`ObjectFrame` checks (finite in the used slots).
_CHECKED_FLOATS = (*_FLOAT_FIELDS, "lateral_speed")


@njit(cache=True)
def _first_non_finite(arrays, valid):  # pragma: no cover - compiled
    """The index of the first of ``arrays`` (each ``(E, M)``) with a non-finite value where
    ``valid``, or -1: one pass over the used slots."""
    for i in range(len(arrays)):
        a = arrays[i]
        for e in range(valid.shape[0]):
            for j in range(valid.shape[1]):
                if valid[e, j] and not np.isfinite(a[e, j]):
                    return i
    return -1


@dataclass(frozen=True)
class ObjectFrame:
    """The objects ahead of E equipped egos at time ``t``.

    Ego arrays have shape ``(E,)``; object arrays ``(E, M)``, row ``e`` the objects of ego
    ``e`` (``M`` is the largest count of any ego this step; ``valid`` marks the used slots;
    object order within a row carries no meaning).

    Attributes:
        t: simulation time [s].
        ego_speed: ego speed [m/s].
        ego_accel: ego longitudinal acceleration over the step that ended at ``t`` [m/s²]
            (:attr:`acc_fusion.truth.frame.TruthFrame.ego_accel`).
        ego_yaw_rate: ego yaw rate [rad/s], positive turning left.
        road_curvature: curvature of the ego's lane at the ego [1/m], positive to the left
            (what a lane-aware path prediction may use; 0 on a straight road).
        valid: ``(E, M)`` bool, the slot holds an object.
        object_id: ``(E, M)`` int64, a stable id of the object in the world (the same object
            seen by two egos has the same id), ``-1`` in unused slots.
        kind: ``(E, M)`` int8, an :class:`ObjectKind`.
        x: longitudinal position of the nearest face's centre in the ego frame [m].
        y: lateral position of the nearest face's centre in the ego frame [m], left positive.
        elevation: height of the object's lower edge above the road [m] (0 for vehicles;
            the clearance of a gantry or bridge).
        vx: relative longitudinal velocity in the ego frame [m/s].
        vy: relative lateral velocity in the ego frame [m/s].
        speed: the object's ground speed [m/s] (0 for stationary objects).
        accel: the object's longitudinal acceleration along its heading [m/s²].
        heading: the object's heading relative to the ego's [rad].
        length: object length [m].
        width: object width [m].
        height: object height [m] (from its lower edge).
        rcs: radar cross-section [dBsm].
        thermal_contrast: apparent temperature difference to the background [K].
        lane: lane relative to the ego's (0 the ego's lane, +1 the next on the left, -1 the
            next on the right, ...), :data:`OFF_ROAD` for objects on no lane.
        lead: ``(E,)`` int64, the slot of the true in-path lead — the nearest vehicle ahead
            in the ego's lane — or ``-1``.
        lateral_speed: ``(E, M)`` the object's speed across its lane [m/s], left positive (a
            lane change); zeros when the source does not know it.
        road_path: ``(E, len(PATH_STATIONS))`` the lateral position [m] in the ego frame of
            the centreline of the ego's lane and the lanes it continues into along the ego's
            route, at the longitudinal distances :data:`PATH_STATIONS` — the road ahead as a
            map gives it, for the ``"map"`` path of :mod:`acc_fusion.warning.selection`;
            NaN in the rows of egos on no lane; ``(E, 0)`` (the default, ``None``) when the
            source gives no map.
        ego_shift: ``(E,)`` how far [m] the ego moved sideways over the step that ended at
            ``t`` beyond the arc its speed and yaw rate describe, left positive, in the ego
            frame at the step's start: SUMO moves a vehicle into the next lane within one
            step (:mod:`acc_fusion.truth.sumo.objects`), which a real car does over seconds
            with its odometry following; zeros (the default, ``None``) for sources whose egos
            move continuously.
    """

    t: float
    ego_speed: np.ndarray
    ego_accel: np.ndarray
    ego_yaw_rate: np.ndarray
    road_curvature: np.ndarray
    valid: np.ndarray
    object_id: np.ndarray
    kind: np.ndarray
    x: np.ndarray
    y: np.ndarray
    elevation: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    speed: np.ndarray
    accel: np.ndarray
    heading: np.ndarray
    length: np.ndarray
    width: np.ndarray
    height: np.ndarray
    rcs: np.ndarray
    thermal_contrast: np.ndarray
    lane: np.ndarray
    lead: np.ndarray
    lateral_speed: np.ndarray = None  # type: ignore[assignment]
    road_path: np.ndarray = None  # type: ignore[assignment]
    ego_shift: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        valid = np.asarray(self.valid)
        if valid.ndim != 2 or valid.dtype != np.bool_:
            raise InputError(f"valid must be a boolean array of shape (E, M), got {valid.shape}")
        e, m = valid.shape
        if self.ego_shift is None:
            object.__setattr__(self, "ego_shift", np.zeros(e))
        for name in ("ego_speed", "ego_accel", "ego_yaw_rate", "road_curvature", "ego_shift"):
            object.__setattr__(self, name, check_array(name, getattr(self, name), (e,)))
        if self.lateral_speed is None:
            object.__setattr__(self, "lateral_speed", np.zeros((e, m)))
        floats = []
        for name in _CHECKED_FLOATS:
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (e, m):
                raise InputError(f"{name} must have shape {(e, m)}, got {value.shape}")
            value = np.ascontiguousarray(value)  # one array type for the compiled check
            object.__setattr__(self, name, value)
            floats.append(value)
        bad = _first_non_finite(tuple(floats), valid)
        if bad >= 0:
            raise InputError(
                f"{_CHECKED_FLOATS[bad]} must be finite (no NaN or inf) in the used slots"
            )
        for name, dtype in (("object_id", np.int64), ("kind", np.int8), ("lane", np.int64)):
            value = np.asarray(getattr(self, name))
            if value.shape != (e, m) or not np.issubdtype(value.dtype, np.integer):
                raise InputError(f"{name} must be an integer array of shape {(e, m)}")
            object.__setattr__(self, name, value.astype(dtype, copy=False))
        lead = np.asarray(self.lead)
        if lead.shape != (e,) or not np.issubdtype(lead.dtype, np.integer):
            raise InputError(f"lead must be an integer array of shape {(e,)}")
        rows = np.flatnonzero(lead >= 0)
        if np.any(lead >= m) or not np.all(valid[rows, lead[rows]]):
            raise InputError("lead must name a valid object slot of its ego or be -1")
        object.__setattr__(self, "valid", valid)
        object.__setattr__(self, "lead", lead.astype(np.int64, copy=False))
        path = np.zeros((e, 0)) if self.road_path is None else np.asarray(self.road_path, float)
        if path.shape not in ((e, 0), (e, PATH_STATIONS.size)):
            raise InputError(f"road_path must have shape ({e}, 0) or ({e}, {PATH_STATIONS.size}), "
                             f"got {path.shape}")  # fmt: skip
        object.__setattr__(self, "road_path", path)

    def head(self, k: int) -> ObjectFrame:
        """The frame of the first ``k`` egos (views of this frame's arrays, no checks)."""
        return self if k == self.n_egos else self.egos(0, k)

    def egos(self, start: int, stop: int) -> ObjectFrame:
        """The frame of the egos ``start`` to ``stop`` (views of this frame's arrays, no
        checks)."""
        arrays = {f.name: getattr(self, f.name)[start:stop] for f in fields(self) if f.name != "t"}
        return ObjectFrame.from_arrays(self.t, **arrays)

    @classmethod
    def from_arrays(cls, t: float, **arrays: np.ndarray) -> ObjectFrame:
        """A frame of arrays its source has built itself at this step, without the checks of
        the constructor: every field given, of the constructor's shapes and dtypes, finite
        where used, taken as they are (no copy).  For sources that build a frame at every
        step (:class:`~acc_fusion.truth.sumo.objects.SumoObjects`: the checks cost a tenth of
        its frame); anything else uses the constructor."""
        return unchecked(cls, {"t": t, **arrays})

    @property
    def n_egos(self) -> int:
        """Number of egos E."""
        return int(self.valid.shape[0])

    @property
    def max_objects(self) -> int:
        """Number of object slots M per ego."""
        return int(self.valid.shape[1])

    @property
    def range(self) -> np.ndarray:
        """``(E, M)`` straight-line distance from the ego's bumper centre to the object [m]."""
        return np.hypot(self.x, self.y)

    @property
    def azimuth(self) -> np.ndarray:
        """``(E, M)`` bearing of the object from the ego's axis [rad], left positive."""
        return np.arctan2(self.y, self.x)

    @property
    def range_rate(self) -> np.ndarray:
        """``(E, M)`` d(range)/dt [m/s]: the relative velocity projected on the line of
        sight (negative when closing)."""
        r = np.maximum(self.range, 1e-9)
        return (self.x * self.vx + self.y * self.vy) / r

    @property
    def stationary(self) -> np.ndarray:
        """``(E, M)`` bool, the object is of a kind that never moves."""
        return np.isin(self.kind, np.asarray(STATIONARY_KINDS, dtype=np.int8))

    def lead_frame(self) -> TruthFrame:
        """The 1-D truth of each ego and its true in-path lead: gap ``x``, the lead's ground
        speed and acceleration, leader id the lead's ``object_id`` (``-1`` without a lead).
        The oracle and the alert classes of the 1-D pipeline judge this frame."""
        n = self.n_egos
        if self.max_objects == 0:
            zero = np.zeros(n)
            return TruthFrame.from_arrays(
                self.t, self.ego_speed, self.ego_accel, zero, zero, zero, -np.ones(n, np.int64)
            )
        e = np.arange(n)
        has = self.lead >= 0
        k = np.where(has, self.lead, 0)

        def pick(a: np.ndarray) -> np.ndarray:
            return np.where(has, a[e, k], 0.0)

        return TruthFrame.from_arrays(
            self.t,
            self.ego_speed,
            self.ego_accel,
            pick(self.x),
            pick(self.speed),
            pick(self.accel),
            np.where(has, self.object_id[e, k], -1),
            pick(self.y),
        )


class SlotWorld:
    """The part of a 2-D world source that is its slot source's (``self.source``, e.g. a
    :class:`~acc_fusion.truth.sumo.source.SumoSource`): the egos are the source's slots,
    and their state — which drive, collided, took a new vehicle, the time, the end — is the
    source's.  :class:`~acc_fusion.truth.sumo.world.SumoWorld` and
    :class:`~acc_fusion.truth.highway.world.HighwayWorld` add the object frame and the
    driving."""

    source: object

    @property
    def slotted(self) -> bool:
        """Its egos are the source's slots (:mod:`acc_fusion.core.slots`)."""
        return getattr(self.source, "slotted", False)

    @property
    def active(self) -> np.ndarray:
        """``(E,)`` slots holding a driving vehicle now."""
        return self.source.active

    @property
    def collided(self) -> np.ndarray:
        """``(E,)`` slots whose vehicle ran into another."""
        return self.source.collided

    @property
    def collision_speed(self) -> np.ndarray:
        """``(E,)`` impact speed [m/s] of each slot's collision (NaN where none)."""
        return self.source.collision_speed

    @property
    def reassigned(self) -> np.ndarray:
        """``(E,)`` slots that got a new vehicle at this step."""
        return self.source.reassigned

    @property
    def t(self) -> float:
        """Simulation time [s]."""
        return self.source.t

    @property
    def done(self) -> bool:
        """The source reached its end (or was closed)."""
        return self.source.done

    @property
    def n_steps(self) -> int:
        """Steps from the begin to the end (an upper bound where episodes may end early)."""
        return self.source.n_steps
