"""Which units (vehicles, or episode slots) a traffic run drove and which of them ran into
their lead, at what impact speed: the pairing of FCW off and on in
:mod:`acc_fusion.metrics.benefit`; the last seconds before each crash, for the replay of
:mod:`acc_fusion.metrics.counterfactual`; and the hazard that made each crash-relevant
situation and crash (:mod:`acc_fusion.metrics.hazards`)."""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence

import numpy as np

from acc_fusion.metrics import hazards as hz
from acc_fusion.metrics.counterfactual import HISTORY_S, ConflictRecord
from acc_fusion.metrics.events import EventState
from acc_fusion.sim.closed_loop import StepView


class CrashLog:
    """An ``on_step`` hook of :func:`acc_fusion.sim.closed_loop.simulate`.

    Args:
        source: the truth source (``active``, ``collided``, ``collision_speed`` per slot).
        units: the unit of each slot now (``None`` for an empty slot), e.g. SUMO's vehicle
            ids.  A source may empty the slot of a vehicle at the step it collides (SUMO
            removes it), so a collided slot without a unit takes the one of the step before.

        dt: with ``history``, the step [s].
        history: keep each unit's last :data:`~acc_fusion.metrics.counterfactual.HISTORY_S`
            seconds and, at its crash, its :class:`ConflictRecord` (needs the drivers of a
            closed loop, :attr:`StepView.driver`).
        hazards: a :class:`HazardLog` called before this hook at every step: each crash's
            hazard category goes into :attr:`causes`.

    Attributes:
        units: every unit seen driving.
        crashes: impact speed [m/s] of every unit that ran into its lead (its first contact).
        conflicts: with ``history``, the :class:`ConflictRecord` of every crash, by unit.
        causes: with ``hazards``, the category of every crash (an index into
            :data:`~acc_fusion.metrics.hazards.CATEGORIES`), by unit.
    """

    _FLOATS = ("t", "gap", "ego_speed", "lead_speed", "lead_accel")
    _FLAGS = ("relevant", "braking", "reacting")

    def __init__(
        self,
        source,
        units: Callable[[], Sequence[Hashable | None]],
        *,
        dt: float = 0.1,
        history: bool = False,
        hazards: HazardLog | None = None,
    ) -> None:
        self.source, self._units, self.hazards = source, units, hazards
        self.causes: dict = {}
        self.units: set = set()
        self.crashes: dict = {}
        self.conflicts: dict[Hashable, ConflictRecord] = {}
        self._last: list = []
        self._steps = int(round(HISTORY_S / dt)) if history else 0
        self._step = 0
        self._ring: dict[str, np.ndarray] = {}

    def __call__(self, view: StepView) -> None:
        src, units, k = self.source, list(self._units()), len(view.ttc)
        if self._steps:
            self._remember(view, units, k)
        for i in np.flatnonzero(src.collided[:k]):
            unit = units[i] if units[i] is not None else self._at(i)
            if unit is not None and unit not in self.crashes:
                self.crashes[unit] = float(src.collision_speed[i])
                if self._steps:  # an emptied slot's last step is no longer its vehicle's
                    self.conflicts[unit] = self._record(i, emptied=units[i] is None)
                if self.hazards is not None:
                    self.causes[unit] = self.hazards.of_slot(i)
        self.units.update(units[i] for i in np.flatnonzero(src.active[:k]))
        self._last = units
        self._step += 1

    def _remember(self, view: StepView, units: list, k: int) -> None:
        """Write this step of the first ``k`` slots into the ring of the last steps."""
        f, d = view.frame, view.driver
        if not self._ring:
            n, w = len(self.source.active), self._steps
            self._ring = {name: np.full((n, w), np.nan) for name in self._FLOATS}
            self._ring |= {name: np.zeros((n, w), dtype=bool) for name in self._FLAGS}
            self._ring |= {m: np.zeros((n, w), dtype=np.int8) for m in view.levels}
            self._since = np.zeros(n, dtype=np.int64)
            self._traits = np.zeros((2, n))
        last = self._last + [None] * (k - len(self._last))
        new = [i for i in range(k) if units[i] is not None and units[i] != last[i]]
        self._since[new] = self._step
        c = self._step % self._steps
        ring = self._ring
        ring["t"][:k, c] = f.t
        ring["gap"][:k, c] = np.where(f.has_leader, f.gap, np.nan)
        ring["ego_speed"][:k, c], ring["lead_speed"][:k, c] = f.ego_speed, f.lead_speed
        ring["lead_accel"][:k, c], ring["relevant"][:k, c] = f.lead_accel, view.relevant
        ring["braking"][:k, c], ring["reacting"][:k, c] = d.braking, d.reacting
        for m, level in view.levels.items():
            ring[m][:k, c] = level
        self._traits[:, :k] = d.reaction_time, d.deceleration

    def _record(self, i: int, emptied: bool) -> ConflictRecord:
        """The :class:`ConflictRecord` of slot ``i``, whose crash was reported now (up to the
        step before if the source ``emptied`` the slot at the crash)."""
        end = self._step - int(emptied)
        kept = min(end - self._since[i] + 1, self._steps - int(emptied))
        cols = np.arange(end - kept + 1, end + 1) % self._steps
        rows = {name: ring[i, cols].copy() for name, ring in self._ring.items()}
        return ConflictRecord(
            **{name: rows.pop(name) for name in (*self._FLOATS, *self._FLAGS)},
            levels=rows,
            reaction_time=float(self._traits[0, i]),
            deceleration=float(self._traits[1, i]),
            impact_speed=float(self.source.collision_speed[i]),
        )

    def _at(self, i: int):
        return self._last[i] if i < len(self._last) else None


class HazardLog:
    """An ``on_step`` hook of a closed loop on an in-process
    :class:`~acc_fusion.truth.sumo.source.SumoSource`: the hazard category of each crash-relevant
    situation (:mod:`acc_fusion.metrics.hazards`), and the drivers' time with their eyes off
    the road.  Run it before the :class:`CrashLog` that reads it.

    Args:
        source: the source (``active``, ``reassigned``, ``inattentive``, ``braking_leaders()``,
            ``dt``, ``config.hazard_rate``).
        tolerance: the matching window of the metrics [s], which also ends a situation
            (:class:`~acc_fusion.metrics.events.FCWMetrics`).
    """

    def __init__(self, source, tolerance: float = 1.0) -> None:
        n = len(source.active)
        self.source, self.tolerance = source, tolerance
        self._situations = EventState(n)
        # The flags (metrics.hazards.category) each slot's live situation met so far, and
        # those of its present step.
        self._met, self._now = np.zeros(n, dtype=np.int8), np.zeros(n, dtype=np.int8)
        self._braked_at = np.full(n, -np.inf)  # last injected braking of the slot's leader
        self._braked_by = np.full(n, -1, dtype=np.int64)  # that leader's id
        self._leader = np.full(n, -1, dtype=np.int64)  # the slot's leader at the last step
        self._changed_at = np.full(n, -np.inf)  # when another vehicle last took that place
        self._relevant = np.zeros(len(hz.CATEGORIES), dtype=np.int64)
        self._driven = self._eyes_off = 0

    def __call__(self, view: StepView) -> None:
        src, f, k, n = self.source, view.frame, len(view.ttc), len(self._met)
        t, leader = f.t, f.leader_id[:k]
        new = np.zeros(n, dtype=bool)
        new[:k] = src.reassigned[:k]
        self._count(self._situations.finish(new))
        self._braked_at[new], self._braked_by[new], self._leader[new] = -np.inf, -1, -1
        self._changed_at[new] = -np.inf
        braking = np.isin(leader, src.braking_leaders()) & (leader >= 0)
        self._braked_at[:k][braking], self._braked_by[:k][braking] = t, leader[braking]
        before = self._leader[:k]
        self._changed_at[:k][(before >= 0) & (leader >= 0) & (leader != before)] = t
        self._leader[:k] = leader
        lead = (self._braked_by[:k] == leader) & (t - self._braked_at[:k] <= hz.LEAD_BRAKING_WINDOW)
        lane = t - self._changed_at[:k] <= hz.LANE_CHANGE_WINDOW
        active, late = src.active[:k], src.inattentive[:k]
        flags = hz.LEAD_BRAKING * lead + hz.LANE_CHANGE * lane + hz.LATE * late
        flags += hz.DISTRACTED * view.driver.holding[:k]
        # A slot emptied by its crash keeps its last step's flags.
        self._now[:k] = np.where(active | new[:k], flags, self._now[:k])
        now = np.zeros(n, dtype=bool)
        now[:k] = view.relevant
        onset, ended = self._situations.advance(t, now, self.tolerance)
        self._count(ended)
        self._met[onset] = 0
        self._met |= np.where(self._situations.live, self._now, 0).astype(np.int8)
        self._driven += int(active.sum())
        self._eyes_off += int((active & view.driver.eyes_off[:k]).sum())

    def _count(self, ended: np.ndarray) -> None:
        cats = hz.category(self._met[ended])
        self._relevant += np.bincount(cats, minlength=len(hz.CATEGORIES))

    def of_slot(self, i: int) -> int:
        """The category of slot ``i``'s crash at this step: that of the situation it ends so
        far (every process met from its onset on), or of its own step without one."""
        flags = self._met[i] if self._situations.live[i] else self._now[i]
        return int(hz.category(flags))

    def counts(self, causes: dict) -> hz.HazardCounts:
        """The :class:`~acc_fusion.metrics.hazards.HazardCounts` of the run (the situations
        still live count as they are), with the crashes' ``causes`` (:attr:`CrashLog.causes`)."""
        live = hz.category(self._met[self._situations.live])
        relevant = self._relevant + np.bincount(live, minlength=len(hz.CATEGORIES))
        crashes = np.bincount(np.fromiter(causes.values(), dtype=np.int64, count=len(causes)),
                              minlength=len(hz.CATEGORIES))  # fmt: skip
        dt = self.source.dt
        return hz.HazardCounts(
            tuple(int(x) for x in relevant),
            tuple(int(x) for x in crashes),
            self._driven * dt,
            self._eyes_off * dt,
            float(self.source.config.hazard_rate),
        )


def chain(*hooks: Callable[[StepView], None] | None) -> Callable[[StepView], None]:
    """The ``on_step`` hook that calls each of ``hooks`` that is not ``None``, in order."""
    called = [h for h in hooks if h is not None]

    def each(view: StepView) -> None:
        for hook in called:
            hook(view)

    return each
