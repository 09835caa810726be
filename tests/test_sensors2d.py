"""The 2-D radar and thermal camera: noise, detection probability, weather, elevation,
resolution, ghosts, clutter, config and reproducibility.

The statistical tests draw thousands of independent detections in one frame (one target per
ego, thousands of egos) with fixed seeds; each tolerance is about four standard errors of the
estimate it checks, so a correct model fails them with a probability below 1e-4 and a seed
change does not break them.
"""

import math

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.sensors.detections import CLUTTER, GHOST, Detections
from acc_fusion.sensors.infrared2d import Infrared2D, Infrared2DSpec
from acc_fusion.sensors.propagation import (
    fog_attenuation_77ghz,
    koschmieder_extinction,
    lwir_transmittance,
    rain_attenuation_77ghz,
)
from acc_fusion.sensors.radar2d import Radar2D, Radar2DSpec
from acc_fusion.sensors.scan import Returns, emit
from acc_fusion.sensors.suite2d import sensors_2d
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.objects import ObjectFrame, ObjectKind

EGOS = 4000
CLEAR = Conditions()


def _frame(x, y=0.0, *, t=0.0, ego_speed=25.0, egos=EGOS, **fields):
    """A frame of ``egos`` egos each with the same objects: ``x``, ``y`` and the other fields
    given per object (scalars or ``(M,)``); defaults are a car closing at 5 m/s."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    m = x.size
    values = dict(
        x=x, y=y, elevation=0.0, vx=-5.0, vy=0.0, speed=ego_speed - 5.0, accel=0.0,
        heading=0.0, length=4.5, width=1.8, height=1.5, rcs=10.0, thermal_contrast=8.0,
        kind=ObjectKind.VEHICLE, lane=0,
    )  # fmt: skip
    values.update(fields)
    grid = {k: np.broadcast_to(np.asarray(v), (egos, m)).copy() for k, v in values.items()}
    grid["kind"] = grid["kind"].astype(np.int8)
    grid["lane"] = grid["lane"].astype(np.int64)
    return ObjectFrame(
        t=t, ego_speed=np.full(egos, float(ego_speed)), ego_accel=np.zeros(egos),
        ego_yaw_rate=np.zeros(egos), road_curvature=np.zeros(egos),
        valid=np.ones((egos, m), dtype=bool),
        object_id=np.arange(egos * m, dtype=np.int64).reshape(egos, m), lead=np.full(egos, -1),
        **grid,
    )  # fmt: skip


def _radar(seed=1, **overrides):
    return Radar2D(Radar2DSpec(**{"clutter_rate": 0.0, **overrides}), seed)


def _camera(seed=1, **overrides):
    return Infrared2D(Infrared2DSpec(**{"false_rate": 0.0, **overrides}), seed)


def _hit_rate(sensor, frame, conditions=CLEAR, origin=ObjectKind.VEHICLE):
    """Fraction of egos with a detection of ``origin``."""
    d = sensor.detect(frame, conditions)
    return np.unique(d.ego[d.origin == origin]).size / frame.n_egos


def _within(p_hat, p, n=EGOS, sigmas=4.0):
    """``p_hat`` within ``sigmas`` binomial standard errors of ``p`` (at least 0.005)."""
    return abs(p_hat - p) <= sigmas * max(math.sqrt(p * (1 - p) / n), 0.005)


# --- noise -------------------------------------------------------------------------------


def test_radar_noise_matches_the_spec_and_what_it_declares():
    radar = _radar()
    d = radar.detect(_frame(60.0, 3.0, vy=0.5), CLEAR)
    car = d.origin == ObjectKind.VEHICLE
    assert car.sum() > 0.95 * EGOS  # P_d(60 m) = 0.999
    r, az = math.hypot(60.0, 3.0), math.atan2(3.0, 60.0)
    rr = (60.0 * -5.0 + 3.0 * 0.5) / r
    spec = radar.spec
    # std of n normal draws: relative standard error 1/sqrt(2n) = 1.1 %; 5 % is 4.4 of them
    for measured, true, std in (
        (d.range, r, spec.range_std),
        (d.azimuth, az, math.radians(spec.azimuth_std_deg)),
        (d.range_rate, rr, spec.range_rate_std),
    ):
        err = measured[car] - true
        assert abs(err.mean()) < 4 * std / math.sqrt(car.sum())
        assert err.std() == pytest.approx(std, rel=0.05)
    np.testing.assert_allclose(d.range_std[car], spec.range_std)
    np.testing.assert_allclose(d.azimuth_std[car], math.radians(spec.azimuth_std_deg))


def test_camera_noise_grows_with_range_as_the_row_and_scale_geometry_says():
    camera = _camera()
    spec = camera.spec
    f, h = spec.focal_px, spec.camera_height
    for x in (20.0, 50.0):
        d = camera.detect(_frame(x, t=x), CLEAR)
        car = d.origin == ObjectKind.VEHICLE
        assert car.sum() > 0.9 * EGOS
        # the 1-D infrared_spec's range noise: 0.3 m + Z^2 sigma_y / (f H) (Stein et al. 2003)
        range_std = 0.3 + x * x * 1.0 / (f * h)
        rate_std = 0.3 + math.sqrt(2) * 0.1 * x * x / (f * 1.8 * 0.5)
        assert (d.range[car] - x).std() == pytest.approx(range_std, rel=0.05)
        assert (d.range_rate[car] + 5.0).std() == pytest.approx(rate_std, rel=0.05)
        assert (d.azimuth[car]).std() == pytest.approx(1.0 / f, rel=0.05)


# --- detection probability ---------------------------------------------------------------


def test_radar_detection_probability_falls_with_range_and_rises_with_rcs():
    radar = _radar()
    ranges = np.array([50.0, 100.0, 150.0, 200.0, 250.0])
    pd = radar.detection_probability(np.full(5, 10.0), ranges, CLEAR)
    assert np.all(np.diff(pd) < 0)
    assert pd[1] == pytest.approx(0.98, abs=0.005) and pd[-1] == pytest.approx(0.5, abs=0.05)
    weak, strong = radar.detection_probability(np.array([0.0, 20.0]), np.full(2, 200.0), CLEAR)
    assert weak < pd[3] < strong
    # Swerling 1: P_d = P_fa ** (1 / (1 + SNR)), SNR 29 dB - 40 log10(2) at 200 m
    snr = 10 ** ((29.0 - 40 * math.log10(2.0)) / 10)
    assert pd[3] == pytest.approx(1e-6 ** (1 / (1 + snr)))
    for k, (r, rcs) in enumerate(((200.0, 10.0), (200.0, 0.0), (150.0, 10.0))):
        p = radar.detection_probability(np.array([rcs]), np.array([r]), CLEAR)[0]
        assert _within(_hit_rate(radar, _frame(r, rcs=rcs, t=k)), p)


def test_camera_detection_probability_falls_with_range_and_rises_with_size_and_contrast():
    camera = _camera()
    pd = camera.detection_probability(np.array([20.0, 60.0, 100.0, 140.0]), 1.8, 1.5, 8.0, CLEAR)
    assert np.all(np.diff(pd) < 0) and pd[0] == pytest.approx(0.95)
    big = camera.detection_probability(np.array([140.0]), 2.5, 3.5, 8.0, CLEAR)[0]
    faint = camera.detection_probability(np.array([20.0]), 1.8, 1.5, 0.25, CLEAR)[0]
    assert big > pd[3] and faint < 0.6
    assert _within(_hit_rate(camera, _frame(95.0)), camera.detection_probability(
        np.array([95.0]), 1.8, 1.5, 8.0, CLEAR)[0])  # fmt: skip


# --- weather and light -------------------------------------------------------------------


def test_rain_cuts_the_radar_range_by_the_itu_attenuation():
    gamma = 1.132 * 25.0**0.7177  # ITU-R P.838-3 at 77 GHz: 11 dB/km at 25 mm/h
    assert rain_attenuation_77ghz(25.0) == pytest.approx(gamma, rel=1e-3)
    # the range where the SNR is what a dry 250 m gives: 40 log10(250/r) = 2 gamma r / 1000
    lo, hi = 100.0, 250.0
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if 40 * math.log10(250 / mid) > 2e-3 * gamma * mid else (lo, mid)
    rain = Conditions(rain_rate=25.0)
    radar = _radar()
    dry_250 = radar.detection_probability(np.array([10.0]), np.array([250.0]), CLEAR)[0]
    wet = radar.detection_probability(np.array([10.0]), np.array([lo]), rain)[0]
    assert wet == pytest.approx(dry_250, abs=1e-6) and lo < 200.0
    assert _within(_hit_rate(radar, _frame(lo), rain), dry_250)
    assert _hit_rate(radar, _frame(lo, t=1.0)) > dry_250 + 0.2


def test_fog_shortens_the_camera_range_but_not_the_radar_range():
    fog = Conditions(fog_visibility=50.0)
    camera, radar = _camera(), _radar()

    def camera_pd(r, conditions):
        return camera.detection_probability(np.array([r]), 1.8, 1.5, 8.0, conditions)[0]

    # an 8 K car: the apparent contrast 8 K exp(-0.5 * 3.912 r / 50) / 50 mK falls to the
    # threshold 5 at 89 m, so the camera's range shrinks from beyond 100 m to about 90 m
    assert camera_pd(100.0, fog) < 0.05 < 0.7 < camera_pd(100.0, CLEAR)
    assert camera_pd(60.0, fog) == pytest.approx(camera_pd(60.0, CLEAR), abs=1e-6)
    for k, (r, conditions) in enumerate(((95.0, CLEAR), (95.0, fog), (100.0, fog))):
        assert _within(_hit_rate(camera, _frame(r, t=k), conditions), camera_pd(r, conditions))
    p_clear = radar.detection_probability(np.array([10.0]), np.array([200.0]), CLEAR)[0]
    p_fog = radar.detection_probability(np.array([10.0]), np.array([200.0]), fog)[0]
    assert p_fog == pytest.approx(p_clear, abs=0.03)  # 1 dB/km: a 0.4 dB two-way loss
    assert fog_attenuation_77ghz(50.0) == pytest.approx(1.0, abs=0.1)
    assert _within(_hit_rate(radar, _frame(200.0), fog), p_fog)
    # Koschmieder: the 2 % contrast threshold lies at the visibility
    assert math.exp(-koschmieder_extinction(50.0) * 50.0) == pytest.approx(0.02)


def test_night_changes_nothing_for_the_camera():
    frame = _frame([30.0, 70.0, 95.0], [0.0, 3.5, -3.5])
    for weather in ({}, {"fog_visibility": 80.0, "rain_rate": 10.0}):
        day = _camera(seed=5).detect(frame, Conditions(light="day", **weather))
        night = _camera(seed=5).detect(frame, Conditions(light="night", **weather))
        for name in ("ego", "range", "azimuth", "range_rate", "object_id", "origin"):
            np.testing.assert_array_equal(getattr(day, name), getattr(night, name))


def test_rain_dims_a_faint_target_for_the_camera():
    r = np.array([90.0])
    rain = Conditions(rain_rate=50.0)
    assert lwir_transmittance(r, rain, 0.5)[0] < lwir_transmittance(r, CLEAR, 0.5)[0] < 1.0 + 1e-12
    camera = _camera()
    faint = (r, 1.8, 1.5, 0.35)
    assert camera.detection_probability(*faint, rain)[0] < camera.detection_probability(
        *faint, CLEAR)[0] - 0.2  # fmt: skip


# --- elevation: the overhead gantry ------------------------------------------------------


def test_a_gantry_is_a_road_level_radar_target_far_away_and_lost_close_by():
    radar = _radar()
    gantry = dict(elevation=5.5, vx=-25.0, rcs=20.0, kind=ObjectKind.GANTRY, height=1.5)
    far = radar.detect(_frame(200.0, **gantry), CLEAR)
    seen = far.origin == ObjectKind.GANTRY
    assert seen.mean() > 0.9 and seen.sum() > 0.9 * EGOS
    # reported like a stationary object on the road: range ~ x, closing at the ego speed
    assert np.median(far.range[seen]) == pytest.approx(math.hypot(200.0, 5.0), abs=0.05)
    assert np.median(far.range_rate[seen]) == pytest.approx(-25.0, abs=0.05)
    limit = 5.0 / math.tan(math.radians(2.5))  # (5.5 m - 0.5 m) / tan(half elevation beam)
    assert 110.0 < limit < 120.0
    for x, t in ((limit + 3.0, 1.0), (limit - 3.0, 2.0), (40.0, 3.0)):
        d = radar.detect(_frame(x, t=t, **gantry), CLEAR)
        assert (np.any(d.origin == ObjectKind.GANTRY)) == (x > limit)


def test_the_camera_never_reports_a_gantry_as_a_vehicle():
    camera = _camera(misclass_prob=1.0)  # every detected non-vehicle called a vehicle
    gantry = dict(elevation=5.5, kind=ObjectKind.GANTRY, thermal_contrast=8.0)
    for x, t in ((10.0, 0.0), (30.0, 1.0), (60.0, 2.0), (95.0, 3.0)):
        assert camera.detect(_frame(x, t=t, **gantry), CLEAR).count == 0
    # the same object at road level (a sign post) is misreported, so the test is not vacuous
    sign = camera.detect(_frame(30.0, t=4.0, kind=ObjectKind.SIGN), CLEAR)
    assert np.mean(sign.origin == ObjectKind.SIGN) == 1.0 and sign.count > 0.9 * EGOS
    rarely = _camera(misclass_prob=0.02).detect(_frame(30.0, kind=ObjectKind.SIGN), CLEAR)
    assert _within(rarely.count / EGOS, 0.02 * 0.95)


# --- resolution, ghosts, clutter ---------------------------------------------------------


def test_two_cars_closer_than_the_azimuth_resolution_merge_into_one_detection():
    radar = _radar()
    # at 150 m, 3 m apart: 1.15 deg < 1.6 deg, same range and range-rate: one cell
    d = radar.detect(_frame([150.0, 150.0], [1.5, -1.5]), CLEAR)
    assert np.all(np.bincount(d.ego, minlength=EGOS) <= 1)
    assert abs(np.mean(d.azimuth)) < 1e-3  # the power-weighted centroid lies between them
    # 10 m apart (3.8 deg) they are resolved
    d = radar.detect(_frame([150.0, 150.0], [5.0, -5.0], t=1.0), CLEAR)
    assert np.mean(np.bincount(d.ego, minlength=EGOS) == 2) > 0.8
    # so are they 3 m apart when their range-rates differ by more than the Doppler cell
    d = radar.detect(_frame([150.0, 150.0], [1.5, -1.5], t=2.0, vx=np.array([-5.0, -6.0])), CLEAR)
    assert np.mean(np.bincount(d.ego, minlength=EGOS) == 2) > 0.8


def test_a_close_car_casts_a_double_bounce_ghost():
    radar = _radar()
    d = radar.detect(_frame(15.0, vx=-4.0), CLEAR)
    ghost = d.origin == GHOST
    assert ghost.sum() > 0.5 * EGOS
    np.testing.assert_array_equal(d.object_id[ghost], -1)
    assert np.median(d.range[ghost]) == pytest.approx(30.0, abs=0.05)
    assert np.median(d.range_rate[ghost]) == pytest.approx(-8.0, abs=0.02)
    # far targets leave no ghost behind (SNR at 2 r less the bounce loss)
    far = radar.detect(_frame(80.0, t=1.0), CLEAR)
    assert np.mean(far.origin == GHOST) < 0.01


def test_clutter_is_poisson_stationary_and_inside_the_coverage():
    radar = Radar2D(Radar2DSpec(clutter_rate=0.2), seed=3)
    d = radar.detect(_frame(60.0, egos=20000), CLEAR)
    clutter = d.origin == CLUTTER
    n = 20000
    assert abs(clutter.sum() / n - 0.2) < 4 * math.sqrt(0.2 / n)
    np.testing.assert_array_equal(d.object_id[clutter], -1)
    assert np.all(np.abs(d.azimuth[clutter]) < math.radians(15.0) + 5 * 0.002)
    assert d.range[clutter].max() < 251.0 and d.range[clutter].min() > -0.5
    err = d.range_rate[clutter] + 25.0 * np.cos(d.azimuth[clutter])
    assert np.abs(err).max() < 6 * 0.12
    # the clutter has its own stream: the car's detections do not change with it
    quiet = _radar(seed=3).detect(_frame(60.0, egos=20000), CLEAR)
    np.testing.assert_array_equal(quiet.range, d.range[~clutter])


def test_stationary_objects_close_at_the_ego_speed_times_cos_azimuth():
    radar = _radar()
    d = radar.detect(_frame(40.0, 8.0, vx=-25.0, kind=ObjectKind.PARKED), CLEAR)
    az = math.atan2(8.0, 40.0)
    assert np.median(d.range_rate[d.origin == ObjectKind.PARKED]) == pytest.approx(
        -25.0 * math.cos(az), abs=0.02)  # fmt: skip


# --- timing, output, reproducibility, config ---------------------------------------------


def test_sample_rates_and_offline_frames():
    radar, camera = sensors_2d(None, seed=1)
    online = []
    for k in range(6):
        frame = _frame(50.0, t=0.05 * k, egos=3)
        online.append((radar.detect(frame, CLEAR).online, camera.detect(frame, CLEAR).online))
    assert online == [(True, True), (True, False)] * 3
    d = camera.detect(_frame(50.0, t=0.27, egos=3), CLEAR)
    assert not d.online and d.count == 0 and d.n_egos == 3
    with pytest.raises(InputError, match="frame.t must increase"):
        radar.detect(_frame(50.0, t=0.1, egos=3), CLEAR)


def test_the_output_is_a_valid_detections_sorted_by_ego():
    rng = np.random.default_rng(0)
    x, y = rng.uniform(1.0, 260.0, 30), rng.uniform(-10.0, 10.0, 30)
    for sensor in sensors_2d({}, seed=2):
        d = sensor.detect(_frame(x, y, egos=50), Conditions(rain_rate=5.0))
        assert isinstance(d, Detections) and d.online and d.count > 0
        assert np.all(np.diff(d.ego) >= 0)
        rebuilt = Detections(**{k: getattr(d, k) for k in d.__dataclass_fields__})
        assert rebuilt.count == d.count
        assert set(np.unique(d.origin)) <= {*map(int, ObjectKind), GHOST, CLUTTER}


def test_emit_sorts_the_returns_by_ego_keeping_their_order_within_an_ego():
    ego = np.array([2, 0, 2, 1, 0, 2])
    k = np.arange(ego.size, dtype=float)
    returns = Returns(ego, np.stack([10.0 + k, k / 100, -k]), np.arange(ego.size) + 7,
                      np.zeros(ego.size, np.int8))  # fmt: skip
    d = emit(0.5, "radar", 3, returns, returns.z, np.stack([1.0 + k, 0.01 + k, 0.1 + k]))
    order = [1, 4, 3, 0, 2, 5]  # by ego, stable
    np.testing.assert_array_equal(d.ego, ego[order])
    np.testing.assert_array_equal(d.range, 10.0 + k[order])
    np.testing.assert_array_equal(d.range_rate_std, 0.1 + k[order])
    np.testing.assert_array_equal(d.object_id, np.array(order) + 7)
    with pytest.raises(InputError, match=r"egos must lie in \[0, 2\)"):
        emit(0.5, "radar", 2, returns, returns.z, returns.z)
    with pytest.raises(InputError, match=r"must have shape \(3, 6\), got \(3, 6\), \(3, 1\)"):
        emit(0.5, "radar", 3, returns, returns.z, np.ones((3, 1)))
    short = Returns(ego, returns.z, np.arange(3), returns.origin)
    with pytest.raises(InputError, match=r"object_id and origin must have shape \(6,\)"):
        emit(0.5, "radar", 3, short, returns.z, returns.z)


def test_unused_slots_and_empty_frames_give_no_detections():
    radar, camera = sensors_2d({"radar": {"clutter_rate": 0.0}}, seed=3)
    frame = _frame([30.0, 40.0], egos=2)
    valid = np.array([[True, False], [False, False]])
    x = np.where(valid, frame.x, np.nan)  # unused slots may hold NaN
    fields = {k: getattr(frame, k) for k in frame.__dataclass_fields__}
    partly = ObjectFrame(**{**fields, "valid": valid, "x": x})
    for sensor in (radar, camera):
        d = sensor.detect(partly, CLEAR)
        assert set(d.object_id[d.object_id >= 0]) <= {0} and np.all(d.ego == 0)
    empty = ObjectFrame(**{**fields, "t": 1.0, "valid": np.zeros((2, 0), dtype=bool),
                           **{k: np.zeros((2, 0), dtype=getattr(frame, k).dtype) for k in (
                               "x", "y", "elevation", "vx", "vy", "speed", "accel", "heading",
                               "length", "width", "height", "rcs", "thermal_contrast",
                               "object_id", "kind", "lane", "lateral_speed")}})  # fmt: skip
    for sensor in (radar, camera):
        d = sensor.detect(empty, CLEAR)
        assert d.online and d.count == 0 and d.n_egos == 2


def test_the_same_seed_gives_the_same_detections():
    rng = np.random.default_rng(1)
    frames = [_frame(rng.uniform(5.0, 200.0, 10), rng.uniform(-5, 5, 10), t=0.1 * k, egos=40)
              for k in range(3)]  # fmt: skip

    def run(seed):
        suite = sensors_2d({"radar": {"clutter_rate": 1.0}}, seed)
        return [s.detect(f, CLEAR) for f in frames for s in suite]

    a, b, c = run(7), run(np.random.SeedSequence(7)), run(8)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.range, y.range)
        np.testing.assert_array_equal(x.object_id, y.object_id)
    differ = [x.count != z.count or not np.array_equal(x.range, z.range)
              for x, z in zip(a, c, strict=True)]  # fmt: skip
    assert any(differ)


def test_reset_restarts_the_clock_and_with_a_seed_the_noise():
    frame = _frame([20.0, 60.0], [0.0, 2.0], egos=30)
    radar = Radar2D(seed=4)
    first = radar.detect(frame, CLEAR)
    radar.reset()
    fresh = radar.detect(frame, CLEAR)  # the same time again: allowed after reset
    assert fresh.online and not np.array_equal(fresh.range, first.range)
    radar.reset(seed=4)
    again = radar.detect(frame, CLEAR)
    np.testing.assert_array_equal(again.range, first.range)


@pytest.mark.parametrize(
    ("config", "message"),
    [
        ({"radar": {"pfa": 2.0}}, r"radar\.pfa must be in \(0, 1\), got 2\.0"),
        ({"radar": {"bogus": 1}}, r"unknown key radar\.'bogus' in radar; allowed keys: name,"),
        ({"lidar": {}}, r"unknown key 'lidar' in Sensors2DConfig"),
        ({"infrared": {"netd": -0.05}}, r"infrared\.netd must be in \(0, inf\)"),
        ({"infrared": {"misclass_prob": 1.5}}, r"infrared\.misclass_prob must be in \[0, 1\]"),
        ({"radar": {"min_range": 10.0, "max_range": 5.0}}, r"radar\.max_range must be in"),
        ({"radar": {"rate_hz": "fast"}}, r"radar\.rate_hz must be a number, got 'fast'"),
        ({"radar": {"name": ""}}, r"sensor name must be a non-empty string"),
        ([1, 2], r"must be a mapping"),
    ],
)
def test_bad_config_is_one_sentence(config, message):
    with pytest.raises(ConfigError, match=message) as info:
        sensors_2d(config, seed=0)
    assert "\n" not in str(info.value)


def test_bad_inputs_are_input_errors():
    radar = _radar()
    with pytest.raises(InputError, match="needs an ObjectFrame"):
        radar.detect("frame", CLEAR)
    with pytest.raises(InputError, match="needs Conditions"):
        radar.detect(_frame(50.0, egos=2), "fog")
    with pytest.raises(ConfigError, match="spec must be a Radar2DSpec"):
        Radar2D(Infrared2DSpec())
    with pytest.raises(ConfigError, match="seed must be"):
        Infrared2D(seed="seven")


def _scans(faults, sensor_index=0, steps=40, dt=0.05):
    """Detections of a radar (or camera) seeing one car 40 m ahead, with ``faults``."""
    config = {"radar": {"clutter_rate": 0.0}, "infrared": {"false_rate": 0.0}}
    key = ("radar_faults", "infrared_faults")[sensor_index]
    sensor = sensors_2d({**config, key: faults}, seed=11)[sensor_index]
    out = []
    for k in range(steps):
        d = sensor.detect(_frame([40.0], t=k * dt, egos=3), CLEAR)
        if d.online or d.count:
            out.append(d)
    return sensor, out


def test_2d_faults_act_on_whole_frames_and_leave_the_nominal_draws_alone():
    _, healthy = _scans([])
    _, biased = _scans([{"kind": "bias", "start": 0.5, "magnitude": 5.0, "rate_magnitude": 1.0}])
    for h, b in zip(healthy, biased, strict=True):
        shift = 5.0 if h.t >= 0.5 else 0.0
        np.testing.assert_allclose(b.range, h.range + shift)
        np.testing.assert_allclose(b.azimuth, h.azimuth)
    _, burst = _scans([{"kind": "noise_burst", "start": 0.0, "magnitude": 10.0}])
    err = lambda ds: np.concatenate([d.range - 40.0 for d in ds])  # noqa: E731
    assert np.std(err(burst)) == pytest.approx(10.0 * np.std(err(healthy)), rel=1e-9)
    assert np.all(np.concatenate([d.range_std for d in burst]) < 1.0)  # declared unchanged


def test_a_stuck_sensor_repeats_its_last_frame_and_a_dropout_gives_none():
    sensor, stuck = _scans([{"kind": "stuck", "start": 0.5, "end": 1.5}])
    frozen = [d for d in stuck if 0.5 <= d.t < 1.5]
    assert len(frozen) > 2 and all(np.array_equal(d.range, frozen[0].range) for d in frozen)
    assert sensor.faulty(1.0) and not sensor.faulty(1.5)
    _, dropped = _scans([{"kind": "dropout", "start": 0.5, "end": 1.0}], sensor_index=1)
    assert all(not d.online for d in dropped if 0.5 <= d.t < 1.0)
    assert any(d.online and d.count for d in dropped if d.t >= 1.0)
