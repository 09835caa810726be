"""Benchmark: steps per second of the native vector environment, against highway-env.

Times, in one run, ``acc_fusion/CollisionWarning-v0`` as a native vector environment
(``gym.make_vec(..., vectorization_mode="vector_entry_point")``, 1 024 copies stepped with
array arithmetic) with random actions, and highway-env's own ``highway-fast-v0`` (one
environment, random actions; it must be installed: ``pip install 'acc_fusion[highway]'``).

    python scripts/bench_env.py            # 1 024 copies, 200 steps
    python scripts/bench_env.py --quick    # 1 024 copies, 50 steps; under a minute
    python scripts/bench_env.py --stages   # and the ms per step of each stage

It prints the median time of a step; ``--stages`` times the stages of a step too (each
stage's method wrapped in a timer, which adds about 1 µs a call; nested stages are counted
in their own row and in the stage that calls them).

The last line is exactly ``vector_env_steps_per_s=<float> ratio_vs_highway_env=<float>``
(target: >= 500 000 steps/s).
"""

from __future__ import annotations

import argparse
import collections
import time

import gymnasium as gym
import numpy as np

import acc_fusion  # noqa: F401  (registers the environment)

#: Untimed steps before timing: at least ``MIN_WARMUP_STEPS`` and, up to ``MAX_WARMUP_STEPS``,
#: until the step after the first copy ended, which restarts it.  The first steps load the
#: numba kernels of a step from numba's cache and start the first tracks; the first restart
#: loads those that clear a copy (12-25 ms once), which timed would weigh a quarter of the
#: quick form's 50 steps.
MIN_WARMUP_STEPS, MAX_WARMUP_STEPS = 5, 200

#: The stages ``--stages`` times: (module, class or None, attribute, row name).
STAGES = (
    ("acc_fusion.envs.core", "_Core", "_new_episodes", "new episodes"),
    ("acc_fusion.truth.scripted", "ScenarioSource", "start", "  placing them"),
    ("acc_fusion.truth.scripted", "ScenarioSource", "draw", "  drawing them"),
    ("acc_fusion.truth.scripted", "ScenarioSource", "move", "source step"),
    ("acc_fusion.truth.scripted", "ScenarioSource", "frame", "source frame"),
    ("acc_fusion.sim.closed_loop", "Perception", "step", "perception"),
    ("acc_fusion.fusion.base", "Estimator", "step", "  estimator"),
    ("acc_fusion.fusion.federated", None, "_federated_step", "    its compiled step"),
    ("acc_fusion.sensors.sensor", "Sensor", "measure", "  sensors"),
    ("acc_fusion.sim.closed_loop", None, "judge", "  oracle and crash relevance"),
    ("acc_fusion.sim.closed_loop", "Perception", "forget", "  clearing restarted copies"),
    ("acc_fusion.envs.core", "_Core", "observe", "observation and info"),
    ("acc_fusion.envs.core", "_Core", "_brakes", "drivers"),
    ("acc_fusion.envs.core", "_Core", "_reward", "reward"),
)


def _timed(stages: collections.Counter) -> None:
    """Wrap every stage of :data:`STAGES` in a timer adding its seconds to ``stages``."""
    import importlib

    for module, cls, name, row in STAGES:
        owner = importlib.import_module(module)
        owner = getattr(owner, cls) if cls else owner
        inner = getattr(owner, name)

        def timed(*args, _inner=inner, _row=row, **kwargs):
            t = time.perf_counter()
            try:
                return _inner(*args, **kwargs)
            finally:
                stages[_row] += time.perf_counter() - t

        setattr(owner, name, timed)


def vector_steps_per_s(num_envs: int, steps: int, seed: int, stages=None) -> float:
    if stages is not None:
        _timed(stages)
    envs = gym.make_vec(
        "acc_fusion/CollisionWarning-v0", num_envs=num_envs, vectorization_mode="vector_entry_point"
    )
    envs.reset(seed=seed)
    rng = np.random.default_rng(seed)
    ended = False
    for k in range(MAX_WARMUP_STEPS):  # warm-up: numba kernels, first tracks, first restarts
        _, _, terminated, truncated, _ = envs.step(rng.integers(0, 3, num_envs))
        if ended and k >= MIN_WARMUP_STEPS:
            break
        ended = ended or bool(np.any(terminated | truncated))
    if stages is not None:
        stages.clear()
    times = np.empty(steps)
    t0 = time.perf_counter()
    for k in range(steps):
        envs.step(rng.integers(0, 3, num_envs))
        times[k] = time.perf_counter()
    steps_per_s = num_envs * steps / (times[-1] - t0)
    step_ms = 1e3 * np.median(np.diff(times, prepend=t0))
    print(f"median step of {num_envs} copies: {step_ms:.3f} ms ({steps} steps)")
    for row in [r for *_, r in STAGES] if stages is not None else []:
        print(f"  {row:32s} {1e3 * stages[row] / steps:.3f} ms a step")
    return steps_per_s


def highway_steps_per_s(steps: int, seed: int) -> float:
    try:
        import highway_env  # noqa: F401
    except ImportError:
        raise SystemExit(
            "highway-env is not installed: pip install 'acc_fusion[highway]'"
        ) from None
    env = gym.make("highway-fast-v0")
    env.reset(seed=seed)
    n, t0 = 0, time.perf_counter()
    while n < steps:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        n += 1
        if terminated or truncated:
            env.reset()
    return n / (time.perf_counter() - t0)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps (under a minute)")
    parser.add_argument("--num-envs", type=int, default=1024, help="copies (default 1024)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--stages", action="store_true", help="time each stage of a step too")
    args = parser.parse_args(argv)
    steps = 50 if args.quick else 200
    stages = collections.Counter() if args.stages else None
    ours = vector_steps_per_s(args.num_envs, steps, args.seed, stages)
    theirs = highway_steps_per_s(100 if args.quick else 300, args.seed)
    print(f"acc_fusion vector env ({args.num_envs} copies): {ours:,.0f} steps/s")
    print(f"highway-env highway-fast-v0 (1 env):          {theirs:,.0f} steps/s")
    print(f"vector_env_steps_per_s={ours:.1f} ratio_vs_highway_env={ours / theirs:.2f}")


if __name__ == "__main__":
    main()
