"""The arguments of ``acc-fusion sumo`` (its work: :mod:`acc_fusion.cli.sumo`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    add_executor_arguments,
    add_osi_argument,
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
        "embedded, every vehicle equipped. Twice, in two processes, on the same seed: FCW off "
        "(every method watches, no driver is warned) and FCW on (the federated alerts make "
        "the equipped drivers brake). The equipped drivers look away from the road now and "
        "then (--distraction), leads brake hard now and then (--hazard-rate). By default in "
        "the 2-D world (radar and thermal camera seeing every object ahead, trackers, "
        "in-path selection; world.* settings); --pair for the 1-D pair world. Prints per "
        "method the false alarms, misses and lead time, the alerts by class judged from "
        "truth (and, in the 2-D world, by cause) per 100 km with 95% intervals, and the "
        "crashes FCW avoids: paired by vehicle (bootstrap interval), and each crash of the "
        "FCW-off run replayed with every method's warnings (Wilson interval). --seeds runs "
        "many seeds and pools them.",
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
        "--pair",
        action="store_true",
        help="the 1-D pair world instead of the 2-D one: each sensor sees only the true leader "
        "of its vehicle (the design's exact form; faster, for large sweeps)",
    )
    p.add_argument(
        "--open-loop",
        action="store_true",
        help="the 2-D pipeline open loop, FCW off (no driver reacts to a warning, nobody "
        "distracted): the alerts by class and cause under each of --conditions",
    )
    p.add_argument(
        "--seeds",
        metavar="SEEDS",
        help="run these seeds (e.g. 0-9 or 1,4,7) in parallel processes and pool them: rates "
        "over all the exposure, the paired benefit over all the vehicles; with --out, "
        "finished runs are kept in OUT/runs and an interrupted study resumes",
    )
    add_executor_arguments(p, "with --seeds: ")
    p.add_argument(
        "--aeb",
        action="store_true",
        help="add a run with automatic emergency braking after the warning (FCW + AEB, "
        "settings [aeb] of --config): its crashes beside FCW alone's, and its activations "
        "by class and cause per 100 km beside the warnings'",
    )
    p.add_argument(
        "--conditions",
        nargs="+",
        metavar="C",
        help="2-D world: weather and light, day, night, fog=METRES, rain=MM_PER_H joined by "
        "'+' (default: day); several only with --open-loop, one SUMO run each",
    )
    add_sim_arguments(p, None)
    p.add_argument(
        "--out", metavar="DIR", type=output_folder, help="also write CSV, PNG and JSON here"
    )
    add_osi_argument(p, "the FCW-off run (files <vehicle id>.mcap)")
    return p
