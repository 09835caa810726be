"""Returning the freed C heap to the system (acc_fusion.core.memory)."""

from __future__ import annotations

import ctypes.util
import os
import platform

import pytest

from acc_fusion.core.memory import release_free_heap


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


@pytest.mark.skipif(
    platform.system() != "Linux" or platform.libc_ver()[0] != "glibc",
    reason="malloc_trim is glibc's",
)
def test_holes_left_in_the_heap_go_back_to_the_system():
    # 2000 blocks of 64 kB (below glibc's mmap threshold: on the heap), every other freed:
    # free() cannot shrink a heap with live blocks above the holes; malloc_trim can.
    blocks = [bytearray(b"x" * 65536) for _ in range(2000)]
    keep = blocks[1::2]
    del blocks
    before = _rss_mb()
    assert release_free_heap()
    assert _rss_mb() < before - 30.0  # the 1000 holes are 62.5 MB
    assert len(keep) == 1000


def test_without_glibc_it_does_nothing(monkeypatch):
    from acc_fusion.core import memory

    memory._malloc_trim.cache_clear()
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: None)
    try:
        assert release_free_heap() is False
    finally:
        memory._malloc_trim.cache_clear()
