"""How a compiled kernel's parallel loop is cut into blocks for numba's threads, and how long
those threads wait for the next kernel.

Numba's OpenMP threading layer (GNU libgomp) keeps its threads spinning after a parallel
kernel, ``GOMP_SPINCOUNT`` iterations (300 000 by default: milliseconds), before they sleep.
The 2-D pipeline runs a parallel kernel every millisecond or so, so with the default the
second core is never free in its serial stretches, which is when SUMO's background process
(:class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource` with object frames) runs.
Importing this module sets :data:`SPIN_COUNT` unless the environment already sets it; it
takes effect if numba has not started its threads yet (the first parallel kernel starts
them, and every parallel kernel of the package imports this module first).
"""

from __future__ import annotations

import os

import numba

#: libgomp's spin iterations after a kernel (see the module docstring).
#: ``python scripts/bench_world.py``, 2026-11-27, SUMO in the background at niceness 19, one
#: run each: ``overhead_ratio`` 10.4 with threads that sleep at once
#: (``OMP_WAIT_POLICY=PASSIVE``: each kernel waits for them to wake), 9.0 with 10 000 spins,
#: 9.2 with 50 000, 11.6 with the default (SUMO's process starved, the pipeline waiting for
#: its frames); then five runs at 10 000: median 10.3 (docs/theory/world-sumo.md).
SPIN_COUNT = 10_000
os.environ.setdefault("GOMP_SPINCOUNT", str(SPIN_COUNT))


def blocks(n: int, threshold: int) -> int:
    """The blocks (four a numba thread, at most ``n``) in which a kernel runs ``n``
    independent items on the cores, or 0: serially, below ``threshold`` items (where the
    threads' start costs more than they save) or with one numba thread (a pool's worker)."""
    threads = numba.get_num_threads()
    return min(n, 4 * threads) if n >= threshold and threads > 1 else 0
