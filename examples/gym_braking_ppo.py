"""Train PPO to warn and brake, and rank it against the baselines on collisions, impact speed
and false activations.

The environment is ``gym.make("acc_fusion/CollisionAvoidance-v0")``: the warning environment
whose action also commands a brake stage (none, partial, full) through the brake system of
:mod:`acc_fusion.braking.aeb`, rewarded from outcomes (a collision and its impact speed, false
braking, nuisance and sensing-false warnings; :mod:`acc_fusion.envs.braking`).  PPO trains on
64 copies of its native vector environment (:func:`acc_fusion.envs.rl.train_ppo`); the
evaluation runs it and the baselines (never, the papers' safety-distance rule, acc_fusion's
warning rule, the rule with AEB as configured) on the same episodes and seeds.  Needs the
``rl`` extra.  Run it:

    python examples/gym_braking_ppo.py                                # 2 M steps, 200 episodes
    python examples/gym_braking_ppo.py --timesteps 4096 --episodes 4  # a smoke test
"""

from __future__ import annotations

import argparse

from acc_fusion.envs.braking_eval import (
    BRAKING_ENV_ID,
    ModelPolicy,
    braking_baselines,
    braking_table,
    evaluate_braking,
)
from acc_fusion.envs.rl import train_ppo


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--timesteps", type=int, default=2_000_000, help="training steps")
    parser.add_argument("--minutes", type=float, default=10.0, help="training time limit")
    parser.add_argument("--episodes", type=int, default=200, help="evaluation episodes")
    parser.add_argument("--seed", type=int, default=0, help="seed of training and evaluation")
    args = parser.parse_args(argv)

    model, stats = train_ppo(args.timesteps, args.minutes, args.seed, env_id=BRAKING_ENV_ID,
                             gamma=0.99, progress=True)  # fmt: skip
    print(f"trained PPO for {stats['timesteps']} steps in {stats['seconds']:.0f} s")
    policies = {"ppo": ModelPolicy(model), **braking_baselines()}
    evals = {name: evaluate_braking(p, args.episodes, args.seed + 1, progress=True)
             for name, p in policies.items()}  # fmt: skip
    title = f"Warn and brake: {args.episodes} episodes, seed {args.seed + 1}"
    print(braking_table(evals, title).format())


if __name__ == "__main__":
    main()
