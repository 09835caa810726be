"""``acc-fusion conformance``: the standard FCW test manoeuvres against the protocols'
requirements, FMVSS 127's AEB tests and Euro NCAP's AEB Car-to-Car rating (exit 1 on failure).
"""

from __future__ import annotations

import argparse

import numpy as np

from acc_fusion.cli.common import (
    sim_config,
)
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import output_dir, write_csv_atomic
from acc_fusion.core.table import Table
from acc_fusion.core.units import KMH, G
from acc_fusion.metrics.euroncap import plot_grid, rating_sheet
from acc_fusion.studies.aeb_tests import euroncap_aeb, fmvss127
from acc_fusion.studies.compare import conformance


def run(args: argparse.Namespace) -> int:
    """Run ``--protocol``: print its table and verdicts (exit 1 when a test fails)."""
    cfg = sim_config(args)
    if args.protocol == "fmvss127":
        return run_fmvss127(cfg, args.trials or 3, args.out)
    if args.protocol == "euroncap-aeb":
        if args.trials is not None:
            raise ConfigError("euroncap-aeb runs each grid point once; drop --trials")
        return run_euroncap(cfg, args.out)
    trials = args.trials or 7
    out = args.out
    results = conformance(trials, cfg.seed, cfg, progress=True)
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
        f"FCW conformance: {trials} trials per manoeuvre, seed {cfg.seed}",
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


def _num(x: float, unit: float = 1.0, digits: int = 1) -> str:
    return "-" if np.isnan(x) else f"{x / unit:.{digits}f}"


def run_fmvss127(cfg, trials: int, out) -> int:
    """``--protocol fmvss127``: every test point with its trials, pass/fail and the figure
    behind it; the last line ``fmvss127_passed=<passed>/<total>``."""
    result = fmvss127(cfg, trials, progress=True)
    rows = []
    for i, point in enumerate(result.points):
        for k, t in enumerate(result.trials[i], start=1):
            if t.false_activation_test:
                figure = f"AEB additional decel {t.peak_additional / G:.2f} g (limit < 0.25 g)"
            elif t.contact:
                figure = f"contact at {t.closing_speed / KMH:.1f} km/h closing"
            else:
                figure = "no contact"
            rows.append({
                "test": point.label, "trial": k, "fcw_ttc_s": _num(t.fcw_ttc, digits=2),
                "aeb_at_kmh": _num(t.speed_at_aeb, KMH), "peak_aeb_g": f"{t.peak_decel / G:.2f}",
                "figure": figure, "result": "pass" if t.passed else "FAIL",
            })  # fmt: skip
    method = cfg.methods[-1]
    table = Table(
        f"FMVSS 127 (49 CFR 571.127, 89 FR 39686 and 89 FR 93199): {trials} trials per test "
        f"point, AEB on the {method} estimate, 2-D world, seed {cfg.seed}",
        ("test", "trial", "fcw_ttc_s", "aeb_at_kmh", "peak_aeb_g", "figure", "result"),
        rows,
        ["a test point passes when every trial passes: no contact (lead vehicle tests), AEB "
         "braking beyond the manual braking below 0.25 g (false-activation tests)"],
    )  # fmt: skip
    print(table.format())
    if out is not None:
        folder = output_dir(out)
        write_csv_atomic(folder / "fmvss127.csv", table.columns, rows)
        print(f"wrote {folder / 'fmvss127.csv'}")
    total = len(result.points)
    print(f"fmvss127_passed={result.passed}/{total}")
    return 0 if result.passed == total else 1


def run_euroncap(cfg, out) -> int:
    """``--protocol euroncap-aeb``: the rating sheet, the grid figure with ``--out``; the last
    line ``euroncap_aeb_score=<points>/<max>``."""
    result = euroncap_aeb(cfg, progress=True)
    sheet = rating_sheet(result.points, result.impact_speeds)
    sheet.title += f", AEB on the {cfg.methods[-1]} estimate, 2-D world, seed {cfg.seed}"
    print(sheet.format())
    if out is not None:
        folder = output_dir(out)
        write_csv_atomic(folder / "euroncap_aeb.csv", sheet.columns, sheet.rows)
        plot_grid(result.points, result.impact_speeds, folder / "euroncap_aeb.png")
        print(f"wrote {folder / 'euroncap_aeb.csv'} and {folder / 'euroncap_aeb.png'}")
    s = result.score
    print(f"euroncap_aeb_score={s.total:.3f}/{s.maximum:g}")
    return 0
