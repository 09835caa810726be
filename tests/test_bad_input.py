"""Bad input gives one clear error naming the field and the allowed values (issue test 7)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import linear_gaussian_source, linear_sensors

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.fusion.config import FilterConfig, FusionConfig
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.fusion.fdi import FDIConfig
from acc_fusion.sensors.sensor import Measurement
from acc_fusion.sensors.spec import radar_spec
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.truth.frame import TruthFrame

N = 4


def measurement(z, valid=None, n=N):
    z = np.asarray(z, float)
    r = np.tile(np.eye(2), (n, 1, 1)) * 0.1
    return Measurement(
        0.0, "radar", z, r, np.ones(n, bool) if valid is None else valid, np.zeros(n, bool)
    )


def good():
    return measurement(np.tile([30.0, -1.0], (N, 1)))


@pytest.mark.parametrize("method", ["radar", "centralized", "federated", "plain"])
@pytest.mark.parametrize(
    "bad, match",
    [
        (np.nan, "NaN or inf"),
        (np.inf, "NaN or inf"),
        (-3.0, "negative range"),
    ],
)
def test_bad_measurement_values_are_rejected(method, bad, match):
    est = make_estimator(method, SENSOR_NAMES, N)
    z = np.tile([30.0, -1.0], (N, 1))
    z[2, 0] = bad
    with pytest.raises(InputError, match=match) as err:
        est.step([measurement(z), good()], np.zeros(N, dtype=np.int64))
    assert "measurements[0] (radar)" in str(err.value)


def test_nan_where_a_sensor_did_not_report_is_fine():
    est = make_estimator("federated", SENSOR_NAMES, N)
    z = np.tile([30.0, -1.0], (N, 1))
    z[1] = np.nan
    valid = np.array([True, False, True, True])
    out = est.step([measurement(z, valid), good()], np.zeros(N, dtype=np.int64))
    assert np.all(np.isfinite(out.x[out.valid]))


def test_mismatched_shapes_are_rejected():
    est = make_estimator("federated", SENSOR_NAMES, N)
    target = np.zeros(N, dtype=np.int64)
    with pytest.raises(InputError, match="expected 2 measurements"):
        est.step([good()], target)
    with pytest.raises(InputError, match=r"z \(N, 2\)"):
        est.step([measurement(np.zeros((N + 1, 2)), n=N + 1), good()], target)
    with pytest.raises(InputError, match="target_id must be an integer array of shape"):
        est.step([good(), good()], np.zeros(N + 2, dtype=np.int64))
    with pytest.raises(InputError, match="target_id"):
        est.step([good(), good()], np.zeros(N))


@pytest.mark.parametrize(
    "build, match",
    [
        (
            lambda: FusionConfig(reset="sometimes"),
            r"fusion.reset must be one of 'fusion', 'zero', 'none'",
        ),
        (lambda: FusionConfig(beta=(0.3, 0.3)), "fusion.beta values must sum to 1"),
        (lambda: FusionConfig(beta=(-0.5, 1.5)), r"fusion.beta\[i\] must be in"),
        (lambda: FusionConfig(beta="random"), "fusion.beta must be one of 'equal', 'trace'"),
        (lambda: FusionConfig(engine="gpu"), "fusion.engine must be one of 'batched', 'filterpy'"),
        (lambda: FusionConfig(fusion_period=0), "fusion.fusion_period must be a whole number >= 1"),
        (lambda: FusionConfig(local="fast"), "fusion.local must be one of 'full', 'steady'"),
        (lambda: FilterConfig(jerk_std=-1.0), r"filter.jerk_std must be in \[0"),
        (lambda: FilterConfig(dt=0.0), r"filter.dt must be in \(0"),
        (lambda: FDIConfig(window=0), "fdi.window must be a whole number"),
        (lambda: FDIConfig(alpha=1.5), r"fdi.alpha must be in \(0, 1\)"),
        (lambda: radar_spec(range_std=-0.1), "radar.range_std"),
        (
            lambda: make_estimator("fusion", SENSOR_NAMES, N),
            "fusion.method must be one of 'radar', 'infrared', 'centralized'",
        ),
        (
            lambda: make_estimator(FusionConfig(beta=(0.2, 0.3, 0.5)), SENSOR_NAMES, N),
            "3 values but there are 2 sensors",
        ),
        (
            lambda: make_estimator(
                FusionConfig(method="federated", local="steady"), SENSOR_NAMES, N
            ),
            "single-sensor",
        ),
        (
            lambda: from_mapping(FusionConfig, {"rest": "fusion"}),
            "unknown key 'rest'.*allowed keys: method",
        ),
        (lambda: from_mapping(FusionConfig, {"fdi": {"window": -2}}), "fdi.window"),
    ],
)
def test_invalid_config_names_the_field_and_the_allowed_values(build, match):
    with pytest.raises(ConfigError, match=match):
        build()


def test_truth_frame_rejects_nan_for_pairs_with_a_leader():
    kw = dict(
        ego_speed=np.ones(2), ego_accel=np.zeros(2), lead_speed=np.ones(2), lead_accel=np.zeros(2)
    )
    TruthFrame(
        t=0.0, gap=np.array([10.0, np.nan]), leader_id=np.array([1, -1]), **kw
    )  # no leader: fine
    with pytest.raises(InputError, match="gap must be finite"):
        TruthFrame(t=0.0, gap=np.array([10.0, np.nan]), leader_id=np.array([1, 2]), **kw)


def test_truth_frame_from_arrays_is_the_checked_frame_without_the_checks():
    n = 3
    arrays = dict(
        ego_speed=np.array([20.0, 0.0, 5.0]),
        ego_accel=np.zeros(n),
        gap=np.array([30.0, np.nan, 4.0]),
        lead_speed=np.array([18.0, np.nan, 5.5]),
        lead_accel=np.array([-1.0, np.nan, 0.0]),
        leader_id=np.array([7, -1, 9]),
    )
    checked = TruthFrame(t=1.5, **arrays)
    fast = TruthFrame.from_arrays(1.5, **arrays)
    for name in ("t", "ego_speed", "gap", "leader_id", "lateral_offset", "range_rate"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(checked, name))
    assert fast.gap is arrays["gap"]  # taken as they are, no copy
    lat = np.array([0.5, 0.0, -0.2])
    assert TruthFrame.from_arrays(1.5, **arrays, lateral_offset=lat).lateral_offset is lat


def test_estimates_stay_finite_through_dropouts_and_track_loss():
    from acc_fusion.sensors.faults import Fault

    n = 50
    src = linear_gaussian_source(n, 0)
    sensors = linear_sensors(1, radar_faults=(Fault("dropout", start=1.0, end=3.0),))
    ests = [
        make_estimator(m, SENSOR_NAMES, n)
        for m in ("radar", "infrared", "centralized", "federated", "plain")
    ]
    frame = src.frame()
    for _ in range(100):
        meas = [s.measure(frame) for s in sensors]
        for e in ests:
            out = e.step(meas, frame.leader_id)
            assert np.all(np.isfinite(out.x[out.valid])) and np.all(np.isfinite(out.p[out.valid]))
        frame = src.advance()
