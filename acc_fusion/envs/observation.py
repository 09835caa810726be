"""What the environments observe: the entries of an observation, their bounds and clips (the
tables are in the docstrings of :class:`~acc_fusion.envs.collision_warning.CollisionWarningEnv`
and :class:`~acc_fusion.envs.world.CollisionWarningWorldEnv`).  Baseline policies read
observations by these names, without the environment."""

from __future__ import annotations

import numpy as np

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
            object at this step.
        isolated, nis: ``(n, S)`` the fault detection isolates the sensor, and its NIS (NaN
            where it did not report).
        age: ``(S, n)`` seconds since each sensor's last measurement of the object.
    """
    std = np.sqrt(np.clip(np.diagonal(p, axis1=1, axis2=2), 0.0, None))
    x = np.where(valid[:, None], x, [NO_TRACK_GAP, 0.0, 0.0])
    std = np.where(valid[:, None], std, 0.0)
    nis = np.where(np.isfinite(nis), np.minimum(nis, NIS_CLIP), 0.0)
    sensors = []
    for i, rep in enumerate(reporting):
        sensors += [rep, isolated[:, i], nis[:, i], age[i]]
    obs = np.column_stack([x, std, np.maximum(v_ego, 0.0), valid, np.column_stack(sensors)])
    return np.clip(obs, _LOW, _HIGH)
