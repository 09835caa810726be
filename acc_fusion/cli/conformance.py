"""``acc-fusion conformance``: the standard FCW test manoeuvres against the protocols'
requirements (exit 1 on failure).
"""

from __future__ import annotations

import argparse

import numpy as np

from acc_fusion.cli.common import (
    sim_config,
)
from acc_fusion.core.outputs import write_csv_atomic
from acc_fusion.core.table import Table
from acc_fusion.studies.compare import conformance


def run(args: argparse.Namespace) -> int:

    cfg = sim_config(args)
    out = args.out
    results = conformance(args.trials, cfg.seed, cfg, progress=True)
    rows = []
    for res in results:
        req = res.requirement
        for i, (ttc, ok) in enumerate(zip(res.ttc, res.passed, strict=True), start=1):
            rows.append(
                {
                    "manoeuvre": req.scenario,
                    "trial": i,
                    "ttc_at_warning_s": "no warning" if np.isnan(ttc) else f"{ttc:.2f}",
                    "required_ttc_s": f">= {req.required_ttc:g}",
                    "result": "pass" if ok else "FAIL",
                }
            )

    table = Table(
        f"FCW conformance: {args.trials} trials per manoeuvre, seed {cfg.seed}",
        ("manoeuvre", "trial", "ttc_at_warning_s", "required_ttc_s", "result"),
        rows,
    )
    print(table.format())
    print()
    for res in results:
        req = res.requirement
        verdict = "PASS" if res.ok else "FAIL"
        note = "" if req.verified else "  (requirement assumed, see acc_fusion.metrics.protocols)"
        print(
            f"{req.scenario:10s} {verdict}: {int(res.passed.sum())} of {len(res.passed)} trials "
            f"passed, {res.needed} needed ({req.protocol}: {req.test}){note}"
        )
    if out is not None:
        write_csv_atomic(out / "conformance.csv", table.columns, rows)
        print(f"wrote {out / 'conformance.csv'}")
    return 0 if all(r.ok for r in results) else 1
