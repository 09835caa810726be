"""What the commands share: argparse types, the study-script parser, the SimConfig from file and
flags, and the writing of a study's outputs."""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import yaml

from acc_fusion.core.config import from_mapping, load_mapping, load_yaml
from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.outputs import (
    output_dir,
    output_file,
    save_figure_atomic,
    write_csv_atomic,
    write_json_atomic,
)
from acc_fusion.core.plots import rates_figure
from acc_fusion.core.schema import field_at, set_path
from acc_fusion.core.validation import check_choice
from acc_fusion.fusion.config import FUSION_METHODS
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.truth.distraction import TRAFFIC_DISTRACTION_RATE
from acc_fusion.truth.sumo.config import SumoConfig
from acc_fusion.truth.sumo.nets import resolve_sumocfg


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value:g}")
    return value


def output_folder(text: str) -> Path:
    """argparse type: an output folder, created and probed for writing as the arguments are
    parsed (:func:`~acc_fusion.core.outputs.output_dir`), before any work."""
    try:
        return output_dir(text)
    except AccFusionError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def output_path(text: str) -> Path:
    """argparse type: an output file, its folder created and probed for writing as the
    arguments are parsed (:func:`~acc_fusion.core.outputs.output_file`), before any work."""
    try:
        return output_file(text)
    except AccFusionError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def study_parser(doc: str, runs: int, plot_help: str | None = None) -> argparse.ArgumentParser:
    """Parser of a study script: ``--runs``, ``--seed`` and, with ``plot_help``, ``--plot``."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument(
        "--runs", type=positive_int, default=runs, help=f"Monte Carlo runs (default {runs})"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of truth and noise (default 0)")
    if plot_help:
        parser.add_argument("--plot", metavar="PATH", type=output_path, help=plot_help)
    return parser


def seed(text: str) -> int:
    """argparse type: a seed, a whole number in [0, 2**63)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"must be in [0, 2**63), got {value}")
    return value


def add_config_arguments(p: argparse.ArgumentParser) -> None:
    """``--config FILE`` and ``--set KEY=VALUE`` (repeatable): the simulation config's sources."""
    p.add_argument(
        "--config",
        metavar="FILE",
        help="TOML or YAML file of config fields (see `acc-fusion config schema`)",
    )
    p.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        dest="overrides",
        help="set one config field by its dotted path, e.g. --set fusion.reset=zero "
        "(applied after --config; VALUE is read as YAML)",
    )


def add_sim_arguments(p: argparse.ArgumentParser, runs_help: str | None) -> None:
    """The arguments of every command that runs the simulation: the config's sources, ``--seed``
    and, with ``runs_help``, ``--runs``."""
    add_config_arguments(p)
    p.add_argument("--seed", type=seed, help="random seed (default 0)")
    if runs_help:
        p.add_argument("--runs", type=positive_int, help=runs_help)


def add_traffic_arguments(p: argparse.ArgumentParser) -> None:
    """The SUMO traffic's flags of the commands that run it (``sumo``, ``tune``):
    ``--penetration``, ``--hazard-rate``, ``--inattentive``."""
    p.add_argument(
        "--penetration", type=float, default=1.0, help="fraction of equipped vehicles (default 1)"
    )
    p.add_argument(
        "--hazard-rate",
        type=float,
        default=2.0,
        help="injected emergency brakings per vehicle-hour (default 2)",
    )
    p.add_argument(
        "--inattentive",
        type=float,
        default=0.2,
        help="fraction of equipped drivers who react late (default 0.2)",
    )
    p.add_argument(
        "--distraction",
        type=float,
        metavar="RATE",
        help="eyes-off-road episodes per driving hour of each equipped driver (default "
        f"{TRAFFIC_DISTRACTION_RATE:g}; 0: none; driver.distraction.* for the durations)",
    )


def add_scenario_arguments(p: argparse.ArgumentParser, warmup: float, before: str) -> None:
    """The arguments of a script that measures a SUMO scenario's own traffic: ``--net``
    (default motorway) or ``--sumocfg``, ``--end``, ``--warmup`` (default ``warmup``, the
    seconds ``before`` measuring) and ``--seed``."""
    where = p.add_mutually_exclusive_group()
    where.add_argument("--net", default="motorway", help="bundled network (default motorway)")
    where.add_argument("--sumocfg", metavar="PATH", help="any SUMO configuration file")
    p.add_argument("--end", type=float, default=300.0, help="simulated seconds (default 300)")
    p.add_argument(
        "--warmup", type=float, default=warmup, help=f"seconds before {before} ({warmup:g})"
    )
    p.add_argument("--seed", type=int, default=0, help="SUMO seed (default 0)")


def scenario_config(args: argparse.Namespace):
    """The ``.sumocfg`` path and :class:`SumoConfig` of :func:`add_scenario_arguments`' flags;
    :class:`AccFusionError` for a ``--warmup`` outside [0, ``--end``) or an unknown scenario."""
    if not 0 <= args.warmup < args.end:
        raise AccFusionError(f"--warmup must be in [0, --end), got {args.warmup:g}")
    path = resolve_sumocfg(None if args.sumocfg else args.net, args.sumocfg)
    return path, SumoConfig(str(path), seed=args.seed)


def traffic_config(args: argparse.Namespace, path, **fields) -> SumoConfig:
    """The :class:`SumoConfig` of the ``.sumocfg`` at ``path`` with the flags of
    :func:`add_traffic_arguments` and ``--end``; ``fields`` set the rest."""
    return SumoConfig(
        sumocfg=str(path),
        end=args.end,
        penetration=args.penetration,
        hazard_rate=args.hazard_rate,
        inattentive=args.inattentive,
        **fields,
    )


def traffic_sim_config(args: argparse.Namespace) -> SimConfig:
    """:func:`sim_config` of a traffic command: one run, the drivers distracted at
    ``--distraction`` (else the config's ``driver.distraction.rate`` if given, else
    :data:`~acc_fusion.truth.distraction.TRAFFIC_DISTRACTION_RATE`), braking for a warning
    only when truth says they must (``driver.brakes_only_for_threats``)."""
    cfg = sim_config(args, runs=1)
    given = config_data(args)[0].get("driver", {})
    rate = args.distraction
    if rate is None and "rate" not in given.get("distraction", {}):
        rate = TRAFFIC_DISTRACTION_RATE
    judged = {} if "brakes_only_for_threats" in given else {"brakes_only_for_threats": True}
    return with_driver(cfg, rate, **judged)


def with_driver(cfg: SimConfig, rate: float | None = None, **fields) -> SimConfig:
    """``cfg`` with its driver distracted ``rate`` times per hour (``None``: as it is) and
    the :class:`~acc_fusion.truth.driver.DriverConfig` ``fields`` set."""
    driver = cfg.driver
    if rate is not None:
        driver = replace(driver, distraction=replace(driver.distraction, rate=rate))
    return replace(cfg, driver=replace(driver, **fields))


def config_data(args: argparse.Namespace) -> tuple[dict, str]:
    """The config mapping a user gave (``--config`` file, then ``--set`` flags) and a label of
    its source for :func:`acc_fusion.core.schema.describe`."""
    data: dict = {}
    sources = []
    if getattr(args, "config", None):
        data = load_mapping(args.config)
        sources.append(f"file {args.config}")
    for item in getattr(args, "overrides", []):
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise ConfigError(f"--set takes KEY=VALUE, got {item!r}")
        field_at(SimConfig, key)  # raises, naming the allowed keys
        try:
            value = load_yaml(text)
        except yaml.YAMLError:
            raise ConfigError(f"--set {key}: {text!r} is not a YAML value") from None
        set_path(data, key, value)
        sources.append("--set")
    return data, " / ".join(dict.fromkeys(sources))


def sim_config(args: argparse.Namespace, **defaults) -> SimConfig:
    """SimConfig from defaults, then ``--config`` FILE and ``--set`` flags, then the flags given."""
    given, _ = config_data(args)
    data = {**defaults, **given}
    for key in ("scenario", "runs", "seed", "method"):
        value = getattr(args, key, None)
        if value is None:
            continue
        if key == "method":
            check_choice("--method", value, SENSOR_NAMES + FUSION_METHODS)
            data["methods"] = tuple(dict.fromkeys([*data.get("methods", ()), value]))
            data["drive"] = value
        else:
            data[key] = value
    return from_mapping(SimConfig, data)


def write_summary(out, name: str, payload: dict) -> None:
    """Write ``payload`` as JSON to ``out/name`` and say so."""

    write_json_atomic(out / name, payload)
    print(f"wrote {out / name}")


def report_world(study, out, stem: str, **fields) -> None:
    """Print a 2-D world study's tables (:class:`~acc_fusion.studies.world.WorldStudy`: the
    alerts by class of each run, then by cause) and, with ``out``, write each as CSV
    (``stem``_classes_*i*.csv, ``stem``_causes.csv), the rates by cause with their intervals
    (``stem``_cause_rates.csv) and their figure (``stem``_causes.png), and ``stem``.json
    (``fields`` and every method's summary by conditions label) into ``out``."""
    tables = {f"classes_{i}": t for i, t in enumerate(study.classes())}
    tables["causes"] = study.causes()
    print("\n\n".join(t.format() for t in tables.values()))
    if out is None:
        return
    tables["cause_rates"] = study.cause_rates()
    for name, t in tables.items():
        write_csv_atomic(out / f"{stem}_{name}.csv", t.columns, t.rows)
    save_figure_atomic(study.figure(), out / f"{stem}_causes.png")
    summaries = {label: {m: s.as_dict() for m, s in runs.items()}
                 for (_, label), runs in study.results.items()}  # fmt: skip
    write_summary(out, f"{stem}.json", {**fields, **summaries})


def write_study(out, stem: str, table, study, **fields) -> None:
    """Write a traffic study (FCW off and on): ``stem``.csv (the table), ``stem``_classes.csv
    (the alert classes), .png (the rates of the FCW-off run) and .json (``fields`` and both
    runs' summaries) into ``out``."""

    classes = study.classes()
    write_csv_atomic(out / f"{stem}.csv", table.columns, table.rows)
    write_csv_atomic(out / f"{stem}_classes.csv", classes.columns, classes.rows)
    save_figure_atomic(rates_figure(study.off.summaries, table.title), out / f"{stem}.png")
    print(f"wrote {out / (stem + '.csv')}, {stem}_classes.csv and {stem}.png")
    runs = {"fcw_off": study.off, "fcw_on": study.on}
    summaries = {k: {m: s.as_dict() for m, s in r.summaries.items()} for k, r in runs.items()}
    write_summary(out, f"{stem}.json", {**fields, **summaries})
