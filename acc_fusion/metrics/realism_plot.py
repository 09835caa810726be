"""The traffic realism check as a figure: what a reader sees before reading the table.

Four panels of :func:`realism_figure`: the braking-onset rates per threshold against the
published ones (log scale: the gaps are orders of magnitude); the cumulative distribution of
car-following headways with King et al. 2022's median and share under 2 s; the acceleration
histogram (log counts) with the braking thresholds; the speed histogram.
"""

from __future__ import annotations

import numpy as np

from acc_fusion.core.plots import pyplot
from acc_fusion.metrics.realism import (
    MAX_HEADWAY,
    RealismStats,
    time_headways,
)
from acc_fusion.metrics.realism_references import REFERENCES, Reference, reference_of
from acc_fusion.truth.trajectories import Trajectories


def realism_figure(
    traj: Trajectories, stats: RealismStats, references: tuple[Reference, ...] = REFERENCES
):
    """The four panels of the module docstring for ``traj`` and its ``stats``."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    _onsets(axes[0, 0], stats, references)
    headway_panel(axes[0, 1], time_headways(traj), references)
    _accelerations(axes[1, 0], traj.accel, stats.thresholds)
    ax = axes[1, 1]
    ax.hist(traj.speed * 3.6, bins=60, color="tab:blue")
    ax.set(xlabel="speed [km/h]", ylabel="samples", title="speed, every vehicle and step")
    fig.suptitle(f"Traffic realism: {stats.label} ({stats.km:.0f} km)")
    fig.tight_layout()
    return fig


def _onsets(ax, stats: RealismStats, references: tuple[Reference, ...]) -> None:
    x = np.arange(len(stats.thresholds))
    rates = np.array([stats.onsets_per_100km(b) for b in stats.thresholds])
    floor = 1e-2  # the log axis's bottom: a rate of 0 draws no bar, only its label
    ax.bar(x, np.where(rates > 0, rates, np.nan), bottom=floor, color="tab:red")
    for xi, b, r in zip(x, stats.thresholds, rates, strict=True):
        ax.annotate(f"{r:.3g}", (xi, max(r, floor)), ha="center", va="bottom", fontsize=8,
                    color="tab:red", xytext=(0, 2), textcoords="offset points")  # fmt: skip
        ref = reference_of(f"onsets_{b:g}", references)
        if ref is not None:
            ax.plot([xi - 0.4, xi + 0.4], [ref.high, ref.high], "k-", lw=2)
            ax.annotate(ref.cite, (xi, ref.high), ha="center", va="top", fontsize=7,
                        xytext=(0, -3), textcoords="offset points")  # fmt: skip
    ax.set_yscale("log")
    ax.set_ylim(floor, max(1e3, np.nanmax(rates, initial=0.0) * 3))
    ax.set_xticks(x, [f"≥ {b:g} m/s²" for b in stats.thresholds])
    ax.set(
        ylabel="braking onsets per 100 km",
        title="hard braking (red: this traffic; black: naturalistic, top of band)",
    )


def headway_panel(ax, h: np.ndarray, references: tuple[Reference, ...] = REFERENCES) -> None:
    """The cumulative distribution of the headways ``h`` [s] on ``ax``, with King et al.
    2022's median and share under 2 s, their bands as error bars."""
    if h.size:
        xs = np.sort(h)
        ax.plot(xs, np.arange(1, xs.size + 1) / xs.size, color="tab:blue", label="simulated")
    median = reference_of("headway_median", references)
    below2 = reference_of("headway_below_2s", references)
    if median is not None and below2 is not None:
        ax.errorbar(
            [median.value, 2.0],
            [0.5, below2.value],
            xerr=[[median.value - median.low, 0.0], [median.high - median.value, 0.0]],
            yerr=[[0.0, below2.value - below2.low], [0.0, below2.high - below2.value]],
            fmt="ko",
            capsize=4,
            label=f"{median.cite} (median, share < 2 s; bars: the check's bands)",
        )
    ax.set(
        xlabel="time headway, front to front [s]",
        ylabel="cumulative share",
        xlim=(0, MAX_HEADWAY),
        ylim=(0, 1),
        title="car-following headways",
    )
    ax.legend(loc="lower right", fontsize=8)


def _accelerations(ax, accel: np.ndarray, thresholds: tuple[float, ...]) -> None:
    lo = min(-10.0, float(accel.min()) if accel.size else -10.0)
    ax.hist(accel, bins=np.arange(lo, 4.01, 0.1), color="tab:gray")
    ax.set_yscale("log")
    for b in thresholds:
        ax.axvline(-b, color="tab:red", ls="--", lw=1)
        ax.annotate(f"-{b:g}", (-b, 1), fontsize=7, color="tab:red", rotation=90,
                    xytext=(2, 2), textcoords="offset points")  # fmt: skip
    ax.set(xlabel="acceleration [m/s²]", ylabel="samples (log)", title="acceleration")
