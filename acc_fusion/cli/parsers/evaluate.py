"""The arguments of ``acc-fusion evaluate`` (its work: :mod:`acc_fusion.cli.evaluate`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import output_folder, positive_float, positive_int, seed


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``evaluate`` command to the ``acc-fusion`` sub-parsers."""

    p = subparsers.add_parser(
        "evaluate",
        help=summary,
        description="Run warning policies closed loop in the collision-warning environment "
        "(acc_fusion/CollisionWarning-v0) on the same episodes and seeds, and print false "
        "alarms per hour and miss rate with 95% intervals, median lead time, collisions and "
        "mean reward per policy. --policy names a policy (repeatable); --baselines adds every "
        "baseline of acc_fusion.envs.policies (the papers' safety-distance rule, the shipped "
        "warning logic, TTC, RSS, uncertainty-aware, always-warn, never-warn).",
    )
    p.add_argument(
        "--policy",
        action="append",
        default=[],
        metavar="SPEC",
        help="MODULE:CALLABLE (a callable obs -> action 0/1/2, or a class/factory without "
        "arguments making one; MODULE may be a .py file), a Stable-Baselines3 model "
        "[PPO|A2C|DQN:]MODEL.zip, or a baseline name; repeatable",
    )
    p.add_argument(
        "--baselines",
        action="store_true",
        help="also evaluate every baseline policy on the same episodes",
    )
    p.add_argument(
        "--source",
        default="scripted",
        choices=("scripted", "sumo", "highway"),
        help="truth source of the environment (default scripted)",
    )
    p.add_argument(
        "--scenario", default="random", help="scenario name, scripted source (default random)"
    )
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--net",
        help="bundled SUMO network of --source sumo: motorway (default), onramp, ring, arterial",
    )
    where.add_argument("--sumocfg", metavar="PATH", help="a SUMO configuration for --source sumo")
    p.add_argument(
        "--highway-env",
        metavar="ID",
        help="highway-env environment of --source highway: highway-fast-v0 (default), "
        "highway-v0, merge-v0",
    )
    p.add_argument(
        "--vehicles",
        type=int,
        metavar="N",
        help="highway-env's vehicles_count of --source highway (default: the environment's)",
    )
    p.add_argument(
        "--episodes", type=positive_int, default=100, help="episodes per policy (default 100)"
    )
    p.add_argument("--seed", type=seed, default=0, help="seed of the episodes (default 0)")
    p.add_argument(
        "--warn-level",
        type=int,
        choices=(1, 2),
        default=2,
        help="level that counts as a warning: 2 imminent (default) or 1 caution",
    )
    p.add_argument(
        "--tolerance",
        type=positive_float,
        default=1.0,
        help="window [s] within which a warning and a threat match (default 1)",
    )
    p.add_argument(
        "--max-steps",
        type=positive_int,
        default=1200,
        help="steps before an episode is truncated (default 1200)",
    )
    p.add_argument("--config", metavar="FILE", help="TOML or YAML file of SimConfig fields")
    p.add_argument(
        "--out",
        metavar="DIR",
        type=output_folder,
        help="also write evaluate.csv and evaluate.json here",
    )
    return p
