"""Steady-state (constant-gain) local filter against the full Kalman filter.

Prints the table of :func:`acc_fusion.studies.estimation.steady_vs_full` for each sensor asked for:
car
following, one sensor alone, the constant-gain filter of patent CN103196450A (gain of the
algebraic Riccati equation, :mod:`acc_fusion.filters.steady_state`) next to the full Kalman filter;
RMSE during the transient (first 2 s) and in steady state (after 4 s), mean NEES, and the
cost per pair-step of each, measured in the same run.

    python scripts/steady_state_vs_full.py --runs 500 --seed 0 --sensor infrared
"""

from __future__ import annotations

from acc_fusion.cli.arguments import study_parser
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.studies.estimation import steady_vs_full


def main(argv: list[str] | None = None) -> None:
    parser = study_parser(__doc__, runs=500)
    parser.add_argument(
        "--sensor",
        choices=SENSOR_NAMES,
        help="the sensor whose local filter is compared (default: each in turn)",
    )
    args = parser.parse_args(argv)
    sensors = [args.sensor] if args.sensor else SENSOR_NAMES
    print(
        "\n\n".join(
            steady_vs_full(n_runs=args.runs, seed=args.seed, sensor=s).format() for s in sensors
        )
    )


if __name__ == "__main__":
    main()
