"""What the environment observes: the entries of an observation, their bounds and clips (the
table is in :class:`~acc_fusion.envs.collision_warning.CollisionWarningEnv`'s docstring).
Baseline policies read observations by these names, without the environment."""

from __future__ import annotations

import numpy as np

from acc_fusion.sensors.suite import SENSOR_NAMES

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
