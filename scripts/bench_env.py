"""Benchmark: steps per second of the native vector environment, against highway-env.

Times, in one run, ``acc_fusion/CollisionWarning-v0`` as a native vector environment
(``gym.make_vec(..., vectorization_mode="vector_entry_point")``, 1 024 copies stepped with
array arithmetic) with random actions, and highway-env's own ``highway-fast-v0`` (one
environment, random actions; it must be installed: ``pip install 'acc_fusion[highway]'``).

    python scripts/bench_env.py            # 1 024 copies, 200 steps
    python scripts/bench_env.py --quick    # 1 024 copies, 50 steps; under a minute

The last line is exactly ``vector_env_steps_per_s=<float> ratio_vs_highway_env=<float>``
(target: >= 100 000 steps/s).
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import acc_fusion  # noqa: F401  (registers the environment)


def vector_steps_per_s(num_envs: int, steps: int, seed: int) -> float:
    envs = gym.make_vec(
        "acc_fusion/CollisionWarning-v0", num_envs=num_envs, vectorization_mode="vector_entry_point"
    )
    envs.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(5):  # warm-up: numba kernels, first tracks
        envs.step(rng.integers(0, 3, num_envs))
    t0 = time.perf_counter()
    for _ in range(steps):
        envs.step(rng.integers(0, 3, num_envs))
    return num_envs * steps / (time.perf_counter() - t0)


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
    args = parser.parse_args(argv)
    steps = 50 if args.quick else 200
    ours = vector_steps_per_s(args.num_envs, steps, args.seed)
    theirs = highway_steps_per_s(100 if args.quick else 300, args.seed)
    print(f"acc_fusion vector env ({args.num_envs} copies): {ours:,.0f} steps/s")
    print(f"highway-env highway-fast-v0 (1 env):          {theirs:,.0f} steps/s")
    print(f"vector_env_steps_per_s={ours:.1f} ratio_vs_highway_env={ours / theirs:.2f}")


if __name__ == "__main__":
    main()
