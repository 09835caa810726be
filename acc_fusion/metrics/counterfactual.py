r"""The crashes FCW avoids, replayed crash by crash: its direct effect, free of the traffic's
chaos.

The paired comparison of :mod:`acc_fusion.metrics.benefit` drives the whole traffic twice,
FCW off and on.  In dense traffic the two runs drift apart after the first warning: a driver
who looks back earlier changes his speed a little, his followers and neighbours change lanes
at other moments, and from then on who follows whom when a lead brakes is a matter of
chance.  On the bundled motorway (900 s, seed 0) only 14 of the 132 vehicles that crashed
with FCW off also crashed with it on, and 99 of the 113 crashes with FCW on were vehicles
that had not crashed without it: the difference of the two counts is mostly that chance.

Prospective safety assessment therefore evaluates a system crash by crash: each crash of the
baseline is re-run with the system, everything the system does not touch kept as it was
(Kusano & Gabler, "Safety benefits of forward collision warning, brake assist, and
autonomous braking systems in rear-end collisions", IEEE Trans. ITS 13(4):1546-1555, 2012,
who replayed 1 396 NASS-CDS rear-end crashes; Bärgman, Boda & Dozza, "Counterfactual
simulations applied to SHRP2 crashes", Accid. Anal. Prev. 102:165-180, 2017; ISO/TR
21934-1:2021).  Here the baseline is the FCW-off run, in which every method already
computes its alerts for every vehicle (no driver hears them), so the alerts a driver would
have heard are known up to the moment he would have responded.

**The replay.**  For each crash the FCW-off run keeps the last seconds of the follower's
life (:class:`ConflictRecord`): his speed, the gap to and the speed and acceleration of his
leader, each method's warning level, whether the situation was crash-relevant in truth
(:mod:`acc_fusion.metrics.alert_classes`), and his driver's state and traits
(:class:`acc_fusion.truth.driver.Driver`).  With FCW on, by the driver's rules:

1. The first warning onset (level rising to ``react_to_level``) at which the driver was idle
   (neither reacting nor braking) starts his reaction; until then nothing differs.  A level
   that is already up when the record begins is ignored: its onset came earlier, perhaps
   before the eyes-off episode, and a continuing warning does not warn again.
2. His reaction time :math:`t_r` later (step :math:`k_r`) he looks at the road; an
   eyes-off-road episode ends there.  He brakes at his deceleration :math:`d` if the situation
   is crash-relevant (``brakes_only_for_threats``; else always).  If it is not, he is back in
   his car-following model; the replay then lets him brake only :math:`t_r` after the next
   crash-relevant onset, as a driver who sees the threat himself.  That is conservative: the
   car-following model he is back in (SUMO's) would brake at once, without a reaction time.
3. If he started braking by himself no later than that (his episode ended first), FCW
   changed nothing: the crash stands as it was.
4. From the braking step :math:`k_b`, his speed falls by :math:`d\,\Delta t` per step while
   he closes on his leader; once he no longer closes he keeps at most the leader's speed (he
   released, and follows).  His speed is never above the one of the FCW-off run, in which he
   braked at :math:`d` too, only later.  The gap is the recorded one plus the distance he did
   not cover, :math:`g'_k = g_k + \Delta t \sum_{j=k_b+1}^{k} (v_j - v'_j)` (SUMO's Euler
   update, positions advanced by the new speed), which keeps any change of leader the record
   holds.  After the record ends the leader keeps its last acceleration until it stops.
5. A crash is a gap :math:`g' \le 0`; its impact speed is the closing speed then.

Everything else is kept as it was, as in the references: the leader's motion (nothing
ahead reacts to the follower), the rest of the traffic, and so also any crash the warned
driver's braking would cause behind him (the paired comparison counts those: *introduced*).
The reduction is the share of crashes avoided, :math:`R = n_\text{avoided}/n_\text{off}`,
each crash of the FCW-off run an independent trial, with the Wilson interval
(:func:`acc_fusion.metrics.stats.wilson_interval`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acc_fusion.core.units import TIME_TOL
from acc_fusion.metrics.benefit import Benefit, median_speed, per_million
from acc_fusion.metrics.stats import wilson_interval
from acc_fusion.truth.driver import DriverConfig

#: Seconds of each follower's history kept before a crash: an imminent alert comes a few
#: seconds before contact.  A warning level already up when the history begins is not an
#: onset the replay can place, and is ignored (conservative: the driver is not warned by it).
HISTORY_S = 15.0

#: Seconds the replay follows a conflict beyond the crash of the FCW-off run (the leader
#: extrapolated at its last acceleration until it stops).
EXTRAPOLATE_S = 20.0


@dataclass(frozen=True)
class ConflictRecord:
    """The last :data:`HISTORY_S` seconds of a follower that crashed with FCW off, step by step
    (arrays ``(K,)``; the last step is the one its crash was reported at).

    Attributes:
        t: time [s].
        gap: bumper-to-bumper gap to the leader [m]; NaN without a leader.
        ego_speed: the follower's speed [m/s].
        lead_speed, lead_accel: the leader's speed [m/s] and acceleration [m/s²].
        relevant: whether the situation was crash-relevant in truth.
        levels: each method's warning level, ``{method: (K,) int}``.
        braking: whether his driver was braking by himself (after the step).
        reacting: whether his driver had an onset pending (after the step).
        reaction_time, deceleration: his driver's traits [s], [m/s²].
        impact_speed: closing speed at the contact of the FCW-off run [m/s].
    """

    t: np.ndarray
    gap: np.ndarray
    ego_speed: np.ndarray
    lead_speed: np.ndarray
    lead_accel: np.ndarray
    relevant: np.ndarray
    levels: dict[str, np.ndarray]
    braking: np.ndarray
    reacting: np.ndarray
    reaction_time: float
    deceleration: float
    impact_speed: float


def _first(mask: np.ndarray, start: int = 0) -> int | None:
    """Index of the first True of ``mask`` at or after ``start`` (``None``: none)."""
    hits = np.flatnonzero(mask[start:])
    return int(start + hits[0]) if hits.size else None


def _after(t: np.ndarray, start: int, delay: float) -> int | None:
    """The first step at or after ``start`` at least ``delay`` seconds after ``t[start]``."""
    return _first(t >= t[start] + delay - TIME_TOL, start)


def braking_step(rec: ConflictRecord, method: str, driver: DriverConfig) -> int | None:
    """The step from which the driver of ``rec`` brakes with ``method``'s warnings heard
    (steps 1-3 of the module docstring), or ``None`` when FCW changes nothing."""
    warned = rec.levels[method] >= driver.react_to_level
    rise = warned & ~np.concatenate(([True], warned[:-1]))  # a level already up: not seen
    idle = ~np.concatenate(([False], rec.braking[:-1] | rec.reacting[:-1]))
    onset = _first(rise & idle)
    if onset is None:
        return None
    k = _after(rec.t, onset, rec.reaction_time)
    if k is not None and driver.brakes_only_for_threats and not rec.relevant[k]:
        seen = _first(rec.relevant, k)  # back in car-following: sees the threat himself
        k = None if seen is None else _after(rec.t, seen, rec.reaction_time)
    own = _first(rec.braking, onset)
    if k is None or (own is not None and own <= k):
        return None
    return k


def replay(rec: ConflictRecord, method: str, driver: DriverConfig) -> float:
    """Impact speed [m/s] of the crash of ``rec`` had ``method``'s warnings been heard (its
    recorded one if FCW changes nothing); NaN if the crash is avoided."""
    k_b = braking_step(rec, method, driver)
    if k_b is None:
        return rec.impact_speed
    dt = float(np.median(np.diff(rec.t)))
    n = len(rec.t)
    extra = int(round(EXTRAPOLATE_S / dt))
    a_end = min(float(rec.lead_accel[-1]), 0.0)
    lead = np.concatenate(
        (rec.lead_speed, np.maximum(rec.lead_speed[-1] + a_end * dt * np.arange(1, extra + 1), 0))
    )
    v, gap = float(rec.ego_speed[k_b]), float(rec.gap[k_b])
    saved = 0.0  # distance [m] not covered thanks to the earlier braking
    for k in range(k_b + 1, n + extra):
        closing = v > lead[k - 1]
        v = max(v - rec.deceleration * dt, 0.0) if closing else min(v, lead[k])
        if k < n:
            v = min(v, float(rec.ego_speed[k]))
            saved += (rec.ego_speed[k] - v) * dt
            gap = rec.gap[k] + saved if np.isfinite(rec.gap[k]) else np.inf
        else:
            gap += (lead[k] - v) * dt
        if gap <= 0.0:
            return float(v - lead[k])
        if k >= n and v <= lead[k] and lead[k] == 0.0:
            break
    return np.nan


def counterfactual_benefit(
    records: list[ConflictRecord],
    method: str,
    driver: DriverConfig,
    km: float,
    *,
    confidence: float = 0.95,
) -> Benefit:
    """:class:`~acc_fusion.metrics.benefit.Benefit` of ``method``'s warnings over the crashes
    of an FCW-off run (``records``, with ``km`` of driving), each replayed (:func:`replay`):
    crashes on are the replayed crashes that remain, ``introduced`` is 0 by construction,
    and the interval is Wilson's on the share avoided.

    >>> t = np.arange(0.0, 3.0, 0.1)
    >>> rec = ConflictRecord(t, 20.0 - 10.0 * t, np.full(30, 10.0), np.zeros(30),
    ...     np.zeros(30), t > 0.5, {"radar": (t >= 0.2).astype(int)}, np.zeros(30, bool),
    ...     np.zeros(30, bool), 0.5, 8.0, 10.0)
    >>> b = counterfactual_benefit([rec], "radar", DriverConfig(), 1.0)
    >>> b.crashes_off, b.crashes_on, b.avoided
    (1, 0, 1)
    """
    off = np.array([r.impact_speed for r in records], dtype=float)
    on = np.array([replay(r, method, driver) for r in records], dtype=float)
    n, crashed = len(records), np.isfinite(on)
    avoided = int(n - crashed.sum())
    lo = hi = reduction = np.nan
    if n:
        reduction = avoided / n
        lo, hi = wilson_interval(avoided, n, confidence)

    return Benefit(
        vehicles=n,
        crashes_off=n,
        crashes_on=int(crashed.sum()),
        reduction=float(reduction),
        reduction_lo=float(lo),
        reduction_hi=float(hi),
        per_million_km_off=per_million(n, km),
        per_million_km_on=per_million(int(crashed.sum()), km),
        avoided=avoided,
        mitigated=int((on[crashed] < off[crashed] - 1e-9).sum()),
        introduced=0,
        impact_speed_off=median_speed(off),
        impact_speed_on=median_speed(on[crashed]),
        confidence=confidence,
    )
