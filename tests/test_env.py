"""The gymnasium environment: API conformance, determinism, bad input (issue 5)."""

from __future__ import annotations

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import acc_fusion  # noqa: E402,F401  (registers the environment)
from acc_fusion.core.errors import ConfigError, InputError  # noqa: E402
from acc_fusion.envs.collision_warning import CollisionWarningEnv  # noqa: E402
from acc_fusion.envs.observation import (  # noqa: E402
    _HIGH,
    _LOW,
    NIS_CLIP,
    NO_TRACK_GAP,
    OBS_FIELDS,
    track_entries,
)


def test_gymnasium_env_checker_passes():
    from gymnasium.utils.env_checker import check_env

    env = gym.make("acc_fusion/CollisionWarning-v0")
    check_env(env.unwrapped, skip_render_check=True)
    assert env.observation_space.shape == (len(OBS_FIELDS),)


def run_episode(env, seed, policy):
    obs, info = env.reset(seed=seed)
    rows = [obs]
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        rows.append(np.append(obs, reward))
        done = terminated or truncated
    return rows


def test_a_fixed_seed_gives_identical_episodes():
    env = CollisionWarningEnv()
    policy = lambda obs: 2 if obs[0] < 35 and obs[7] else 0  # noqa: E731
    a, b = run_episode(env, 7, policy), run_episode(env, 7, policy)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    c = run_episode(env, 8, policy)
    assert len(c) != len(a) or not all(np.array_equal(x, y) for x, y in zip(a, c, strict=False))


def test_warning_the_driver_avoids_collisions_that_silence_causes():
    env = CollisionWarningEnv(scenario="nhtsa_lvs")

    def never(obs):
        return 0

    def warn(obs):
        return 2 if obs[7] and obs[0] < 60 else 0

    crashes = {"never": 0, "warn": 0}
    for seed in range(5):
        for name, policy in (("never", never), ("warn", warn)):
            run_episode(env, seed, policy)
            crashes[name] += int(env._core.source.collided[0])
    assert crashes["never"] == 5 and crashes["warn"] < 5


def test_render_draws_the_situation():
    env = CollisionWarningEnv(render_mode="rgb_array")
    env.reset(seed=3)
    for _ in range(20):
        env.step(1)
    img = env.render()
    assert img.ndim == 3 and img.shape[2] == 3 and img.std() > 0


def test_bad_input_is_a_clear_error():
    env = CollisionWarningEnv()
    with pytest.raises(gym.error.ResetNeeded):
        env.step(0)
    env.reset(seed=0)
    with pytest.raises(gym.error.InvalidAction, match="action must be 0, 1 or 2"):
        env.step(3)
    with pytest.raises(ConfigError, match="source must be one of"):
        CollisionWarningEnv(source="carla")
    with pytest.raises(ConfigError, match="highway options apply to source 'highway'"):
        CollisionWarningEnv(highway={"env": "highway-v0"})
    with pytest.raises(ConfigError, match="scenario must be one of"):
        CollisionWarningEnv(scenario="moon")


def make_vec(n):
    return gym.make_vec(
        "acc_fusion/CollisionWarning-v0", num_envs=n, vectorization_mode="vector_entry_point"
    )


def test_native_vector_env_steps_all_copies_and_autoresets():
    envs = make_vec(16)
    obs, info = envs.reset(seed=0)
    assert obs.shape == (16, len(OBS_FIELDS)) and obs.dtype == np.float32
    assert envs.observation_space.contains(obs)
    rng = np.random.default_rng(0)
    pending = np.zeros(16, dtype=bool)
    ended = 0
    for _ in range(400):
        obs, reward, terminated, truncated, info = envs.step(rng.integers(0, 3, 16))
        assert envs.observation_space.contains(obs)
        # NEXT_STEP autoreset: the step after an episode ends starts a new one.
        assert np.all(reward[pending] == 0) and not np.any(terminated[pending])
        pending = terminated | truncated
        ended += int(pending.sum())
    assert ended > 16


def test_vector_env_is_deterministic_and_checks_actions():
    runs = []
    for _ in range(2):
        envs = make_vec(8)
        obs, _ = envs.reset(seed=3)
        rows = [obs]
        for k in range(120):
            obs, r, *_ = envs.step(np.full(8, k % 3))
            rows.append(np.column_stack([obs, r]))
        runs.append(np.concatenate(rows, axis=None))
    assert np.array_equal(runs[0], runs[1])
    with pytest.raises(gym.error.InvalidAction, match="array of 8 values"):
        envs.step(np.full(8, 5))
    with pytest.raises(ConfigError, match="does not render"):
        from acc_fusion.envs.collision_warning import CollisionWarningVectorEnv

        CollisionWarningVectorEnv(4, render_mode="rgb_array")


def test_track_entries_are_the_clipped_columns_of_the_estimates():
    """The compiled observation entries equal the columns built with NumPy, bit for bit,
    without a track, with negative or NaN variances, non-finite NIS and unbounded ages."""
    rng = np.random.default_rng(7)
    n = 500
    x = rng.normal(0.0, [150.0, 40.0, 10.0], (n, 3))
    p = rng.normal(0.0, 30.0, (n, 3, 3))
    p[rng.random((n, 3, 3)) < 0.05] = np.nan
    valid = rng.random(n) < 0.7
    v_ego = rng.normal(20.0, 30.0, n)
    reporting = rng.random((2, n)) < 0.5
    isolated = rng.random((n, 2)) < 0.2
    nis = rng.exponential(60.0, (n, 2))
    nis[rng.random((n, 2)) < 0.2] = np.nan
    nis[rng.random((n, 2)) < 0.05] = np.inf
    age = rng.exponential(8.0, (2, n))
    age[rng.random((2, n)) < 0.1] = np.inf

    std = np.sqrt(np.clip(np.diagonal(p, axis1=1, axis2=2), 0.0, None))
    columns = [
        np.where(valid[:, None], x, [NO_TRACK_GAP, 0.0, 0.0]),
        np.where(valid[:, None], std, 0.0),
        np.maximum(v_ego, 0.0)[:, None],
        valid[:, None],
    ]
    limited = np.where(np.isfinite(nis), np.minimum(nis, NIS_CLIP), 0.0)
    for s in range(2):
        columns.append(np.column_stack([reporting[s], isolated[:, s], limited[:, s], age[s]]))
    expected = np.clip(np.column_stack(columns), _LOW, _HIGH)
    got = track_entries(x, p, valid, v_ego, list(reporting), isolated, nis, age)
    assert got.shape == (n, len(OBS_FIELDS))
    assert np.array_equal(got, expected, equal_nan=True)
    assert np.isnan(got).any()  # a NaN variance of a track stays NaN, as in NumPy


def test_track_entries_name_an_input_of_the_wrong_shape():
    n = 4
    args = dict(
        x=np.zeros((n, 3)), p=np.zeros((n, 3, 3)), valid=np.ones(n, bool), v_ego=np.zeros(n),
        reporting=np.zeros((2, n), bool), isolated=np.zeros((n, 2), bool), nis=np.zeros((n, 2)),
        age=np.zeros((2, n)),
    )  # fmt: skip
    assert track_entries(**args).shape == (n, len(OBS_FIELDS))
    empty = {k: v[:, :0] if k in ("reporting", "age") else v[:0] for k, v in args.items()}
    assert track_entries(**empty).shape == (0, len(OBS_FIELDS))
    for name, bad in (("v_ego", np.zeros(1)), ("x", np.zeros((n, 2))), ("age", np.zeros((2, 3)))):
        with pytest.raises(InputError, match=rf"track_entries: {name} must have shape"):
            track_entries(**{**args, name: bad})
