"""Every vehicle's motion at every step of a traffic source: what the realism check reads.

A truth source hands the FCW pipeline follower→leader *pairs* of its equipped vehicles
(:class:`~acc_fusion.truth.frame.TruthFrame`); the traffic realism check
(:mod:`acc_fusion.metrics.realism`) needs instead the kinematics of *all* the traffic, every
vehicle at every step, to compare with naturalistic driving. :class:`Trajectories` holds them
as flat ``(M,)`` arrays, one entry per vehicle per step, in any order; a source's collector
fills it: :func:`acc_fusion.truth.sumo.trajectories.sumo_trajectories` (SUMO),
:func:`acc_fusion.truth.highway.trajectories.highway_trajectories` (highway-env) and
:func:`acc_fusion.truth.replay.trajectories.replay_trajectories` (recorded traffic).

Conventions (DESIGN.md): SI units; ``gap`` is bumper to bumper (NaN without a leader); a lane
change is a change of ``lane`` while ``road`` stays the same (a change of road, e.g. SUMO's
next edge, renumbers the lanes and is no lane change).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from acc_fusion.core.errors import InputError

#: The per-sample arrays of :class:`Trajectories`, in the order of its constructor.
COLUMNS = (
    "vehicle", "time", "speed", "accel", "lane", "road", "gap", "lead_speed", "lead_length",
    "odometer",
)  # fmt: skip
#: The integer ones among :data:`COLUMNS`.
INTEGER_COLUMNS = ("vehicle", "lane", "road")


@dataclass(frozen=True)
class Trajectories:
    """Samples of every vehicle at every step of a source (``(M,)`` arrays, any order).

    Attributes:
        vehicle: integer id of the vehicle (unique within the source's run).
        time: simulation or recording time [s].
        speed: speed [m/s].
        accel: longitudinal acceleration [m/s²] (negative when braking).
        lane: lane index within ``road`` (-1 where unknown).
        road: integer code of the road segment the lane belongs to (SUMO's edge,
            highway-env's ``(from, to)``, a recording's carriageway).
        gap: bumper-to-bumper gap to the leader [m]; NaN without a leader.
        lead_speed: the leader's speed [m/s]; NaN without a leader.
        lead_length: the leader's length [m]; NaN without a leader.
        odometer: distance the vehicle has driven since it entered [m].
        dt: the step, the time each sample stands for [s].
        label: what the samples are of (a scenario's name), for the tables.
    """

    vehicle: np.ndarray
    time: np.ndarray
    speed: np.ndarray
    accel: np.ndarray
    lane: np.ndarray
    road: np.ndarray
    gap: np.ndarray
    lead_speed: np.ndarray
    lead_length: np.ndarray
    odometer: np.ndarray
    dt: float
    label: str = ""

    def __post_init__(self) -> None:
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise InputError(f"dt must be > 0 s, got {self.dt!r}")
        n = None
        for name in COLUMNS:
            kind = np.int64 if name in INTEGER_COLUMNS else float
            a = np.asarray(getattr(self, name), dtype=kind)
            if a.ndim != 1:
                raise InputError(f"{name} must be a 1-D array, got shape {a.shape}")
            if n is None:
                n = a.shape[0]
            elif a.shape[0] != n:
                raise InputError(f"{name} has {a.shape[0]} samples, vehicle has {n}")
            object.__setattr__(self, name, a)

    def __len__(self) -> int:
        return int(self.vehicle.shape[0])

    @property
    def km(self) -> float:
        """Kilometres driven: the sum of speed × step over the samples."""
        return float(self.speed.sum() * self.dt / 1000.0)

    @property
    def hours(self) -> float:
        """Vehicle-hours of driving the samples stand for."""
        return len(self) * self.dt / 3600.0

    def subset(self, keep: np.ndarray) -> Trajectories:
        """The samples where ``keep`` (a boolean or index array)."""
        return Trajectories(
            **{name: getattr(self, name)[keep] for name in COLUMNS}, dt=self.dt, label=self.label
        )

    def after(self, warmup: float) -> Trajectories:
        """The samples at ``time >= warmup`` [s]."""
        return self.subset(self.time >= warmup)

    @classmethod
    def from_columns(cls, columns: dict[str, list], dt: float, label: str = "") -> Trajectories:
        """The trajectories of ``columns`` (lists or arrays, keyed by :data:`COLUMNS`; a
        column of lists of arrays is joined)."""
        arrays = {}
        for name in COLUMNS:
            parts = columns[name]
            if len(parts) and isinstance(parts[0], np.ndarray):
                arrays[name] = np.concatenate(parts)
            else:
                arrays[name] = np.asarray(parts)
        return cls(**arrays, dt=dt, label=label)

    @classmethod
    def concat(cls, parts: list[Trajectories], label: str = "") -> Trajectories:
        """The samples of ``parts`` (one step ``dt``; vehicle ids already distinct)."""
        if not parts:
            raise InputError("no trajectories to join")
        dts = {p.dt for p in parts}
        if len(dts) > 1:
            raise InputError(f"trajectories of different steps cannot be joined: {sorted(dts)}")
        return cls(
            **{f.name: np.concatenate([getattr(p, f.name) for p in parts]) for f in _arrays()},
            dt=parts[0].dt,
            label=label or parts[0].label,
        )


def _arrays():
    """The array fields of :class:`Trajectories`."""
    return [f for f in fields(Trajectories) if f.name in COLUMNS]
