"""A SUMO study over many seeds, pooled (``acc-fusion sumo --seeds 0-9``).

Each seed is a study of its own (:func:`acc_fusion.studies.traffic.study_runs`: FCW off and on,
on that seed's traffic); every run of every seed is one task of a map over worker processes
(:func:`acc_fusion.sweep.executors.make_map`: a local pool, or Ray tasks on a cluster), each in
a process of its own (libsumo: one simulation per process).  The results are pooled over the
seeds (:func:`acc_fusion.studies.traffic.pool_studies`): rates per 100 km over all the
exposure, the paired benefit over all the vehicles.  The rows are the same whatever the
executor, the number of workers or the order in which the runs finish: each run depends only
on its seed and the settings.

With a ``store`` folder each finished run is kept there as it arrives
(``run_<seed>_<name>.pkl``, written atomically, beside ``seeds.json``, which names the study),
and a study started again with the same settings runs only what is missing: an interrupted run
resumes.  A damaged file is reported in one line and run again; a store of a different study
is refused.  The files are Python pickles of the study's own results: load only stores you
wrote yourself.
"""

from __future__ import annotations

import json
import pickle
import re
from dataclasses import asdict, replace
from pathlib import Path

from tqdm.auto import tqdm

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import write_bytes_atomic, write_json_atomic
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.studies.traffic import (
    SumoRun,
    SumoStudy,
    assemble,
    pool_studies,
    run_one,
    study_runs,
)
from acc_fusion.sweep.executors import Mapper

#: The most seeds one command runs.
MAX_SEEDS = 10_000


def parse_seeds(text: str) -> tuple[int, ...]:
    """The seeds of ``--seeds``: ``"0-9"``, ``"1,4,7"`` or both (``"0-4,10"``), each a whole
    number in [0, 2**31) (SUMO's ``--seed``); in the order given, without repeats."""
    seeds: list[int] = []
    for part in text.split(","):
        m = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", part)
        if m is None:
            raise ConfigError(
                f"--seeds takes whole numbers and ranges such as 0-9 or 1,4,7, got {text!r}"
            )
        lo, hi = int(m[1]), int(m[2] if m[2] is not None else m[1])
        if hi < lo or hi >= 2**31 or hi - lo >= MAX_SEEDS:
            raise ConfigError(
                f"--seeds: {part.strip()!r} must be a range lo-hi with lo <= hi < 2**31 and at "
                f"most {MAX_SEEDS} seeds"
            )
        seeds += [k for k in range(lo, hi + 1) if k not in seeds]
    if len(seeds) > MAX_SEEDS:
        raise ConfigError(f"--seeds gives {len(seeds)} seeds; at most {MAX_SEEDS}")
    return tuple(seeds)


def _describe(sumo_config, sim: SimConfig, world: bool, drives: tuple[str, ...]) -> dict:
    """What makes two studies the same (everything but the seed), as plain JSON."""
    return json.loads(
        json.dumps(
            {
                "sumo": asdict(replace(sumo_config, seed=0, gui=False)),
                "sim": repr(replace(sim, seed=0)),
                "world": world,
                "drives": list(drives),
            },
            default=str,
        )
    )


class RunStore:
    """The finished runs of a many-seed study in a folder (see the module docstring)."""

    MANIFEST = "seeds.json"

    def __init__(self, folder: Path, description: dict) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        manifest = self.folder / self.MANIFEST
        if manifest.exists():
            try:
                held = json.loads(manifest.read_text(encoding="utf-8"))
            except (OSError, ValueError, UnicodeDecodeError):
                held = None
            if held is not None and held != description:
                raise ConfigError(
                    f"{str(self.folder)!r} holds the runs of a different study; give another "
                    "--out folder, or delete it to start again"
                )
        write_json_atomic(manifest, description)

    def path(self, seed: int, name: str) -> Path:
        """The file of one run."""
        return self.folder / f"run_{seed}_{name.replace(':', '-')}.pkl"

    def load(self, seed: int, name: str) -> SumoRun | None:
        """The run if stored and readable; ``None`` if not stored; a damaged file is said in
        one line and treated as missing."""
        path = self.path(seed, name)
        if not path.exists():
            return None
        try:
            run = pickle.loads(path.read_bytes())
        except Exception:  # any damage: truncated, garbage, another version's classes
            run = None
        if not isinstance(run, SumoRun):
            print(f"note: {path} is damaged; running seed {seed} ({name}) again")
            return None
        return run

    def save(self, seed: int, name: str, run: SumoRun) -> None:
        """Keep one finished run."""
        write_bytes_atomic(self.path(seed, name), pickle.dumps(run))


def _task(item: tuple) -> SumoRun:
    """Worker function: one run (item: seed, name, arguments of :func:`run_one`)."""
    return run_one(item[2])


def seeds_study(
    sumo_config,
    sim: SimConfig,
    seeds: tuple[int, ...],
    mapper: Mapper,
    *,
    drives: tuple[str, ...] = (),
    world: bool = False,
    store: Path | None = None,
    progress: bool = True,
    aeb: bool = False,
) -> tuple[SumoStudy, dict[int, SumoStudy]]:
    """The study of ``sumo_config`` on every seed of ``seeds``, run by ``mapper``
    (:func:`~acc_fusion.sweep.executors.make_map`), pooled; and each seed's own study
    (``aeb``: with the FCW-on run with automatic emergency braking of each seed)."""
    if not seeds:
        raise ConfigError("--seeds names no seed")
    if sumo_config.gui:
        raise ConfigError("--seeds runs headless; drop --gui")
    runs = RunStore(store, _describe(sumo_config, sim, world, drives)) if store else None
    todo, done = [], {}
    for seed in seeds:  # each seed seeds SUMO and the pipeline, as --seed does
        config, sim_k = replace(sumo_config, seed=seed), replace(sim, seed=seed)
        for name, args in study_runs(config, sim_k, drives=drives, world=world, aeb=aeb).items():
            held = runs.load(seed, name) if runs else None
            if held is None:
                todo.append((seed, name, args))
            else:
                done[(seed, name)] = held
    if done and todo:
        print(f"resuming: {len(done)} runs of {len(done) + len(todo)} already done")
    bar = tqdm(total=len(todo), desc="SUMO runs", disable=None if progress else True)
    runs_of = mapper(_task, todo, lambda item: True, lambda item: f"seed {item[0]} ({item[1]})")
    for (seed, name, _), run in runs_of:
        done[(seed, name)] = run
        if runs:
            runs.save(seed, name, run)
        bar.update()
    bar.close()
    studies = {}
    for seed in seeds:
        names = {name: run for (k, name), run in done.items() if k == seed}
        studies[seed] = assemble(replace(sumo_config, seed=seed), replace(sim, seed=seed), names)
    return pool_studies(studies), studies
