"""Shared fixtures: linear-Gaussian runs of the pipeline with real sensors."""

from __future__ import annotations

import numpy as np
import pytest

from acc_fusion.fusion.config import FilterConfig, FusionConfig
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.sensors.spec import infrared_spec, radar_spec
from acc_fusion.sensors.suite import SENSOR_NAMES, make_sensors
from acc_fusion.sim.estimation import run_estimation
from acc_fusion.truth.frame import LinearGaussianSource

#: Filter model matched to :func:`linear_gaussian_source`.
LG_FILTER = FilterConfig(dt=0.05, jerk_std=1.0, init_accel_std=0.5)


def linear_gaussian_source(n: int, seed: int) -> LinearGaussianSource:
    """Relative motion drawn from the filters' own model (jerk 1 m/s³, accel0 ~ N(0, 0.5²))."""
    return LinearGaussianSource(
        n, dt=0.05, jerk_std=1.0, x0=(50.0, 0.0, 0.0), x0_std=(3.0, 0.3, 0.5), seed=seed
    )


def linear_sensors(seed: int, **faults):
    """Radar and infrared with range-independent noise (so R is known exactly)."""
    return make_sensors(
        seed, radar_spec(), infrared_spec(range_std=1.0, range_std_quadratic=0.0), **faults
    )


def run_methods(configs: dict[str, FusionConfig], n: int, steps: int, seed: int, **kw):
    """Run several estimators on one linear-Gaussian truth; returns (result, estimates)."""
    ests = {name: make_estimator(c, SENSOR_NAMES, n) for name, c in configs.items()}
    trace: dict[str, list] = {name: [] for name in configs}

    def record(frame, meas, out):
        for name, est in out.items():
            trace[name].append(est)

    res = run_estimation(
        linear_gaussian_source(n, seed), linear_sensors(seed + 1), ests, steps, on_step=record, **kw
    )
    return res, trace


@pytest.fixture(scope="session", autouse=True)
def replay_cache(tmp_path_factory):
    """The replay's binary copies of recordings go to a folder of the session, not the user's
    cache (the scripts the tests run inherit it)."""
    mp = pytest.MonkeyPatch()
    mp.setenv("ACC_FUSION_REPLAY_CACHE", str(tmp_path_factory.mktemp("replay_cache")))
    yield
    mp.undo()


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


def run_episode(env, seed=None, policy=lambda obs: 0):
    """Play one episode of a gymnasium env; returns (observations and rewards flattened,
    infos, terminated, truncated)."""
    obs, info = env.reset(seed=seed)
    rows, infos = [obs], [info]
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        rows.append(np.append(obs, reward))
        infos.append(info)
        done = terminated or truncated
    return np.concatenate(rows, axis=None), infos, terminated, truncated
