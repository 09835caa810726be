"""``acc-fusion run``: one scenario, closed loop; the summary per method, a PNG, the trace CSV
and a JSON summary.
"""

from __future__ import annotations

import argparse

import numpy as np

from acc_fusion.cli.common import (
    sim_config,
    write_summary,
)
from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic
from acc_fusion.core.plots import run_figure
from acc_fusion.sim.closed_loop import simulate
from acc_fusion.sim.hooks import Trace


def run(args: argparse.Namespace) -> int:

    cfg = sim_config(args, runs=1, drive="federated", methods=("radar", "infrared", "federated"))
    out = args.out
    trace = Trace(cfg.warning)
    result = simulate(cfg, progress=True, on_step=trace)
    for method, summary in result.summaries.items():
        print(f"== {method}{' (drives the closed loop)' if method == cfg.drive else ''}")
        print(summary.format())
    hit = np.flatnonzero(result.collided)
    which = f" (run {', '.join(map(str, hit))})" if 0 < hit.size <= 10 else ""
    print(f"collisions: {hit.size} of {cfg.runs} runs{which}")
    stem = f"run_{cfg.scenario}_seed{cfg.seed}"
    write_csv_atomic(out / f"{stem}.csv", list(trace.rows[0]), trace.rows)
    save_figure_atomic(run_figure(trace, cfg), out / f"{stem}.png")
    print(f"wrote {out / (stem + '.csv')} and {out / (stem + '.png')}")
    write_summary(
        out,
        f"{stem}.json",
        {
            "scenario": cfg.scenario,
            "seed": cfg.seed,
            "runs": cfg.runs,
            "drive": cfg.drive,
            "collisions": int(result.collided.sum()),
            "methods": {m: s.as_dict() for m, s in result.summaries.items()},
        },
    )
    return 0
