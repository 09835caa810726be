"""``acc-fusion estimation``: every fusion method on the same car-following truth: RMSE,
NEES, cost per pair-step.
"""

from __future__ import annotations

import argparse

from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic
from acc_fusion.core.plots import estimation_bars
from acc_fusion.studies.estimation import compare_methods


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
