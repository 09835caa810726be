"""Aggregation of a sweep's rows by any columns: summed counts and exposure, rates with exact
Poisson and Wilson intervals (:func:`aggregate`), their printable form and the CSV tables."""

from __future__ import annotations

import math
from pathlib import Path

from acc_fusion.core.outputs import write_csv_atomic
from acc_fusion.metrics.stats import Rate
from acc_fusion.metrics.summary import ALERT_CLASSES, CAUSE_COUNTS, event_rates
from acc_fusion.sweep.columns import COUNT_COLUMNS, SUM_COLUMNS
from acc_fusion.sweep.config import SweepConfig


def aggregate(rows, by: list[str], confidence: float = 0.95):
    """Pool the runs of ``rows`` (a DataFrame of :func:`run_sweep`) by the columns ``by``.

    Returns a DataFrame with ``by``, ``runs``, the summed counts (the nuisance and
    sensing-false warnings by cause too) and exposure, and per group
    false alarms and each alert class per 100 km (and false alarms per hour; exact Poisson
    intervals), miss rates and false-alarm ratio (Wilson intervals) as ``<name>``,
    ``<name>_lo``, ``<name>_hi``, and the mean lead time [s] of the detected threats.
    """
    import pandas as pd

    sums = rows.groupby(by, sort=True, dropna=False)[[*COUNT_COLUMNS, *SUM_COLUMNS]].sum()
    sums.insert(0, "runs", rows.groupby(by, sort=True, dropna=False)["run_id"].nunique())
    out = []
    for key, g in sums.iterrows():
        counts = {c: int(g[c]) for c in COUNT_COLUMNS}
        rates = event_rates(counts, float(g["hours"]), float(g["km"]), confidence)
        rec = dict(zip(by, key if isinstance(key, tuple) else (key,), strict=True))
        rec |= {"runs": int(g["runs"]), **counts, "hours": g["hours"], "km": g["km"]}
        for short, r in _rate_columns(rates).items():
            rec |= {short: r.value, f"{short}_lo": r.lo, f"{short}_hi": r.hi}
        rec["lead_time_mean_s"] = (
            g["lead_time_sum_s"] / g["detected"] if g["detected"] else math.nan
        )
        out.append(rec)
    return pd.DataFrame(out)


#: Rate of :func:`acc_fusion.metrics.summary.event_rates` -> column name in :func:`aggregate`.
_RATE_COLUMNS = {
    "false_alarms_per_hour": "fa_per_hour",
    "false_alarms_per_100km": "fa_per_100km",
    "miss_rate": "miss_rate",
    "false_alarm_ratio": "false_alarm_ratio",
    "relevant_miss_rate": "relevant_miss_rate",
}
#: The alert classes' rates per 100 km, one column each.
_CLASS_COLUMNS = tuple(f"{c}_per_100km" for c in ALERT_CLASSES)


def _rate_columns(rates: dict) -> dict[str, Rate]:
    """The rates of :func:`event_rates` by column name (the alert classes per 100 km too)."""
    out = {short: rates[name] for name, short in _RATE_COLUMNS.items()}
    return out | {f"{c}_per_100km": rates["alerts_per_100km"][c] for c in ALERT_CLASSES}


def formatted(table) -> list[dict]:
    """Rows of an :func:`aggregate` table for reading: each rate as ``"value [lo, hi]"`` (the
    counts by cause are left to the CSV tables)."""

    keep = [c for c in table.columns if not c.endswith(("_lo", "_hi"))]
    out = []
    for rec in table.to_dict("records"):
        row = {}
        for c in keep:
            if c in _RATE_COLUMNS.values() or c in _CLASS_COLUMNS:
                row[c] = Rate(rec[c], rec[f"{c}_lo"], rec[f"{c}_hi"]).format()
            elif c == "missed":
                row[c] = f"{rec['missed']}/{rec['threats']}"
            elif c == "relevant_missed":
                row[c] = f"{rec['relevant_missed']}/{rec['relevant']}"
            elif c not in ("threats", "detected", "relevant", "relevant_detected", *CAUSE_COUNTS):
                row[c] = rec[c]
        out.append(row)
    return out


def write_tables(cfg: SweepConfig, rows, out: Path) -> list[Path]:
    """``summary.csv`` (per point and method) and ``methods.csv`` (per method, pooled)."""

    written = []
    axes = [a.key for a in cfg.axes]
    for name, by in (("summary", [*axes, "fault", "method"]), ("methods", ["method"])):
        table = aggregate(rows, by)
        written.append(
            write_csv_atomic(out / f"{name}.csv", list(table.columns), table.to_dict("records"))
        )
    return written
