"""Ground truth handed from a truth source to the sensors, one :class:`TruthFrame` per step.

A truth source (scripted manoeuvres, SUMO, highway-env) describes, at every simulation step,
N follower→leader pairs.  Pair ``i`` is an (equipped) ego vehicle and the vehicle ahead of it.
Conventions (see DESIGN.md): SI units; ``gap`` is bumper to bumper; range-rate is
``d(gap)/dt = lead_speed - ego_speed`` (negative when closing); ``leader_id[i] < 0`` means
pair ``i`` has no leader in range, and a change of ``leader_id`` is a new target for which the
filters re-initialise.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import InputError
from acc_fusion.core.motion import ca_transition
from acc_fusion.core.validation import unchecked


@dataclass(frozen=True)
class TruthFrame:
    """Ground truth of N follower→leader pairs at time ``t`` (all arrays have shape ``(N,)``).

    Attributes:
        t: simulation time [s].
        ego_speed: ego (follower) speed [m/s].
        ego_accel: the ego's acceleration over the step that ended at ``t`` [m/s²]: what its
            accelerometer measured, the known input of the estimators' prediction from the
            previous frame to this one (SUMO's ``getAcceleration``, highway-env's and the
            scripted sources' speed difference over the step; a recorded data set's
            acceleration at ``t``).
        gap: bumper-to-bumper distance to the leader [m]; ignored where there is no leader.
        lead_speed: leader speed [m/s].
        lead_accel: leader acceleration [m/s²].
        leader_id: integer id of the leader, ``-1`` where the pair has no leader.
        lateral_offset: lateral offset of the leader's centre from the ego's axis [m]
            (zeros when the source does not know it).
    """

    t: float
    ego_speed: np.ndarray
    ego_accel: np.ndarray
    gap: np.ndarray
    lead_speed: np.ndarray
    lead_accel: np.ndarray
    leader_id: np.ndarray
    lateral_offset: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        leader = np.asarray(self.leader_id)
        if leader.ndim != 1 or not np.issubdtype(leader.dtype, np.integer):
            raise InputError(
                f"leader_id must be an integer array of shape (N,), got {leader.shape}"
            )
        object.__setattr__(self, "leader_id", leader.astype(np.int64, copy=False))
        has = self.leader_id >= 0
        n = self.leader_id.shape[0]
        for name in ("ego_speed", "ego_accel"):
            object.__setattr__(self, name, check_array(name, getattr(self, name), (n,)))
        for name in ("lead_speed", "lead_accel"):
            object.__setattr__(self, name, check_array(name, getattr(self, name), (n,), where=has))
        gap = check_array("gap", self.gap, (n,), nonnegative=False, where=has)
        object.__setattr__(self, "gap", gap)
        lat = np.zeros(n) if self.lateral_offset is None else self.lateral_offset
        object.__setattr__(self, "lateral_offset", check_array("lateral_offset", lat, (n,)))

    @classmethod
    def from_arrays(
        cls,
        t: float,
        ego_speed: np.ndarray,
        ego_accel: np.ndarray,
        gap: np.ndarray,
        lead_speed: np.ndarray,
        lead_accel: np.ndarray,
        leader_id: np.ndarray,
        lateral_offset: np.ndarray | None = None,
    ) -> TruthFrame:
        """A frame of arrays its source has built itself at this step, without the checks of
        the constructor: float64 and int64 ``(N,)`` arrays, finite where used, taken as they
        are (no copy; ``None``: no lateral offset).  For sources that build a frame at every
        step (the checks cost about as much as a SUMO step's reads); anything else uses the
        constructor."""
        values = {
            "t": t,
            "ego_speed": ego_speed,
            "ego_accel": ego_accel,
            "gap": gap,
            "lead_speed": lead_speed,
            "lead_accel": lead_accel,
            "leader_id": leader_id,
            "lateral_offset": (
                np.zeros(leader_id.shape[0]) if lateral_offset is None else lateral_offset
            ),
        }
        return unchecked(cls, values)

    @property
    def n_pairs(self) -> int:
        """Number of follower→leader pairs N."""
        return int(self.leader_id.shape[0])

    def head(self, m: int) -> TruthFrame:
        """The frame of the first ``m`` pairs (views of this frame's arrays, no checks)."""
        fields = ("ego_speed", "ego_accel", "gap", "lead_speed", "lead_accel", "leader_id")
        return TruthFrame.from_arrays(
            self.t, *(getattr(self, f)[:m] for f in fields), self.lateral_offset[:m]
        )

    @property
    def has_leader(self) -> np.ndarray:
        """Boolean mask of the pairs that have a leader."""
        return self.leader_id >= 0

    @property
    def range_rate(self) -> np.ndarray:
        """``lead_speed - ego_speed`` [m/s] (negative when closing)."""
        return self.lead_speed - self.ego_speed

    @property
    def rel_accel(self) -> np.ndarray:
        """``lead_accel - ego_accel`` [m/s²]."""
        return self.lead_accel - self.ego_accel

    @property
    def state(self) -> np.ndarray:
        """True state ``(N, 3)`` of the estimators: gap, range-rate, lead acceleration."""
        return np.stack([self.gap, self.range_rate, self.lead_accel], axis=1)


class SlotSource(ABC):
    """The per-slot arrays of a truth source whose pairs are *slots* that vehicles come and go
    from (SUMO, highway-env): each property returns a copy of the source's current array.

    A subclass keeps ``_frame`` (the current :class:`TruthFrame`) and the ``(N,)`` arrays
    ``_active`` (the slot holds a vehicle), ``_collided`` (its vehicle ran into another),
    ``_collision_speed`` (impact speed [m/s], NaN where none) and ``_reassigned`` (a new
    vehicle took the slot at this step: its per-slot state starts afresh).  It also has a
    ``close()`` that releases the simulation (idempotent), called on leaving a ``with`` block
    and when the source is garbage-collected.
    """

    #: Its pairs are slots: a pipeline works on the prefix of slots that holds the vehicles
    #: (:mod:`acc_fusion.core.slots`); a source of slots that is no subclass says so too.
    slotted = True

    _frame: TruthFrame
    _active: np.ndarray
    _collided: np.ndarray
    _collision_speed: np.ndarray
    _reassigned: np.ndarray

    @property
    def active(self) -> np.ndarray:
        """``(N,)`` slots holding a vehicle now."""
        return self._active.copy()

    @property
    def collided(self) -> np.ndarray:
        """``(N,)`` slots whose vehicle ran into another (the flag stays until the slot is
        reassigned)."""
        return self._collided.copy()

    @property
    def collision_speed(self) -> np.ndarray:
        """``(N,)`` impact speed (collider minus victim speed) [m/s]; NaN where none."""
        return self._collision_speed.copy()

    @property
    def reassigned(self) -> np.ndarray:
        """``(N,)`` slots that got a new vehicle at this step (reset their per-slot state)."""
        return self._reassigned.copy()

    def frame(self) -> TruthFrame:
        """The current truth as a :class:`TruthFrame`."""
        return self._frame

    @abstractmethod
    def close(self) -> None:
        """Release the simulation (idempotent); the last frame stays readable."""

    def __enter__(self):
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # a half-built source, or interpreter shutdown
            pass


class LinearGaussianSource:
    r"""Relative motion drawn from the estimator's own model: the linear-Gaussian test bed.

    The relative state of every pair follows the constant-acceleration model of
    :mod:`acc_fusion.core.motion` exactly, :math:`X(k+1) = \Phi X(k) + w`, :math:`w \sim N(0,
    Q)`,
    so the Kalman filter is the optimal estimator and its consistency (NEES, NIS) can be
    tested against chi-square bounds.  The ego drives at a constant ``ego_speed``; the lead's
    speed is ``ego_speed + range-rate``.  kong2011's set-up (target at 3 m/s, T = 1 s) is
    ``LinearGaussianSource(n, dt=1.0, x0=(gap, 3.0 - ego_speed, 0.0), ...)``.

    Args:
        n_pairs: number of independent pairs N.
        dt: step [s].
        jerk_std: relative-jerk standard deviation of the process noise [m/s³].
        x0: mean initial relative state (gap [m], range-rate [m/s], rel. accel [m/s²]).
        x0_std: standard deviation of the initial state around ``x0``.
        ego_speed: constant ego speed [m/s].
        seed: seed of the generator (or a ``numpy.random.Generator``).
    """

    def __init__(
        self,
        n_pairs: int,
        dt: float = 0.05,
        jerk_std: float = 2.0,
        x0: tuple[float, float, float] = (40.0, 0.0, 0.0),
        x0_std: tuple[float, float, float] = (0.0, 0.0, 0.0),
        ego_speed: float = 20.0,
        seed: int | np.random.Generator | None = None,
    ) -> None:
        self.n_pairs, self.dt, self.ego_speed = int(n_pairs), float(dt), float(ego_speed)
        self.f = ca_transition(dt)
        # Q = G G^T (jerk_std dt)^2 has rank one: w = G (jerk_std dt) xi, xi ~ N(0, 1).
        self._g = np.array([0.5 * dt * dt, dt, 1.0]) * (jerk_std * dt)
        rng = np.random.default_rng(seed)
        self._rng = rng
        self.state = np.asarray(x0, float) + rng.standard_normal((self.n_pairs, 3)) * np.asarray(
            x0_std, float
        )
        self.t = 0.0
        self.leader_id = np.zeros(self.n_pairs, dtype=np.int64)

    def frame(self) -> TruthFrame:
        """The current truth as a :class:`TruthFrame`."""
        n = self.n_pairs
        ego = np.full(n, self.ego_speed)
        return TruthFrame(
            t=self.t,
            ego_speed=ego,
            ego_accel=np.zeros(n),
            gap=self.state[:, 0].copy(),
            lead_speed=ego + self.state[:, 1],
            lead_accel=self.state[:, 2].copy(),
            leader_id=self.leader_id.copy(),
        )

    def advance(self) -> TruthFrame:
        """Move every pair one step along the model and return the new frame."""
        self.state = (
            self.state @ self.f.T + self._rng.standard_normal(self.n_pairs)[:, None] * self._g
        )
        self.t += self.dt
        return self.frame()
