"""The compiled step of the scripted source (:class:`~acc_fusion.truth.scripted.ScenarioSource`):
the leader search, the controls, the exact motion and the run ends of the module docstring of
:mod:`acc_fusion.truth.scripted`, one loop over the runs instead of some forty NumPy calls per
step over ``(N, S)`` and ``(N, S, K)`` arrays.

Every expression is the NumPy form's, operation for operation (no fast-math, no reordering), so
the frames are the same bit for bit (``tests/test_fingerprints.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from acc_fusion.truth.manoeuvre_params import idm_accel


@njit(cache=True, inline="always")
def _ramp(x, v, target, rate, dt):  # pragma: no cover - compiled
    """Exact motion over ``dt`` toward speed ``target`` at ``|a| = rate``, then holding it."""
    dv = target - v
    reached = rate * dt >= np.abs(dv)
    tau = np.abs(dv) / (rate if rate > 0 else 1.0) if reached else dt
    a = np.sign(dv) * rate
    x_new = x + v * dt + 0.5 * a * (tau * tau) + a * tau * (dt - tau)
    return x_new, (target if reached else v + a * dt)


@njit(cache=True, inline="always")
def find_leader(
    i, x, ego_x, run_t, present, lateral, overlap, length, slot, has, gap, lat
):  # pragma: no cover
    """Run ``i``'s leader: the nearest vehicle ahead whose lateral offset (the lane change's
    smooth step) is below ``overlap``; writes its slot, whether there is one, the gap (inf
    without) and the slot's lateral offset."""
    best, best_s, best_lat, found = np.inf, 0, 0.0, False
    for s in range(x.shape[1]):
        start, frm, to, span = (
            lateral[i, s, 0],
            lateral[i, s, 1],
            lateral[i, s, 2],
            lateral[i, s, 3],
        )
        u = (run_t[i] - start) / span
        if u < 0.0:
            u = 0.0
        elif u > 1.0:
            u = 1.0
        y = frm + (to - frm) * u * u * (3.0 - 2.0 * u)
        if s == 0:
            best_lat = y
        if present[i, s] and np.abs(y) < overlap and x[i, s] + length > ego_x[i]:
            found = True
            g = x[i, s] - ego_x[i]
            if g < best:
                best, best_s, best_lat = g, s, y
    slot[i], has[i], gap[i], lat[i] = best_s, found, best, best_lat


@njit(cache=True)
def leaders(rows, x, ego_x, run_t, present, lateral, overlap, length, slot, has, gap, lat):
    """:func:`find_leader` of the runs ``rows``, written into ``slot, has, gap, lat``
    (``(N,)`` each; the other runs' entries are left as they are)."""
    for i in rows:
        find_leader(i, x, ego_x, run_t, present, lateral, overlap, length, slot, has, gap, lat)


@njit(cache=True, inline="always")
def _segment(i, s, seg_t, seg_v, seg_rate, now):  # pragma: no cover - compiled
    """Target speed and rate of vehicle ``s`` of run ``i``: its last segment started by
    ``now`` (the last segment of all if none has started, as NumPy's index -1)."""
    k = -1
    for j in range(seg_t.shape[2]):
        if seg_t[i, s, j] <= now:
            k += 1
    return seg_v[i, s, k], seg_rate[i, s, k]


@njit(cache=True, inline="always")
def _ego_accel(
    i, plan_idm, desired, headway, v, ego_v, brake, hold, slot, has, gap, idm
):  # pragma: no cover
    """The ego's acceleration: the driver's brake request, else the IDM (not while held),
    else 0 (its scripted constant speed)."""
    if brake[i] > 0:
        return -brake[i]
    if plan_idm[i] and not hold[i]:
        a_max, root, s0, delta, d_max = idm
        return idm_accel(
            ego_v[i], desired[i], headway[i], gap[i], v[i, slot[i]], has[i],
            a_max, root, s0, delta, d_max,
        )  # fmt: skip
    return 0.0


@njit(cache=True)
def lead_state(
    seg_t, seg_v, seg_rate, run_t, end_time, tol, x, v, slot, has, gap, lat, generation, slots,
    length,
):  # fmt: skip  # pragma: no cover - compiled
    """The leader columns of every run's state: position, speed, acceleration (0 once it holds
    its target speed or the run has ended), length, gap and lateral offset (NaN where no
    leader is shown: none, or the run ended before now) and the leader id (-1 there)."""
    n = x.shape[0]
    out = np.full((6, n), np.nan)
    ids = np.full(n, -1, np.int64)
    for i in range(n):
        if not (has[i] and run_t[i] <= end_time[i] + tol):
            continue
        s = slot[i]
        target, rate = _segment(i, s, seg_t, seg_v, seg_rate, run_t[i] + tol)
        accel = 0.0
        if np.isinf(end_time[i]) and v[i, s] != target:
            accel = np.sign(target - v[i, s]) * rate
        out[0, i], out[1, i], out[2, i] = x[i, s], v[i, s], accel
        out[3, i], out[4, i], out[5, i] = length, gap[i], lat[i]
        ids[i] = s + 1 + slots * generation[i]
    return out, ids


@njit(cache=True)
def step(
    seg_t, seg_v, seg_rate, lateral, present, plan_idm, desired, headway, duration,
    x, v, ego_x, ego_v, ego_a, brake, hold, braked, end_time, collided, collision_speed,
    run_t, k, k0, dt, tol, overlap, length, idm, slot, has, gap, lat,
):  # fmt: skip  # pragma: no cover - compiled
    """Advance every active run one step of ``dt`` in place (the arrays of the source) and
    settle its collisions and end; ``slot, has, gap, lat`` enter as the leaders of the old
    state and leave as those of the new one."""
    n, n_slots = x.shape
    for i in range(n):
        active = np.isinf(end_time[i])
        now = run_t[i] + tol
        a = _ego_accel(i, plan_idm, desired, headway, v, ego_v, brake, hold, slot, has, gap, idm)
        ex, ev = _ramp(ego_x[i], ego_v[i], 0.0 if a < 0 else np.inf, np.abs(a), dt)
        if active:
            ego_a[i] = (ev - ego_v[i]) / dt
            ego_x[i], ego_v[i] = ex, ev
            for s in range(n_slots):
                target, rate = _segment(i, s, seg_t, seg_v, seg_rate, now)
                x[i, s], v[i, s] = _ramp(x[i, s], v[i, s], target, rate, dt)
            braked[i] |= brake[i] > 0
        else:
            ego_a[i] = 0.0
        run_t[i] = (k - k0[i]) * dt
        find_leader(i, x, ego_x, run_t, present, lateral, overlap, length, slot, has, gap, lat)
        hit = active and has[i] and gap[i] <= 1e-9
        if hit:
            s = slot[i]
            collision_speed[i] = ego_v[i] - v[i, s]
            ego_x[i], ego_v[i], v[i, s] = x[i, s], 0.0, 0.0
            collided[i] = True
        lead_v = v[i, slot[i]]
        resolved = (
            not plan_idm[i] and braked[i] and (ego_v[i] <= 0 or not has[i] or lead_v >= ego_v[i])
        )
        timeout = run_t[i] >= duration[i] - tol
        if active and (hit or resolved or timeout):
            end_time[i] = run_t[i]
        if hit:  # the ego now stands at the leader's bumper
            find_leader(i, x, ego_x, run_t, present, lateral, overlap, length, slot, has, gap, lat)
