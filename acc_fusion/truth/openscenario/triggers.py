r"""OpenSCENARIO triggers resolved into times (ASAM OpenSCENARIO XML 1.3: ``Trigger``,
``ConditionGroup``, ``Condition`` and the conditions named below): the 2-D world scripts its
actors as functions of time, so every start trigger the reader accepts becomes the time it
fires.

Accepted: a trigger of one ``ConditionGroup`` of one ``Condition`` (``conditionEdge`` ``none``
or ``rising``, any ``delay``), which is a ``SimulationTimeCondition``, or a
``ByEntityCondition`` of one triggering entity with a ``RelativeDistanceCondition``, a
``DistanceCondition`` (to a position) or a ``TimeToCollisionCondition`` (to an entity or a
position).  Distances are measured in the road's coordinates (:math:`s` along the ego lane,
:math:`d` across it): ``longitudinal`` :math:`|\Delta s|`, ``lateral`` :math:`|\Delta d|`,
``cartesian`` :math:`\sqrt{\Delta s^2 + \Delta d^2}` (exact on straight roads); with
``freespace`` between the bounding boxes (aligned with the road), else between the reference
points.  Time to collision: the longitudinal distance over the closing speed of the one behind
(infinite when not closing; assumption: the entities' lateral positions are not checked).

An entity condition is evaluated on the motion known when the reader meets it (assumption):
the ego at its initial speed (the 2-D world's test driver holds it; it is exact until a
driver or AEB brakes, and triggers fire at the same time whatever the ego does after), the
actors with the events read before it.  It fires at the first time on a 10 ms grid where it
holds, refined by bisection to 1e-9 s; a condition that never holds before the scenario ends
never fires (its event does not happen).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.truth.openscenario.document import number, refusal

#: The grid step of the search [s] and the accuracy of the time it finds [s].
GRID, ACCURACY = 0.01, 1e-9
_RULES = ("greaterThan", "greaterOrEqual", "lessThan", "lessOrEqual", "equalTo")

#: state(name, times) -> (s centre, d, v) arrays [m, m, m/s] of entity ``name``.
State = Callable[[str, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


class Conditions:
    """Resolves triggers into times for one file.

    Args:
        name: the file's name (for the errors).
        state: the entities' motion (:data:`State`).
        boxes: entity name -> (length, width, centre offset [m]) of its bounding box.
        point: a ``Position`` element -> its ``(s, d)`` [m].
        horizon: the last time a condition may fire [s].
    """

    def __init__(self, name: str, state: State, boxes, point, horizon: float) -> None:
        self.name, self.state, self.boxes, self.point = name, state, boxes, point
        self.horizon = horizon

    def refuse(self, el, what: str) -> InputError:
        """The one-sentence error for element ``el``."""
        return refusal(self.name, el, what)

    def time(self, trigger, after: float) -> float:
        """When ``trigger`` (a ``StartTrigger`` element) fires, not before ``after`` [s]."""
        if trigger is None:
            return after
        groups = trigger.findall("ConditionGroup")
        conditions = [c for g in groups for c in g.findall("Condition")]
        if len(groups) != 1 or len(conditions) != 1:
            raise self.refuse(trigger, "must hold one condition group of one condition")
        cond = conditions[0]
        if cond.get("conditionEdge", "none") not in ("none", "rising"):
            raise self.refuse(cond, "has a conditionEdge other than none or rising")
        delay = number(cond, "delay", self.name, 0.0)
        by_value, by_entity = cond.find("ByValueCondition"), cond.find("ByEntityCondition")
        if by_value is not None:
            sim = by_value.find("SimulationTimeCondition")
            if sim is None:
                raise self.refuse(by_value[0], "is outside the conditions the 2-D world reads")
            rule = self._rule(sim)
            start = number(sim, "value", self.name)
            fire = after if rule.startswith("less") else max(start, after)
            return fire + delay
        return self._entity(by_entity, after) + delay

    def _rule(self, el) -> str:
        rule = el.get("rule", "")
        if rule not in _RULES:
            raise self.refuse(el, f"has rule {rule!r}; the 2-D world reads {', '.join(_RULES)}")
        return rule

    def _entity(self, el, after: float) -> float:
        refs = el.findall("TriggeringEntities/EntityRef")
        if len(refs) != 1:
            raise self.refuse(el, "must have one triggering entity")
        who = refs[0].get("entityRef")
        cond = el.find("EntityCondition")
        kind = cond[0] if cond is not None and len(cond) else el
        if kind.tag == "RelativeDistanceCondition":
            other = kind.get("entityRef")
            metric = self._distance(kind, kind.get("relativeDistanceType", "longitudinal"))
            quantity = lambda ts: metric(who, other, ts)[0]  # noqa: E731
        elif kind.tag == "DistanceCondition":
            metric = self._distance(kind, kind.get("relativeDistanceType", "cartesian"))
            quantity = lambda ts: metric(who, kind.find("Position"), ts)[0]  # noqa: E731
        elif kind.tag == "TimeToCollisionCondition":
            target = kind.find("TimeToCollisionConditionTarget")
            ref = target.find("EntityRef") if target is not None else None
            other = ref.get("entityRef") if ref is not None else target.find("Position")
            metric = self._distance(kind, "longitudinal")
            quantity = lambda ts: self._ttc(metric, who, other, ts)  # noqa: E731
        else:
            raise self.refuse(kind, "is outside the conditions the 2-D world reads")
        value = number(kind, "value", self.name)
        return self._search(quantity, value, self._rule(kind), after, kind)

    def _where(self, other, ts):
        """(s, d, v, length, width, centre offset) of an entity or a position."""
        if isinstance(other, str):
            if other not in self.boxes:
                raise InputError(f"{self.name}: no entity {other!r} to measure a distance to")
            s, d, v = self.state(other, ts)
            return (s, d, v, *self.boxes[other])
        s, d = self.point(other)
        return np.full_like(ts, s), np.full_like(ts, d), np.zeros_like(ts), 0.0, 0.0, 0.0

    def _distance(self, el, kind: str):
        free = el.get("freespace", "false") == "true"
        if kind not in ("longitudinal", "lateral", "cartesian"):
            raise self.refuse(el, f"has relativeDistanceType {kind!r}, outside the subset")

        def metric(who, other, ts):
            s1, d1, v1, l1, w1, c1 = self._where(who, ts)
            s2, d2, v2, l2, w2, c2 = self._where(other, ts)
            ds, dd = s2 - s1, d2 - d1
            if free:
                ds = np.maximum(np.abs(ds) - (l1 + l2) / 2, 0.0)
                dd = np.maximum(np.abs(dd) - (w1 + w2) / 2, 0.0)
            else:  # between the reference points
                ds = ds - c2 + c1
            ds, dd = np.abs(ds), np.abs(dd)
            value = {"longitudinal": ds, "lateral": dd}.get(kind)
            return (np.hypot(ds, dd) if value is None else value), s2 - s1, v1 - v2

        return metric

    @staticmethod
    def _ttc(metric, who, other, ts):
        gap, ahead, closing = metric(who, other, ts)
        closing = np.where(ahead >= 0, closing, -closing)
        safe = np.where(closing > 0, closing, 1.0)
        return np.where(closing > 0, gap / safe, np.inf)

    def _search(self, quantity, value: float, rule: str, after: float, el) -> float:
        """The first time in [after, horizon] when ``quantity(t) rule value`` holds."""

        def holds(ts, sign0=None):
            x = quantity(ts) - value
            if rule == "equalTo":
                return x * sign0 <= 0.0
            return {"greaterThan": x > 0, "greaterOrEqual": x >= 0, "lessThan": x < 0,
                    "lessOrEqual": x <= 0}[rule]  # fmt: skip

        ts = np.append(np.arange(after, self.horizon, GRID), self.horizon)
        sign0 = np.sign(quantity(ts[:1])[0] - value) or 1.0
        ok = holds(ts, sign0)
        if not ok.any():
            return math.inf
        i = int(np.argmax(ok))
        if i == 0:
            return after
        lo, hi = ts[i - 1], ts[i]
        while hi - lo > ACCURACY:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if holds(np.array([mid]), sign0)[0] else (mid, hi)
        return float(hi)
