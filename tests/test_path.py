"""Path prediction from the yaw rate and the vehicles ahead (:mod:`acc_fusion.warning.path`)
and the in-path selection on it (``path="fused"``)."""

import math

import numpy as np
import pytest

from acc_fusion.warning import path as fp
from acc_fusion.warning.selection import InPathSelector, SelectionConfig

SPEED = 30.0


class Road:
    """A straight, then a clothoid of ``length`` m into an arc of ``radius`` (left), from arc
    length ``start``; drawn on a 0.5 m grid."""

    def __init__(self, start=200.0, length=100.0, radius=400.0, end=800.0):
        self.s = np.arange(0.0, end, 0.5)
        self.kappa = np.clip((self.s - start) / length, 0.0, 1.0) / radius
        step = np.diff(self.s, prepend=0.0)
        self.theta = np.cumsum(self.kappa * step)
        self.x = np.cumsum(np.cos(self.theta) * step)
        self.y = np.cumsum(np.sin(self.theta) * step)

    def at(self, s, d=0.0):
        """Position and heading at arc length ``s``, ``d`` to the left of the centreline."""
        i = np.searchsorted(self.s, s)
        th = self.theta[i]
        return self.x[i] - d * np.sin(th), self.y[i] + d * np.cos(th), th

    def seen(self, ego_s, objects):
        """Each object ``(s, d)`` in the frame of an ego at ``ego_s`` on the centreline:
        ``x, y`` and its heading relative to the ego's."""
        ex, ey, eth = self.at(ego_s)
        c, sn = np.cos(eth), np.sin(eth)
        out = []
        for s, d in objects:
            ox, oy, oth = self.at(s, d)
            out.append((c * (ox - ex) + sn * (oy - ey), -sn * (ox - ex) + c * (oy - ey), oth - eth))
        return np.array(out).T


def _drive(config, road, objects, t_end=6.0, dt=0.1, gyro_std=0.0, seed=0):
    """The ego drives the road's centreline at ``SPEED`` from arc length 0, the objects
    ``(s0, d)`` ahead of it at the same speed; the slot it selects at each step."""
    rng = np.random.default_rng(seed)
    sel = InPathSelector(config, 1, len(objects), yaw_rate_std=max(gyro_std, 1e-4))
    ids, chosen = np.arange(len(objects))[None, :], []
    for t in np.arange(0.0, t_end, dt):
        ego_s = SPEED * t
        x, y, rel = road.seen(ego_s, [(ego_s + s0, d) for s0, d in objects])
        i = np.searchsorted(road.s, ego_s)
        yaw = SPEED * road.kappa[i] + rng.normal(0.0, gyro_std)
        vx, vy = SPEED * np.cos(rel) - SPEED, SPEED * np.sin(rel)
        pick = sel.step(ids, x[None], y[None], (SPEED + vx)[None], True, SPEED, yaw, 0.0,
                        vy[None], 0.04, 0.04, dt)  # fmt: skip
        chosen.append(int(pick[0]))
    return np.array(chosen), sel


def test_the_vehicles_ahead_bend_the_path_into_a_curve_the_yaw_rate_has_not_reached():
    """Approaching a left curve (a 60 m clothoid into R 400 m, 200 m ahead) at 30 m/s behind
    a lead 110 m ahead, with a car in the right lane 70 m ahead: as the two cars enter the
    curve the right-lane car crosses the straight extension of the ego's path.  The yaw-rate
    path then takes it for the target, and loses the lead; the path bent by the cars'
    headings keeps the lead (it may lose it for a step)."""
    road = Road(start=200.0, length=60.0, radius=400.0)
    objects = [(70.0, -3.5), (110.0, 0.0)]
    by_yaw, _ = _drive(SelectionConfig(path="yaw_rate"), road, objects, t_end=9.0)
    fused, sel = _drive(SelectionConfig(), road, objects, t_end=9.0)
    assert (by_yaw == 0).sum() >= 5 and (by_yaw == -1).sum() >= 5
    assert (fused == 0).sum() == 0 and (fused == 1).mean() > 0.9
    assert sel.curvature_rate[0] > 0.0


@pytest.mark.parametrize("heading", [0.06, 0.15])
def test_a_vehicle_changing_lanes_does_not_bend_the_path_much(heading):
    """On a straight road four cars ahead keep their lanes and one changes lanes: a lane
    change at 0.06 rad (1.8 m/s across at 30 m/s) moves the path by less than 0.3 m where
    the cars are; a swerve at 0.15 rad fails the outlier gate and moves it not at all."""
    road = Road(start=1e6)
    cars = [(30.0, 0.0), (50.0, 3.5), (70.0, 0.0), (90.0, -3.5), (60.0, 0.0)]
    _, sel = _drive(SelectionConfig(), road, cars, t_end=1.0)
    _, kept = _drive(SelectionConfig(outlier_gate=1e6), road, cars, t_end=1.0)
    for s in (sel, kept):  # the fifth car turns to the left from now on
        x, y = np.array([[30.0, 50.0, 70.0, 90.0, 60.0]]), np.array([[0.0, 3.5, 0.0, -3.5, 0.0]])
        vy = np.array([[0.0, 0.0, 0.0, 0.0, SPEED * heading]])
        for _ in range(5):
            s.step(np.arange(5)[None], x, y, SPEED, True, SPEED, 0.0, 0.0, vy, 0.04, 0.04, 0.1)
    assert np.abs(sel.offset[0, [0, 2]]).max() < 0.3
    if heading > 0.1:
        assert abs(sel.curvature[0]) < 0.1 * abs(kept.curvature[0])


def test_the_in_path_probability_is_the_gaussian_mass_in_the_corridor():
    erf = math.erf
    for off, var in ((0.0, 1.0), (1.2, 0.3), (-3.0, 2.0), (1.75, 4.0)):
        s = math.sqrt(var)
        phi = lambda z: 0.5 * (1.0 + erf(z / math.sqrt(2.0)))  # noqa: E731
        want = phi((1.75 - off) / s) - phi((-1.75 - off) / s)
        assert fp.in_path_probability(off, var, 1.75) == pytest.approx(want, rel=1e-12)
    assert fp.in_path_probability(1.7, 0.0, 1.75) == 1.0
    assert fp.in_path_probability(1.8, 0.0, 1.75) == 0.0
    # far outside the corridor: nothing (the erf pair would give at most rounding)
    assert fp.in_path_probability(-12.0, 1.0, 1.75) == 0.0
    assert 0.0 < fp.in_path_probability(-6.0, 0.5, 1.75) < 1e-6


def test_the_path_uncertainty_widens_with_distance_and_the_gyro_narrows_it():
    cfg = SelectionConfig()
    theta, cov = np.zeros(3), cfg.initial_road_cov()
    x, no = np.array([0.0]), np.zeros(1, bool)
    scratch = (np.empty(1), np.empty(1, np.int64))
    args = (x,) * 6 + (no, no, SPEED, 0.0, 0.005**2, 0.0, cfg.path_parameters(), *scratch)
    fp.road_step(theta, cov, 0.1, *args)
    once = cov[1, 1]
    var = [fp.path_offset(theta, cov, d, 0.0, 0.0)[1] for d in (20.0, 50.0, 100.0, 150.0)]
    assert all(b > 4 * a for a, b in zip(var, var[1:], strict=False))
    for _ in range(50):
        fp.road_step(theta, cov, 0.1, *args)
    assert cov[1, 1] < once / 2  # the filtered yaw rate: less noisy than one sample


def test_a_guardrail_beside_a_curve_bends_the_path_whatever_the_order_of_its_posts():
    """Posts on a line parallel to a curve (offset unknown to the filter) give its curvature
    through their neighbours' differences, and the slot order of the posts does not matter."""
    cfg, c0 = SelectionConfig(), 2e-4
    x = np.arange(10.0, 101.0, 5.0)
    y = -4.0 + 0.5 * c0 * x**2  # a guardrail 4 m to the right, in the band
    f, zeros = x.size, np.zeros(x.size)

    def fit(order):
        theta, cov = np.zeros(3), cfg.initial_road_cov()
        for _ in range(20):  # standing still: no yaw-rate update, the trail alone
            fp.road_step(theta, cov, 0.1, x[order], y[order], zeros, zeros, zeros + 0.01, zeros,
                         np.zeros(f, bool), np.ones(f, bool), 0.0, 0.0, 0.0, 0.0,
                         cfg.path_parameters(), np.empty(f), np.empty(f, np.int64))  # fmt: skip
        return theta

    theta = fit(np.arange(f))
    assert theta[1] == pytest.approx(c0, rel=0.05)
    np.testing.assert_allclose(fit(np.random.default_rng(1).permutation(f)), theta, rtol=1e-9)


def test_the_selected_target_is_kept_down_to_the_keep_probability():
    """An object whose in-path probability lies between the keep and enter thresholds stays
    selected when it was, and is not selected afresh."""
    cfg = SelectionConfig(enter_probability=0.6, keep_probability=0.2)
    sel = InPathSelector(cfg, 1, 1, yaw_rate_std=0.005)

    def step(y, oid=7):
        args = (np.array([[oid]]), np.array([[40.0]]), np.array([[y]]), SPEED, True, SPEED)
        return sel.step(*args, 0.0, 0.0, 0.0, 0.04, 0.04, 0.1)[0]

    assert step(0.0) == 0
    assert 0.2 < sel.probability[0, 0] and step(1.8) == 0
    assert 0.2 < sel.probability[0, 0] < 0.6
    assert step(1.8, oid=8) == -1  # another object at the same place: not selected


def test_yaw_rate_noise_on_a_straight_road_selects_the_adjacent_car_less_often():
    """1 000 egos on a straight road with a noisy gyro (0.005 rad/s), a car in the next lane
    100 m ahead and cars ahead in every lane: the fused path, which weighs the gyro by its
    noise and reads the road from the cars, selects the adjacent car far less often."""
    rng = np.random.default_rng(0)
    n = 1000
    x = np.tile([100.0, 60.0, 130.0], (n, 1))
    y = np.tile([3.5, -3.5, 3.4], (n, 1))
    ids = np.tile([0, 1, 2], (n, 1))

    def adjacent(cfg):
        """How many times an ego selects the adjacent car over 30 steps (0.1 s)."""
        sel, count = InPathSelector(cfg, n, 3, yaw_rate_std=0.005), 0
        for _ in range(30):
            yaw, vy = rng.normal(0.0, 0.005, n), rng.normal(0.0, 0.1, (n, 3))
            chosen = sel.step(ids, x, y, SPEED, True, np.full(n, SPEED), yaw, 0.0, vy, 0.04,
                              0.01, 0.1)  # fmt: skip
            count += np.count_nonzero(chosen == 0)
        return count

    yaw_path, fused = adjacent(SelectionConfig(path="yaw_rate")), adjacent(SelectionConfig())
    assert yaw_path > 300 and fused < yaw_path / 10


def test_bad_path_settings_are_one_error():
    from acc_fusion.core.errors import ConfigError

    with pytest.raises(ConfigError, match="selection.keep_probability"):
        SelectionConfig(enter_probability=0.4, keep_probability=0.5)
    with pytest.raises(ConfigError, match="selection.heading_std"):
        SelectionConfig(heading_std=0.0)
    with pytest.raises(ConfigError, match="selection.trail_range"):
        SelectionConfig(trail_range=(5.0,))
