"""Benchmark: the cost of the FCW pipeline on top of a SUMO traffic simulation.

Runs the same SUMO scenario (the bundled motorway, about 390 vehicles once full, with the SUMO
options of :func:`acc_fusion.truth.sumo.launch.sumo_command`) in four ways, each in a fresh process
(libsumo allows one simulation per process), one after the other: ``--repeat`` (3) pairs of a
bare run and a pipeline run back to back, then one reads run and one source run:

* **bare**: SUMO alone, ``simulationStep`` in a loop;
* **reads**: SUMO plus only what any libsumo design must read per step: the speed and the
  leader (``getSpeed``, ``getLeader``) of every vehicle, the way the source reads them (the
  compiled reader of :mod:`acc_fusion.truth.sumo.native`, else libsumo's raw SWIG functions), with
  nothing done with them.  Its ratio to bare is the floor of ``overhead_ratio``: the
  pipeline can overlap SUMO on another core, the reads cannot;
* **source**: the same background source as the pipeline run below, alone: SUMO in its
  child process streaming frames that this process only receives.  Its ratio to bare is the
  child's share, which bounds ``overhead_ratio`` when the pipeline keeps up;
* **pipeline**: SUMO through :class:`acc_fusion.truth.sumo.background.BackgroundSumoSource` (the
  :class:`acc_fusion.truth.sumo.source.SumoSource` in a child process, streaming its frames ahead:
  exact
  in open loop) with the whole FCW pipeline on every equipped vehicle: radar and infrared sensors,
  ego-motion filter, federated fusion with fault detection, warning logic, oracle and
  streaming metrics.  ``--inline`` runs the source in the pipeline's own process instead.

It prints each pair's wall times and ratio, the four wall times (bare and pipeline: the
medians; and the pipeline process's CPU time per step), the peak number of vehicles and
equipped pairs, the resident memory of the pipeline and SUMO processes at a quarter of the
run and at its end (memory must stay flat: every per-vehicle record is dropped when the
vehicle leaves, and the metrics stream), ``source_ratio=<source wall time / bare wall
time>``, ``floor_ratio=<reads wall time / bare wall time>``, and as its last line
``overhead_ratio=<median over the pairs of pipeline wall time / bare wall time>`` (target:
<= 1.25).  A pair's two runs share the machine's state of the moment; on a shared virtual
machine a single pair's ratio moves by +-0.3 from one pair to the next.

    python scripts/bench_sumo.py             # 600 s simulated
    python scripts/bench_sumo.py --quick     # 200 s simulated, under a minute
    python scripts/bench_sumo.py --end 3600  # one simulated hour: the memory check
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import resource
import time
from collections import deque
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from itertools import repeat
from statistics import median

from tqdm import tqdm


def _bare(sumocfg: str, end: float, reads: bool = False) -> tuple[float, int]:
    """Wall time of SUMO alone (with ``reads``: plus every vehicle's speed and leader at every
    step), and the peak number of vehicles."""
    import libsumo
    import numpy as np

    from acc_fusion.truth.sumo.config import SumoConfig
    from acc_fusion.truth.sumo.launch import sumo_command
    from acc_fusion.truth.sumo.native import sumo_reader

    config = SumoConfig(sumocfg=sumocfg, end=end)
    libsumo.start([*sumo_command(config), "--end", str(end)])
    # As SumoSource reads: the compiled reader, else the SWIG functions without libsumo's
    # Python wrappers.
    native = sumo_reader() if reads else None
    codes = native.Codes() if native is not None else None  # empty: no leader is found
    get_ids, get_speed = libsumo._libsumo.vehicle_getIDList, libsumo._libsumo.vehicle_getSpeed
    get_leader, lookahead = libsumo._libsumo.vehicle_getLeader, config.lookahead
    out, slots = np.empty((3, 4096)), np.arange(4096)
    peak = 0
    t0 = time.perf_counter()
    try:
        while libsumo.simulation.getTime() < end - 1e-9:
            libsumo.simulationStep()
            peak = max(peak, libsumo.vehicle.getIDCount())
            if not reads:
                continue
            ids = get_ids()
            if native is not None:
                if len(ids) > out.shape[1]:
                    out, slots = np.empty((3, 2 * len(ids))), np.arange(2 * len(ids))
                n = out.shape[1]
                native.read(list(ids), slots, lookahead, codes, n, *out[:2], out[2].view(np.int64))
            else:
                deque(map(get_speed, ids), maxlen=0)
                deque(map(get_leader, ids, repeat(lookahead)), maxlen=0)
    finally:
        elapsed = time.perf_counter() - t0
        libsumo.close()
    return elapsed, peak


def _source(sumocfg: str, end: float) -> tuple[float]:
    """Wall time of the background source alone, from its first frame to its last, with
    nothing done with the frames."""
    from acc_fusion.truth.sumo.background import BackgroundSumoSource
    from acc_fusion.truth.sumo.config import SumoConfig

    source = BackgroundSumoSource(SumoConfig(sumocfg=sumocfg, end=end))
    t0 = time.perf_counter()
    try:
        while not source.done:
            source.advance()
    finally:
        elapsed = time.perf_counter() - t0
        source.close()
    return (elapsed,)


def _rss_mb(pids: tuple[int | str, ...] = ("self",)) -> float:
    """Resident memory of these processes together [MB] (Linux /proc; else this process's
    peak so far)."""
    try:
        total = 0
        for pid in pids:
            with open(f"/proc/{pid}/statm") as f:
                total += int(f.read().split()[1])
        return total * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**10


def _pipeline(sumocfg: str, end: float, inline: bool) -> tuple[float, int, float, float, float]:
    """Wall time of SUMO with the FCW pipeline on every equipped vehicle, the peak of
    simultaneously equipped vehicles, the resident memory [MB] of the pipeline's process
    and SUMO's child process together at a quarter of the run and at its end, and the
    pipeline process's CPU time per step [ms]."""
    from acc_fusion.sim.closed_loop import SimConfig, simulate
    from acc_fusion.truth.sumo.background import BackgroundSumoSource
    from acc_fusion.truth.sumo.config import SumoConfig
    from acc_fusion.truth.sumo.source import SumoSource

    # Before SUMO starts (a background source would run ahead meanwhile, off the clock):
    # compile, or load from numba's cache, every kernel of the pipeline.
    simulate(SimConfig(runs=4, duration=2.0, methods=("federated",)))
    config = SumoConfig(sumocfg=sumocfg, end=end)
    source = SumoSource(config) if inline else BackgroundSumoSource(config)
    pids = ("self",) if inline else ("self", source.pid)
    sim = SimConfig(runs=1, dt=source.dt, methods=("federated",))
    peak, rss = [0], []

    def count(view) -> None:
        peak[0] = max(peak[0], int(source.active.sum()))
        if not rss and view.frame.t >= source.begin + end / 4:
            rss.append(_rss_mb(pids))

    t0, c0 = time.perf_counter(), time.process_time()
    try:
        steps = simulate(replace(sim), source=source, on_step=count).steps
    finally:
        elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
        rss.append(_rss_mb(pids))
        source.close()
    return elapsed, peak[0], rss[0], rss[-1], 1e3 * cpu / max(steps, 1)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="200 s simulated (under a minute)")
    parser.add_argument("--end", type=float, help="simulated seconds (default 600, quick 200)")
    parser.add_argument("--net", default="motorway", help="bundled network (default motorway)")
    parser.add_argument(
        "--repeat", type=int, default=3, help="bare + pipeline pairs, median ratio (default 3)"
    )
    parser.add_argument(
        "--inline", action="store_true", help="SUMO in the pipeline's process (no child)"
    )
    args = parser.parse_args(argv)
    # Here, not at the top: the worker processes import this script, and the traffic module
    # brings the whole pipeline with it (a second or more per worker).
    from acc_fusion.truth.sumo.nets import bundled_nets

    nets = bundled_nets()
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    if args.net not in nets:
        parser.error(f"--net must be one of {', '.join(nets)}, got {args.net!r}")
    end = args.end or (200.0 if args.quick else 600.0)
    sumocfg = str(nets[args.net])
    ctx = multiprocessing.get_context("spawn")

    def measure(func, *extra):
        with ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
            return pool.submit(func, sumocfg, end, *extra).result()

    # Bare and pipeline runs back to back, repeated: each pair shares the machine's state of
    # the moment, and the median of the pairs' ratios is robust to a slow spell in one run.
    pairs_run = []
    for _ in tqdm(range(args.repeat), desc="bare + pipeline runs", unit="pair", leave=False):
        pairs_run.append((measure(_bare), measure(_pipeline, args.inline)))
    t_reads, t_source = measure(_bare, True)[0], measure(_source)[0]
    t_bare = median(b[0] for b, _ in pairs_run)
    t_pipe = median(p[0] for _, p in pairs_run)
    ratio = median(p[0] / b[0] for b, p in pairs_run)
    peak, (_, pairs, rss_quarter, rss_end, _) = pairs_run[0][0][1], pairs_run[-1][1]
    cpu_step = median(p[4] for _, p in pairs_run)
    print(f"network {args.net}: {end:g} s simulated, peak {peak} vehicles, {pairs} equipped pairs")
    for i, ((b, _), (p, *_)) in enumerate(pairs_run, 1):
        print(f"pair {i}: bare {b:.2f} s, pipeline {p:.2f} s wall, ratio {p / b:.3f}")
    print(f"bare SUMO           {t_bare:8.2f} s wall (median)")
    print(f"SUMO + reads only   {t_reads:8.2f} s wall (speed and leader of every vehicle)")
    print(f"SUMO source alone   {t_source:8.2f} s wall (child process, frames only received)")
    where = "in the pipeline's process" if args.inline else "in a child process, streaming ahead"
    print(
        f"SUMO + FCW pipeline {t_pipe:8.2f} s wall (median; SUMO {where}; "
        f"the pipeline's process {cpu_step:.2f} ms CPU per step)"
    )
    print(
        f"memory (pipeline and SUMO processes): {rss_quarter:.0f} MB at {end / 4:g} s, "
        f"{rss_end:.0f} MB at {end:g} s ({rss_end - rss_quarter:+.1f} MB)"
    )
    print(f"source_ratio={t_source / t_bare:.3f}")
    print(f"floor_ratio={t_reads / t_bare:.3f}")
    print(f"overhead_ratio={ratio:.3f}")


if __name__ == "__main__":
    main()
