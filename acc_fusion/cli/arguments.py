"""The command line's arguments: argparse types (numbers, seeds, output paths checked as they
are parsed) and the groups of arguments the commands share.  Light to import: the parsers of
:mod:`acc_fusion.cli.parsers` use it, and ``acc-fusion CMD --help`` or a usage error must not
wait for the pipeline's imports."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path

from acc_fusion.core.errors import AccFusionError
from acc_fusion.core.outputs import check_output_dir, check_output_file
from acc_fusion.sweep import EXECUTORS
from acc_fusion.truth.distraction import TRAFFIC_DISTRACTION_RATE
from acc_fusion.truth.sumo.config import TRAFFIC_WARMUP


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1."""
    value = _parse(int, text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a number > 0."""
    value = _parse(float, text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value:g}")
    return value


def output_folder(text: str) -> Path:
    """argparse type: an output folder, probed for writing (and left as it was) as the
    arguments are parsed (:func:`~acc_fusion.core.outputs.check_output_dir`), before any work."""
    return _as_argument(check_output_dir, text)


def output_path(text: str) -> Path:
    """argparse type: an output file, its folder probed for writing (and left as it was) as
    the arguments are parsed (:func:`~acc_fusion.core.outputs.check_output_file`), before any
    work."""
    return _as_argument(check_output_file, text)


def _as_argument(check: Callable[[str], Path], text: str) -> Path:
    """``check(text)``, its :class:`AccFusionError` turned into argparse's error."""
    try:
        return check(text)
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
    value = _parse(int, text)
    if not 0 <= value < 2**63:
        raise argparse.ArgumentTypeError(f"must be in [0, 2**63), got {value}")
    return value


def _parse(kind: type[int] | type[float], text: str) -> int | float:
    """``text`` as a ``kind``, else argparse's error saying what it must be."""
    what = "a whole number" if kind is int else "a finite number"
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
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


def add_osi_argument(p: argparse.ArgumentParser, which: str) -> None:
    """``--osi DIR`` and ``--osi-vehicles N``: write an ASAM OSI trace per ego of ``which``
    there (:func:`acc_fusion.cli.common.osi_output`)."""
    p.add_argument(
        "--osi",
        metavar="DIR",
        type=output_folder,
        help=f"write an ASAM OSI trace (MCAP: ground truth, the ego's readings, detections, "
        f"tracks and estimates) of every ego of {which} here, one file per ego vehicle",
    )
    p.add_argument(
        "--osi-vehicles",
        metavar="N",
        type=positive_int,
        help="with --osi: trace only the first N ego vehicles to appear (default: all)",
    )


def add_traffic_arguments(p: argparse.ArgumentParser) -> None:
    """The SUMO traffic's flags of the commands that run it (``sumo``, ``tune``):
    ``--penetration``, ``--warmup``, ``--hazard-rate``, ``--inattentive``, ``--distraction``."""
    p.add_argument(
        "--penetration", type=float, default=1.0, help="fraction of equipped vehicles (default 1)"
    )
    p.add_argument(
        "--warmup",
        type=float,
        default=TRAFFIC_WARMUP,
        help="simulated seconds SUMO runs before anything is measured, the network filling "
        f"(default {TRAFFIC_WARMUP:g}); --end counts after it",
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
    add_distraction_argument(p)


def add_distraction_argument(p: argparse.ArgumentParser) -> None:
    """``--distraction RATE``: the drivers' eyes-off-road episodes of a traffic command."""
    p.add_argument(
        "--distraction",
        type=float,
        metavar="RATE",
        help="eyes-off-road episodes per driving hour of each equipped driver (default "
        f"{TRAFFIC_DISTRACTION_RATE:g}; 0: none; driver.distraction.* for the durations)",
    )


def add_executor_arguments(p: argparse.ArgumentParser, what: str = "") -> None:
    """``--executor``, ``--address`` and ``--workers``: where parallel runs go (local
    processes or Ray, :func:`acc_fusion.sweep.executors.make_map`); ``what`` prefixes their
    help (e.g. ``"with --seeds: "``)."""
    p.add_argument(
        "--executor",
        choices=EXECUTORS,
        default="local",
        help=f"{what}where to run: local processes or Ray (default local)",
    )
    p.add_argument(
        "--address",
        metavar="ADDR",
        help=f"{what}Ray cluster address HOST:PORT or ray://HOST:PORT (default: a local Ray)",
    )
    p.add_argument(
        "--workers",
        type=positive_int,
        default=2,
        help=f"{what}worker processes (local) or CPUs of the local Ray (default 2)",
    )


def add_scenario_arguments(
    p: argparse.ArgumentParser, warmup: float | None, before: str
) -> argparse._MutuallyExclusiveGroup:
    """The arguments of a script that measures a SUMO scenario's own traffic: ``--net``
    (default motorway) or ``--sumocfg``, ``--end``, ``--warmup`` (default ``warmup``, the
    seconds ``before`` measuring) and ``--seed``.  Returns the group of ``--net`` and
    ``--sumocfg``, for a script that offers other sources beside them."""
    where = p.add_mutually_exclusive_group()
    where.add_argument("--net", default="motorway", help="bundled network (default motorway)")
    where.add_argument("--sumocfg", metavar="PATH", help="any SUMO configuration file")
    p.add_argument("--end", type=float, default=300.0, help="simulated seconds (default 300)")
    default = "by source" if warmup is None else f"{warmup:g}"
    p.add_argument(
        "--warmup", type=float, default=warmup, help=f"seconds before {before} ({default})"
    )
    p.add_argument("--seed", type=int, default=0, help="SUMO seed (default 0)")
    return where
