"""The environment's ``highway`` source: checkers, Gymnasium seeding, the closed loop, vector
environments, the harness and the CLI, and bad options.  Short episodes (a few seconds of
``highway-fast-v0`` at 15 Hz) keep the file fast."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("highway_env")
gym = pytest.importorskip("gymnasium")

from conftest import run_episode  # noqa: E402

import acc_fusion  # noqa: E402,F401  (registers the environment)
from acc_fusion.core.errors import ConfigError  # noqa: E402
from acc_fusion.envs.collision_warning import CollisionWarningEnv, CollisionWarningVectorEnv  # noqa: E402
from acc_fusion.envs.options import HighwayOptions  # noqa: E402

ENV_ID = "acc_fusion/CollisionWarning-v0"
SHORT = {"duration": 6.0}


def test_default_highway_env_passes_the_gymnasium_and_sb3_checkers():
    from gymnasium.utils.env_checker import check_env

    env = gym.make(ENV_ID, source="highway")
    try:
        base = env.unwrapped
        check_env(base, skip_render_check=True)
        assert base.scenario == "highway-fast-v0" and base.dt == pytest.approx(1 / 15)
        assert base.config.dt == base.dt and not base.reseeding_restarts
        sb3 = pytest.importorskip("stable_baselines3.common.env_checker")
        sb3.check_env(base, warn=True)
    finally:
        env.close()


def test_a_seed_repeats_the_episode_and_each_reset_starts_a_new_one():
    env = CollisionWarningEnv(source="highway", highway=SHORT)
    try:
        first, infos, terminated, truncated = run_episode(env, seed=4)
        assert infos[0]["t"] == 0.0 and (terminated or truncated)
        other, *_ = run_episode(env)  # unseeded: the next episode drawn from the generator
        again, *_ = run_episode(env, seed=4)
        assert np.array_equal(first, again) and not np.array_equal(first, other)
        assert env.highway_episodes == 3 and env.sumo_starts == 0
        fresh = CollisionWarningEnv(source="highway", highway=SHORT)
        assert np.array_equal(run_episode(fresh, seed=4)[0], first)  # another environment
        fresh.close()
        if truncated:
            assert infos[-1]["t"] == pytest.approx(6.0)
    finally:
        env.close()


def test_warnings_make_the_controlled_vehicle_brake():
    env = CollisionWarningEnv(source="highway", highway={"duration": 10.0})
    try:
        outcomes = {}
        for action in (0, 2):
            # seed 2: the ego closes in on a slower leader within 6 s
            _, infos, *_ = run_episode(env, seed=2, policy=lambda obs, a=action: a)
            speeds = [i["ego_speed"] for i in infos]
            outcomes[action] = (min(speeds), any(i["collided"] for i in infos), infos)
        never, always = outcomes[0], outcomes[2]
        # Never warned, the ego holds its speed into the threat and collides; warned, it brakes.
        assert any(i["oracle"] == 2 for i in never[2]) and never[1]
        assert never[0] == pytest.approx(25.0) and always[0] < 20.0 and not always[1]
    finally:
        env.close()


def test_render_draws_the_situation():
    env = CollisionWarningEnv(source="highway", highway=SHORT, render_mode="rgb_array")
    try:
        env.reset(seed=1)
        for _ in range(10):
            env.step(1)
        img = env.render()
        assert img.ndim == 3 and img.shape[2] == 3 and img.std() > 0
    finally:
        env.close()


def test_sync_vector_env_runs_one_highway_env_per_copy():
    envs = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode="sync",
        source="highway",
        highway={"duration": 2.0},
    )
    try:
        obs, info = envs.reset(seed=0)
        assert obs.shape == (2, 16) and not np.array_equal(obs[0], obs[1])
        ended = 0
        for _ in range(70):  # 30 steps per episode, with the autoresets in between
            obs, reward, terminated, truncated, info = envs.step(np.array([0, 2]))
            ended += int((terminated | truncated).sum())
        assert ended >= 4 and envs.observation_space.contains(obs)
        assert all(n >= 2 for n in envs.call("highway_episodes"))
    finally:
        envs.close()


def test_harness_and_cli_evaluate_on_the_highway_source(capsys):
    from acc_fusion.cli.main import main
    from acc_fusion.envs.evaluation import evaluate, evaluate_many
    from acc_fusion.envs.policies import AlwaysWarn, NeverWarn

    never, always = evaluate_many(
        {"never": NeverWarn(), "always": AlwaysWarn()},
        source="highway",
        episodes=2,
        highway=SHORT,
    )
    assert never.source == "highway" and never.scenario == "highway-fast-v0"
    assert never.episodes == 2 and always.summary.warnings > 0
    again = evaluate(NeverWarn(), source="highway", episodes=2, highway=SHORT)
    assert again.steps == never.steps and again.collisions == never.collisions
    argv = ["evaluate", "--source", "highway", "--policy", "never_warn", "--episodes", "2"]
    assert main([*argv, "--max-steps", "30"]) == 0
    out = capsys.readouterr().out
    assert "2 episodes of 'highway-fast-v0' (highway source)" in out and "never_warn" in out
    assert main(["evaluate", "--highway-env", "highway-v0", "--policy", "never_warn"]) == 2
    assert "apply to --source highway" in capsys.readouterr().err
    assert main([*argv, "--highway-env", "moon-v0"]) == 2
    assert "highway.env must be one of" in capsys.readouterr().err


def test_bad_highway_options_are_clear_errors():
    cases = [
        ({"env": "moon-v0"}, "highway.env must be one of"),
        ({"duration": 0.0}, "highway.duration must be in"),
        ({"vehicles_count": -1}, "highway.vehicles_count must be in"),
        ({"simulation_frequency": 2}, "highway.simulation_frequency must be a whole number"),
        ({"lookahead": -5.0}, "highway.lookahead"),
        ({"env_config": {"controlled_vehicles": 2}}, "must not set 'controlled_vehicles'"),
        ({"env_config": {"no_such_entry": 1}}, "has no config entry 'no_such_entry'"),
        ({"speed": 3}, "unknown key highway.'speed'|highway.speed"),
    ]
    for options, message in cases:
        with pytest.raises(ConfigError, match=message):
            CollisionWarningEnv(source="highway", highway=options)
    with pytest.raises(ConfigError, match="highway must be HighwayOptions or a mapping"):
        CollisionWarningEnv(source="highway", highway=42)
    with pytest.raises(ConfigError, match="apply to source 'highway'"):
        CollisionWarningEnv(highway=HighwayOptions())
    with pytest.raises(ConfigError, match="applies to the scripted source"):
        CollisionWarningEnv(source="highway", scenario="nhtsa_lvs")
    with pytest.raises(ConfigError, match="vectorization_mode='sync' or 'async'"):
        CollisionWarningVectorEnv(2, source="highway")


def test_missing_highway_env_names_the_install_command(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "highway_env", None)  # import highway_env fails
    with pytest.raises(
        ConfigError, match=r"needs highway-env: pip install 'acc_fusion\[highway\]'"
    ):
        CollisionWarningEnv(source="highway")
