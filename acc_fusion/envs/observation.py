"""What the environments observe: the entries of an observation, their bounds and clips (the
tables are in the docstrings of :class:`~acc_fusion.envs.collision_warning.CollisionWarningEnv`
and :class:`~acc_fusion.envs.world.CollisionWarningWorldEnv`).  Baseline policies read
observations by these names, without the environment."""

from __future__ import annotations

import numpy as np
from numba import njit

from acc_fusion.core.errors import InputError
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.warning.selection import MAX_HALF_WIDTH

#: Names of the observation's entries, in order (see the environment's docstring).
OBS_FIELDS = (
    "gap",
    "range_rate",
    "lead_accel",
    "gap_std",
    "range_rate_std",
    "lead_accel_std",
    "ego_speed",
    "track_valid",
) + tuple(f"{s}_{k}" for s in SENSOR_NAMES for k in ("reporting", "isolated", "nis", "age"))


#: Clips of a sensor's NIS and of the age of its last report [s] in the observation.
NIS_CLIP, AGE_CLIP = 100.0, 10.0
#: Values reported where there is no track: the gap at the radar's maximum range.
NO_TRACK_GAP = 250.0
#: Bounds of the observation space.
_LOW = np.array([0.0, -60.0, -15.0, 0.0, 0.0, 0.0, 0.0, 0.0] + [0.0, 0.0, 0.0, 0.0] * 2)
_HIGH = np.array(
    [NO_TRACK_GAP, 60.0, 15.0, 100.0, 60.0, 30.0, 70.0, 1.0] + [1.0, 1.0, NIS_CLIP, AGE_CLIP] * 2
)

#: The world environment's entries after :data:`OBS_FIELDS` (which describe its selected
#: in-path object), in order (see its docstring).
WORLD_FIELDS = (
    "lateral_offset",
    "lateral_speed",
    "ground_speed",
    "confirmed",
    "in_path_count",
    "second_gap",
    "path_curvature",
    "selection_age",
)
#: Names of the world environment's observation entries, in order.
WORLD_OBS_FIELDS = OBS_FIELDS + WORLD_FIELDS
#: Clips of the lateral speed [m/s], of the count of in-path objects and of the path's
#: curvature [1/m] (a radius of 10 m) in the world observation.
LATERAL_SPEED_CLIP, COUNT_CLIP, CURVATURE_CLIP = 10.0, 10.0, 0.1
#: Bounds of the world environment's observation space.
_WORLD_LOW = np.concatenate(
    [_LOW, [-MAX_HALF_WIDTH, -LATERAL_SPEED_CLIP, -70.0, 0.0, 0.0, 0.0, -CURVATURE_CLIP, 0.0]]
)
_WORLD_HIGH = np.concatenate(
    [
        _HIGH,
        [MAX_HALF_WIDTH, LATERAL_SPEED_CLIP, 70.0, 1.0, COUNT_CLIP, NO_TRACK_GAP,
         CURVATURE_CLIP, AGE_CLIP],
    ]
)  # fmt: skip


def track_entries(x, p, valid, v_ego, reporting, isolated, nis, age) -> np.ndarray:
    """The :data:`OBS_FIELDS` entries ``(n, 16)`` of n tracks, clipped to the bounds.

    Args:
        x, p: ``(n, 3)`` estimates [gap, range-rate, lead acceleration] and ``(n, 3, 3)``
            their covariances (meaningless where not ``valid``).
        valid: ``(n,)`` there is a track.
        v_ego: ``(n,)`` ego speed of the ego-motion filter [m/s].
        reporting: per sensor of :data:`SENSOR_NAMES`, ``(n,)`` the sensor measured the track's
            object at this step (``(S, n)``).
        isolated, nis: ``(n, S)`` the fault detection isolates the sensor, and its NIS (NaN
            where it did not report).
        age: ``(S, n)`` seconds since each sensor's last measurement of the object.

    Where there is no track, the estimate is :data:`NO_TRACK_GAP`, 0, 0 and its standard
    deviations 0; a NIS that is not finite is 0, a finite one at most :data:`NIS_CLIP`.
    """
    valid = np.asarray(valid, dtype=bool)
    n, s = valid.shape[0] if valid.ndim == 1 else -1, len(SENSOR_NAMES)
    args = []
    for name, value, dtype, shape in (
        ("valid", valid, bool, (n,)), ("x", x, float, (n, 3)), ("p", p, float, (n, 3, 3)),
        ("v_ego", v_ego, float, (n,)), ("reporting", reporting, bool, (s, n)),
        ("isolated", isolated, bool, (n, s)), ("nis", nis, float, (n, s)),
        ("age", age, float, (s, n)),
    ):  # fmt: skip
        a = np.asarray(value, dtype=dtype)
        if a.shape != shape or n < 0:
            want = "(N,)" if n < 0 else str(shape)
            raise InputError(f"track_entries: {name} must have shape {want}, got {a.shape}")
        args.append(np.ascontiguousarray(a))
    out = np.empty((n, _LOW.size))
    _entries(*args, _LOW, _HIGH, NO_TRACK_GAP, NIS_CLIP, out)
    return out


@njit(cache=True)
def _entries(
    valid, x, p, v_ego, reporting, isolated, nis, age, low, high, no_gap, nis_clip, out
):  # pragma: no cover - compiled
    """:func:`track_entries` into ``out (n, 8 + 4 S)``, row by row, each entry clipped to
    ``[low, high]`` as :func:`numpy.clip` clips (NaN stays NaN)."""
    for i in range(valid.size):
        ok = valid[i]
        for a in range(3):
            var = p[i, a, a]
            if var < 0.0:  # np.clip(var, 0, None): NaN stays NaN
                var = 0.0
            out[i, a] = x[i, a] if ok else (no_gap if a == 0 else 0.0)
            out[i, 3 + a] = np.sqrt(var) if ok else 0.0
        out[i, 6] = max(v_ego[i], 0.0) if v_ego[i] == v_ego[i] else v_ego[i]
        out[i, 7] = 1.0 if ok else 0.0
        for s in range(reporting.shape[0]):
            v = nis[i, s]
            col = 8 + 4 * s
            out[i, col] = 1.0 if reporting[s, i] else 0.0
            out[i, col + 1] = 1.0 if isolated[i, s] else 0.0
            out[i, col + 2] = min(v, nis_clip) if np.isfinite(v) else 0.0
            out[i, col + 3] = age[s, i]
        for c in range(low.size):
            v = out[i, c]
            if v == v:  # numpy's clip: max(v, lo) then min(., hi), NaN kept
                v = v if v > low[c] else low[c]
                out[i, c] = v if v < high[c] else high[c]
