"""Method comparison and protocol conformance on the closed FCW loop.

:func:`compare` runs radar, infrared, centralized and federated warnings over one scripted suite;
:func:`conformance` runs the standard FCW test manoeuvres against the protocols' requirements;
:func:`on_off_table` tabulates a run per method with FCW off and on.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from acc_fusion.core.levels import IMMINENT
from acc_fusion.core.table import Table
from acc_fusion.metrics.benefit import MIN_CRASHES, Benefit, paired_benefit
from acc_fusion.metrics.protocols import REQUIREMENTS
from acc_fusion.metrics.summary import ALERT_CLASSES, FCWSummary
from acc_fusion.sim.closed_loop import SimConfig, SimResult, simulate
from acc_fusion.sim.hooks import FirstWarning

#: Radar clutter of the comparison runs: ghosts of stationary roadside objects, the classic
#: cause of FCW false alarms (0.05 per second per vehicle: one every 20 s of driving).
COMPARE_CLUTTER = {"ghost_rate": 0.05}

#: Columns of :func:`summary_row`.
SUMMARY_COLUMNS = (
    "method",
    "warnings",
    "false_alarms",
    "fa_per_hour",
    "fa_per_100km",
    "missed",
    "miss_rate",
    "lead_time_median_s",
)


def summary_row(method: str, s: FCWSummary) -> dict:
    """One method's metrics as a table row (rates with their 95 % intervals)."""
    return {
        "method": method,
        "warnings": s.warnings,
        "false_alarms": s.false_alarms,
        "fa_per_hour": s.false_alarms_per_hour.format(),
        "fa_per_100km": s.false_alarms_per_100km.format(),
        "missed": f"{s.missed}/{s.threats}",
        "miss_rate": s.miss_rate.format(),
        "lead_time_median_s": s.lead_time.median,
    }


#: Columns of :func:`class_row`.
CLASS_COLUMNS = (
    "method",
    "crash_relevant_per_100km",
    "nuisance_per_100km",
    "sensing_false_per_100km",
    "relevant_missed",
    "relevant_miss_rate",
    "relevant_lead_time_median_s",
)


def class_row(method: str, s: FCWSummary) -> dict:
    """One method's alerts by class (judged from truth, :mod:`acc_fusion.metrics.alert_classes`)
    per 100 km, and the crash-relevant situations it missed, with 95 % intervals."""
    rates = s.alerts_per_100km
    return {
        "method": method,
        **{f"{c}_per_100km": rates[c].format() for c in ALERT_CLASSES},
        "relevant_missed": f"{s.relevant_missed}/{s.relevant}",
        "relevant_miss_rate": s.relevant_miss_rate.format(),
        "relevant_lead_time_median_s": s.relevant_lead_time.median,
    }


def class_table(title: str, summaries: dict[str, FCWSummary]) -> Table:
    """The alert classes of every method (:func:`class_row`), with what the oracle (the same
    rule on truth) fired on."""
    t = Table(title, CLASS_COLUMNS)
    t.rows += [class_row(m, s) for m, s in summaries.items()]
    first = next(iter(summaries.values()), None)
    if first is not None:
        t.notes.append(
            f"truth: {first.relevant} crash-relevant situations; the rule on truth (oracle) "
            f"fired {first.threats} times, {first.threats_relevant} of them crash-relevant"
        )
    return t


#: The columns of :func:`benefit_table`.
BENEFIT_COLUMNS = (
    "drive", "pairs", "crashes_fcw_off", "crashes_fcw_on", "reduction",
    "per_million_km_off", "per_million_km_on", "avoided", "mitigated", "introduced",
    "impact_speed_off_mps", "impact_speed_on_mps",
)  # fmt: skip


def reduction_text(b: Benefit) -> str:
    """The reduction of ``b`` with its interval, in words where the crashes are too few for
    one: none with FCW off, or fewer than :data:`~acc_fusion.metrics.benefit.MIN_CRASHES`."""
    if b.crashes_off == 0:
        return "no crash with FCW off"
    if b.crashes_off < MIN_CRASHES:
        return f"{b.reduction:.3g} (too few crashes for an interval: {b.crashes_off})"
    return f"{b.reduction:.3g} [{b.reduction_lo:.3g}, {b.reduction_hi:.3g}]"


def benefit_table(
    title: str, benefits: dict[str, Benefit], unit: str = "vehicles", note: str | None = None
) -> Table:
    """The crashes FCW avoided with each method driving the alert, paired by ``unit``
    (vehicles or runs driven with FCW off and on, :mod:`acc_fusion.metrics.benefit`);
    ``note`` replaces the note that says so (e.g. for the replay of
    :mod:`acc_fusion.metrics.counterfactual`)."""
    t = Table(title, BENEFIT_COLUMNS)
    for drive, b in benefits.items():
        t.rows.append(
            {
                "drive": drive,
                "pairs": b.vehicles,
                "crashes_fcw_off": b.crashes_off,
                "crashes_fcw_on": b.crashes_on,
                "reduction": reduction_text(b),
                "per_million_km_off": b.per_million_km_off,
                "per_million_km_on": b.per_million_km_on,
                "avoided": b.avoided,
                "mitigated": b.mitigated,
                "introduced": b.introduced,
                "impact_speed_off_mps": b.impact_speed_off,
                "impact_speed_on_mps": b.impact_speed_on,
            }
        )
    first = next(iter(benefits.values()), None)
    if note is not None:
        t.notes.append(note)
    elif first is not None:
        t.notes.append(
            f"pairs: {unit} driven with FCW off and on; reduction = 1 - crashes on / crashes "
            f"off, {first.confidence:.0%} bootstrap interval over the {unit}; impact speed: "
            "median closing speed at contact"
        )
    return t


def on_off_table(
    title: str,
    off: dict[str, FCWSummary],
    on: dict[str, FCWSummary],
    *,
    subject: str = "equipped",
    same: str = "same seed",
):
    """The per-method table of a traffic study run with FCW off and on.

    ``off``: every method's metrics of the open-loop run (no driver hears an alert); ``on``:
    the closed-loop run, whose single method's alerts make the drivers brake, on the same
    traffic (``same`` says how it is the same).  One row per method of ``off`` (its
    :func:`summary_row` and its collisions with FCW off), then notes: the exposure and the
    collisions of the ``subject`` vehicles with FCW off and on.
    """

    t = Table(title, (*SUMMARY_COLUMNS, "collisions_fcw_off"))
    for m, s in off.items():
        t.rows.append({**summary_row(m, s), "collisions_fcw_off": s.collisions})
    drive, on_summary = next(iter(on.items()), (None, None))
    first = next(iter(off.values()), None)
    if first is not None:
        t.notes.append(f"exposure: {first.hours:.2f} h, {first.km:.1f} km of {subject} driving")
    if on_summary is not None:
        t.notes.append(
            f"{subject}-vehicle collisions: {first.collisions if first else '-'} with FCW off, "
            f"{on_summary.collisions} with {drive} FCW on ({same})"
        )
    return t


def compare_config(**overrides) -> SimConfig:
    """The comparison's defaults: the randomised suite, radar clutter, open loop."""
    overrides.setdefault("radar", COMPARE_CLUTTER)
    return SimConfig(**{"scenario": "random", **overrides})


def exposure_km(summaries: dict[str, FCWSummary]) -> float:
    """The km driven in a run, from its methods' summaries (all watch the same pairs; 0
    without a summary)."""
    return next(iter(summaries.values())).km if summaries else 0.0


def run_benefit(off: SimResult, on: SimResult) -> Benefit:
    """The crashes of ``off`` (warnings off) that ``on`` (the same runs, warnings on)
    avoided, paired by run (:func:`acc_fusion.metrics.benefit.paired_benefit`)."""

    def crashes(res: SimResult) -> dict[int, float]:
        return {int(i): float(res.collision_speed[i]) for i in np.flatnonzero(res.collided)}

    km_off, km_on = exposure_km(off.summaries), exposure_km(on.summaries)
    return paired_benefit(range(off.collided.size), crashes(off), crashes(on), km_off, km_on)


@dataclass
class Comparison:
    """Open-loop metrics of every method plus collisions with warnings on and off."""

    result: SimResult
    collisions: dict[str, int]
    benefits: dict[str, Benefit]
    """Per method driving the alert: the crashes it avoided, paired by run."""

    def table(self):
        """The false-alarm / miss / lead-time table with 95 % intervals."""

        cfg = self.result.config
        level = "imminent" if cfg.warn_level == IMMINENT else "caution"
        t = Table(
            f"FCW comparison: {cfg.runs} runs of '{cfg.scenario}', seed {cfg.seed}, "
            f"{level} alerts, tolerance {cfg.tolerance:g} s, 95% intervals",
            (*SUMMARY_COLUMNS, "ttc_at_warning_median_s"),
        )
        for m, s in self.result.summaries.items():
            t.rows.append({**summary_row(m, s), "ttc_at_warning_median_s": s.ttc_at_warning.median})
        first = next(iter(self.result.summaries.values()))
        c = self.collisions
        t.notes += [
            f"exposure: {first.hours:.2f} h, {first.km:.1f} km of driving",
            f"closed loop ({c['drive']} alerts a driver who brakes after his reaction time): "
            f"{c['on']} collisions in {c['runs']} runs with warnings, {c['off']} without",
        ]
        return t

    def classes(self) -> Table:
        """Per method: alerts per 100 km by class, missed crash-relevant situations."""
        cfg = self.result.config
        return class_table(
            f"Alert classes (judged from truth), {cfg.runs} runs of '{cfg.scenario}'",
            self.result.summaries,
        )

    def benefit_table(self) -> Table:
        """:attr:`benefits` as a table."""
        cfg = self.result.config
        title = f"Crashes FCW avoids, {cfg.runs} runs of '{cfg.scenario}', same seeds"
        t = benefit_table(title, self.benefits, unit="runs")
        driver = self.result.config.driver
        if driver.sees_threats:
            t.notes.append(
                "FCW off: the driver brakes by himself for a crash-relevant situation when "
                f"his eyes are on the road ({driver.distraction.rate:g} eyes-off episodes/h)"
            )
        else:
            t.notes.append("FCW off: the scripted ego's driver never brakes by himself")
        return t


def compare(
    config: SimConfig, *, progress: bool = False, drives: tuple[str, ...] = ()
) -> Comparison:
    """Every method on the same runs (open loop), then collisions with the last method's
    warnings on and off on the same seeds (closed loop); ``drives`` adds a closed loop with
    warnings on per further method, for :attr:`Comparison.benefits`."""
    result = simulate(replace(config, drive=None), progress=progress)
    drive = config.drive or config.methods[-1]

    def closed(method: str) -> SimConfig:
        return replace(config, drive=method, methods=(method,))

    off = simulate(closed(drive), progress=progress, warnings_on=False)
    ons = {m: simulate(closed(m), progress=progress) for m in dict.fromkeys((drive, *drives))}
    on = ons[drive]
    collisions = {"drive": drive, "on": int(on.collided.sum()), "off": int(off.collided.sum())}
    benefits = {m: run_benefit(off, run) for m, run in ons.items()}
    return Comparison(result, {**collisions, "runs": config.runs}, benefits)


@dataclass
class ConformanceResult:
    """TTC at the first warning of every trial of every standard manoeuvre."""

    requirement: object
    ttc: np.ndarray
    passed: np.ndarray
    needed: int

    @property
    def ok(self) -> bool:
        return int(self.passed.sum()) >= self.needed


def conformance(
    trials: int = 7, seed: int = 0, base: SimConfig | None = None, *, progress: bool = False
) -> list[ConformanceResult]:
    """Run every standard manoeuvre of :mod:`acc_fusion.metrics.protocols` with noisy sensors.

    Each manoeuvre runs ``trials`` trials (open loop: the subject vehicle keeps its test
    speed, as in the protocols) with the federated method (or ``base.methods[-1]``); a trial
    passes when its first alert comes at a TTC of at least the requirement, and the
    manoeuvre passes when at least ``min_passes / n_trials`` of its trials pass (5 of 7).
    """

    base = base or SimConfig()
    method = base.methods[-1]
    out = []
    for name, req in REQUIREMENTS.items():
        cfg = replace(base, scenario=name, runs=trials, seed=seed, methods=(method,), drive=None)
        first = FirstWarning(trials, method, cfg.warn_level)
        simulate(cfg, progress=progress, on_step=first)
        passed = req.trial_passes(first.ttc)
        needed = int(np.ceil(req.min_passes * trials / req.n_trials - 1e-9))
        out.append(ConformanceResult(req, first.ttc, passed, needed))
    return out
