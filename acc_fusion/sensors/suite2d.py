"""The 2-D sensor suite of an equipped vehicle — a :class:`Radar2D` and an :class:`Infrared2D`
— from a typed config mapping, seeded together."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.sensors.faults import Fault
from acc_fusion.sensors.infrared2d import Infrared2D, Infrared2DSpec
from acc_fusion.sensors.radar2d import Radar2D, Radar2DSpec
from acc_fusion.sensors.scan import streams


@dataclass(frozen=True)
class Sensors2DConfig:
    """The specs of the 2-D suite; a mapping ``{"radar": {...}, "infrared": {...}}`` overrides
    any field of :class:`Radar2DSpec` / :class:`Infrared2DSpec`, the rest keep their defaults.

    Attributes:
        radar: the radar's spec.
        infrared: the thermal camera's spec.
        radar_faults, infrared_faults: faults injected into each sensor (the kinds of
            :mod:`acc_fusion.sensors.faults`, acting on whole frames of detections:
            :mod:`acc_fusion.sensors.scan`).
    """

    radar: Radar2DSpec = field(default_factory=Radar2DSpec)
    infrared: Infrared2DSpec = field(default_factory=Infrared2DSpec)
    radar_faults: tuple[Fault, ...] = ()
    infrared_faults: tuple[Fault, ...] = ()


def sensors_2d(
    config: Mapping[str, Any] | Sensors2DConfig | None,
    seed: int | np.random.SeedSequence | np.random.Generator | None,
) -> list[Radar2D | Infrared2D]:
    """A radar and a thermal camera with independent random streams spawned from ``seed``
    (the same seed gives the same detections); unknown keys or bad values in ``config`` are
    one-sentence :class:`~acc_fusion.core.errors.ConfigError`.

    >>> radar, camera = sensors_2d({"radar": {"clutter_rate": 0.0}}, seed=7)
    >>> radar.spec.clutter_rate, camera.spec.name
    (0.0, 'infrared')
    """
    if config is not None and not isinstance(config, (Mapping, Sensors2DConfig)):
        raise ConfigError(f"the 2-D sensor config must be a mapping, got {config!r}")
    if not isinstance(config, Sensors2DConfig):
        config = from_mapping(Sensors2DConfig, config)
    radar_rng, camera_rng = streams(seed, 2)
    return [
        Radar2D(config.radar, radar_rng, config.radar_faults),
        Infrared2D(config.infrared, camera_rng, config.infrared_faults),
    ]
