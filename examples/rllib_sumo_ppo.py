"""Train a warning policy with RLlib's PPO on SUMO traffic, two env runners in parallel.

Each RLlib env runner is a process with its own embedded SUMO (libsumo allows one simulation
per process and is not thread-safe: that is why runners, never threads); each episode is one
equipped vehicle of that simulation and its leader.  Needs the ``rllib`` and ``sumo`` extras
(``pip install 'acc_fusion[rllib,sumo]'``).  On a cluster, point ``ray.init`` at it and raise
``--runners``.  Run it:

    python examples/rllib_sumo_ppo.py                      # 2 iterations, a few minutes
    python examples/rllib_sumo_ppo.py --iterations 50 --net motorway
"""

from __future__ import annotations

import argparse


def make_env(env_config: dict):
    """The env creator each runner calls: importing acc_fusion registers the environment."""
    import gymnasium as gym

    import acc_fusion  # noqa: F401

    return gym.make("acc_fusion/CollisionWarning-v0", source="sumo", **env_config)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=2, help="training iterations")
    parser.add_argument("--runners", type=int, default=2, help="env runner processes")
    parser.add_argument("--net", default="ring", help="bundled SUMO network (default ring)")
    parser.add_argument("--batch", type=int, default=400, help="steps per training batch")
    parser.add_argument(
        "--episode-steps", type=int, default=200, help="steps per episode at most (default 200)"
    )
    args = parser.parse_args(argv)

    import ray
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.tune.registry import register_env

    ray.init(num_cpus=args.runners + 1, include_dashboard=False, log_to_driver=False)
    register_env("acc_fusion_sumo", make_env)
    config = (
        PPOConfig()
        .environment(
            "acc_fusion_sumo",
            env_config={
                "sumo": {"net": args.net, "warmup": 0},
                "max_episode_steps": args.episode_steps,
            },
        )
        .env_runners(num_env_runners=args.runners, num_envs_per_env_runner=1)
        .training(
            train_batch_size_per_learner=args.batch,
            minibatch_size=min(128, args.batch),
            num_epochs=2,
            lr=3e-4,
        )
        .learners(num_learners=0)
        .debugging(seed=0)
    )
    algo = config.build_algo()
    try:
        for i in range(args.iterations):
            result = algo.train()
            runners = result["env_runners"]
            print(
                f"iteration {i + 1}: {runners['num_env_steps_sampled_lifetime']} steps, "
                f"episode return mean {runners.get('episode_return_mean', float('nan')):.2f}"
            )
    finally:
        algo.stop()
        ray.shutdown()


if __name__ == "__main__":
    main()
