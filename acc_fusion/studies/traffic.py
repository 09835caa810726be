"""False-alarm rates and the crashes FCW avoids in SUMO traffic: bundled networks, FCW on
and off, SSM cross-check.

:func:`sumo_study` runs one SUMO scenario twice, each in its own process (libsumo allows one
simulation per process): FCW off, where every method (radar, infrared, centralized,
federated) watches every equipped vehicle and no driver hears an alert, and FCW on, where the
federated alerts make the equipped drivers brake.  Both runs use the same seed, so the same
vehicles, hazards, inattentive drivers and eyes-off-road episodes
(:mod:`acc_fusion.truth.distraction`).  Without distraction the FCW-off run is open loop, SUMO
running ahead in a child process; with it the drivers act in both runs (closed loop, deaf to
warnings when FCW is off).  On request (``ssm``) the FCW-off run also compares the oracle's
true TTC with the minTTC of SUMO's SSM device, vehicle by vehicle; the device more than
doubles that run's time (bundled motorway, 300 s: 19 s without it, 44 s with it).
With ``aeb`` a third run adds automatic emergency braking to the FCW-on run
(:mod:`acc_fusion.braking.aeb`): its crashes pair with the FCW-off run's as the FCW-on run's
do, and its AEB activations are classed from truth as the warnings are (an activation outside
a crash-relevant situation is a false one).
:meth:`SumoStudy.benefit` pairs the two runs vehicle by vehicle
(:mod:`acc_fusion.metrics.benefit`); :attr:`SumoStudy.replayed` replays each crash of the
FCW-off run with each method's warnings (:mod:`acc_fusion.metrics.counterfactual`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np

from acc_fusion.core.pools import process_pool
from acc_fusion.core.table import Table
from acc_fusion.metrics.benefit import Benefit, paired_benefit
from acc_fusion.metrics.counterfactual import ConflictRecord, counterfactual_benefit
from acc_fusion.metrics.hazards import (
    HazardCounts,
    NaturalisticRates,
    hazard_figure,
    hazard_table,
)
from acc_fusion.metrics.summary import CAUSES, FALSE_CLASSES, FCWSummary, pool_summaries
from acc_fusion.sim.closed_loop import SimConfig, StepView, simulate
from acc_fusion.sim.osi_trace import OsiOutput
from acc_fusion.sim.world import simulate_world
from acc_fusion.studies.compare import benefit_table, class_table, exposure_km, on_off_table
from acc_fusion.studies.crashes import CrashLog, HazardLog, chain
from acc_fusion.truth.driver import DriverConfig
from acc_fusion.truth.sumo.background import BackgroundSumoSource
from acc_fusion.truth.sumo.config import SumoError
from acc_fusion.truth.sumo.source import SumoSource
from acc_fusion.truth.sumo.world import SumoWorld


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


@dataclass
class SumoRun:
    """What one SUMO run returns from its worker process.

    ``collisions`` counts every collision SUMO reported (equipped or not); the collisions of
    equipped vehicles are in each summary.  ``error`` is SUMO's message when it failed
    mid-run (the summaries then cover the run up to the failure, and ``steps`` is 0);
    ``steps`` counts the simulation steps of a completed run.  ``vehicles``: the equipped
    vehicles driven; ``crashes``: the impact speed of each that ran into its lead;
    ``conflicts``: the FCW-off closed loop's record of each crash, for the replay of
    :mod:`acc_fusion.metrics.counterfactual` (``None`` in other runs);
    ``ssm_pairs``: (oracle, SSM) minimum TTC [s] per vehicle, ``None`` without the cross-check;
    ``aeb``: the AEB's activations by class (a run with AEB, else ``None``);
    ``by_hazard``: the crash-relevant situations and crashes by hazard (a closed loop, else
    ``None``; :mod:`acc_fusion.metrics.hazards`).
    """

    summaries: dict[str, FCWSummary]
    collisions: int
    equipped: int
    hazards: int
    ssm_pairs: list[tuple[float, float]] | None
    error: str | None = None
    steps: int = 0
    vehicles: set[str] = field(default_factory=set)
    crashes: dict[str, float] = field(default_factory=dict)
    conflicts: list[ConflictRecord] | None = None
    aeb: FCWSummary | None = None
    by_hazard: HazardCounts | None = None


def _run(
    sumo_config,
    sim: SimConfig,
    progress: bool,
    cross_check: bool,
    warnings_on: bool = True,
    world: bool = False,
    osi: OsiOutput | None = None,
) -> SumoRun:
    """One SUMO run (in a worker process); with ``osi`` (the 2-D world) an OSI trace of every
    equipped vehicle (:class:`~acc_fusion.sim.osi_trace.OsiOutput`).  In open loop SUMO runs
    in a child process ahead of the pipeline
    (:class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource`, with the object frames
    for ``world``); in ``sumo-gui`` (``sumo_config.gui``) the vehicles are coloured by the
    warning level of the last method of ``sim``; with ``warnings_on`` false the drivers act
    but hear no warning; with ``world`` the 2-D pipeline perceives
    (:func:`~acc_fusion.sim.world.simulate_world` on
    :class:`~acc_fusion.truth.sumo.world.SumoWorld`)."""

    config = replace(sumo_config, ssm=cross_check)
    objects = sim.world.object_field() if world else None
    background = sim.drive is None and not config.gui
    with BackgroundSumoSource(config, objects) if background else SumoSource(config) as source:
        history = sim.drive is not None and not warnings_on
        hazards = None if background or sim.drive is None else HazardLog(source, sim.tolerance)
        crashes = CrashLog(source, lambda: source.vehicle_ids, dt=source.dt, history=history,
                           hazards=hazards)  # fmt: skip
        min_ttc = _MinTTC(source) if cross_check else None
        hook = chain(min_ttc, hazards, crashes)
        if sumo_config.gui:
            method = sim.methods[-1]
            hook = chain(hook, lambda view: source.set_warning_colors(view.levels[method]))
        recorder = None
        if osi is not None:
            recorder = osi.recorder(sim, "", lambda: source.vehicle_ids)
            hook = chain(hook, recorder)
        metrics_so_far: dict[str, FCWSummary] = {}
        error, steps, aeb = None, 0, None
        try:
            run, how = replace(sim, dt=source.dt), {"progress": progress, "on_step": hook}
            if world:
                result = simulate_world(
                    run, source=SumoWorld(source, objects), warnings_on=warnings_on, **how
                )
            else:
                result = simulate(run, source=source, warnings_on=warnings_on, **how)
            metrics_so_far, steps, aeb = result.summaries, result.steps, result.aeb
        except SumoError as exc:  # SUMO failed mid-run: report it with what was measured
            error = str(exc)
            metrics_so_far = getattr(exc, "summaries", {})
        finally:
            if recorder is not None:
                recorder.close()
        pairs = [] if cross_check else None
        if cross_check and error is None:
            ssm, seen = source.ssm_min_ttc(), min_ttc.min_ttc
            pairs = [(seen[v], ssm[v]) for v in seen if v in ssm]
        return SumoRun(
            metrics_so_far,
            int(source.n_collisions),
            int(source.n_equipped),
            int(source.n_hazards),
            pairs,
            error,
            steps,
            crashes.units,
            crashes.crashes,
            list(crashes.conflicts.values()) if history else None,
            aeb,
            None if hazards is None else hazards.counts(crashes.causes),
        )


@dataclass
class SumoStudy:
    """FCW metrics in traffic with FCW off (open loop) and on (closed loop)."""

    sumocfg: Path
    off: SumoRun
    on: SumoRun
    also: dict[str, SumoRun] = field(default_factory=dict)
    """FCW-on runs driven by further methods (``drives`` of :func:`sumo_study`)."""
    driver: DriverConfig = field(default_factory=DriverConfig)
    """The drivers' rules (for the replay of :meth:`replayed`)."""
    with_aeb: SumoRun | None = None
    """The FCW-on run with automatic emergency braking added (``aeb`` of :func:`sumo_study`)."""

    def ssm_agreement(self) -> dict[str, float] | None:
        """Median relative difference between the oracle's and SSM's minimum TTC; ``None``
        when the study ran without the cross-check."""
        if self.off.ssm_pairs is None:
            return None
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
        if agree is not None:
            t.notes.append(
                f"oracle TTC vs SUMO SSM minTTC: {agree['vehicles']} vehicles, median relative "
                f"difference {agree['median_rel_diff']:.3g}"
            )
        for label, error in self.errors().items():
            t.notes.append(f"SUMO failed during the {label} run: {error}")
        return t

    def errors(self) -> dict[str, str]:
        """SUMO's message of every run that failed, by run (``FCW off``, ``FCW on``, ...)."""
        runs = {"FCW off": self.off, "FCW on": self.on}
        runs |= {f"FCW on ({m})": run for m, run in self.also.items()}
        if self.with_aeb is not None:
            runs["FCW + AEB"] = self.with_aeb
        return {label: run.error for label, run in runs.items() if run.error}

    def classes(self) -> Table:
        """Per method (FCW off): alerts per 100 km by class, missed crash-relevant situations."""
        title = f"Alert classes (judged from truth), {self.sumocfg.name}"
        return class_table(title, self.off.summaries)

    def benefits(self) -> Table:
        """:meth:`benefit` of every FCW-on run, one row per method that drove it."""
        title = f"Crashes FCW avoids, {self.sumocfg.name}, equipped vehicles, same seed"
        return benefit_table(title, self.benefit_by_method())

    def benefit_by_method(self) -> dict[str, Benefit]:
        """:meth:`benefit` of every FCW-on run, by the method that drove it; the run with AEB
        as ``<method> + AEB``."""
        runs = {self._drive(self.on): self.on, **self.also}
        if self.with_aeb is not None:
            runs[f"{self._drive(self.with_aeb)} + AEB"] = self.with_aeb
        return {m: self.benefit(run) for m, run in runs.items()}

    def aeb_table(self) -> Table | None:
        """The run with AEB: its warnings and its AEB activations by class per 100 km, side
        by side (``None`` without that run)."""
        run = self.with_aeb
        if run is None or run.aeb is None:
            return None
        drive = self._drive(run)
        title = (
            f"AEB activations and FCW alerts, {self.sumocfg.name}, FCW + AEB on {drive}, "
            "judged from truth, 95% intervals"
        )
        t = class_table(title, {f"FCW alerts ({drive})": run.summaries[drive],
                                f"AEB activations ({drive})": run.aeb})  # fmt: skip
        t.notes.append(
            "an AEB activation outside a crash-relevant situation is a false activation: "
            "nuisance (the lead is real, the situation not critical) or sensing-false"
        )
        by_cause = run.aeb.by_cause
        if by_cause is not None:
            false = {k: sum(by_cause[c][k] for c in FALSE_CLASSES) for k in CAUSES}
            t.notes.append(
                "false activations by cause: "
                + ", ".join(f"{k} {n}" for k, n in false.items() if n)
                if any(false.values())
                else "no false activation"
            )
        return t

    def benefit(self, on: SumoRun | None = None, *, seed: int = 0) -> Benefit:
        """The crashes of equipped vehicles that FCW (the run ``on``, default :attr:`on`)
        avoided, paired by vehicle, with a bootstrap interval
        (:func:`acc_fusion.metrics.benefit.paired_benefit`)."""
        on = self.on if on is None else on
        return paired_benefit(
            self.off.vehicles | on.vehicles,
            self.off.crashes,
            on.crashes,
            exposure_km(self.off.summaries),
            exposure_km(on.summaries),
            seed=seed,
        )

    @cached_property
    def replayed(self) -> dict[str, Benefit]:
        """Per method, the crashes of the FCW-off run its warnings would have avoided,
        replayed crash by crash (:mod:`acc_fusion.metrics.counterfactual`; empty when the
        FCW-off run was open loop, without drivers)."""
        if self.off.conflicts is None:
            return {}
        km, driver = exposure_km(self.off.summaries), self.driver
        return {
            m: counterfactual_benefit(self.off.conflicts, m, driver, km) for m in self.off.summaries
        }

    def replayed_table(self) -> Table:
        """:attr:`replayed` as a table."""
        title = f"Crashes FCW avoids, replayed crash by crash, {self.sumocfg.name}"
        note = (
            "pairs: the crashes of the FCW-off run, each replayed with the method's warnings "
            "heard, its leader and the rest of the traffic as they were (the direct effect: "
            "no crash introduced behind a braking driver); reduction = share avoided, 95% "
            "Wilson interval; impact speed: median closing speed at contact"
        )
        return benefit_table(title, self.replayed, note=note)

    def hazard_table(self, rates: NaturalisticRates | None = None) -> Table | None:
        """The FCW-off run's crash-relevant situations and crashes by hazard, as simulated and
        re-weighted to the naturalistic ``rates`` (:mod:`acc_fusion.metrics.hazards`), with
        the FCW-on run's re-weighted reduction; ``None`` when the FCW-off run was open loop."""
        exposure = self._hazard_exposure()
        if exposure is None:
            return None
        title = (
            f"Crash-relevant situations and crashes by hazard, {self.sumocfg.name}, FCW off: "
            "as simulated and re-weighted to naturalistic rates"
        )
        return hazard_table(title, self.off.by_hazard, *exposure, rates or NaturalisticRates(),
                            self.on.by_hazard, exposure_km(self.on.summaries))  # fmt: skip

    def hazard_figure(self, rates: NaturalisticRates | None = None):
        """:meth:`hazard_table`'s crashes as a figure
        (:func:`~acc_fusion.metrics.hazards.hazard_figure`); ``None`` as the table."""
        exposure = self._hazard_exposure()
        if exposure is None:
            return None
        return hazard_figure(self.off.by_hazard, *exposure, rates or NaturalisticRates())

    def _hazard_exposure(self) -> tuple[float, float] | None:
        """The FCW-off run's km and hours, if it counted its hazards (else ``None``)."""
        if self.off.by_hazard is None or not self.off.summaries:
            return None
        summary = next(iter(self.off.summaries.values()))
        return summary.km, summary.hours

    @staticmethod
    def _drive(run: SumoRun) -> str:
        return next(iter(run.summaries), "fcw")


#: The name of the FCW-off run, of the FCW-on run, and the prefix of the FCW-on runs driven by
#: further methods, in :func:`study_runs`; the name of the FCW-on run with AEB.
OFF, ON, ALSO, WITH_AEB = "off", "on", "on:", "aeb"


def study_runs(
    sumo_config, sim: SimConfig, *, drives: tuple[str, ...] = (), ssm: bool = False,
    world: bool = False, progress: bool = False, aeb: bool = False, osi: OsiOutput | None = None,
) -> dict[str, tuple]:  # fmt: skip
    """The runs of a study of ``sumo_config`` (:func:`sumo_study`), by name (:data:`OFF`,
    :data:`ON`, :data:`ALSO` + method, :data:`WITH_AEB` with ``aeb``): the arguments of the
    worker function :func:`run_one`; ``osi``: the FCW-off run's OSI traces' folder.
    Only the FCW-off run shows a progress bar, and only the FCW-on run a ``sumo-gui``."""
    drive = sim.drive or sim.methods[-1]
    distracted = sim.driver.distraction.rate > 0
    headless = replace(sumo_config, gui=False)
    off_sim = replace(sim, drive=drive if distracted else None)
    runs = {OFF: (headless, off_sim, progress, ssm, False, world, osi)}

    def fcw_on(method: str, config) -> tuple:
        return (config, replace(sim, drive=method, methods=(method,)), False, False, True, world)

    runs[ON] = fcw_on(drive, sumo_config)
    runs |= {ALSO + m: fcw_on(m, headless) for m in drives if m != drive}
    if aeb:
        braking = replace(sim, aeb=replace(sim.aeb, enabled=True, method=None))
        runs[WITH_AEB] = (headless, replace(braking, drive=drive, methods=(drive,)), False,
                          False, True, world)  # fmt: skip
    return runs


def run_one(args: tuple) -> SumoRun:
    """One run of :func:`study_runs` (in a worker process)."""
    return _run(*args)


def assemble(sumo_config, sim: SimConfig, runs: dict[str, SumoRun]) -> SumoStudy:
    """The :class:`SumoStudy` of the runs of :func:`study_runs`, by name."""
    also = {name[len(ALSO) :]: run for name, run in runs.items() if name.startswith(ALSO)}
    return SumoStudy(
        Path(sumo_config.sumocfg), runs[OFF], runs[ON], also, sim.driver, runs.get(WITH_AEB)
    )


def sumo_study(
    sumo_config,
    sim: SimConfig,
    *,
    progress: bool = False,
    drives: tuple[str, ...] = (),
    ssm: bool = False,
    world: bool = False,
    aeb: bool = False,
    osi: OsiOutput | None = None,
) -> SumoStudy:
    """Run ``sumo_config`` with FCW off (every method watching) and on (federated alerts),
    each in its own process, in parallel; ``drives`` adds an FCW-on run per further method
    (:attr:`SumoStudy.also`); ``aeb`` adds the FCW-on run with automatic emergency braking
    (:attr:`SumoStudy.with_aeb`); ``ssm`` adds the SSM cross-check to the FCW-off run.  With
    ``gui``, the FCW-on run is the one shown in ``sumo-gui`` (vehicles coloured by its
    warning level); the other runs stay headless.  With ``world`` every run perceives with
    the 2-D pipeline (settings ``sim.world``), so its summaries have the alerts by cause and
    the warnings the drivers hear are the 2-D pipeline's; ``osi`` (with ``world``) writes an
    OSI trace of every equipped vehicle of the FCW-off run there."""
    runs = study_runs(
        sumo_config, sim, drives=drives, ssm=ssm, world=world, progress=progress, aeb=aeb,
        osi=osi,
    )  # fmt: skip
    with process_pool(f"SUMO on {sumo_config.sumocfg!r}", 2) as pool:
        futures = {name: pool.submit(run_one, args) for name, args in runs.items()}
        return assemble(sumo_config, sim, {name: f.result() for name, f in futures.items()})


def pool_runs(runs: dict[int, SumoRun]) -> SumoRun:
    """The same run of several seeds as one (``runs`` by seed): every method's summaries
    pooled (:func:`~acc_fusion.metrics.summary.pool_summaries`), counts added, the vehicles
    and crashes kept apart by seed (ids ``"<seed>:<id>"``), so that the paired benefit and
    the replayed crashes pool over every seed's vehicles."""
    seeds = sorted(runs)
    first = runs[seeds[0]]
    summaries = {
        m: pool_summaries([runs[k].summaries[m] for k in seeds if m in runs[k].summaries])
        for m in first.summaries
    }
    errors = [f"seed {k}: {runs[k].error}" for k in seeds if runs[k].error]
    ssm = None
    if all(runs[k].ssm_pairs is not None for k in seeds):
        ssm = [p for k in seeds for p in runs[k].ssm_pairs]
    conflicts = None
    if all(runs[k].conflicts is not None for k in seeds):
        conflicts = [c for k in seeds for c in runs[k].conflicts]
    aeb = by_hazard = None
    if all(runs[k].aeb is not None for k in seeds):
        aeb = pool_summaries([runs[k].aeb for k in seeds])
    if all(runs[k].by_hazard is not None for k in seeds):
        by_hazard = sum((runs[k].by_hazard for k in seeds[1:]), runs[seeds[0]].by_hazard)
    return SumoRun(
        summaries,
        sum(runs[k].collisions for k in seeds),
        sum(runs[k].equipped for k in seeds),
        sum(runs[k].hazards for k in seeds),
        ssm,
        "; ".join(errors) or None,
        sum(runs[k].steps for k in seeds),
        {f"{k}:{v}" for k in seeds for v in runs[k].vehicles},
        {f"{k}:{v}": speed for k in seeds for v, speed in runs[k].crashes.items()},
        conflicts,
        aeb,
        by_hazard,
    )


def pool_studies(studies: dict[int, SumoStudy]) -> SumoStudy:
    """The studies of several seeds (by seed) as one :class:`SumoStudy`: each run pooled over
    the seeds by :func:`pool_runs`."""
    seeds = sorted(studies)
    first = studies[seeds[0]]
    also = {m: pool_runs({k: studies[k].also[m] for k in seeds}) for m in first.also}
    return SumoStudy(
        first.sumocfg,
        pool_runs({k: studies[k].off for k in seeds}),
        pool_runs({k: studies[k].on for k in seeds}),
        also,
        first.driver,
        None if first.with_aeb is None else pool_runs({k: studies[k].with_aeb for k in seeds}),
    )
