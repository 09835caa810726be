"""How often the drivers of a SUMO scenario brake hard: the leads behind FCW's nuisance alerts.

Runs the scenario with SUMO's own drivers (nobody warned, nobody distracted) and reads every
vehicle's acceleration at every step after a warm-up. A *hard braking* starts when a vehicle's
deceleration reaches ``--threshold`` (default 3.4 m/s², AASHTO's deceleration that 90 % of
drivers exceed only for an unexpected object, the alert classes' crash-relevant threshold) and
ends when it falls below it. Prints the onsets per 100 km of driving and the share of driving
time spent braking that hard. ``--car-decel`` sets the ``decel`` of every passenger-car type
first (SUMO's Krauss drivers brake up to it in ordinary following; the bundled networks keep
SUMO's default 4.5 m/s²), for the sensitivity in docs/theory/alert-classes.md.
``--by-distance`` also prints the onsets by the distance the vehicle had driven since it
entered the network (SUMO's odometer, ``vehicle.getDistance``; bins :data:`DISTANCE_BINS`):
how far downstream the traffic settles after SUMO inserts its vehicles. The last line is
``onsets_per_100km=<x> share_of_time=<y> km=<z>``.

    python scripts/hard_braking.py                      # bundled motorway, 300 s
    python scripts/hard_braking.py --car-decel 3.0      # cars braking at most 3 m/s² normally
    python scripts/hard_braking.py --sumocfg my.sumocfg --end 600 --threshold 3.0
    python scripts/hard_braking.py --by-distance        # where along the trips
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass

import numpy as np

from acc_fusion.cli.arguments import add_scenario_arguments
from acc_fusion.cli.common import scenario_config
from acc_fusion.core.errors import AccFusionError
from acc_fusion.metrics.realism import braking_onsets, by_odometer
from acc_fusion.truth.sumo.config import SumoConfig
from acc_fusion.truth.sumo.trajectories import sumo_trajectories

#: Bins of the distance driven since entering the network [m] (``--by-distance``).
DISTANCE_BINS = (0.0, 500.0, 1000.0, 2000.0, 4000.0, math.inf)


@dataclass
class HardBraking:
    """What :func:`hard_braking` counted: onsets and kilometres, in all and by the distance
    since entering (:data:`DISTANCE_BINS`), and the share of the vehicle-time spent braking."""

    onsets: int
    km: float
    share: float
    onsets_by_distance: np.ndarray
    km_by_distance: np.ndarray


def hard_braking(
    config: SumoConfig,
    end: float,
    warmup: float,
    threshold: float,
    car_decel: float | None = None,
    progress: bool = True,
) -> HardBraking:
    """Hard-braking onsets, kilometres driven and the share of the vehicle-time spent braking
    at ``threshold`` [m/s²] or harder, from ``warmup`` to ``end``: every vehicle's samples
    (:func:`~acc_fusion.truth.sumo.trajectories.sumo_trajectories`) counted by
    :func:`~acc_fusion.metrics.realism.braking_onsets`."""

    def set_car_decel(api) -> None:
        for vtype in api.vehicletype.getIDList():
            if api.vehicletype.getVehicleClass(vtype) == "passenger":
                api.vehicletype.setDecel(vtype, car_decel)

    setup = None if car_decel is None else set_car_decel
    traj = sumo_trajectories(config, end, warmup, setup=setup, progress=progress)
    onsets, km = by_odometer(traj, braking_onsets(traj, threshold), DISTANCE_BINS)
    share = float(np.mean(traj.accel <= -threshold)) if len(traj) else 0.0
    return HardBraking(int(onsets.sum()), float(km.sum()), share, onsets, km)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_scenario_arguments(p, 60.0, "counting")
    p.add_argument("--threshold", type=float, default=3.4, help="hard braking from [m/s²] (3.4)")
    p.add_argument("--car-decel", type=float, help="set every car type's decel [m/s²] first")
    p.add_argument(
        "--by-distance",
        action="store_true",
        help="also print the onsets by the distance driven since entering the network",
    )
    args = p.parse_args(argv)
    try:
        if not args.threshold > 0:
            raise AccFusionError(f"--threshold must be > 0 m/s², got {args.threshold:g}")
        if args.car_decel is not None and not args.car_decel > 0:
            raise AccFusionError(f"--car-decel must be > 0 m/s², got {args.car_decel:g}")
        path, config = scenario_config(args)
        hb = hard_braking(config, args.end, args.warmup, args.threshold, args.car_decel)
    except AccFusionError as exc:
        print(f"hard_braking.py: error: {exc}", file=sys.stderr)
        return 2
    onsets, km, share = hb.onsets, hb.km, hb.share
    if km <= 0:
        print("hard_braking.py: error: no vehicle drove after the warm-up", file=sys.stderr)
        return 2
    rate = 100.0 * onsets / km
    cars = "SUMO's" if args.car_decel is None else f"{args.car_decel:g} m/s²"
    print(f"{path.name} ({args.warmup:g}-{args.end:g} s, car decel {cars}): {km:.0f} km driven")
    print(
        f"  braking at {args.threshold:g} m/s² or harder: {onsets} onsets, "
        f"{rate:.1f} per 100 km, {share:.2%} of the driving time"
    )
    if args.by_distance:
        print("  by the distance driven since entering the network:")
        edges = zip(DISTANCE_BINS[:-1], DISTANCE_BINS[1:], strict=True)
        for (lo, hi), n, k in zip(edges, hb.onsets_by_distance, hb.km_by_distance, strict=True):
            per = f"{100.0 * n / k:.1f} per 100 km" if k > 0 else "no driving"
            print(f"  {lo:g}-{hi:g} m: {k:.0f} km, {n:.0f} onsets, {per}")
    print(f"onsets_per_100km={rate:.2f} share_of_time={share:.4f} km={km:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
