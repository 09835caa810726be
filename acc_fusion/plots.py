"""Figures (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def estimation_bars(table):
    """Bar chart of gap and range-rate RMSE per method, from :func:`studies.compare_methods`."""
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
