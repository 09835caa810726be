"""``acc-fusion sweep``: a Monte Carlo sweep from a TOML/YAML file, resumable, with ROC curves and
a report.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from acc_fusion.core.table import Table
from acc_fusion.sweep.aggregate import aggregate, formatted
from acc_fusion.sweep.config import load_sweep
from acc_fusion.sweep.run import run_sweep


def run(args: argparse.Namespace) -> int:
    """``acc-fusion sweep``: run (or resume) the sweep and print the per-method table."""

    cfg = load_sweep(args.config)
    out = Path(args.out or Path("out") / f"sweep_{cfg.name}")
    result = run_sweep(cfg, out, executor=args.executor, workers=args.workers, address=args.address)
    if result.damaged:
        damaged = ", ".join(result.damaged)
        print(
            f"acc-fusion: warning: {out} held damaged files, recovered: {damaged}", file=sys.stderr
        )
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
