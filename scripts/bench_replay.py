"""Benchmark: recorded traffic through the whole FCW pipeline, in pair-steps per second.

Writes synthetic highD recordings (:mod:`acc_fusion.truth.replay.synthetic`: IDM traffic on
both carriageways, 25 Hz, three files each in the highD format) into a temporary folder
(``--recordings``, each of ``--duration`` seconds), then times
the replay end to end: the readers (pyarrow, streamed, windows of frames), the pairing and
packing, and :func:`~acc_fusion.sim.closed_loop.simulate` over every pair with radar and
infrared sensors, the ego-motion filter, every method's estimator (``--methods``: default the
federated filter; ``all``: radar, infrared, centralized, federated), each method's warning
logic, the oracle and the streaming metrics.  A pair-step is one vehicle of the recording
advanced by one frame.  The recordings are batched together up to ``--max-rows`` rows (a
wide batch keeps the pipeline's fixed cost per step small); while a batch plays, the source
reads the next in a thread (pyarrow parses without the GIL).  The numba kernels are compiled
(or loaded from the cache) before the clock starts.  The recordings are replayed twice: the
first replay parses each CSV and keeps its binary copy (:mod:`acc_fusion.truth.replay.cache`,
in the temporary folder), the second reads the copies, as every replay of a data set after
its first does.  The last line is the second's, ``pair_steps_per_s=<float>`` (goal: >= 1e6
on 2 cores); the first's rate is printed above it.

    python scripts/bench_replay.py                 # 4 recordings, about 1.5 M pair-steps
    python scripts/bench_replay.py --quick         # 2 recordings, about 0.2 M
    python scripts/bench_replay.py --methods all --slots 8192
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from acc_fusion.cli.arguments import positive_float, positive_int
from acc_fusion.sim.closed_loop import DEFAULT_METHODS, SimConfig, simulate
from acc_fusion.truth.replay.recording import MAX_ROWS
from acc_fusion.truth.replay.source import ReplayConfig, ReplaySource
from acc_fusion.truth.replay.synthetic import simulate_traffic, write_highd


def replay(
    folder: Path, slots: int, methods: tuple[str, ...], max_rows: int = MAX_ROWS
) -> tuple[float, int]:
    """Wall time [s] of the replay of ``folder``'s recordings, and its pair-steps."""
    t0 = time.perf_counter()
    source = ReplaySource(ReplayConfig("highd", str(folder), slots=slots, max_rows=max_rows))
    result = simulate(SimConfig(dt=source.dt, methods=methods), source=source)
    seconds = time.perf_counter() - t0
    steps = round(next(iter(result.summaries.values())).hours * 3600.0 / source.dt)
    return seconds, steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="2 short recordings (a few s)")
    parser.add_argument("--recordings", type=positive_int, default=4, help="default 4")
    parser.add_argument(
        "--duration", type=positive_float, default=200.0, help="seconds each (default 200)"
    )
    parser.add_argument(
        "--slots", type=positive_int, default=4096, help="pairs at once, at most (default 4096)"
    )
    parser.add_argument(
        "--methods", choices=("federated", "all"), default="federated", help="default federated"
    )
    parser.add_argument(
        "--max-rows", type=positive_int, default=MAX_ROWS, help=f"rows a batch (default {MAX_ROWS})"
    )
    args = parser.parse_args()
    methods = DEFAULT_METHODS if args.methods == "all" else ("federated",)
    count, duration = (2, 60.0) if args.quick else (args.recordings, args.duration)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        t0 = time.perf_counter()
        rows = 0
        for k in range(1, count + 1):
            traffic = simulate_traffic(lanes=3, duration=duration, spacing=30.0, seed=k)
            write_highd(traffic, folder, k)
            rows += traffic.s.size
        size = sum(f.stat().st_size for f in folder.glob("*_tracks.csv")) / 1e6
        print(f"synthetic highD: {count} recordings, {rows} rows, {size:.0f} MB of tracks "
              f"(written in {time.perf_counter() - t0:.1f} s)")  # fmt: skip
        os.environ["ACC_FUSION_REPLAY_CACHE"] = str(folder / "cache")  # copies: here only
        warm = folder / "warm"
        write_highd(simulate_traffic(lanes=1, duration=5.0, seed=0), warm, 1)
        replay(warm, 64, methods)  # compile or load the kernels
        first, steps = replay(folder, args.slots, methods, args.max_rows)
        seconds, again = replay(folder, args.slots, methods, args.max_rows)
    if again != steps:
        raise SystemExit(f"the replays differ: {steps} pair-steps, then {again}")
    print(f"methods: {', '.join(methods)}; slots: {args.slots}")
    print(f"first replay: {steps} pair-steps in {first:.2f} s (parsing and keeping the binary "
          f"copies, pairing, packing, pipeline): {steps / first:.4g} pair-steps/s")  # fmt: skip
    print(f"replay again: {steps} pair-steps in {seconds:.2f} s (reading the copies)")
    print(f"pair_steps_per_s={steps / seconds:.4g}")


if __name__ == "__main__":
    main()
