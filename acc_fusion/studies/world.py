"""The 2-D world under each weather and light condition, every method: alerts by class and by
cause — of the scripted scenes (:func:`world_study`, the tables and the figure of ``acc-fusion
world``), of a scenario file (:func:`scenario_file_study`, ``acc-fusion world --scenario``)
and of SUMO traffic (:func:`sumo_world_study`, ``acc-fusion sumo --open-loop``)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numba
import numpy as np
from tqdm.auto import tqdm

from acc_fusion.core.plots import method_color, pyplot
from acc_fusion.core.pools import process_pool
from acc_fusion.core.table import Table
from acc_fusion.metrics.stats import Rate
from acc_fusion.metrics.summary import (
    ALERT_CLASSES,
    CAUSE_CELLS,
    CAUSES,
    FALSE_CLASSES,
    FCWSummary,
)
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.sim.osi_trace import OsiOutput, traced_world
from acc_fusion.sim.world import simulate_world
from acc_fusion.studies.compare import class_table
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.openscenario.read import read_scenario
from acc_fusion.truth.procedures import TrackSource
from acc_fusion.truth.sumo.background import BackgroundSumoSource
from acc_fusion.truth.sumo.config import SumoConfig
from acc_fusion.truth.sumo.world import SumoWorld

#: The columns of :meth:`WorldStudy.scenes`.
SCENE_COLUMNS = (
    "scene", "conditions", "method", "runs", "crash_relevant", "nuisance", "sensing_false",
    "relevant", "relevant_missed", "runs_with_false_alert",
)  # fmt: skip
#: The columns of :meth:`WorldStudy.causes`.
CAUSE_COLUMNS = ("conditions", "method", "class", *CAUSES, "per_100km")
#: The columns of :meth:`WorldStudy.cause_rates`.
CAUSE_RATE_COLUMNS = ("conditions", "method", "class", "cause", "warnings", "km", "per_100km",
                      "per_100km_lo", "per_100km_hi")  # fmt: skip
#: The note under the tables by cause.
CAUSE_NOTE = (
    "cause: what the selected object was in truth at the warning's onset; lead = the true "
    "in-path lead (a nuisance: the rule fired on the right target); noise = a sensing-false "
    "warning on the true lead (the target was right, its estimate was not)"
)


@dataclass
class WorldStudy:
    """Summaries by (scene, conditions label) and method; ``where`` names what the causes are
    pooled over (the scripted scenes, or a SUMO network)."""

    config: SimConfig
    results: dict[tuple[str, str], dict[str, FCWSummary]]
    where: str = "all scenes"
    traces: list[Path] = field(default_factory=list)
    """The OSI traces written (``osi`` of :func:`world_study`)."""

    def scenes(self) -> Table:
        """Per scene, condition and method: warnings by class, crash-relevant situations and
        how many were missed, and the share of runs with a nuisance or sensing-false alert
        (Wilson interval)."""
        t = Table("Alerts by scene (judged from truth), 95% intervals", SCENE_COLUMNS)
        for (scene, label), summaries in self.results.items():
            for m, s in summaries.items():
                per = s.per_pair
                false = int(np.count_nonzero(per["nuisance"] + per["sensing_false"]))
                runs = per["nuisance"].size
                t.rows.append(
                    {"scene": scene, "conditions": label, "method": m, "runs": runs,
                     "crash_relevant": s.crash_relevant, "nuisance": s.nuisance,
                     "sensing_false": s.sensing_false, "relevant": s.relevant,
                     "relevant_missed": s.relevant_missed,
                     "runs_with_false_alert": Rate.proportion(false, runs).format(".2f")}
                )  # fmt: skip
        return t

    def pooled(self) -> dict[tuple[str, str], tuple[dict[str, dict[str, int]], float]]:
        """Per (conditions, method): warnings by class and cause over every scene, and km."""
        out: dict[tuple[str, str], tuple[dict[str, dict[str, int]], float]] = {}
        for (_, label), summaries in self.results.items():
            for m, s in summaries.items():
                counts, km = out.get((label, m), ({c: dict.fromkeys(CAUSES, 0)
                                                  for c in ALERT_CLASSES}, 0.0))  # fmt: skip
                for c in ALERT_CLASSES:
                    for cause in CAUSES:
                        counts[c][cause] += s.by_cause[c][cause]
                out[(label, m)] = (counts, km + s.km)
        return out

    def causes(self) -> Table:
        """Per condition and method, pooled over :attr:`where`: nuisance and sensing-false
        warnings by cause, and each class's rate per 100 km (exact Poisson interval)."""
        t = Table(f"Nuisance and sensing-false alerts by cause, {self.where}", CAUSE_COLUMNS)
        for (label, m), (counts, km) in self.pooled().items():
            for c in FALSE_CLASSES:
                total = sum(counts[c].values())
                t.rows.append(
                    {"conditions": label, "method": m, "class": c, **counts[c],
                     "per_100km": Rate.poisson(total, km / 100.0).format(".3g")}
                )  # fmt: skip
        t.notes.append(CAUSE_NOTE)
        return t

    def cause_rates(self) -> Table:
        """:meth:`causes` as rates: one row per condition, method, class and cause that can
        go together (:data:`~acc_fusion.metrics.summary.CAUSE_CELLS`), its warnings per
        100 km with the exact Poisson 95 % interval (an upper bound where none was counted)."""
        t = Table(f"Alerts by cause per 100 km, {self.where}, 95% intervals", CAUSE_RATE_COLUMNS)
        for (label, m), (counts, km) in self.pooled().items():
            for c in FALSE_CLASSES:
                for cause, k in counts[c].items():
                    if (c, cause) not in CAUSE_CELLS:
                        continue
                    rate = Rate.poisson(k, km / 100.0)
                    t.rows.append(
                        {"conditions": label, "method": m, "class": c, "cause": cause,
                         "warnings": k, "km": round(km, 3), "per_100km": rate.value,
                         "per_100km_lo": rate.lo, "per_100km_hi": rate.hi}
                    )  # fmt: skip
        t.notes.append(CAUSE_NOTE)
        return t

    def classes(self) -> list[Table]:
        """Per (scene, condition): the alert classes of every method per 100 km
        (:func:`~acc_fusion.studies.compare.class_table`)."""
        return [class_table(f"Alerts by class, {scene}, {label} (judged from truth)", summaries)
                for (scene, label), summaries in self.results.items()]  # fmt: skip

    def figure(self):
        """Nuisance (top row) and sensing-false (bottom row) warnings per 100 km by cause, a
        bar per method with its exact Poisson 95 % interval, one column per condition; a
        cause no method showed in a row is left out of it."""
        from matplotlib.patches import Patch

        plt = pyplot()
        rows = self.cause_rates().rows
        labels = list(dict.fromkeys(r["conditions"] for r in rows))
        methods = list(dict.fromkeys(r["method"] for r in rows))
        at = {(r["conditions"], r["method"], r["class"], r["cause"]): r for r in rows}
        fig, axes = plt.subplots(len(FALSE_CLASSES), len(labels), squeeze=False, sharey="row",
                                 figsize=(max(1.2 + 4.4 * len(labels), 9.0), 7.0))  # fmt: skip
        width = 0.8 / max(len(methods), 1)
        for i, c in enumerate(FALSE_CLASSES):
            shown = [k for k in CAUSES if any(r["warnings"] for r in rows
                                              if r["class"] == c and r["cause"] == k)]  # fmt: skip
            for ax, label in zip(axes[i], labels, strict=True):
                for j, m in enumerate(methods):
                    cells = [at[(label, m, c, k)] for k in shown]
                    value = np.array([r["per_100km"] for r in cells])
                    err = np.array([[v - r["per_100km_lo"], r["per_100km_hi"] - v]
                                    for v, r in zip(value, cells, strict=True)]).T  # fmt: skip
                    x = np.arange(len(shown)) + (j - (len(methods) - 1) / 2) * width
                    ax.bar(x, value, width, yerr=err.reshape(2, -1), capsize=2, label=m,
                           color=method_color(m))  # fmt: skip
                ax.set_xticks(np.arange(len(shown)), shown, rotation=30)
                if not shown:
                    ax.text(0.5, 0.5, "none", ha="center", va="center", transform=ax.transAxes)
                ax.set_title(f"{c.replace('_', '-')}, {label}", fontsize=10)
                ax.set_ylim(bottom=0)
            axes[i][0].set_ylabel("warnings per 100 km")
        handles = [Patch(color=method_color(m), label=m) for m in methods]
        fig.legend(handles=handles, title="method", fontsize=8, loc="center right")
        fig.suptitle(f"Nuisance and sensing-false alerts by cause, {self.where}, 95% intervals")
        fig.tight_layout(rect=(0.0, 0.0, 0.88, 1.0))
        return fig


def world_study(
    config: SimConfig,
    scenes: list[str],
    conditions: list[Conditions],
    progress: bool = False,
    osi: OsiOutput | None = None,
) -> WorldStudy:
    """Every scene under every condition (``config.runs`` runs each, the same seed); with
    ``osi``, an OSI trace of every run (:class:`OsiOutput`)."""
    results, traces = {}, []
    jobs = [(s, c) for s in scenes for c in conditions]
    for scene, cond in tqdm(jobs, disable=None if progress else True, desc="scenes"):
        run = replace(config, world=replace(config.world, scene=scene, conditions=cond))
        result, written = traced_world(run, osi=osi, prefix=f"{scene}_{cond.label}_")
        results[(scene, cond.label)], traces = result.summaries, traces + written
    return WorldStudy(config, results, traces=traces)


def scenario_file_study(
    config: SimConfig,
    path: str | Path,
    conditions: list[Conditions],
    progress: bool = False,
    osi: OsiOutput | None = None,
) -> WorldStudy:
    """An OpenSCENARIO file (:func:`~acc_fusion.truth.openscenario.read.read_scenario`) in the
    2-D world under every condition: ``config.runs`` runs of it, each run ending at its stop
    trigger or at contact (:class:`~acc_fusion.truth.procedures.TrackSource`); with ``osi``,
    an OSI trace of every run (:class:`OsiOutput`)."""
    scene = read_scenario(path, config.runs)
    results, traces = {}, []
    for cond in tqdm(conditions, disable=None if progress else True, desc="conditions"):
        run = replace(config, world=replace(config.world, conditions=cond))
        source = TrackSource(scene, scene.duration, config.dt)
        result, written = traced_world(run, source, osi, f"{scene.name}_{cond.label}_")
        results[(scene.name, cond.label)], traces = result.summaries, traces + written
    return WorldStudy(config, results, where=Path(path).name, traces=traces)


def _sumo_world_run(sumo_config: SumoConfig, config: SimConfig, progress: bool):
    """One SUMO run of the 2-D pipeline, open loop, at SUMO's step; every method's summary.
    SUMO and the object frames run in a process of their own, ahead of the pipeline
    (:class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource` with ``objects``)."""
    with BackgroundSumoSource(sumo_config, objects=config.world.object_field()) as source:
        run = replace(config, dt=source.dt)
        return simulate_world(run, source=SumoWorld(source), progress=progress).summaries


def sumo_world_study(
    sumo_config: SumoConfig,
    config: SimConfig,
    conditions: list[Conditions],
    progress: bool = False,
) -> WorldStudy:
    """The 2-D pipeline in SUMO traffic, open loop (no driver hears a warning), once per
    condition on the same seed, each in its own process, two at a time; the progress bar is
    the first run's."""
    name = Path(sumo_config.sumocfg).stem
    with process_pool(
        f"SUMO on {sumo_config.sumocfg!r}", 2, initializer=numba.set_num_threads, initargs=(1,)
    ) as pool:  # two runs share the cores: one numba thread each
        jobs = {
            c.label: pool.submit(
                _sumo_world_run,
                sumo_config,
                replace(config, world=replace(config.world, conditions=c)),
                progress and i == 0,
            )
            for i, c in enumerate(conditions)
        }
        results = {(name, label): job.result() for label, job in jobs.items()}
    return WorldStudy(config, results, where=f"SUMO {name}")
