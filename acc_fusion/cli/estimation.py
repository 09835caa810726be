"""``acc-fusion estimation``: every fusion method on the same car-following truth: RMSE,
NEES, cost per pair-step.
"""

from __future__ import annotations

import argparse

from acc_fusion.cli.common import (
    output_folder,
    positive_float,
    positive_int,
    seed,
)
from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic
from acc_fusion.core.plots import estimation_bars
from acc_fusion.studies.estimation import compare_methods


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``estimation`` command."""
    p = subparsers.add_parser(
        "estimation",
        help="compare federated fusion with its baselines (RMSE, NEES, cost)",
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


def run(args: argparse.Namespace) -> int:

    out = args.out
    table = compare_methods(
        n_runs=args.runs, duration=args.duration, seed=args.seed, engine=args.engine
    )
    print(table.format())
    if out is not None:
        write_csv_atomic(out / "estimation.csv", table.columns, table.rows)
        save_figure_atomic(estimation_bars(table), out / "estimation.png")
        print(f"wrote {out / 'estimation.csv'} and {out / 'estimation.png'}")
    return 0
