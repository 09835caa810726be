"""Automatic emergency braking (acc_fusion.braking.aeb): the stage machine, the brake
system's dynamics, and the closed loop in which AEB and the driver brake together."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.braking.aeb import AEB, FULL, OFF, PARTIAL, AEBConfig
from acc_fusion.core.errors import ConfigError
from acc_fusion.sim.closed_loop import SimConfig, simulate
from acc_fusion.truth.driver import DriverConfig
from acc_fusion.warning.kinematics import required_deceleration

DT = 0.05


def _approach(config: AEBConfig, v0: float, gap0: float, steps: int, v_lead: float = 0.0):
    """A true-state closed loop of one ego behind a lead at constant speed ``v_lead``,
    braked by AEB alone: the gaps, speeds, stages and decelerations of every step."""
    aeb = AEB(config, 1, DT)
    gap, v = gap0, v0
    rows = []
    for _ in range(steps):
        a = aeb.step([gap], [v], [v_lead - v], [0.0], [True], [True])[0]
        rows.append((gap, v, int(aeb.stage[0]), a, float(aeb.required[0])))
        v_new = max(v - a * DT, 0.0)
        gap += (v_lead - 0.5 * (v + v_new)) * DT
        v = v_new
    return np.array(rows)


def test_a_stopped_lead_is_avoided_by_staged_braking_and_released_at_standstill():
    rows = _approach(AEBConfig(enabled=True), 80 / 3.6, 120.0, 300)
    gap, v, stage, decel, need = rows.T
    assert gap.min() > 0.0  # no contact
    first = int(np.argmax(stage > OFF))
    # engaged only once the required deceleration reached the partial trigger
    assert need[first] >= 4.0 and need[: first - 2].max() < 4.0
    assert stage[first] == PARTIAL
    stopped = np.flatnonzero(v <= 0.1)
    assert stopped.size and (stage[stopped[-1]] == OFF)  # released after the hold
    assert decel.max() <= 9.0 + 1e-9


def test_full_braking_engages_when_the_need_jumps_past_the_full_trigger():
    # a stopped car revealed 30 m ahead at 20 m/s needs 6.7 m/s²: straight to full braking
    rows = _approach(AEBConfig(enabled=True), 20.0, 30.0, 80)
    stage = rows[:, 2]
    assert stage[np.argmax(stage > OFF)] == FULL
    assert rows[:, 0].min() > 0.0


def test_the_brakes_act_after_the_dead_time_and_build_up_at_the_jerk():
    cfg = AEBConfig(enabled=True, delay=0.2, jerk=20.0, confirm=0.0)
    aeb = AEB(cfg, 1, DT)
    out = [aeb.step([10.0], [20.0], [-20.0], [0.0], [True], [True])[0] for _ in range(16)]
    # engaged at once (full: 20²/(2·10) = 20 m/s² needed); the command waits 4 steps
    assert aeb.stage[0] == FULL
    assert out[:4] == [0.0] * 4
    steps = np.diff(out[3:])
    np.testing.assert_allclose(steps[:4], 20.0 * DT)  # 1 m/s² per step
    assert out[-1] == pytest.approx(cfg.full_decel)


def test_one_noisy_step_does_not_engage_and_no_object_never_brakes():
    aeb = AEB(AEBConfig(enabled=True, confirm=0.1), 2, DT)
    # pair 0: one step of an alarming estimate among calm ones; pair 1: nothing selected
    for k in range(20):
        gap = 5.0 if k == 7 else 80.0
        aeb.step([gap, 5.0], [25.0, 25.0], [-20.0 if k == 7 else 0.0, -20.0], [0.0, 0.0],
                 [True, False], [True, True])  # fmt: skip
        assert (aeb.stage == OFF).all()
    assert (aeb.decel == 0.0).all()


def test_outside_the_operating_range_it_does_not_engage():
    aeb = AEB(AEBConfig(enabled=True), 2, DT)
    for _ in range(10):  # 1.5 m/s (below 7 km/h) and 45 m/s (above 145 km/h), both alarming
        aeb.step([0.3, 20.0], [1.5, 45.0], [-1.5, -45.0], [0.0, 0.0], [True, True], [True, True])
    assert (aeb.stage == OFF).all()


def test_an_override_releases_and_a_reset_starts_afresh():
    aeb = AEB(AEBConfig(enabled=True, delay=0.0), 1, DT)
    for _ in range(5):
        aeb.step([15.0], [20.0], [-20.0], [0.0], [True], [True])
    assert aeb.stage[0] == FULL and aeb.decel[0] > 0
    aeb.step([15.0], [20.0], [-20.0], [0.0], [True], [True], override=[True])
    assert aeb.stage[0] == OFF
    aeb.reset(np.array([True]))
    assert aeb.decel[0] == 0.0 and aeb.required[0] == 0.0


def test_the_decision_reads_the_required_deceleration_after_the_latency():
    cfg = AEBConfig(enabled=True)
    aeb = AEB(cfg, 1, DT)
    aeb.step([40.0], [20.0], [-20.0], [0.0], [True], [True])
    # the ego covers its latency at its speed and aims to stop short by the margin
    g = 40.0 - 20.0 * cfg.latency - cfg.stop_margin
    assert aeb.required[0] == pytest.approx(required_deceleration(g, 20.0, 0.0, 0.0)[0])


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        ({"full_trigger": 3.0}, "full_trigger"),
        ({"partial_decel": -1.0}, "partial_decel"),
        ({"full_decel": 4.0}, "full_decel"),
        ({"jerk": 0.0}, "jerk"),
        ({"max_speed": 1.0}, "max_speed"),
        ({"enabled": "yes"}, "enabled"),
    ],
)
def test_impossible_settings_are_one_line_errors(fields, match):
    with pytest.raises(ConfigError, match=match) as err:
        AEBConfig(**fields)
    assert "\n" not in str(err.value)


def test_aeb_method_must_be_a_compared_method():
    with pytest.raises(ConfigError, match="aeb.method"):
        SimConfig(methods=("radar",), aeb=AEBConfig(enabled=True, method="federated"))


@pytest.mark.parametrize("scenario", ["ccrs", "nhtsa_lvd"])
def test_aeb_avoids_the_crashes_of_the_scripted_tests_and_only_when_assistance_is_on(scenario):
    base = SimConfig(scenario=scenario, runs=20, seed=3, methods=("federated",))
    without = simulate(base)
    with_aeb = SimConfig(scenario=scenario, runs=20, seed=3, methods=("federated",),
                         aeb=AEBConfig(enabled=True))  # fmt: skip
    braked = simulate(with_aeb)
    off = simulate(with_aeb, warnings_on=False)
    assert without.collided.sum() >= 15 and off.collided.sum() == without.collided.sum()
    assert braked.collided.sum() == 0
    assert braked.aeb is not None and braked.aeb.crash_relevant >= 15
    assert braked.aeb.nuisance + braked.aeb.sensing_false == 0
    assert without.aeb is None and off.aeb is None


def test_the_stronger_of_the_driver_and_aeb_brakes():
    """The driver reacts to the warning at about 0.2 g; AEB brakes harder when it engages: at
    every step the ego decelerates at the stronger of the two requests."""
    driver = DriverConfig(react_to_level=2, reaction_time_median=0.6, reaction_time_log_sd=0.0,
                          deceleration_mean=2.0, deceleration_sd=0.0,
                          deceleration_range=(1.9, 2.1))  # fmt: skip
    cfg = SimConfig(scenario="ccrs", runs=4, seed=1, methods=("federated",), drive="federated",
                    driver=driver, aeb=AEBConfig(enabled=True, delay=0.0))  # fmt: skip
    seen = []

    def watch(view):
        by_driver = np.where(view.driver.braking, view.driver.deceleration, 0.0)
        seen.append((by_driver, view.aeb.decel.copy(), view.frame.ego_speed.copy()))

    simulate(cfg, on_step=watch)
    by_driver, by_aeb, speed = (np.array(x) for x in zip(*seen, strict=True))
    wanted = np.maximum(by_driver, by_aeb)[:-1]
    moving = speed[1:] > 0.0
    got = (speed[:-1] - speed[1:]) / cfg.dt
    assert (by_driver[:-1][moving] > 0).any() and (
        by_aeb[:-1][moving] > by_driver[:-1][moving]
    ).any()
    np.testing.assert_allclose(got[moving], wanted[moving], atol=1e-6)
