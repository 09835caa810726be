"""``acc-fusion highway``: FCW in highway-env traffic, FCW off and on on the same seeds, with
rendered replays; with ``--world`` the 2-D object pipeline in the same traffic, open loop,
alerts by class and cause.
"""

from __future__ import annotations

import argparse

from acc_fusion.cli.common import (
    osi_output,
    report_world,
    sim_config,
    traffic_sim_config,
    write_study,
)
from acc_fusion.cli.world import parse_conditions
from acc_fusion.core.errors import ConfigError
from acc_fusion.studies.highway import check_replay_path, highway_study
from acc_fusion.studies.highway_world import highway_world_study
from acc_fusion.truth.highway.config import HighwayConfig


def run_world(args: argparse.Namespace, cfg: HighwayConfig) -> int:
    """``acc-fusion highway --world``, open loop, once per condition: print the tables (and
    write them with ``--out``)."""
    if args.render:
        raise ConfigError("--world runs open loop and films no replay; drop --render")
    sim = sim_config(args, runs=1)
    if sim.drive is not None:
        raise ConfigError("--world runs open loop, nobody driving on the warnings; remove drive")
    conditions = [parse_conditions(c) for c in args.conditions or ["day"]]
    out = args.out
    study = highway_world_study(cfg, sim, conditions, progress=True, osi=osi_output(args))
    stem = f"highway_world_{cfg.env}_seed{cfg.seed}"
    report_world(study, out, stem, env=cfg.env, episodes=cfg.episodes, seed=cfg.seed,
                 pairs=cfg.pairs)  # fmt: skip
    if args.osi is not None:
        print(f"wrote {len(study.traces)} OSI traces in {args.osi}")
    return 0


def run(args: argparse.Namespace) -> int:
    """``acc-fusion highway``: print the table (and write CSV/PNG/JSON with ``--out``)."""

    cfg = HighwayConfig(
        env=args.env,
        episodes=args.episodes,
        seed=args.seed,
        duration=args.duration,
        pairs=args.pairs,
        vehicles_count=args.vehicles,
    )
    if (args.conditions or args.osi is not None) and not args.world:
        raise ConfigError("--conditions and --osi are settings of the 2-D pipeline; add --world")
    if args.world:
        if args.distraction is not None:
            raise ConfigError(
                "--world runs open loop, with no driver to distract; drop --distraction"
            )
        return run_world(args, cfg)
    render = check_replay_path(args.render) if args.render else None
    out = args.out
    sim = traffic_sim_config(args)
    study = highway_study(cfg, sim, progress=True, render=render)
    table = study.table()
    print(table.format() + "\n\n" + study.classes().format())
    print("\n" + study.benefits().format())
    if study.on.replay is not None:
        print(f"wrote {study.on.replay}")
    if out is not None:
        write_study(
            out,
            f"highway_{cfg.env}_seed{cfg.seed}",
            table,
            study,
            env=cfg.env,
            episodes=study.off.episodes,
            seed=cfg.seed,
            pairs=cfg.pairs,
            egos_per_episode=study.off.pairs,
            crashes={"fcw_off": study.off.crashes, "fcw_on": study.on.crashes},
            benefit=study.benefit().as_dict(),
            replay=str(study.on.replay) if study.on.replay else None,
        )
    return 0
