"""Recorded traffic through the FCW pipeline: every method on the pairs of highD, NGSIM or
mapped CSV recordings, open loop (:func:`replay_study`), with the data's exposure, headway
distribution and the cross-check of the replay's headways against the data set's own."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from acc_fusion.core.plots import plt
from acc_fusion.core.table import Table
from acc_fusion.metrics.summary import FCWSummary
from acc_fusion.sim.closed_loop import SimConfig, simulate
from acc_fusion.studies.compare import SUMMARY_COLUMNS, class_table, summary_row
from acc_fusion.truth.replay.crosscheck import GAP_BINS, THW_BINS, TOLERANCES
from acc_fusion.truth.replay.source import RecordingStats, ReplayConfig, ReplaySource

#: Columns of :meth:`ReplayStudy.exposure`.
EXPOSURE_COLUMNS = (
    "recording", "hours", "km", "vehicles", "pairs", "pair_steps", "leaders",
    "leader_agreement",
)  # fmt: skip
#: Columns of :meth:`ReplayStudy.crosscheck`.
CROSSCHECK_COLUMNS = (
    "recording", "figure", "compared", "share_within", "mean_diff", "max_abs_diff", "tolerance",
)  # fmt: skip


@dataclass
class ReplayStudy:
    """What :func:`replay_study` measured."""

    config: ReplayConfig
    summaries: dict[str, FCWSummary]
    stats: dict[str, RecordingStats]
    steps: int

    @property
    def name(self) -> str:
        """The recordings, in a few words."""
        return ", ".join(self.stats)

    def table(self) -> Table:
        """Per method: warnings, false alarms against the oracle, misses, lead time."""
        t = Table(
            f"FCW on recorded traffic ({self.name}), open loop, 95% intervals", SUMMARY_COLUMNS
        )
        t.rows += [summary_row(m, s) for m, s in self.summaries.items()]
        first = next(iter(self.summaries.values()))
        t.notes.append(f"exposure: {first.hours:.2f} h, {first.km:.1f} km of recorded driving")
        return t

    def classes(self) -> Table:
        """Per method: alerts per 100 km by class, missed crash-relevant situations."""
        return class_table(f"Alert classes (judged from truth), {self.name}", self.summaries)

    def exposure(self) -> Table:
        """Per recording: hours, km, vehicles, pairs, where the leaders come from."""
        t = Table("Exposure per recording", EXPOSURE_COLUMNS)
        for s in self.stats.values():
            agree = f"{s.agree}/{s.either}" if s.either else "-"
            t.rows.append(
                {"recording": s.label, "hours": s.hours, "km": s.km, "vehicles": s.vehicles,
                 "pairs": s.pairs, "pair_steps": s.pair_steps, "leaders": s.leaders,
                 "leader_agreement": agree}
            )  # fmt: skip
        t.notes.append(
            "leader_agreement: rows whose file and recomputed (lane, position) leaders agree"
        )
        t.notes += [
            f"{s.label}: dropped {s.dropped} of its rows, outside the physical bounds "
            "(--bad-rows drop)"
            for s in self.stats.values()
            if s.dropped
        ]
        return t

    def crosscheck(self) -> Table:
        """Per recording and figure: the replay against the data set's own column."""
        t = Table("Cross-check against the data set's headway columns", CROSSCHECK_COLUMNS)
        for s in self.stats.values():
            for name, a in s.crosscheck.figures.items():
                if a.compared:
                    atol, rtol = TOLERANCES[name]
                    t.rows.append(
                        {"recording": s.label, "figure": f"{name} ({s.crosscheck.basis})",
                         "compared": a.compared, "share_within": a.share_within,
                         "mean_diff": a.mean_diff, "max_abs_diff": a.max_abs,
                         "tolerance": f"{atol:g} + {rtol:g} x value"}
                    )  # fmt: skip
        t.notes.append("difference = replay - data set; see acc_fusion.truth.replay.crosscheck")
        return t

    def headway_figure(self):
        """Histograms of the data's time headway and gap (every pair-step with a leader)."""
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        for ax, attr, bins, label in (
            (axes[0], "thw_counts", THW_BINS, "time headway [s]"),
            (axes[1], "gap_counts", GAP_BINS, "gap, bumper to bumper [m]"),
        ):
            lo, _, width = bins
            counts = sum(getattr(s.crosscheck, attr) for s in self.stats.values())
            edges = lo + width * np.arange(counts.size)
            ax.bar(edges, counts, width=width, align="edge", color="tab:blue")
            ax.set_xlabel(label + " (last bin: all above)")
            ax.set_ylabel("pair-steps")
            ax.grid(axis="y", alpha=0.3)
        fig.suptitle(f"Headway distribution of the data: {self.name}", fontsize=10)
        fig.tight_layout()
        return fig


def replay_study(config: ReplayConfig, sim: SimConfig, *, progress: bool = False) -> ReplayStudy:
    """Replay ``config``'s recordings through ``sim``'s pipeline (its step replaced by the
    recordings' frame period), open loop: every method of ``sim`` watches, no driver hears."""
    with ReplaySource(config, progress=progress) as source:
        result = simulate(replace(sim, dt=source.dt, drive=None), source=source)
        return ReplayStudy(config, result.summaries, source.stats, result.steps)
