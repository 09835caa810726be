r"""Tuning a warning rule: the standard tests' margin against the nuisance it causes in traffic.

For every point of a grid of warning settings (dotted paths into
:class:`~acc_fusion.sim.closed_loop.SimConfig`, e.g. ``warning.model`` or
``warning.params.reaction_imminent``), :func:`tune` measures

* the **conformance margin**: per NHTSA FCW confirmation test (LVS, LVD, LVM), the TTC at the
  first alert of the trial that decides the 5-of-7 rule (the 5th best of 7) minus the
  required TTC, with noisy sensors (:func:`acc_fusion.studies.compare.conformance`), and the
  smallest of the three: >= 0 passes all three;
* the **rule's own alert classes in traffic**: the rule run on the true trajectories of a
  recorded SUMO run (:func:`record_sumo`), so with perfect sensing every alert is
  crash-relevant or nuisance (:mod:`acc_fusion.metrics.alert_classes`), per 100 km with exact
  Poisson intervals, and the crash-relevant situations it missed.

The recording is made once (SUMO with nobody warned: the truth does not depend on the rule;
with distracted drivers it is the FCW-off closed loop of ``acc-fusion sumo``, the traffic
whose alert classes that command prints) and every point replays it, so a point costs a
fraction of a second of traffic plus the conformance runs.  A point is on the *Pareto
front* when no other point has a margin at least as large and a nuisance rate at most as
large, one of them strictly.  The issue this answers: a default that passes the tests with
at most 1 nuisance alert per 100 km.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np
from tqdm.auto import tqdm

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.schema import set_path
from acc_fusion.core.table import Table
from acc_fusion.metrics.alert_classes import crash_relevant
from acc_fusion.metrics.events import FCWMetrics
from acc_fusion.metrics.summary import FCWSummary
from acc_fusion.sensors.driver_monitor import DriverMonitor
from acc_fusion.sim.closed_loop import SimConfig, StepView, simulate
from acc_fusion.studies.compare import conformance
from acc_fusion.truth.sumo.config import SumoConfig
from acc_fusion.truth.sumo.source import SumoSource
from acc_fusion.warning.logic import WarningLogic
from acc_fusion.warning.ttc import time_to_collision

#: The tests whose margin is tuned: NHTSA's FCW confirmation tests.
NHTSA_TESTS = ("nhtsa_lvs", "nhtsa_lvd", "nhtsa_lvm")


@dataclass
class Recording:
    """The true state of every equipped vehicle at every step of a traffic run: per step the
    time and the ``(k,)`` arrays of the first k slots (which hold every vehicle);
    ``distraction``: the drivers' eyes-off-road episodes per hour (0: SUMO's drivers)."""

    name: str
    dt: float
    n_pairs: int
    steps: list[tuple]
    distraction: float = 0.0

    @property
    def pair_steps(self) -> int:
        return sum(int(s[6].sum()) for s in self.steps)


class _Recorder:
    """An ``on_step`` hook of :func:`simulate` that keeps every step's truth (a
    :class:`Recording`'s step), with the drivers' eyes-off-road state as a driver monitor
    reads it at the step's start (the state the drivers' previous step left)."""

    def __init__(self, source) -> None:
        self.source, self.steps = source, []
        self._eyes = np.zeros(0, dtype=bool)

    def __call__(self, view: StepView) -> None:
        f, src, k = view.frame, self.source, view.frame.n_pairs
        eyes = np.zeros(k, dtype=bool)
        m = min(k, self._eyes.size)
        eyes[:m] = self._eyes[:m]
        self._eyes = view.driver.eyes_off
        self.steps.append(_truth(f, src.active, src.reassigned, k, eyes))


def _truth(f, active, new, k: int, eyes: np.ndarray | None = None) -> tuple:
    """One step of a :class:`Recording`: the time and the first ``k`` slots' truth (with the
    egos' accelerations, and the drivers' eyes-off-road state ``eyes (k,)``, ``None`` for
    drivers without episodes)."""
    return (
        f.t, f.gap[:k].copy(), f.ego_speed[:k].copy(), f.lead_speed[:k].copy(),
        f.lead_accel[:k].copy(), f.has_leader[:k].copy(), active[:k].copy(), new[:k].copy(),
        eyes, f.ego_accel[:k].copy(),
    )  # fmt: skip


def record_sumo(
    config: SumoConfig, sim: SimConfig | None = None, *, progress: bool = False
) -> Recording:
    """Run ``config`` with nobody warned and keep the truth of every step.

    With a ``sim`` whose drivers are distracted the drivers act, deaf to the warnings, as in
    the FCW-off run of :func:`~acc_fusion.studies.traffic.sumo_study` (one method watches);
    otherwise SUMO's own drivers drive."""
    if sim is not None and sim.driver.distraction.rate > 0:
        method = sim.drive or sim.methods[-1]
        with SumoSource(config) as src:
            hook = _Recorder(src)
            run = replace(sim, dt=src.dt, drive=method, methods=(method,))
            simulate(run, source=src, progress=progress, on_step=hook, warnings_on=False)
            rate = sim.driver.distraction.rate
            return Recording(f"{config.sumocfg}", src.dt, src.n_pairs, hook.steps, rate)
    steps = []
    with SumoSource(config) as src:
        for _ in tqdm(
            range(src.n_steps), disable=None if progress else True, desc="SUMO", leave=False
        ):
            f, active, new = src.frame(), src.active, src.reassigned
            k = int(np.flatnonzero(active)[-1]) + 1 if active.any() else 1
            steps.append(_truth(f, active, new, k))
            src.advance(None)
            if src.done:
                break
        name = f"{config.sumocfg}"
        return Recording(name, src.dt, src.n_pairs, steps)


def rule_on_truth(recording: Recording, config: SimConfig) -> FCWSummary:
    """The warning rule of ``config`` on the recorded truth (perfect sensing): its alerts are
    the oracle's, classed against the crash-relevant situations of ``config.alert_classes``;
    with the rule's adaptive timing (:class:`~acc_fusion.warning.logic.AdaptiveConfig`:
    the drivers' braking, and with distracted drivers a driver monitor) as :func:`simulate`
    runs it."""
    n, dt = recording.n_pairs, recording.dt
    logic = WarningLogic(config.warning, n, dt)
    adaptive = config.warning.adaptive
    monitor = None
    if adaptive.enabled and recording.distraction > 0:
        monitor = DriverMonitor(n, adaptive.latency, adaptive.recovery)
    looked = np.zeros(n, dtype=bool)
    metrics = FCWMetrics(n, dt, config.tolerance, config.warn_level)
    buf = np.zeros((5, n))
    flags = np.zeros((3, n), dtype=bool)
    t = 0.0
    for t, gap, v, vl, al, has, active, new, eyes, ae in recording.steps:
        k = gap.size
        g, ve, vle, ale, aeg = buf
        h, act, fresh = flags
        g[:k], ve[:k], vle[:k], ale[:k], aeg[:k] = gap, v, vl, al, ae
        h[:k], act[:k], fresh[:k] = has, active, new
        g[k:] = ve[k:] = vle[k:] = ale[k:] = aeg[k:] = 0.0
        h[k:] = act[k:] = fresh[k:] = False
        if fresh.any():
            logic.reset(fresh)
            metrics.reset(fresh)
        seen = None
        if monitor is not None:
            looked[:k], looked[k:] = eyes, False
            seen = monitor.watch(t, looked, fresh)
        attentive = adaptive.attentive(seen, aeg)
        use = h & act
        rate = np.where(use, vle - ve, 0.0)
        a_lead = np.where(use, ale, 0.0)
        level = logic.step(np.where(use, g, 0.0), ve, rate, a_lead, valid=use, attentive=attentive)
        ttc = time_to_collision(np.where(use, g, 1.0), rate)
        relevant = act & crash_relevant(config.alert_classes, h, g, ve, vle, ale)
        metrics.update(t, level, level, ttc, ve, act.copy(), None, relevant)
    metrics.finish(t + dt)
    return metrics.summary()


def conformance_margin(config: SimConfig, trials: int = 7) -> tuple[float, bool]:
    """The smallest margin [s] over the NHTSA tests (the deciding trial's TTC at the first
    alert minus the requirement; ``-inf`` when too few trials warn) and whether every
    manoeuvre of :data:`acc_fusion.metrics.protocols.REQUIREMENTS` passes."""
    results = conformance(trials, config.seed, config)
    margins = []
    for res in results:
        if res.requirement.scenario in NHTSA_TESTS:
            ttc = np.sort(np.nan_to_num(res.ttc, nan=-np.inf))[::-1]
            margins.append(float(ttc[res.needed - 1]) - res.requirement.required_ttc)
    return min(margins), all(r.ok for r in results)


def grid_points(axes: dict[str, list]) -> list[dict]:
    """The Cartesian product of ``axes`` (dotted SimConfig paths -> values), one dict each."""
    for key, values in axes.items():  # the keys are checked when each point's config is built
        if not isinstance(values, list) or not values:
            raise ConfigError(f"--grid {key} needs a non-empty list of values, got {values!r}")
    keys = list(axes)
    return [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*axes.values())]


@dataclass
class TunePoint:
    """One grid point's settings and figures."""

    settings: dict
    margin_s: float
    nhtsa_pass: bool
    all_pass: bool
    traffic: FCWSummary
    pareto: bool = False


def point_configs(base: dict, axes: dict[str, list]) -> list[tuple[dict, SimConfig]]:
    """Every grid point of ``axes`` over the SimConfig mapping ``base``, with its config
    (built, and so checked, before anything runs)."""
    out = []
    for point in grid_points(axes):
        data = dict(base)
        for key, value in point.items():
            set_path(data, key, value)
        out.append((point, from_mapping(SimConfig, data)))
    return out


def tune(
    points: list[tuple[dict, SimConfig]],
    recording: Recording,
    *,
    trials: int = 7,
    progress: bool = False,
) -> list[TunePoint]:
    """Each ``(settings, config)`` of :func:`point_configs`: its conformance margin and its
    alert classes on ``recording`` (see the module docstring), the Pareto front marked."""
    out = []
    for point, config in tqdm(points, disable=None if progress else True, desc="tune"):
        margin, all_pass = conformance_margin(config, trials)
        traffic = rule_on_truth(recording, config)
        out.append(TunePoint(point, margin, margin >= 0, all_pass, traffic))
    mark_pareto(out)
    return out


def mark_pareto(points: list[TunePoint]) -> None:
    """Mark the points no other point beats: a margin at least as large and a nuisance rate
    at most as large, one of them strictly."""

    def nuisance(p: TunePoint) -> float:
        return p.traffic.alerts_per_100km["nuisance"].value

    for p in points:
        p.pareto = not any(
            q.margin_s >= p.margin_s
            and nuisance(q) <= nuisance(p)
            and (q.margin_s > p.margin_s or nuisance(q) < nuisance(p))
            for q in points
        )


def tune_table(points: list[TunePoint], recording: Recording) -> Table:
    """One row per grid point (its settings, margin, passes, alerts per 100 km by class)."""
    keys = list(points[0].settings) if points else []
    columns = (
        *keys, "nhtsa_margin_s", "nhtsa_pass", "all_tests_pass", "nuisance_per_100km",
        "crash_relevant_per_100km", "relevant_missed", "pareto",
    )  # fmt: skip
    t = Table(f"Warning tuning on {recording.name}: conformance margin against nuisance", columns)
    for p in points:
        s = p.traffic
        t.rows.append(
            {
                **p.settings,
                "nhtsa_margin_s": round(p.margin_s, 3),
                "nhtsa_pass": p.nhtsa_pass,
                "all_tests_pass": p.all_pass,
                "nuisance_per_100km": s.alerts_per_100km["nuisance"].format(),
                "crash_relevant_per_100km": s.alerts_per_100km["crash_relevant"].format(),
                "relevant_missed": f"{s.relevant_missed}/{s.relevant}",
                "pareto": "yes" if p.pareto else "",
            }
        )
    if points:
        s = points[0].traffic
        drivers = (
            f"drivers distracted {recording.distraction:g} times per hour, FCW off"
            if recording.distraction > 0
            else "SUMO's drivers"
        )
        t.notes.append(
            f"traffic: {s.hours:.2f} h, {s.km:.1f} km of equipped driving ({drivers}), perfect "
            "sensing (the rule on truth); margin: the 5-of-7 deciding trial's TTC minus the NHTSA "
            "requirement, smallest of LVS, LVD, LVM"
        )
    return t
