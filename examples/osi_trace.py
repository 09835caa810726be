"""An ASAM OSI trace of ``make run``'s first minute, read back and replayed.

``make run`` is ``acc-fusion sumo --net motorway --end 300``; this runs its first minute with
``--osi``, which writes one OSI trace (MCAP) per equipped vehicle of the FCW-off run — the
ground truth it drove in, its own speed, acceleration and yaw-rate readings, the radar's and
the thermal camera's detections and tracks, every method's estimates — here for the first
``--vehicles`` vehicles only.  It then reads each trace back with ``asam-osi-utilities`` (what
any OSI tool would read) and replays them with ``acc-fusion replay --format osi``: the 2-D
world's trackers, fusion and warning on the recorded detections.  Needs the ``sumo`` and
``interop`` extras.  Run it:

    python examples/osi_trace.py                  # 60 s, 3 vehicles, traces in osi_traces/
    python examples/osi_trace.py --end 20 --vehicles 1 --out /tmp/osi
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

from acc_fusion.cli.main import main as acc_fusion
from acc_fusion.sim.osi_trace import read_channels, topics


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--end", default="60", help="simulated seconds after the warm-up (60)")
    parser.add_argument("--vehicles", default="3", help="vehicles traced (3)")
    parser.add_argument("--out", type=Path, default=Path("osi_traces"), help="the traces' folder")
    args = parser.parse_args(argv)

    run = ["sumo", "--net", "motorway", "--end", args.end]
    if acc_fusion([*run, "--osi", str(args.out), "--osi-vehicles", args.vehicles]) != 0:
        raise SystemExit("the SUMO run failed")
    print("\nThe traces, read back with asam-osi-utilities")
    for path in sorted(args.out.glob("*.mcap")):
        channels = read_channels(path, topics(path))
        truth = channels["ground_truth"]
        objects = [len(gt.moving_object) + len(gt.stationary_object) for gt in truth]
        radar = [len(sd.feature_data.radar_sensor[0].detection) for sd in channels["sensor/radar"]]
        fused = [len(sd.moving_object) for sd in channels["estimate/federated"]]
        print(
            f"{path.name}: {len(channels)} channels, {len(truth)} steps, "
            f"objects ahead {statistics.median(objects):g} (median), radar detections "
            f"{statistics.median(radar):g}, fused objects {statistics.median(fused):g}, "
            f"{path.stat().st_size / 1e6:.1f} MB"
        )
    print()
    acc_fusion(["replay", "--format", "osi", "--path", str(args.out)])


if __name__ == "__main__":
    main()
