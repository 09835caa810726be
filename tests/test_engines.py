"""The batched engine equals the filterpy reference (issue test 6)."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from conftest import LG_FILTER, linear_gaussian_source, linear_sensors

from acc_fusion.core.motion import (
    MEASUREMENT_MATRIX,
    STATE_DIM,
    ca_process_noise,
    ca_transition,
)
from acc_fusion.core.threads import blocks
from acc_fusion.filters import kalman
from acc_fusion.fusion.config import FusionConfig
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.sensors.faults import Fault
from acc_fusion.sensors.suite import SENSOR_NAMES

N_PAIRS = 100
STEPS = 160

CONFIGS = {
    "radar": {"method": "radar"},
    "centralized": {"method": "centralized"},
    "centralized_stacked": {"method": "centralized_stacked"},
    "federated": {"method": "federated"},
    "federated_trace_period3": {"method": "federated", "beta": "trace", "fusion_period": 3},
    "federated_zero": {"method": "federated", "reset": "zero"},
    "federated_none": {"method": "federated", "reset": "none", "beta": (0.7, 0.3)},
    "plain": {"method": "plain"},
}


def scheduled_frames(seed: int):
    """Truth where pairs get their leader at different times and change leader once."""
    rng = np.random.default_rng(seed)
    start = rng.integers(0, 40, N_PAIRS)
    change = rng.integers(60, 140, N_PAIRS)
    src = linear_gaussian_source(N_PAIRS, seed)
    frame = src.frame()
    for k in range(STEPS):
        leader = np.where(k < start, -1, np.where(k < change, 1, 2))
        yield type(frame)(**{**frame.__dict__, "leader_id": leader})
        frame = src.advance()


@pytest.mark.parametrize("name", list(CONFIGS))
def test_batched_equals_filterpy(name):
    faults = {
        "radar_faults": (
            Fault("dropout", start=2.0, end=2.6),
            Fault("bias", start=4.0, end=6.0, magnitude=4.0),
            Fault("stuck", start=6.2, end=7.4),
        ),
        "infrared_faults": (
            Fault("spikes", start=1.0, end=7.0, magnitude=8.0, probability=0.05),
            Fault("noise_burst", start=2.0, end=4.0, magnitude=10.0),
        ),
    }
    runs, scales = {}, {}
    for engine in ("batched", "filterpy"):
        cfg = FusionConfig(engine=engine, filter=LG_FILTER, **CONFIGS[name])
        est = make_estimator(cfg, SENSOR_NAMES, N_PAIRS)
        sensors = linear_sensors(11, **faults)
        accel = np.random.default_rng(9).normal(0.0, 2.0, (STEPS, N_PAIRS))  # ego input
        runs[engine], scales[engine] = [], []
        for k, f in enumerate(scheduled_frames(5)):
            runs[engine].append(est.step([s.measure(f) for s in sensors], f.leader_id, accel[k]))
            if getattr(est, "fdi", None) is not None:
                scales[engine].append(est.fdi.noise_scale.copy())
    np.testing.assert_array_equal(scales["batched"], scales["filterpy"])
    isolated_any = False
    frozen = [e.isolated[:, 0].sum() for e in runs["batched"][124:148]]  # radar stuck 6.2-7.4 s
    for a, b in zip(runs["batched"], runs["filterpy"], strict=True):
        assert np.array_equal(a.valid, b.valid)
        assert np.array_equal(a.isolated, b.isolated)
        v = a.valid
        np.testing.assert_allclose(a.x[v], b.x[v], rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.p[v], b.p[v], rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.nis, b.nis, rtol=0, atol=1e-9)
        isolated_any |= bool(a.isolated.any())
    assert runs["batched"][-1].valid.sum() > 0.8 * N_PAIRS
    if name == "federated":
        assert isolated_any, "the fault scenario should exercise isolation"
        assert max(frozen) > 0.8 * runs["batched"][130].valid.sum(), "the stuck radar is caught"
        assert np.max(scales["batched"], axis=(0, 1))[1] > 10.0, "the noise burst adapts R"


def test_batched_banks_have_the_models_state_dimension():
    from acc_fusion.core.errors import ConfigError
    from acc_fusion.core.motion import STATE_DIM
    from acc_fusion.filters.engines import Engine

    assert Engine("batched").bank(2, 5, STATE_DIM).x.shape == (2, 5, STATE_DIM)
    with pytest.raises(ConfigError, match="dimension 3, got 2"):
        Engine("batched").bank(1, 5, 2)


@pytest.mark.parametrize("detection_prob", [None, 0.6])
def test_engines_agree_when_the_acceleration_jumps(monkeypatch, detection_prob):
    """At SUMO's 0.5 s step with a jerk far beyond the filters' model, both sensors often fail
    the gate together and the prior takes an acceleration jump (:mod:`acc_fusion.fusion.fdi`):
    the two engines take the same jumps and give the same estimates.  With sensors that miss
    four reports in ten, the jump often spans a different time for each sensor."""
    from acc_fusion.fusion.config import FilterConfig
    from acc_fusion.fusion.federated import FederatedFilter
    from acc_fusion.sensors.spec import infrared_spec, radar_spec
    from acc_fusion.sensors.suite import make_sensors
    from acc_fusion.truth.frame import LinearGaussianSource

    jumps = []
    take = FederatedFilter._take_jump

    def counted(self, pairs, var, g):
        jumps.append(int(pairs.sum()))
        take(self, pairs, var, g)

    monkeypatch.setattr(FederatedFilter, "_take_jump", counted)
    runs = {}
    for engine in ("batched", "filterpy"):
        cfg = FusionConfig(engine=engine, filter=FilterConfig(dt=0.5, jerk_std=1.0))
        est = make_estimator(cfg, SENSOR_NAMES, N_PAIRS)
        sensors = (
            linear_sensors(3)
            if detection_prob is None
            else make_sensors(
                3,
                radar_spec(detection_prob=detection_prob),
                infrared_spec(
                    range_std=1.0, range_std_quadratic=0.0, detection_prob=detection_prob
                ),
            )
        )
        src = LinearGaussianSource(
            N_PAIRS, dt=0.5, jerk_std=8.0, x0=(40.0, 0.0, 0.0), x0_std=(3.0, 1.0, 1.0), seed=4
        )
        frame, runs[engine] = src.frame(), []
        for _ in range(60):
            runs[engine].append(est.step([s.measure(frame) for s in sensors], frame.leader_id))
            frame = src.advance()
    assert sum(jumps) > 20, "the scenario should make the sensors fail the gate together"
    for a, b in zip(runs["batched"], runs["filterpy"], strict=True):
        assert np.array_equal(a.isolated, b.isolated)
        np.testing.assert_allclose(a.x[a.valid], b.x[a.valid], rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.p[a.valid], b.p[a.valid], rtol=0, atol=1e-9)


@pytest.mark.skipif(numba.get_num_threads() < 2, reason="numba has one thread: no parallel run")
def test_the_parallel_kalman_kernels_equal_the_serial_ones_bit_for_bit():
    """From ``PARALLEL_PAIRS`` pairs the batched bank's time and measurement updates and the
    NIS run on numba's threads, in blocks: the filters are independent, so every state,
    covariance and NIS is the serial kernels' exactly (pairs masked out, pairs with one
    measurement row, pairs with none)."""
    rng = np.random.default_rng(3)
    n = kalman.PARALLEL_PAIRS + 37
    assert blocks(n, kalman.PARALLEL_PAIRS) > 1
    f, q, h = ca_transition(0.05), ca_process_noise(0.05, 2.0), MEASUREMENT_MATRIX
    x0 = rng.normal(0.0, 10.0, (n, STATE_DIM))
    a = rng.normal(size=(n, STATE_DIM, STATE_DIM))
    p0 = a @ a.transpose(0, 2, 1) + np.eye(STATE_DIM)
    z = rng.normal(0.0, 10.0, (n, 2))
    r = np.eye(2) * rng.uniform(0.1, 2.0, (n, 1, 1))
    rows = rng.random((n, 2)) < 0.8
    mask, q_scale, u = rng.random(n) < 0.9, rng.uniform(0.5, 2.0, n), rng.normal(size=n)
    b = np.array([0.0, -0.05, 0.0])
    results = []
    for chunks in (blocks(n, kalman.PARALLEL_PAIRS), 0):
        x, p = x0.copy(), p0.copy()
        nis, prior = np.empty(n), np.empty(n)
        if chunks:
            kalman.predict_parallel(x, p, f, q, q_scale, mask, b, u, chunks)
            kalman.innovation_nis_parallel(x, p, z, r, h, rows, prior, chunks)
            kalman.update_parallel(x, p, z, r, h, rows, nis, chunks)
        else:
            kalman.predict(x, p, f, q, q_scale, mask, b, u)
            kalman.innovation_nis(x, p, z, r, h, rows, prior)
            kalman.update(x, p, z, r, h, rows, nis)
        results.append((x, p, nis, prior))
    for par, ser in zip(*results, strict=True):
        np.testing.assert_array_equal(par, ser)
    np.testing.assert_array_equal(results[0][2], results[0][3])  # the prior's NIS is the update's
    assert np.isnan(results[0][2]).sum() == np.sum(~rows.any(axis=1))


@pytest.mark.parametrize("dt", [0.01, 0.04, 0.05, 1 / 15, 0.1, 1.0])
@pytest.mark.parametrize("jerk_std", [0.0, 0.5, 2.0, 7.3])
def test_the_process_noise_is_filterpys_bit_for_bit(dt, jerk_std):
    from filterpy.common import Q_discrete_white_noise

    want = Q_discrete_white_noise(dim=3, dt=dt, var=(jerk_std * dt) ** 2)
    np.testing.assert_array_equal(ca_process_noise(dt, jerk_std), want)
