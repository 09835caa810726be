"""Benchmark: recorded traffic through the whole FCW pipeline, in pair-steps per second.

Writes a synthetic highD recording (:mod:`acc_fusion.truth.replay.synthetic`: IDM traffic on
both carriageways, 25 Hz, three files in the highD format) into a temporary folder, then times
the replay end to end: the readers (pyarrow, streamed, windows of frames), the pairing and
packing, and :func:`~acc_fusion.sim.closed_loop.simulate` over every pair with radar and
infrared sensors, the ego-motion filter, every method's estimator (``--methods``: default the
federated filter; ``all``: radar, infrared, centralized, federated), each method's warning
logic, the oracle and the streaming metrics.  A pair-step is one vehicle of the recording
advanced by one frame.  The numba kernels are compiled (or loaded from the cache) before the
clock starts.  The last line is ``pair_steps_per_s=<float>`` (goal: >= 1e6 on 2 cores).

    python scripts/bench_replay.py                 # about 1.5 M pair-steps
    python scripts/bench_replay.py --quick         # about 0.2 M, a few seconds
    python scripts/bench_replay.py --methods all --slots 8192
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from acc_fusion.sim.closed_loop import DEFAULT_METHODS, SimConfig, simulate
from acc_fusion.truth.replay.source import ReplayConfig, ReplaySource
from acc_fusion.truth.replay.synthetic import simulate_traffic, write_highd


def replay(folder: Path, slots: int, methods: tuple[str, ...]) -> tuple[float, int]:
    """Wall time [s] of the replay of ``folder``'s recording, and its pair-steps."""
    t0 = time.perf_counter()
    source = ReplaySource(ReplayConfig("highd", str(folder), slots=slots))
    result = simulate(SimConfig(dt=source.dt, methods=methods), source=source)
    seconds = time.perf_counter() - t0
    steps = round(next(iter(result.summaries.values())).hours * 3600.0 / source.dt)
    return seconds, steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a small recording (a few s)")
    parser.add_argument("--slots", type=int, default=4096, help="pairs at once (default 4096)")
    parser.add_argument(
        "--methods", choices=("federated", "all"), default="federated", help="default federated"
    )
    args = parser.parse_args()
    methods = DEFAULT_METHODS if args.methods == "all" else ("federated",)
    duration = 120.0 if args.quick else 900.0
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        t0 = time.perf_counter()
        traffic = simulate_traffic(lanes=3, duration=duration, spacing=30.0, seed=1)
        write_highd(traffic, folder, 1)
        size = (folder / "01_tracks.csv").stat().st_size / 1e6
        print(f"synthetic highD recording: {traffic.s.size} rows, {size:.0f} MB "
              f"(written in {time.perf_counter() - t0:.1f} s)")  # fmt: skip
        warm = folder / "warm"
        write_highd(simulate_traffic(lanes=1, duration=5.0, seed=2), warm, 1)
        replay(warm, 64, methods)  # compile or load the kernels
        seconds, steps = replay(folder, args.slots, methods)
    rate = steps / seconds
    print(f"methods: {', '.join(methods)}; slots: {args.slots}")
    print(f"replay: {steps} pair-steps in {seconds:.2f} s (readers, pairing, packing, pipeline)")
    print(f"pair_steps_per_s={rate:.4g}")


if __name__ == "__main__":
    main()
