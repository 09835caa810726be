"""How a compiled kernel's parallel loop is cut into blocks for numba's threads."""

from __future__ import annotations

import numba


def blocks(n: int, threshold: int) -> int:
    """The blocks (four a numba thread, at most ``n``) in which a kernel runs ``n``
    independent items on the cores, or 0: serially, below ``threshold`` items (where the
    threads' start costs more than they save) or with one numba thread (a pool's worker)."""
    threads = numba.get_num_threads()
    return min(n, 4 * threads) if n >= threshold and threads > 1 else 0
