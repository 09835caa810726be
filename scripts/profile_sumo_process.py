"""Profile: what SUMO's process spends besides SUMO's step, as a fraction of the step.

Runs the loop of :class:`acc_fusion.truth.sumo.background.BackgroundSumoSource`'s child in this
process (``--repeat`` times, each in a fresh process: libsumo runs one simulation per
process): SUMO's step, the source's reads, their arrays written into a ring of shared memory
(:class:`~acc_fusion.truth.sumo.ring._Snapshots`, the parent's room given back at once) and
the message pickled and written (to ``/dev/null``); the parent makes the frames.  It times
SUMO's step, the compiled reader's call (``reads``; 0 where the reader is not available),
the rest of the source's reading (``fill``: the arrays, the leaders without a slot), the
ring (``snapshot``), the message (``message``) and everything else (``rest``: events, slot
bookkeeping, stepping), and prints each run's
fractions of the step's time and, last, ``besides_step=<median of the runs' totals>``.
This is the child's share of ``overhead_ratio`` in ``scripts/bench_sumo.py``, measured
without the other process and with a smaller spread than the bench's wall times.

    python scripts/profile_sumo_process.py                 # motorway, 200 s, 3 runs
    python scripts/profile_sumo_process.py --net onramp --end 600
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from statistics import median

PARTS = ("reads", "fill", "snapshot", "message", "rest")


def _profile(sumocfg: str, end: float) -> tuple[float, dict[str, float]]:
    """SUMO's mean step time [µs] and each part's time as a fraction of the step's."""
    import libsumo

    from acc_fusion.truth.sumo import background as bg
    from acc_fusion.truth.sumo import ring as ring_mod
    from acc_fusion.truth.sumo.config import SumoConfig
    from acc_fusion.truth.sumo.source import SumoSource

    class NoParent(bg._RingWriter):
        """The child's ring writer, with the room given back at once (no parent reads)."""

        def _await_room(self) -> None:
            self._returned = self._head

    spent = dict.fromkeys(("step", "reading", *PARTS), 0.0)

    def timed(func, key):
        def call(*args):
            t0 = time.perf_counter()
            try:
                return func(*args)
            finally:
                spent[key] += time.perf_counter() - t0

        return call

    class Reader:  # the compiled reader, its read timed
        def __init__(self, native):
            self.read = timed(native.read, "reads")

    src = SumoSource(SumoConfig(sumocfg=sumocfg, end=end))
    raw_step = libsumo._libsumo.simulation_step
    libsumo._libsumo.simulation_step = timed(raw_step, "step")
    try:
        if src._native is not None:
            src._native = Reader(src._native)
        src._fill = timed(src._fill, "reading")
        size = bg._ring_bytes(src.n_pairs)
        ring = bg._FrameRing(bg._FrameRing.create(size), size)
        snapshot = timed(bg._Snapshots(src.n_pairs, NoParent(ring, None, None)), "snapshot")
        outbox = ring_mod._Outbox(os.open(os.devnull, os.O_WRONLY), ring_mod.OUTBOX_LIMIT)
        put = timed(outbox.put, "message")
        put(snapshot(src, []))  # the first frame, as the child sends it: off the clock
        for key in spent:
            spent[key] = 0.0
        steps, t0 = 0, time.perf_counter()
        while not src.done:
            src._step()
            put(snapshot(src, []))
            steps += 1
        total = time.perf_counter() - t0
    finally:
        libsumo._libsumo.simulation_step = raw_step
        src.close()
    step = spent["step"]
    spent["fill"] = spent["reading"] - spent["reads"]
    spent["rest"] = total - step - spent["reading"] - spent["snapshot"] - spent["message"]
    return 1e6 * step / max(steps, 1), {k: spent[k] / step for k in PARTS}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--net", default="motorway", help="bundled network (default motorway)")
    parser.add_argument("--end", type=float, default=200.0, help="simulated seconds (200)")
    parser.add_argument("--repeat", type=int, default=3, help="runs, median total (default 3)")
    args = parser.parse_args(argv)
    # Here, not at the top: the worker processes import this script, and the traffic module
    # brings the whole pipeline with it (a second or more per worker).
    from acc_fusion.truth.sumo.nets import bundled_nets

    nets = bundled_nets()
    if args.net not in nets:
        parser.error(f"--net must be one of {', '.join(nets)}, got {args.net!r}")
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    if not args.end > 0:
        parser.error(f"--end must be positive, got {args.end}")
    ctx = multiprocessing.get_context("spawn")
    totals = []
    for i in range(1, args.repeat + 1):
        with ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
            step_us, parts = pool.submit(_profile, str(nets[args.net]), args.end).result()
        totals.append(sum(parts.values()))
        shares = ", ".join(f"{name} {parts[name]:.3f}" for name in PARTS)
        print(f"run {i}: SUMO step {step_us:.0f} µs; {shares}; total {totals[-1]:.3f}")
    print(f"besides_step={median(totals):.3f}")


if __name__ == "__main__":
    main()
