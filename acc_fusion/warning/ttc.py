"""Time to collision from the gap, range-rate and relative acceleration, batched over pairs
(:func:`time_to_collision`)."""

from __future__ import annotations

import numpy as np
from numba import njit

from acc_fusion.core.arrays import all_finite, check_array
from acc_fusion.core.errors import InputError
from acc_fusion.warning.safety_kernels import _maximum


def time_to_collision(gap, v_rel, a_rel=None) -> np.ndarray:
    r"""Time until the gap closes [s], ``inf`` where it never does (arrays ``(N,)``).

    Without ``a_rel`` (constant range-rate): :math:`\mathrm{TTC} = g / (-\dot g)` where
    :math:`\dot g < 0`.  With the relative acceleration :math:`\ddot g` = ``a_rel`` [m/s²]
    (constant-acceleration TTC), the first positive root of
    :math:`g + \dot g t + \tfrac12 \ddot g t^2 = 0`, computed in the cancellation-free form

    .. math::

        \mathrm{TTC} = \frac{2 g}{-\dot g + \sqrt{\dot g^2 - 2 \ddot g g}},

    ``inf`` where the discriminant is negative or the denominator is not positive (the gap
    never closes).  A gap that is already ``<= 0`` has a TTC of 0.
    """
    g = np.asarray(gap, dtype=float)
    rate = np.asarray(v_rel, dtype=float)
    acc = np.zeros(()) if a_rel is None else np.asarray(a_rel, dtype=float)
    try:
        shape = np.broadcast(g, rate, acc).shape or (1,)  # scalars give (1,)
    except ValueError:
        shape = None
    if shape is not None:
        out = np.empty(shape)
        size = out.size
        if _time_to_collision(
            _flat(g, shape, size), _flat(rate, shape, size), _flat(acc, shape, size), out.ravel()
        ):
            return out
    # An input is not finite (the checks raise), or the shapes do not broadcast.
    check_array("gap", g)
    check_array("v_rel", rate)
    check_array("a_rel", acc)
    raise InputError(
        "gap, v_rel and a_rel must be scalars or arrays of one length N, got shapes "
        f"{np.shape(gap)}, {np.shape(v_rel)} and {np.shape(a_rel)}"
    )


def _flat(x: np.ndarray, shape: tuple[int, ...], size: int) -> np.ndarray:
    """``x`` flat for :func:`_time_to_collision`: itself if it has 1 or ``size`` entries, or
    if ``size`` is 0 (then it is only checked), else broadcast to ``shape``."""
    if x.size in (1, size) or size == 0:
        return x.ravel()
    return np.broadcast_to(x, shape).ravel()


@njit(cache=True, error_model="numpy")
def _time_to_collision(g, rate, acc, out):  # pragma: no cover - compiled
    """:func:`time_to_collision` of flat inputs of ``out.size`` entries (or 1, broadcast) into
    ``out``; False, before writing, if an input is not finite."""
    if not (all_finite(g) and all_finite(rate) and all_finite(acc)):
        return False
    for i in range(out.size):
        gi = g[i if g.size > 1 else 0]
        ri = rate[i if rate.size > 1 else 0]
        ai = acc[i if acc.size > 1 else 0]
        gap_pos = _maximum(gi, 0.0)
        disc = ri * ri - 2.0 * ai * gap_pos
        denom = -ri + np.sqrt(_maximum(disc, 0.0))
        if gi <= 0.0:
            out[i] = 0.0
        elif disc >= 0.0 and denom > 0.0:
            out[i] = 2.0 * gap_pos / denom
        else:
            out[i] = np.inf
    return True
