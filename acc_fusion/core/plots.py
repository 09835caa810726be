"""Figures (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

from functools import cache

import numpy as np


@cache
def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (no display needed), imported on the first
    figure: the import takes half a second that a run without figures need not pay."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def estimation_bars(table):
    """Bar chart of gap and range-rate RMSE per method, from :func:`studies.compare_methods`."""
    plt = pyplot()
    labels = [r["method"] for r in table.rows]
    y = np.arange(len(labels))
    fig, axes = plt.subplots(1, 3, figsize=(13, 0.45 * len(labels) + 1.5), sharey=True)
    for ax, key, title in zip(
        axes,
        ("rmse_gap_m", "rmse_rate_mps", "mean_nees"),
        ("gap RMSE [m]", "range-rate RMSE [m/s]", "mean NEES (3 = consistent)"),
        strict=True,
    ):
        values = [r[key] for r in table.rows]
        ax.barh(y, values, color="tab:blue")
        ax.set_title(title)
        ax.grid(axis="x", alpha=0.3)
    axes[2].axvline(3.0, color="k", ls="--", lw=1)
    axes[0].set_yticks(y, labels)
    axes[0].invert_yaxis()
    fig.suptitle(table.title, fontsize=10)
    fig.tight_layout()
    return fig


#: The colour of each sensor and method in every figure.
METHOD_COLORS = {
    "radar": "tab:blue",
    "infrared": "tab:orange",
    "centralized": "tab:purple",
    "federated": "tab:green",
    "plain": "tab:gray",
}


def method_color(method: str) -> str:
    """The colour of ``method`` (red for a method without one of its own)."""
    return METHOD_COLORS.get(method, "tab:red")


def _column(rows, key):
    return np.array([r.get(key, np.nan) for r in rows], dtype=float)


def run_figure(trace, config):
    """One run: gap (truth, sensors, local and fused estimates, safety distance), range-rate,
    and the warning levels of the driving method and of the oracle."""
    plt = pyplot()
    rows = trace.rows
    t = _column(rows, "t")
    fig, (ax_g, ax_r, ax_w) = plt.subplots(
        3, 1, sharex=True, figsize=(10, 9), gridspec_kw={"height_ratios": [3, 2, 1.3]}
    )
    ax_g.plot(t, _column(rows, "gap"), "k-", lw=2, label="true gap")
    for sensor in ("radar", "infrared"):
        ax_g.plot(
            t,
            _column(rows, f"{sensor}_range"),
            ".",
            ms=3,
            color=METHOD_COLORS[sensor],
            alpha=0.6,
            label=f"{sensor} measurement",
        )
        ax_r.plot(
            t,
            _column(rows, f"{sensor}_range_rate"),
            ".",
            ms=3,
            color=METHOD_COLORS[sensor],
            alpha=0.6,
            label=f"{sensor} measurement",
        )
    for method in config.methods:
        gap, std = _column(rows, f"{method}_gap"), _column(rows, f"{method}_gap_std")
        color = method_color(method)
        fused = method not in ("radar", "infrared")
        ax_g.plot(
            t,
            gap,
            "-" if fused else "--",
            color=color,
            lw=1.8 if fused else 1.0,
            label=f"{method} estimate",
        )
        if fused:
            ax_g.fill_between(
                t, gap - 2 * std, gap + 2 * std, color=color, alpha=0.25, label=f"{method} ±2σ"
            )
    ax_g.plot(
        t,
        _column(rows, "d_caution"),
        ":",
        color="goldenrod",
        lw=1.5,
        label="safety distance, caution",
    )
    ax_g.plot(
        t,
        _column(rows, "d_imminent"),
        ":",
        color="crimson",
        lw=1.5,
        label="safety distance, imminent",
    )
    ax_g.set_ylabel("gap [m]")
    top = np.nanmax(np.concatenate([_column(rows, "gap"), _column(rows, "d_caution")]))
    ax_g.set_ylim(bottom=0, top=1.15 * top if np.isfinite(top) else None)
    ax_g.legend(fontsize=7, ncol=3, loc="upper right")
    ax_r.plot(t, _column(rows, "range_rate"), "k-", lw=2, label="true range-rate")
    ax_r.set_ylabel("range-rate [m/s]")
    ax_r.legend(fontsize=7, loc="lower left")
    drive = config.drive or config.methods[-1]
    level = _column(rows, f"{drive}_level")
    for value, color, name in ((1, "goldenrod", "caution"), (2, "crimson", "imminent")):
        ax_w.fill_between(
            t,
            0,
            1,
            where=level >= value,
            step="post",
            color=color,
            alpha=0.5,
            transform=ax_w.get_xaxis_transform(),
            label=f"{drive}: {name}",
        )
    ax_w.step(
        t,
        _column(rows, "oracle_level"),
        where="post",
        color="k",
        lw=1.2,
        label="oracle level (truth)",
    )
    ax_w.set_yticks([0, 1, 2], ["none", "caution", "imminent"])
    ax_w.set_ylabel("warning")
    ax_w.set_xlabel("time [s]")
    speed = ax_w.twinx()
    speed.plot(t, _column(rows, "ego_speed"), color="tab:cyan", lw=1, label="ego speed")
    speed.set_ylabel("ego speed [m/s]", color="tab:cyan")
    ax_w.legend(fontsize=7, loc="upper left", ncol=3)
    fig.suptitle(
        f"{config.scenario}, seed {config.seed}, run {trace.run}: "
        f"{drive} alerts drive the closed loop",
        fontsize=10,
    )
    fig.tight_layout()
    return fig


def rates_figure(summaries, title: str):
    """False alarms per hour and miss rate of every method, with their 95 % intervals."""
    plt = pyplot()
    names = list(summaries)
    x = np.arange(len(names))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, attr, label in (
        (axes[0], "false_alarms_per_hour", "false alarms per hour"),
        (axes[1], "miss_rate", "miss rate (missed / threats)"),
    ):
        rates = [getattr(summaries[m], attr) for m in names]
        values = np.array([r.value for r in rates])
        err = np.array([[r.value - r.lo for r in rates], [r.hi - r.value for r in rates]])
        ax.bar(x, values, color=[method_color(m) for m in names], yerr=err, capsize=5)
        ax.set_xticks(x, names)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
        for xi, v in zip(x, values, strict=True):
            ax.annotate(
                f"{v:.3g}",
                (xi, v),
                ha="center",
                va="bottom",
                fontsize=8,
                xytext=(0, 2),
                textcoords="offset points",
            )
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def warning_frame(history, title: str = "") -> np.ndarray:
    """An RGB image of the recent fused gap, the imminent safety distance and the warning.

    ``history`` holds ``(t, fused gap, imminent distance, warning level)`` tuples.
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.2), dpi=80)
    if history:
        t, gap, d, level = (np.array(c, dtype=float) for c in zip(*history, strict=True))
        ax.plot(t, gap, color="tab:green", lw=2, label="fused gap")
        ax.plot(t, d, ":", color="crimson", lw=1.5, label="safety distance (imminent)")
        for value, color in ((1, "goldenrod"), (2, "crimson")):
            ax.fill_between(
                t,
                0,
                1,
                where=level == value,
                step="post",
                color=color,
                alpha=0.3,
                transform=ax.get_xaxis_transform(),
            )
        now = int(level[-1])
        ax.set_title(
            f"{title}  t = {t[-1]:.1f} s  warning: {('none', 'caution', 'imminent')[now]}",
            fontsize=9,
        )
        ax.legend(fontsize=7, loc="upper right")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("gap [m]")
    fig.tight_layout()
    fig.canvas.draw()
    image = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    return image


def tradeoff_figure(margin, rate, lo, hi, front, labels, title: str, target: float = 1.0):
    """Conformance margin [s] against a rate per 100 km (with its interval), one point per
    setting, the Pareto front joined; the pass line (margin 0) and the ``target`` rate drawn."""
    plt = pyplot()
    margin, rate = np.asarray(margin, dtype=float), np.asarray(rate, dtype=float)
    err = np.array([rate - np.asarray(lo), np.asarray(hi) - rate])
    front = np.asarray(front, dtype=bool)
    fig, ax = plt.subplots(figsize=(8, 5.5))
    ax.errorbar(margin, rate, yerr=err, fmt="o", color="0.45", ms=5, capsize=3, label="settings")
    order = np.argsort(margin[front])
    ax.plot(margin[front][order], rate[front][order], "-o", color="C3", ms=6, label="Pareto front")
    for x, y, text in zip(margin, rate, labels, strict=True):
        ax.annotate(text, (x, y), fontsize=7, xytext=(4, 3), textcoords="offset points")
    ax.axvline(0.0, color="k", lw=0.8, ls="--", label="passes the tests (margin >= 0)")
    ax.axhline(target, color="C2", lw=0.8, ls="--", label=f"target {target:g} per 100 km")
    ax.set_yscale("symlog", linthresh=0.1)  # a rate of 0 stays on the plot
    ax.set_xlabel("conformance margin [s] (smallest over NHTSA LVS, LVD, LVM)")
    ax.set_ylabel("nuisance alerts per 100 km (95 % interval)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig
