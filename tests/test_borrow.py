"""Arrays without a reference count (:mod:`acc_fusion.core.borrow`): the same memory, with
no count to keep, for as long as their owners live."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

from acc_fusion.core.borrow import borrow, keep_alive


@njit
def _write_through(a, b):
    a, b = borrow((a, b))
    view = borrow(a)[1:]
    view[0] = 7.0
    b[1, 0] += 1.0
    return a.sum() + b.sum()


@njit
def _scratch_sum(n):
    owners = (np.arange(float(n)), np.ones((n, 2)))
    seq, ones = borrow(owners)
    total = 0.0
    for _ in range(3):  # reallocations here would reuse freed owners' memory
        junk = np.full(n, -1.0)
        total += seq.sum() + ones.sum() + 0.0 * junk[0]
    keep_alive(owners)
    return total


def test_a_borrowed_array_views_the_same_memory():
    a, b = np.zeros(4), np.ones((3, 2))
    assert _write_through(a, b) == 7.0 + 7.0
    assert a[1] == 7.0 and b[1, 0] == 2.0


def test_borrowed_scratch_lives_until_keep_alive():
    n = 1000
    assert _scratch_sum(n) == 3 * (n * (n - 1) / 2 + 2 * n)


def test_only_arrays_or_tuples_of_arrays_are_borrowed():
    @njit
    def scalar(x):
        return borrow(x)

    @njit
    def mixed(a):
        return borrow((a, 1.0))

    with pytest.raises(TypingError):
        scalar(1.0)
    with pytest.raises(TypingError):
        mixed(np.zeros(2))
