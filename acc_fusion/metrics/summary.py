"""The summary of a run's FCW metrics (:class:`FCWSummary`: counts, exposure, rates with exact
Poisson and Wilson intervals, lead time and TTC distributions, the confusion of levels) and the
rates of event counts (:func:`event_rates`)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from acc_fusion.core.levels import LEVEL_NAMES
from acc_fusion.metrics.stats import Distribution, Rate


@dataclass(frozen=True)
class FCWSummary:
    """Event-level FCW metrics of one or more runs (see :mod:`acc_fusion.metrics.events`).

    Attributes:
        warn_level, tolerance, confidence: the rule the figures follow (level, s) and the
            confidence of the intervals.
        warnings, false_alarms, threats, detected, missed, collisions: event counts.
        hours, km: exposure, over active pair-steps.
        false_alarms_per_hour, false_alarms_per_100km: exact Poisson rates.
        miss_rate: missed / threats; false_alarm_ratio: false_alarms / warnings (Wilson).
        lead_time: lead times [s] of the detected threats.
        ttc_at_warning: true TTC [s] at the onset of matched warnings.
        ttc_at_any_warning: true TTC [s] at the onset of all warnings.
        confusion: active pair-steps by oracle level (rows) and system level (columns).
        per_pair: the per-pair figures of :meth:`FCWMetrics.per_pair` (arrays ``(N,)``), or
            ``None``; left out of :meth:`as_dict`, :meth:`format` and comparisons.
    """

    warn_level: int
    tolerance: float
    confidence: float
    warnings: int
    false_alarms: int
    threats: int
    detected: int
    missed: int
    collisions: int
    hours: float
    km: float
    false_alarms_per_hour: Rate
    false_alarms_per_100km: Rate
    miss_rate: Rate
    false_alarm_ratio: Rate
    lead_time: Distribution
    ttc_at_warning: Distribution
    ttc_at_any_warning: Distribution
    confusion: tuple[tuple[int, int, int], ...]
    per_pair: dict[str, np.ndarray] | None = field(default=None, repr=False, compare=False)

    def as_dict(self) -> dict:
        """Plain nested dicts (without ``per_pair``); NaN and ±inf become ``None``."""

        def clean(x: object) -> object:
            if isinstance(x, dict):
                return {k: clean(v) for k, v in x.items()}
            if isinstance(x, (tuple, list)):
                return [clean(v) for v in x]
            if isinstance(x, float) and not math.isfinite(x):
                return None
            return x

        return clean({k: v for k, v in asdict(self).items() if k != "per_pair"})

    def format(self) -> str:
        """A readable multi-line summary."""
        pct = int(round(100 * self.confidence))
        width = max(len(name) for name in LEVEL_NAMES)
        header = "oracle \\ system".ljust(16) + " ".join(n.rjust(width + 2) for n in LEVEL_NAMES)
        rows = [
            f"  {name:<14}" + " ".join(str(c).rjust(width + 2) for c in counts)
            for name, counts in zip(LEVEL_NAMES, self.confusion, strict=True)
        ]
        return "\n".join(
            [
                f"FCW metrics: warning level >= {self.warn_level} "
                f"({LEVEL_NAMES[self.warn_level]}), "
                f"tolerance {self.tolerance:g} s, {pct} % intervals",
                f"exposure              {self.hours:.4g} h, {self.km:.4g} km",
                f"warnings              {self.warnings} ({self.false_alarms} false alarms)",
                f"threats               {self.threats} ({self.detected} detected, "
                f"{self.missed} missed)",
                f"collisions            {self.collisions}",
                f"false alarms / h      {self.false_alarms_per_hour.format()}",
                f"false alarms / 100 km {self.false_alarms_per_100km.format()}",
                f"miss rate             {self.miss_rate.format()}",
                f"false-alarm ratio     {self.false_alarm_ratio.format()}",
                f"lead time [s]         {self.lead_time.format()}",
                f"TTC at warning [s]    matched: {self.ttc_at_warning.format()}",
                f"                      all:     {self.ttc_at_any_warning.format()}",
                "confusion (active pair-steps):",
                "  " + header,
                *rows,
            ]
        )


def event_rates(count: dict, hours: float, km: float, confidence: float = 0.95) -> dict[str, Rate]:
    """False alarms per hour and per 100 km (exact Poisson), miss rate and false-alarm ratio
    (Wilson), from event counts (keys as :meth:`FCWMetrics.per_pair`) and exposure [h, km]."""
    false_alarms = count["false_alarms"]
    return {
        "false_alarms_per_hour": Rate.poisson(false_alarms, hours, confidence),
        "false_alarms_per_100km": Rate.poisson(false_alarms, km / 100.0, confidence),
        "miss_rate": Rate.proportion(count["missed"], count["threats"], confidence),
        "false_alarm_ratio": Rate.proportion(false_alarms, count["warnings"], confidence),
    }
