"""The ``acc-fusion`` command line.

Every command has ``--help``.  A user's mistake (an unknown name, a value out of range, an
unwritable folder) ends with one line ``acc-fusion: error: …`` and exit code 2, never a
Python traceback.

Each command has two modules (:data:`COMMANDS` lists them with their one-line help): its
arguments, ``acc_fusion.cli.parsers.<command>`` (``add_parser``, light), and its work,
``acc_fusion.cli.<command>`` (``run``).  Only the command given is imported
(:func:`command_module`), its work only once its arguments are parsed and its outputs checked:
``acc-fusion --help``, a usage error or an unwritable ``--out`` answer at once, and a command
loads only the stages it runs.

Settings come from ``--config FILE`` (TOML or YAML, the fields of
:class:`acc_fusion.sim.closed_loop.SimConfig`) and from flags, which override the file.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Collection, Sequence
from types import ModuleType

from acc_fusion.core.errors import AccFusionError

#: The commands in the order of ``acc-fusion --help``, with the one line it shows for each.
COMMANDS = {
    "run": "one scenario, closed loop: summary, PNG, trace CSV, JSON",
    "compare": "radar, infrared, centralized, federated: false alarms, misses, lead time",
    "conformance": "standard FCW manoeuvres against the protocols' requirements "
    "(exit 1 on failure)",
    "tune": "warning settings: NHTSA test margin against nuisance alerts in traffic",
    "sumo": "FCW in SUMO traffic, FCW off and on: alerts by class and cause, crashes avoided",
    "highway": "FCW in highway-env traffic: false alarms per method, collisions with FCW on "
    "and off, rendered replays",
    "replay": "recorded traffic (highD, NGSIM, trajectory CSV) through the FCW pipeline, "
    "open loop: alert classes per method, headways, exposure",
    "world": "the 2-D scenes (curves, cut-in/out, gantry, parked car) or an OpenSCENARIO "
    "file under weather and light: alerts by class and cause per method",
    "scenarios": "the test protocols as OpenSCENARIO files with their OpenDRIVE road "
    "(export, with ASAM's checkers)",
    "evaluate": "a warning policy (yours or a learned agent) against the baselines, in the "
    "gymnasium environment",
    "sweep": "Monte Carlo sweep over sensors, faults, fusion and warning settings (resumable)",
    "estimation": "compare federated fusion with its baselines (RMSE, NEES, cost)",
    "config": "the resolved configuration with units and origins, or its JSON Schema",
}


def command_module(name: str, *, parser: bool = False) -> ModuleType:
    """The module of command ``name``, imported by name on first use: its work
    ``acc_fusion.cli.<name>`` (``run``), or with ``parser`` its arguments
    ``acc_fusion.cli.parsers.<name>`` (``add_parser``).  The one place the command line loads a
    command, so that only the command given pays for its imports, and only once its arguments
    (outputs included) have been checked."""
    package = "acc_fusion.cli.parsers" if parser else "acc_fusion.cli"
    return importlib.import_module(f"{package}.{name}")


class _Parser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one line ``acc-fusion: error: …`` (exit 2)."""

    def error(self, message: str):
        print(f"acc-fusion: error: {message} (see `{self.prog} --help`)", file=sys.stderr)
        sys.exit(2)


def build_parser(commands: Collection[str] = tuple(COMMANDS)) -> argparse.ArgumentParser:
    """The ``acc-fusion`` parser: one sub-command per entry of :data:`COMMANDS`, with the full
    arguments of ``commands`` (by default all, which imports every command's module) and only
    the name and help line of the others."""
    parser = _Parser(
        prog="acc-fusion",
        description="Forward-collision-warning research by simulation: radar + infrared "
        "sensors, per-sensor Kalman filters and a federated fusion center.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, summary in COMMANDS.items():
        if name in commands:
            command_module(name, parser=True).add_parser(sub, summary)
        else:
            sub.add_parser(name, help=summary)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``acc-fusion`` console script: the exit code (0 done, 2 a user's
    mistake, reported in one line on standard error)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    given = next((a for a in argv if not a.startswith("-")), None)  # the command's name
    parser = build_parser([given])
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help (0) or a usage error, already printed (2)
        return int(exc.code or 0)
    try:
        return int(command_module(args.command).run(args))
    except AccFusionError as exc:
        print(f"acc-fusion: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("acc-fusion: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
