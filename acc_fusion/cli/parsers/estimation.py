"""The arguments of ``acc-fusion estimation`` (its work: :mod:`acc_fusion.cli.estimation`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    output_folder,
    positive_float,
    positive_int,
    seed,
)


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``estimation`` command."""
    p = subparsers.add_parser(
        "estimation",
        help=summary,
        description="Run every fusion method (each sensor alone, centralized sequential and "
        "stacked, federated in its three reset modes, with fault isolation, and the plain "
        "formula) on the same car-following truth and measurements; print RMSE, mean NEES "
        "with its 95% bounds, and the cost per pair-step.",
    )
    p.add_argument("--runs", type=positive_int, default=500, help="Monte Carlo runs (default 500)")
    p.add_argument(
        "--duration", type=positive_float, default=10.0, help="seconds per run (default 10)"
    )
    p.add_argument("--seed", type=seed, default=0, help="random seed (default 0)")
    p.add_argument(
        "--engine",
        choices=("batched", "filterpy"),
        default="batched",
        help="filter engine (default batched)",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        type=output_folder,
        help="also write estimation.csv and estimation.png here",
    )
    return p
