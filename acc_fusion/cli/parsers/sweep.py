"""The arguments of ``acc-fusion sweep`` (its work: :mod:`acc_fusion.cli.sweep`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import add_executor_arguments, output_folder


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

    add_executor_arguments(p)
    p.add_argument(
        "--out", metavar="DIR", type=output_folder, help="output folder (default out/sweep_<name>)"
    )
    return p
