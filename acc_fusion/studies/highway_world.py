"""The 2-D world in highway-env traffic (``acc-fusion highway --world``): the object pipeline
open loop (FCW off: no driver hears a warning) on the same episodes under each weather and
light condition, every method's alerts by class and by cause (:class:`WorldStudy`)."""

from __future__ import annotations

from dataclasses import replace

from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.sim.osi_trace import OsiOutput, traced_world
from acc_fusion.studies.world import WorldStudy
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.highway.config import HighwayConfig
from acc_fusion.truth.highway.source import HighwaySource
from acc_fusion.truth.highway.world import DEFAULT_FIELD, HighwayWorld
from acc_fusion.truth.sumo.objects import ObjectFieldConfig


def highway_world_study(
    cfg: HighwayConfig,
    sim: SimConfig,
    conditions: list[Conditions],
    progress: bool = False,
    field: ObjectFieldConfig | None = None,
    osi: OsiOutput | None = None,
) -> WorldStudy:
    """The 2-D pipeline of ``sim`` (``sim.world`` settings, its step replaced by highway-env's,
    ``drive`` ignored: open loop) on the episodes of ``cfg``, once per condition: each run
    resets highway-env with the same seeds, so every condition sees the same traffic.

    Args:
        cfg: the highway-env episodes.
        sim: the pipeline's settings.
        conditions: weather and light, one run each (the study's results keyed by
            ``(cfg.env, condition label)``).
        progress: show the source's progress bar over the episodes.
        field: the forward field and roadside objects (``None``:
            :data:`~acc_fusion.truth.highway.world.DEFAULT_FIELD`); its ``map_path`` follows
            ``sim.world``'s path (the map's lanes for the ``"map"`` path).
        osi: where to write an OSI trace of every vehicle of every episode, named
            ``<env>_<condition>_epNNN_vNN.mcap`` (:class:`OsiOutput`).
    """
    field = DEFAULT_FIELD if field is None else field
    results, traces = {}, []
    for cond in conditions:
        with HighwaySource(cfg, progress=progress) as source:
            world = replace(sim.world, conditions=cond)
            run = replace(sim, dt=source.dt, drive=None, world=world)

            def names(source=source) -> list[str]:
                return [f"ep{source.episode:03d}_v{e:02d}" for e in range(source.n_pairs)]

            objects = HighwayWorld(source, replace(field, map_path=sim.world.map_path))
            result, written = traced_world(run, objects, osi, f"{cfg.env}_{cond.label}_", names)
        results[(cfg.env, cond.label)], traces = result.summaries, traces + written
    return WorldStudy(sim, results, where=f"highway-env {cfg.env}", traces=traces)
