r"""Benchmark: the cost of the 2-D world (object truth from SUMO) on SUMO's own A10KW scenario.

Runs ``<SUMO_HOME>/tools/game/A10KW.sumocfg`` (an OpenStreetMap motorway interchange scenario
of SUMO's game, shipped in the eclipse-sumo wheel: 0.5 s steps, about 470 vehicles at 300 s,
1794 edges) with the
SUMO options of :func:`acc_fusion.truth.sumo.launch.sumo_command` and the same seed, five
times, each in a fresh process (libsumo allows one simulation per process), one after the
other:

* **bare**: SUMO alone, ``simulationStep`` in a loop;
* **source**: :class:`acc_fusion.truth.sumo.source.SumoSource` with every vehicle equipped
  (``penetration`` 1, as ``acc-fusion sumo --sumocfg`` does by default), frames made and
  nothing done with them;
* **objects**: the same source plus :meth:`acc_fusion.truth.sumo.objects.SumoObjects.frame`
  at every step (every vehicle, the roadside objects, the per-ego search and transform), for
  the prefix of slots that holds the egos, as the pipeline asks for it;
* **inline**: :func:`acc_fusion.sim.world.simulate_world` on
  :class:`~acc_fusion.truth.sumo.world.SumoWorld` of the in-process source — the objects,
  the 2-D radar and thermal camera, a tracker per sensor, the track-to-track association,
  all four methods' estimators on every associated object, in-path selection, warning,
  oracle and metrics — with the default config (``world.*``, day), over the occupied prefix
  of the slots;
* **pipeline**: the same on a
  :class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource` opened with ``objects``,
  as ``acc-fusion sumo --open-loop`` runs it: SUMO and the object frames in a
  process of their own, ahead of the pipeline; the same frames bit for bit.

Each run simulates the same ``--warmup`` seconds (30) untimed — the network fills, numba
loads its compiled kernels (the pipelines run ``simulate_world`` over the warm-up too, then
afresh over the timed part) — then is timed from there to ``--end`` (300 s).  It prints each
run's wall time and its ratio to bare, the egos per step and objects per ego (means over the
timed steps), each run's resident memory (current and peak) at the start and the end of its
timed part (memory must stay flat: a run may grow only as bare SUMO does, with the number of
vehicles), the pipelines' time per stage (each stage's methods timed in the pipeline's process:
:data:`STAGES`; with SUMO in the background, ``sumo`` and ``objects`` are the waits for and
copies of its frames), ``objects_ratio=<objects wall time / bare wall time>``,
``inline_ratio=<inline wall time / bare wall time>`` and as its last line
``overhead_ratio=<pipeline wall time / bare wall time>`` (target: <= 3).

Memory against traffic: the bare and pipeline runs also sample their resident memory (the
pipeline's: its process's and SUMO's, whose shared ring of frames counts twice, a constant)
and the number of vehicles (bare: SUMO's; pipeline: the equipped egos) every ``--sample``
simulated seconds (60) of the timed part, and fit :math:`\mathrm{RSS} = a + b\,n + c\,t` by least
squares (:func:`memory_fit`).  The slope :math:`c` in MB per simulated hour, with its 95 %
interval, is the growth that the traffic's size does not explain: a leak shows as a
pipeline slope above bare SUMO's.

    python scripts/bench_world.py               # 300 s simulated
    python scripts/bench_world.py --quick       # 90 s simulated (make bench)
    python scripts/bench_world.py --end 1800 --capacity 2048  # the half hour: memory check
"""

from __future__ import annotations

import argparse
import functools
import importlib
import math
import multiprocessing
import os
import resource
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

#: SUMO options that silence A10KW's verbose report (the same in every run).
QUIET = ("--verbose", "false", "--duration-log.statistics", "false")


def _object_stages(source) -> list[Callable[[], object]]:
    """The objects run's stages: the object frame of every step, of the prefix of slots the
    pipeline works on (:class:`~acc_fusion.core.slots.Extent`)."""
    from acc_fusion.core.slots import Extent
    from acc_fusion.truth.sumo.objects import SumoObjects

    objects, extent = SumoObjects(source), Extent(source.n_pairs)
    return [lambda: objects.frame(extent.fit(source.active))]


#: The pipeline's stages and the methods timed as each: (module, class or None, name).
STAGES = {
    "sumo": [("acc_fusion.truth.sumo.source", "SumoSource", "advance"),
             ("acc_fusion.truth.sumo.background", "BackgroundSumoSource", "advance")],
    "objects": [("acc_fusion.truth.sumo.objects", "SumoObjects", "frame"),
                ("acc_fusion.truth.sumo.background", "ReceivedObjects", "frame")],
    "sensors": [("acc_fusion.sensors.radar2d", "Radar2D", "detect"),
                ("acc_fusion.sensors.infrared2d", "Infrared2D", "detect")],
    "trackers": [("acc_fusion.fusion.tracking.tracker", "Tracker", "step")],
    "association": [("acc_fusion.fusion.tracking.association", "TrackAssociator", "step"),
                    ("acc_fusion.sim.world", None, "fused_measurements")],
    "estimators": [("acc_fusion.fusion.base", "Estimator", "step")],
    "selection": [("acc_fusion.sim.world", "WorldPerception", "_select")],
    "warning": [("acc_fusion.warning.logic", "WarningLogic", "step")],
    "metrics": [("acc_fusion.metrics.events", "FCWMetrics", "update"),
                ("acc_fusion.sim.world", None, "alert_cause")],
}  # fmt: skip


def _time_stages() -> dict[str, float]:
    """Wrap every method of :data:`STAGES` (in this process) to add its wall time to its
    stage; the seconds per stage, filled as the pipeline runs."""
    spent = dict.fromkeys(STAGES, 0.0)

    def timed(stage, func):
        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return func(*args, **kwargs)
            finally:
                spent[stage] += time.perf_counter() - t0

        return wrapper

    for stage, methods in STAGES.items():
        for module, cls, name in methods:
            owner = importlib.import_module(module)
            owner = owner if cls is None else getattr(owner, cls)
            setattr(owner, name, timed(stage, getattr(owner, name)))
    return spent


def _staged(factory: Callable, config, end: float, warmup: float) -> dict:
    """A run of per-step stages (``factory``: made from the open source, each called after
    every step): its timed wall time, steps, egos and objects, memory."""
    from acc_fusion.truth.sumo.source import SumoSource

    egos = objects = 0
    with SumoSource(config) as source:
        stages = factory(source)
        while source.t < source.begin + warmup - 1e-9:
            source.advance()
            for stage in stages:
                stage()
        rss_start = _rss_mb()
        steps, t0 = 0, time.perf_counter()
        while not source.done:
            source.advance()
            outputs = [stage() for stage in stages]
            steps += 1
            if outputs:  # the object frame: egos and objects per ego this step
                frame = outputs[0]
                active = source.active
                egos += int(active.sum())
                objects += int(frame.valid[active[: frame.n_egos]].sum())
        elapsed = time.perf_counter() - t0
        rss_end = _rss_mb()
    return {"wall": elapsed, "steps": steps, "egos": egos, "objects": objects,
            "rss_start": rss_start, "rss_end": rss_end}  # fmt: skip


def _pipeline(config, end: float, warmup: float, every: float, background: bool = True) -> dict:
    """``simulate_world`` on the SUMO source (in the ``background``, else in process) over
    the warm-up, then afresh, timed, to the end, with the time of every stage of
    :data:`STAGES`."""
    from acc_fusion.sim.closed_loop import SimConfig
    from acc_fusion.sim.world import simulate_world
    from acc_fusion.truth.sumo.background import BackgroundSumoSource
    from acc_fusion.truth.sumo.objects import ObjectFieldConfig
    from acc_fusion.truth.sumo.source import SumoSource
    from acc_fusion.truth.sumo.world import SumoWorld

    class Until(SumoWorld):
        """The source, done at the end of the warm-up."""

        @property
        def done(self) -> bool:
            return self.source.done or self.source.t >= self.source.begin + warmup - 1e-9

    class Sampled(SumoWorld):
        """The source, sampling memory and egos every ``every`` simulated seconds."""

        samples: list[tuple[float, int, float]] = []

        def advance(self) -> None:
            super().advance()
            src = self.source
            if not self.samples or src.t >= self.samples[-1][0] + every - 1e-9:
                rss = _rss_mb()[0] + (_current_mb(src.pid) if background else 0.0)
                self.samples.append((src.t, int(src.active.sum()), rss))

    opened = BackgroundSumoSource(config, ObjectFieldConfig()) if background else SumoSource(config)
    with opened as source:
        sim = SimConfig(runs=1, dt=source.dt)
        simulate_world(sim, source=Until(source))
        spent = _time_stages()
        rss_start, t0 = _rss_mb(), time.perf_counter()
        result = simulate_world(sim, source=Sampled(source))
        elapsed = time.perf_counter() - t0
        rss_end = _rss_mb()
    return {"wall": elapsed, "steps": result.steps, "egos": 0, "objects": 0,
            "rss_start": rss_start, "rss_end": rss_end, "stages": spent,
            "samples": Sampled.samples}  # fmt: skip


def _current_mb(pid: int | str = "self") -> float:
    """Current resident memory of process ``pid`` [MB] (Linux /proc; NaN elsewhere)."""
    try:
        with open(f"/proc/{pid}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:
        return float("nan")


def _rss_mb() -> tuple[float, float]:
    """Current and peak resident memory of this process [MB] (the current from Linux /proc,
    else the peak)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**10
    current = _current_mb()
    return (peak if math.isnan(current) else current), peak


def _run(
    name: str, sumocfg: str, end: float, warmup: float, seed: int, capacity: int, every: float
) -> dict:
    """One run of :data:`RUNS` (``every``: the memory sampling period of those that sample)."""
    from acc_fusion.truth.sumo.config import SumoConfig

    config = SumoConfig(sumocfg=sumocfg, end=end, seed=seed, capacity=capacity, extra_args=QUIET)
    run = RUNS[name]
    return run(config, end, warmup, every) if name in SAMPLED else run(config, end, warmup)


def _bare(config, end: float, warmup: float, every: float) -> dict:
    """SUMO alone on the source's command line, warm-up and timed part as :func:`_staged`."""
    import libsumo

    from acc_fusion.truth.sumo.launch import sumo_command

    libsumo.start([*sumo_command(config), "--end", str(end)])
    try:
        while libsumo.simulation.getTime() < warmup - 1e-9:
            libsumo.simulationStep()
        rss_start, steps, t0 = _rss_mb(), 0, time.perf_counter()
        samples: list[tuple[float, int, float]] = []
        while libsumo.simulation.getTime() < end - 1e-9:
            libsumo.simulationStep()
            steps += 1
            t = libsumo.simulation.getTime()
            if not samples or t >= samples[-1][0] + every - 1e-9:
                samples.append((t, libsumo.vehicle.getIDCount(), _rss_mb()[0]))
        elapsed = time.perf_counter() - t0
    finally:
        libsumo.close()
    return {"wall": elapsed, "steps": steps, "egos": 0, "objects": 0,
            "rss_start": rss_start, "rss_end": _rss_mb(), "samples": samples}  # fmt: skip


def memory_fit(samples: list[tuple[float, int, float]]) -> tuple[float, float, float]:
    r"""Least squares :math:`\mathrm{RSS} = a + b\,n + c\,t` over ``samples`` of (simulated
    time [s], vehicles n, RSS [MB]): ``(b [MB per vehicle], c [MB per simulated hour], the
    half-width of c's 95 % interval)`` (NaN with fewer than four samples)."""
    import numpy as np
    from scipy.stats import t as student

    data = np.array(samples, dtype=float)
    if len(data) < 4:
        return float("nan"), float("nan"), float("nan")
    design = np.column_stack([np.ones(len(data)), data[:, 1], data[:, 0] / 3600.0])
    coef, *_ = np.linalg.lstsq(design, data[:, 2], rcond=None)
    dof = len(data) - 3
    resid = data[:, 2] - design @ coef
    cov = np.linalg.pinv(design.T @ design) * float(resid @ resid) / dof
    half = float(student.ppf(0.975, dof) * np.sqrt(cov[2, 2]))
    return float(coef[1]), float(coef[2]), half


#: Per run: its function of (SUMO config, end, warm-up) giving its timed figures.
RUNS: dict[str, Callable[..., dict]] = {
    "bare": _bare,
    "source": functools.partial(_staged, lambda source: []),
    "objects": functools.partial(_staged, _object_stages),
    "inline": functools.partial(_pipeline, background=False),
    "pipeline": _pipeline,
}

#: The runs that sample memory against the traffic.
SAMPLED = ("bare", "inline", "pipeline")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--end", type=float, help="simulated seconds (300; --quick 90)")
    parser.add_argument("--quick", action="store_true", help="a shorter run: --end 90")
    parser.add_argument("--warmup", type=float, default=30.0, help="untimed seconds (30)")
    parser.add_argument("--seed", type=int, default=0, help="SUMO's seed (0)")
    parser.add_argument(
        "--capacity", type=int, default=1024, help="slots E (1024; 2048 for --end 1800)"
    )
    parser.add_argument("--sumocfg", help="scenario (default: SUMO's tools/game/A10KW.sumocfg)")
    parser.add_argument(
        "--sample", type=float, default=60.0, help="memory sampling period, simulated s (60)"
    )
    args = parser.parse_args(argv)
    args.end = args.end or (90.0 if args.quick else 300.0)
    if args.sample <= 0:
        parser.error(f"--sample must be positive, got {args.sample}")
    if not 0 <= args.warmup < args.end:
        parser.error(f"need 0 <= --warmup < --end, got {args.warmup} and {args.end}")
    if args.capacity < 1:
        parser.error(f"--capacity must be at least 1, got {args.capacity}")
    if args.sumocfg is None:
        import sumo

        args.sumocfg = str(Path(sumo.SUMO_HOME) / "tools" / "game" / "A10KW.sumocfg")
    ctx = multiprocessing.get_context("spawn")
    res = {}
    for name in RUNS:
        with ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
            job = pool.submit(
                _run, name, args.sumocfg, args.end, args.warmup, args.seed, args.capacity,
                args.sample,
            )  # fmt: skip
            res[name] = job.result()
    bare = res["bare"]
    print(f"scenario {args.sumocfg}, {args.warmup:g} s warm-up, timed to {args.end:g} s, "
          f"{bare['steps']} steps")  # fmt: skip
    for name, r in res.items():
        assert r["steps"] == bare["steps"], f"{name} ran {r['steps']} steps, bare {bare['steps']}"
        print(f"{name:8s} {r['wall']:7.2f} s  {1e3 * r['wall'] / r['steps']:6.2f} ms/step  "
              f"ratio {r['wall'] / bare['wall']:5.2f}  RSS {r['rss_start'][0]:.0f} -> "
              f"{r['rss_end'][0]:.0f} MB, peak {r['rss_start'][1]:.0f} -> "
              f"{r['rss_end'][1]:.0f} MB")  # fmt: skip
    obj, pipe = res["objects"], res["pipeline"]
    print(f"egos per step {obj['egos'] / obj['steps']:.1f}, "
          f"objects per ego {obj['objects'] / max(obj['egos'], 1):.1f}")  # fmt: skip
    for name in ("inline", "pipeline"):
        run = res[name]
        spent = run["stages"]
        print(f"{name} by stage (s, ms/step, share of its wall time):")
        for stage, sec in [*spent.items(), ("other", run["wall"] - sum(spent.values()))]:
            print(f"  {stage:12s} {sec:7.2f} s  {1e3 * sec / run['steps']:6.2f} ms/step  "
                  f"{sec / run['wall']:6.1%}")  # fmt: skip
    print("memory against traffic: RSS = a + b·vehicles + c·t (least squares over the samples)")
    for name in SAMPLED:
        samples = res[name]["samples"]
        b, c, half = memory_fit(samples)
        n = [v for _, v, _ in samples]
        print(f"  {name:8s} {len(samples)} samples, {min(n)}-{max(n)} vehicles: "
              f"b {1e3 * b:.1f} kB/vehicle, c {c:+.1f} ± {half:.1f} MB/h")  # fmt: skip
    print(f"source_ratio={res['source']['wall'] / bare['wall']:.3f}")
    print(f"objects_ratio={obj['wall'] / bare['wall']:.3f}")
    print(f"inline_ratio={res['inline']['wall'] / bare['wall']:.3f}")
    print(f"overhead_ratio={pipe['wall'] / bare['wall']:.3f}")


if __name__ == "__main__":
    main()
