"""Throughput of ``acc-fusion sweep`` on the local and the Ray executor.

A sweep of 20-second runs of the randomised scripted suite (dt = 0.05 s: 400 steps; every
run evaluates the four methods radar, infrared, centralized and federated on the same truth,
with radar clutter), two warning settings (``warning.z`` 0 and 1), chunks of ``--chunk``
runs, on ``--workers`` processes: first the local process pool, then a local Ray with the
same number of CPUs (skipped when Ray is not installed, or with ``--no-ray``).  Prints per
executor the runs, the wall time (from the first chunk submitted to the last row stored,
worker start-up included; Ray's own start-up is timed apart), runs/s and pair-steps/s (a
pair-step: one run advanced by one step, all four methods), and whether both executors gave
identical rows.  The last line is ``runs_per_s=<float>`` of the local executor (target:
>= 1 800 on 2 cores).

    python scripts/bench_sweep.py            # 10 000 runs per executor
    python scripts/bench_sweep.py --quick    # 4 000 runs per executor (under a minute)

Throughput grows with the chunk size: a batched step costs a fixed few milliseconds of
Python overhead plus about 1 µs per run and method (see README, "Sweeps").
"""

from __future__ import annotations

import argparse
import tempfile
import time

from acc_fusion.cli.arguments import positive_int
from acc_fusion.sweep.config import SweepConfig
from acc_fusion.sweep.run import run_sweep


def sweep_config(runs_per_point: int, chunk: int) -> SweepConfig:
    return SweepConfig.from_mapping(
        {
            "name": "bench",
            "runs": runs_per_point,
            "chunk_runs": chunk,
            "base": {"scenario": "random", "duration": 20.0, "radar": {"ghost_rate": 0.05}},
            "axes": {"warning.z": [0.0, 1.0]},
        }
    )


def measure(cfg: SweepConfig, executor: str, workers: int):
    with tempfile.TemporaryDirectory() as out:
        result = run_sweep(
            cfg, out, executor=executor, workers=workers, progress=False, report=False
        )
    steps = int(result.rows["steps"].iloc[0])
    runs_per_s = result.ran_runs / result.seconds
    print(
        f"{executor:5s}: {result.ran_runs} runs x {steps} steps in {result.seconds:.1f} s: "
        f"{runs_per_s:.0f} runs/s, {runs_per_s * steps:.3g} pair-steps/s "
        f"({len(set(result.rows['method']))} methods each)",
        flush=True,
    )
    return result, runs_per_s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="4 000 runs per executor")
    parser.add_argument("--workers", type=positive_int, default=2, help="processes / Ray CPUs (2)")
    parser.add_argument(
        "--chunk", type=positive_int, default=None, help="runs per chunk (2000 / 2500)"
    )
    parser.add_argument("--no-ray", action="store_true", help="only the local executor")
    args = parser.parse_args()
    per_point = 2000 if args.quick else 5000
    cfg = sweep_config(per_point, args.chunk or (2000 if args.quick else 2500))
    print(
        f"sweep: {cfg.total_runs} runs of 20 s ({len(cfg.chunks())} chunks of "
        f"{cfg.chunk_runs}), {args.workers} workers",
        flush=True,
    )
    local, local_rate = measure(cfg, "local", args.workers)
    ray = None
    if not args.no_ray:
        try:
            import ray
        except ImportError:
            print("ray  : not installed, skipped")
    if ray is not None:
        t0 = time.perf_counter()
        ray.init(num_cpus=args.workers, include_dashboard=False, log_to_driver=False)
        print(f"ray  : started a local Ray in {time.perf_counter() - t0:.1f} s", flush=True)
        try:
            remote, _ = measure(cfg, "ray", args.workers)
        finally:
            ray.shutdown()
        print(f"identical rows on both executors: {remote.rows.equals(local.rows)}")
    print(f"runs_per_s={local_rate:.1f}")


if __name__ == "__main__":
    main()
