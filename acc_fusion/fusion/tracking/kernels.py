r"""The compiled frame step of :class:`~acc_fusion.fusion.tracking.tracker.Tracker`: ego-motion
compensation, Kalman prediction, gating, GNN assignment, update, M-of-N confirmation, deletion
and track birth for every ego in one call (the equations:
:mod:`~acc_fusion.fusion.tracking.tracker`).  A set of numba kernels that must stay together:
the frame step inlines the others.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from acc_fusion.core.borrow import borrow, keep_alive
from acc_fusion.core.units import TIME_TOL
from acc_fusion.filters.kalman import _inverse, predict_one
from acc_fusion.fusion.tracking.assignment import gnn, scratch_arrays

#: State dimension [x, vx, y, vy] and the indices of the position components.
DIM = 4
POS = (0, 2)


@njit(cache=True)
def converted(rng, azimuth, range_std, azimuth_std):  # pragma: no cover - compiled
    r"""Converted measurement of polar detections (scalars or arrays): ``x, y`` and the
    covariance entries ``rxx, rxy, ryy`` of :math:`J\,\mathrm{diag}(\sigma_r^2,
    \sigma_\theta^2)\,J^\top` (module docstring of the tracker)."""
    c, s = np.cos(azimuth), np.sin(azimuth)
    vr, va = range_std**2, (rng * azimuth_std) ** 2
    return rng * c, rng * s, c * c * vr + s * s * va, c * s * (vr - va), s * s * vr + c * c * va


@njit(cache=True)
def cv_model(dt, q):  # pragma: no cover - compiled
    r"""Transition :math:`F` and process noise :math:`Q` of the constant-velocity model of state
    ``[x, vx, y, vy]`` over ``dt`` with spectral density ``q`` per axis."""
    f, qm = np.eye(DIM), np.zeros((DIM, DIM))
    for a in POS:
        f[a, a + 1] = dt
        qm[a, a] = q * dt**3 / 3.0
        qm[a, a + 1] = qm[a + 1, a] = q * dt**2 / 2.0
        qm[a + 1, a + 1] = q * dt
    return f, qm


@njit(cache=True, inline="always")
def ego_transform(dt, speed0, speed1, yaw_rate, shift, f, a, b):  # pragma: no cover - compiled
    r"""The affine map :math:`x \mapsto A x + b` of a track's state over one step, into ``a``
    and ``b``: the ego-motion compensation :math:`x_c = T x + c` followed by the CV
    transition, :math:`A = F T`, :math:`b = F c` (tracker module docstring);
    ``speed0``/``speed1``: the ego's speed at the start/end of the step, ``shift`` its
    sideways jump [m] over it.  :math:`T` rotates the positions and the velocities by
    :math:`-\varphi`; the products are written out."""
    phi = yaw_rate * dt
    cs, sn = np.cos(phi), np.sin(phi)
    if abs(phi) < 1e-6:  # the arc's chord, to second order
        along, side = 1.0 - phi * phi / 6.0, phi / 2.0
    else:
        along, side = sn / phi, (1.0 - cs) / phi
    step = 0.5 * (speed0 + speed1) * dt
    dx, dy = step * along, step * side + shift
    c0 = -(cs * dx + sn * dy) + speed1 * dt
    c1 = cs * speed0 - speed1
    c2 = -(-sn * dx + cs * dy)
    c3 = -sn * speed0
    for i in range(DIM):
        # columns of F T: T's column j has cs at row j and -sn / +sn at row j ± 2
        a[i, 0] = f[i, 0] * cs - f[i, 2] * sn
        a[i, 1] = f[i, 1] * cs - f[i, 3] * sn
        a[i, 2] = f[i, 0] * sn + f[i, 2] * cs
        a[i, 3] = f[i, 1] * sn + f[i, 3] * cs
        b[i] = f[i, 0] * c0 + f[i, 1] * c1 + f[i, 2] * c2 + f[i, 3] * c3


@njit(cache=True, inline="always")
def std_at(std, growth, measured, range_sq):  # pragma: no cover - compiled
    r"""A std declared as :math:`\sigma(\hat r) = \sigma_0 + q \hat r^2` at the ``measured``
    range :math:`\hat r`, taken at the range whose square is ``range_sq`` instead (``growth``
    :math:`q`; :class:`~acc_fusion.sensors.detections.Detections`), never below 0."""
    return max(std + growth * (range_sq - measured * measured), 0.0)


@njit(cache=True, inline="always")
def _at_range(x, k, rng, range_std, growth, zx, zy, rxx, rxy, ryy, out):  # pragma: no cover
    r"""Detection ``k``'s converted covariance ``(rxx, rxy, ryy)`` into ``out``, its range std
    taken at the range of the predicted state ``x`` instead of the measured one when the std
    grows with range (``growth`` :math:`q > 0`): :math:`\sigma_r = \sigma_r(\hat r) + q ((r^-)^2
    - \hat r^2)` (:class:`~acc_fusion.sensors.detections.Detections`), the azimuth term as
    declared.  With :math:`R_z = J \operatorname{diag}(\sigma_r^2, \sigma_\theta^2) J^\top`,
    only the range variance's part :math:`\sigma_r^2 \mathbf u \mathbf u^\top` (:math:`\mathbf
    u` the unit vector to the detection) changes."""
    out[0], out[1], out[2] = rxx[k], rxy[k], ryy[k]
    if growth <= 0.0 or rng[k] <= 0.0:
        return
    std = std_at(range_std[k], growth, rng[k], x[0] * x[0] + x[2] * x[2])
    dv = std * std - range_std[k] * range_std[k]
    c, s = zx[k] / rng[k], zy[k] / rng[k]
    out[0] += c * c * dv
    out[1] += c * s * dv
    out[2] += s * s * dv


@njit(cache=True, inline="always")
def _innovation(x, p, zx, zy, rxx, rxy, ryy, y, s_mat, si, work):  # pragma: no cover
    """Innovation ``y``, its covariance's inverse ``si`` for the measurement ``(zx, zy)`` of the
    position; returns the squared Mahalanobis distance."""
    y[0], y[1] = zx - x[0], zy - x[2]
    s_mat[0, 0] = p[0, 0] + rxx
    s_mat[0, 1] = p[0, 2] + rxy
    s_mat[1, 0] = p[2, 0] + rxy
    s_mat[1, 1] = p[2, 2] + ryy
    _inverse(s_mat, si, work, 2)
    return y[0] * (si[0, 0] * y[0] + si[0, 1] * y[1]) + y[1] * (si[1, 0] * y[0] + si[1, 1] * y[1])


@njit(cache=True, inline="always")
def _update(x, p, y, si, ph, kg):  # pragma: no cover - compiled
    """Kalman update in place with the innovation ``y`` and its inverse covariance ``si``:
    :math:`K = P H^\\top S^{-1}`, :math:`x \\mathrel{+}= K y`, :math:`P \\mathrel{-}= K H P`."""
    for i in range(DIM):
        ph[i, 0], ph[i, 1] = p[i, 0], p[i, 2]
    for i in range(DIM):
        for b in range(2):
            kg[i, b] = ph[i, 0] * si[0, b] + ph[i, 1] * si[1, b]
    for i in range(DIM):
        x[i] += kg[i, 0] * y[0] + kg[i, 1] * y[1]
    for i in range(DIM):
        for j in range(i, DIM):
            v = p[i, j] - (kg[i, 0] * ph[j, 0] + kg[i, 1] * ph[j, 1])
            p[i, j] = v
            p[j, i] = v


@njit(cache=True, inline="always")
def _birth(x, p, zx, zy, rxx, rxy, ryy, rr, rr_std, azimuth, vel_var):  # pragma: no cover
    """A new track's state and covariance from one detection (tracker module docstring)."""
    c, s = np.cos(azimuth), np.sin(azimuth)
    vr = rr_std**2
    for i in range(DIM):
        for j in range(DIM):
            p[i, j] = 0.0
    x[0], x[1], x[2], x[3] = zx, rr * c, zy, rr * s
    p[0, 0], p[0, 2], p[2, 0], p[2, 2] = rxx, rxy, rxy, ryy
    p[1, 1] = c * c * vr + s * s * vel_var
    p[1, 3] = p[3, 1] = c * s * (vr - vel_var)
    p[3, 3] = s * s * vr + c * c * vel_var


#: The id of a track (or fused object) born in a frame, until :func:`number_new` numbers it.
UNNUMBERED = -2


@njit(cache=True)
def track_step(
    x, p, valid, confirmed, track_id, detection, hits, misses, scans, object_id, age, coast,
    rows, rng, azimuth, range_rate, range_std, azimuth_std, range_rate_std, growth, det_object,
    online, speed0, speed1, yaw_rate, shift, dt, params, next_id, widest,
):  # pragma: no cover - compiled  # fmt: skip
    """One frame of every ego's tracks, in place (slot arrays ``(E, T, ...)``; the frame's
    detections flat, ego ``e``'s in ``rows[e]:rows[e + 1]``, at most ``widest`` per ego;
    ``growth`` their range std's growth with the square of the range).
    ``params``: ``(q, gate, confirm_m, confirm_n, delete_misses, max_coast,
    init_velocity_var)``; ``next_id[0]``: the next unused track id."""
    conv = converted(rng, azimuth, range_std, azimuth_std)
    _track_egos(0, valid.shape[0], x, p, valid, confirmed, track_id, detection, hits, misses,
                scans, object_id, age, coast, rows, conv, rng, azimuth, range_std, growth,
                range_rate, range_rate_std, det_object, online, speed0, speed1, yaw_rate, shift,
                dt, params, widest)  # fmt: skip
    number_new(track_id, next_id)


@njit(cache=True, parallel=True)
def track_step_parallel(
    x, p, valid, confirmed, track_id, detection, hits, misses, scans, object_id, age, coast,
    rows, rng, azimuth, range_rate, range_std, azimuth_std, range_rate_std, growth, det_object,
    online, speed0, speed1, yaw_rate, shift, dt, params, next_id, widest, chunks,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`track_step` on the cores, the egos in ``chunks`` blocks, one thread each at a
    time: the egos' tracks are independent, and the new tracks are numbered after, in the
    order of the serial kernel, so the two give the same tracks bit for bit."""
    conv = converted(rng, azimuth, range_std, azimuth_std)
    n = valid.shape[0]
    for c in prange(chunks):
        _track_egos(c * n // chunks, (c + 1) * n // chunks, x, p, valid, confirmed, track_id,
                    detection, hits, misses, scans, object_id, age, coast, rows, conv, rng,
                    azimuth, range_std, growth, range_rate, range_rate_std, det_object, online,
                    speed0, speed1, yaw_rate, shift, dt, params, widest)  # fmt: skip
    number_new(track_id, next_id)


@njit(cache=True)
def number_new(track_id, next_id):  # pragma: no cover - compiled
    """Give the tracks born in this frame their ids, ego by ego and slot by slot (a frame's
    new tracks of one ego take free slots in the order of their detections)."""
    for e in range(track_id.shape[0]):
        for t in range(track_id.shape[1]):
            if track_id[e, t] == UNNUMBERED:
                track_id[e, t], next_id[0] = next_id[0], next_id[0] + 1


@njit(cache=True)
def _track_egos(
    lo, hi, x, p, valid, confirmed, track_id, detection, hits, misses, scans, object_id, age,
    coast, rows, conv, rng, azimuth, range_std, growth, range_rate, range_rate_std, det_object,
    online, speed0, speed1, yaw_rate, shift, dt, params, widest,
):  # pragma: no cover - compiled  # fmt: skip
    """The frame of egos ``lo`` to ``hi`` (:func:`track_step`; ``conv``: the detections'
    converted positions and covariances at the measured range, :func:`converted`; with a
    ``growth`` of the range std, each track-detection pair's covariance takes the range std
    at the track's predicted range, :func:`_at_range`), with work arrays of its own; new
    tracks are left :data:`UNNUMBERED`."""
    q, gate, m_conf, n_conf, max_misses, max_coast, vel_var = params
    x, p, valid, confirmed, track_id, detection, hits, misses, scans, object_id, age, coast = (
        borrow((x, p, valid, confirmed, track_id, detection, hits, misses, scans, object_id,
                age, coast))
    )  # fmt: skip
    rows, azimuth, range_rate, range_rate_std, det_object, speed0, speed1, yaw_rate, shift = (
        borrow((rows, azimuth, range_rate, range_rate_std, det_object, speed0, speed1, yaw_rate,
                shift))
    )  # fmt: skip
    rng, range_std = borrow((rng, range_std))
    zx, zy, rxx, rxy, ryy = borrow(conv)
    cov = np.empty(3)  # one pair's (rxx, rxy, ryy)
    n_slots = valid.shape[1]
    k_max = max(widest, 1)
    owners = (
        *cv_model(dt, q), np.empty(DIM), np.empty((DIM, DIM)), np.empty(2), np.empty((2, 2)),
        np.empty((2, 2)), np.empty((2, 2)), np.empty((DIM, 2)), np.empty((DIM, 2)),
        np.empty((n_slots, k_max)), np.empty((DIM, DIM)), np.empty(DIM),
    )  # fmt: skip
    f, qm, xt, ap, y, s_mat, si, work, ph, kg, d2, a, b = borrow(owners)
    int_owners = (np.empty(n_slots, np.int64), np.empty(n_slots, np.int64))
    slots, out = borrow(int_owners)
    used_owner = np.empty(k_max, np.bool_)
    used = borrow(used_owner)
    scratch_owner = scratch_arrays(n_slots, k_max)
    scratch = borrow(scratch_owner)
    for e in range(lo, hi):
        ego_transform(dt, speed0[e], speed1[e], yaw_rate[e], shift[e], f, a, b)
        n_t = 0
        for t in range(n_slots):
            detection[e, t] = -1
            if valid[e, t]:
                predict_one(x[e, t], p[e, t], a, qm, 1.0, b, 1.0, xt, ap, DIM)
                age[e, t] += dt
                coast[e, t] += dt
                slots[n_t] = t
                n_t += 1
        if not online:  # between samples: prediction only, nothing counted
            _manage(valid, confirmed, hits, misses, scans, coast, e, params)
            continue
        k0, n_k = rows[e], rows[e + 1] - rows[e]
        for i in range(n_t):
            t = slots[i]
            for j in range(n_k):
                k = k0 + j
                _at_range(x[e, t], k, rng, range_std, growth, zx, zy, rxx, rxy, ryy, cov)
                dx = zx[k] - x[e, t, 0]
                if dx * dx >= gate * (p[e, t, 0, 0] + cov[0]):  # d2 >= dx^2 / S_xx: outside
                    d2[i, j] = np.inf
                    continue
                d2[i, j] = _innovation(
                    x[e, t], p[e, t], zx[k], zy[k], cov[0], cov[1], cov[2], y, s_mat, si, work
                )
        gnn(d2, n_t, n_k, gate, out, scratch)
        for j in range(n_k):
            used[j] = False
        for i in range(n_t):
            t, j = slots[i], out[i]
            scans[e, t] += 1
            if j < 0:
                misses[e, t] += 1
                continue
            k = k0 + j
            _at_range(x[e, t], k, rng, range_std, growth, zx, zy, rxx, rxy, ryy, cov)
            _innovation(x[e, t], p[e, t], zx[k], zy[k], cov[0], cov[1], cov[2], y, s_mat, si, work)
            _update(x[e, t], p[e, t], y, si, ph, kg)
            used[j] = True
            detection[e, t], object_id[e, t] = k, det_object[k]
            hits[e, t] += 1
            misses[e, t] = 0
            coast[e, t] = 0.0
        _manage(valid, confirmed, hits, misses, scans, coast, e, params)
        t = 0
        for j in range(n_k):  # unassigned detections start tentative tracks in free slots
            if used[j]:
                continue
            while t < n_slots and valid[e, t]:
                t += 1
            if t == n_slots:
                break
            k = k0 + j
            _birth(x[e, t], p[e, t], zx[k], zy[k], rxx[k], rxy[k], ryy[k], range_rate[k],
                   range_rate_std[k], azimuth[k], vel_var)  # fmt: skip
            valid[e, t], confirmed[e, t] = True, m_conf <= 1
            track_id[e, t] = UNNUMBERED
            detection[e, t], object_id[e, t] = k, det_object[k]
            hits[e, t], misses[e, t], scans[e, t] = 1, 0, 1
            age[e, t], coast[e, t] = 0.0, 0.0
    keep_alive((owners, int_owners, used_owner, scratch_owner))


@njit(cache=True, inline="always")
def _manage(valid, confirmed, hits, misses, scans, coast, e, params):  # pragma: no cover
    """M-of-N confirmation and deletion of ego ``e``'s tracks (tracker module docstring)."""
    m_conf, n_conf, max_misses, max_coast = params[2], params[3], params[4], params[5]
    for t in range(valid.shape[1]):
        if not valid[e, t]:
            continue
        if not confirmed[e, t]:
            if hits[e, t] >= m_conf:
                confirmed[e, t] = True
            elif hits[e, t] + n_conf - scans[e, t] < m_conf:
                valid[e, t] = False
        if confirmed[e, t] and misses[e, t] >= max_misses:
            valid[e, t] = False
        if coast[e, t] > max_coast + TIME_TOL:
            valid[e, t] = False
        if not valid[e, t]:
            confirmed[e, t] = False
