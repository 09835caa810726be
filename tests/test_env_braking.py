"""The environment that warns and brakes (acc_fusion/CollisionAvoidance-v0), its reward term by
term, the braking baselines and their evaluation."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import acc_fusion  # noqa: F401  (registers the environments)
from acc_fusion.core.errors import ConfigError
from acc_fusion.envs.braking import BRAKING_OBS_FIELDS, BrakingRewardConfig
from acc_fusion.envs.braking_eval import (
    BRAKING_ENV_ID,
    braking_baselines,
    braking_table,
    evaluate_braking,
)


def test_the_env_passes_gymnasiums_checker_and_has_its_spaces():
    from gymnasium.utils.env_checker import check_env

    env = gym.make(BRAKING_ENV_ID)
    check_env(env.unwrapped)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (len(BRAKING_OBS_FIELDS),) == (17,)
    assert env.action_space == gym.spaces.MultiDiscrete([3, 3])
    with pytest.raises(gym.error.InvalidAction, match="brake stage"):
        env.step(np.array([0, 3]))


def test_without_braking_a_collision_costs_its_weight_plus_the_impact_speed():
    w = BrakingRewardConfig(collision=100.0, impact=10.0)
    env = gym.make(BRAKING_ENV_ID, scenario="ccrs", reward=w).unwrapped
    env.reset(seed=2)
    done, rewards = False, []
    while not done:
        _, r, terminated, truncated, info = env.step(np.array([0, 0]))
        rewards.append(r)
        done = terminated or truncated
    assert info["collided"] and info["impact_speed"] > 5.0
    assert rewards[-1] == pytest.approx(-(100.0 + 10.0 * info["impact_speed"]))
    assert sum(rewards[:-1]) == 0.0  # no warning, no braking: nothing else costs


def test_braking_full_avoids_the_stopped_car_and_braking_on_an_empty_road_is_false():
    env = gym.make(BRAKING_ENV_ID, scenario="ccrs").unwrapped
    obs, _ = env.reset(seed=2)
    done = False
    while not done:
        near = obs[BRAKING_OBS_FIELDS.index("gap")] < 40.0
        obs, r, terminated, truncated, info = env.step(np.array([0, 2 if near else 0]))
        done = terminated or truncated
    assert not info["collided"]
    assert obs[BRAKING_OBS_FIELDS.index("brake_decel")] >= 0.0
    # braking while nothing is near: each step a false activation, costing w_b·dt
    env = gym.make(BRAKING_ENV_ID, scenario="following").unwrapped
    env.reset(seed=0)
    for _ in range(3):
        _, r, _, _, info = env.step(np.array([0, 1]))
        assert info["false_braking"] and not info["crash_relevant"]
        assert r == pytest.approx(-BrakingRewardConfig().false_braking * env.dt)


def test_the_vector_env_takes_one_warning_and_stage_per_copy():
    envs = gym.make_vec(BRAKING_ENV_ID, num_envs=4, vectorization_mode="vector_entry_point")
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (4, 17)
    obs, reward, *_ = envs.step(np.ones((4, 2), dtype=np.int64))
    assert reward.shape == (4,)
    with pytest.raises(gym.error.InvalidAction, match=r"\(4, 2\)"):
        envs.step(np.ones(4, dtype=np.int64))


def test_only_the_scripted_source_and_a_braking_reward():
    with pytest.raises(ConfigError, match="scripted source"):
        gym.make(BRAKING_ENV_ID, source="sumo")
    with pytest.raises(ConfigError, match="BrakingRewardConfig"):
        gym.make(BRAKING_ENV_ID, reward=object())
    with pytest.raises(ConfigError, match="reward.impact"):
        BrakingRewardConfig(impact=-1.0)


def test_aeb_as_configured_avoids_the_collisions_the_rule_alone_leaves():
    evals = {n: evaluate_braking(p, 12, 0) for n, p in braking_baselines().items()}
    assert evals["never"].collisions >= 6
    assert evals["rule+aeb"].collisions < evals["rule"].collisions <= evals["never"].collisions
    assert evals["never"].false_activations == 0 == evals["rule"].false_activations
    table = braking_table(evals, "braking baselines")
    assert table.rows[0]["policy"] == "rule+aeb"  # ranked by collisions
    assert {r["policy"] for r in table.rows} == set(evals)
