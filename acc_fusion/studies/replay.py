"""Recorded traffic through the FCW pipeline: every method on the pairs of highD, NGSIM or
mapped CSV recordings, open loop (:func:`replay_study`), with the data's exposure, headway
distribution and the cross-check of the replay's headways against the data set's own; and
ASAM OSI traces, each host an ego, through the 1-D pair or the 2-D world
(:func:`osi_replay_study`)."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, replace

import numpy as np

from acc_fusion.core.plots import pyplot
from acc_fusion.core.table import Table
from acc_fusion.metrics.summary import FCWSummary
from acc_fusion.sim.closed_loop import SimConfig, simulate
from acc_fusion.sim.osi_trace import OsiOutput, has_sensors, recorded_perception
from acc_fusion.sim.world import simulate_world
from acc_fusion.studies.compare import SUMMARY_COLUMNS, class_table, summary_row
from acc_fusion.studies.crashes import chain
from acc_fusion.studies.world import WorldStudy
from acc_fusion.truth.osi.source import OsiPairs, OsiTraces, trace_paths
from acc_fusion.truth.replay.crosscheck import GAP_BINS, THW_BINS, TOLERANCES
from acc_fusion.truth.replay.pairs import Pairs
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
    """What :func:`replay_study` measured; ``world_config``: the pipeline config of a 2-D
    world's run, whose alerts also have causes (:meth:`causes`)."""

    config: ReplayConfig
    summaries: dict[str, FCWSummary]
    stats: dict[str, RecordingStats]
    steps: int
    world_config: SimConfig | None = None

    @property
    def name(self) -> str:
        """The recordings, in a few words (the first and last of more than three)."""
        names = list(self.stats)
        if len(names) <= 3:
            return ", ".join(names)
        return f"{names[0]} … {names[-1]}, {len(names)} recordings"

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

    def causes(self) -> Table | None:
        """The 2-D world's nuisance and sensing-false alerts by cause
        (:meth:`~acc_fusion.studies.world.WorldStudy.causes`), ``None`` for the 1-D pair."""
        cfg = self.world_config
        if cfg is None:
            return None
        label = cfg.world.conditions.label
        return WorldStudy(cfg, {("recorded", label): self.summaries}, self.name).causes()

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
        plt = pyplot()
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


def replay_study(
    config: ReplayConfig,
    sim: SimConfig,
    *,
    progress: bool = False,
    world: bool = False,
    topic: str | None = None,
    osi: OsiOutput | None = None,
) -> ReplayStudy:
    """Replay ``config``'s recordings through ``sim``'s pipeline (its step replaced by the
    recordings' frame period), open loop: every method of ``sim`` watches, no driver hears.
    Format ``osi``: :func:`osi_replay_study` (``world``, ``topic``, ``osi``)."""
    if config.format == "osi":
        return osi_replay_study(config, sim, progress=progress, world=world, topic=topic, osi=osi)
    with ReplaySource(config, progress=progress) as source:
        result = simulate(replace(sim, dt=source.dt, drive=None), source=source)
        return ReplayStudy(config, result.summaries, source.stats, result.steps)


class _TraceLog:
    """Each host's 1-D truth at every step it is active (an ``on_step`` of
    :func:`~acc_fusion.sim.closed_loop.simulate`), for the exposure and headways."""

    def __init__(self, source: OsiTraces) -> None:
        self.source, self.rows = source, []

    def __call__(self, view) -> None:
        f, active = view.frame, self.source.active
        self.rows.append((active, f.ego_speed, f.ego_accel, f.gap, f.lead_speed, f.lead_accel,
                          f.leader_id, f.lateral_offset))  # fmt: skip

    def stats(self) -> dict[str, RecordingStats]:
        """Per trace: what was replayed (:class:`RecordingStats`; ``vehicles`` its one host,
        ``leaders`` ``"file"`` where the trace marks its leads, else ``"recomputed"``)."""
        out, dt = {}, self.source.dt
        cols = [np.stack(c, axis=1) for c in zip(*self.rows, strict=True)]
        for e, tr in enumerate(self.source.traces):
            on = cols[0][e]
            speed, accel, gap, v_lead, a_lead, leader, lateral = (c[e][on] for c in cols[1:])
            has = leader >= 0
            stats = RecordingStats(
                label=tr.path.name, leaders="file" if tr.marked else "recomputed",
                hours=on.sum() * dt / 3600.0, km=float(speed.sum() * dt / 1000.0), vehicles=1,
                pairs=np.unique(leader[has]).size, pair_steps=int(has.sum()),
            )  # fmt: skip
            n = int(on.sum())
            stats.crosscheck.add(
                Pairs(np.zeros(n, np.int64), np.zeros(n, bool), speed, accel, leader,
                      np.where(has, gap, np.nan), v_lead, a_lead, np.zeros(n), lateral)
            )  # fmt: skip
            out[tr.path.name] = stats
        return out


def osi_replay_study(
    config: ReplayConfig,
    sim: SimConfig,
    *,
    progress: bool = False,
    world: bool = False,
    topic: str | None = None,
    osi: OsiOutput | None = None,
) -> ReplayStudy:
    """Replay the OSI traces of ``config.path`` (a ``.mcap`` or ``.osi`` file, or a folder of
    them; ``topic``: the MCAP channel), each host an ego
    (:class:`~acc_fusion.truth.osi.source.OsiTraces`), open loop, through the 1-D pair (each
    host and its true in-path lead, :class:`~acc_fusion.truth.osi.source.OsiPairs`) or, with
    ``world``, the 2-D world (:func:`~acc_fusion.sim.world.simulate_world`: every object the
    traces hold, alerts by cause); ``sim``'s step replaced by the traces'.  Traces of this
    project's runs (:class:`~acc_fusion.sim.osi_trace.OsiRecorder`) replay in the 2-D world
    with their recorded detections and readings rather than drawn ones
    (:func:`~acc_fusion.sim.osi_trace.recorded_perception`), so with the recorded run's
    ``sim`` they give its alerts again.  With ``osi`` (the 2-D world) each trace's replay is
    written as a trace of ours, named as its source (a foreign ground truth comes out with
    this project's detections, tracks and estimates)."""
    paths = trace_paths(config.path)
    source = OsiTraces(paths, topic=topic)
    log = _TraceLog(source)
    sim = replace(sim, dt=source.dt, drive=None)
    if world:
        sensed = recorded_perception(paths) if all(map(has_sensors, paths)) else None

        def names() -> list[str]:
            return ["" if tr.done else tr.path.stem for tr in source.traces]

        recorder = None if osi is None else osi.recorder(sim, "", names)
        with recorder or contextlib.nullcontext():
            result = simulate_world(sim, source=source, progress=progress,
                                    on_step=chain(log, recorder), perception=sensed)  # fmt: skip
    else:
        result = simulate(sim, source=OsiPairs(source), progress=progress, on_step=log)
    return ReplayStudy(config, result.summaries, log.stats(), result.steps, sim if world else None)
