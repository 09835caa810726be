"""The arguments of ``acc-fusion compare`` (its work: :mod:`acc_fusion.cli.compare`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    add_sim_arguments,
    output_folder,
)


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``compare`` command."""
    p = subparsers.add_parser(
        "compare",
        help=summary,
        description="Radar alone, infrared alone, centralized and federated fusion on the "
        "same randomised scenarios and seeds (with radar clutter): false alarms per hour and "
        "per 100 km, miss rate, lead time, with 95% intervals; then collisions with the "
        "federated alerts on and off, closed loop, on the same seeds.",
    )
    add_sim_arguments(p, "Monte Carlo runs (default 200)")
    p.add_argument(
        "--distraction",
        type=float,
        metavar="RATE",
        help="a human driver in the closed loops: he brakes by himself for a crash-relevant "
        "situation when his eyes are on the road, and looks away RATE times per hour "
        "(default: a driver who never brakes by himself)",
    )
    p.add_argument(
        "--all-drives",
        action="store_true",
        help="one closed loop with warnings on per method (radar, infrared, centralized, "
        "federated driving the alert), to compare the crashes each avoids",
    )
    p.add_argument(
        "--out", metavar="DIR", type=output_folder, help="also write compare.csv/.png/.json here"
    )
    return p
