"""Fault tolerance: federated fusion with fault isolation against the centralized filter.

Prints the table of :func:`acc_fusion.studies.estimation.fault_tolerance`: car following (radar 20
Hz,
infrared 10 Hz, 10 s runs) with each fault of :data:`acc_fusion.studies.estimation.FAULT_SCENARIOS`
active from 3 s to 8 s; per fault and method, the fused-gap RMSE, its ratio to the same
method's healthy RMSE and how often the chi-square test isolated a sensor.  With ``--plot``,
writes a grouped bar chart of the ratios (log scale, 1.5 marked).

    python scripts/fault_tolerance.py --runs 200 --seed 0 --plot out/fault_tolerance.png
"""

from __future__ import annotations

import numpy as np

from acc_fusion.cli.common import study_parser
from acc_fusion.core.outputs import save_figure_atomic
from acc_fusion.core.table import Table
from acc_fusion.studies.estimation import fault_tolerance

#: Ratio to the healthy RMSE marked on the plot (a fault-tolerant method stays below it).
TOLERATED_RATIO = 1.5


def plot(table: Table, path: str) -> None:
    """Write a PNG: one group of bars per fault, one bar per method, ratio to healthy."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    faults = list(dict.fromkeys(r["fault"] for r in table.rows))
    methods = list(dict.fromkeys(r["method"] for r in table.rows))
    width = 0.8 / len(methods)
    x = np.arange(len(faults))
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ratio = {(r["fault"], r["method"]): r["ratio_to_healthy"] for r in table.rows}
    for i, method in enumerate(methods):
        ratios = [ratio[f, method] for f in faults]
        bars = ax.bar(x + (i - (len(methods) - 1) / 2) * width, ratios, width, label=method)
        ax.bar_label(bars, fmt="%.3g", fontsize=8)
    ax.axhline(TOLERATED_RATIO, color="k", ls="--", lw=1, label=f"{TOLERATED_RATIO:g}× healthy")
    ax.set_yscale("log")
    ax.set_ylim(bottom=0.5)  # so that the healthy bars (ratio 1) show
    ax.set_xticks(x, faults)
    ax.set_xlabel("fault (active 3-8 s)")
    ax.set_ylabel("fused gap RMSE / healthy RMSE")
    ax.set_title(table.title, fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure_atomic(fig, path)


def main(argv: list[str] | None = None) -> None:
    parser = study_parser(__doc__, runs=200, plot_help="write a bar chart of the ratios here")
    args = parser.parse_args(argv)
    table = fault_tolerance(n_runs=args.runs, seed=args.seed)
    print(table.format())
    if args.plot:
        plot(table, args.plot)
        print(f"plot written to {args.plot}")


if __name__ == "__main__":
    main()
