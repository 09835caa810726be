"""The arguments of ``acc-fusion world`` (its work: :mod:`acc_fusion.cli.world`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    add_osi_argument,
    add_sim_arguments,
    output_folder,
    output_path,
)
from acc_fusion.truth.scenes import SCENES

#: The conditions of ``--conditions`` by default: day, night, and day in fog of 25 m.
DEFAULT_CONDITIONS = ("day", "night", "fog=25")


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``world`` command."""
    p = subparsers.add_parser(
        "world",
        help=summary,
        description="Run the scripted 2-D scenes (or an OpenSCENARIO file, --scenario) "
        "through the object-level pipeline: a radar and "
        "a thermal camera that see every object ahead, a multi-target tracker per sensor, "
        "track-to-track association, every method's estimator per object, in-path target "
        "selection and the warning. Prints per scene the alerts by class (judged from truth) "
        "and, pooled over the scenes, the nuisance and sensing-false alerts by cause.",
    )
    which = p.add_mutually_exclusive_group()
    which.add_argument(
        "--scene",
        action="append",
        choices=sorted(SCENES),
        help="a scene (repeatable; default: all)",
    )
    which.add_argument(
        "--scenario",
        dest="scenario_file",
        metavar="FILE.xosc",
        help="an OpenSCENARIO XML file instead of the scenes (the longitudinal and "
        "lane-keeping subset the 2-D world reads; its subject vehicle is the entity 'Ego'): "
        "--runs copies of it, each with its own sensor noise",
    )
    p.add_argument(
        "--conditions",
        nargs="+",
        metavar="C",
        default=list(DEFAULT_CONDITIONS),
        help="weather and light: day, night, fog=METRES, rain=MM_PER_H, joined by '+' "
        f"(default: {' '.join(DEFAULT_CONDITIONS)})",
    )
    add_sim_arguments(p, "runs per scene and condition (default 50)")
    p.add_argument(
        "--plot",
        metavar="PNG",
        type=output_path,
        help="write the figure of the alerts by cause per 100 km, with 95%% intervals, here",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        type=output_folder,
        help="also write CSV (the tables, and the rates by cause with their intervals) and "
        "JSON here",
    )
    add_osi_argument(p, "every scene and condition (files <scene>_<condition>_runNNN.mcap)")
    return p
