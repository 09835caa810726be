"""The arguments of ``acc-fusion conformance`` (its work: :mod:`acc_fusion.cli.conformance`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import (
    add_sim_arguments,
    output_folder,
    positive_int,
)


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``conformance`` command."""
    p = subparsers.add_parser(
        "conformance",
        help=summary,
        description="Run the NHTSA FCW confirmation tests and Euro NCAP's car-to-car rear "
        "stationary test with noisy sensors, several trials each; print the TTC at the first "
        "alert of every trial against the protocol's requirement. Exit code 0 only when every "
        "manoeuvre passes by its pass rule (5 of 7 trials).",
    )
    p.add_argument(
        "--trials", type=positive_int, default=7, help="trials per manoeuvre (default 7)"
    )
    add_sim_arguments(p, None)
    p.add_argument(
        "--out", metavar="DIR", type=output_folder, help="also write conformance.csv here"
    )
    return p
