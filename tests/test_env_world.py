"""The 2-D world's gymnasium environment: API conformance, determinism, the object-list entries
of the observation, bad options."""

from __future__ import annotations

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import acc_fusion  # noqa: E402,F401  (registers the environments)
from acc_fusion.core.errors import ConfigError  # noqa: E402
from acc_fusion.envs.evaluation import evaluate  # noqa: E402
from acc_fusion.envs.observation import OBS_FIELDS, WORLD_OBS_FIELDS  # noqa: E402
from acc_fusion.envs.options import RewardConfig  # noqa: E402
from acc_fusion.envs.policies import SafetyDistancePolicy  # noqa: E402
from acc_fusion.envs.world import CollisionWarningWorldEnv  # noqa: E402
from acc_fusion.sim.closed_loop import SimConfig  # noqa: E402
from acc_fusion.sim.world_config import WorldConfig  # noqa: E402
from acc_fusion.warning.selection import SelectionConfig  # noqa: E402

I = {name: i for i, name in enumerate(WORLD_OBS_FIELDS)}  # noqa: E741
#: A path from the yaw rate alone: it runs straight on into a curve, so the selection takes
#: the objects the scripted curves exist for (the fused path does not).
BY_YAW = SimConfig(world=WorldConfig(selection=SelectionConfig(path="yaw_rate")))


def episode(env, seed, policy=lambda obs: 0, options=None):
    """Observations ``(T, 24)``, rewards ``(T-1,)`` and infos of one episode."""
    obs, info = env.reset(seed=seed, options=options)
    rows, rewards, infos = [obs], [], [info]
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        rows.append(obs)
        rewards.append(reward)
        infos.append(info)
        done = terminated or truncated
    return np.array(rows), np.array(rewards), infos


def test_gymnasium_env_checker_passes():
    from gymnasium.utils.env_checker import check_env

    env = gym.make("acc_fusion/CollisionWarningWorld-v0")
    check_env(env.unwrapped, skip_render_check=True)
    assert env.observation_space.shape == (len(WORLD_OBS_FIELDS),)
    assert WORLD_OBS_FIELDS[: len(OBS_FIELDS)] == OBS_FIELDS


def test_a_fixed_seed_gives_identical_episodes():
    env = CollisionWarningWorldEnv(conditions=[{}, {"light": "night", "fog_visibility": 40.0}])
    a, ra, ia = episode(env, 3)
    b, rb, ib = episode(env, 3)
    assert np.array_equal(a, b) and np.array_equal(ra, rb)
    assert [i["cause"] for i in ia] == [i["cause"] for i in ib]
    draws = {(episode(env, s)[2][0]["scene"], env.reset(seed=s)[1]["conditions"]) for s in range(8)}
    assert len({scene for scene, _ in draws}) > 1 and len({c for _, c in draws}) == 2


def test_a_radar_only_gantry_is_unconfirmed_and_a_parked_car_confirmed():
    everything = SimConfig(world=WorldConfig(selection=SelectionConfig(stationary="all")))
    gantry = CollisionWarningWorldEnv(scene="gantry_crest", config=everything)
    obs, _, infos = episode(gantry, 0)
    selected = obs[:, I["track_valid"]] == 1
    assert selected.sum() > 10
    assert np.all(obs[selected, I["confirmed"]] == 0)
    assert np.all(obs[selected, I["infrared_reporting"]] == 0)
    assert np.all(np.abs(obs[selected, I["ground_speed"]]) < 2.0)
    assert {infos[i]["cause"] for i in np.flatnonzero(selected)} == {"stationary"}
    obs, _, _ = episode(CollisionWarningWorldEnv(scene="parked_curve", config=BY_YAW), 0)
    selected = obs[:, I["track_valid"]] == 1
    assert selected.sum() > 10 and np.all(obs[selected, I["confirmed"]] == 1)


def test_the_adjacent_car_before_a_curve_is_selected_off_the_path_centre():
    obs, _, infos = episode(CollisionWarningWorldEnv(scene="curve_adjacent", config=BY_YAW), 0)
    selected = obs[:, I["track_valid"]] == 1
    assert selected.any()
    assert np.abs(obs[selected, I["lateral_offset"]]).max() > 0.5
    assert np.all(np.abs(obs[selected, I["lateral_offset"]]) <= 1.75)
    assert obs[selected, I["ground_speed"]].min() > 8.0  # a moving truck, 12-18 m/s
    assert {infos[i]["cause"] for i in np.flatnonzero(selected)} == {"adjacent"}
    assert np.all(obs[~selected, I["lateral_offset"]] == 0)


def test_a_cut_out_shows_the_second_object_and_changes_the_selection():
    obs, _, _ = episode(CollisionWarningWorldEnv(scene="cut_out"), 0)
    two = obs[:, I["in_path_count"]] >= 2
    assert two.any()
    assert np.all(obs[two, I["second_gap"]] > obs[two, I["gap"]])
    assert np.all(obs[~two, I["second_gap"]] == 250)
    age = obs[:, I["selection_age"]]
    assert np.any(np.diff(age) < 0) and age.max() > 1.0


def test_a_threshold_policy_on_the_gap_runs_an_episode():
    env = gym.make("acc_fusion/CollisionWarningWorld-v0", scene="lead_brakes")

    def policy(obs):
        return 2 if obs[I["track_valid"]] and obs[I["gap"]] < 15.0 else 0

    obs, rewards, infos = episode(env, 1, policy)
    warned = (obs[:-1, I["track_valid"]] == 1) & (obs[:-1, I["gap"]] < 15.0)
    assert warned.any() and np.isfinite(rewards).all()
    assert infos[-1]["t"] > 5.0 and env.observation_space.contains(obs[-1])
    # the same reward rule as the 1-D environment, against the oracle on the true lead
    oracle = np.array([i["oracle"] for i in infos[:-1]])
    collided = np.array([i["collided"] for i in infos[1:]])
    expected = RewardConfig().reward(np.where(warned, 2, 0), oracle, collided, 0.05)
    np.testing.assert_allclose(rewards, expected)


def test_the_driver_brakes_for_an_imminent_alert():
    env = CollisionWarningWorldEnv(scene="lead_brakes")

    def speeds(policy):
        return np.array([info["ego_speed"] for info in episode(env, 2, policy)[2]])

    quiet = speeds(lambda obs: 0)
    warned = speeds(lambda obs: 2 if obs[I["track_valid"]] and obs[I["gap"]] < 30.0 else 0)
    n = min(len(quiet), len(warned))
    assert np.any(warned[:n] < quiet[:n] - 1.0)


def test_the_baselines_and_evaluate_run_in_the_world():
    env = CollisionWarningWorldEnv(scene="lead_brakes")
    ev = evaluate(SafetyDistancePolicy(), episodes=2, seed=0, env=env)
    assert (ev.source, ev.scenario, ev.episodes) == ("world", "lead_brakes", 2)
    assert ev.summary.warnings > 0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"scene": "moon"}, "scene must be one of"),
        ({"method": "radar"}, "method must be one of"),
        ({"conditions": "fog"}, "conditions must be a Conditions"),
        ({"conditions": []}, "conditions must be a Conditions"),
        ({"conditions": {"fog": 25}}, "conditions have no field 'fog'"),
        ({"conditions": {"light": "dusk"}}, "conditions.light must be one of"),
        ({"conditions": [1]}, "conditions must be Conditions or mappings"),
        ({"config": {"dt": 0.1}}, "config must be a SimConfig"),
        ({"reward": 1.0}, "reward must be a RewardConfig"),
        ({"max_episode_steps": 0}, "max_episode_steps must be a whole number"),
    ],
)
def test_bad_arguments_are_one_line_errors(kwargs, message):
    with pytest.raises(ConfigError, match=message) as err:
        CollisionWarningWorldEnv(**kwargs)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"scenario": "cut_in"}, "reset options are"),
        ({"scene": "moon"}, "scene must be one of"),
        ({"conditions": {"rain_rate": -1.0}}, "conditions.rain_rate"),
    ],
)
def test_bad_reset_options_are_one_line_errors(options, message):
    env = CollisionWarningWorldEnv(scene="cut_in")
    with pytest.raises(ConfigError, match=message) as err:
        env.reset(seed=0, options=options)
    assert "\n" not in str(err.value)
    with pytest.raises(gym.error.ResetNeeded):
        env.step(0)


def test_reset_options_set_the_episode_and_actions_are_checked():
    env = CollisionWarningWorldEnv(scene="cut_in")
    _, info = env.reset(
        seed=0, options={"scene": "gantry_crest", "conditions": {"fog_visibility": 25.0}}
    )
    assert (info["scene"], info["conditions"]) == ("gantry_crest", "day, fog 25 m")
    assert env.reset(seed=0)[1]["scene"] == "cut_in"
    with pytest.raises(gym.error.InvalidAction):
        env.step(3)
