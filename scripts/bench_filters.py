"""Speed benchmark: one pair-step of federated fusion on the batched engine vs filterpy.

A pair-step is one step of one follower→leader pair through ``FederatedFilter.step``: the
radar and infrared local Kalman filters, the federated fusion and the chi-square fault test
(default :class:`~acc_fusion.fusion.fdi.FDIConfig`).  Both engines run in the same process on the
same measurements, recorded beforehand so that sensor time is left out (car following,
radar 20 Hz + infrared 10 Hz, step 0.05 s), at each N of ``--sizes``.  The first
``WARMUP_STEPS`` steps of every timed estimator are not timed: they hold numba's compilation
(or cache load) and the initialisation of every track, so both engines are timed in steady
operation.  The batched engine also times the radar's full Kalman filter against its
steady-state constant-gain filter (``local="steady"``).

The last line is exactly ``speedup_vs_filterpy=<float>``: the filterpy time over the batched
time per pair-step at the largest N run.  Target: >= 500.

    python scripts/bench_filters.py            # N = 1 000 and 10 000, about a minute
    python scripts/bench_filters.py --quick    # the same sizes, fewer steps: < 60 s
    python scripts/bench_filters.py --sizes 1000 100000 --steps 20 --reference-steps 2
"""

from __future__ import annotations

import argparse
import gc
import statistics
import time
from dataclasses import replace

import numpy as np

from acc_fusion.core.table import Table
from acc_fusion.fusion.config import FusionConfig
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.sensors.sensor import Measurement
from acc_fusion.sensors.spec import infrared_spec, radar_spec
from acc_fusion.sensors.suite import SENSOR_NAMES, make_sensors
from acc_fusion.studies.estimation import FOLLOWING_FILTER, following_source

#: Untimed steps before timing: step 0 initialises the tracks (and compiles/loads the numba
#: kernels), steps 1-3 cover the radar-only and radar + infrared steps once more.  Even, so
#: that the timed steps start on a step where both sensors report.
WARMUP_STEPS = 4
#: Timed steps (batched engine, filterpy engine) of a full run and of ``--quick``.
STEPS = {"full": (50, 20), "quick": (20, 4)}
#: Timed runs per estimator (the median is kept): the batched engine's runs are short, so
#: they are repeated against scheduling noise; one filterpy run lasts seconds already.
REPEATS = {"batched": 3, "filterpy": 1}
TARGET_SPEEDUP = 500.0

FEDERATED = FusionConfig(method="federated", filter=FOLLOWING_FILTER)
RADAR_FULL = FusionConfig(method="radar", filter=FOLLOWING_FILTER)
RADAR_STEADY = replace(RADAR_FULL, local="steady")


def record(n_pairs: int, n_steps: int, seed: int) -> list[tuple[list[Measurement], np.ndarray]]:
    """``n_steps`` steps of (measurements of both sensors, leader ids) for ``n_pairs`` pairs."""
    source = following_source(n_pairs, seed)
    sensors = make_sensors(seed + 1)
    frame = source.frame()
    steps = []
    for _ in range(n_steps):
        steps.append(([s.measure(frame) for s in sensors], frame.leader_id))
        frame = source.advance()
    return steps


def seconds_per_pair_step(config: FusionConfig, steps: list, n_timed: int, repeats: int) -> float:
    """Wall time of ``config``'s estimator per pair-step over ``n_timed`` steps after warm-up.

    The median over ``repeats`` runs, each with a new estimator; the garbage collector is
    off while timing (as in :mod:`timeit`).
    """
    n_pairs = len(steps[0][1])
    timed = steps[WARMUP_STEPS : WARMUP_STEPS + n_timed]
    times = []
    for _ in range(repeats):
        est = make_estimator(config, SENSOR_NAMES, n_pairs, specs=[radar_spec(), infrared_spec()])
        for meas, target in steps[:WARMUP_STEPS]:
            est.step(meas, target)
        gc.disable()
        try:
            t0 = time.perf_counter()
            for meas, target in timed:
                est.step(meas, target)
            times.append(time.perf_counter() - t0)
        finally:
            gc.enable()
    return statistics.median(times) / (len(timed) * n_pairs)


def positive(text: str) -> int:
    """argparse type: a whole number >= 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text}")
    return value


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--quick", action="store_true", help="fewer timed steps: finishes within a minute"
    )
    parser.add_argument(
        "--sizes",
        type=positive,
        nargs="+",
        default=[1000, 10000],
        metavar="N",
        help="numbers of pairs to time (default 1000 10000)",
    )
    parser.add_argument(
        "--steps",
        type=positive,
        help=f"timed steps of the batched engine (default {STEPS['full'][0]}, "
        f"--quick {STEPS['quick'][0]}); even counts balance the 10 Hz infrared",
    )
    parser.add_argument(
        "--reference-steps",
        type=positive,
        help=f"timed steps of the filterpy engine (default {STEPS['full'][1]}, "
        f"--quick {STEPS['quick'][1]}); it costs about 0.1-0.2 ms per pair-step",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of truth and noise (default 0)")
    args = parser.parse_args(argv)
    steps, ref_steps = STEPS["quick" if args.quick else "full"]
    steps = args.steps or steps
    ref_steps = args.reference_steps or ref_steps

    costs = Table(
        "Cost per pair-step, car following, radar 20 Hz + infrared 10 Hz, "
        f"step {FOLLOWING_FILTER.dt:g} s",
        ("N", "estimator", "engine", "timed_steps", "repeats", "us_per_pair_step"),
    )
    ratios = Table(
        "Ratios per N",
        ("N", "speedup_vs_filterpy", "full_over_steady"),
        notes=[
            f"speedup_vs_filterpy = filterpy / batched, federated + FDI (target >= "
            f"{TARGET_SPEEDUP:g}); full_over_steady = radar full KF / steady-state KF, batched"
        ],
    )
    cases = (
        ("federated + FDI", "filterpy", replace(FEDERATED, engine="filterpy"), ref_steps),
        ("federated + FDI", "batched", FEDERATED, steps),
        ("radar full KF", "batched", RADAR_FULL, steps),
        ("radar steady-state KF", "batched", RADAR_STEADY, steps),
    )
    for n in sorted(set(args.sizes)):
        recorded = record(n, WARMUP_STEPS + max(steps, ref_steps), args.seed)
        us = {}
        for label, engine, config, n_timed in cases:
            repeats = REPEATS[engine]
            us[label, engine] = 1e6 * seconds_per_pair_step(config, recorded, n_timed, repeats)
            costs.rows.append(
                {
                    "N": n,
                    "estimator": label,
                    "engine": engine,
                    "timed_steps": n_timed,
                    "repeats": repeats,
                    "us_per_pair_step": us[label, engine],
                }
            )
        speedup = us["federated + FDI", "filterpy"] / us["federated + FDI", "batched"]
        ratios.rows.append(
            {
                "N": n,
                "speedup_vs_filterpy": speedup,
                "full_over_steady": us["radar full KF", "batched"]
                / us["radar steady-state KF", "batched"],
            }
        )
    print(costs.format())
    print()
    print(ratios.format())
    print(f"speedup_vs_filterpy={speedup:.1f}")


if __name__ == "__main__":
    main()
