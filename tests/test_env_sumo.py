"""The environment's ``sumo`` source: checkers, one simulation per environment (no restart per
episode), Gymnasium seeding, the closed loop, SUMO failures, AsyncVectorEnv and the harness
(issue 5).  Most tests run the bundled ``ring`` (120 cars) without warm-up."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pytest.importorskip("libsumo")
gym = pytest.importorskip("gymnasium")

from conftest import run_episode  # noqa: E402

import acc_fusion  # noqa: E402,F401  (registers the environment)
from acc_fusion.core.errors import ConfigError  # noqa: E402
from acc_fusion.envs.collision_warning import CollisionWarningEnv, CollisionWarningVectorEnv  # noqa: E402
from acc_fusion.envs.options import SumoOptions  # noqa: E402
from acc_fusion.truth.sumo.config import SumoError  # noqa: E402

ENV_ID = "acc_fusion/CollisionWarning-v0"
RING = {"net": "ring", "warmup": 0.0}


@pytest.fixture
def make():
    """``make(**kwargs)``: a sumo-source environment, closed after the test (libsumo holds one
    simulation per process)."""
    made = []

    def build(max_episode_steps=40, **sumo):
        env = CollisionWarningEnv(
            source="sumo", sumo={**RING, **sumo}, max_episode_steps=max_episode_steps
        )
        made.append(env)
        return env

    yield build
    for env in made:
        env.close()


def test_default_sumo_env_passes_the_gymnasium_and_sb3_checkers():
    from gymnasium.utils.env_checker import check_env

    env = gym.make(ENV_ID, source="sumo")
    try:
        check_env(env.unwrapped, skip_render_check=True)
        assert env.unwrapped.scenario == "motorway" and env.unwrapped.dt == 0.05
        sb3 = pytest.importorskip("stable_baselines3.common.env_checker")
        sb3.check_env(env.unwrapped, warn=True)
    finally:
        env.close()


def test_reset_follows_the_next_vehicle_without_restarting_and_a_seed_repeats(make):
    env = make()
    first, infos, *_ = run_episode(env, seed=3)
    assert infos[0]["t"] == 0.0 and infos[-1]["t"] == pytest.approx(2.0)  # 40 steps of 0.05 s
    vehicles, times = [env.vehicle_id], [env._traffic.sim.t]
    for _ in range(3):
        run_episode(env)
        vehicles.append(env.vehicle_id)
        times.append(env._traffic.sim.t)
    assert env.sumo_starts == 1  # four episodes, one simulation
    assert len(set(vehicles)) == 4 and times == sorted(times)
    again, *_ = run_episode(env, seed=3)  # a seed restarts: the same episode
    assert env.sumo_starts == 2 and env.vehicle_id == vehicles[0]
    np.testing.assert_array_equal(first, again)
    other, *_ = run_episode(env, seed=4)
    assert not np.array_equal(first, other)


def test_the_end_of_the_simulation_truncates_and_the_next_reset_restarts(make):
    env = make(max_episode_steps=400, end=4.0)
    _, infos, terminated, truncated = run_episode(env, seed=0)
    assert truncated and not terminated and len(infos) <= 81  # SUMO ran 4 s
    run_episode(env)
    assert env.sumo_starts == 2


def test_warnings_make_the_sumo_driver_brake_and_collisions_end_episodes(make):
    """Closed loop: imminent alerts make the ego's driver brake (SUMO is commanded); the
    leader's emergency braking (lead_hazard) makes threats and collisions."""
    from acc_fusion.envs.policies import NeverWarn, TTCPolicy

    env = make(max_episode_steps=300, warmup=30.0, lead_hazard=1.0)
    speeds = {}
    for policy in (NeverWarn(), TTCPolicy()):
        _, infos, *_ = run_episode(env, seed=7, policy=policy)
        speeds[policy.name] = np.array([i["ego_speed"] for i in infos])
        assert max(i["oracle"] for i in infos) == 2
    silent, warned = speeds["never_warn"], speeds["ttc(3/2.4 s)"]
    assert silent[0] == warned[0] and (warned < silent - 1.0).any()
    _, infos, terminated, truncated = run_episode(env, seed=6)
    assert terminated and infos[-1]["collided"] and not infos[-1]["active"]


def test_a_sumo_failure_is_reported_and_reset_restarts(tmp_path):
    from importlib.resources import as_file, files

    with as_file(files("acc_fusion.sumo_nets") / "ring") as ring:
        (tmp_path / "late_bad.rou.xml").write_text(
            '<routes><vehicle id="ok" depart="3"><route edges="ring0"/></vehicle>'
            '<vehicle id="bad" depart="6"><route edges="no_such_edge"/></vehicle></routes>'
        )
        (tmp_path / "bad.sumocfg").write_text(
            f'<configuration><input><net-file value="{ring}/ring.net.xml"/>'
            f'<route-files value="{ring}/ring.rou.xml,late_bad.rou.xml"/></input>'
            '<processing><route-steps value="2"/></processing></configuration>'
        )
        env = CollisionWarningEnv(
            source="sumo",
            sumo={"sumocfg": str(tmp_path / "bad.sumocfg"), "warmup": 0.0},
            max_episode_steps=1000,
        )
        try:
            env.reset(seed=0)
            with pytest.warns(RuntimeWarning, match="no_such_edge.*next reset"):
                for _ in range(200):
                    obs, reward, terminated, truncated, info = env.step(0)
                    if terminated or truncated:
                        break
            assert truncated and not terminated and reward == 0.0
            assert "no_such_edge" in info["sumo_error"] and env.observation_space.contains(obs)
            with pytest.raises(gym.error.ResetNeeded):
                env.step(0)
            obs, info = env.reset()  # a new simulation
            assert env.sumo_starts == 2 and info["t"] == 0.0
            env.step(0)
        finally:
            env.close()


def test_one_sumo_environment_per_process(make):
    make().reset(seed=0)
    second = CollisionWarningEnv(source="sumo", sumo=RING)
    with pytest.raises(SumoError, match="one simulation per process"):
        second.reset(seed=0)


def test_bad_sumo_options_are_clear_errors(tmp_path):
    cases = [
        ({"net": "moon"}, "unknown network 'moon'"),
        ({"net": "ring", "sumocfg": "x.sumocfg"}, "one of sumo.net and sumo.sumocfg"),
        ({"sumocfg": str(tmp_path / "none.sumocfg")}, "does not exist"),
        ({"penetration": 0.0}, r"sumo.penetration must be in \(0, 1\]"),
        ({"lead_hazard": 2}, "sumo.lead_hazard"),
        ({"inattentive": -1}, "sumo.inattentive must be in"),
        ({"capacity": 0}, "sumo.capacity must be an integer"),
        ({"speed": 3}, "speed"),
    ]
    for options, message in cases:
        with pytest.raises(ConfigError, match=message):
            CollisionWarningEnv(source="sumo", sumo=options)
    with pytest.raises(ConfigError, match="apply to source 'sumo'"):
        CollisionWarningEnv(sumo=SumoOptions(net="ring"))
    with pytest.raises(ConfigError, match="applies to the scripted source"):
        CollisionWarningEnv(source="sumo", scenario="nhtsa_lvs")
    with pytest.raises(ConfigError, match="vectorization_mode='async'"):
        CollisionWarningVectorEnv(2, source="sumo")
    with pytest.raises(ConfigError, match="raise sumo.penetration"):
        env = CollisionWarningEnv(source="sumo", sumo={**RING, "end": 0.1, "penetration": 1e-6})
        try:
            env.reset(seed=0)
        finally:
            env.close()


def test_async_vector_env_runs_one_simulation_per_process():
    envs = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode="async",
        vector_kwargs={"context": "spawn"},
        source="sumo",
        sumo=RING,
        max_episode_steps=20,
    )
    try:
        obs, info = envs.reset(seed=0)
        assert obs.shape == (2, 16) and not np.array_equal(obs[0], obs[1])
        ended = 0
        for _ in range(45):  # two episodes each, and the autoresets in between
            obs, reward, terminated, truncated, info = envs.step(np.array([0, 2]))
            ended += int((terminated | truncated).sum())
        assert ended == 4 and envs.observation_space.contains(obs)
        assert envs.call("sumo_starts") == (1, 1)
    finally:
        envs.close()


def test_harness_and_cli_evaluate_on_the_sumo_source(capsys):
    from acc_fusion.cli.main import main
    from acc_fusion.envs.evaluation import evaluate_many
    from acc_fusion.envs.policies import AlwaysWarn, NeverWarn

    never, always = evaluate_many(
        {"never": NeverWarn(), "always": AlwaysWarn()},
        source="sumo",
        episodes=3,
        max_episode_steps=30,
        sumo=RING,
    )
    assert never.source == "sumo" and never.scenario == "ring" and never.episodes == 3
    assert never.steps == always.steps == 90 and always.summary.warnings > 0
    argv = ["evaluate", "--source", "sumo", "--net", "ring", "--policy", "never_warn"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main([*argv, "--episodes", "2", "--max-steps", "20"]) == 0
    out = capsys.readouterr().out
    assert "2 episodes of 'ring' (sumo source)" in out and "never_warn" in out
    assert main(["evaluate", "--net", "ring", "--policy", "never_warn"]) == 2
    assert "--net and --sumocfg apply to --source sumo" in capsys.readouterr().err
