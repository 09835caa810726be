"""In-path target selection: the corridor, the path models and the stationary policies."""

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.warning.selection import InPathSelector, SelectionConfig


def _select(config, x, y, ground, confirmed=None, yaw=0.0, speed=25.0, curvature=0.0, ids=None):
    x, y, ground = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (x, y, ground))
    ids = np.arange(x.shape[1])[None, :] if ids is None else np.atleast_2d(ids)
    confirmed = np.zeros(x.shape, bool) if confirmed is None else np.atleast_2d(confirmed)
    sel = InPathSelector(config, *x.shape)
    return sel.step(ids, x, y, ground, confirmed, np.array([speed]), np.array([yaw]),
                    np.array([curvature]))  # fmt: skip


def test_the_nearest_object_in_the_corridor_is_selected():
    cfg = SelectionConfig(stationary="all")
    # 20 m ahead but 2.5 m aside (out), 40 m ahead in lane, 60 m in lane.
    assert _select(cfg, [20, 40, 60], [2.5, 0.3, 0.0], [20, 20, 20])[0] == 1


def test_nothing_in_path_selects_nothing():
    assert _select(SelectionConfig(), [20, 40], [3.0, -3.0], [20, 20])[0] == -1


def test_a_yaw_rate_path_follows_the_curve():
    # A left curve of radius 400 m: a car in the ego lane 60 m ahead is 4.5 m to the left.
    y = 0.5 * 60.0**2 / 400.0
    straight = SelectionConfig(path="straight")
    curved = SelectionConfig(path="yaw_rate")
    assert _select(straight, [60], [y], [20], yaw=25.0 / 400.0)[0] == -1
    assert _select(curved, [60], [y], [20], yaw=25.0 / 400.0)[0] == 0


def test_a_lane_aware_path_uses_the_road_curvature_not_the_yaw_rate():
    y = 0.5 * 60.0**2 / 400.0
    lane = SelectionConfig(path="lane")
    assert _select(lane, [60], [y], [20], yaw=0.0, curvature=1 / 400.0)[0] == 0


@pytest.mark.parametrize(
    ("policy", "confirmed", "expected"),
    [("all", False, 0), ("ignore", True, -1), ("confirmed", False, -1), ("confirmed", True, 0)],
)
def test_stationary_policies(policy, confirmed, expected):
    cfg = SelectionConfig(stationary=policy)
    assert _select(cfg, [50], [0.0], [0.0], confirmed=[[confirmed]])[0] == expected


@pytest.mark.parametrize(("oncoming", "expected"), [(False, 1), (True, 0)])
def test_an_oncoming_car_in_the_corridor_is_no_rear_end_target(oncoming, expected):
    """A car coming toward the ego at 26 m/s, 120 m ahead in the corridor (the other
    carriageway, swept in by the path), and a car ahead moving the ego's way 150 m ahead: by
    default the selection takes the one a rear-end collision could involve."""
    cfg = SelectionConfig(oncoming=oncoming)
    assert _select(cfg, [120, 150], [1.0, 0.0], [-26.0, 30.0])[0] == expected


def test_an_object_seen_moving_stays_selectable_when_it_stops_until_its_slot_changes_object():
    sel = InPathSelector(SelectionConfig(), 1, 1)
    args = (np.array([[50.0]]), np.zeros((1, 1)))
    ego = (np.array([20.0]), np.zeros(1), np.zeros(1))
    no = np.zeros((1, 1), bool)
    assert sel.step(np.array([[7]]), *args, np.array([[15.0]]), no, *ego)[0] == 0
    assert sel.step(np.array([[7]]), *args, np.array([[0.0]]), no, *ego)[0] == 0
    assert sel.step(np.array([[8]]), *args, np.array([[0.0]]), no, *ego)[0] == -1


def _lateral(config, x, y, vy, vy_var=0.0):
    """The slot selected among moving cars at ``x``, ``y`` with lateral velocities ``vy``."""
    sel = InPathSelector(config, 1, len(x))
    ids, ones = np.arange(len(x))[None, :], np.ones((1, len(x)))
    return sel.step(ids, ones * x, ones * y, ones * 20.0, ones > 0, np.array([25.0]),
                    np.zeros(1), np.zeros(1), vy=ones * vy, vy_var=ones * vy_var)[0]  # fmt: skip


@pytest.mark.parametrize("path", ["straight", "fused"])
def test_a_lateral_horizon_takes_a_cut_in_early_and_lets_a_cut_out_go(path):
    now = SelectionConfig(path=path)
    ahead = SelectionConfig(path=path, lateral_horizon=0.5)
    # a car 2.5 m to the left, 20 m ahead, coming in at 2 m/s: in path at 1.5 m in 0.5 s
    assert _lateral(now, [20.0], [2.5], [-2.0]) == -1
    assert _lateral(ahead, [20.0], [2.5], [-2.0]) == 0
    # the lead 1.2 m to the right, leaving at 2 m/s, hides a car 30 m further on: let go
    assert _lateral(now, [20.0, 50.0], [-1.2, 0.0], [-2.0, 0.0]) == 0
    assert _lateral(ahead, [20.0, 50.0], [-1.2, 0.0], [-2.0, 0.0]) == 1
    # a lane keeper is kept; an uncertain lateral speed widens the prediction
    assert _lateral(ahead, [20.0], [0.2], [0.0], vy_var=0.25) == 0
    assert _lateral(ahead, [20.0], [1.6], [0.0], vy_var=0.0) == 0
    assert _lateral(ahead, [20.0], [1.6], [0.0], vy_var=16.0) == -1


def test_bad_selection_settings_are_one_error():
    with pytest.raises(ConfigError, match="selection.path"):
        SelectionConfig(path="gps")
    with pytest.raises(ConfigError, match="selection.half_width"):
        SelectionConfig(half_width=0.0)
    with pytest.raises(ConfigError, match="selection.lateral_horizon"):
        SelectionConfig(lateral_horizon=-0.5)


def test_inputs_of_the_wrong_shape_are_one_error_and_scalars_broadcast():
    sel = InPathSelector(SelectionConfig(stationary="all"), 1, 2)
    ids, x = np.array([[0, 1]]), np.array([[40.0, 60.0]])
    args = (np.array([25.0]), np.array([0.0]), np.array([0.0]))
    assert sel.step(ids, x, 0.0, 20.0, True, *args)[0] == 0  # one value for every slot
    with pytest.raises(InputError, match=r"y must have shape \(1, 2\), got \(3,\)"):
        sel.step(ids, x, np.zeros(3), 20.0, True, *args)
