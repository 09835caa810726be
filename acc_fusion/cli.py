"""The ``acc-fusion`` command line.

Every command has ``--help``.  A user's mistake (an unknown name, a value out of range, an
unwritable folder) ends with one line ``acc-fusion: error: …`` and exit code 2, never a
Python traceback.

Commands:
    estimation   federated fusion against its baselines (RMSE, NEES, cost per pair-step)
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from acc_fusion.errors import AccFusionError


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value:g}")
    return value


def study_parser(doc: str, runs: int, plot_help: str | None = None) -> argparse.ArgumentParser:
    """Parser of a study script: ``--runs``, ``--seed`` and, with ``plot_help``, ``--plot``."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument(
        "--runs", type=positive_int, default=runs, help=f"Monte Carlo runs (default {runs})"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of truth and noise (default 0)")
    if plot_help:
        parser.add_argument("--plot", metavar="PATH", help=plot_help)
    return parser


def _cmd_estimation(args: argparse.Namespace) -> int:
    from acc_fusion.outputs import output_dir, save_figure_atomic, write_csv_atomic
    from acc_fusion.plots import estimation_bars
    from acc_fusion.studies import compare_methods

    out = output_dir(args.out) if args.out else None
    table = compare_methods(
        n_runs=args.runs, duration=args.duration, seed=args.seed, engine=args.engine
    )
    print(table.format())
    if out is not None:
        write_csv_atomic(out / "estimation.csv", table.columns, table.rows)
        save_figure_atomic(estimation_bars(table), out / "estimation.png")
        print(f"wrote {out / 'estimation.csv'} and {out / 'estimation.png'}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="acc-fusion",
        description="Forward-collision-warning research by simulation: radar + infrared "
        "sensors, per-sensor Kalman filters and a federated fusion center.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    est = sub.add_parser(
        "estimation",
        help="compare federated fusion with its baselines (RMSE, NEES, cost)",
        description="Run every fusion method (each sensor alone, centralized sequential and "
        "stacked, federated in its three reset modes, with fault isolation, and the plain "
        "formula) on the same car-following truth and measurements; print RMSE, mean NEES "
        "with its 95%% bounds, and the cost per pair-step.",
    )
    est.add_argument(
        "--runs", type=positive_int, default=500, help="Monte Carlo runs (default 500)"
    )
    est.add_argument(
        "--duration", type=positive_float, default=10.0, help="seconds per run (default 10)"
    )
    est.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    est.add_argument(
        "--engine",
        choices=("batched", "filterpy"),
        default="batched",
        help="filter engine (default batched)",
    )
    est.add_argument(
        "--out", metavar="DIR", help="also write estimation.csv and estimation.png here"
    )
    est.set_defaults(func=_cmd_estimation)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``acc-fusion`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
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
