r"""Batched Kalman-filter kernels: the same equations as filterpy, over many pairs at once.

Every kernel works in place on arrays whose first axis is the pair (or filter) index:
states ``x`` of shape ``(N, n)``, covariances ``P`` of shape ``(N, n, n)`` with
``n = STATE_DIM`` (:mod:`acc_fusion.core.motion`).  They are compiled with numba, one tight loop
per pair with no temporary allocation, because numpy's stacked operations on 3×3 matrices
spend their time in per-matrix overhead (about 30× slower here).  The state dimension is a
compile-time constant, so the compiler unrolls the loops over it: twice as fast as reading
``n`` from the array shape (measured on the time update).  The equations are those of
filterpy's ``KalmanFilter`` (the reference engine), so the two engines agree to rounding
error:

.. math::

    \hat x^- = F \hat x,\qquad P^- = F P F^\top + s\,Q                                   \\
    y = z - H \hat x^-,\quad S = H P^- H^\top + R,\quad K = P^- H^\top S^{-1}          \\
    \hat x = \hat x^- + K y,\qquad
    P = P^- - K S K^\top \quad\text{(filterpy: the Joseph form, equal for the optimal } K)   \\
    \epsilon_\nu = y^\top S^{-1} y \quad\text{(NIS: the square of filterpy's ``mahalanobis``)}

where :math:`s` is a per-filter process-noise scale (:math:`1/\beta_i` in the federated filter).
The information fusion of several estimates of the same state (kong2011 eq. 5, hu2005 eq. 8,
Carlson 1990),

.. math::

    P_f = \Big(\sum_i P_i^{-1}\Big)^{-1},\qquad \hat x_f = P_f \sum_i P_i^{-1}\hat x_i,

is :func:`fuse`.  Rows of a measurement can be masked per pair (``rows``), so one call
updates the pairs whose sensor reported and leaves the others untouched; a pair with no
active row gets a NIS of NaN.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from acc_fusion.core.borrow import borrow, keep_alive
from acc_fusion.core.motion import MEAS_DIM, STATE_DIM

#: Pairs from which the batched kernels (here and the federated filter's,
#: :func:`~acc_fusion.fusion.kernels._federated_step_parallel`) run on all of numba's threads:
#: below it the threads' start costs more than they save, and the 1-D pipeline, whose SUMO
#: runs in a process of its own on the other core, keeps to one (its default 1 024 slots stay
#: below).
PARALLEL_PAIRS = 2048


@njit(cache=True)
def _invert(a, out, work, m):  # pragma: no cover - compiled
    """Invert the leading ``m×m`` block of ``a`` into ``out`` (Gauss-Jordan, partial pivoting)."""
    for i in range(m):
        for j in range(m):
            work[i, j] = a[i, j]
            out[i, j] = 1.0 if i == j else 0.0
    for c in range(m):
        piv = c
        big = abs(work[c, c])
        for r in range(c + 1, m):
            if abs(work[r, c]) > big:
                big = abs(work[r, c])
                piv = r
        if piv != c:
            for j in range(m):
                t = work[c, j]
                work[c, j] = work[piv, j]
                work[piv, j] = t
                t = out[c, j]
                out[c, j] = out[piv, j]
                out[piv, j] = t
        d = work[c, c]
        for j in range(m):
            work[c, j] /= d
            out[c, j] /= d
        for r in range(m):
            if r != c:
                fct = work[r, c]
                if fct != 0.0:
                    for j in range(m):
                        work[r, j] -= fct * work[c, j]
                        out[r, j] -= fct * out[c, j]


@njit(cache=True, inline="always")
def _inverse(a, out, work, m):  # pragma: no cover - compiled
    """Inverse of the leading ``m×m`` block of the symmetric matrix ``a`` into ``out``: closed
    form for 1×1, 2×2 and 3×3, else pivoted Gauss-Jordan.  (Covariances, innovation
    covariances and information matrices are symmetric positive definite and well conditioned
    at these sizes.)  The size is an argument rather than a slice: no array view per call.
    Inlined into its callers, so that a size known when compiling selects its branch there."""
    if m == 1:
        out[0, 0] = 1.0 / a[0, 0]
    elif m == 2:
        det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        out[0, 0] = a[1, 1] / det
        out[0, 1] = -a[0, 1] / det
        out[1, 0] = -a[1, 0] / det
        out[1, 1] = a[0, 0] / det
    elif m == 3:
        c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
        c01 = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
        c02 = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
        c11 = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
        c12 = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
        c22 = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        det = (
            a[0, 0] * c00
            + a[0, 1] * (a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2])
            + a[0, 2] * (a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0])
        )
        out[0, 0] = c00 / det
        out[0, 1] = c01 / det
        out[0, 2] = c02 / det
        out[1, 0] = c01 / det
        out[1, 1] = c11 / det
        out[1, 2] = c12 / det
        out[2, 0] = c02 / det
        out[2, 1] = c12 / det
        out[2, 2] = c22 / det
    else:
        _invert(a, out, work, m)


@njit(cache=True)
def _active_rows(rows, k, idx):  # pragma: no cover - compiled
    """Put the indices of pair ``k``'s active measurement rows in ``idx``; return how many."""
    m = 0
    for i in range(rows.shape[1]):
        if rows[k, i]:
            idx[m] = i
            m += 1
    return m


def input_args(b: np.ndarray, u: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The ``b, u`` arguments of :func:`predict` for the known input ``u (N,)`` through
    ``b (n,)``, or for none (``u`` is ``None``: a zero input)."""
    if u is None:
        return np.zeros(STATE_DIM), np.zeros(1)
    return np.ascontiguousarray(b, dtype=float), np.ascontiguousarray(u, dtype=float)


@njit(cache=True)
def predict(x, p, f, q, q_scale, mask, b, u):  # pragma: no cover - compiled
    r"""Time update in place: :math:`x \leftarrow F x + b\,u`, :math:`P \leftarrow F P F^\top
    + s Q`.

    Shapes: ``x (N, n)``, ``p (N, n, n)``, ``f, q (n, n)``, ``q_scale (N,)``, ``mask (N,)``,
    ``b (n,)``; the known input ``u (M,)`` with N a multiple of M: row k uses ``u[k % M]``
    (K banks of M pairs share the pairs' inputs).
    """
    if x.shape[1] != STATE_DIM:
        raise ValueError("predict: the state must have STATE_DIM entries")
    _predict_range(0, x.shape[0], x, p, f, q, q_scale, mask, b, u)


@njit(cache=True, parallel=True)
def predict_parallel(x, p, f, q, q_scale, mask, b, u, chunks):  # pragma: no cover - compiled
    """:func:`predict` on the cores, the pairs in ``chunks`` blocks (the filters are
    independent: the same result bit for bit)."""
    if x.shape[1] != STATE_DIM:
        raise ValueError("predict: the state must have STATE_DIM entries")
    n = x.shape[0]
    for c in prange(chunks):
        _predict_range(c * n // chunks, (c + 1) * n // chunks, x, p, f, q, q_scale, mask, b, u)


@njit(cache=True)
def _predict_range(lo, hi, x, p, f, q, q_scale, mask, b, u):  # pragma: no cover - compiled
    """:func:`predict` of the pairs ``lo`` to ``hi``, with work arrays of its own."""
    x, p, f, q, q_scale, mask, b, u = borrow((x, p, f, q, q_scale, mask, b, u))
    n = STATE_DIM
    owners = (np.empty(n), np.empty((n, n)))
    xt, fp = borrow(owners)
    for k in range(lo, hi):
        if mask[k]:
            predict_one(x[k], p[k], f, q, q_scale[k], b, u[k % u.size], xt, fp, STATE_DIM)
    keep_alive(owners)


@njit(cache=True, inline="always")
def predict_one(x, p, f, q, scale, b, u, xt, fp, n):  # pragma: no cover - compiled
    """:func:`predict` of one filter ``x (n,)``, ``p (n, n)`` with process-noise scale
    ``scale`` and input ``u`` (``xt (n,)``, ``fp (n, n)``: scratch); the state size ``n`` a
    constant of the caller's, so that the loops over it unroll where this is inlined."""
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += f[i, j] * x[j]
        xt[i] = s + b[i] * u
    for i in range(n):
        x[i] = xt[i]
        for j in range(n):
            s = 0.0
            for m in range(n):
                s += f[i, m] * p[m, j]
            fp[i, j] = s
    for i in range(n):
        for j in range(n):
            s = 0.0
            for m in range(n):
                s += fp[i, m] * f[j, m]
            p[i, j] = s + scale * q[i, j]


@njit(cache=True)
def assign(x, p, mask, x_new, p_new, p_scale):  # pragma: no cover - compiled
    r"""Set the filters in ``mask (N,)`` in place: :math:`x = x_{new}`, :math:`P = s\,P_{new}`
    with the per-pair scale ``p_scale (N,)``."""
    x, p, mask, x_new, p_new, p_scale = borrow((x, p, mask, x_new, p_new, p_scale))
    for k in range(x.shape[0]):
        if mask[k]:
            assign_one(x[k], p[k], x_new[k], p_new[k], p_scale[k])


@njit(cache=True, inline="always")
def assign_one(x, p, x_new, p_new, scale):  # pragma: no cover - compiled
    """:func:`assign` of one filter: ``x = x_new``, ``p = scale * p_new``."""
    n = STATE_DIM
    for i in range(n):
        x[i] = x_new[i]
        for j in range(n):
            p[i, j] = p_new[i, j] * scale


@njit(cache=True, inline="always")
def _row_scratch(m_all):  # pragma: no cover - compiled
    """Work arrays of :func:`update` and :func:`innovation_nis` for measurements of up to
    ``m_all`` rows: ``idx, hs, zs, rs, s_mat, si, work, y``."""
    n = STATE_DIM
    return (
        np.empty(m_all, dtype=np.int64), np.empty((m_all, n)), np.empty(m_all),
        np.empty((m_all, m_all)), np.empty((m_all, m_all)), np.empty((m_all, m_all)),
        np.empty((m_all, m_all)), np.empty(m_all),
    )  # fmt: skip


@njit(cache=True)
def update(x, p, z, r, h, rows, nis):  # pragma: no cover - compiled
    r"""Measurement update in place using the active rows of each pair.

    The covariance update is :math:`P - K S K^\top = P - K (P H^\top)^\top`, kept exactly
    symmetric; with the optimal gain it equals filterpy's Joseph form to rounding error
    (the engines test holds them equal to 1e-9) at a fifth of the cost.

    Shapes: ``x (N, n)``, ``p (N, n, n)``, ``z (N, m)``, ``r (N, m, m)``, ``h (m, n)``,
    ``rows (N, m)`` bool (which measurement rows pair ``k`` has), ``nis (N,)`` output.
    A pair with all the :data:`~acc_fusion.core.motion.MEAS_DIM` rows of a sensor (the usual
    case) is updated with the row count known when compiling, which unrolls the loops over
    it (twice as fast); other pairs with their active rows gathered first.
    """
    _update_range(0, x.shape[0], x, p, z, r, h, rows, nis)


@njit(cache=True, parallel=True)
def update_parallel(x, p, z, r, h, rows, nis, chunks):  # pragma: no cover - compiled
    """:func:`update` on the cores, the pairs in ``chunks`` blocks (the same result bit for
    bit)."""
    n = x.shape[0]
    for c in prange(chunks):
        _update_range(c * n // chunks, (c + 1) * n // chunks, x, p, z, r, h, rows, nis)


@njit(cache=True)
def _update_range(lo, hi, x, p, z, r, h, rows, nis):  # pragma: no cover - compiled
    """:func:`update` of the pairs ``lo`` to ``hi``, with work arrays of its own."""
    x, p, z, r, h, rows, nis = borrow((x, p, z, r, h, rows, nis))
    n = STATE_DIM
    m_all = h.shape[0]
    full = m_all == MEAS_DIM
    owners = _row_scratch(m_all)
    idx, hs, zs, rs, s_mat, si, work, y = borrow(owners)
    kg_owners = (np.empty((n, m_all)), np.empty((n, m_all)))
    pht, kg = borrow(kg_owners)
    for k in range(lo, hi):
        m = _active_rows(rows, k, idx)
        if m == 0:
            nis[k] = np.nan
        elif full and m == MEAS_DIM:
            nis[k] = update_one(x[k], p[k], h, z[k], r[k], MEAS_DIM, pht, kg, s_mat, si, work, y)
        else:
            _gather_rows(h, z[k], r[k], idx, m, hs, zs, rs)
            nis[k] = update_one(x[k], p[k], hs, zs, rs, m, pht, kg, s_mat, si, work, y)
    keep_alive((owners, kg_owners))


@njit(cache=True, inline="always")
def _gather_rows(h, z, r, idx, m, hs, zs, rs):  # pragma: no cover - compiled
    """The rows ``idx[:m]`` of a measurement model ``h``, its value ``z`` and covariance
    ``r`` into the leading blocks of ``hs``, ``zs``, ``rs``."""
    for a in range(m):
        zs[a] = z[idx[a]]
        for j in range(h.shape[1]):
            hs[a, j] = h[idx[a], j]
        for b in range(m):
            rs[a, b] = r[idx[a], idx[b]]


@njit(cache=True, inline="always")
def update_one(x, p, h, z, r, m, pht, kg, s_mat, si, work, y):  # pragma: no cover - compiled
    """:func:`update` of one filter ``x (n,)``, ``p (n, n)`` in place with the first ``m``
    rows of ``h``, ``z``, ``r``; returns the NIS."""
    n = STATE_DIM
    for i in range(n):  # P H^T
        for a in range(m):
            s = 0.0
            for j in range(n):
                s += p[i, j] * h[a, j]
            pht[i, a] = s
    for a in range(m):  # S = H P H^T + R
        for b in range(m):
            s = 0.0
            for j in range(n):
                s += h[a, j] * pht[j, b]
            s_mat[a, b] = s + r[a, b]
    _inverse(s_mat, si, work, m)
    for i in range(n):  # K = P H^T S^-1
        for b in range(m):
            s = 0.0
            for a in range(m):
                s += pht[i, a] * si[a, b]
            kg[i, b] = s
    for a in range(m):  # y = z - H x
        s = 0.0
        for j in range(n):
            s += h[a, j] * x[j]
        y[a] = z[a] - s
    e = 0.0
    for a in range(m):
        for b in range(m):
            e += y[a] * si[a, b] * y[b]
    for i in range(n):
        s = 0.0
        for a in range(m):
            s += kg[i, a] * y[a]
        x[i] += s
    for i in range(n):  # P - K (H P) = P - K S K^T, upper triangle mirrored
        for j in range(i, n):
            t = 0.0
            for a in range(m):
                t += kg[i, a] * pht[j, a]
            v = p[i, j] - t
            p[i, j] = v
            p[j, i] = v
    return e


@njit(cache=True)
def innovation_nis(x, p, z, r, h, rows, nis):  # pragma: no cover - compiled
    r"""NIS :math:`y^\top (H P H^\top + R)^{-1} y` of each pair's active rows, without
    updating (all :data:`~acc_fusion.core.motion.MEAS_DIM` rows: unrolled, as :func:`update`)."""
    _nis_range(0, x.shape[0], x, p, z, r, h, rows, nis)


@njit(cache=True, parallel=True)
def innovation_nis_parallel(x, p, z, r, h, rows, nis, chunks):  # pragma: no cover - compiled
    """:func:`innovation_nis` on the cores, the pairs in ``chunks`` blocks."""
    n = x.shape[0]
    for c in prange(chunks):
        _nis_range(c * n // chunks, (c + 1) * n // chunks, x, p, z, r, h, rows, nis)


@njit(cache=True)
def _nis_range(lo, hi, x, p, z, r, h, rows, nis):  # pragma: no cover - compiled
    """:func:`innovation_nis` of the pairs ``lo`` to ``hi``, with work arrays of its own."""
    x, p, z, r, h, rows, nis = borrow((x, p, z, r, h, rows, nis))
    m_all = h.shape[0]
    full = m_all == MEAS_DIM
    owners = _row_scratch(m_all)
    idx, hs, zs, rs, s_mat, si, work, y = borrow(owners)
    for k in range(lo, hi):
        m = _active_rows(rows, k, idx)
        if m == 0:
            nis[k] = np.nan
        elif full and m == MEAS_DIM:
            nis[k] = nis_one(x[k], p[k], h, z[k], r[k], MEAS_DIM, s_mat, si, work, y)
        else:
            _gather_rows(h, z[k], r[k], idx, m, hs, zs, rs)
            nis[k] = nis_one(x[k], p[k], hs, zs, rs, m, s_mat, si, work, y)
    keep_alive(owners)


@njit(cache=True, inline="always")
def nis_one(x, p, h, z, r, m, s_mat, si, work, y):  # pragma: no cover - compiled
    """:func:`innovation_nis` of one filter with the first ``m`` rows of ``h``, ``z``, ``r``."""
    n = STATE_DIM
    for a in range(m):
        s = 0.0
        for j in range(n):
            s += h[a, j] * x[j]
        y[a] = z[a] - s
        for b in range(m):
            s = 0.0
            for i in range(n):
                for j in range(n):
                    s += h[a, i] * p[i, j] * h[b, j]
            s_mat[a, b] = s + r[a, b]
    _inverse(s_mat, si, work, m)
    e = 0.0
    for a in range(m):
        for b in range(m):
            e += y[a] * si[a, b] * y[b]
    return e


@njit(cache=True)
def fuse(xs, ps, active, x_prior, p_prior, increments, x_out, p_out):  # pragma: no cover
    r"""Information fusion of the active local estimates of every pair.

    ``xs (S, N, n)``, ``ps (S, N, n, n)``, ``active (S, N)``; ``x_prior (N, n)``,
    ``p_prior (N, n, n)`` is the master's own prediction.  With ``increments`` false:
    :math:`Y = \sum_i P_i^{-1}`, :math:`y = \sum_i P_i^{-1} x_i`.  With ``increments`` true
    (zero-reset mode) each local contributes only the information it gathered since the
    last fusion: :math:`Y = Y_m + \sum_i (P_i^{-1} - Y_m)`, with :math:`Y_m = (P_m^-)^{-1}`.
    A pair with no active local keeps the prior.  Results go to ``x_out``, ``p_out``.
    """
    xs, ps, active, x_prior, p_prior, x_out, p_out = borrow(
        (xs, ps, active, x_prior, p_prior, x_out, p_out)
    )
    n = STATE_DIM
    owners = (np.empty((n, n)), np.empty(n), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)))
    info, vec, yi, ym, work = borrow(owners)
    for k in range(xs.shape[1]):
        fuse_one(xs, ps, active, k, x_prior[k], p_prior[k], increments, x_out[k], p_out[k],
                 info, vec, yi, ym, work)  # fmt: skip
    keep_alive(owners)


@njit(cache=True, inline="always")
def fuse_one(
    xs, ps, active, k, x_prior, p_prior, increments, x_out, p_out, info, vec, yi, ym, work
):  # pragma: no cover - compiled
    """:func:`fuse` of pair ``k`` into ``x_out (n,)``, ``p_out (n, n)`` (``info``, ``vec``,
    ``yi``, ``ym``, ``work``: scratch)."""
    n_s, n = xs.shape[0], STATE_DIM
    count = 0
    for si_ in range(n_s):
        if active[si_, k]:
            count += 1
    if count == 0:
        for i in range(n):
            x_out[i] = x_prior[i]
            for j in range(n):
                p_out[i, j] = p_prior[i, j]
        return
    for i in range(n):
        vec[i] = 0.0
        for j in range(n):
            info[i, j] = 0.0
    if increments:
        _inverse(p_prior, ym, work, n)
        w = 1.0 - count
        for i in range(n):
            for j in range(n):
                info[i, j] += w * ym[i, j]
                vec[i] += w * ym[i, j] * x_prior[j]
    for si_ in range(n_s):
        if not active[si_, k]:
            continue
        _inverse(ps[si_, k], yi, work, n)
        for i in range(n):
            for j in range(n):
                info[i, j] += yi[i, j]
                vec[i] += yi[i, j] * xs[si_, k, j]
    _inverse(info, yi, work, n)
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += yi[i, j] * vec[j]
            p_out[i, j] = 0.5 * (yi[i, j] + yi[j, i])
        x_out[i] = s


def warmup() -> None:
    """Compile (or load from numba's cache) every kernel, so that timings exclude it."""
    x, p = np.zeros((1, 3)), np.eye(3)[None].copy()
    z, r, h = np.zeros((1, 2)), np.eye(2)[None].copy(), np.eye(3)[:2].copy()
    rows, out = np.ones((1, 2), dtype=bool), np.empty(1)
    predict(x, p, np.eye(3), np.eye(3), np.ones(1), np.ones(1, dtype=bool), np.zeros(3), z[0, :1])
    update(x, p, z, r, h, rows, out)
    assign(x, p, rows[:, 0], x.copy(), p.copy(), np.ones(1))
    innovation_nis(x, p, z, r, h, rows, out)
    fuse(x[None], p[None], np.ones((1, 1), dtype=bool), x, p, True, x.copy(), p.copy())
