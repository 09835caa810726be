"""A Monte Carlo sweep from a config file: false alarms and misses over a grid of settings.

A sweep config (TOML or YAML, like ``scripts/sweeps/quick.toml``: radar clutter x warning
margin, the randomised scripted suite, all four methods) names the axes of a grid over
:class:`acc_fusion.sim.closed_loop.SimConfig` fields.  Every point runs ``runs`` Monte Carlo
runs on two local worker processes; the rows are stored in Parquet parts under ``--out`` (an
interrupted sweep resumes where it stopped), then pooled per point and method with exact 95%
intervals.  ``acc-fusion sweep`` does the same and also writes ROC/DET curves and a report.
Run it:

    python examples/sweep.py                                # quick.toml with 100 runs a point
    python examples/sweep.py scripts/sweeps/roc.toml --runs 500 --out out/roc
"""

from __future__ import annotations

import argparse
from pathlib import Path

from acc_fusion.core.config import load_mapping
from acc_fusion.core.table import Table
from acc_fusion.sweep.aggregate import aggregate, formatted
from acc_fusion.sweep.config import SweepConfig
from acc_fusion.sweep.run import run_sweep

QUICK = Path(__file__).resolve().parent.parent / "scripts" / "sweeps" / "quick.toml"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("config", nargs="?", default=str(QUICK), help="sweep config file")
    parser.add_argument("--runs", type=int, default=100, help="runs per point and seed (100)")
    parser.add_argument("--out", help="output folder (default out/example_sweep_<name>)")
    args = parser.parse_args(argv)

    # The file's settings, with fewer runs (one chunk each: one batched call per point).
    data = load_mapping(args.config) | {"runs": args.runs, "chunk_runs": args.runs}
    cfg = SweepConfig.from_mapping(data)
    out = args.out or f"out/example_sweep_{cfg.name}"
    result = run_sweep(cfg, out, workers=2, progress=False, report=False)

    axes = [axis.key for axis in cfg.axes]
    rows = formatted(aggregate(result.rows, [*axes, "method"]))
    columns = [*axes, "method", "runs", "false_alarms", "fa_per_hour", "missed", "miss_rate"]
    title = f"sweep {cfg.name!r}: {len(cfg.points())} points x {cfg.runs} runs, 95% intervals"
    print(Table(title, columns, rows).format())
    print(f"rows of every run: {Path(out) / 'runs.parquet'}")


if __name__ == "__main__":
    main()
