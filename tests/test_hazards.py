"""The hazards of the accelerated test, attributed and re-weighted to naturalistic rates."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError
from acc_fusion.metrics.events import EventState, FCWMetrics
from acc_fusion.metrics.hazards import (
    CATEGORIES,
    DISTRACTED,
    LANE_CHANGE,
    LATE,
    LEAD_BRAKING,
    HazardCounts,
    NaturalisticRates,
    category,
    hazard_table,
)


def counts(
    relevant=(1, 2, 3, 4, 5, 6, 0, 1, 2), crashes=(1, 0, 2, 1, 0, 1, 0, 0, 1), p=0.05, rate=2.0
) -> HazardCounts:
    return HazardCounts(relevant, crashes, 3600.0, 3600.0 * p, rate)


def test_the_categories_follow_the_flags_by_precedence():
    flags = [
        LEAD_BRAKING | DISTRACTED | LATE, LEAD_BRAKING | LANE_CHANGE | LATE, LEAD_BRAKING,
        LANE_CHANGE | DISTRACTED, LANE_CHANGE | LATE, LANE_CHANGE,
        DISTRACTED | LATE, LATE, 0,
    ]  # fmt: skip
    assert [CATEGORIES[i] for i in category(np.array(flags))] == list(CATEGORIES)


def test_the_weights_are_the_natural_over_the_simulated_rate_of_each_process():
    rates = NaturalisticRates(hard_braking_per_100km=(0.1, 0.5), eyes_off_share=(0.1, 0.2))
    w = counts(p=0.05, rate=2.0).weights(rates, km_per_h=80.0)
    # Lead braking: 0.1 per 100 km at 80 km/h is 0.08 per hour, against 2 injected.
    lead = np.array([0.08, 0.4]) / 2.0
    distracted, attentive = np.array([0.1, 0.2]) / 0.05, np.array([0.9, 0.8]) / 0.95
    np.testing.assert_allclose(w[:, 0], lead * distracted)
    np.testing.assert_allclose(w[:, 1], lead * attentive)  # a late driver's eyes are on
    np.testing.assert_allclose(w[:, 2], lead * attentive)
    for process in (1, 2):  # lane changes and the traffic run at their natural rates
        np.testing.assert_allclose(w[:, 3 * process], distracted)
        np.testing.assert_allclose(w[:, 3 * process + 1], attentive)
        np.testing.assert_allclose(w[:, 3 * process + 2], attentive)
    # A process the run did not simulate keeps weight 1 (its categories are empty).
    np.testing.assert_array_equal(counts(p=0.0, rate=0.0).weights(rates, 80.0), 1.0)


def test_runs_pool_by_adding_their_counts():
    other = counts(relevant=(0, 1) * 4 + (1,), crashes=(0, 0, 1) + (0,) * 6, p=0.15)
    both = counts() + other
    assert both.relevant == (1, 3, 3, 5, 5, 7, 0, 2, 3)
    assert both.crashes == (1, 0, 3, 1, 0, 1, 0, 0, 1)
    assert both.eyes_off_share == pytest.approx(0.1)


def test_the_table_re_weights_every_category_and_the_total():
    rates = NaturalisticRates(hard_braking_per_100km=(0.1, 0.5), eyes_off_share=(0.1, 0.1))
    off = counts()
    km, hours = 500.0, 6.25  # 80 km/h
    on = counts(crashes=(0, 0, 1) + (0,) * 6)
    t = hazard_table("t", off, km, hours, rates, on, km_on=500.0)
    rows = {(r["hazard"], r["driver"]): r for r in t.rows}
    w = off.weights(rates, 80.0)
    crashes = np.array(off.crashes)
    lo, hi = (w * crashes).sum(axis=1) / km * 1e6
    assert rows["all", "all"]["crashes"] == 6 and rows["all", "all"]["relevant"] == 24
    assert rows["all", "all"]["crashes_per_million_km_reweighted"] == f"{lo:.3g}-{hi:.3g}"
    assert rows["traffic", "attentive"]["weight"] == f"{w[0, 8]:.3g}"
    on_lo, on_hi = w[:, 2] / km * 1e6
    text = t.format()
    assert f"reduction {1 - on_lo / lo:.3g}-{1 - on_hi / hi:.3g}" in text
    assert "nan" not in text


def test_no_crash_is_said_in_words():
    t = hazard_table("t", counts(crashes=(0,) * 9), 100.0, 1.0, NaturalisticRates())
    assert "no crash with FCW off" in t.format() and "nan" not in t.format()


@pytest.mark.parametrize(
    "fields",
    [{"hard_braking_per_100km": (0.5, 0.1)}, {"eyes_off_share": (0.1, 1.0)},
     {"field_rear_end_per_million_km": (-1.0, 0.4)}],
)  # fmt: skip
def test_bad_references_are_one_line_errors(fields):
    with pytest.raises(ConfigError):
        NaturalisticRates(**fields)


def test_the_situations_start_and_end_as_the_metrics_count_them():
    rng = np.random.default_rng(3)
    n, dt = 6, 0.1
    flags = rng.random((400, n)) < 0.2
    flags &= np.roll(flags, 1, axis=0)  # runs of a few steps, with gaps of any length
    metrics, state, onsets, ends = FCWMetrics(n, dt), EventState(n), 0, 0
    zeros, on = np.zeros(n, dtype=np.int8), np.ones(n, dtype=bool)
    for k, now in enumerate(flags):
        t = k * dt
        metrics.update(t, zeros, zeros, np.full(n, np.inf), np.full(n, 20.0), on, relevant=now)
        new, ended = state.advance(t, now, 1.0)
        onsets, ends = onsets + int(new.sum()), ends + int(ended.sum())
    metrics.finish(len(flags) * dt)
    assert onsets == metrics.summary().relevant > 50
    assert ends + int(state.live.sum()) == onsets
