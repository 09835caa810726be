"""The arguments of ``acc-fusion config`` (its work: :mod:`acc_fusion.cli.config`)."""

from __future__ import annotations

import argparse

from acc_fusion.cli.arguments import add_config_arguments, output_path


def add_parser(subparsers, summary: str) -> argparse.ArgumentParser:
    """The ``config`` command and its ``show`` and ``schema`` subcommands."""
    p = subparsers.add_parser(
        "config",
        help=summary,
        description=__doc__.split("\n\n")[0],
    )
    sub = p.add_subparsers(dest="config_command", metavar="SUBCOMMAND", required=True)
    show = sub.add_parser(
        "show", help="every config field: value, unit, and where the value comes from"
    )
    add_config_arguments(show)
    show.add_argument("--json", action="store_true", help="print the rows as JSON")
    schema = sub.add_parser("schema", help="the JSON Schema of config files")
    schema.add_argument(
        "--out",
        metavar="FILE",
        type=output_path,
        help="write it to FILE (default: standard output)",
    )
    return p
