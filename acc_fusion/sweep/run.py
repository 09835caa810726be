"""Run a sweep: every chunk not yet in the store, on the chosen executor, then the tables,
ROC curves and report (:func:`run_sweep`). The file format is described in
:mod:`acc_fusion.sweep.config`."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from acc_fusion.sweep.aggregate import write_tables
from acc_fusion.sweep.config import SweepConfig
from acc_fusion.sweep.executors import make_executor
from acc_fusion.sweep.report import write_report
from acc_fusion.sweep.store import SweepStore

# --------------------------------------------------------------------------------------------
# Config
# --------------------------------------------------------------------------------------------


# --------------------------------------------------------------------------------------------
# Points and chunks
# --------------------------------------------------------------------------------------------


# --------------------------------------------------------------------------------------------
# Running a chunk (in a worker process)
# --------------------------------------------------------------------------------------------


# --------------------------------------------------------------------------------------------
# The resumable store
# --------------------------------------------------------------------------------------------


# --------------------------------------------------------------------------------------------
# Running a sweep
# --------------------------------------------------------------------------------------------


@dataclass
class SweepResult:
    """What :func:`run_sweep` did: the rows (a pandas DataFrame), the chunks it ran now and
    those it found done, the wall time [s] of the runs, the files written and the damaged
    files of an earlier run it recovered (:attr:`SweepStore.damaged`)."""

    config: SweepConfig
    rows: Any
    ran_chunks: int
    skipped_chunks: int
    ran_runs: int
    seconds: float
    files: list[Path] = field(default_factory=list)
    damaged: list[str] = field(default_factory=list)

    @property
    def runs_per_s(self) -> float:
        return self.ran_runs / self.seconds if self.seconds > 0 else math.nan


def run_sweep(
    config: SweepConfig,
    out: str | Path,
    *,
    executor: str = "local",
    workers: int = 2,
    address: str | None = None,
    progress: bool = True,
    report: bool = True,
) -> SweepResult:
    """Run the chunks of ``config`` not yet stored in ``out``, then consolidate and report.

    Returns the rows of every run of the sweep (those found done included).
    """

    run = make_executor(executor, workers, address)
    store = SweepStore(out, config)
    chunks = config.chunks()
    done = store.done(chunks)
    todo = [c for c in chunks if c.id not in done]
    total = config.total_runs
    from tqdm.auto import tqdm

    # No monitor thread (it only refreshes bars left idle for 10 s): a process with a second
    # thread spawns its workers rather than forking them (executors.start_method).
    bar = type("SweepBar", (tqdm,), {"monitor_interval": 0})(
        total=total,
        initial=total - sum(c.n_runs for c in todo),
        unit="run",
        desc=config.name,
        disable=None if progress else True,
        smoothing=0.1,
    )
    t0 = time.perf_counter()
    ran = 0
    with bar:
        for chunk, columns in run(todo):
            store.write_part(chunk, columns)
            ran += chunk.n_runs
            bar.update(chunk.n_runs)
    seconds = time.perf_counter() - t0
    rows = store.consolidate(c.id for c in chunks).to_pandas()
    result = SweepResult(
        config,
        rows,
        len(todo),
        len(chunks) - len(todo),
        ran,
        seconds,
        [store.out / "runs.parquet"],
        store.damaged,
    )
    result.files += write_tables(config, rows, store.out)
    if report:
        result.files += write_report(config, rows, store.out)
    return result


# --------------------------------------------------------------------------------------------
# Aggregation
# --------------------------------------------------------------------------------------------


# --------------------------------------------------------------------------------------------
# acc-fusion sweep
# --------------------------------------------------------------------------------------------
