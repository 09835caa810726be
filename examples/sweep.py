"""A Monte Carlo sweep: false alarms and misses over a grid of warning settings and clutter.

Every point of the grid runs the scripted suite ``runs`` times on local worker processes; the
rows are stored as Parquet parts (an interrupted sweep resumes), then pooled with exact
intervals.  Run it:

    python examples/sweep.py --out out/example_sweep
"""

from __future__ import annotations

import argparse

from acc_fusion.core.table import Table
from acc_fusion.sweep.aggregate import aggregate, formatted
from acc_fusion.sweep.config import SweepConfig
from acc_fusion.sweep.run import run_sweep


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="out/example_sweep", help="output folder")
    parser.add_argument("--runs", type=int, default=100, help="runs per point (default 100)")
    args = parser.parse_args(argv)

    cfg = SweepConfig.from_mapping(
        {
            "name": "example",
            "runs": args.runs,
            "chunk_runs": args.runs,
            "base": {"scenario": "random", "duration": 10.0, "methods": ["radar", "federated"]},
            "axes": {"warning.z": [0.0, 2.0], "radar.ghost_rate": [0.0, 0.2]},
        }
    )
    result = run_sweep(cfg, args.out, progress=False, report=False)
    rows = formatted(aggregate(result.rows, ["method", "warning.z", "radar.ghost_rate"]))
    columns = ["method", "warning.z", "radar.ghost_rate", "runs", "fa_per_hour", "miss_rate"]
    print(Table(f"sweep {cfg.name!r}: {len(rows)} groups, 95% intervals", columns, rows).format())


if __name__ == "__main__":
    main()
