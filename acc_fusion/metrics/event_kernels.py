"""The compiled steps of :class:`~acc_fusion.metrics.events.FCWMetrics`: checking a step's inputs,
advancing every pair's warnings, threats and crash-relevant situations, and ending events
(the definitions are in :mod:`acc_fusion.metrics.events`)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _usable(system, oracle, ttc, speed, active):  # pragma: no cover - compiled
    """True if the levels are 0, 1 or 2 and, where ``active``, ``ttc`` is a number >= 0 or inf
    and ``speed`` a finite number >= 0 (the checks of
    :meth:`~acc_fusion.metrics.events.FCWMetrics.update`)."""
    for i in range(active.size):
        if not (0 <= system[i] <= 2 and 0 <= oracle[i] <= 2):
            return False
        if active[i] and not (ttc[i] >= 0.0 and np.isfinite(speed[i]) and speed[i] >= 0.0):
            return False
    return True


@njit(cache=True)
def _finish(pairs, on, live, ended):  # pragma: no cover - compiled
    """``EventState.finish`` of the pairs in ``pairs (N,)``: their events end (not on, not live,
    in place); ``ended (N,)`` receives those whose event was live."""
    for i in range(pairs.size):
        ended[i] = pairs[i] and live[i]
        if pairs[i]:
            on[i] = False
            live[i] = False


@njit(cache=True)
def _event_step(t, now, horizon, on, live, start, end):  # pragma: no cover - compiled
    """Advance one pair's event of one kind (an ``EventState`` of :mod:`acc_fusion.metrics.events`)
    to time ``t`` with the flag ``now``.

    Takes and returns the pair's ``(on, live, start, end)``, preceded on return by whether a
    new event starts at ``t`` and whether the live event ended (its tail passed ``horizon``
    after its last interval); the caller resets ``matched`` and ``flagged`` of a new event,
    after reading those of the ended one.
    """
    held = on and now
    if on and not now:
        end = t
    expired = live and not held and t - end > horizon
    live = live and not expired
    new = now and not on and not live
    if new:
        live, start = True, t
    return new, expired, now, live, start, end


@njit(cache=True)
def _advance(t, now, horizon, on, live, start, end, new, ended):  # pragma: no cover - compiled
    """:func:`_event_step` of every pair (arrays ``(N,)``, in place); ``new (N,)`` receives
    the pairs whose event starts at ``t``, ``ended (N,)`` those whose event ended."""
    for i in range(now.size):
        new[i], ended[i], on[i], live[i], start[i], end[i] = _event_step(
            t, now[i], horizon, on[i], live[i], start[i], end[i]
        )


@njit(cache=True)
def _record(
    t, system, oracle, ttc, speed, active, collided, relevant, warn_level, horizon, dt,
    w_on, w_live, w_matched, w_flagged, w_start, w_end,
    h_on, h_live, h_matched, h_flagged, h_start, h_end,
    c_on, c_live, c_matched, c_flagged, c_start, c_end,
    onset_ttc, was_collided, counts, pair_counts, pair_driven_s, pair_distance_m,
    pair_lead_time_s, confusion, values,
):  # pragma: no cover - compiled  # fmt: skip
    """One step of :meth:`~acc_fusion.metrics.events.FCWMetrics.update` on checked inputs, in
    place (``w_*``: the warnings, ``h_*``: the threats, ``c_*``: the crash-relevant situations,
    as ``EventState``; counts in the order of :data:`~acc_fusion.metrics.events.COUNTS`).

    Rows 0 to 4 of ``values`` receive, in the order of the pairs, the TTC at the new warnings,
    the onset TTC of the newly matched warnings, the lead times of the newly detected threats,
    the speeds of the active pairs and the lead times of the newly detected crash-relevant
    situations; returns how many of each.
    """
    n_new = n_matched = n_lead = n_active = n_relevant = 0
    for i in range(active.size):
        warns = active[i] and system[i] >= warn_level
        threatened = active[i] and oracle[i] >= warn_level
        critical = active[i] and relevant[i]
        warn_new, w_ended, w_on[i], w_live[i], w_start[i], w_end[i] = _event_step(
            t, warns, horizon, w_on[i], w_live[i], w_start[i], w_end[i]
        )
        threat_new, h_ended, h_on[i], h_live[i], h_start[i], h_end[i] = _event_step(
            t, threatened, horizon, h_on[i], h_live[i], h_start[i], h_end[i]
        )
        relevant_new, c_ended, c_on[i], c_live[i], c_start[i], c_end[i] = _event_step(
            t, critical, horizon, c_on[i], c_live[i], c_start[i], c_end[i]
        )
        # What the ended events were, before a new event of the same kind resets the flags.
        false_alarm = w_ended and not w_matched[i]
        crash_relevant = w_ended and w_flagged[i]
        nuisance = w_ended and not w_flagged[i] and w_matched[i]
        sensing_false = w_ended and not w_flagged[i] and not w_matched[i]
        missed = h_ended and not h_matched[i]
        relevant_missed = c_ended and not c_matched[i]
        if warn_new:
            w_matched[i] = w_flagged[i] = False
            onset_ttc[i] = ttc[i]
            values[0, n_new] = ttc[i]
            n_new += 1
        if threat_new:
            h_matched[i] = h_flagged[i] = False
        if relevant_new:
            c_matched[i] = c_flagged[i] = False
        both = w_live[i] and h_live[i]
        warn_matched = both and not w_matched[i]
        detected = both and not h_matched[i]
        if both:
            w_matched[i] = True
            h_matched[i] = True
        if warn_matched:
            values[1, n_matched] = onset_ttc[i]
            n_matched += 1
        if detected:
            lead = h_start[i] - w_start[i]
            values[2, n_lead] = lead
            n_lead += 1
            pair_lead_time_s[i] += lead
        relevant_detected = w_live[i] and c_live[i] and not c_matched[i]
        if w_live[i] and c_live[i]:
            w_flagged[i] = True
            c_matched[i] = True
        if relevant_detected:
            values[4, n_relevant] = c_start[i] - w_start[i]
            n_relevant += 1
        threat_relevant = h_live[i] and c_live[i] and not h_flagged[i]
        if threat_relevant:
            h_flagged[i] = True
        if active[i]:
            confusion[oracle[i], system[i]] += 1
            values[3, n_active] = speed[i]
            n_active += 1
            pair_driven_s[i] += dt
            pair_distance_m[i] += speed[i] * dt
        collision = collided[i] and not was_collided[i]
        was_collided[i] = collided[i]
        events = (
            warn_new, false_alarm, threat_new, detected, missed, collision,
            crash_relevant, nuisance, sensing_false,
            relevant_new, relevant_detected, relevant_missed, threat_relevant,
        )  # fmt: skip
        for k in range(len(events)):
            if events[k]:
                counts[k] += 1
                pair_counts[k, i] += 1
    return n_active, n_new, n_matched, n_lead, n_relevant
