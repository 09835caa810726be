"""Warnings counted by class and by the cause recorded at their onset."""

import numpy as np
import pytest

from acc_fusion.core.errors import InputError
from acc_fusion.metrics.events import FCWMetrics
from acc_fusion.metrics.summary import CAUSE_COUNTS, CAUSES


def _run(cause_at_onset, steps=60, dt=0.1):
    m = FCWMetrics(3, dt)
    for k in range(steps):
        t = k * dt
        on = 1.0 <= t < 2.0
        system = np.array([on, on, 0], np.int8)
        oracle = np.array([0, on, 0], np.int8)  # pair 1's warning meets a threat
        relevant = np.array([False, on, False])
        cause = None if cause_at_onset is None else np.array(cause_at_onset)
        m.update(t, system, oracle, np.full(3, np.inf), np.full(3, 20.0), np.ones(3, bool),
                 relevant=relevant, cause=cause)  # fmt: skip
    m.finish(steps * dt)
    return m.summary()


def test_each_warning_is_counted_under_its_class_and_its_onset_cause():
    s = _run([CAUSES.index("stationary"), CAUSES.index("lead"), 0])
    assert s.by_cause["sensing_false"]["stationary"] == 1
    assert s.by_cause["crash_relevant"]["lead"] == 1
    total = sum(sum(row.values()) for row in s.by_cause.values())
    assert total == s.warnings == 2


def test_a_sensing_false_warning_on_the_true_lead_counts_as_noise():
    """The target was right and the rule would not have fired on it: its estimate was wrong.
    A warning on the true lead that met a threat stays ``lead``."""
    s = _run([CAUSES.index("lead"), CAUSES.index("lead"), 0])
    assert s.by_cause["sensing_false"]["noise"] == 1
    assert s.by_cause["sensing_false"]["lead"] == 0
    assert s.by_cause["crash_relevant"]["lead"] == 1
    assert s.by_cause["crash_relevant"]["noise"] == 0


def test_per_pair_counts_the_false_warnings_by_cause():
    per = _run([CAUSES.index("stationary"), CAUSES.index("lead"), 0]).per_pair
    assert per["sensing_false_stationary"].tolist() == [1, 0, 0]
    assert all(per[c].sum() == 0 for c in CAUSE_COUNTS if c != "sensing_false_stationary")
    assert "sensing_false_lead" not in per and "nuisance_noise" not in per


def test_without_causes_the_summary_has_none_and_its_dict_no_key():
    s = _run(None)
    assert s.by_cause is None
    assert "by_cause" not in s.as_dict()


@pytest.mark.parametrize("bad", [len(CAUSES), -2, CAUSES.index("noise")])
def test_a_cause_out_of_range_or_noise_at_onset_is_one_error(bad):
    m = FCWMetrics(1, 0.1)
    with pytest.raises(InputError, match="cause"):
        m.update(0.0, np.zeros(1, np.int8), np.zeros(1, np.int8), np.full(1, np.inf),
                 np.ones(1), np.ones(1, bool), cause=np.array([bad]))  # fmt: skip
