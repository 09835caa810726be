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
        description="Run a test protocol with noisy sensors. nhtsa-fcw (default): the NHTSA "
        "FCW confirmation tests and Euro NCAP's car-to-car rear stationary test, several "
        "trials each, the TTC at the first alert of every trial against the requirement "
        "(pass: 5 of 7 trials). fmvss127: FMVSS 127's lead-vehicle and false-activation tests "
        "with automatic emergency braking in the 2-D world, ending with "
        "fmvss127_passed=<passed>/<total>. euroncap-aeb: Euro NCAP's AEB Car-to-Car rear grid "
        "(CCRs, CCRm, CCRb), its rating sheet, ending with euroncap_aeb_score=<points>/<max>. "
        "Exit code 0 only when every test passes (euroncap-aeb: always, it is a score).",
    )
    p.add_argument(
        "--protocol",
        choices=("nhtsa-fcw", "fmvss127", "euroncap-aeb"),
        default="nhtsa-fcw",
        help="the protocol to run (default nhtsa-fcw)",
    )
    p.add_argument(
        "--trials",
        type=positive_int,
        help="trials per manoeuvre or test point (default: 7 for nhtsa-fcw, 3 for fmvss127; "
        "euroncap-aeb runs each grid point once)",
    )
    add_sim_arguments(p, None)
    p.add_argument(
        "--out",
        metavar="DIR",
        type=output_folder,
        help="also write the table (CSV) and, for euroncap-aeb, the grid figure here",
    )
    return p
