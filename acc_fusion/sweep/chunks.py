"""One chunk of a sweep run as one batched simulation (a SUMO chunk: one SUMO run), returning
its rows (:func:`run_chunk`); what executors call in their worker processes."""

from __future__ import annotations

import numpy as np

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import AccFusionError
from acc_fusion.metrics.events import COUNTS
from acc_fusion.metrics.summary import CAUSE_CELLS, CAUSE_COUNTS
from acc_fusion.sim.closed_loop import SimConfig, simulate
from acc_fusion.sim.world import simulate_world
from acc_fusion.studies.traffic import _run
from acc_fusion.sweep.columns import COUNT_COLUMNS, SUM_COLUMNS
from acc_fusion.sweep.points import Chunk, _sumo_config


def run_chunk(chunk: Chunk) -> dict[str, list]:
    """Simulate ``chunk`` and return its rows as columns (one row per run and method)."""

    point = chunk.point
    sim = from_mapping(SimConfig, {**point.sim, "runs": chunk.n_runs, "seed": chunk.sim_seed})
    if point.source == "sumo":
        run = _run(_sumo_config(point.sumo, chunk.sim_seed), sim, False, False)
        if run.error:
            raise AccFusionError(f"SUMO failed in chunk {chunk.id}: {run.error}")
        steps = run.steps
        per_run = {m: _summary_counts(s) for m, s in run.summaries.items()}
    else:
        result = simulate_world(sim) if point.source == "world" else simulate(sim)
        steps = result.steps
        per_run = {m: s.per_pair for m, s in result.summaries.items()}
    methods = list(per_run)
    rows = chunk.n_runs * len(methods)  # run by run, each run's methods in order
    runs = np.repeat(np.arange(chunk.first, chunk.first + chunk.n_runs), len(methods)).tolist()
    cols: dict[str, list] = {
        "run_id": [f"{point.id}-s{chunk.seed}-r{r:07d}" for r in runs],
        "point_id": [point.id] * rows,
        "chunk_id": [chunk.id] * rows,
        "seed": [chunk.seed] * rows,
        "run": runs,
        **{key: [value] * rows for key, value in point.columns.items()},
        "fault": [point.fault] * rows,
        "method": methods * chunk.n_runs,
    }
    for c in (*COUNT_COLUMNS, *SUM_COLUMNS):
        cols[c] = np.stack([per_run[m][c] for m in methods], axis=1).reshape(-1).tolist()
    cols["steps"] = [steps] * rows
    return cols


def _summary_counts(s) -> dict[str, np.ndarray]:
    """The per-run figures of a one-run :class:`~acc_fusion.metrics.summary.FCWSummary` (a SUMO run:
    all its vehicles together)."""
    lead = s.lead_time.mean * s.lead_time.finite if s.lead_time.finite else 0.0
    figures = {c: getattr(s, c) for c in (*COUNTS, "hours", "km")}
    by_cause = s.by_cause or {}
    for name, (cls, cause) in zip(CAUSE_COUNTS, CAUSE_CELLS, strict=True):
        figures[name] = by_cause.get(cls, {}).get(cause, 0)
    return {k: np.array([v]) for k, v in {**figures, "lead_time_sum_s": lead}.items()}
