"""A gymnasium environment for testing collision-warning policies."""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from acc_fusion.driver import Driver
from acc_fusion.errors import ConfigError
from acc_fusion.fcw import Perception, SimConfig
from acc_fusion.safety import safety_distances
from acc_fusion.scenarios import SCENARIOS, make_scenario
from acc_fusion.studies import SENSOR_NAMES
from acc_fusion.validation import check_choice, check_range
from acc_fusion.warning import CAUTION, IMMINENT, NONE

#: Names of the observation's entries, in order (see the environment's docstring).
OBS_FIELDS = (
    "gap",
    "range_rate",
    "lead_accel",
    "gap_std",
    "range_rate_std",
    "lead_accel_std",
    "ego_speed",
    "track_valid",
) + tuple(f"{s}_{k}" for s in SENSOR_NAMES for k in ("reporting", "isolated", "nis", "age"))
#: Truth sources of the environment; only ``scripted`` exists yet.
SOURCES = ("scripted", "sumo", "highway")
#: Values reported where there is no track: the gap at the radar's maximum range.
NO_TRACK_GAP = 250.0
NIS_CLIP, AGE_CLIP = 100.0, 10.0

_LOW = np.array([0.0, -60.0, -15.0, 0.0, 0.0, 0.0, 0.0, 0.0] + [0.0, 0.0, 0.0, 0.0] * 2)
_HIGH = np.array(
    [NO_TRACK_GAP, 60.0, 15.0, 100.0, 60.0, 30.0, 70.0, 1.0] + [1.0, 1.0, NIS_CLIP, AGE_CLIP] * 2
)


@dataclass(frozen=True)
class RewardConfig:
    """Weights of the reward (per second of simulated time unless stated).

    Attributes:
        false_alarm: cost per second of an imminent alert while the oracle sees no threat.
        missed: cost per second of an oracle threat without an imminent alert.
        timely: credit per second of an imminent alert during an oracle threat.
        nuisance: cost per second of a caution alert while the oracle sees nothing.
        collision: cost of a collision (once; the episode ends).
    """

    false_alarm: float = 1.0
    missed: float = 2.0
    timely: float = 0.5
    nuisance: float = 0.1
    collision: float = 100.0

    def __post_init__(self) -> None:
        for name in ("false_alarm", "missed", "timely", "nuisance", "collision"):
            check_range(f"reward.{name}", getattr(self, name), 0.0, 1e6)


class CollisionWarningEnv(gym.Env):
    """Decide, every step, which forward-collision warning the driver hears.

    ## Description

    An equipped ego vehicle follows a lead vehicle through one scripted scenario (by default
    the randomised suite of :mod:`acc_fusion.scenarios`: NHTSA and Euro NCAP test manoeuvres,
    cut-ins, cut-outs, stop-and-go, steady following).  A radar (20 Hz) and an infrared
    camera (10 Hz) measure the lead; their local Kalman filters and the federated fusion
    center (with fault detection) estimate its motion; the policy sees what the fusion center
    knows and chooses the warning.  The simulated driver reacts to an imminent alert after his
    reaction time and brakes (closed loop).  The oracle, the same warning rule evaluated on
    ground truth, judges the alerts.

    ## Action Space

    ``Discrete(3)``: 0 no warning, 1 caution, 2 imminent (the FCW alert the driver brakes for).

    ## Observation Space

    ``Box(16,)`` float32:

    | index | observation                                   | min  | max  |
    |-------|-----------------------------------------------|------|------|
    | 0     | fused gap [m] (250 without a track)           | 0    | 250  |
    | 1     | fused range-rate [m/s]                         | -60  | 60   |
    | 2     | fused lead acceleration [m/s²]                 | -15  | 15   |
    | 3-5   | standard deviations of 0-2                     | 0    | 100, 60, 30 |
    | 6     | ego speed from the ego-motion filter [m/s]     | 0    | 70   |
    | 7     | 1 when the fusion center has a track           | 0    | 1    |
    | 8-11  | radar: reports now, isolated, last NIS, age [s] | 0    | 1, 1, 100, 10 |
    | 12-15 | infrared: the same                             | 0    | 1, 1, 100, 10 |

    (age: seconds since the sensor's last measurement of this target)

    ## Rewards

    Per step of ``dt`` seconds (weights in :class:`RewardConfig`): ``-false_alarm·dt`` for an
    imminent alert with no oracle threat, ``-missed·dt`` for an oracle threat without an
    imminent alert, ``+timely·dt`` for an imminent alert during a threat, ``-nuisance·dt`` for
    a caution with no oracle caution, and ``-collision`` once on a collision.

    ## Starting State

    A new scenario run drawn with the environment's random generator: on ``reset(seed=...)``
    the manoeuvre, its parameters, the sensor noise and the driver are all drawn from
    ``self.np_random``.

    ## Episode End

    Terminated on a collision or when the scenario's run ends (the ego stopped, the threat
    passed, or its duration ran out); truncated after ``max_episode_steps`` steps.

    ## Arguments

    ``source`` (``"scripted"``; ``"sumo"`` and ``"highway"`` are not available yet),
    ``scenario`` (a name of :data:`acc_fusion.scenarios.SCENARIOS`), ``config``
    (:class:`acc_fusion.fcw.SimConfig`: sensors, fusion, warning model, driver), ``reward``
    (:class:`RewardConfig`), ``render_mode`` (``None`` or ``"rgb_array"``),
    ``max_episode_steps``.

    ## Example

    >>> import gymnasium as gym, acc_fusion
    >>> env = gym.make("acc_fusion/CollisionWarning-v0")
    >>> obs, info = env.reset(seed=1)
    >>> obs.shape
    (16,)
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self,
        source: str = "scripted",
        scenario: str = "random",
        config: SimConfig | None = None,
        reward: RewardConfig | None = None,
        render_mode: str | None = None,
        max_episode_steps: int = 1200,
    ) -> None:
        check_choice("source", source, SOURCES)
        if source != "scripted":
            raise ConfigError(
                f"source {source!r} is not available yet: the environment runs the 'scripted' "
                "source (the SUMO and highway-env sources are open work)"
            )
        check_choice("scenario", scenario, tuple(SCENARIOS))
        if render_mode is not None:
            check_choice("render_mode", render_mode, tuple(self.metadata["render_modes"]))
        if not isinstance(max_episode_steps, int) or max_episode_steps < 1:
            raise ConfigError(
                f"max_episode_steps must be a whole number >= 1, got {max_episode_steps!r}"
            )
        self.source_name, self.scenario = source, scenario
        self.config = config or SimConfig(scenario=scenario, runs=1, methods=("federated",))
        self.reward_config = reward or RewardConfig()
        self.render_mode = render_mode
        self.max_episode_steps = max_episode_steps
        self.dt = self.config.dt
        self.action_space = spaces.Discrete(3)
        self.observation_space = spaces.Box(
            _LOW.astype(np.float32), _HIGH.astype(np.float32), dtype=np.float32
        )
        self._core: _Core | None = None
        self._history: list[tuple[float, float, float, int]] = []

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self._core = _Core(1, self.scenario, self.config, self.reward_config, self.np_random)
        self._history = []
        obs, info = self._core.observe(np.zeros(1, dtype=bool))
        return obs[0], _single(info)

    def step(self, action):
        if self._core is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        if not self.action_space.contains(action):
            raise gym.error.InvalidAction(
                f"action must be 0, 1 or 2 (none, caution, imminent), got {action!r}"
            )
        core = self._core
        self._history.append((core.t, core.fused_gap[0], core.d_imminent()[0], int(action)))
        del self._history[:-400]
        reward = core.act(np.array([action], dtype=np.int8))
        terminated = core.collided | core.ended
        truncated = ~terminated & (core.steps >= self.max_episode_steps)
        obs, info = core.observe(core.collided)
        return obs[0], float(reward[0]), bool(terminated[0]), bool(truncated[0]), _single(info)

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        from acc_fusion.plots import warning_frame

        return warning_frame(self._history, self.scenario)


def _single(info: dict) -> dict:
    """The info of copy 0 of a batched info dict, as plain Python values."""
    return {k: v[0].item() if isinstance(v, np.ndarray) else v for k, v in info.items()}


class _Core:
    """The simulation behind the environments, batched over ``n`` copies (array arithmetic).

    Each copy is one run of the scenario: truth source, sensors, ego-motion filter, the
    federated fusion center, the oracle and the driver, all over arrays of ``n`` pairs.
    """

    def __init__(self, n, scenario, config, reward, rng: np.random.Generator) -> None:
        root = np.random.SeedSequence(int(rng.integers(2**63)))
        s_source, s_perception, s_driver = root.spawn(3)
        self.n, self.config, self.reward = n, config, reward
        self.dt = config.dt
        self.source = make_scenario(scenario, n, seed=np.random.default_rng(s_source), dt=self.dt)
        self.perception = Perception(config, n, s_perception)
        self.driver = Driver(n, config.driver, seed=np.random.default_rng(s_driver))
        self.steps = np.zeros(n, dtype=np.int64)
        self.last_seen = np.full((len(SENSOR_NAMES), n), -np.inf)
        self.collided = np.zeros(n, dtype=bool)
        self._perceive(None)

    @property
    def t(self) -> float:
        return float(self.seen.frame.t)

    @property
    def ended(self) -> np.ndarray:
        """Copies whose scenario run is over."""
        return ~self.source.active

    @property
    def fused_gap(self) -> np.ndarray:
        est = self.seen.estimates["federated"]
        return np.where(est.valid, est.gap, np.nan)

    def act(self, action: np.ndarray, restart=None, rng=None) -> np.ndarray:
        """Apply the warnings and advance one step; the copies in ``restart`` then start a
        new run (drawn from ``rng``) while the others continue.  Returns the rewards."""
        reward = self._reward(action, self.seen.oracle)
        brake = self.driver.step(action, self.seen.frame)
        was = self.source.collided
        self.source.advance(brake)
        self.perception.advanced()
        self.steps += 1
        self.collided = self.source.collided & ~was
        reward -= self.reward.collision * self.collided
        if restart is not None and restart.any():
            self.source.restart(restart, np.random.default_rng(int(rng.integers(2**63))))
            self.driver.reset(restart)
            self.steps[restart] = 0
            self.last_seen[:, restart] = -np.inf
            self.collided[restart] = False
            reward[restart] = 0.0
        self._perceive(restart)
        return reward

    def _perceive(self, reassigned) -> None:
        frame = self.source.frame()
        self.seen = self.perception.step(frame, self.source.active, reassigned)
        for i, m in enumerate(self.seen.measurements):
            self.last_seen[i, m.valid] = frame.t

    def _reward(self, action: np.ndarray, oracle: np.ndarray) -> np.ndarray:
        w = self.reward
        per_s = np.where(
            oracle >= IMMINENT,
            np.where(action >= IMMINENT, w.timely, -w.missed),
            np.where(
                action >= IMMINENT,
                -w.false_alarm,
                np.where((action == CAUTION) & (oracle == NONE), -w.nuisance, 0.0),
            ),
        )
        return per_s * self.dt

    def d_imminent(self) -> np.ndarray:
        """The imminent safety distance of the fused estimate (NaN without a track)."""
        est = self.seen.estimates["federated"]
        _, d = safety_distances(
            self.config.warning.model,
            np.maximum(self.seen.v_ego, 0.0),
            np.where(est.valid, est.x[:, 1], 0.0),
            np.where(est.valid, est.x[:, 2], 0.0),
            self.config.warning.params,
        )
        return np.where(est.valid, d, np.nan)

    def observe(self, collided: np.ndarray) -> tuple[np.ndarray, dict]:
        """Observations ``(n, 16)`` and the info arrays."""
        p, est = self.seen, self.seen.estimates["federated"]
        valid = est.valid
        std = np.sqrt(np.clip(np.diagonal(est.p, axis1=1, axis2=2), 0.0, None))
        x = np.where(valid[:, None], est.x, [NO_TRACK_GAP, 0.0, 0.0])
        std = np.where(valid[:, None], std, 0.0)
        nis = np.where(np.isfinite(est.nis), np.minimum(est.nis, NIS_CLIP), 0.0)
        age = np.minimum(p.frame.t - self.last_seen, AGE_CLIP)
        sensors = []
        for i, m in enumerate(p.measurements):
            sensors += [m.valid, est.isolated[:, i], nis[:, i], age[i]]
        obs = np.column_stack([x, std, np.maximum(p.v_ego, 0.0), valid, np.column_stack(sensors)])
        obs = np.clip(obs, _LOW, _HIGH).astype(np.float32)
        info = {
            "t": np.full(self.n, p.frame.t),
            "oracle": p.oracle.astype(np.int64),
            "ttc": p.ttc.astype(float),
            "ego_speed": p.frame.ego_speed.copy(),
            "gap_true": np.where(p.frame.has_leader, p.frame.gap, np.nan),
            "collided": collided.copy(),
            "active": self.source.active.copy(),
        }
        return obs, info


class CollisionWarningVectorEnv(gym.vector.VectorEnv):
    """``num_envs`` copies of :class:`CollisionWarningEnv` stepped with array arithmetic.

    Every copy's truth, sensors, filters, oracle and driver live in arrays over the copies
    (one batched simulation, not ``num_envs`` Python environments), so a step of 1 024 copies
    costs a few milliseconds.  Autoreset follows gymnasium's default ``NEXT_STEP`` mode: the
    step after a copy terminates or truncates ignores its action and returns the first
    observation of a new run (reward 0, not terminated).

    >>> import gymnasium as gym, acc_fusion
    >>> envs = gym.make_vec("acc_fusion/CollisionWarning-v0", num_envs=8,
    ...                     vectorization_mode="vector_entry_point")
    >>> obs, info = envs.reset(seed=0)
    >>> obs.shape
    (8, 16)
    """

    metadata = {"render_modes": [], "autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        source: str = "scripted",
        scenario: str = "random",
        config: SimConfig | None = None,
        reward: RewardConfig | None = None,
        max_episode_steps: int = 1200,
        render_mode: str | None = None,
    ) -> None:
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ConfigError(f"num_envs must be a whole number >= 1, got {num_envs!r}")
        if render_mode is not None:
            raise ConfigError("the vector environment does not render; use CollisionWarningEnv")
        single = CollisionWarningEnv(source, scenario, config, reward, None, max_episode_steps)
        self.num_envs = num_envs
        self.scenario, self.config = scenario, single.config
        self.reward_config, self.max_episode_steps = single.reward_config, max_episode_steps
        self.single_observation_space = single.observation_space
        self.single_action_space = single.action_space
        self.observation_space = gym.vector.utils.batch_space(
            self.single_observation_space, num_envs
        )
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, num_envs)
        self.render_mode = None
        self._core: _Core | None = None
        self._needs_reset = np.zeros(num_envs, dtype=bool)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(seed)
        self._core = _Core(
            self.num_envs, self.scenario, self.config, self.reward_config, self.np_random
        )
        self._needs_reset[:] = False
        return self._core.observe(np.zeros(self.num_envs, dtype=bool))

    def step(self, actions):
        if self._core is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        actions = np.asarray(actions)
        if actions.shape != (self.num_envs,) or not np.isin(actions, (0, 1, 2)).all():
            raise gym.error.InvalidAction(
                f"actions must be an array of {self.num_envs} values in {{0, 1, 2}}, "
                f"got shape {actions.shape}"
            )
        core, restart = self._core, self._needs_reset.copy()
        actions = np.where(restart, NONE, actions).astype(np.int8)
        reward = core.act(actions, restart, self.np_random)
        terminated = (core.collided | core.ended) & ~restart
        truncated = ~terminated & ~restart & (core.steps >= self.max_episode_steps)
        self._needs_reset = terminated | truncated
        obs, info = core.observe(core.collided & ~restart)
        return obs, reward, terminated, truncated, info
