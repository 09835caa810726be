"""The arguments of ``acc-fusion scenarios`` (its work: :mod:`acc_fusion.cli.scenarios`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import output_folder

#: The protocols ``scenarios export`` writes (the names of ``conformance --protocol``;
#: :data:`acc_fusion.studies.scenarios.PROTOCOLS`).
PROTOCOLS = ("nhtsa-fcw", "fmvss127", "euroncap-aeb")


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """Add the ``scenarios`` command and its action ``export``."""
    p = subparsers.add_parser(
        "scenarios",
        help=summary,
        description="The test protocols as ASAM OpenSCENARIO XML 1.3 files with their "
        "OpenDRIVE 1.8 road. Run a scenario file in the 2-D world with `acc-fusion world "
        "--scenario FILE.xosc`.",
    )
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    export = actions.add_parser(
        "export",
        help="write a protocol's test points as .xosc files and their .xodr road",
        description="Write one .xosc per test point of the protocol (named from its label) "
        "and the .xodr test track they reference into DIR; with --check, run ASAM's quality "
        "checkers (asam-qc-openscenarioxml, asam-qc-opendrive) on them first. Prints a "
        "summary table; the last line is scenarios_written=N. Exit code 1 when a checker "
        "finds an issue.",
    )
    export.add_argument("--protocol", choices=PROTOCOLS, required=True, help="the protocol")
    export.add_argument(
        "--out", metavar="DIR", type=output_folder, required=True, help="the folder to write"
    )
    export.add_argument(
        "--check", action="store_true", help="run ASAM's quality checkers on the files"
    )
    return p
