"""The simulated driver: documented draws, reaction exact to the step, release, closed loop."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.slots import unit_key
from acc_fusion.core.units import G
from acc_fusion.truth.driver import Driver, DriverConfig
from acc_fusion.truth.frame import TruthFrame
from acc_fusion.truth.scripted import make_scenario

DT = 0.05


def frame(t, n, range_rate=-5.0, ego_speed=20.0, has_leader=True):
    """A truth frame of n identical runs."""
    return TruthFrame(
        t=t,
        ego_speed=np.full(n, ego_speed),
        ego_accel=np.zeros(n),
        gap=np.full(n, 30.0),
        lead_speed=np.full(n, ego_speed + range_rate),
        lead_accel=np.zeros(n),
        leader_id=np.full(n, 1 if has_leader else -1),
    )


def test_same_seed_same_drivers_and_documented_distributions():
    a, b = Driver(20000, seed=3), Driver(20000, seed=3)
    np.testing.assert_array_equal(a.reaction_time, b.reaction_time)
    np.testing.assert_array_equal(a.deceleration, b.deceleration)
    assert not np.array_equal(a.reaction_time, Driver(20000, seed=4).reaction_time)
    c = DriverConfig()
    assert np.median(a.reaction_time) == pytest.approx(c.reaction_time_median, rel=0.02)
    assert np.std(np.log(a.reaction_time)) == pytest.approx(c.reaction_time_log_sd, rel=0.05)
    assert np.mean(a.deceleration) == pytest.approx(0.5 * G, rel=0.01)
    assert a.reaction_time.min() >= 0.5 and a.reaction_time.max() <= 3.0
    assert a.deceleration.min() >= 0.3 * G and a.deceleration.max() <= 0.9 * G


def test_an_assigned_driver_is_his_units_whatever_his_slot():
    from acc_fusion.truth.distraction import DistractionConfig

    config = DriverConfig(distraction=DistractionConfig(rate=600.0))
    a, b = Driver(4, config, seed=3), Driver(4, config, seed=3)
    a.assign(np.array([True, False, True, False]), np.array([11, 0, 22, 0]))
    b.assign(np.array([False, True, False, True]), np.array([0, 22, 0, 11]))
    np.testing.assert_array_equal(a.reaction_time[[0, 2]], b.reaction_time[[3, 1]])
    np.testing.assert_array_equal(a.deceleration[[0, 2]], b.deceleration[[3, 1]])
    assert a.reaction_time[0] != a.reaction_time[2]
    for t in np.arange(0.0, 60.0, DT):  # the same episodes in either slot
        a.step(np.zeros(4), frame(t, 4, range_rate=1.0))
        b.step(np.zeros(4), frame(t, 4, range_rate=1.0))
        np.testing.assert_array_equal(a.eyes_off[[0, 2]], b.eyes_off[[3, 1]])
    assert a._episodes[[0, 2]].min() > 3
    named = Driver(4, config, seed=3)
    named.new_vehicles(np.array([False, False, True, False]), [None, None, "car.7", None])
    c = Driver(4, config, seed=3)
    c.assign(np.array([False, False, True, False]), np.array([0, 0, unit_key("car.7"), 0]))
    assert named.reaction_time[2] == c.reaction_time[2] != a.reaction_time[2]
    seed4 = Driver(4, config, seed=4)
    seed4.assign(np.array([True, False, False, False]), np.array([11, 0, 0, 0]))
    assert seed4.reaction_time[0] != a.reaction_time[0]


def test_reaction_is_exact_to_the_step():
    n = 200
    driver = Driver(n, seed=7)
    onset_step = 10
    first_brake = np.full(n, -1)
    for k in range(120):
        warning = np.full(n, 1 if k >= onset_step else 0)
        brake = driver.step(warning, frame(k * DT, n))
        first_brake[(brake > 0) & (first_brake < 0)] = k
    expected = np.ceil((onset_step * DT + driver.reaction_time) / DT - 1e-9).astype(int)
    np.testing.assert_array_equal(first_brake, expected)


def test_brakes_with_his_deceleration_and_ignores_lower_levels():
    n = 3
    driver = Driver(n, DriverConfig(reaction_time_log_sd=0.0, react_to_level=2), seed=1)
    levels = np.array([1, 2, 3])
    for k in range(30):  # 1.5 s > 1.1 s
        brake = driver.step(levels, frame(k * DT, n))
    np.testing.assert_array_equal(brake > 0, [False, True, True])
    np.testing.assert_array_equal(brake[1:], driver.deceleration[1:])


@pytest.mark.parametrize(
    "release, view, warning, released",
    [
        ("not_closing", dict(range_rate=0.5), 1, True),
        ("not_closing", dict(has_leader=False), 1, True),
        ("not_closing", dict(range_rate=-1.0), 0, False),
        ("warning_ended", dict(range_rate=0.5), 1, False),
        ("warning_ended", dict(range_rate=0.5), 0, True),
        ("stopped", dict(range_rate=0.5), 0, False),
        ("stopped", dict(ego_speed=0.0, range_rate=0.0), 1, True),
    ],
)
def test_release_rules(release, view, warning, released):
    driver = Driver(1, DriverConfig(reaction_time_log_sd=0.0, release=release), seed=0)
    for k in range(22):  # warning onset at 0 s
        driver.step(np.ones(1), frame(k * DT, 1))
    assert driver.step(np.ones(1), frame(22 * DT, 1))[0] > 0  # braking from 1.1 s on
    brake = driver.step(np.array([warning]), frame(23 * DT, 1, **view))
    assert (brake[0] == 0) == released


def test_a_new_onset_after_release_starts_a_new_reaction():
    driver = Driver(1, DriverConfig(reaction_time_log_sd=0.0), seed=0)
    brakes = []
    for k in range(120):
        warning = np.array([1 if k < 30 or k >= 60 else 0])
        view = frame(k * DT, 1, range_rate=-5.0 if k < 40 or k >= 60 else 1.0)
        brakes.append(driver.step(warning, view)[0] > 0)
    starts = np.flatnonzero(np.diff(np.array(brakes, int)) == 1) + 1
    np.testing.assert_array_equal(starts, [22, 82])  # onsets at steps 0 and 60, + 1.1 s


def test_closed_loop_warned_drivers_avoid_the_stopped_vehicle():
    n = 50
    src = make_scenario("nhtsa_lvs", n, seed=1)
    driver = Driver(n, seed=2)
    f = src.frame()
    braking_seen = False
    while not src.done:
        ttc = np.where(f.range_rate < 0, f.gap / np.maximum(-f.range_rate, 1e-9), np.inf)
        brake = driver.step((ttc < 5.0).astype(int), f)  # a warning at TTC 5 s
        f = src.advance(brake)
        on = src.active & (brake > 0)
        if on.any():
            braking_seen = True
            np.testing.assert_allclose(f.ego_accel[on], -driver.deceleration[on])
    assert braking_seen and not src.collided.any()


def test_bad_config_and_input_name_the_field():
    with pytest.raises(ConfigError, match=r"driver.reaction_time_median must be in \(0, 10\]"):
        DriverConfig(reaction_time_median=-1.0)
    with pytest.raises(ConfigError, match="driver.release must be one of 'not_closing'"):
        DriverConfig(release="never")
    with pytest.raises(ConfigError, match="driver.deceleration_range"):
        DriverConfig(deceleration_range=(5.0, 2.0))
    with pytest.raises(ConfigError, match="driver.react_to_level must be an integer >= 1"):
        DriverConfig(react_to_level=0)
    with pytest.raises(ConfigError, match="n_runs must be an integer >= 1"):
        Driver(0)
    driver = Driver(2)
    with pytest.raises(InputError, match=r"warning must have shape \(2,\)"):
        driver.step(np.zeros(3), frame(0.0, 2))
    with pytest.raises(InputError, match="frame must hold 2 runs, got 3"):
        driver.step(np.zeros(2), frame(0.0, 3))
