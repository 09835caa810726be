"""The driver-monitoring camera and the warning that adapts to what it and the driver's
braking report."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.sensors.driver_monitor import DriverMonitor
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.warning.logic import AdaptiveConfig, WarningConfig, WarningLogic
from acc_fusion.warning.safety_params import RequiredDecelerationParams, TTCParams

DT = 0.1
ADAPTIVE = AdaptiveConfig(enabled=True)
NONE = AdaptiveConfig(braking=0.0)  # nothing adapts


def reports(eyes_off: list[bool], latency=0.5, recovery=1.0) -> list[bool]:
    """What a monitor of one driver reports at each step of ``eyes_off``, from t = 0 (a
    driver it has watched for long)."""
    monitor = DriverMonitor(1, latency, recovery)
    monitor.reset([0], -10.0)
    return [bool(monitor.step(k * DT, np.array([off]))[0]) for k, off in enumerate(eyes_off)]


def test_a_glance_shorter_than_the_latency_goes_unseen():
    eyes = [False] * 5 + [True] * 4 + [False] * 10  # 0.4 s off, latency 0.5 s
    assert all(reports(eyes))


def test_a_long_glance_is_seen_after_the_latency_and_held_for_the_recovery():
    eyes = [False] * 5 + [True] * 20 + [False] * 20  # off from 0.5 s to 2.5 s
    got = reports(eyes)
    # Seen from 0.5 + 0.5 = 1.0 s (step 10) to the glance's last step (2.4 s, step 24),
    # then distracted until 2.4 + 1.0 = 3.4 s (step 34): attentive again from there on.
    assert got[:10] == [True] * 10
    assert got[10:34] == [False] * 24
    assert got[34:] == [True] * 11


def test_a_new_driver_counts_as_distracted_while_the_camera_acquires_him():
    monitor = DriverMonitor(2, 0.5, 1.0)
    monitor.reset([0, 1], -10.0)
    monitor.reset(np.array([False, True]), 5.0)
    eyes_on = np.zeros(2, dtype=bool)
    assert monitor.step(5.5, eyes_on).tolist() == [True, False]
    assert monitor.step(6.0, eyes_on).tolist() == [True, True]


def test_the_monitor_rejects_eyes_of_the_wrong_shape_or_type():
    monitor = DriverMonitor(2, 0.5, 1.0)
    with pytest.raises(InputError, match=r"eyes_off must be a boolean array of shape \(2,\)"):
        monitor.step(0.0, np.zeros(3, dtype=bool))
    with pytest.raises(InputError, match="eyes_off must be a boolean array"):
        monitor.step(0.0, np.zeros(2))


def test_an_attentive_driver_is_warned_as_with_the_attentive_reaction_time():
    """Each driver the monitor reports attentive gets exactly the levels of the rule with the
    attentive reaction time; the others those of the rule itself."""
    rng = np.random.default_rng(3)
    n, steps = 40, 200
    adaptive = WarningLogic(WarningConfig(adaptive=ADAPTIVE), n, DT)
    plain = WarningLogic(WarningConfig(), n, DT)
    late_params = RequiredDecelerationParams(reaction_time=AdaptiveConfig().reaction_time)
    late = WarningLogic(WarningConfig(params=late_params), n, DT)
    looking = rng.random(n) < 0.5
    differ = 0
    for _ in range(steps):
        gap = rng.uniform(5.0, 60.0, n)
        v_ego, v_rel = rng.uniform(5.0, 35.0, n), rng.uniform(-12.0, 2.0, n)
        a_lead = rng.uniform(-6.0, 1.0, n)
        got = adaptive.step(gap, v_ego, v_rel, a_lead, attentive=looking)
        want = np.where(
            looking, late.step(gap, v_ego, v_rel, a_lead), plain.step(gap, v_ego, v_rel, a_lead)
        )
        np.testing.assert_array_equal(got, want)
        differ += int((want != plain.level).sum())
    assert differ > 0  # the attentive timing did change some levels


def test_the_adaptive_timing_warns_an_attentive_driver_later():
    """A lead braking at 4 m/s² from 30 m/s at 30 m: the attentive driver's imminent alert
    comes later (the rule with a 0.75 s instead of a 1.25 s reaction time)."""
    logic = WarningLogic(WarningConfig(adaptive=ADAPTIVE), 2, DT)
    looking = np.array([False, True])
    first = [None, None]
    gap, v_ego, v_lead = 30.0, 30.0, 30.0
    for k in range(60):
        rel = v_lead - v_ego
        level = logic.step([gap] * 2, v_ego, rel, -4.0, attentive=looking)
        for i in range(2):
            if first[i] is None and level[i] == 2:
                first[i] = k
        v_lead = max(v_lead - 4.0 * DT, 0.0)
        gap += rel * DT
    assert first[0] is not None and first[1] is not None and first[1] > first[0]


def test_bad_adaptive_settings_and_inputs_are_one_line_errors():
    with pytest.raises(ConfigError, match="warning.adaptive needs a model with a reaction_time"):
        WarningConfig(model="ttc", params=TTCParams(), adaptive=ADAPTIVE)
    with pytest.raises(ConfigError, match="warning.adaptive needs a model"):
        from_mapping(SimConfig, {"warning": {"model": "mazda", "adaptive": {"enabled": True}}})
    with pytest.raises(ConfigError, match=r"warning.adaptive.latency must be in \[0, 60\]"):
        AdaptiveConfig(latency=-1.0)
    with pytest.raises(ConfigError, match="warning.adaptive.reaction_time"):
        replace(AdaptiveConfig(), reaction_time=float("nan"))
    logic = WarningLogic(WarningConfig(adaptive=ADAPTIVE), 2, DT)
    with pytest.raises(InputError, match=r"attentive must be a boolean array of shape \(2,\)"):
        logic.step([10.0, 10.0], 20.0, -1.0, attentive=[1, 0])


def test_a_braking_driver_counts_as_attentive_with_or_without_the_camera():
    accel = np.array([-3.0, -1.0, -0.99, 0.5])
    assert NONE.attentive(None, accel) is None
    assert replace(NONE, enabled=True).attentive(None, accel) is None  # no camera in the run
    braking = AdaptiveConfig(braking=1.0)
    assert braking.active and not NONE.active
    assert braking.attentive(None, accel).tolist() == [True, True, False, False]
    looking = np.array([False, False, True, False])
    both = replace(braking, enabled=True)
    assert both.attentive(looking, accel).tolist() == [True, True, True, False]
    assert replace(NONE, enabled=True).attentive(looking, accel).tolist() == looking.tolist()


def test_a_braking_driver_is_warned_with_the_attentive_timing_but_still_warned():
    """A lead braking at 4 m/s² from 30 m/s at 20 m, the ego braking at 2 m/s² from the start:
    with ``braking`` the imminent alert comes later than without, but it comes (an attentive
    reaction is not enough there)."""
    first = {}
    for braking in (0.0, 1.0):
        cfg = WarningConfig(adaptive=AdaptiveConfig(braking=braking))
        logic = WarningLogic(cfg, 1, DT)
        gap, v_ego, v_lead, a_ego = 20.0, 30.0, 30.0, -2.0
        for k in range(60):
            attentive = cfg.adaptive.attentive(None, np.array([a_ego]))
            level = logic.step([gap], v_ego, v_lead - v_ego, -4.0, attentive=attentive)
            if level[0] == 2:
                first[braking] = k
                break
            gap += (v_lead - v_ego) * DT
            v_lead, v_ego = max(v_lead - 4.0 * DT, 0.0), max(v_ego + a_ego * DT, 0.0)
    assert set(first) == {0.0, 1.0} and first[1.0] > first[0.0]


def test_the_braking_signal_leaves_a_model_without_a_reaction_time_as_it_is():
    cfg = WarningConfig(model="ttc", adaptive=AdaptiveConfig(braking=1.0))
    braked, plain = WarningLogic(cfg, 2, DT), WarningLogic(replace(cfg, adaptive=NONE), 2, DT)
    for gap in (40.0, 25.0, 12.0, 6.0):
        got = braked.step([gap] * 2, 20.0, -8.0, attentive=np.array([True, False]))
        np.testing.assert_array_equal(got, plain.step([gap] * 2, 20.0, -8.0))
    assert braked.level.max() > 0


def test_the_attentive_timing_never_warns_earlier_than_the_model():
    """With a model reaction time shorter than the attentive one, an attentive driver keeps
    the model's timing."""
    quick = RequiredDecelerationParams(reaction_time=0.5)
    cfg = WarningConfig(params=quick, adaptive=AdaptiveConfig(braking=1.0))
    logic, plain = WarningLogic(cfg, 1, DT), WarningLogic(replace(cfg, adaptive=NONE), 1, DT)
    for gap in np.linspace(40.0, 5.0, 30):
        got = logic.step([gap], 20.0, -8.0, attentive=np.array([True]))
        np.testing.assert_array_equal(got, plain.step([gap], 20.0, -8.0))


def test_bad_braking_settings_are_one_line_errors():
    with pytest.raises(ConfigError, match=r"warning.adaptive.braking must be in \[0, 20\]"):
        AdaptiveConfig(braking=-1.0)


def test_watch_meets_new_drivers_whose_eyes_are_still_their_predecessors():
    monitor = DriverMonitor(2, 0.0, 1.0)
    monitor.reset([0, 1], -10.0)
    stale = np.array([True, True])  # both "off": slot 1's is the old driver's last state
    got = monitor.watch(3.0, stale, new=np.array([False, True]))
    assert got.tolist() == [False, False]
    assert monitor.watch(4.0, np.array([False, False])).tolist() == [True, True]
