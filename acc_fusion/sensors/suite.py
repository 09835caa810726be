"""The sensor suite of an equipped vehicle: one radar and one infrared sensor, seeded together."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from acc_fusion.sensors.faults import Fault
from acc_fusion.sensors.sensor import InfraredSensor, RadarSensor
from acc_fusion.sensors.spec import SensorSpec, infrared_spec, radar_spec

SENSOR_NAMES = ("radar", "infrared")


def make_sensors(
    seed: int,
    radar: SensorSpec | None = None,
    infrared: SensorSpec | None = None,
    radar_faults: Sequence[Fault] = (),
    infrared_faults: Sequence[Fault] = (),
) -> list:
    """A radar and an infrared sensor with independent random streams derived from ``seed``."""
    ss = np.random.SeedSequence(seed).spawn(2)
    return [
        RadarSensor(radar or radar_spec(), radar_faults, seed=np.random.default_rng(ss[0])),
        InfraredSensor(
            infrared or infrared_spec(), infrared_faults, seed=np.random.default_rng(ss[1])
        ),
    ]
