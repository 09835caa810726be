"""Train a warning policy with RLlib's PPO in SUMO traffic, on two env runners.

The environment is ``acc_fusion/CollisionWarning-v0`` with ``source="sumo"``: an episode
follows one equipped vehicle of a running SUMO simulation (a bundled network) and the policy
chooses the warning its driver hears.  libsumo holds one simulation per process, so the SUMO
source scales out with processes, never threads: RLlib's env runners are Ray actors, each a
process of its own with its own libsumo (and each seeded differently, so each runs its own
traffic).  This uses RLlib's new API stack (RLModule, Learner, EnvRunner, ConnectorV2), the
default since Ray 2.40; it needs the ``rllib`` extra (RLlib and torch) and the ``sumo`` one
(``pip install 'acc_fusion[rllib,sumo]'``).  Run it:

    python examples/rllib_sumo_ppo.py                      # 5 iterations of 2 000 steps
    python examples/rllib_sumo_ppo.py --iterations 2 --batch 200 --episode-steps 50
    python examples/rllib_sumo_ppo.py --net motorway --runners 4 --iterations 50

It prints, per training iteration, the steps sampled so far and the mean return of the
episodes finished in that iteration (the reward of :class:`acc_fusion.envs.options.RewardConfig`:
penalties for false alarms, misses and collisions), then the process of each env runner.
"""

from __future__ import annotations

import argparse
import math
import os

import gymnasium as gym
import ray
from ray.rllib.algorithms.ppo import PPOConfig
from ray.tune.registry import register_env

ENV_ID = "acc_fusion/CollisionWarning-v0"


def make_sumo_env(env_config: dict) -> gym.Env:
    """The collision-warning environment on SUMO traffic (called in every env runner)."""
    import acc_fusion  # noqa: F401  (registers the environment in the env runner's process)

    return gym.make(ENV_ID, source="sumo", **env_config)


def sumo_process(runner) -> tuple[int, int]:
    """The process id of an env runner and the SUMO simulations its environment started."""
    env = runner.env.unwrapped.envs[0].unwrapped
    return os.getpid(), env.sumo_starts


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=5, help="training iterations (5)")
    parser.add_argument("--batch", type=int, default=2000, help="steps per iteration (2000)")
    parser.add_argument("--episode-steps", type=int, default=400, help="steps per episode (400)")
    parser.add_argument("--net", default="ring", help="bundled SUMO network (ring)")
    parser.add_argument("--warmup", type=float, default=30.0, help="SUMO warm-up [s] (30)")
    parser.add_argument("--runners", type=int, default=2, help="env runner processes (2)")
    parser.add_argument("--seed", type=int, default=0, help="seed (env runner i: seed + i)")
    args = parser.parse_args(argv)

    register_env("acc_fusion_sumo", make_sumo_env)
    config = (
        PPOConfig()
        .environment(
            "acc_fusion_sumo",
            env_config={
                "sumo": {"net": args.net, "warmup": args.warmup},
                "max_episode_steps": args.episode_steps,
            },
        )
        .framework("torch")
        # Each env runner is a Ray actor: a process of its own, with one SUMO simulation.  Its
        # first sample starts SUMO and may compile the pipeline (numba's cache is cold on a
        # fresh install): minutes on a loaded machine, beyond RLlib's default 60 s wait.
        .env_runners(
            num_env_runners=args.runners, num_envs_per_env_runner=1, sample_timeout_s=900.0
        )  # fmt: skip
        .training(
            train_batch_size_per_learner=args.batch,
            minibatch_size=min(128, args.batch),
            num_epochs=4,
            gamma=0.97,
            lr=3e-4,
        )
        .debugging(seed=args.seed)
    )
    # A local Ray with a logical CPU for the main process (which holds the learner) and one
    # per env runner; on a cluster, ray.init(address=...) instead.
    ray.init(num_cpus=args.runners + 1, include_dashboard=False, log_to_driver=False)
    try:
        algo = config.build_algo()
        for i in range(1, args.iterations + 1):
            runners = algo.train().get("env_runners", {})  # empty if nothing was sampled
            mean = runners.get("episode_return_mean", math.nan)
            print(
                f"iteration {i}: {int(runners.get('num_env_steps_sampled_lifetime', 0))} steps "
                f"sampled, {int(runners.get('num_episodes', 0))} episodes done, "
                f"mean return {mean:.2f}"
            )
        runners = algo.env_runner_group.foreach_env_runner(sumo_process, local_env_runner=False)
        print(f"main process {os.getpid()}; env runners (process, SUMO starts): {runners}")
        algo.stop()
    finally:
        ray.shutdown()


if __name__ == "__main__":
    main()
