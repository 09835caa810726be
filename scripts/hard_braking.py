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
import bisect
import math
import sys
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from acc_fusion.cli.arguments import add_scenario_arguments
from acc_fusion.cli.common import scenario_config
from acc_fusion.core.errors import AccFusionError
from acc_fusion.truth.sumo.config import SumoConfig
from acc_fusion.truth.sumo.launch import load_api, sumo_command

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


def _bin(distance: float) -> int:
    """The :data:`DISTANCE_BINS` bin of ``distance`` [m] (per vehicle and step: no numpy)."""
    return bisect.bisect_right(DISTANCE_BINS, distance) - 1


def hard_braking(
    config: SumoConfig,
    end: float,
    warmup: float,
    threshold: float,
    car_decel: float | None = None,
    progress: bool = True,
) -> HardBraking:
    """Hard-braking onsets, kilometres driven and the share of the vehicle-time spent braking
    at ``threshold`` [m/s²] or harder, from ``warmup`` to ``end``."""
    sumo = load_api(False)
    sumo.start(sumo_command(config))
    hard_time, time = 0.0, 0.0
    by_onsets, by_km = np.zeros(len(DISTANCE_BINS) - 1), np.zeros(len(DISTANCE_BINS) - 1)
    braking: set[str] = set()
    try:
        veh, dt = sumo.vehicle, sumo.simulation.getDeltaT()
        if car_decel is not None:
            for vtype in sumo.vehicletype.getIDList():
                if sumo.vehicletype.getVehicleClass(vtype) == "passenger":
                    sumo.vehicletype.setDecel(vtype, car_decel)
        for k in tqdm(
            range(1, int(round(end / dt)) + 1),
            disable=None if progress else True,
            desc="SUMO",
            leave=False,
        ):
            sumo.simulationStep()
            if k * dt < warmup:
                continue
            now = set()
            for vid in veh.getIDList():
                b = _bin(veh.getDistance(vid))
                by_km[b] += veh.getSpeed(vid) * dt / 1000.0
                time += dt
                if veh.getAcceleration(vid) <= -threshold:
                    now.add(vid)
                    if vid not in braking:
                        by_onsets[b] += 1
            hard_time += len(now) * dt
            braking = now
    finally:
        sumo.close()
    share = hard_time / max(time, 1e-12)
    return HardBraking(int(by_onsets.sum()), float(by_km.sum()), share, by_onsets, by_km)


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
