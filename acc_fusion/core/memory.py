"""Give the heap that a long run has freed back to the operating system.

A step of the 2-D world allocates and frees arrays of a few hundred kB to a few MB (one row
per ego and object, sized by the traffic of the moment).  glibc's ``malloc`` raises its mmap
threshold each time such a block is freed, so later ones come from the main heap, and the
heap keeps its high-water mark: the resident memory of a run on SUMO's A10KW scenario rose
by some 94 MB per simulated hour beyond what the traffic explains, while the memory Python
and numpy hold (``tracemalloc``) stayed flat and ``malloc_trim(0)`` gave back about 150 MB
every 150 simulated seconds (docs/theory/world-sumo.md).  :func:`release_free_heap` calls
``malloc_trim(0)`` (glibc's documented way to return free heap pages, ``man 3
malloc_trim``); elsewhere (musl, macOS, Windows) it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools


@functools.cache
def _malloc_trim():
    """glibc's ``malloc_trim``, or ``None`` where the C library has none."""
    name = ctypes.util.find_library("c")
    try:
        return getattr(ctypes.CDLL(name), "malloc_trim", None) if name else None
    except OSError:
        return None


def release_free_heap() -> bool:
    """Return the free pages of the C heap to the operating system; whether any were."""
    trim = _malloc_trim()
    return bool(trim(0)) if trim is not None else False
