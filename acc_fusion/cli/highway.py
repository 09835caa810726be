"""``acc-fusion highway``: FCW in highway-env traffic, FCW off and on on the same seeds, with
rendered replays.
"""

from __future__ import annotations

import argparse

from acc_fusion.cli.common import (
    add_config_arguments,
    positive_float,
    positive_int,
    seed,
    sim_config,
    write_study,
)
from acc_fusion.core.outputs import output_dir
from acc_fusion.studies.highway import check_replay_path, highway_study
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
        f"rate, lead time and collisions, with 95% intervals. Needs highway-env ({INSTALL}).",
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
        help="write a replay of the FCW-on run (.gif, or .mp4 with imageio-ffmpeg) with the "
        "fused gap, safety distance and warning level drawn on highway-env's frames",
    )
    p.add_argument("--out", metavar="DIR", help="also write CSV, PNG and JSON here")
    return p


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
    render = check_replay_path(args.render) if args.render else None
    out = output_dir(args.out) if args.out else None
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
