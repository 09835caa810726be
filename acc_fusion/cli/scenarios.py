"""``acc-fusion scenarios export``: a test protocol written as OpenSCENARIO files with their
OpenDRIVE road (:func:`acc_fusion.studies.scenarios.export_protocol`), optionally checked by
ASAM's quality checkers; a summary table and the last line ``scenarios_written=N``."""

from __future__ import annotations

import argparse
from collections import Counter

from acc_fusion.core.table import Table
from acc_fusion.studies.scenarios import export_protocol, protocol_points
from acc_fusion.truth.openscenario.export import OSC_MINOR

#: Findings printed at most.
_SHOWN = 10


def run(args: argparse.Namespace) -> int:
    """Write the files (the only action, ``export``) and print what was written."""
    written = export_protocol(args.protocol, args.out, check=args.check)
    kinds = Counter(p.kind for p in protocol_points(args.protocol))
    report = written.check
    verdict = "-"
    if report is not None:
        verdict = (f"{'pass' if report.passed else 'FAIL'}: {len(report.findings)} issues "
                   f"({report.completed} checks run, {report.skipped} skipped)")  # fmt: skip
    rows = [{"protocol": args.protocol, "kind": kind, "points": n, "files": n, "checkers": ""}
            for kind, n in kinds.items()]  # fmt: skip
    rows.append({"protocol": args.protocol, "kind": "road (.xodr)", "points": "", "files": 1,
                 "checkers": ""})  # fmt: skip
    rows.append({"protocol": args.protocol, "kind": "total", "points": len(written.scenarios),
                 "files": len(written.scenarios) + 1, "checkers": verdict})  # fmt: skip
    table = Table(
        f"OpenSCENARIO XML 1.{OSC_MINOR} and OpenDRIVE 1.8 files in {written.folder}",
        ("protocol", "kind", "points", "files", "checkers"),
        rows,
        ["one .xosc per test point, all referencing the one .xodr test track; checkers: "
         "asam-qc-openscenarioxml and asam-qc-opendrive (--check)"],
    )  # fmt: skip
    print(table.format())
    if report is not None:
        for f in report.findings[:_SHOWN]:
            print(f"{f.file}: {f.checker}: {f.description}")
    print(f"scenarios_written={len(written.scenarios)}")
    return 0 if report is None or report.passed else 1
