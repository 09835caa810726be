"""Weather and light, the environment the sensors work in (a config axis and a sweep axis).

The truth sources only carry the conditions; how each sensor degrades under them is in
:mod:`acc_fusion.sensors` with its sources.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from acc_fusion.core.validation import check_choice, check_range

#: The light conditions: daylight, or night (headlamps only).
LIGHTS = ("day", "night")
#: The densest fog accepted: a meteorological optical range of 10 m [m], about the least
#: measured in fog; below it the fog models' liquid water content leaves any physical range.
MIN_FOG_VISIBILITY = 10.0
#: The heaviest rain accepted [mm/h], above the heaviest hour ever recorded (about 305 mm in
#: Holt, Missouri, 1947: WMO, *Global Weather & Climate Extremes*).
MAX_RAIN_RATE = 500.0


@dataclass(frozen=True)
class Conditions:
    """Weather and light for a run.

    Attributes:
        light: ``"day"`` or ``"night"``.
        fog_visibility: meteorological optical range in fog [m], at least
            :data:`MIN_FOG_VISIBILITY`; ``inf`` is clear
            air (fog is visibility below 1 000 m: WMO, *International Meteorological
            Vocabulary*, WMO-No. 182, 1992).
        rain_rate: rain intensity [mm/h], in [0, :data:`MAX_RAIN_RATE`] (0: dry).
    """

    light: str = "day"
    fog_visibility: float = math.inf
    rain_rate: float = 0.0

    def __post_init__(self) -> None:
        check_choice("conditions.light", self.light, LIGHTS)
        vis = check_range("conditions.fog_visibility", self.fog_visibility, MIN_FOG_VISIBILITY)
        rain = check_range("conditions.rain_rate", self.rain_rate, 0.0, MAX_RAIN_RATE)
        object.__setattr__(self, "fog_visibility", vis)
        object.__setattr__(self, "rain_rate", rain)

    @property
    def label(self) -> str:
        """A short name for tables: ``day``, ``night, fog 80 m, rain 10 mm/h`` ..."""
        parts = [self.light]
        if math.isfinite(self.fog_visibility):
            parts.append(f"fog {self.fog_visibility:g} m")
        if self.rain_rate > 0:
            parts.append(f"rain {self.rain_rate:g} mm/h")
        return ", ".join(parts)
