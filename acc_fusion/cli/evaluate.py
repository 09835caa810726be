"""``acc-fusion evaluate``: a warning policy (yours, a baseline or a learned agent) against the
baselines in the gymnasium environment.
"""

from __future__ import annotations

import argparse

from acc_fusion.core.config import from_mapping, load_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import write_csv_atomic, write_json_atomic
from acc_fusion.envs.evaluation import comparison_table, evaluate_many
from acc_fusion.envs.loader import load_policy
from acc_fusion.envs.options import HighwayOptions, SumoOptions
from acc_fusion.envs.policies import BASELINES
from acc_fusion.sim.closed_loop import SimConfig


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
            {"policies": [e.as_dict() for e in evaluations]},
        )
        print(f"wrote {out / 'evaluate.csv'} and {out / 'evaluate.json'}")
    return 0
