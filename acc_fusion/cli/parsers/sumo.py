"""The arguments of ``acc-fusion sumo`` (its work: :mod:`acc_fusion.cli.sumo`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    add_sim_arguments,
    add_traffic_arguments,
    output_folder,
    positive_float,
)


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``sumo`` command."""
    p = subparsers.add_parser(
        "sumo",
        help=summary,
        description="Run a SUMO scenario (a bundled network or any .sumocfg) with libsumo, "
        "embedded: every equipped vehicle and its leader are a pair. Twice, in two "
        "processes: FCW off (every method watches, no driver is warned) and FCW on (the "
        "federated alerts make equipped drivers brake), on the same seed. Prints false "
        "alarms per hour and per 100 km, miss rate, lead time and collisions, with 95% "
        "intervals, the alerts by class judged from truth, and the crashes FCW avoids: "
        "paired by vehicle (bootstrap interval), and each crash of the FCW-off run replayed "
        "with every method's warnings (Wilson interval). "
        "The equipped drivers look away from the road now and then (--distraction). "
        "With --world, the 2-D object pipeline instead, open loop (FCW off); with "
        "--world --closed-loop, FCW off and on as above with the 2-D pipeline's warnings.",
    )
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--net", help="bundled network: motorway, onramp, ring, arterial")
    where.add_argument("--sumocfg", metavar="PATH", help="any SUMO configuration file")
    p.add_argument("--end", type=positive_float, help="simulated seconds (default: the file's)")
    add_traffic_arguments(p)
    p.add_argument("--step-length", type=positive_float, help="SUMO step [s] (default: the file's)")
    p.add_argument("--gui", action="store_true", help="sumo-gui, vehicles coloured by warning")
    p.add_argument(
        "--all-drives",
        action="store_true",
        help="one FCW-on run per method (radar, infrared, centralized, federated driving the "
        "alert), to compare the crashes each avoids (two at a time)",
    )
    p.add_argument(
        "--ssm",
        action="store_true",
        help="also compare the oracle's minimum TTC per vehicle with SUMO's SSM device in the "
        "FCW-off run (a cross-check of the TTC; more than doubles that run's time)",
    )
    p.add_argument(
        "--world",
        action="store_true",
        help="run the 2-D object pipeline instead (radar and thermal camera seeing every object "
        "ahead, trackers, association, every method's estimator per object, in-path selection; "
        "world.* settings): open loop, FCW off (no driver reacts to a warning); prints per "
        "method the alerts by class per 100 km and the nuisance and sensing-false alerts by "
        "cause",
    )
    p.add_argument(
        "--closed-loop",
        action="store_true",
        help="with --world: FCW off and on, as without --world, the equipped drivers hearing "
        "the 2-D pipeline's federated warnings (one condition); prints the same tables and the "
        "FCW-off run's alerts by cause",
    )
    p.add_argument(
        "--conditions",
        nargs="+",
        metavar="C",
        help="with --world: weather and light, day, night, fog=METRES, rain=MM_PER_H joined by "
        "'+', one SUMO run each (default: day)",
    )
    add_sim_arguments(p, None)
    p.add_argument(
        "--out", metavar="DIR", type=output_folder, help="also write CSV, PNG and JSON here"
    )
    return p
