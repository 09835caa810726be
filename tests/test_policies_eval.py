"""Baseline warning policies and the evaluation harness (issue 5)."""

from __future__ import annotations

import sys

import numpy as np
import pytest

pytest.importorskip("gymnasium")

from acc_fusion.cli import evaluate as evaluate_command
from acc_fusion.cli.main import build_parser
from acc_fusion.core.errors import ConfigError, InputError  # noqa: E402
from acc_fusion.envs.evaluation import episode_seed, evaluate, evaluate_many
from acc_fusion.envs.loader import load_policy
from acc_fusion.envs.observation import OBS_FIELDS
from acc_fusion.envs.policies import (  # noqa: E402
    BASELINES,
    AlwaysWarn,
    NeverWarn,
    RSSPolicy,
    SafetyDistancePolicy,
    TTCPolicy,
    UncertaintyAwarePolicy,
    WarningLogicPolicy,
    obs_field,
)
from acc_fusion.warning.logic import WarningConfig  # noqa: E402
from acc_fusion.warning.safety import safety_distances  # noqa: E402


def make_obs(**fields) -> np.ndarray:
    """An observation with the named fields set (a track by default, 20 m/s, closing 5 m/s)."""
    values = {"gap": 50.0, "range_rate": -5.0, "ego_speed": 20.0, "track_valid": 1.0, **fields}
    obs = np.zeros(len(OBS_FIELDS), dtype=np.float32)
    for name, value in values.items():
        obs[OBS_FIELDS.index(name)] = value
    return obs


def distances(model: str, v=20.0, rate=-5.0, accel=0.0) -> tuple[float, float]:
    d_c, d_i = safety_distances(model, [v], [rate], [accel])
    return float(d_c[0]), float(d_i[0])


# ------------------------------------------------------------------------------ baselines


@pytest.mark.parametrize(
    ("policy", "model"), [(SafetyDistancePolicy(), "stopping_distance"), (RSSPolicy(), "rss")]
)
def test_safety_distance_rules_compare_the_fused_gap_with_the_models_distances(policy, model):
    d_c, d_i = distances(model)
    assert 0 < d_i < d_c
    assert policy(make_obs(gap=d_i - 0.1)) == 2
    assert policy(make_obs(gap=(d_i + d_c) / 2)) == 1
    assert policy(make_obs(gap=d_c + 0.1)) == 0
    assert policy(make_obs(gap=d_i - 0.1, track_valid=0.0)) == 0


def test_the_safety_distance_uses_ego_speed_range_rate_and_lead_acceleration():
    policy = SafetyDistancePolicy("required_deceleration")
    _, d_i = distances("required_deceleration", 25.0, -8.0, -3.0)
    _, d_i_steady = distances("required_deceleration", 25.0, -8.0, 0.0)
    assert d_i_steady < d_i - 1.0  # a braking lead needs a longer distance
    kinematics = {"ego_speed": 25.0, "range_rate": -8.0}
    assert policy(make_obs(gap=d_i - 0.5, lead_accel=-3.0, **kinematics)) == 2
    assert policy(make_obs(gap=d_i - 0.5, lead_accel=0.0, **kinematics)) < 2


def test_uncertainty_aware_rule_warns_earlier_for_an_uncertain_gap():
    d_c, d_i = distances("stopping_distance")
    policy = UncertaintyAwarePolicy(z=1.645)
    assert policy(make_obs(gap=d_c + 1.0, gap_std=0.0)) == 0
    assert policy(make_obs(gap=d_c + 1.0, gap_std=(d_c + 1.0 - d_i + 0.5) / 1.645)) == 2
    assert SafetyDistancePolicy()(make_obs(gap=d_c + 1.0, gap_std=100.0)) == 0


def test_ttc_policy_thresholds():
    policy = TTCPolicy(caution=3.0, imminent=2.4)
    assert policy(make_obs(gap=20.0, range_rate=-10.0)) == 2  # TTC 2 s
    assert policy(make_obs(gap=20.0, range_rate=-7.5)) == 1  # TTC 2.67 s
    assert policy(make_obs(gap=20.0, range_rate=-5.0)) == 0  # TTC 4 s
    assert policy(make_obs(gap=5.0, range_rate=1.0)) == 0  # opening
    assert policy(make_obs(gap=20.0, range_rate=-10.0, track_valid=0.0)) == 0
    with pytest.raises(ConfigError, match="imminent must be <= caution"):
        TTCPolicy(caution=2.0, imminent=3.0)


def test_warning_logic_policy_holds_its_alert_by_hysteresis_and_resets():
    config = WarningConfig(hysteresis=0.1, min_on_time=0.0)
    d_c, d_i = distances(config.model)
    assert d_i * 1.05 < d_c
    policy = WarningLogicPolicy(config)
    assert policy(make_obs(gap=d_i - 0.5)) == 2
    assert policy(make_obs(gap=d_i * 1.05)) == 2  # inside the hysteresis band: still on
    stateless = SafetyDistancePolicy(config.model)
    assert stateless(make_obs(gap=d_i * 1.05)) == 1  # the stateless rule drops
    policy.reset()
    assert policy(make_obs(gap=d_i * 1.05)) == 1


def test_anchors_and_batches():
    tracked, lost = make_obs(gap=200.0, range_rate=5.0), make_obs(track_valid=0.0)
    assert AlwaysWarn()(tracked) == 2 and AlwaysWarn()(lost) == 0
    assert AlwaysWarn(level=1)(tracked) == 1 and NeverWarn()(make_obs(gap=0.5)) == 0
    batch = np.stack([make_obs(gap=g) for g in (1.0, 20.0, 40.0, 200.0)] + [lost])
    for name, policy in BASELINES.items():
        policy.reset()
        levels = policy(batch)
        assert levels.shape == (5,) and levels.dtype == np.int8, name
        assert set(levels.tolist()) <= {0, 1, 2} and levels[-1] == 0, name
        if not isinstance(policy, WarningLogicPolicy):  # stateless: rows are independent
            assert levels.tolist() == [policy(row) for row in batch], name
        assert isinstance(policy(batch[0]), int), name


def test_policies_read_the_observation_by_name_and_reject_bad_shapes():
    obs = make_obs(gap=12.5, gap_std=0.7)
    assert obs_field(obs, "gap") == np.float32(12.5)
    assert obs_field(obs, "gap_std") == np.float32(0.7)
    with pytest.raises(ConfigError, match="observation field"):
        obs_field(obs, "speed")
    with pytest.raises(InputError, match="obs must be one observation"):
        TTCPolicy()(obs[:5])


# ------------------------------------------------------------------------------ the harness


class Recorder:
    """Wraps a policy and keeps the first observation of every episode."""

    def __init__(self, policy):
        self.policy, self.name, self.first = policy, policy.name, []
        self._new = True

    def reset(self):
        self.policy.reset()
        self._new = True

    def __call__(self, obs):
        if self._new:
            self.first.append(np.array(obs))
            self._new = False
        return self.policy(obs)


EPISODES = 12  # about 20 s for three policies; the ranking held on seeds 0-3


@pytest.fixture(scope="module")
def ranked():
    policies = {
        "safety_distance": Recorder(SafetyDistancePolicy()),
        "always_warn": Recorder(AlwaysWarn()),
        "never_warn": Recorder(NeverWarn()),
    }
    evaluations = evaluate_many(policies, episodes=EPISODES, seed=0)
    return policies, {e.policy: e for e in evaluations}


def test_every_policy_sees_the_same_episodes(ranked):
    policies, _ = ranked
    firsts = [np.stack(p.first) for p in policies.values()]
    assert len(firsts[0]) == EPISODES
    assert all(np.array_equal(firsts[0], f) for f in firsts[1:])


def test_the_harness_ranks_the_sanity_anchors(ranked):
    _, ev = ranked
    rule, always, never = ev["safety_distance"], ev["always_warn"], ev["never_warn"]
    fa = {k: e.summary.false_alarms_per_hour.value for k, e in ev.items()}
    assert fa["always_warn"] > max(fa["safety_distance"], fa["never_warn"])
    assert always.summary.false_alarms > rule.summary.false_alarms
    assert never.summary.warnings == 0 and never.summary.missed == never.summary.threats > 0
    worst = max(rule.summary.miss_rate.value, always.summary.miss_rate.value)
    assert never.summary.miss_rate.value > worst
    assert never.collisions > max(rule.collisions, always.collisions)
    assert never.mean_reward < rule.mean_reward
    for e in ev.values():
        assert e.episodes == EPISODES and e.collisions == e.summary.collisions
        assert e.summary.hours > 0 and e.steps > EPISODES


def test_the_same_seed_gives_identical_evaluations():
    a = evaluate(TTCPolicy(), episodes=2, seed=5)
    b = evaluate(TTCPolicy(), episodes=2, seed=5)
    assert a.as_dict() == b.as_dict() and a.steps == b.steps
    assert episode_seed(5, 1) == episode_seed(5, 1) != episode_seed(5, 0)
    assert episode_seed(5, 1) != episode_seed(6, 1)


class DummyModel:
    """Stable-Baselines3's predict API, acting like the safety-distance rule."""

    def __init__(self):
        self.rule = SafetyDistancePolicy()

    def predict(self, obs, deterministic=False):
        assert deterministic
        return np.array(self.rule(obs)), None


class DummyRecurrentModel(DummyModel):
    def __init__(self):
        super().__init__()
        self.starts = []

    def predict(self, obs, state=None, episode_start=None, deterministic=False):
        self.starts.append(bool(episode_start[0]))
        assert (state is None) == bool(episode_start[0])
        return np.array(self.rule(obs)), ("hidden",)


def test_models_with_predict_are_evaluated_like_the_policy_they_mimic():
    reference = evaluate(SafetyDistancePolicy(), episodes=2, seed=3, name="x")
    model = evaluate(DummyModel(), episodes=2, seed=3, name="x")
    assert model.as_dict() == reference.as_dict()
    recurrent = DummyRecurrentModel()
    assert evaluate(recurrent, episodes=2, seed=3, name="x").as_dict() == reference.as_dict()
    assert sum(recurrent.starts) == 2 and recurrent.starts[0]
    assert evaluate(DummyModel, episodes=1, seed=3).policy == "DummyModel"  # a class: built


def test_bad_policies_and_arguments_are_clear_errors():
    with pytest.raises(InputError, match=r"returned 3: an action must be 0, 1 or 2"):
        evaluate(lambda obs: 3, episodes=1)
    with pytest.raises(ConfigError, match="policy must be a callable"):
        evaluate(42, episodes=1)
    with pytest.raises(ConfigError, match="episodes must be a whole number >= 1"):
        evaluate(NeverWarn(), episodes=0)
    with pytest.raises(ConfigError, match="warn_level"):
        evaluate(NeverWarn(), episodes=1, warn_level=3)
    with pytest.raises(ConfigError, match="highway options apply to source 'highway'"):
        evaluate(NeverWarn(), highway={"env": "highway-v0"}, episodes=1)


# ------------------------------------------------------------------------------ load_policy


@pytest.fixture
def forget_modules():
    """Drop the users' modules a test imported from a temporary folder."""
    yield
    for name in ("my_rules", "bad_rules"):
        sys.modules.pop(name, None)


def test_load_policy_from_specs(tmp_path, monkeypatch, forget_modules):
    assert load_policy("ttc") is BASELINES["ttc"]
    assert isinstance(load_policy("acc_fusion.envs.policies:TTCPolicy"), TTCPolicy)
    (tmp_path / "my_rules.py").write_text(
        "def policy(obs):\n    return 2 if obs[0] < 10 else 0\n\n"
        "def make():\n    return lambda obs: 1\n\n"
        "class Holder:\n    rule = staticmethod(policy)\n"
    )
    monkeypatch.chdir(tmp_path)
    assert load_policy("my_rules:policy")(make_obs(gap=5.0)) == 2
    assert load_policy("my_rules:make")(make_obs()) == 1  # a factory without arguments
    assert load_policy("my_rules:Holder.rule")(make_obs(gap=50.0)) == 0
    assert load_policy(f"{tmp_path / 'my_rules.py'}:policy")(make_obs(gap=5.0)) == 2


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("bad_rules", "--policy must be MODULE:CALLABLE"),
        ("bad_rules:", "--policy must be MODULE:CALLABLE"),
        ("", "--policy must be MODULE:CALLABLE"),
        ("no_such_module_xyz:policy", "no module named 'no_such_module_xyz'"),
        ("bad_rules:missing", "'bad_rules' has no attribute 'missing'"),
        ("broken:policy", "importing 'broken' failed: ZeroDivisionError"),
        ("needs_dep:policy", "importing 'needs_dep' failed: ModuleNotFoundError"),
        ("bad_rules:VALUE", "is not a policy .*got a int value"),
        ("bad_rules:two_args", "must take one argument"),
        ("bad_rules:Needy", "the class must be callable with no arguments"),
        ("nowhere.py:policy", "file 'nowhere.py' does not exist"),
        ("missing_model.zip", "model file 'missing_model.zip' does not exist"),
    ],
)
def test_load_policy_errors_are_one_line(tmp_path, monkeypatch, forget_modules, spec, message):
    (tmp_path / "bad_rules.py").write_text(
        "VALUE = 3\n\ndef two_args(obs, other):\n    return 0\n\n"
        "class Needy:\n    def __init__(self, x):\n        pass\n"
    )
    (tmp_path / "broken.py").write_text("1 / 0\n")
    (tmp_path / "needs_dep.py").write_text("import not_installed_dep_xyz\n")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=message.replace("(", r"\(")) as err:
        load_policy(spec)
    assert "\n" not in str(err.value)


def test_an_sb3_model_file_needs_stable_baselines3(tmp_path):
    try:
        import stable_baselines3  # noqa: F401
    except ImportError:
        (tmp_path / "agent.zip").write_bytes(b"PK")
        with pytest.raises(ConfigError, match="needs Stable-Baselines3"):
            load_policy(str(tmp_path / "agent.zip"))
    else:
        pytest.skip("stable-baselines3 is installed")


# ------------------------------------------------------------------------------ the command


def run_command(argv):
    args = build_parser(["evaluate"]).parse_args(["evaluate", *argv])
    return evaluate_command.run(args)


def test_evaluate_command_prints_the_table_and_writes_files(tmp_path, capsys):
    argv = ["--policy", "acc_fusion.envs.policies:NeverWarn", "--policy", "ttc", "--episodes", "1"]
    assert run_command([*argv, "--seed", "2", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "Warning policies: 1 episodes of 'random'" in out
    assert "acc_fusion.envs.policies:NeverWarn" in out and "fa_per_hour" in out
    csv = (tmp_path / "evaluate.csv").read_text().splitlines()
    assert csv[0].startswith("policy,warnings,false_alarms") and len(csv) == 3
    assert (tmp_path / "evaluate.json").stat().st_size > 100


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--highway-env", "highway-v0", "--baselines"], "apply to --source highway"),
        (["--episodes", "1"], "give a policy to evaluate"),
        (["--policy", "nope"], "--policy must be MODULE:CALLABLE"),
    ],
)
def test_evaluate_command_errors(argv, message):
    with pytest.raises(ConfigError, match=message):
        run_command(argv)


def test_evaluate_command_through_the_cli_is_one_line(capsys):
    from acc_fusion.cli.main import main

    try:
        code = main(["evaluate", "--policy", "nope:x", "--episodes", "1"])
    except SystemExit:
        pytest.skip("acc-fusion evaluate is not wired into cli.py yet")
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("acc-fusion: error: --policy 'nope:x'")
    assert "Traceback" not in err and err.count("\n") == 1
