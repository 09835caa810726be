"""The arguments of ``acc-fusion tune`` (its work: :mod:`acc_fusion.cli.tune`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    add_config_arguments,
    add_traffic_arguments,
    output_folder,
    positive_float,
    positive_int,
)


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``tune`` command."""
    p = subparsers.add_parser(
        "tune",
        help=summary,
        description="For every point of a grid of warning settings (--grid KEY=[V1, V2, ...], "
        "dotted config paths, repeatable: a Cartesian product), measure the margin on the "
        "NHTSA FCW confirmation tests (noisy sensors, 7 trials) and the rule's alerts per "
        "100 km by class on the truth of one SUMO run (recorded once, perfect sensing). "
        "Prints the table with the Pareto front; --out adds tune.csv and tune.png.",
    )
    where = p.add_mutually_exclusive_group()
    where.add_argument("--net", default="motorway", help="bundled network (default motorway)")
    where.add_argument("--sumocfg", metavar="PATH", help="any SUMO configuration file")
    p.add_argument(
        "--end", type=positive_float, default=300.0, help="simulated seconds (default 300)"
    )
    p.add_argument(
        "--grid",
        action="append",
        required=True,
        metavar="KEY=VALUES",
        help="a swept setting and its values as a YAML list, e.g. "
        "'warning.params.decel_imminent=[4, 5, 6]' (with --set warning.model=...)",
    )
    add_traffic_arguments(p)
    p.add_argument(
        "--trials", type=positive_int, default=7, help="trials per test manoeuvre (default 7)"
    )
    add_config_arguments(p)
    p.add_argument(
        "--out", metavar="DIR", type=output_folder, help="also write tune.csv and tune.png here"
    )
    return p
