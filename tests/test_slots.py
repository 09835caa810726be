"""The pipeline works on the prefix of occupied slots, with the results of the whole capacity."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.slots import Extent, PairPool
from acc_fusion.metrics.events import COUNTS, FCWMetrics
from acc_fusion.warning.logic import WarningConfig, WarningLogic


def test_resize_parks_the_tail_and_growing_back_restores_it():
    metrics = FCWMetrics(8, dt=0.1)
    metrics._pair_driven_s[:] = np.arange(8.0)
    metrics._warnings.start[:] = np.arange(8.0) + 10
    metrics.resize(3)
    assert metrics.n_pairs == 3 and metrics._pair_counts.shape == (len(COUNTS), 3)
    np.testing.assert_array_equal(metrics._warnings.start, [10.0, 11.0, 12.0])
    metrics._pair_driven_s[:] += 100.0  # the held pairs move on; the parked ones do not
    metrics.resize(5)
    np.testing.assert_array_equal(metrics._pair_driven_s, [100, 101, 102, 3, 4])
    metrics.resize(8)
    np.testing.assert_array_equal(metrics._pair_driven_s, [100, 101, 102, 3, 4, 5, 6, 7])
    np.testing.assert_array_equal(metrics._warnings.start, np.arange(8.0) + 10)
    with pytest.raises(ConfigError, match="FCWMetrics can hold 1 to 8 pairs, got 9"):
        metrics.resize(9)


def test_a_resized_stage_takes_inputs_of_its_new_size():
    logic = WarningLogic(WarningConfig(), 6, dt=0.1)
    logic.resize(2)
    level = logic.step(np.array([5.0, 80.0]), 20.0, np.array([-10.0, 0.0]))
    assert level.shape == (2,) and level[0] > 0 == level[1]


def test_extent_covers_the_active_slots_and_those_active_a_step_ago():
    extent = Extent(256, quantum=16)
    active = np.zeros(256, dtype=bool)
    active[[0, 20]] = True
    assert extent.fit(active) == 32  # slot 20 needs 21 slots, rounded up to two quanta
    active[20] = False
    assert extent.fit(active) == 32  # slot 20 emptied: seen empty once more
    assert extent.fit(active) == 32  # 16 would do, but a prefix shrinks by two quanta or more
    active[100] = True
    assert extent.fit(active) == 112  # grows at once
    active[100] = False
    extent.fit(active)
    assert extent.fit(active) == 16
    assert extent.fit(np.zeros(256, dtype=bool)) == 16  # never empty
    active[:] = True
    assert extent.fit(active) == 256


def test_pair_mask_takes_a_mask_indices_or_none():
    from acc_fusion.core.slots import pair_mask

    mask = np.array([False, True, False, True])
    assert np.array_equal(pair_mask(mask, 4), mask)
    assert np.array_equal(pair_mask([1, 3], 4), mask)
    assert pair_mask(None, 4).all()
    with pytest.raises(IndexError):
        pair_mask([4], 4)
    with pytest.raises(IndexError):
        pair_mask(np.ones(3, dtype=bool), 4)


def test_pair_pool_keeps_the_used_pairs_a_dense_prefix():
    pool = PairPool(n_keys=10, n_pairs=4)
    live = np.zeros(10, dtype=bool)
    live[[7, 2, 9]] = True
    assert not pool.update(live).any()
    np.testing.assert_array_equal(pool.key_of, [2, 7, 9, -1])  # lowest free pair first
    live[7] = False
    live[5] = True
    freed = pool.update(live)
    np.testing.assert_array_equal(freed, [False, True, False, False])  # key 7's pair, retaken
    np.testing.assert_array_equal(pool.key_of, [2, 5, 9, -1])
    assert pool.pair_of[5] == 1 and pool.pair_of[7] == -1
    np.testing.assert_array_equal(pool.update(live[:6]), [False, False, True, False])  # 9 left
    np.testing.assert_array_equal(pool.used, [True, True, False, False])
    keys = np.zeros(10, dtype=bool)
    keys[2] = True
    np.testing.assert_array_equal(pool.release(keys), [True, False, False, False])
    with pytest.raises(ConfigError, match="the pool of 4 pairs is full"):
        pool.update(np.ones(10, dtype=bool))


def test_pair_pool_holds_exactly_the_live_keys_with_the_lowest_free_pairs():
    rng = np.random.default_rng(5)
    pool = PairPool(n_keys=64, n_pairs=40)
    for _ in range(200):
        live = rng.random(rng.integers(0, 65)) < 0.4
        if live.sum() > 40:
            continue
        before, pairs_before = pool.key_of.copy(), pool.pair_of.copy()
        freed = pool.update(live)
        keys = np.flatnonzero(pool.pair_of >= 0)
        np.testing.assert_array_equal(keys, np.flatnonzero(live))
        np.testing.assert_array_equal(pool.key_of[pool.pair_of[keys]], keys)  # inverse maps
        assert np.count_nonzero(pool.key_of >= 0) == keys.size
        stayed = keys[pairs_before[keys] >= 0]
        np.testing.assert_array_equal(pool.pair_of[stayed], pairs_before[stayed])  # kept
        np.testing.assert_array_equal(freed, (before >= 0) & ~np.isin(before, stayed))
        taken = pool.pair_of[keys[pairs_before[keys] < 0]]
        free_then = np.flatnonzero(~np.isin(np.arange(40), pairs_before[stayed]))
        np.testing.assert_array_equal(taken, free_then[: taken.size])  # the lowest, in order
