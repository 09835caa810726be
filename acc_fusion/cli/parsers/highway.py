"""The arguments of ``acc-fusion highway`` (its work: :mod:`acc_fusion.cli.highway`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    add_config_arguments,
    add_distraction_argument,
    add_osi_argument,
    output_folder,
    output_path,
    positive_float,
    positive_int,
    seed,
)
from acc_fusion.truth.highway.config import INSTALL, PAIRS, SUPPORTED


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``highway`` command."""

    p = subparsers.add_parser(
        "highway",
        help=summary,
        description="Run highway-env episodes (highway-v0, highway-fast-v0, merge-v0), "
        "stepped at the simulation frequency, with every vehicle (or only the controlled "
        "one) and its leader as a pair. Twice, on the same seeds: FCW off (every method "
        "watches, no driver is warned) and FCW on (the federated alerts make the drivers "
        "brake after their reaction time); the drivers look away from the road now and then "
        "(--distraction). Prints false alarms per hour and per 100 km, miss "
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
    add_distraction_argument(p)
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
    add_osi_argument(p, "every episode (--world; files <env>_<condition>_epNNN_vNN.mcap)")
    return p
