"""Which units (vehicles, or episode slots) a traffic run drove and which of them ran into
their lead, at what impact speed: the pairing of FCW off and on in
:mod:`acc_fusion.metrics.benefit`; and the last seconds before each crash, for the replay of
:mod:`acc_fusion.metrics.counterfactual`."""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence

import numpy as np

from acc_fusion.metrics.counterfactual import HISTORY_S, ConflictRecord
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

    Attributes:
        units: every unit seen driving.
        crashes: impact speed [m/s] of every unit that ran into its lead (its first contact).
        conflicts: with ``history``, the :class:`ConflictRecord` of every crash, by unit.
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
    ) -> None:
        self.source, self._units = source, units
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


def chain(*hooks: Callable[[StepView], None] | None) -> Callable[[StepView], None]:
    """The ``on_step`` hook that calls each of ``hooks`` that is not ``None``, in order."""
    called = [h for h in hooks if h is not None]

    def each(view: StepView) -> None:
        for hook in called:
            hook(view)

    return each
