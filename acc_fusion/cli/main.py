"""The ``acc-fusion`` command line.

Every command has ``--help``.  A user's mistake (an unknown name, a value out of range, an
unwritable folder) ends with one line ``acc-fusion: error: …`` and exit code 2, never a
Python traceback.

Commands:
    run          one scenario, closed loop: summary, PNG, trace CSV and JSON summary
    compare      every method on the randomised suite: false alarms, misses, lead time
    conformance  the standard FCW test manoeuvres against the protocols' requirements
    tune         warning settings: test margin against nuisance alerts in traffic, Pareto front
    sumo         FCW in SUMO traffic (bundled networks or any .sumocfg), FCW on and off
    highway      FCW in highway-env traffic, FCW on and off, rendered replays
    replay       recorded traffic (highD, NGSIM, trajectory CSV) through the pipeline, open loop
    world        the 2-D scenes under weather and light: alerts by class and cause per method
    evaluate     a warning policy against the baselines in the gymnasium environment
    sweep        Monte Carlo sweeps (local processes or Ray), resumable, ROC curves, report
    estimation   federated fusion against its baselines (RMSE, NEES, cost per pair-step)

Settings come from ``--config FILE`` (TOML or YAML, the fields of
:class:`acc_fusion.sim.closed_loop.SimConfig`) and from flags, which override the file.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from acc_fusion.cli import (
    compare,
    config,
    conformance,
    estimation,
    evaluate,
    highway,
    replay,
    run,
    sumo,
    sweep,
    tune,
    world,
)
from acc_fusion.core.errors import AccFusionError

#: The commands in the order of ``acc-fusion --help``: each module has ``add_parser`` and ``run``.
COMMANDS = (
    run,
    compare,
    conformance,
    tune,
    sumo,
    highway,
    replay,
    world,
    evaluate,
    sweep,
    estimation,
    config,
)


class _Parser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one line ``acc-fusion: error: …`` (exit 2)."""

    def error(self, message: str):
        print(f"acc-fusion: error: {message} (see `{self.prog} --help`)", file=sys.stderr)
        sys.exit(2)


def build_parser() -> argparse.ArgumentParser:
    """The ``acc-fusion`` parser: one sub-command per module of :data:`COMMANDS`."""
    parser = _Parser(
        prog="acc-fusion",
        description="Forward-collision-warning research by simulation: radar + infrared "
        "sensors, per-sensor Kalman filters and a federated fusion center.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(sub).set_defaults(func=command.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``acc-fusion`` console script: the exit code (0 done, 2 a user's
    mistake, reported in one line on standard error)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help (0) or a usage error, already printed (2)
        return int(exc.code or 0)
    try:
        return int(args.func(args))
    except AccFusionError as exc:
        print(f"acc-fusion: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("acc-fusion: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
