"""``acc-fusion evaluate``: a warning policy (yours, a baseline or a learned agent) against the
baselines in the gymnasium environment.
"""

from __future__ import annotations

import argparse
import math

from acc_fusion.cli.common import output_folder, positive_float, positive_int, seed
from acc_fusion.core.config import from_mapping, load_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import write_csv_atomic, write_json_atomic
from acc_fusion.envs.evaluation import comparison_table, evaluate_many
from acc_fusion.envs.loader import load_policy
from acc_fusion.envs.options import HighwayOptions, SumoOptions
from acc_fusion.envs.policies import BASELINES
from acc_fusion.sim.closed_loop import SimConfig


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``evaluate`` command to the ``acc-fusion`` sub-parsers."""

    p = subparsers.add_parser(
        "evaluate",
        help="a warning policy (yours or a learned agent) against the baselines, in the "
        "gymnasium environment",
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


def _env_config(path: str | None, scenario: str):
    """SimConfig of the environment from ``--config`` (its methods are the environment's)."""
    if not path:
        return None

    data = dict(load_mapping(path))
    data.update(scenario=scenario, runs=1, methods=("federated",), drive=None)
    return from_mapping(SimConfig, data)


def _sumo_options(args: argparse.Namespace):
    """The sumo source's options from ``--net`` / ``--sumocfg`` (``None``: the defaults)."""
    if args.net is None and args.sumocfg is None:
        return None
    if args.source != "sumo":
        raise ConfigError(f"--net and --sumocfg apply to --source sumo, not {args.source!r}")

    return SumoOptions(net=args.net, sumocfg=args.sumocfg)


def _highway_options(args: argparse.Namespace):
    """The highway source's options from ``--highway-env`` / ``--vehicles`` (``None``: the
    defaults)."""
    given = {"env": args.highway_env, "vehicles_count": args.vehicles}
    given = {k: v for k, v in given.items() if v is not None}
    if not given:
        return None
    if args.source != "highway":
        raise ConfigError(
            f"--highway-env and --vehicles apply to --source highway, not {args.source!r}"
        )

    return HighwayOptions(**given)


def run(args: argparse.Namespace) -> int:
    """``acc-fusion evaluate``: print the comparison table (and write CSV/JSON with ``--out``).

    The table holds the ``--policy`` policies, in order, then, with ``--baselines``, every
    baseline; at least one of the two is needed.
    """

    if not args.policy and not args.baselines:
        raise ConfigError("give a policy to evaluate with --policy MODULE:CALLABLE, or --baselines")
    out = args.out
    policies = {spec: load_policy(spec) for spec in args.policy}
    if args.baselines:
        policies.update({k: v for k, v in BASELINES.items() if k not in policies})
    evaluations = evaluate_many(
        policies,
        source=args.source,
        episodes=args.episodes,
        seed=args.seed,
        scenario=args.scenario,
        warn_level=args.warn_level,
        tolerance=args.tolerance,
        progress=True,
        config=_env_config(args.config, args.scenario),
        max_episode_steps=args.max_steps,
        sumo=_sumo_options(args),
        highway=_highway_options(args),
    )
    table = comparison_table(evaluations)
    print(table.format())
    if out is not None:
        write_csv_atomic(out / "evaluate.csv", table.columns, table.rows)
        write_json_atomic(
            out / "evaluate.json",
            {"policies": [_clean(e.as_dict()) for e in evaluations]},
        )
        print(f"wrote {out / 'evaluate.csv'} and {out / 'evaluate.json'}")
    return 0


def _clean(x: object) -> object:
    """NaN and ±inf become ``None`` (JSON has neither)."""
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x
