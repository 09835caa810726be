"""``acc-fusion highway``: FCW in highway-env traffic, FCW off and on on the same seeds, with
rendered replays; with ``--world`` the 2-D object pipeline in the same traffic, open loop,
alerts by class and cause.
"""

from __future__ import annotations

import argparse

from acc_fusion.cli.common import (
    add_config_arguments,
    output_folder,
    output_path,
    positive_float,
    positive_int,
    report_world,
    seed,
    sim_config,
    write_study,
)
from acc_fusion.cli.world import parse_conditions
from acc_fusion.core.errors import ConfigError
from acc_fusion.studies.highway import check_replay_path, highway_study
from acc_fusion.studies.highway_world import highway_world_study
from acc_fusion.truth.highway.config import INSTALL, PAIRS, SUPPORTED, HighwayConfig


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``highway`` command."""

    p = subparsers.add_parser(
        "highway",
        help="FCW in highway-env traffic: false alarms per method, collisions with FCW on "
        "and off, rendered replays",
        description="Run highway-env episodes (highway-v0, highway-fast-v0, merge-v0), "
        "stepped at the simulation frequency, with every vehicle (or only the controlled "
        "one) and its leader as a pair. Twice, on the same seeds: FCW off (every method "
        "watches, no driver is warned) and FCW on (the federated alerts make the drivers "
        "brake after their reaction time). Prints false alarms per hour and per 100 km, miss "
        "rate, lead time and collisions, with 95% intervals. With --world, the 2-D object "
        "pipeline instead, open loop (FCW off): alerts by class and cause per method. "
        f"Needs highway-env ({INSTALL}).",
    )
    p.add_argument(
        "--env",
        default="highway-v0",
        help=f"environment: {', '.join(SUPPORTED)} (default highway-v0)",
    )
    p.add_argument("--episodes", type=positive_int, default=10, help="episodes (default 10)")
    p.add_argument(
        "--seed", type=seed, default=0, help="episode k is reset with seed + k (default 0)"
    )
    p.add_argument(
        "--pairs",
        choices=PAIRS,
        default="all",
        help="egos: every vehicle (default) or the controlled one only",
    )
    p.add_argument("--duration", type=positive_float, help="seconds per episode (default: env's)")
    p.add_argument("--vehicles", type=int, help="highway-env's vehicles_count (default: env's)")
    add_config_arguments(p)
    p.add_argument(
        "--render",
        metavar="PATH",
        type=output_path,
        help="write a replay of the FCW-on run (.gif, or .mp4 with imageio-ffmpeg) with the "
        "fused gap, safety distance and warning level drawn on highway-env's frames",
    )
    p.add_argument(
        "--world",
        action="store_true",
        help="run the 2-D object pipeline instead (radar and thermal camera seeing every vehicle, "
        "road object and roadside object ahead, trackers, association, every method's estimator "
        "per object, in-path selection; world.* settings): open loop, FCW off; prints per "
        "method the alerts by class per 100 km and the nuisance and sensing-false alerts by cause",
    )
    p.add_argument(
        "--conditions",
        nargs="+",
        metavar="C",
        help="with --world: weather and light, day, night, fog=METRES, rain=MM_PER_H joined by "
        "'+', one run of the same episodes each (default: day)",
    )
    p.add_argument(
        "--out", metavar="DIR", type=output_folder, help="also write CSV, PNG and JSON here"
    )
    return p


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
    study = highway_world_study(cfg, sim, conditions, progress=True)
    stem = f"highway_world_{cfg.env}_seed{cfg.seed}"
    report_world(study, out, stem, env=cfg.env, episodes=cfg.episodes, seed=cfg.seed,
                 pairs=cfg.pairs)  # fmt: skip
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
    if args.conditions and not args.world:
        raise ConfigError("--conditions is a setting of the 2-D pipeline; add --world")
    if args.world:
        return run_world(args, cfg)
    render = check_replay_path(args.render) if args.render else None
    out = args.out
    sim = sim_config(args, runs=1)
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
