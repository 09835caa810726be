"""The summary of a run's FCW metrics (:class:`FCWSummary`: counts, exposure, rates with exact
Poisson and Wilson intervals, lead time and TTC distributions, the confusion of levels), the
rates of event counts (:func:`event_rates`) and the summary of several runs pooled
(:func:`pool_summaries`)."""

from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.core.levels import LEVEL_NAMES
from acc_fusion.metrics.stats import Distribution, Histogram, Rate

#: The classes of a warning, judged from truth (:mod:`acc_fusion.metrics.events`).
ALERT_CLASSES = ("crash_relevant", "nuisance", "sensing_false")

#: The event counts of :meth:`~acc_fusion.metrics.events.FCWMetrics.per_pair`, of an
#: :class:`FCWSummary` (and of a sweep's rows), in order.
COUNTS = (
    "warnings", "false_alarms", "threats", "detected", "missed", "collisions", *ALERT_CLASSES,
    "relevant", "relevant_detected", "relevant_missed", "threats_relevant",
)  # fmt: skip

#: What a warning was given on, judged from truth at its onset (the 2-D world's
#: :mod:`acc_fusion.sim.world`): the true in-path lead; a stationary object (parked car,
#: gantry, bridge, guardrail, sign); a vehicle in another lane; a vehicle changing lanes
#: (cut-in or cut-out); a ghost or clutter return (no object); any target while a fault of a
#: sensor the method uses was active.  ``noise`` is given by the class, not at the onset: a
#: *sensing-false* warning on the true lead (the target was right, its estimate was wrong
#: enough to fire the rule, which on the true lead would not have fired) counts as ``noise``,
#: never as ``lead``; a nuisance or crash-relevant one on the true lead stays ``lead``.
CAUSES = ("lead", "noise", "stationary", "adjacent", "cut_in_out", "ghost", "fault")

#: The classes of a warning that truth did not call for, which the causes break down.
FALSE_CLASSES = ("nuisance", "sensing_false")

#: The (class, cause) pairs that can occur among :data:`FALSE_CLASSES` (a nuisance warning
#: is never ``noise``, a sensing-false one never ``lead``).
CAUSE_CELLS = tuple(
    (c, k)
    for c in FALSE_CLASSES
    for k in CAUSES
    if (c, k) not in (("nuisance", "noise"), ("sensing_false", "lead"))
)
#: Per-run counts of :data:`CAUSE_CELLS`, named ``<class>_<cause>``, as
#: :meth:`acc_fusion.metrics.events.FCWMetrics.per_pair` and a sweep's rows give them.
CAUSE_COUNTS = tuple(f"{c}_{k}" for c, k in CAUSE_CELLS)


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
        crash_relevant, nuisance, sensing_false: warnings by class (judged from truth).
        relevant, relevant_detected, relevant_missed: crash-relevant situations in truth, of
            them matched by a warning and missed; threats_relevant: oracle threats that met one.
        alerts_per_hour, alerts_per_100km: each alert class's exact Poisson rate (keys
            :data:`ALERT_CLASSES`).
        relevant_miss_rate: relevant_missed / relevant (Wilson).
        lead_time: lead times [s] of the detected threats.
        relevant_lead_time: lead times [s] of the detected crash-relevant situations.
        ttc_at_warning: true TTC [s] at the onset of matched warnings.
        ttc_at_any_warning: true TTC [s] at the onset of all warnings.
        confusion: active pair-steps by oracle level (rows) and system level (columns).
        by_cause: warnings by class and cause, ``{class: {cause: count}}`` (keys
            :data:`ALERT_CLASSES` and :data:`CAUSES`), or ``None`` when the caller gave no
            causes (the 1-D pipeline).
        per_pair: the per-pair figures of :meth:`FCWMetrics.per_pair` (arrays ``(N,)``), or
            ``None``; left out of :meth:`as_dict`, :meth:`format` and comparisons.
        histograms: the streamed samples behind the four distributions (keys
            :data:`DISTRIBUTIONS`), so that :func:`pool_summaries` pools them exactly, or
            ``None``; left out like ``per_pair``.
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
    crash_relevant: int
    nuisance: int
    sensing_false: int
    relevant: int
    relevant_detected: int
    relevant_missed: int
    threats_relevant: int
    hours: float
    km: float
    false_alarms_per_hour: Rate
    false_alarms_per_100km: Rate
    miss_rate: Rate
    false_alarm_ratio: Rate
    alerts_per_hour: dict[str, Rate]
    alerts_per_100km: dict[str, Rate]
    relevant_miss_rate: Rate
    lead_time: Distribution
    relevant_lead_time: Distribution
    ttc_at_warning: Distribution
    ttc_at_any_warning: Distribution
    confusion: tuple[tuple[int, int, int], ...]
    by_cause: dict[str, dict[str, int]] | None = None
    per_pair: dict[str, np.ndarray] | None = field(default=None, repr=False, compare=False)
    histograms: dict[str, Histogram] | None = field(default=None, repr=False, compare=False)

    def as_dict(self) -> dict:
        """Plain nested dicts (without ``per_pair``); NaN and ±inf become ``None``; the alert
        classes' rates are flat: ``{"nuisance": x, "nuisance_lo": lo, "nuisance_hi": hi, ...}``."""

        def clean(x: object) -> object:
            if isinstance(x, dict):
                return {k: clean(v) for k, v in x.items()}
            if isinstance(x, (tuple, list)):
                return [clean(v) for v in x]
            if isinstance(x, float) and not math.isfinite(x):
                return None
            return x

        out = asdict(replace(self, per_pair=None, histograms=None))
        del out["per_pair"], out["histograms"]
        if out["by_cause"] is None:
            del out["by_cause"]
        for key in ("alerts_per_hour", "alerts_per_100km"):  # {class: x, class_lo:, class_hi:}
            out[key] = {
                f"{c}{end}": rate[part]
                for c, rate in out[key].items()
                for end, part in (("", "value"), ("_lo", "lo"), ("_hi", "hi"))
            }
        return clean(out)

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
                f"alerts by class       {self.crash_relevant} crash-relevant, "
                f"{self.nuisance} nuisance, {self.sensing_false} sensing-false",
                *(
                    f"  {name.replace('_', '-'):<19} {rate.format()} / 100 km"
                    for name, rate in self.alerts_per_100km.items()
                ),
                f"crash-relevant        {self.relevant} situations ({self.relevant_detected} "
                f"warned, {self.relevant_missed} missed); {self.threats_relevant} of "
                f"{self.threats} threats",
                f"  missed share        {self.relevant_miss_rate.format()}",
                f"  lead time [s]       {self.relevant_lead_time.format()}",
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


def event_rates(count: dict, hours: float, km: float, confidence: float = 0.95) -> dict:
    """False alarms and each alert class per hour and per 100 km (exact Poisson), miss rates
    and false-alarm ratio (Wilson), from event counts (keys as :meth:`FCWMetrics.per_pair`)
    and exposure [h, km]."""
    false_alarms = count["false_alarms"]
    return {
        "false_alarms_per_hour": Rate.poisson(false_alarms, hours, confidence),
        "false_alarms_per_100km": Rate.poisson(false_alarms, km / 100.0, confidence),
        "miss_rate": Rate.proportion(count["missed"], count["threats"], confidence),
        "false_alarm_ratio": Rate.proportion(false_alarms, count["warnings"], confidence),
        "alerts_per_hour": {c: Rate.poisson(count[c], hours, confidence) for c in ALERT_CLASSES},
        "alerts_per_100km": {
            c: Rate.poisson(count[c], km / 100.0, confidence) for c in ALERT_CLASSES
        },
        "relevant_miss_rate": Rate.proportion(
            count["relevant_missed"], count["relevant"], confidence
        ),
    }


#: The distributions of an :class:`FCWSummary`, each from the histogram of the same name.
DISTRIBUTIONS = ("lead_time", "relevant_lead_time", "ttc_at_warning", "ttc_at_any_warning")


def pool_summaries(summaries: list[FCWSummary]) -> FCWSummary:
    """The summary of several runs of one method pooled, as if they were one run: counts,
    exposure and the confusion of levels added, the rates and their intervals computed on the
    totals (:func:`event_rates`), the distributions from the histograms merged (exact to a
    bin, as for one run), the per-pair figures concatenated.

    Raises :class:`~acc_fusion.core.errors.InputError` for no summary, summaries of different
    rules or confidence, or a summary without its histograms.
    """
    if not summaries:
        raise InputError("pool_summaries needs at least one summary")
    first = summaries[0]
    rule = (first.warn_level, first.tolerance, first.confidence)
    if any((s.warn_level, s.tolerance, s.confidence) != rule for s in summaries):
        raise InputError("pool_summaries needs summaries of one warning rule and confidence")
    if any(s.histograms is None for s in summaries):
        raise InputError("pool_summaries needs summaries that carry their histograms")
    count = {k: sum(getattr(s, k) for s in summaries) for k in COUNTS}
    hours, km = sum(s.hours for s in summaries), sum(s.km for s in summaries)
    histograms = {}
    for name in DISTRIBUTIONS:
        merged = copy.deepcopy(first.histograms[name])
        for s in summaries[1:]:
            merged.merge(s.histograms[name])
        histograms[name] = merged
    confusion = np.sum([np.array(s.confusion) for s in summaries], axis=0)
    by_cause = None
    if all(s.by_cause is not None for s in summaries):
        by_cause = {
            c: {k: sum(s.by_cause[c][k] for s in summaries) for k in CAUSES} for c in ALERT_CLASSES
        }
    per_pair = None
    if all(s.per_pair is not None for s in summaries):
        per_pair = {k: np.concatenate([s.per_pair[k] for s in summaries]) for k in first.per_pair}
    return FCWSummary(
        warn_level=first.warn_level,
        tolerance=first.tolerance,
        confidence=first.confidence,
        **count,
        hours=hours,
        km=km,
        **event_rates(count, hours, km, first.confidence),
        **{name: h.distribution() for name, h in histograms.items()},
        confusion=tuple(tuple(int(c) for c in row) for row in confusion),
        by_cause=by_cause,
        per_pair=per_pair,
        histograms=histograms,
    )
