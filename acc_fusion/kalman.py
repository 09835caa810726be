r"""Batched Kalman-filter algebra over many independent filters at once.

Layout: the *pair axis is last*.  A batch of N state vectors is an array of shape ``(n, N)``
and a batch of covariances ``(n, n, N)``; a matrix without the trailing axis (``(n, n)``)
broadcasts over all pairs.  Putting the pair axis last keeps every elementary operation a
contiguous vector operation of length N, which is what makes the batched engine fast
(numpy's stacked ``matmul`` on ``(N, 3, 3)`` spends its time in per-matrix overhead).

The equations are those of filterpy's ``KalmanFilter`` (the reference engine), so the two
engines agree to rounding error:

.. math::

    \hat x^- = F \hat x,\qquad P^- = F P F^\top + Q                       \\
    y = z - H \hat x^-,\qquad S = H P^- H^\top + R,\qquad K = P^- H^\top S^{-1} \\
    \hat x = \hat x^- + K y,\qquad
    P = (I - K H) P^- (I - K H)^\top + K R K^\top \quad\text{(Joseph form)}

and the normalised innovation squared :math:`\epsilon_\nu = y^\top S^{-1} y` (the square of
filterpy's ``mahalanobis``).
"""

from __future__ import annotations

import numpy as np


def mm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched matrix product ``a @ b`` with the pair axis last (either side may be unbatched)."""
    return np.einsum("ij...,jk...->ik...", a, b)


def mv(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Batched matrix-vector product ``a @ x`` with the pair axis last."""
    return np.einsum("ij...,j...->i...", a, x)


def mt(a: np.ndarray) -> np.ndarray:
    """Batched transpose (swap the two matrix axes)."""
    return a.swapaxes(0, 1)


def inv(a: np.ndarray) -> np.ndarray:
    """Batched inverse of 1x1, 2x2 or symmetric 3x3 matrices (closed form), others by LAPACK.

    The 3x3 branch uses the adjugate of a *symmetric* matrix; it is used for covariance and
    information matrices only.
    """
    n = a.shape[0]
    if n == 1:
        return 1.0 / a
    if n == 2:
        det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        return np.stack([np.stack([a[1, 1], -a[0, 1]]), np.stack([-a[1, 0], a[0, 0]])]) / det
    if n == 3:
        p00, p01, p02, p11, p12, p22 = a[0, 0], a[0, 1], a[0, 2], a[1, 1], a[1, 2], a[2, 2]
        c00 = p11 * p22 - p12 * p12
        c01 = p02 * p12 - p01 * p22
        c02 = p01 * p12 - p02 * p11
        c11 = p00 * p22 - p02 * p02
        c12 = p01 * p02 - p00 * p12
        c22 = p00 * p11 - p01 * p01
        det = p00 * c00 + p01 * c01 + p02 * c02
        return np.stack(
            [np.stack([c00, c01, c02]), np.stack([c01, c11, c12]), np.stack([c02, c12, c22])]
        ) / det
    moved = np.moveaxis(a, -1, 0) if a.ndim == 3 else a
    out = np.linalg.inv(moved)
    return np.moveaxis(out, 0, -1) if a.ndim == 3 else out


def predict(
    x: np.ndarray, p: np.ndarray, f: np.ndarray, q: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    r"""Time update :math:`\hat x^- = F\hat x`, :math:`P^- = F P F^\top + Q` for all pairs."""
    p_new = mm(mm(f, p), f.T)
    return mv(f, x), p_new + (q if q.ndim == p_new.ndim else q[..., None])


def update(
    x: np.ndarray, p: np.ndarray, z: np.ndarray, r: np.ndarray, h: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Measurement update (Joseph form) of every pair; returns ``(x, P, nis)``.

    ``h`` is ``(m, n)`` or per-pair ``(m, n, N)``; ``z`` is ``(m, N)``; ``r`` is ``(m, m, N)``.
    Callers select the pairs that actually reported (``np.where`` on a mask).
    """
    ht = mt(h)
    pht = mm(p, ht)
    s = mm(h, pht) + r
    si = inv(s)
    k = mm(pht, si)
    y = z - mv(h, x)
    x_new = x + mv(k, y)
    i_kh = np.eye(x.shape[0])[..., None] - mm(k, h) if h.ndim == 2 else _eye_minus(mm(k, h))
    p_new = mm(mm(i_kh, p), mt(i_kh)) + mm(mm(k, r), mt(k))
    nis = np.einsum("i...,ij...,j...->...", y, si, y)
    return x_new, p_new, nis


def _eye_minus(a: np.ndarray) -> np.ndarray:
    out = -a
    for i in range(a.shape[0]):
        out[i, i] += 1.0
    return out


def innovation_nis(
    x: np.ndarray, p: np.ndarray, z: np.ndarray, r: np.ndarray, h: np.ndarray
) -> np.ndarray:
    r"""NIS :math:`y^\top (H P H^\top + R)^{-1} y` of measurement ``z`` against prior ``(x, P)``."""
    y = z - mv(h, x)
    s = mm(mm(h, p), mt(h)) + r
    return np.einsum("i...,ij...,j...->...", y, inv(s), y)


def select(mask: np.ndarray, new: np.ndarray, old: np.ndarray) -> np.ndarray:
    """Per-pair choice: ``new`` where ``mask`` (shape ``(N,)``) is true, ``old`` elsewhere."""
    return np.where(mask, new, old)
