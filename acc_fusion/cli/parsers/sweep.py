"""The arguments of ``acc-fusion sweep`` (its work: :mod:`acc_fusion.cli.sweep`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import output_folder, positive_int
from acc_fusion.sweep import EXECUTORS


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``sweep`` command to the ``acc-fusion`` sub-parsers."""

    p = subparsers.add_parser(
        "sweep",
        help=summary,
        description="Run a sweep (a TOML/YAML file: grid and random axes over SimConfig "
        "fields, SUMO settings and seeds) on local processes or Ray. Writes one row per run "
        "and method to DIR/runs.parquet, aggregated tables with 95% intervals, ROC/DET "
        "curves and a report. Rerunning with the same --out skips the finished chunks.",
    )
    p.add_argument("config", metavar="CONFIG", help="sweep config file (.toml, .yaml or .yml)")

    p.add_argument(
        "--executor", choices=EXECUTORS, default="local", help="where to run (default local)"
    )
    p.add_argument(
        "--address",
        metavar="ADDR",
        help="Ray cluster address HOST:PORT or ray://HOST:PORT (default: a local Ray)",
    )
    p.add_argument(
        "--workers",
        type=positive_int,
        default=2,
        help="worker processes (local) or CPUs of the local Ray (default 2)",
    )
    p.add_argument(
        "--out", metavar="DIR", type=output_folder, help="output folder (default out/sweep_<name>)"
    )
    return p
