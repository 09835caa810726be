"""Which units (vehicles, or episode slots) a traffic run drove and which of them ran into
their lead, at what impact speed: the pairing of FCW off and on in
:mod:`acc_fusion.metrics.benefit`."""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence

import numpy as np

from acc_fusion.sim.closed_loop import StepView


class CrashLog:
    """An ``on_step`` hook of :func:`acc_fusion.sim.closed_loop.simulate`.

    Args:
        source: the truth source (``active``, ``collided``, ``collision_speed`` per slot).
        units: the unit of each slot now (``None`` for an empty slot), e.g. SUMO's vehicle
            ids.  A source may empty the slot of a vehicle at the step it collides (SUMO
            removes it), so a collided slot without a unit takes the one of the step before.

    Attributes:
        units: every unit seen driving.
        crashes: impact speed [m/s] of every unit that ran into its lead (its first contact).
    """

    def __init__(self, source, units: Callable[[], Sequence[Hashable | None]]) -> None:
        self.source, self._units = source, units
        self.units: set = set()
        self.crashes: dict = {}
        self._last: list = []

    def __call__(self, view: StepView) -> None:
        src, units, k = self.source, list(self._units()), len(view.ttc)
        for i in np.flatnonzero(src.collided[:k]):
            unit = units[i] if units[i] is not None else self._at(i)
            if unit is not None and unit not in self.crashes:
                self.crashes[unit] = float(src.collision_speed[i])
        self.units.update(units[i] for i in np.flatnonzero(src.active[:k]))
        self._last = units

    def _at(self, i: int):
        return self._last[i] if i < len(self._last) else None


def chain(*hooks: Callable[[StepView], None] | None) -> Callable[[StepView], None]:
    """The ``on_step`` hook that calls each of ``hooks`` that is not ``None``, in order."""
    called = [h for h in hooks if h is not None]

    def each(view: StepView) -> None:
        for hook in called:
            hook(view)

    return each
