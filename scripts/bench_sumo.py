"""Benchmark: the cost of the FCW pipeline on top of a SUMO traffic simulation.

Runs the same SUMO scenario (the bundled motorway, >= 500 vehicles at peak) twice, each in a
fresh process (libsumo allows one simulation per process), one after the other:

* **bare**: SUMO alone, ``simulationStep`` in a loop;
* **pipeline**: SUMO through :class:`acc_fusion.sumo.SumoSource` with the whole FCW
  pipeline on every equipped vehicle: radar and infrared sensors, ego-motion filter,
  federated fusion with fault detection, warning logic, oracle and streaming metrics.

It prints both wall times, the peak number of vehicles and equipped pairs, and as its last
line ``overhead_ratio=<pipeline wall time / bare wall time>`` (target: <= 1.5).

    python scripts/bench_sumo.py            # 600 s simulated
    python scripts/bench_sumo.py --quick    # 200 s simulated, under a minute
"""

from __future__ import annotations

import argparse
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

from acc_fusion.traffic import bundled_nets


def _bare(sumocfg: str, end: float) -> tuple[float, int]:
    """Wall time of SUMO alone, and the peak number of vehicles."""
    import libsumo
    import sumo  # noqa: F401  (sets SUMO_HOME)

    libsumo.start(
        ["sumo", "-c", sumocfg, "--no-step-log", "true", "--no-warnings", "true", "--end", str(end)]
    )
    peak = 0
    t0 = time.perf_counter()
    try:
        while libsumo.simulation.getTime() < end - 1e-9:
            libsumo.simulationStep()
            peak = max(peak, libsumo.vehicle.getIDCount())
    finally:
        elapsed = time.perf_counter() - t0
        libsumo.close()
    return elapsed, peak


def _pipeline(sumocfg: str, end: float) -> tuple[float, int]:
    """Wall time of SUMO with the FCW pipeline on every equipped vehicle, and the peak of
    simultaneously equipped vehicles."""
    from acc_fusion.fcw import SimConfig, simulate
    from acc_fusion.kalman import warmup
    from acc_fusion.sumo import SumoConfig, SumoSource

    warmup()
    source = SumoSource(SumoConfig(sumocfg=sumocfg, end=end))
    sim = SimConfig(runs=1, dt=source.dt, methods=("federated",))
    peak = [0]

    def count(view) -> None:
        peak[0] = max(peak[0], int(source.active.sum()))

    t0 = time.perf_counter()
    try:
        simulate(replace(sim), source=source, on_step=count)
    finally:
        elapsed = time.perf_counter() - t0
        source.close()
    return elapsed, peak[0]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="200 s simulated (under a minute)")
    parser.add_argument("--end", type=float, help="simulated seconds (default 600, quick 200)")
    parser.add_argument("--net", default="motorway", help="bundled network (default motorway)")
    args = parser.parse_args(argv)
    nets = bundled_nets()
    if args.net not in nets:
        parser.error(f"--net must be one of {', '.join(nets)}, got {args.net!r}")
    end = args.end or (200.0 if args.quick else 600.0)
    sumocfg = str(nets[args.net])
    ctx = multiprocessing.get_context("spawn")
    results = {}
    for name, func in (("bare", _bare), ("pipeline", _pipeline)):
        with ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
            results[name] = pool.submit(func, sumocfg, end).result()
    (t_bare, peak), (t_pipe, pairs) = results["bare"], results["pipeline"]
    print(f"network {args.net}: {end:g} s simulated, peak {peak} vehicles, {pairs} equipped pairs")
    print(f"bare SUMO           {t_bare:8.2f} s wall")
    print(f"SUMO + FCW pipeline {t_pipe:8.2f} s wall")
    print(f"overhead_ratio={t_pipe / t_bare:.3f}")


if __name__ == "__main__":
    main()
