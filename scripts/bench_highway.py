"""Benchmark: the cost of the FCW pipeline on top of a highway-env simulation.

Runs the same highway-env episodes (same environment, seeds and driving: open loop, the
controlled vehicle cruising, nobody braking for warnings) twice in this process:

* **bare**: highway-env alone, stepped at its simulation frequency as
  ``AbstractEnv._simulate`` does (``road.act()``, ``road.step(dt)``) until highway-env
  terminates the episode or its duration is reached;
* **pipeline**: the same episodes through :class:`acc_fusion.truth.highway.source.HighwaySource`
with the
  whole FCW pipeline on every pair (``pairs="all"``: every vehicle and its leader): radar and
  infrared sensors, ego-motion filter, the fusion methods (``--methods federated``, default:
  the federated filter with fault detection; ``--methods all``: radar alone, infrared alone,
  centralized and federated), each method's warning logic, the oracle and streaming metrics.

Each is run ``--repeat`` times, alternately, and the fastest run of each counts.  Times are
the process's CPU time (``time.process_time``): on a shared machine the wall time also counts
the waits for other users' processes (it is printed too).  It prints both times, the
simulation steps, the pairs, and as its last line
``overhead_ratio=<pipeline CPU time / bare CPU time>`` (target: <= 1.2).

    python scripts/bench_highway.py                          # highway-v0, 5 episodes
    python scripts/bench_highway.py --env highway-fast-v0 --methods all
    python scripts/bench_highway.py --quick                  # 2 episodes of 10 s, < 1 minute
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from acc_fusion.sim.closed_loop import DEFAULT_METHODS, SimConfig, simulate
from acc_fusion.truth.highway.config import DEFAULT_DURATION, SUPPORTED, HighwayConfig, make_env
from acc_fusion.truth.highway.source import HighwaySource


def bare(config: HighwayConfig) -> tuple[float, float, int]:
    """Wall and CPU time of highway-env alone over the episodes of ``config``, its steps."""
    t0, c0 = time.perf_counter(), time.process_time()
    env = make_env(config)
    dt = 1.0 / env.config["simulation_frequency"]
    duration = config.duration or env.config.get("duration") or DEFAULT_DURATION
    steps = 0
    for k in range(config.episodes):
        env.reset(seed=config.seed + k)
        for _ in range(max(1, math.ceil(duration / dt - 1e-6))):
            env.road.act()
            env.road.step(dt)
            env.steps += 1
            steps += 1
            if env._is_terminated():
                break
    env.close()
    return time.perf_counter() - t0, time.process_time() - c0, steps


def pipeline(config: HighwayConfig, methods: tuple[str, ...]) -> tuple[float, float, int, int]:
    """Wall and CPU time of highway-env with the FCW pipeline on every pair, its steps
    (without the one reset step per episode) and its pairs."""
    t0, c0 = time.perf_counter(), time.process_time()
    source = HighwaySource(config)
    result = simulate(SimConfig(runs=1, dt=source.dt, methods=methods, drive=None), source=source)
    source.close()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return wall, cpu, result.steps - config.episodes, source.n_pairs


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", default="highway-v0", choices=SUPPORTED)
    parser.add_argument("--episodes", type=int, help="episodes (default 5, quick 2)")
    parser.add_argument(
        "--duration", type=float, help="seconds per episode (default: env's, quick 10)"
    )
    parser.add_argument("--seed", type=int, default=0, help="episode k uses seed + k (default 0)")
    parser.add_argument("--methods", choices=("federated", "all"), default="federated")
    parser.add_argument("--repeat", type=int, default=2, help="runs of each, best counts (2)")
    parser.add_argument("--quick", action="store_true", help="2 episodes of 10 s")
    args = parser.parse_args(argv)
    from acc_fusion.filters.kalman import warmup

    config = HighwayConfig(
        env=args.env,
        episodes=args.episodes or (2 if args.quick else 5),
        seed=args.seed,
        duration=args.duration or (10.0 if args.quick else None),
        pairs="all",
    )
    methods = ("federated",) if args.methods == "federated" else DEFAULT_METHODS
    warmup()  # before timing: compile the batched engine's kernels, import highway-env
    make_env(config).close()
    repeat = max(1, args.repeat)
    t_bare, t_pipe = [], []
    for _ in range(repeat):
        *times, steps = bare(config)
        t_bare.append(times)
        *times, steps_pipe, pairs = pipeline(config, methods)
        t_pipe.append(times)
    if steps != steps_pipe:
        raise SystemExit(f"the runs differ: {steps} bare steps, {steps_pipe} pipeline steps")
    print(
        f"{args.env}: {config.episodes} episodes from seed {config.seed}, {steps} simulation "
        f"steps, {pairs} pairs, methods {', '.join(methods)}, best of {repeat}"
    )
    (w_bare, c_bare), (w_pipe, c_pipe) = np.min(t_bare, axis=0), np.min(t_pipe, axis=0)
    print(f"bare highway-env            {c_bare:8.2f} s CPU {w_bare:8.2f} s wall")
    print(f"highway-env + FCW pipeline  {c_pipe:8.2f} s CPU {w_pipe:8.2f} s wall")
    print(f"wall-time ratio {w_pipe / w_bare:.3f}")
    print(f"overhead_ratio={c_pipe / c_bare:.3f}")


if __name__ == "__main__":
    main()
