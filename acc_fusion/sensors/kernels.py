"""The compiled measurement steps of the sensors: observation of the true gap and range-rate
(limits, detection probability, noise), clutter ghosts, held outputs. A set of numba kernels
that must stay together: :func:`_observe_emit` fuses the per-pair kernels."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _forget(pairs, held_z, held_valid, held_ghost, ghost_range, ghost_life):  # pragma: no cover
    """:meth:`Sensor.forget` of the pairs in ``pairs (N,)``, in place: no held output
    (``held_z (2, N)`` NaN, not valid, no ghost) and a free clutter slot (range inf,
    lifetime 0)."""
    for i in range(pairs.size):
        if pairs[i]:
            for a in range(held_z.shape[0]):
                held_z[a, i] = np.nan
            held_valid[i] = False
            held_ghost[i] = False
            ghost_range[i] = np.inf
            ghost_life[i] = 0.0


@njit(cache=True)
def _move_ghosts(
    u, ego_speed, dt, p_spawn, r_lo, r_hi, d_lo, d_hi, ghost_range, ghost_life
):  # pragma: no cover - compiled
    """Age every pair's ghost by ``dt`` and close it at ``ego_speed``, or spawn a new one.

    A free slot (lifetime ``<= 0`` after ageing) spawns when ``u[0] < p_spawn``, at range
    ``r_lo + (r_hi - r_lo) u[1]`` with lifetime ``d_lo + (d_hi - d_lo) u[2]``;
    ``ghost_range`` and ``ghost_life`` ``(N,)`` are updated in place.
    """
    for i in range(ghost_life.size):
        life = ghost_life[i] - dt
        if life <= 0 and u[0, i] < p_spawn:
            ghost_range[i] = r_lo + (r_hi - r_lo) * u[1, i]
            ghost_life[i] = d_lo + (d_hi - d_lo) * u[2, i]
        else:
            ghost_range[i] = ghost_range[i] - ego_speed[i] * dt
            ghost_life[i] = life


@njit(cache=True)
def _observe(
    gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e, params,
    clean, noise, seen, ghost,
):  # pragma: no cover - compiled  # fmt: skip
    """What the sensor sees of each pair, before faults (:func:`_observe_one` of every pair).

    Writes ``clean (2, N)`` the true [range, range-rate] of the reported object, ``noise
    (2, N)`` the scaled noise, ``seen (N,)`` visible and detected, ``ghost (N,)`` the reported
    object is a ghost.
    """
    for i in range(gap.size):
        clean[0, i], clean[1, i], noise[0, i], noise[1, i], seen[i], ghost[i] = _observe_one(
            i, gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e,
            params,
        )  # fmt: skip


# The per-pair helpers are left to LLVM to inline: numba's own inlining (inline="always")
# made the loop of _observe_emit three times slower.
@njit(cache=True)
def _observe_one(
    i, gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e, params
):  # pragma: no cover - compiled
    """What the sensor sees of pair ``i``, before faults (the model of the module docstring).

    The target is visible with a leader, ``min_range <= gap <= max_range`` and
    ``|bearing| <= half_fov`` (``bearing`` ``None``: every lateral offset is zero, the bearing
    is ``atan2(0, gap)``); a live ghost in the range limits is reported instead unless the
    visible target is closer.  A visible return is detected when ``u < detection_prob``.
    Returns the true range and range-rate of the reported object, the draws ``e[:, i]``
    scaled by ``[range_noise_std(true range), range_rate_std]``, whether the object is seen
    (visible and detected) and whether it is a ghost.
    """
    min_range, max_range, half_fov, detection_prob, range_std, quadratic, rate_std = params
    g = gap[i]
    target = leader_id[i] >= 0 and g >= min_range and g <= max_range
    if target:
        if bearing is not None:
            b = bearing[i]
        else:  # atan2(0, g) is 0 for g > 0; g = +-0 gives 0 or pi
            b = 0.0 if g > 0.0 else np.arctan2(0.0, g)
        target = abs(b) <= half_fov
    gr = ghost_range[i]
    in_view = ghost_life[i] > 0 and gr >= min_range and gr <= max_range
    use_ghost = in_view and not (target and g <= gr)
    if use_ghost:
        true_range, true_rate = gr, -ego_speed[i]
    else:
        true_range, true_rate = g, lead_speed[i] - ego_speed[i]
    noise_range = e[0, i] * (range_std + quadratic * true_range * true_range)
    noise_rate = e[1, i] * rate_std
    seen = (target or use_ghost) and u[i] < detection_prob
    return true_range, true_rate, noise_range, noise_rate, seen, use_ghost


@njit(cache=True)
def _emit(
    out_z, out_valid, out_ghost, held_z, held_valid, held_ghost, params, z, r, valid, ghost
):  # pragma: no cover - compiled
    """Turn the (faulted) report ``out_*`` (``out_z (2, N)``) into the measurement
    (:func:`_emit_one` of every pair)."""
    for i in range(valid.size):
        _emit_one(
            i, out_z[0, i], out_z[1, i], out_valid[i], out_ghost[i], held_z, held_valid,
            held_ghost, params, z, r, valid, ghost,
        )  # fmt: skip


@njit(cache=True)
def _emit_one(
    i, out_range, out_rate, out_valid, out_ghost, held_z, held_valid, held_ghost, params, z, r,
    valid, ghost,
):  # pragma: no cover - compiled  # fmt: skip
    """Turn pair ``i``'s report into its measurement; remember what was output.

    Where ``out_valid``: ``held_*`` takes the report (in place), ``z (2, N)`` is the report
    with the range clipped at 0 (a range sensor cannot report a negative range; as with
    ``np.maximum``, NaN stays NaN and -0 becomes +0) and ``r (2, 2, N)`` is
    ``diag(range_noise_std(z[0])**2, range_rate_std**2)``; elsewhere ``z`` is NaN and ``r``
    the identity.  ``valid`` and ``ghost (N,)`` are the output flags.
    """
    range_std, quadratic, rate_var = params
    if out_valid:
        held_z[0, i] = out_range
        held_z[1, i] = out_rate
        held_valid[i] = True
        held_ghost[i] = out_ghost
        dist = 0.0 if out_range <= 0.0 else out_range
        std = range_std + quadratic * dist * dist
        z[0, i] = dist
        z[1, i] = out_rate
        r[0, 0, i] = std * std
        r[1, 1, i] = rate_var
    else:
        z[0, i] = np.nan
        z[1, i] = np.nan
        r[0, 0, i] = 1.0
        r[1, 1, i] = 1.0
    r[0, 1, i] = 0.0
    r[1, 0, i] = 0.0
    valid[i] = out_valid
    ghost[i] = out_valid and out_ghost


@njit(cache=True)
def _observe_emit(
    gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e,
    observe_params, held_z, held_valid, held_ghost, emit_params, z, r, valid, ghost,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_observe` then :func:`_emit` of the unfaulted report (clean value plus noise),
    pair by pair in one pass."""
    for i in range(gap.size):
        true_range, true_rate, noise_range, noise_rate, seen, use_ghost = _observe_one(
            i, gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e,
            observe_params,
        )  # fmt: skip
        _emit_one(
            i, true_range + noise_range, true_rate + noise_rate, seen, use_ghost, held_z,
            held_valid, held_ghost, emit_params, z, r, valid, ghost,
        )  # fmt: skip
