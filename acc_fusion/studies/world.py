"""The 2-D world under each weather and light condition, every method: alerts by class and by
cause — of the scripted scenes (:func:`world_study`, the tables and the figure of ``acc-fusion
world``) and of SUMO traffic (:func:`sumo_world_study`, ``acc-fusion sumo --world``)."""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numba
import numpy as np
from tqdm.auto import tqdm

from acc_fusion.core.plots import method_color, plt
from acc_fusion.core.table import Table
from acc_fusion.metrics.stats import Rate
from acc_fusion.metrics.summary import ALERT_CLASSES, CAUSES, FCWSummary
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.sim.world import simulate_world
from acc_fusion.studies.compare import class_table
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.sumo.background import BackgroundSumoSource
from acc_fusion.truth.sumo.config import SumoConfig
from acc_fusion.truth.sumo.objects import ObjectFieldConfig
from acc_fusion.truth.sumo.world import SumoWorld

#: The columns of :meth:`WorldStudy.scenes`.
SCENE_COLUMNS = (
    "scene", "conditions", "method", "runs", "crash_relevant", "nuisance", "sensing_false",
    "relevant", "relevant_missed", "runs_with_false_alert",
)  # fmt: skip
#: The columns of :meth:`WorldStudy.causes`.
CAUSE_COLUMNS = ("conditions", "method", "class", *CAUSES, "per_100km")


@dataclass
class WorldStudy:
    """Summaries by (scene, conditions label) and method; ``where`` names what the causes are
    pooled over (the scripted scenes, or a SUMO network)."""

    config: SimConfig
    results: dict[tuple[str, str], dict[str, FCWSummary]]
    where: str = "all scenes"

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
            for c in ("nuisance", "sensing_false"):
                total = sum(counts[c].values())
                t.rows.append(
                    {"conditions": label, "method": m, "class": c, **counts[c],
                     "per_100km": Rate.poisson(total, km / 100.0).format(".3g")}
                )  # fmt: skip
        t.notes.append(
            "cause: what the selected object was in truth at the warning's onset; lead = the "
            "true in-path lead (the warning's target was right: the rule or its estimate was not)"
        )
        return t

    def classes(self) -> list[Table]:
        """Per (scene, condition): the alert classes of every method per 100 km
        (:func:`~acc_fusion.studies.compare.class_table`)."""
        return [class_table(f"Alerts by class, {scene}, {label} (judged from truth)", summaries)
                for (scene, label), summaries in self.results.items()]  # fmt: skip

    def figure(self):
        """Stacked bars: the nuisance and sensing-false warnings of each method by cause, one
        panel per condition."""
        pooled = self.pooled()
        labels = list(dict.fromkeys(label for label, _ in pooled))
        methods = list(self.config.methods)
        fig, axes = plt.subplots(1, len(labels), figsize=(4.2 * len(labels), 3.8), squeeze=False)
        colors = plt.get_cmap("tab10")
        for ax, label in zip(axes[0], labels, strict=True):
            bottom = np.zeros(len(methods))
            for j, cause in enumerate(CAUSES):
                height = np.array([
                    pooled[(label, m)][0]["nuisance"][cause]
                    + pooled[(label, m)][0]["sensing_false"][cause]
                    for m in methods
                ])  # fmt: skip
                ax.bar(methods, height, bottom=bottom, label=cause, color=colors(j))
                bottom += height
            for tick, m in zip(ax.get_xticklabels(), methods, strict=True):
                tick.set_color(method_color(m))
            ax.set_title(label)
            ax.set_ylim(bottom=0)
            ax.set_ylabel("nuisance + sensing-false warnings")
            ax.tick_params(axis="x", rotation=30)
        handles, names = axes[0][0].get_legend_handles_labels()
        fig.legend(handles, names, title="cause", fontsize=8, loc="center right")
        fig.suptitle(f"False and nuisance alerts by cause, {self.config.runs} runs per scene")
        fig.tight_layout(rect=(0.0, 0.0, 0.9, 1.0))
        return fig


def world_study(
    config: SimConfig,
    scenes: list[str],
    conditions: list[Conditions],
    progress: bool = False,
) -> WorldStudy:
    """Every scene under every condition (``config.runs`` runs each, the same seed)."""
    results = {}
    jobs = [(s, c) for s in scenes for c in conditions]
    for scene, cond in tqdm(jobs, disable=None if progress else True, desc="scenes"):
        world = replace(config.world, scene=scene, conditions=cond)
        result = simulate_world(replace(config, world=world))
        results[(scene, cond.label)] = result.summaries
    return WorldStudy(config, results)


def _sumo_world_run(sumo_config: SumoConfig, config: SimConfig, progress: bool):
    """One SUMO run of the 2-D pipeline, open loop, at SUMO's step; every method's summary.
    SUMO and the object frames run in a process of their own, ahead of the pipeline
    (:class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource` with ``objects``)."""
    with BackgroundSumoSource(sumo_config, objects=ObjectFieldConfig()) as source:
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
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(
        max_workers=2, mp_context=ctx, initializer=numba.set_num_threads, initargs=(1,)
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
