"""Train a Stable-Baselines3 PPO warning policy on the native vector environment and compare it
with the baselines.

PPO learns on ``acc_fusion/CollisionWarning-v0`` as a native vector environment
(``--num-envs`` copies stepped with array arithmetic, presented to Stable-Baselines3 by
:class:`acc_fusion.envs.rl.GymVectorToSB3`) for ``--timesteps`` steps or ``--minutes`` of wall-clock
time, whichever comes first.  The model is saved (``--save``) and then evaluated with
:mod:`acc_fusion.envs.evaluation` against the baselines of
:data:`acc_fusion.envs.policies.BASELINES` on
the same ``--episodes`` episodes and seeds; the comparison table is printed.  The PPO
hyper-parameters are :data:`acc_fusion.envs.rl.PPO_DEFAULTS`.

Needs the ``rl`` extra: ``pip install 'acc_fusion[rl]'``.

    python scripts/train_ppo.py                     # 1.5 M steps (about 5 min), 30 episodes
    python scripts/train_ppo.py --minutes 2 --save ppo_fcw.zip --baselines never_warn,rss
    acc-fusion evaluate --policy PPO:ppo_fcw.zip    # evaluate the saved model again later

The default budget is 1.5 million steps, what about five minutes buy on two shared CPU cores
(5 200 steps/s measured with 64 copies; ``--minutes`` caps it): within 200 000 steps the
greedy policy usually still never warns; at 400 000 steps (seed 0) it already misses 5 of 21
threats against never-warn's 21 of 21 and collides in 6 of 20 episodes against 14.  The policy
scales the observation and adds threat features inside the network
(:class:`acc_fusion.envs.rl.FCWFeatures`), so the saved model takes raw observations; rewards are
normalised for training only.  The evaluation runs one episode at a time, as the harness
does: about 1.2-1.7 s per episode and policy, so 30 episodes of PPO and the seven baselines
take five minutes more.

Measured with the defaults except ``--episodes 50`` (seed 0; 1 507 328 steps in 291 s, then
475 s of evaluation):

=================  ============  =========  ===========  ==========  ===========
policy             false alarms  FA/hour    missed       collisions  mean reward
=================  ============  =========  ===========  ==========  ===========
ppo                16            57.3       10/53        7/50        -14.5
safety_distance    1             3.6        0/65         12/50       -22.5
warning_logic      1             3.6        0/65         12/50       -22.1
ttc                7             24.1       14/59        23/50       -51.3
rss                20            71.7       0/50         12/50       -24.1
uncertainty_aware  1             3.6        0/65         12/50       -22.4
always_warn        21            76.7       0/36         12/50       -37.7
never_warn         0             0          54/54        35/50       -80.9
=================  ============  =========  ===========  ==========  ===========

PPO collides least and earns the best reward, at the price of false alarms: the reward weighs
a collision (100) far above a second of false alarm (1).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}")
    return value


def _seed(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 0, got {text!r}")
    return value


def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    from acc_fusion.envs.policies import BASELINES

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--timesteps", type=_positive_int, default=1_500_000, help="PPO steps (default 1.5 M)"
    )
    parser.add_argument(
        "--minutes", type=_positive_float, default=5.0, help="wall-clock cap of the training"
    )
    parser.add_argument("--seed", type=_seed, default=0, help="seed of the training")
    parser.add_argument("--num-envs", type=_positive_int, default=64, help="vector env copies")
    parser.add_argument("--n-steps", type=_positive_int, default=128, help="rollout per copy")
    parser.add_argument("--save", type=Path, default=Path("ppo_collision_warning.zip"))
    parser.add_argument("--episodes", type=_positive_int, default=30, help="evaluation episodes")
    parser.add_argument("--eval-seed", type=_seed, default=0, help="seed of the evaluation")
    parser.add_argument(
        "--baselines",
        default=",".join(BASELINES),
        help=f"comma-separated baselines to compare with (default all: {','.join(BASELINES)})",
    )
    parser.add_argument("--no-eval", action="store_true", help="train and save only")
    parser.add_argument("--progress", action="store_true", help="progress bars")
    parser.add_argument("--verbose", type=int, default=0, help="Stable-Baselines3 verbosity")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from acc_fusion.envs.policies import BASELINES

    names = [b.strip() for b in args.baselines.split(",") if b.strip()]
    unknown = [b for b in names if b not in BASELINES]
    if unknown:
        parser.error(
            f"--baselines: unknown {', '.join(unknown)}; choose from {', '.join(BASELINES)}"
        )
    if args.save.suffix != ".zip":
        parser.error(f"--save must end in .zip, got {str(args.save)!r}")
    try:
        import torch

        from acc_fusion.envs.rl import train_ppo
    except ImportError as exc:
        print(f"Stable-Baselines3 is needed ({exc}): pip install 'acc_fusion[rl]'", file=sys.stderr)
        return 2
    torch.set_num_threads(1)  # a 64-64 MLP: one thread is fastest (see train_ppo)

    model, stats = train_ppo(
        timesteps=args.timesteps,
        minutes=args.minutes,
        seed=args.seed,
        num_envs=args.num_envs,
        n_steps=args.n_steps,
        verbose=args.verbose,
        progress=args.progress,
    )
    print(
        f"trained PPO: {stats['timesteps']} steps in {stats['seconds']:.1f} s "
        f"({stats['steps_per_s']:.0f} steps/s, {args.num_envs} copies"
        f"{', stopped by the wall-clock limit' if stats['stopped_by_clock'] else ''})"
    )
    args.save.parent.mkdir(parents=True, exist_ok=True)
    model.save(args.save)
    print(f"saved {args.save}")
    if args.no_eval:
        return 0

    from acc_fusion.envs.evaluation import comparison_table, evaluate_many

    policies = {"ppo": model, **{name: BASELINES[name] for name in names}}
    t0 = time.perf_counter()
    evaluations = evaluate_many(
        policies, episodes=args.episodes, seed=args.eval_seed, progress=args.progress
    )
    print(comparison_table(evaluations).format())
    print(f"evaluation: {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
