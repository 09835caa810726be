"""``acc-fusion compare``: radar, infrared, centralized and federated on the same randomised
runs: false alarms, misses, lead time; then collisions with FCW on and off.
"""

from __future__ import annotations

import argparse

from acc_fusion.cli.common import (
    sim_config,
    with_driver,
    write_summary,
)
from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic
from acc_fusion.core.plots import rates_figure
from acc_fusion.studies.compare import COMPARE_CLUTTER, compare


def run(args: argparse.Namespace) -> int:

    cfg = sim_config(args, scenario="random", radar=COMPARE_CLUTTER)
    if args.distraction is not None:
        cfg = with_driver(cfg, args.distraction, sees_threats=True)
    out = args.out
    comparison = compare(cfg, progress=True, drives=cfg.methods if args.all_drives else ())
    table, classes = comparison.table(), comparison.classes()
    print(table.format() + "\n\n" + classes.format())
    print("\n" + comparison.benefit_table().format())
    if out is not None:
        write_csv_atomic(out / "compare.csv", table.columns, table.rows)
        write_csv_atomic(out / "compare_classes.csv", classes.columns, classes.rows)
        c = comparison.collisions
        title = (
            f"{cfg.runs} randomised runs, 95% intervals; closed loop: {c['on']} collisions "
            f"with {c['drive']} alerts, {c['off']} without"
        )
        save_figure_atomic(rates_figure(comparison.result.summaries, title), out / "compare.png")
        print(f"wrote {out / 'compare.csv'}, {out / 'compare_classes.csv'}, {out / 'compare.png'}")
        write_summary(
            out,
            "compare.json",
            {
                "config": {"scenario": cfg.scenario, "runs": cfg.runs, "seed": cfg.seed},
                "collisions": comparison.collisions,
                "benefit": comparison.benefits[comparison.collisions["drive"]].as_dict(),
                "benefit_by_method": {m: b.as_dict() for m, b in comparison.benefits.items()},
                "methods": {m: s.as_dict() for m, s in comparison.result.summaries.items()},
            },
        )
    return 0
