"""The compiled steps of the estimators: gathering the sensors' reports, track loss and
confirmation, and the federated filter's step (local updates, fusion, information sharing,
isolation). A set of numba kernels that must stay together: the federated step inlines the
sharing and dropping kernels.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from acc_fusion.core.borrow import borrow, keep_alive
from acc_fusion.core.motion import (
    MEAS_DIM,
    STATE_DIM,
)
from acc_fusion.filters.kalman import (
    assign_one,
    fuse_one,
    nis_one,
    predict_one,
    update_one,
)
from acc_fusion.fusion.bias import correct_bias_one
from acc_fusion.fusion.fdi import SCALE, reset_one, reset_sensors_one, window_one


@njit(cache=True)
def _gather(z_in, r_in, valid_in, z, r, valid):  # pragma: no cover - compiled
    """One sensor's valid measurements ``z (N, 2)`` and covariances ``r (N, 2, 2)`` from its
    ``z_in``, ``r_in`` and ``valid_in (N,)`` (copied to ``valid``), zero and identity where
    not valid, in one pass; returns whether every value is finite, the lowest range (0
    without a valid one) and whether every variance is positive."""
    finite, low, positive = True, 0.0, True
    for k in range(valid.size):
        ok = valid_in[k]
        valid[k] = ok
        for a in range(2):
            v = z_in[k, a] if ok else 0.0
            z[k, a] = v
            finite &= np.isfinite(v)
            for b in range(2):
                w = r_in[k, a, b] if ok else (1.0 if a == b else 0.0)
                r[k, a, b] = w
                finite &= np.isfinite(w)
        low = min(low, z[k, 0])
        positive &= r[k, 0, 0] > 0 and r[k, 1, 1] > 0
    return finite, low, positive


@njit(cache=True)
def _first_reports(initialised, z, r, valid, accel_var, init, x0, p0, consumed):  # pragma: no cover
    """:meth:`~acc_fusion.fusion.base.Estimator._initial` of every pair, in place: ``init (N,)``
    the uninitialised pairs with a report, ``x0 (N, n)``, ``p0 (N, n, n)`` their first
    reporting sensor's measurement and covariance, the acceleration's variance ``accel_var``,
    zero elsewhere (rows not starting are left as they are), ``consumed (S, N)`` that
    sensor's report.
    Returns whether any pair starts."""
    any_init = False
    for k in range(valid.shape[1]):
        first = -1
        if not initialised[k]:
            for s in range(valid.shape[0]):
                if valid[s, k]:
                    first = s
                    break
        init[k] = first >= 0
        if first < 0:
            continue
        any_init = True
        consumed[first, k] = True
        x0[k], p0[k] = 0.0, 0.0
        for i in range(MEAS_DIM):
            x0[k, i] = z[first, k, i]
            for j in range(MEAS_DIM):
                p0[k, i, j] = r[first, k, i, j]
        p0[k, STATE_DIM - 1, STATE_DIM - 1] = accel_var
    return any_init


@njit(cache=True)
def _lose(initialised, target, target_id, last, t, coast_limit, lost):  # pragma: no cover
    """The tracks lost at time ``t``: ``lost (N,)`` receives the initialised pairs whose target
    id changed (``target`` takes ``target_id``, in place) or whose last measurement, at
    ``last``, is more than ``coast_limit`` old; they are no longer ``initialised``.  Returns
    whether any was lost."""
    any_lost = False
    for k in range(lost.size):
        lost[k] = initialised[k] and (target_id[k] != target[k] or t - last[k] > coast_limit)
        target[k] = target_id[k]
        initialised[k] = initialised[k] and not lost[k]
        any_lost = any_lost or lost[k]
    return any_lost


@njit(cache=True)
def _noise_at_prediction(x, f0, b0, u, initialised, valid, noise, r):  # pragma: no cover
    """Re-evaluate the range variance of every valid report of an initialised pair at the
    pair's predicted range, in place: ``r[s, k, 0, 0] = (noise[s, 0] + noise[s, 1] ·
    ĝ²)²`` with ``ĝ = max(0, f0 · x[k] + b0 · u[k])`` (``u`` empty: no input), for the
    sensors whose range noise grows with range (``noise[s, 1] > 0``; the rule and its source:
    :class:`~acc_fusion.fusion.config.FusionConfig`, ``noise_at``)."""
    for s in range(noise.shape[0]):
        if noise[s, 1] <= 0.0:
            continue
        for k in range(initialised.size):
            if not (initialised[k] and valid[s, k]):
                continue
            g = f0[0] * x[k, 0] + f0[1] * x[k, 1] + f0[2] * x[k, 2]
            if u.size:
                g += b0 * u[k]
            g = max(g, 0.0)
            std = noise[s, 0] + noise[s, 1] * g * g
            r[s, k, 0, 0] = std * std


@njit(cache=True)
def _confirmed(
    needed, seen, online_at, t, coast_limit, x, lo, hi, isolated, initialised, out
):  # pragma: no cover - compiled
    """:meth:`FederatedFilter._reported` in one pass: sensor ``s`` of an initialised pair
    becomes *needed* when it is online (it delivered a frame at ``online_at[s]``, at most
    ``coast_limit`` before ``t``), not isolated (``isolated (N, S)``) and the estimated gap
    ``x[k, 0]`` lies in ``[lo[s], hi[s]]``; ``out[k]``: the pair is initialised and every
    needed sensor that is still online and not isolated has been seen."""
    n_sensors, n_pairs = needed.shape
    online = np.empty(n_sensors, dtype=np.bool_)
    for s in range(n_sensors):
        online[s] = t - online_at[s] <= coast_limit
    for k in range(n_pairs):
        gap, ok = x[k, 0], initialised[k]
        confirmed = ok
        for s in range(n_sensors):
            if online[s] and gap >= lo[s] and gap <= hi[s] and not isolated[k, s] and ok:
                needed[s, k] = True
            # A sensor gone offline or isolated since can no longer confirm: it does not block.
            confirmed &= seen[s, k] or not needed[s, k] or not online[s] or isolated[k, s]
        out[k] = confirmed


#: Stand-ins for a federated filter without fault detection: its (empty) window arrays and
#: thresholds.
_NO_FDI = (
    np.zeros((0, 0, 0)), np.zeros((0, 0)), np.zeros((0, 0), dtype=np.int64),
    np.zeros((0, 0), dtype=np.int64), np.zeros((0, 0), dtype=bool),
    np.zeros((0, 0), dtype=np.int8), np.zeros((0, 0), dtype=bool), np.zeros((0, 0, 0)),
    np.zeros((0, 0), dtype=bool), np.zeros((0, 0), dtype=np.int64),
)  # fmt: skip


_NO_TESTS = (0.0, 0.0, 0.0, 0, False, (0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0))


@njit(cache=True)
def _federated_step(
    xm, pm, xl, pl, f, q, b, u, h, z, r, valid, initialised, reported_at, explained_at, beta, beta0,
    seen, needed, has_fdi, buf, total, count, pos, isolated, verdict, suspect, last, frozen, gate,
    clip, threshold, common_steps, manoeuvre_first, var, age, inflate, feedback, increments,
    trace, fuse_now, accel_var, t, coast_limit, nis, used,
):  # pragma: no cover - compiled  # fmt: skip
    """:meth:`FederatedFilter._advance` of every pair, in place, pair by pair.

    Master ``xm (N, n)``, ``pm (N, n, n)`` and locals ``xl (S, N, n)``, ``pl (S, N, n, n)``;
    measurements ``z (S, N, m)``, ``r (S, N, m, m)``, ``valid (S, N)``; track state
    ``initialised (N,)``, ``explained_at (S, N)`` (the last step at which the model explained
    each sensor's report), ``reported_at``, ``beta``, ``seen``, ``needed (S, N)``; the fault
    detector's windows (``has_fdi``; arrays of :class:`~acc_fusion.fusion.fdi.WindowedChiSquare`).
    Writes the NIS against the master's prior ``nis (N, S)`` and the pairs that used a
    measurement ``used (N,)``.  The first pass runs each pair's predict, initialisation,
    fault tests, local updates and fusion with feedback; the second, once the whole step's
    rejoining sensors are known, the re-sharing they cause (of every pair, as the reference
    does), the bookkeeping and the loss of tracks whose every sensor is isolated or silent.
    """
    state = _state(
        xm, pm, xl, pl, f, q, b, u, h, z, r, valid, initialised, reported_at, explained_at,
        beta, beta0, seen, needed, has_fdi, buf, total, count, pos, isolated, verdict, suspect,
        last, frozen, gate, clip, threshold, common_steps, manoeuvre_first, var, age, inflate,
        feedback, increments, trace, fuse_now, accel_var, t, coast_limit, nis, used,
    )  # fmt: skip
    flags = _pair_flags(valid.shape[0], valid.shape[1])
    again = _federated_first(0, valid.shape[1], state, flags)
    _federated_second(0, valid.shape[1], state, flags, again)


@njit(cache=True, parallel=True)
def _federated_step_parallel(
    xm, pm, xl, pl, f, q, b, u, h, z, r, valid, initialised, reported_at, explained_at, beta, beta0,
    seen, needed, has_fdi, buf, total, count, pos, isolated, verdict, suspect, last, frozen, gate,
    clip, threshold, common_steps, manoeuvre_first, var, age, inflate, feedback, increments,
    trace, fuse_now, accel_var, t, coast_limit, nis, used, chunks,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_federated_step` on the cores, the pairs in ``chunks`` blocks: each pass is
    pair by pair, and the second waits for every pair's first (the re-sharing needs the whole
    step's rejoining sensors), so the two give the same estimates bit for bit."""
    n_pairs = valid.shape[1]
    reporting, consumed, accepted, rejoined, manoeuvre, jump, active, wide = _pair_flags(
        valid.shape[0], n_pairs
    )
    again = np.zeros(chunks, dtype=np.bool_)
    go = False
    for second in (False, True):  # a parallel loop takes arrays, not tuples: made inside
        for c in prange(chunks):
            state = _state(
                xm, pm, xl, pl, f, q, b, u, h, z, r, valid, initialised, reported_at,
                explained_at, beta, beta0, seen, needed, has_fdi, buf, total, count, pos,
                isolated, verdict, suspect, last, frozen, gate, clip, threshold, common_steps,
                manoeuvre_first, var, age, inflate, feedback, increments, trace, fuse_now,
                accel_var, t, coast_limit, nis, used,
            )  # fmt: skip
            flags = (reporting, consumed, accepted, rejoined, manoeuvre, jump, active, wide)
            lo, hi = c * n_pairs // chunks, (c + 1) * n_pairs // chunks
            if second:
                _federated_second(lo, hi, state, flags, go)
            else:
                again[c] = _federated_first(lo, hi, state, flags)
        go = again.any()


@njit(cache=True)
def _state(
    xm, pm, xl, pl, f, q, b, u, h, z, r, valid, initialised, reported_at, explained_at, beta, beta0,
    seen, needed, has_fdi, buf, total, count, pos, isolated, verdict, suspect, last, frozen, gate,
    clip, threshold, common_steps, manoeuvre_first, var, age, inflate, feedback, increments,
    trace, fuse_now, accel_var, t, coast_limit, nis, used,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_federated_step`'s arguments grouped for its passes: the filters and
    measurements, the tracks' state, the fault detector's windows, the settings."""
    return (
        (xm, pm, xl, pl, f, q, b, u, h, z, r, valid),
        (initialised, reported_at, explained_at, beta, beta0, seen, needed, nis, used),
        (buf, total, count, pos, isolated, verdict, suspect, last, frozen, age),
        (has_fdi, gate, clip, threshold, common_steps, manoeuvre_first, var, inflate, feedback,
         increments, trace, fuse_now, accel_var, t, coast_limit),
    )  # fmt: skip


@njit(cache=True)
def _pair_flags(n_s, n_pairs):  # pragma: no cover - compiled
    """The per-pair work arrays of one step of :func:`_federated_step`: ``reporting``,
    ``consumed``, ``accepted``, ``rejoined (N, S)``, ``manoeuvre``, ``jump (N,)``, ``active
    (S, N)`` and ``wide (N, S)``, the NIS against a jump's prior (inf: none tested)."""
    return (
        np.zeros((n_pairs, n_s), dtype=np.bool_), np.zeros((n_pairs, n_s), dtype=np.bool_),
        np.zeros((n_pairs, n_s), dtype=np.bool_), np.zeros((n_pairs, n_s), dtype=np.bool_),
        np.zeros(n_pairs, dtype=np.bool_), np.zeros(n_pairs, dtype=np.bool_),
        np.zeros((n_s, n_pairs), dtype=np.bool_), np.full((n_pairs, n_s), np.inf),
    )  # fmt: skip


@njit(cache=True)
def _scratch(n_s):  # pragma: no cover - compiled
    """The small work arrays of one thread of :func:`_federated_step`."""
    n, m = STATE_DIM, MEAS_DIM
    return (
        np.empty(n), np.empty((n, n)), np.empty(n), np.empty((n, n)), np.empty((n, m)),
        np.empty((n, m)), np.empty(m), np.empty((m, m)), np.empty((m, m)), np.empty((m, m)),
        np.empty((n, n)), np.empty(n), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)),
        np.empty(n), np.empty((n, n)), np.empty(n_s), np.empty(n), np.empty(n), np.empty((n, n)),
    )  # fmt: skip


@njit(cache=True)
def _federated_first(lo, hi, state, flags):  # pragma: no cover - compiled
    """The first pass of :func:`_federated_step` over pairs ``lo`` to ``hi`` (``state``: its
    arguments, ``flags``: :func:`_pair_flags`); whether a sensor rejoined in any."""
    filters, tracks, windows, params = state
    xm, pm, xl, pl, f, q, b, u, h, z, r, valid = borrow(filters)
    initialised, reported_at, explained_at, beta, beta0, seen, needed, nis, used = borrow(tracks)
    buf, total, count, pos, isolated, verdict, suspect, last, frozen, age = borrow(windows)
    (has_fdi, gate, clip, threshold, common_steps, manoeuvre_first, var, inflate, feedback,
     increments, trace, fuse_now, accel_var, t, coast_limit) = params  # fmt: skip
    reporting, consumed, accepted, rejoined, manoeuvre, jump, active, wide = borrow(flags)
    n_s = valid.shape[0]
    n, m = STATE_DIM, MEAS_DIM
    floats = _scratch(n_s)
    xt, fp, x0, p0, pht, kg, y, s_mat, si, work_m, info, vec, yi, ym, work, xf, pf, w, g, gm = (
        borrow(floats[:20])
    )
    pw = borrow(floats[20])
    any_rejoined = False
    for k in range(lo, hi):
        uk = u[k % u.size]
        if initialised[k]:
            predict_one(xm[k], pm[k], f, q, 1.0, b, uk, xt, fp, n)
            for s in range(n_s):
                scale = _inflation_one(beta[s, k], inflate)
                predict_one(xl[s, k], pl[s, k], f, q, scale, b, uk, xt, fp, n)
        else:  # a new track from the first reporting sensor
            first = -1
            for s in range(n_s):  # the first reporting sensor that is not frozen
                if valid[s, k] and not (has_fdi and frozen[k, s]):
                    first = s
                    break
            if first >= 0:
                _drop_one(k, beta, beta0, seen, needed, has_fdi, buf, total, count, pos,
                          isolated, verdict, suspect, last, frozen)  # fmt: skip
                p0[:] = 0.0
                for i in range(m):
                    x0[i] = z[first, k, i]
                    for j in range(m):
                        p0[i, j] = r[first, k, i, j]
                x0[n - 1] = 0.0
                p0[n - 1, n - 1] = accel_var
                assign_one(xm[k], pm[k], x0, p0, 1.0)
                for s in range(n_s):
                    assign_one(xl[s, k], pl[s, k], x0, p0, _inflation_one(beta[s, k], inflate))
                initialised[k] = True
                consumed[k, first] = True
                explained_at[:, k] = t
        ini = initialised[k]
        for s in range(n_s):
            if has_fdi:  # a noise burst's adapted R, an estimated bias removed
                r[s, k] *= last[k, s, SCALE]
                correct_bias_one(k, s, z, last)
            reporting[k, s] = ini and valid[s, k] and not consumed[k, s]
            if reporting[k, s]:
                nis[k, s] = nis_one(xm[k], pm[k], h, z[s, k], r[s, k], m, s_mat, si, work_m, y)
            else:
                nis[k, s] = np.nan
            if has_fdi and reporting[k, s] and nis[k, s] > gate:  # against a jump's prior
                _jump_one(t, explained_at[s, k], var[3], common_steps, g)
                _widen_one(pm[k], g, accel_var, pw)
                wide[k, s] = nis_one(xm[k], pw, h, z[s, k], r[s, k], m, s_mat, si, work_m, y)
        if has_fdi:
            window_one(k, nis, reporting, z, r, gate, clip, threshold, common_steps,
                       manoeuvre_first, var, buf, total, count, pos, isolated, verdict,
                       suspect, last, frozen, age, accepted, rejoined, manoeuvre, wide,
                       jump)  # fmt: skip
            if jump[k]:  # since the model last explained a report it now fails to explain
                start = _jump_start(accepted[k], nis[k], gate, explained_at[:, k])
                jump[k] = start < np.inf  # none used (isolated meanwhile): no jump to take
                _jump_one(t, start, var[3], common_steps, g)
            for s in range(n_s):
                if accepted[k, s] and (nis[k, s] <= gate or jump[k]):
                    explained_at[s, k] = t
        else:
            accepted[k] = reporting[k]
        if manoeuvre[k]:  # a jump at one of the last common_steps steps, which unknown
            span = max(common_steps, 1)
            for j in range(1, span + 1):
                _jump_one(j * var[3], 0.0, var[3], span, gm)
                _widen_all(k, gm, accel_var / span, pm, pl, beta, inflate)
        if jump[k]:  # it jumped during the step: the priors take it
            _widen_all(k, g, accel_var, pm, pl, beta, inflate)
        for s in range(n_s):
            if accepted[k, s]:
                update_one(xl[s, k], pl[s, k], h, z[s, k], r[s, k], m, pht, kg, s_mat, si,
                           work_m, y)  # fmt: skip
            active[s, k] = ini and not (has_fdi and isolated[k, s])
            any_rejoined = any_rejoined or rejoined[k, s]
        if fuse_now and ini:
            fuse_one(xl, pl, active, k, xm[k], pm[k], increments, xf, pf, info, vec, yi, ym,
                     work)  # fmt: skip
            assign_one(xm[k], pm[k], xf, pf, 1.0)
            if feedback:
                _share_one(k, active, pl, beta, beta0, trace, w)
                for s in range(n_s):
                    if active[s, k]:
                        assign_one(xl[s, k], pl[s, k], xf, pf, _inflation_one(beta[s, k], inflate))
    keep_alive(floats)
    return any_rejoined


@njit(cache=True)
def _federated_second(lo, hi, state, flags, any_rejoined):  # pragma: no cover - compiled
    """The second pass of :func:`_federated_step` over pairs ``lo`` to ``hi``."""
    filters, tracks, windows, params = state
    xm, pm, xl, pl = borrow(filters[:4])
    initialised, reported_at, _, beta, beta0, seen, needed, _, used = borrow(tracks)
    buf, total, count, pos, isolated, verdict, suspect, last, frozen, _ = borrow(windows)
    has_fdi, inflate, trace, t = params[0], params[7], params[10], params[13]
    coast_limit = params[14]
    reporting, consumed, accepted, rejoined, _, _, active, _ = borrow(flags)
    n_s = pl.shape[0]
    w_owner = np.empty(n_s)
    w = borrow(w_owner)
    for k in range(lo, hi):
        ini = initialised[k]
        if any_rejoined:
            _share_one(k, active, pl, beta, beta0, trace, w)
            for s in range(n_s):
                if rejoined[k, s] and ini:
                    assign_one(
                        xl[s, k], pl[s, k], xm[k], pm[k], _inflation_one(beta[s, k], inflate)
                    )
        any_isolated, all_out, took_any = False, True, False
        for s in range(n_s):
            took = accepted[k, s] or consumed[k, s]
            seen[s, k] = seen[s, k] or took
            took_any = took_any or took
            if reporting[k, s] or consumed[k, s]:
                reported_at[s, k] = t
            iso = has_fdi and isolated[k, s]
            any_isolated = any_isolated or iso
            all_out = all_out and (iso or t - reported_at[s, k] > coast_limit)
        used[k] = took_any
        if ini and any_isolated and all_out:  # every recently reporting sensor is isolated
            initialised[k] = False
            _drop_one(k, beta, beta0, seen, needed, has_fdi, buf, total, count, pos, isolated,
                      verdict, suspect, last, frozen)  # fmt: skip
    keep_alive(w_owner)


@njit(cache=True, inline="always")
def _jump_one(t, explained_at, dt, steps, g):  # pragma: no cover - compiled
    """``g`` :math:`= [\tau^2/2, \tau, 1]^\top`: what a jump of the relative acceleration
    :math:`\tau` before ``t`` changes, with :math:`\tau` the time since ``explained_at``, at
    least ``dt`` and at most ``steps`` steps (:mod:`acc_fusion.fusion.fdi`, "Acceleration
    jump")."""
    tau = max(min(t - explained_at, steps * dt), dt)
    g[0], g[1], g[2] = 0.5 * tau * tau, tau, 1.0


@njit(cache=True, inline="always")
def _jump_start(accepted, nis, gate, explained_at):  # pragma: no cover - compiled
    """The earliest of ``explained_at (S,)`` (the last step at which the model explained each
    sensor's report) over the sensors whose report is ``accepted`` beyond the ``gate``: when
    the acceleration jumped, the last evidence that it had not yet (``inf`` if there is none).
    """
    start = np.inf
    for s in range(explained_at.size):
        if accepted[s] and nis[s] > gate:
            start = min(start, explained_at[s])
    return start


@njit(cache=True)
def jump_vectors(t, explained_at, dt, steps):  # pragma: no cover - compiled
    """:func:`_jump_one` of every sensor and pair: ``(S, N, 3)`` from ``explained_at (S, N)``."""
    g = np.empty((explained_at.shape[0], explained_at.shape[1], 3))
    for s in range(explained_at.shape[0]):
        for k in range(explained_at.shape[1]):
            _jump_one(t, explained_at[s, k], dt, steps, g[s, k])
    return g


@njit(cache=True)
def jump_start(accepted, nis, gate, explained_at):  # pragma: no cover - compiled
    """:func:`_jump_start` of every pair: ``(N,)`` from ``accepted, nis, explained_at (S, N)``."""
    out = np.empty(explained_at.shape[1])
    for k in range(out.size):
        out[k] = _jump_start(accepted[:, k], nis[:, k], gate, explained_at[:, k])
    return out


@njit(cache=True, inline="always")
def _widen_one(p, g, var, out):  # pragma: no cover - compiled
    """``out = p + var · g gᵀ`` (``out`` may be ``p``)."""
    for a in range(p.shape[0]):
        for b in range(p.shape[1]):
            out[a, b] = p[a, b] + var * g[a] * g[b]


@njit(cache=True, inline="always")
def _widen_all(k, g, var, pm, pl, beta, inflate):  # pragma: no cover - compiled
    """:func:`_widen_one` of pair ``k``'s master prior ``pm`` and of its locals ``pl`` (times
    their inflation)."""
    _widen_one(pm[k], g, var, pm[k])
    for s in range(pl.shape[0]):
        _widen_one(pl[s, k], g, var * _inflation_one(beta[s, k], inflate), pl[s, k])


@njit(cache=True, inline="always")
def _inflation_one(beta, inflate):  # pragma: no cover - compiled
    """The factor :math:`1/\\beta_i` of a local's prior and process noise (1 without
    inflation or with :math:`\\beta_i = 0`)."""
    return 1.0 / beta if inflate and beta > 0 else 1.0


@njit(cache=True, inline="always")
def _share_one(k, active, pl, beta, beta0, trace, w):  # pragma: no cover - compiled
    """Recompute pair ``k``'s :math:`\\beta` over its active locals (sum 1; unchanged
    without one): :math:`\\beta_i \\propto 1/\\mathrm{tr}(\\beta_i P_i)` (``trace``) or the
    initial factors ``beta0`` (``w (S,)``: scratch)."""
    total = 0.0
    for s in range(beta.shape[0]):
        if not active[s, k]:
            w[s] = 0.0
        elif trace:
            b = beta[s, k] if beta[s, k] > 0 else 1.0
            w[s] = 1.0 / ((pl[s, k, 0, 0] + pl[s, k, 1, 1] + pl[s, k, 2, 2]) * b)
        else:
            w[s] = beta0[s]
        total += w[s]
    if total > 0:
        for s in range(beta.shape[0]):
            beta[s, k] = w[s] / total


@njit(cache=True)
def _share_pairs(active, pl, beta, beta0, trace):  # pragma: no cover - compiled
    """:func:`_share_one` of every pair."""
    w = np.empty(beta.shape[0])
    for k in range(beta.shape[1]):
        _share_one(k, active, pl, beta, beta0, trace, w)


@njit(cache=True, inline="always")
def _drop_one(
    k, beta, beta0, seen, needed, has_fdi, buf, total, count, pos, isolated, verdict, suspect,
    last, frozen,
):  # pragma: no cover - compiled  # fmt: skip
    """Forget pair ``k``'s track state: initial sharing factors, no sensor seen or needed,
    fresh fault-detection windows."""
    for s in range(beta.shape[0]):
        beta[s, k] = beta0[s]
        seen[s, k] = False
        needed[s, k] = False
    if has_fdi:
        reset_one(k, buf, total, count, pos, isolated, verdict, suspect, last, frozen)


@njit(cache=True)
def _drop_pairs(
    pairs, new_vehicle, beta, beta0, seen, needed, has_fdi, buf, total, count, pos, isolated,
    verdict, suspect, last, frozen,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_drop_one` of the pairs in ``pairs (N,)``; for a ``new_vehicle`` their sensors'
    tests too (:func:`~acc_fusion.fusion.fdi.reset_sensors_one`: no frozen output, no noise
    burst)."""
    pairs, beta, beta0, seen, needed = borrow((pairs, beta, beta0, seen, needed))
    buf, total, count, pos, isolated, verdict, suspect, last, frozen = borrow(
        (buf, total, count, pos, isolated, verdict, suspect, last, frozen)
    )
    for k in range(pairs.size):
        if pairs[k]:
            if has_fdi and new_vehicle:
                reset_sensors_one(k, last, frozen)
            _drop_one(k, beta, beta0, seen, needed, has_fdi, buf, total, count, pos, isolated,
                      verdict, suspect, last, frozen)  # fmt: skip
