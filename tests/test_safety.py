"""Safety-distance models against hand-computed values, and their invariants."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.warning.safety import SAFETY_MODELS, safety_distances
from acc_fusion.warning.safety_params import (
    BerkeleyParams,
    HondaParams,
    MazdaParams,
    RequiredDecelerationParams,
    RSSParams,
    StoppingDistanceParams,
    TimeHeadwayParams,
    TTCParams,
)
from acc_fusion.warning.ttc import time_to_collision

# The reference state of the hand computations: ego at 20 m/s closing at 5 m/s on a lead
# at 15 m/s that brakes at 2 m/s² (v = 20, v_l = 15, v_c = 5, b = 2).
V, REL, ACC = 20.0, -5.0, -2.0


def distances(name, v=V, rel=REL, acc=ACC, params=None):
    d_c, d_i = safety_distances(name, v, rel, acc, params)
    return float(d_c[0]), float(d_i[0])


def test_time_headway_by_hand():
    # caution: 2.5 + 2.0 * 20 = 42.5; imminent: 2.5 + 1.0 * 20 = 22.5
    assert distances("time_headway") == pytest.approx((42.5, 22.5))


def test_ttc_by_hand():
    # caution: 2.4 s * 5 m/s = 12; imminent: 1.5 * 5 = 7.5; opening (v_rel = +3): 0 and 0
    assert distances("ttc") == pytest.approx((12.0, 7.5))
    assert distances("ttc", rel=3.0) == (0.0, 0.0)
    # d0 = 1: 2.4 * 5 + 1 = 13
    assert distances("ttc", params=TTCParams(d0=1.0))[0] == pytest.approx(13.0)


def test_stopping_distance_by_hand():
    # caution:  20*1.5  + 20²/(2*4.9) - 15²/(2*6.0) + 2.5
    #         = 30      + 40.816327   - 18.75       + 2.5 = 54.566327
    # imminent: 20*1.0  + 20²/(2*6.0) - 18.75       + 2.5
    #         = 20      + 33.333333   - 18.75       + 2.5 = 37.083333
    assert distances("stopping_distance") == pytest.approx((54.566327, 37.083333), abs=1e-6)
    # a fast lead: 5*1.5 + 25/9.8 - 30²/12 < 0 -> clipped at d0 = 2.5 for both levels
    assert distances("stopping_distance", v=5.0, rel=25.0) == (2.5, 2.5)


def test_mazda_by_hand():
    # v_c = 5, v - v_c = 15 (the lead speed):
    # 0.5*(20²/6 - 15²/8) + 20*0.1 + 5*0.6 + 5 = 0.5*(66.666667 - 28.125) + 2 + 3 + 5
    #                                          = 19.270833 + 10 = 29.270833
    # imminent (no driver delay, tau2 = 0): 29.270833 - 3 = 26.270833
    assert distances("mazda") == pytest.approx((29.270833, 26.270833), abs=1e-6)


def test_honda_by_hand_both_cases():
    # warning: 2.2*5 + 6.2 = 17.2
    # braking, lead still moving at tau2 (15/7.8 = 1.92 s >= 1.5 s), Fujita's first case:
    # 5*1.5 + 0.5*1.5*7.8 - 0.5*7.8*0.5² = 7.5 + 5.85 - 0.975 = 12.375
    assert distances("honda") == pytest.approx((17.2, 12.375))
    # lead at 5 m/s stops before tau2 (5/7.8 = 0.64 s): second case
    # warning: 2.2*15 + 6.2 = 39.2
    # braking: 20*1.5 - 0.5*7.8*(1.5-0.5)² - 5²/(2*7.8) = 30 - 3.9 - 1.602564 = 24.497436
    assert distances("honda", rel=-15.0) == pytest.approx((39.2, 24.497436), abs=1e-6)


def test_berkeley_by_hand():
    # warning: 0.5*(20² - 15²)/6 + 20*1.2 + 5 = 14.583333 + 24 + 5 = 43.583333
    # braking: 5*1.2 + 0.5*6*1.2² = 6 + 4.32 = 10.32
    assert distances("berkeley") == pytest.approx((43.583333, 10.32), abs=1e-6)


def test_rss_by_hand():
    # rho = 1, a_acc = 3.5, v after rho = 23.5, lead stop = 15²/(2*8) = 14.0625
    # caution:  20 + 0.5*3.5 + 23.5²/(2*4) - 14.0625 = 20 + 1.75 + 69.03125  - 14.0625 = 76.71875
    # imminent: 20 + 1.75    + 23.5²/(2*8) - 14.0625 = 20 + 1.75 + 34.515625 - 14.0625 = 42.203125
    assert distances("rss") == pytest.approx((76.71875, 42.203125))
    # a much faster lead: the bracket is negative -> 0
    assert distances("rss", v=0.0, rel=30.0) == (0.0, 0.0)


def test_required_deceleration_by_hand():
    # Lead braking at b = 2 from 15 m/s; ego reacts after 1.25 s (25 m), then brakes at a.
    # caution, a = 3.4: equal speeds at t* = (15 - 20 - 3.4*1.25)/(2 - 3.4) = 6.607143 s
    #   ego:  25 + 20*5.357143 - 1.7*5.357143² = 25 + 107.142857 - 48.788265 = 83.354592
    #   lead: 15*6.607143 - 6.607143²           = 99.107143 - 43.654337      = 55.452806
    #   closest approach 27.901786 (> 83.823529 - 56.25 = 27.573529 at the stops) + 2.5
    # imminent, a = 5: t* = (15 - 20 - 6.25)/(2 - 5) = 3.75 s, both at 7.5 m/s
    #   ego:  25 + 20*2.5 - 2.5*2.5² = 59.375; lead: 15*3.75 - 3.75² = 42.1875
    #   closest approach 17.1875 + 2.5 = 19.6875
    assert distances("required_deceleration") == pytest.approx((30.401786, 19.6875), abs=1e-6)


def test_required_deceleration_special_cases():
    p = RequiredDecelerationParams()
    # stopped lead: d = d0 + v t_r + v²/(2a) = 2.5 + 25 + 400/6.8 = 86.323529 (caution)
    #                                        = 2.5 + 25 + 400/10  = 67.5 (imminent)
    stopped = distances("required_deceleration", rel=-20.0, acc=0.0)
    assert stopped == pytest.approx((86.323529, 67.5), abs=1e-6)
    # steady following or an opening range, no braking: the gap never shrinks, no
    # deceleration is required -> 0, whatever the gap (not d0)
    assert distances("required_deceleration", rel=0.0, acc=0.0) == (0.0, 0.0)
    assert distances("required_deceleration", rel=3.0, acc=0.0) == (0.0, 0.0)
    # closing at 0.1 m/s: 0.1*1.25 + 0.1²/(2a) more than d0
    slow = distances("required_deceleration", rel=-0.1, acc=0.0)
    assert slow == pytest.approx((p.d0 + 0.125 + 0.01 / 6.8, p.d0 + 0.125 + 0.01 / 10))
    # an opening range but a braking lead: the gap shrinks later -> d0 and more
    assert distances("required_deceleration", rel=3.0, acc=-4.0)[1] > p.d0
    # lead at constant 5 m/s: closing until the ego is down to 5 m/s:
    # (20-5)*1.25 + 15²/(2*5) = 18.75 + 22.5 = 41.25 (+ 2.5 = 43.75, imminent)
    assert distances("required_deceleration", rel=-15.0, acc=0.0)[1] == pytest.approx(43.75)
    # a lead that accelerates is treated as one at constant speed (b = max(-a_lead, 0))
    accel = distances("required_deceleration", rel=-15.0, acc=1.5)
    assert accel == distances("required_deceleration", rel=-15.0, acc=0.0)


def test_models_match_their_defaults_and_params_are_honoured():
    for model, cls in SAFETY_MODELS.values():
        default = model(V, REL, ACC)
        explicit = model(V, REL, ACC, cls())
        assert np.array_equal(default[0], explicit[0]) and np.array_equal(default[1], explicit[1])
    slow = distances("mazda", params=MazdaParams(tau2=1.0))[0]
    assert slow == pytest.approx(29.270833 + 5 * 0.4, abs=1e-6)


@pytest.mark.parametrize("name", sorted(SAFETY_MODELS))
def test_more_closing_speed_never_shrinks_the_distances(name):
    v = np.full(26, 25.0)
    rel = -np.arange(26.0)  # closing from 0 to 25 m/s (the lead slows from 25 to 0 m/s)
    d_c, d_i = safety_distances(name, v, rel, -1.0)
    assert np.all(np.diff(d_c) >= -1e-12) and np.all(np.diff(d_i) >= -1e-12)
    if name != "time_headway":  # the only model blind to the lead's speed
        assert d_c[-1] > d_c[0] and d_i[-1] > d_i[0]


@pytest.mark.parametrize("name", sorted(SAFETY_MODELS))
def test_imminent_never_exceeds_caution_and_both_are_nonnegative(name):
    rng = np.random.default_rng(7)
    n = 2000
    v = rng.uniform(0.0, 40.0, n)
    rel = rng.uniform(-40.0, 15.0, n)
    acc = rng.uniform(-9.0, 3.0, n)
    d_c, d_i = safety_distances(name, v, rel, acc)
    assert d_c.shape == d_i.shape == (n,)
    assert np.all(d_i >= 0.0) and np.all(d_i <= d_c)


@pytest.mark.parametrize("name", sorted(SAFETY_MODELS))
def test_vectorised_over_pairs_with_mixed_inputs(name):
    v = np.array([0.0, 10.0, 20.0, 30.0, 25.0])
    rel = np.array([0.0, -10.0, 5.0, -30.0, -3.0])
    acc = np.array([0.0, -4.0, 1.0, 0.0, -8.0])
    d_c, d_i = safety_distances(name, v, rel, acc)
    for i in range(v.size):
        c, m = safety_distances(name, v[i], rel[i], acc[i])
        assert d_c[i] == c[0] and d_i[i] == m[0]
    # scalars broadcast against arrays
    c, m = safety_distances(name, 20.0, rel, 0.0)
    assert c.shape == (5,) and np.array_equal(c, safety_distances(name, np.full(5, 20.0), rel)[0])


@pytest.mark.parametrize(
    "build, match",
    [
        (lambda: TimeHeadwayParams(headway_caution=-1.0), r"time_headway.headway_caution must"),
        (lambda: TimeHeadwayParams(headway_imminent=3.0), r"headway_imminent must be <="),
        (lambda: TTCParams(ttc_caution=float("nan")), r"ttc.ttc_caution must be in"),
        (lambda: StoppingDistanceParams(decel_caution=0.0), r"decel_caution must be in \(0"),
        (lambda: StoppingDistanceParams(decel_imminent=3.0), r"decel_caution must be <="),
        (lambda: MazdaParams(alpha2=-8.0), r"mazda.alpha2 must be in"),
        (lambda: HondaParams(tau1=2.0), r"honda.tau1 must be <= honda.tau2"),
        (lambda: BerkeleyParams(d0=-5.0), r"berkeley.d0 must be in \[0, 100\]"),
        (lambda: RSSParams(brake_min_imminent=2.0), r"rss.brake_min must be <="),
        (lambda: RequiredDecelerationParams(reaction_time="slow"), r"must be a number"),
    ],
)
def test_bad_params_raise_config_error(build, match):
    with pytest.raises(ConfigError, match=match):
        build()


def test_params_of_another_model_are_rejected():
    with pytest.raises(ConfigError, match="params of safety model 'honda' must be a HondaParams"):
        safety_distances("honda", V, REL, params=MazdaParams())


def test_unknown_model_lists_the_valid_names():
    with pytest.raises(ConfigError) as err:
        safety_distances("volvo", V, REL)
    msg = str(err.value)
    assert "'volvo'" in msg
    for name in SAFETY_MODELS:
        assert repr(name) in msg


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"v_ego": [20.0, np.nan]}, r"v_ego must be finite"),
        ({"v_rel": [np.inf, 0.0]}, r"v_rel must be finite"),
        ({"a_lead": np.nan}, r"a_lead must be finite"),
        ({"v_ego": [-1.0, 20.0]}, r"v_ego must be >= 0"),
        ({"v_rel": [0.0, 1.0, 2.0]}, r"one length N"),
        ({"v_ego": np.ones((2, 2))}, r"must be 1-D"),
    ],
)
@pytest.mark.parametrize("name", ["ttc", "rss", "required_deceleration"])
def test_bad_inputs_raise_input_error(name, kwargs, match):
    args = {"v_ego": [20.0, 10.0], "v_rel": [-5.0, 0.0], "a_lead": 0.0} | kwargs
    with pytest.raises(InputError, match=match):
        safety_distances(name, **args)


def test_time_to_collision():
    gap = np.array([10.0, 10.0, 10.0, 10.0, 10.0, 0.0, -1.0])
    v_rel = np.array([-5.0, 2.0, 0.0, 0.0, -1.0, 1.0, 1.0])
    # constant range-rate: 10/5 = 2; opening or steady: inf; gap <= 0: 0
    ttc0 = time_to_collision(gap, v_rel)
    assert np.array_equal(ttc0, [2.0, np.inf, np.inf, np.inf, 10.0, 0.0, 0.0])
    a_rel = np.array([0.0, -2.0, -2.0, 2.0, 2.0, 0.0, 0.0])
    ttc = time_to_collision(gap, v_rel, a_rel)
    # 10 + 2t - t² = 0 -> t = 1 + sqrt(11) = 4.316625; 10 - t² = 0 -> sqrt(10) = 3.162278
    # 10 + t² > 0 never closes; 10 - t + t² > 0 (discriminant 1 - 80 < 0) never closes
    assert ttc[0] == pytest.approx(2.0)
    assert ttc[1] == pytest.approx(1.0 + np.sqrt(11.0))
    assert ttc[2] == pytest.approx(np.sqrt(10.0))
    assert np.isinf(ttc[3]) and np.isinf(ttc[4])
    # closing at 4 m/s, relative acceleration +1 m/s²: 10 - 4t + 0.5t² has discriminant
    # 16 - 20 < 0 (the gap stops shrinking at 2 m) -> inf; from 7 m it closes:
    # 7 - 4t + 0.5t² = 0 -> t = 4 - sqrt(2) = 2.585786
    assert np.isinf(time_to_collision(10.0, -4.0, 1.0)[0])
    assert time_to_collision(7.0, -4.0, 1.0)[0] == pytest.approx(4.0 - np.sqrt(2.0))
    with pytest.raises(InputError, match="gap must be finite"):
        time_to_collision([np.nan], [-1.0])
