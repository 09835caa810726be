"""``acc-fusion sweep``: a Monte Carlo sweep from a TOML/YAML file, resumable, with ROC curves and
a report.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from acc_fusion.cli.common import output_folder, positive_int
from acc_fusion.core.outputs import output_dir
from acc_fusion.core.table import Table
from acc_fusion.sweep.aggregate import aggregate, formatted
from acc_fusion.sweep.config import load_sweep
from acc_fusion.sweep.executors import EXECUTORS
from acc_fusion.sweep.run import run_sweep


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``sweep`` command to the ``acc-fusion`` sub-parsers."""

    p = subparsers.add_parser(
        "sweep",
        help="Monte Carlo sweep over sensors, faults, fusion and warning settings (resumable)",
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


def run(args: argparse.Namespace) -> int:
    """``acc-fusion sweep``: run (or resume) the sweep and print the per-method table."""

    cfg = load_sweep(args.config)
    out = args.out or output_dir(Path("out") / f"sweep_{cfg.name}")
    result = run_sweep(cfg, out, executor=args.executor, workers=args.workers, address=args.address)
    methods = aggregate(result.rows, ["method"])
    rows = formatted(methods)
    table = Table(
        f"sweep {cfg.name!r}: {len(cfg.points())} points x {len(cfg.seeds)} seeds x "
        f"{cfg.runs} runs, 95% intervals",
        list(rows[0]) if rows else ["method"],
        rows,
    )
    table.notes.append(
        f"ran {result.ran_chunks} chunks ({result.ran_runs} runs, {result.runs_per_s:.1f} runs/s); "
        f"{result.skipped_chunks} were already done"
    )
    print(table.format())
    for path in result.files:
        print(f"wrote {path}")
    return 0
