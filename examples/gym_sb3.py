"""Train a PPO warning policy with Stable-Baselines3 and compare it with the baseline rules.

The environment is the ordinary gymnasium one, ``gym.make("acc_fusion/CollisionWarning-v0")``
(one ego following one lead through the randomised scripted suite; the action is the warning
level the driver hears), so any gymnasium agent can learn on it.  PPO here gets the project's
feature extractor (:class:`acc_fusion.envs.rl.FCWFeatures`: the observation scaled to [-1, 1]
plus time-to-collision-like threat features) and hyper-parameters
(:data:`acc_fusion.envs.rl.PPO_DEFAULTS`).  The evaluation harness then runs the trained
policy and two baseline rules on the same episodes and seeds.  Needs the ``rl`` extra
(``pip install 'acc_fusion[rl]'``).  Run it:

    python examples/gym_sb3.py                              # 20 000 steps, 5 episodes
    python examples/gym_sb3.py --timesteps 512 --episodes 2 # a smoke test

One environment learns slowly (a few hundred steps per second): to learn a useful policy,
train on the native vector environment, thousands of steps per second
(``python scripts/train_ppo.py``, :func:`acc_fusion.envs.rl.train_ppo`).
"""

from __future__ import annotations

import argparse

import gymnasium as gym

import acc_fusion  # noqa: F401  (registers the environment)
from acc_fusion.envs.evaluation import compare_policies
from acc_fusion.envs.policies import BASELINES
from acc_fusion.envs.rl import ENV_ID, make_ppo


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--timesteps", type=int, default=20_000, help="training steps")
    parser.add_argument("--episodes", type=int, default=5, help="evaluation episodes")
    parser.add_argument("--seed", type=int, default=0, help="seed of training and evaluation")
    args = parser.parse_args(argv)

    env = gym.make(ENV_ID)
    model = make_ppo(env, seed=args.seed, n_steps=256, batch_size=64)
    model.learn(total_timesteps=args.timesteps)
    env.close()
    print(f"trained PPO for {model.num_timesteps} steps")

    policies = {"ppo": model, "ttc": BASELINES["ttc"], "never_warn": BASELINES["never_warn"]}
    print(compare_policies(policies, episodes=args.episodes, seed=args.seed).format())


if __name__ == "__main__":
    main()
