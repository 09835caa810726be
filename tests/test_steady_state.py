"""Tests of the steady-state (constant-gain) filter maths and the CN103196450A example."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.motion import MEASUREMENT_MATRIX, ca_process_noise, ca_transition
from acc_fusion.filters.ego import EgoFilterConfig
from acc_fusion.filters.steady_state import (
    continuous_steady_state_gain,
    periodic_steady_state,
    steady_state_gain,
)


def _load_script(name: str):
    """A script of ``scripts/`` imported by path (the tilt example lives there, not in the
    library)."""
    path = Path(__file__).resolve().parents[1] / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


_cn = _load_script("reproduce_cn103196450a")
TiltExampleConfig, TiltExampleRun = _cn.TiltExampleConfig, _cn.TiltExampleRun
simulate_cn103196450a = _cn.simulate_cn103196450a

DT = 0.05
F_CA = ca_transition(DT)
Q_CA = ca_process_noise(DT, 2.0)
R_CA = np.diag([0.5**2, 0.2**2])


@pytest.fixture(scope="module")
def tilt_run() -> TiltExampleRun:
    return simulate_cn103196450a(seed=3)


def _riccati_limit(period: int, cycles: int) -> tuple[list[np.ndarray], KalmanFilter]:
    """Iterate filterpy's full filter (predict every step, update every ``period``-th step);
    return its covariances over the last cycle (index j = j steps after an update) and the
    filter after one more update."""
    kf = KalmanFilter(dim_x=3, dim_z=2)
    kf.F, kf.Q, kf.H, kf.R = F_CA, Q_CA, MEASUREMENT_MATRIX, R_CA
    kf.P = np.eye(3) * 100.0
    for _ in range(cycles):
        for _ in range(period):
            kf.predict()
        kf.update(np.zeros(2))
    cycle = [kf.P.copy()]
    for _ in range(period):
        kf.predict()
        cycle.append(kf.P.copy())
    kf.update(np.zeros(2))
    return cycle, kf


def test_dare_gain_is_the_limit_of_the_riccati_recursion() -> None:
    gain = steady_state_gain(F_CA, Q_CA, MEASUREMENT_MATRIX, R_CA)
    cycle, kf = _riccati_limit(period=1, cycles=3000)
    np.testing.assert_allclose(cycle[1], gain.P_prior, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(kf.K, gain.K, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(kf.P, gain.P_post, rtol=1e-9, atol=1e-12)


def test_periodic_with_period_one_equals_steady_state_gain() -> None:
    gain = steady_state_gain(F_CA, Q_CA, MEASUREMENT_MATRIX, R_CA)
    periodic = periodic_steady_state(F_CA, Q_CA, MEASUREMENT_MATRIX, R_CA, 1)
    np.testing.assert_allclose(periodic.K, gain.K, rtol=1e-12)
    np.testing.assert_allclose(periodic.P_prior, gain.P_prior, rtol=1e-12)
    np.testing.assert_allclose(periodic.P_post, gain.P_post, rtol=1e-12)
    assert periodic.P_between.shape == (0, 3, 3)


@pytest.mark.parametrize("period", [2, 4])
def test_periodic_steady_state_is_the_fixed_point_of_the_m_step_cycle(period: int) -> None:
    ss = periodic_steady_state(F_CA, Q_CA, MEASUREMENT_MATRIX, R_CA, period)
    assert ss.P_between.shape == (period - 1, 3, 3)
    # m predictions from P_post give P_prior; the update with K gives P_post back
    p = ss.P_post
    for j in range(1, period + 1):
        p = F_CA @ p @ F_CA.T + Q_CA
        np.testing.assert_allclose(ss.covariance_after(j), p, rtol=1e-9)
    s = MEASUREMENT_MATRIX @ ss.P_prior @ MEASUREMENT_MATRIX.T + R_CA
    k = ss.P_prior @ MEASUREMENT_MATRIX.T @ np.linalg.inv(s)
    np.testing.assert_allclose(ss.K, k, rtol=1e-9)
    np.testing.assert_allclose(
        (np.eye(3) - k @ MEASUREMENT_MATRIX) @ ss.P_prior, ss.P_post, rtol=1e-9, atol=1e-12
    )
    # and it is where the full filter with an update every m-th step ends up, at every phase
    cycle, _ = _riccati_limit(period=period, cycles=3000 // period)
    for j, p_full in enumerate(cycle):
        np.testing.assert_allclose(ss.covariance_after(j), p_full, rtol=1e-9, atol=1e-12)


def test_continuous_gain_solves_the_care_and_is_the_limit_of_the_discrete_gain() -> None:
    errors = []
    for fs in (500.0, 5000.0):
        cfg = TiltExampleConfig(fs=fs)
        a, qc, c, rc = cfg.continuous_model
        cont = continuous_steady_state_gain(a, qc, c, rc)
        p = cont.P
        residual = a @ p + p @ a.T + qc - p @ c.T @ np.linalg.inv(rc) @ c @ p
        assert np.max(np.abs(residual)) < 1e-9 * np.max(np.abs(qc))
        disc = steady_state_gain(*cfg.discrete_model)
        errors.append(np.max(np.abs(disc.K * fs - cont.K) / np.abs(cont.K)))
    assert errors[0] < 0.02
    assert errors[1] < errors[0] / 3.0  # the gap shrinks like sqrt(T): 10x faster → ~3.2x


def test_constant_gain_matches_full_filter_after_the_transient(tilt_run: TiltExampleRun) -> None:
    """CN103196450A: the constant-gain filter matches the digital KF over a ±20° sweep."""
    run = tilt_run
    settled = run.t >= 10.0
    assert np.max(np.abs(run.true_angle[settled])) > 19.9
    assert np.max(np.abs(run.constant_gain - run.full)[settled]) < 1e-3  # patent: < 0.4°
    # during the transient the full filter (large early gains) is clearly better
    early = run.t < 2.0
    rmse_full = np.sqrt(np.mean((run.full - run.true_angle)[early] ** 2))
    rmse_const = np.sqrt(np.mean((run.constant_gain - run.true_angle)[early] ** 2))
    assert rmse_full < 0.6 * rmse_const
    # and both beat the raw inclinometer once settled
    rmse_incl = np.sqrt(np.mean((run.inclinometer - run.true_angle)[settled] ** 2))
    assert np.sqrt(np.mean((run.full - run.true_angle)[settled] ** 2)) < 0.5 * rmse_incl


def test_analog_filter_reproduces_the_patents_04_degrees(tilt_run: TiltExampleRun) -> None:
    """The patent's 0.4° at ±20° is the inclinometer's small-angle error (its table 1)."""
    run = tilt_run
    settled = run.t >= 10.0
    diff = np.abs(run.analog - run.full)[settled]
    small_angle_error_20 = 20.0 - np.degrees(np.sin(np.radians(20.0)))  # 0.41°, table 1
    assert abs(np.max(diff) - small_angle_error_20) < 0.03
    assert abs(run.true_angle[settled][np.argmax(diff)]) > 18.0


def test_bad_models_raise_one_sentence_errors() -> None:
    h, r = MEASUREMENT_MATRIX, R_CA
    with pytest.raises(InputError, match="F must be a non-empty square matrix"):
        steady_state_gain(np.ones((3, 2)), Q_CA, h, r)
    with pytest.raises(InputError, match="Q must be symmetric"):
        steady_state_gain(F_CA, Q_CA + np.triu(np.ones((3, 3)), 1), h, r)
    with pytest.raises(InputError, match="Q must be positive semi-definite"):
        steady_state_gain(F_CA, -np.eye(3), h, r)
    with pytest.raises(InputError, match="R must be positive definite"):
        steady_state_gain(F_CA, Q_CA, h, np.diag([1.0, 0.0]))
    with pytest.raises(InputError, match=r"H must have shape \(N, 3\)"):
        steady_state_gain(F_CA, Q_CA, np.ones((2, 2)), r)
    with pytest.raises(InputError, match="F must be finite"):
        steady_state_gain(np.full((3, 3), np.nan), Q_CA, h, r)
    # yang2009's constant bias (no process noise on it) has no stabilising steady state
    yang = EgoFilterConfig.yang2009()
    with pytest.raises(ConfigError, match="driven by Q"):
        steady_state_gain(yang.transition, yang.process_noise, [[1.0, 0.0]], [[0.04]])
    # a sensor that sees only the bias cannot observe the angle
    f, q, _, rt = TiltExampleConfig().discrete_model
    with pytest.raises(ConfigError, match="seen through H"):
        steady_state_gain(f, q, [[0.0, 1.0]], rt)
    a, qc, _, rc = TiltExampleConfig().continuous_model
    with pytest.raises(ConfigError, match="seen through C"):
        continuous_steady_state_gain(a, qc, [[0.0, 1.0]], rc)
    for bad in (0, 1.5, True):
        with pytest.raises(ConfigError, match="period_steps must be an integer >= 1"):
            periodic_steady_state(F_CA, Q_CA, h, r, bad)
    with pytest.raises(InputError, match=r"steps must be an integer in \[0, 2\]"):
        periodic_steady_state(F_CA, Q_CA, h, r, 2).covariance_after(3)
    with pytest.raises(ConfigError, match="amplitude_deg must be in"):
        TiltExampleConfig(amplitude_deg=90.0)
