"""False-alarm rates in SUMO traffic: bundled networks, FCW on and off, SSM cross-check.

:func:`sumo_study` runs one SUMO scenario twice, each in its own process (libsumo allows one
simulation per process): open loop, where every method (radar, infrared, centralized,
federated) watches every equipped vehicle and no driver hears an alert (FCW off), and closed
loop, where the federated alerts make the equipped drivers brake (FCW on).  Both runs use
the same seed, so the same vehicles, hazards and inattentive drivers.  The open-loop run also
compares the oracle's true TTC with the minTTC of SUMO's SSM device, vehicle by vehicle.
"""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from acc_fusion.core.table import Table
from acc_fusion.metrics.summary import FCWSummary
from acc_fusion.sim.closed_loop import SimConfig, StepView, simulate
from acc_fusion.studies.compare import class_table, on_off_table
from acc_fusion.truth.sumo.background import BackgroundSumoSource
from acc_fusion.truth.sumo.config import SumoError
from acc_fusion.truth.sumo.source import SumoSource


class _MinTTC:
    """Per vehicle id, the minimum true TTC the oracle saw (for the SSM cross-check)."""

    def __init__(self, source) -> None:
        self.source = source
        self.min_ttc: dict[str, float] = {}

    def __call__(self, view: StepView) -> None:
        ids, ttc = self.source.vehicle_ids, view.ttc  # ttc: the first slots, every occupied one
        for k in np.flatnonzero(np.isfinite(ttc) & self.source.active[: len(ttc)]):
            vid = ids[k]
            if vid is not None:
                self.min_ttc[vid] = min(self.min_ttc.get(vid, np.inf), float(ttc[k]))


def _then(first, second):
    """The ``on_step`` hook that calls ``first`` (if any), then ``second``."""
    if first is None:
        return second

    def both(view: StepView) -> None:
        first(view)
        second(view)

    return both


@dataclass
class SumoRun:
    """What one SUMO run returns from its worker process.

    ``collisions`` counts every collision SUMO reported (equipped or not); the collisions of
    equipped vehicles are in each summary.  ``error`` is SUMO's message when it failed
    mid-run (the summaries then cover the run up to the failure, and ``steps`` is 0);
    ``steps`` counts the simulation steps of a completed run.
    """

    summaries: dict[str, FCWSummary]
    collisions: int
    equipped: int
    hazards: int
    ssm_pairs: list[tuple[float, float]]
    error: str | None = None
    steps: int = 0


def _run(sumo_config, sim: SimConfig, progress: bool, cross_check: bool) -> SumoRun:
    """One SUMO run (in a worker process).  In open loop SUMO runs in a child process ahead of
    the pipeline (:class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource`); in ``sumo-gui``
    (``sumo_config.gui``) the vehicles are coloured by the warning level of the last method
    of ``sim``."""

    config = replace(sumo_config, ssm=cross_check)
    background = sim.drive is None and not config.gui
    with BackgroundSumoSource(config) if background else SumoSource(config) as source:
        hook = _MinTTC(source) if cross_check else None
        if sumo_config.gui:
            method = sim.methods[-1]
            hook = _then(hook, lambda view: source.set_warning_colors(view.levels[method]))
        metrics_so_far: dict[str, FCWSummary] = {}
        error, steps = None, 0
        try:
            result = simulate(
                replace(sim, dt=source.dt), source=source, progress=progress, on_step=hook
            )
            metrics_so_far, steps = result.summaries, result.steps
        except SumoError as exc:  # SUMO failed mid-run: report it with what was measured
            error = str(exc)
            metrics_so_far = getattr(exc, "summaries", {})
        pairs = []
        if cross_check and error is None:
            ssm = source.ssm_min_ttc()
            pairs = [(hook.min_ttc[v], ssm[v]) for v in hook.min_ttc if v in ssm]
        return SumoRun(
            metrics_so_far,
            int(source.n_collisions),
            int(source.n_equipped),
            int(source.n_hazards),
            pairs,
            error,
            steps,
        )


@dataclass
class SumoStudy:
    """FCW metrics in traffic with FCW off (open loop) and on (closed loop)."""

    sumocfg: Path
    off: SumoRun
    on: SumoRun

    def ssm_agreement(self) -> dict[str, float]:
        """Median relative difference between the oracle's and SSM's minimum TTC."""
        pairs = np.array([p for p in self.off.ssm_pairs if np.isfinite(p).all() and p[1] > 0])
        if pairs.size == 0:
            return {"vehicles": 0, "median_rel_diff": float("nan")}
        rel = np.abs(pairs[:, 0] - pairs[:, 1]) / pairs[:, 1]
        return {"vehicles": int(len(pairs)), "median_rel_diff": float(np.median(rel))}

    def table(self):
        """Per method: false alarms, misses, lead time, collisions of equipped vehicles."""
        off, on = self.off, self.on
        t = on_off_table(
            f"FCW in SUMO traffic: {self.sumocfg.name}, {off.equipped} equipped vehicles, "
            f"{off.hazards} injected hazards, 95% intervals",
            off.summaries,
            on.summaries,
        )
        agree = self.ssm_agreement()
        t.notes.append(
            f"oracle TTC vs SUMO SSM minTTC: {agree['vehicles']} vehicles, median relative "
            f"difference {agree['median_rel_diff']:.3g}"
        )
        for label, run in (("FCW off", off), ("FCW on", on)):
            if run.error:
                t.notes.append(f"SUMO failed during the {label} run: {run.error}")
        return t

    def classes(self) -> Table:
        """Per method (FCW off): alerts per 100 km by class, missed crash-relevant situations."""
        title = f"Alert classes (judged from truth), {self.sumocfg.name}"
        return class_table(title, self.off.summaries)


def sumo_study(sumo_config, sim: SimConfig, *, progress: bool = False) -> SumoStudy:
    """Run ``sumo_config`` with FCW off (every method watching) and on (federated alerts),
    each in its own process, in parallel.  With ``gui``, the FCW-on run is the one shown in
    ``sumo-gui`` (vehicles coloured by its warning level); the FCW-off run stays headless."""
    drive = sim.drive or sim.methods[-1]
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=2, mp_context=ctx) as pool:
        headless = replace(sumo_config, gui=False)
        off = pool.submit(_run, headless, replace(sim, drive=None), progress, True)
        on = pool.submit(
            _run, sumo_config, replace(sim, drive=drive, methods=(drive,)), False, False
        )
        return SumoStudy(Path(sumo_config.sumocfg), off.result(), on.result())
