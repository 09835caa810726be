"""Alert classes judged from truth, on hand-built trajectories, and the kinematics behind them."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.units import G
from acc_fusion.metrics.alert_classes import AlertClassConfig, crash_relevant
from acc_fusion.metrics.events import FCWMetrics
from acc_fusion.warning.kinematics import required_deceleration, time_to_collision_braking_lead
from acc_fusion.warning.logic import WarningConfig, WarningLogic
from acc_fusion.warning.safety import ttc
from acc_fusion.warning.safety_kernels import _closest_approach
from acc_fusion.warning.safety_params import TTCParams

DT = 0.05


def follow(gap0, v0, lead_speed, duration=12.0):
    """A follower at constant ``v0`` behind a lead whose speed profile is ``lead_speed(t)``:
    the true (t, gap, v_ego, v_lead, a_lead) arrays, integrated at DT."""
    t = np.arange(0.0, duration, DT)
    vl = np.array([lead_speed(x) for x in t])
    al = np.gradient(vl, DT)
    lead_x = gap0 + np.concatenate([[0.0], np.cumsum((vl[1:] + vl[:-1]) / 2 * DT)])
    gap = lead_x - v0 * t
    return t, gap, np.full(t.size, v0), vl, al


#: The stopping-distance rule (the default before the calibration): it fires in close following.
STOPPING = WarningConfig(model="stopping_distance")


def classify(t, gap, v, vl, al, system=None, leader=None, warning=None):
    """Run one pair through the oracle (the rule ``warning``, default: the default rule, on
    truth) and the metrics; the system is the oracle itself (perfect sensing) unless given."""
    has = np.ones(t.size, bool) if leader is None else leader
    oracle = WarningLogic(warning or WarningConfig(), 1, DT)
    metrics = FCWMetrics(1, DT, tolerance=1.0, warn_level=2)
    cfg = AlertClassConfig()
    relevant = crash_relevant(cfg, has, np.where(has, gap, 1.0), v, vl, al)
    for k in range(t.size):
        h = has[k : k + 1]
        level = oracle.step(
            np.where(h, gap[k], 0.0), v[k : k + 1], np.where(h, vl[k] - v[k], 0.0),
            np.where(h, al[k], 0.0), valid=h,
        )  # fmt: skip
        own = level if system is None else system[k : k + 1]
        metrics.update(
            t[k], own, level, np.full(1, np.inf), v[k : k + 1], np.ones(1, bool),
            relevant=relevant[k : k + 1],
        )  # fmt: skip
    metrics.finish(t[-1] + DT)
    return metrics.summary(), relevant


def test_steady_following_at_one_second_headway_is_never_crash_relevant():
    t, gap, v, vl, al = follow(30.0, 30.0, lambda x: 30.0)
    s, relevant = classify(t, gap, v, vl, al)
    assert not relevant.any() and s.relevant == 0 and s.warnings == 0  # the default is quiet
    # The stopping-distance rule fires on it in truth: a nuisance alert, not a crash-relevant one.
    s, _ = classify(t, gap, v, vl, al, warning=STOPPING)
    assert s.warnings == 1 and s.nuisance == 1 and s.crash_relevant == s.sensing_false == 0


def test_the_default_raises_neither_level_in_steady_following():
    # 10 to 40 m/s at 0.8, 1.0 and 1.5 s headway, equal speeds, nobody braking.
    v = np.repeat([10.0, 20.0, 30.0, 40.0], 3)
    gap = v * np.tile([0.8, 1.0, 1.5], 4)
    logic = WarningLogic(WarningConfig(), v.size, DT)
    assert (logic.step(gap, v, np.zeros(v.size)) == 0).all()
    stopping = WarningLogic(STOPPING, v.size, DT)  # on at 1 s: its caution distance is 2.14 s
    assert (stopping.step(gap, v, np.zeros(v.size))[v == 30.0] > 0).all()


def test_lead_braking_at_0_6_g_from_two_seconds_headway_is_crash_relevant():
    t, gap, v, vl, al = follow(
        60.0, 30.0, lambda x: 30.0 if x < 1.0 else max(30.0 - 0.6 * G * (x - 1.0), 0.0)
    )
    s, relevant = classify(t, gap, v, vl, al)
    assert not relevant[t < 1.0].any() and relevant[t > 2.0].any()
    assert s.relevant == 1 and s.relevant_detected == 1 and s.relevant_missed == 0
    assert s.crash_relevant == s.warnings == 1 and s.nuisance == s.sensing_false == 0
    assert s.threats_relevant == s.threats == 1


def test_a_ghost_alert_is_sensing_false():
    t, gap, v, vl, al = follow(90.0, 25.0, lambda x: 25.0)
    system = np.zeros(t.size, np.int8)
    system[(t > 4.0) & (t < 5.0)] = 2  # a radar ghost raised the alert for a second
    s, relevant = classify(t, gap, v, vl, al, system=system)
    assert not relevant.any() and s.threats == 0
    assert s.sensing_false == s.warnings == s.false_alarms == 1


def test_a_faster_car_cutting_in_close_ahead_is_nuisance():
    # At t = 3 s a car 3 m/s faster cuts in 8 m ahead of a follower at 30 m/s.
    t, gap, v, vl, al = follow(8.0, 30.0, lambda x: 33.0)
    leader = t >= 3.0
    gap = np.where(leader, gap + 3.0 * 30.0 - 3.0 * 33.0, 0.0)  # 8 m at the cut-in
    s, relevant = classify(t, gap, v, vl, al, leader=leader)
    assert not relevant.any() and s.warnings == 0  # the default sees the gap opening
    s, _ = classify(t, gap, v, vl, al, leader=leader, warning=STOPPING)
    assert s.nuisance == s.warnings == 1 and s.crash_relevant == s.sensing_false == 0


def test_a_late_alert_on_a_crash_relevant_situation_still_counts_and_a_missed_one_is_missed():
    t, gap, v, vl, al = follow(
        20.0, 20.0, lambda x: 20.0 if x < 1.0 else max(20.0 - 6.0 * (x - 1.0), 0.0)
    )
    s, _ = classify(t, gap, v, vl, al, system=np.zeros(t.size, np.int8))
    assert s.relevant == s.relevant_missed == 1 and s.warnings == 0
    assert s.relevant_miss_rate.value == 1.0


@pytest.mark.parametrize("seed", range(3))
def test_required_deceleration_leaves_exactly_the_gap_at_the_closest_approach(seed):
    rng = np.random.default_rng(seed)
    n = 2000
    gap = rng.uniform(0.5, 80.0, n)
    v = rng.uniform(0.0, 40.0, n)
    vl = rng.uniform(0.0, 40.0, n)
    b = np.where(rng.random(n) < 0.3, 0.0, rng.uniform(0.0, 9.0, n))  # lead braking, >= 0
    need = required_deceleration(gap, v, vl, -b)
    checked = 0
    for i in np.flatnonzero(need > 0.05):
        closing = _closest_approach(v[i], vl[i], b[i], 0.0, need[i])
        assert closing == pytest.approx(gap[i], rel=1e-9, abs=1e-9)
        # A tenth of a percent less braking is not enough.
        assert _closest_approach(v[i], vl[i], b[i], 0.0, need[i] * 0.999) > gap[i]
        checked += 1
    assert checked > n // 3
    # Where none is needed, the follower stays behind without braking.
    for i in np.flatnonzero(need == 0.0):
        assert v[i] <= vl[i] + 1e-12 and b[i] == 0.0


def test_time_to_collision_with_a_braking_lead_matches_a_fine_simulation():
    rng = np.random.default_rng(7)
    for _ in range(200):
        gap, v, vl = rng.uniform(1, 60), rng.uniform(0, 35), rng.uniform(0, 35)
        a = -rng.uniform(0, 8) if rng.random() < 0.8 else rng.uniform(0, 2)
        ttc = float(time_to_collision_braking_lead(gap, v, vl, a)[0])
        h = 1e-3
        x_lead, s_lead, x_ego, t = gap, vl, 0.0, 0.0
        while x_lead - x_ego > 0 and t < 100.0:
            t += h
            x_ego += v * h
            new = max(s_lead + a * h, 0.0)
            x_lead += (s_lead + new) / 2 * h
            s_lead = new
        want = t if t < 100.0 else np.inf
        if np.isfinite(want):
            assert ttc == pytest.approx(want, abs=2e-3)
        else:
            assert ttc > 90.0


def test_nhtsa_lvd_ttc_judged_with_the_leads_deceleration():
    # Both at 45 mph, 30 m apart, the lead braking at 0.3 g: constant-speed TTC is infinite at
    # the onset, the braking-lead TTC is finite and shrinking.
    v = 45 * 0.44704
    a = -0.3 * G
    assert float(time_to_collision_braking_lead(30.0, v, v, a)[0]) == pytest.approx(
        np.sqrt(2 * 30.0 / (0.3 * G))
    )


def test_the_ttc_rule_with_a_braking_lead_fires_at_its_ttc():
    # At the distance the rule returns, the braking-lead TTC is the rule's threshold; a gap
    # 1 % shorter is inside it, 1 % longer outside.  (An accelerating lead is taken at constant
    # speed, as the rule uses only the lead's braking.)
    rng = np.random.default_rng(3)
    params = TTCParams(lead_braking=True)
    v, vl = rng.uniform(5, 35, 300), rng.uniform(0, 35, 300)
    a = np.where(rng.random(300) < 0.2, 0.0, -rng.uniform(0, 8, 300))
    d_caution, d_imminent = ttc(v, vl - v, a, params)
    for d, threshold in ((d_caution, params.ttc_caution), (d_imminent, params.ttc_imminent)):
        closing = d > 0.5
        assert closing.sum() > 100
        at, lo, hi = (time_to_collision_braking_lead(f * d, v, vl, a) for f in (1, 0.99, 1.01))
        np.testing.assert_allclose(at[closing], threshold, rtol=1e-9)
        assert (lo[closing] < threshold).all() and (hi[closing] > threshold).all()
    # Without lead braking it is the constant-speed TTC, which a braking lead does not change.
    plain = ttc(v, vl - v, a, TTCParams())[1]
    np.testing.assert_allclose(plain, TTCParams().ttc_imminent * np.maximum(v - vl, 0.0))


def test_thresholds_are_checked():
    with pytest.raises(ConfigError, match="decel_threshold"):
        AlertClassConfig(decel_threshold=-1.0)
    with pytest.raises(ConfigError, match="ttc_threshold"):
        AlertClassConfig(ttc_threshold=float("nan"))


def test_urgency_broadcasts_scalars_and_names_a_bad_input():
    """Scalars broadcast over the pairs; a NaN, or arrays of two lengths, is one error
    naming the input (the finite (N,) arrays take a shortcut past the checks)."""
    need = required_deceleration(np.array([50.0, 20.0]), 20.0, 0.0, 0.0)
    assert np.array_equal(need, [4.0, 10.0])
    with pytest.raises(InputError, match="v_lead must be finite"):
        required_deceleration(np.full(2, 50.0), np.full(2, 20.0), np.array([0.0, np.nan]), 0.0)
    with pytest.raises(InputError, match=r"v_ego must be a number or have shape \(3,\)"):
        time_to_collision_braking_lead(np.ones(3), np.ones(2), np.ones(2), np.ones(2))
