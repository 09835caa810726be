"""The 2-D truth's and the detections' containers: shapes, checks, and the 1-D special case."""

import math

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.sensors.detections import GHOST, Detections
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.objects import ObjectFrame, ObjectKind


def _frame(**overrides):
    e, m = 2, 3
    f = {name: np.zeros((e, m)) for name in (
        "x", "y", "elevation", "vx", "vy", "speed", "accel", "heading",
        "length", "width", "height", "rcs", "thermal_contrast")}  # fmt: skip
    f["x"] = np.array([[30.0, 50.0, 80.0], [12.0, 0.0, 0.0]])
    f["y"] = np.array([[0.0, 3.5, -4.0], [0.2, 0.0, 0.0]])
    f["speed"] = np.array([[25.0, 30.0, 0.0], [20.0, 0.0, 0.0]])
    f["vx"] = f["speed"] - np.array([[30.0], [22.0]])
    valid = np.array([[True, True, True], [True, False, False]])
    kind = np.array([[ObjectKind.VEHICLE, ObjectKind.VEHICLE, ObjectKind.GANTRY], [0, 0, 0]])
    f.update(
        t=1.0, ego_speed=np.array([30.0, 22.0]), ego_accel=np.zeros(2),
        ego_yaw_rate=np.zeros(2), road_curvature=np.zeros(2), valid=valid,
        object_id=np.array([[7, 8, 100], [9, -1, -1]]), kind=kind,
        lane=np.array([[0, 1, 99], [0, 0, 0]]), lead=np.array([0, 0]),
    )  # fmt: skip
    f.update(overrides)
    return ObjectFrame(**f)


def test_the_lead_frame_is_the_1d_pair_of_each_ego_and_its_in_path_lead():
    frame = _frame().lead_frame()
    np.testing.assert_array_equal(frame.leader_id, [7, 9])
    np.testing.assert_allclose(frame.gap, [30.0, 12.0])
    np.testing.assert_allclose(frame.range_rate, [-5.0, -2.0])
    np.testing.assert_allclose(frame.lateral_offset, [0.0, 0.2])


def test_an_ego_without_a_lead_has_no_leader_in_the_1d_frame():
    frame = _frame(lead=np.array([-1, 0])).lead_frame()
    np.testing.assert_array_equal(frame.leader_id, [-1, 9])


def test_polar_views_and_the_stationary_kinds():
    f = _frame()
    assert f.range[0, 1] == pytest.approx(math.hypot(50.0, 3.5))
    assert f.azimuth[0, 2] < 0
    np.testing.assert_array_equal(f.stationary[0], [False, False, True])
    assert f.range_rate[0, 0] == pytest.approx(-5.0)


def test_a_lead_in_an_unused_slot_is_one_error():
    with pytest.raises(InputError, match="lead must name a valid object slot"):
        _frame(lead=np.array([0, 2]))


def test_a_nan_position_of_a_used_slot_is_one_error_but_unused_slots_are_free():
    x = np.array([[np.nan, 50.0, 80.0], [12.0, np.nan, np.nan]])
    with pytest.raises(InputError, match="x"):
        _frame(x=x)
    x[0, 0] = 30.0
    assert _frame(x=x).n_egos == 2


def test_from_arrays_is_the_checked_frame_without_the_checks():
    checked = _frame()
    arrays = {name: getattr(checked, name) for name in ObjectFrame.__dataclass_fields__}
    fast = ObjectFrame.from_arrays(arrays.pop("t"), **arrays)
    for name in ObjectFrame.__dataclass_fields__:
        assert getattr(fast, name) is getattr(checked, name)  # taken as they are, no copy
    np.testing.assert_array_equal(fast.head(1).x, checked.x[:1])
    with pytest.raises(InputError, match="ObjectFrame needs exactly the fields"):
        ObjectFrame.from_arrays(1.0, **{k: v for k, v in arrays.items() if k != "lead"})


def _detections(**overrides):
    d = dict(
        t=0.0, sensor="radar", n_egos=3, online=True, ego=np.array([0, 0, 2]),
        range=np.array([10.0, 20.0, 30.0]), azimuth=np.array([0.0, 0.1, -0.1]),
        range_rate=np.zeros(3), range_std=np.full(3, 0.25), azimuth_std=np.full(3, 0.005),
        range_rate_std=np.full(3, 0.12), object_id=np.array([1, -1, 4]),
        origin=np.array([0, GHOST, 0]),
    )  # fmt: skip
    d.update(overrides)
    return Detections(**d)


def test_detection_rows_and_cartesian_positions():
    d = _detections()
    np.testing.assert_array_equal(d.rows(), [0, 2, 2, 3])
    assert d.x[1] == pytest.approx(20.0 * math.cos(0.1))
    assert d.y[2] == pytest.approx(-30.0 * math.sin(0.1))


def test_unsorted_detections_are_one_error():
    with pytest.raises(InputError, match="sorted"):
        _detections(ego=np.array([2, 0, 0]))


def test_conditions_check_their_values_and_name_themselves():
    assert Conditions("night", 80.0, 5.0).label == "night, fog 80 m, rain 5 mm/h"
    assert Conditions().label == "day"
    with pytest.raises(ConfigError, match="conditions.rain_rate"):
        Conditions(rain_rate=-1.0)
    with pytest.raises(ConfigError, match="conditions.light"):
        Conditions(light="dusk")
