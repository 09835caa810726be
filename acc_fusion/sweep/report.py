r"""The report of a sweep: ROC/DET curves per method, the fault-type breakdown, tables.

:func:`write_report` reads the rows of :func:`acc_fusion.sweep.run.run_sweep` and writes into the
sweep's output folder:

``roc.png``
    Per method, the operating points of the warning as the threshold axis varies
    (``report.threshold``; by default the first ``warning.*`` axis), pooled over every other
    axis (or split by ``report.curves_by``).  Left, ROC: detection rate
    :math:`1 - \text{miss rate}` against false alarms per hour, with the 95 % intervals of both;
    right, DET: miss rate against false alarms per hour on logarithmic axes (zero drawn at the
    lower limit), where good operating points sit at the lower left.  Without a threshold axis
    each sweep point is a separate operating point (markers, no lines).
``faults.png``, ``faults.csv``
    False alarms per hour and miss rate per injected fault type (``fault`` column) and method.
``report.md`` or ``report.html``
    The sweep's size, the per-method table pooled over the sweep, the curves, the operating
    points, and the fault breakdown, with 95 % intervals (exact Poisson for rates per hour,
    Wilson for the miss rate).
"""

from __future__ import annotations

import html
import math
from pathlib import Path

import numpy as np

from acc_fusion.core import plots
from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic, write_text_atomic
from acc_fusion.sweep.aggregate import aggregate, formatted
from acc_fusion.sweep.config import SweepConfig

#: Floor of the DET plot's logarithmic axes: zero false alarms per hour / zero misses.
DET_FLOOR = (1e-2, 1e-3)


def threshold_axis(cfg: SweepConfig) -> str | None:
    """The axis the ROC curves follow: ``report.threshold``, else the first ``warning.*`` axis."""
    if cfg.report.threshold is not None:
        return cfg.report.threshold
    return next((a.key for a in cfg.axes if a.key.startswith("warning.")), None)


def operating_points(cfg: SweepConfig, rows):
    """The ROC table: per method (and ``curves_by`` value), one row per threshold value (or per
    point without a threshold axis), pooled over every other axis; sorted by threshold."""
    threshold = threshold_axis(cfg)
    split = [cfg.report.curves_by] if cfg.report.curves_by else []
    along = [threshold] if threshold else ["point_id"]
    return aggregate(rows, ["method", *split, *along])


def roc_figure(cfg: SweepConfig, table):
    """ROC (detection rate vs false alarms per hour) and DET (miss rate vs false alarms per
    hour, log-log) curves per method, from :func:`operating_points`."""
    plt = plots.pyplot()

    threshold = threshold_axis(cfg)
    split = cfg.report.curves_by
    fig, (roc, det) = plt.subplots(1, 2, figsize=(12, 4.8))
    styles = ("-", "--", ":", "-.")
    groups = ["method", split] if split else ["method"]
    for i, (key, g) in enumerate(table.groupby(groups, sort=True)):
        key = key if isinstance(key, tuple) else (key,)
        label = key[0] if not split else f"{key[0]}, {split} = {key[1]}"
        style = (styles[i % len(styles)] if split else "-") if threshold else "none"
        g = g.sort_values(threshold) if threshold else g
        x, miss = g["fa_per_hour"].to_numpy(float), g["miss_rate"].to_numpy(float)
        xerr = [x - g["fa_per_hour_lo"], g["fa_per_hour_hi"] - x]
        yerr = [g["miss_rate_hi"] - miss, miss - g["miss_rate_lo"]]
        kw = {
            "color": plots.method_color(key[0]),
            "ls": style,
            "marker": "o",
            "ms": 4,
            "label": label,
        }
        roc.errorbar(x, 1.0 - miss, xerr=xerr, yerr=yerr, capsize=2, lw=1.2, **kw)
        det.plot(np.maximum(x, DET_FLOOR[0]), np.maximum(miss, DET_FLOOR[1]), **kw)
        if threshold:
            for xi, yi, t in zip(x, miss, g[threshold], strict=True):
                det.annotate(
                    f"{t:g}" if isinstance(t, (int, float)) else str(t),
                    (max(xi, DET_FLOOR[0]), max(yi, DET_FLOOR[1])),
                    fontsize=6,
                    xytext=(3, 3),
                    textcoords="offset points",
                )
    roc.set_xlabel("false alarms per hour")
    roc.set_ylabel("detection rate (1 - miss rate)")
    roc.set_title("ROC (95% intervals)", fontsize=10)
    det.set_xscale("log")
    det.set_yscale("log")
    det.set_xlabel(f"false alarms per hour (0 drawn at {DET_FLOOR[0]:g})")
    det.set_ylabel(f"miss rate (0 drawn at {DET_FLOOR[1]:g})")
    det.set_title("DET" + (f", labels: {threshold}" if threshold else ""), fontsize=10)
    for ax in (roc, det):
        ax.grid(alpha=0.3, which="both")
    roc.legend(fontsize=7)
    along = f"as {threshold} varies" if threshold else "one marker per sweep point"
    fig.suptitle(f"sweep {cfg.name!r}: operating points per method, {along}", fontsize=10)
    fig.tight_layout()
    return fig


def fault_figure(cfg: SweepConfig, table):
    """False alarms per hour and miss rate per fault type (groups) and method (bars)."""
    plt = plots.pyplot()

    faults = list(dict.fromkeys(table["fault"]))
    methods = list(dict.fromkeys(table["method"]))
    width = 0.8 / len(methods)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    for ax, col, label in (
        (axes[0], "fa_per_hour", "false alarms per hour"),
        (axes[1], "miss_rate", "miss rate (missed / threats)"),
    ):
        for j, m in enumerate(methods):
            g = table[table["method"] == m].set_index("fault").reindex(faults)
            v = g[col].to_numpy(float)
            err = np.array([v - g[f"{col}_lo"], g[f"{col}_hi"] - v])
            x = np.arange(len(faults)) + (j - (len(methods) - 1) / 2) * width
            ax.bar(x, v, width, yerr=err, capsize=3, color=plots.method_color(m), label=m)
        ax.set_xticks(np.arange(len(faults)), faults, rotation=20, ha="right", fontsize=8)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"sweep {cfg.name!r}: by injected fault type (95% intervals)", fontsize=10)
    fig.tight_layout()
    return fig


# --------------------------------------------------------------------------------------------
# Documents: a list of blocks rendered as Markdown or HTML
# --------------------------------------------------------------------------------------------


def _cell(v: object) -> str:
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def _markdown(blocks: list[tuple]) -> str:
    out = []
    for kind, *body in blocks:
        if kind == "h":
            out.append(f"{'#' * body[1]} {body[0]}")
        elif kind == "p":
            out.append(body[0])
        elif kind == "img":
            out.append(f"![{body[1]}]({body[0]})")
        else:
            columns, rows = body
            lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
            lines += ["| " + " | ".join(_cell(r.get(c, "")) for c in columns) + " |" for r in rows]
            out.append("\n".join(lines))
    return "\n\n".join(out) + "\n"


def _html(blocks: list[tuple], title: str) -> str:
    esc = html.escape
    out = [
        "<!DOCTYPE html>",
        f'<html><head><meta charset="utf-8"><title>{esc(title)}</title>',
        "<style>body{font-family:sans-serif;max-width:72em;margin:auto}"
        "table{border-collapse:collapse;font-size:90%}"
        "td,th{border:1px solid #bbb;padding:2px 6px}img{max-width:100%}</style>",
        "</head><body>",
    ]
    for kind, *body in blocks:
        if kind == "h":
            out.append(f"<h{body[1]}>{esc(body[0])}</h{body[1]}>")
        elif kind == "p":
            out.append(f"<p>{esc(body[0])}</p>")
        elif kind == "img":
            out.append(f'<p><img src="{esc(body[0])}" alt="{esc(body[1])}"></p>')
        else:
            columns, rows = body
            head = "".join(f"<th>{esc(c)}</th>" for c in columns)
            cells = (
                "<tr>" + "".join(f"<td>{esc(_cell(r.get(c, '')))}</td>" for c in columns) + "</tr>"
                for r in rows
            )
            out.append(f"<table><tr>{head}</tr>{''.join(cells)}</table>")
    return "\n".join([*out, "</body></html>"]) + "\n"


def _table_block(table) -> tuple:
    rows = formatted(table)
    columns = list(rows[0]) if rows else list(table.columns)
    return ("table", columns, rows)


def write_report(cfg: SweepConfig, rows, out: str | Path) -> list[Path]:
    """Write ``roc.png``, ``faults.png``/``faults.csv`` and ``report.md`` (or ``.html``)."""
    out = Path(out)
    written = []
    points = len(cfg.points())
    summary = (
        f"{points} points x {len(cfg.seeds)} seeds x {cfg.runs} runs = {cfg.total_runs} runs "
        f"of the {cfg.source} source, in chunks of up to {cfg.chunk_runs} runs; methods: "
        f"{', '.join(sorted(set(rows['method'])))}. Rates with 95% intervals: false alarms per "
        "hour and per 100 km exact Poisson (Garwood), miss rate and false-alarm ratio Wilson. "
        "Every run's row is in runs.parquet, the table per point in summary.csv."
    )
    blocks: list[tuple] = [("h", f"Sweep {cfg.name!r}", 1), ("p", summary)]
    blocks += [("h", "All runs, per method", 2), _table_block(aggregate(rows, ["method"]))]

    table = operating_points(cfg, rows)
    save_figure_atomic(roc_figure(cfg, table), out / "roc.png")
    written.append(out / "roc.png")
    threshold = threshold_axis(cfg)
    blocks += [
        ("h", "ROC and DET curves", 2),
        ("img", "roc.png", "ROC and DET curves"),
        (
            "p",
            f"Operating points per method as {threshold} varies, pooled over the other axes."
            if threshold
            else "No warning-threshold axis: one operating point per sweep point.",
        ),
        _table_block(table),
    ]

    faults = aggregate(rows, ["fault", "method"])
    written.append(
        write_csv_atomic(out / "faults.csv", list(faults.columns), faults.to_dict("records"))
    )
    save_figure_atomic(fault_figure(cfg, faults), out / "faults.png")
    written.append(out / "faults.png")
    blocks += [
        ("h", "By injected fault type", 2),
        ("img", "faults.png", "false alarms and misses per fault type"),
        _table_block(faults),
    ]

    if cfg.report.format == "html":
        path = write_text_atomic(out / "report.html", _html(blocks, f"Sweep {cfg.name}"))
    else:
        path = write_text_atomic(out / "report.md", _markdown(blocks))
    return [*written, path]
