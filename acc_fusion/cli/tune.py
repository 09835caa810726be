"""``acc-fusion tune``: a grid of warning settings, each judged by its margin on the NHTSA FCW
tests and the nuisance alerts it raises in recorded SUMO traffic, with the Pareto front."""

from __future__ import annotations

import argparse

from acc_fusion.cli.common import (
    config_data,
    traffic_config,
    traffic_sim_config,
)
from acc_fusion.core.config import load_yaml
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import save_figure_atomic, write_csv_atomic
from acc_fusion.core.plots import tradeoff_figure
from acc_fusion.studies.tune import point_configs, record_sumo, tune, tune_table
from acc_fusion.truth.sumo.nets import resolve_sumocfg


def _axes(items: list[str]) -> dict[str, list]:
    axes = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise ConfigError(f"--grid takes KEY=[V1, V2, ...], got {item!r}")
        values = load_yaml(text, f"--grid {key}")
        if not isinstance(values, list) or not values:
            raise ConfigError(f"--grid {key}: give a non-empty list of values, got {text!r}")
        axes[key] = values
    return axes


def run(args: argparse.Namespace) -> int:
    axes = _axes(args.grid)
    base, _ = config_data(args)
    configs = point_configs(base, axes)
    out = args.out
    path = resolve_sumocfg(None if args.sumocfg else args.net, args.sumocfg)
    seed = int(base.get("seed", 0))
    traffic = traffic_sim_config(args)
    recording = record_sumo(traffic_config(args, path, seed=seed), traffic, progress=True)
    recording.name = path.name
    points = tune(configs, recording, trials=args.trials, progress=True)
    table = tune_table(points, recording)
    print(table.format())
    if out is not None:
        write_csv_atomic(out / "tune.csv", table.columns, table.rows)
        rates = [p.traffic.alerts_per_100km["nuisance"] for p in points]
        figure = tradeoff_figure(
            [p.margin_s for p in points],
            [r.value for r in rates],
            [r.lo for r in rates],
            [r.hi for r in rates],
            [p.pareto for p in points],
            [", ".join(f"{v}" for v in p.settings.values()) for p in points],
            f"{table.title}\n{', '.join(axes)}",
        )
        save_figure_atomic(figure, out / "tune.png")
        print(f"wrote {out / 'tune.csv'} and {out / 'tune.png'}")
    return 0
