"""Physical constants and unit conversions (SI everywhere), and the time tolerance of event
comparisons."""

from __future__ import annotations

#: Standard gravity [m/s²].
G = 9.80665


#: One mile per hour and one kilometre per hour in m/s.
MPH = 0.44704


KMH = 1.0 / 3.6


#: Tolerance [s] when comparing the simulation time with event times.
TIME_TOL = 1e-9
