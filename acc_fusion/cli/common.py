"""What the commands' work shares: the SimConfig from file and flags, the SUMO configs of the
traffic commands, and the writing of a study's outputs (their arguments:
:mod:`acc_fusion.cli.arguments`)."""

from __future__ import annotations

import argparse
from dataclasses import replace

from acc_fusion.core.config import from_mapping, load_mapping, load_yaml
from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.outputs import (
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
from acc_fusion.sim.osi_trace import OsiOutput
from acc_fusion.truth.distraction import TRAFFIC_CALM, TRAFFIC_DISTRACTION_RATE
from acc_fusion.truth.sumo.config import SumoConfig
from acc_fusion.truth.sumo.nets import resolve_sumocfg


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
        warmup=args.warmup,
        hazard_rate=args.hazard_rate,
        inattentive=args.inattentive,
        **fields,
    )


def traffic_sim_config(args: argparse.Namespace) -> SimConfig:
    """:func:`sim_config` of a traffic command: one run, the drivers distracted at
    ``--distraction`` (else the config's ``driver.distraction.rate`` if given, else
    :data:`~acc_fusion.truth.distraction.TRAFFIC_DISTRACTION_RATE`), looking away only when
    calm (:data:`~acc_fusion.truth.distraction.TRAFFIC_CALM`, unless the config sets
    ``calm_headway`` or ``calm_ttc``), braking for a warning only when truth says they must
    (``driver.brakes_only_for_threats``)."""
    cfg = sim_config(args, runs=1)
    given = config_data(args)[0].get("driver", {})
    distraction = given.get("distraction", {})
    rate = args.distraction
    if rate is None and "rate" not in distraction:
        rate = TRAFFIC_DISTRACTION_RATE
    if not {"calm_headway", "calm_ttc"} & set(distraction):
        headway, ttc = TRAFFIC_CALM
        calm = replace(cfg.driver.distraction, calm_headway=headway, calm_ttc=ttc)
        cfg = replace(cfg, driver=replace(cfg.driver, distraction=calm))
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
        set_path(data, key, load_yaml(text, f"--set {key}"))
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


def osi_output(args: argparse.Namespace) -> OsiOutput | None:
    """The :class:`~acc_fusion.sim.osi_trace.OsiOutput` of ``--osi`` and ``--osi-vehicles``
    (``None`` without ``--osi``; ``--osi-vehicles`` alone is one ConfigError)."""
    if args.osi is None:
        if args.osi_vehicles is not None:
            raise ConfigError("--osi-vehicles is a setting of --osi; add --osi DIR")
        return None
    return OsiOutput(args.osi, args.osi_vehicles)
