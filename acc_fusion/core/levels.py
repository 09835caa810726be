"""The warning levels every stage speaks of: their codes, names and display colours.

A level is an ``int8`` code per pair: :data:`NONE` (0), :data:`CAUTION` (1), :data:`IMMINENT`
(2), the two alert stages of the CAMP / NHTSA FCW work.  Truth sources accept levels back (a
warned driver reacts, a warned vehicle is coloured), the warning stage produces them, the
metrics count them; so they live here, below all of them.
"""

from __future__ import annotations

#: Level codes: no alert, cautionary alert, imminent (crash) alert.
NONE, CAUTION, IMMINENT = 0, 1, 2

#: Level names, indexed by code.
LEVEL_NAMES = ("none", "caution", "imminent")

#: RGBA colours by level (none, caution, imminent) for sumo-gui vehicles and rendered replays.
WARNING_COLORS = ((40, 180, 40, 255), (255, 200, 0, 255), (230, 30, 30, 255))
