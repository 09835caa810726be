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
from acc_fusion.warning import CAUTION, IMMINENT, LEVEL_NAMES, NONE

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
        self._source = None
        self._history: list[tuple[float, float, float, int]] = []

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        root = np.random.SeedSequence(int(self.np_random.integers(2**63)))
        s_source, s_perception, s_driver = root.spawn(3)
        self._source = make_scenario(
            self.scenario, 1, seed=np.random.default_rng(s_source), dt=self.dt
        )
        self._perception = Perception(self.config, 1, s_perception)
        self._driver = Driver(1, self.config.driver, seed=np.random.default_rng(s_driver))
        self._steps = 0
        self._last_seen = np.full(len(SENSOR_NAMES), -np.inf)
        self._history = []
        self._perceive()
        return self._observation(), self._info(collided=False)

    def step(self, action):
        if self._source is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        if not self.action_space.contains(action):
            raise gym.error.InvalidAction(
                f"action must be 0, 1 or 2 (none, caution, imminent), got {action!r}"
            )
        action = int(action)
        oracle = int(self._seen.oracle[0])
        frame = self._seen.frame
        reward = self._reward(action, oracle)
        brake = self._driver.step(np.array([action], dtype=np.int8), frame)
        self._history.append(
            (frame.t, float(self._seen.estimates["federated"].gap[0]), self._d_imminent(), action)
        )
        del self._history[:-400]
        self._source.advance(brake)
        self._perception.advanced()
        self._steps += 1
        collided = bool(self._source.collided[0])
        if collided:
            reward -= self.reward_config.collision
        terminated = collided or self._source.done
        truncated = not terminated and self._steps >= self.max_episode_steps
        self._perceive()
        return self._observation(), float(reward), terminated, truncated, self._info(collided)

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        from acc_fusion.plots import warning_frame

        return warning_frame(self._history, self.scenario)

    # ------------------------------------------------------------------ internals
    def _perceive(self) -> None:
        frame = self._source.frame()
        self._seen = self._perception.step(frame, self._source.active)
        for i, m in enumerate(self._seen.measurements):
            if m.valid[0]:
                self._last_seen[i] = frame.t

    def _reward(self, action: int, oracle: int) -> float:
        w, dt = self.reward_config, self.dt
        if oracle >= IMMINENT:
            return (w.timely if action >= IMMINENT else -w.missed) * dt
        if action >= IMMINENT:
            return -w.false_alarm * dt
        if action == CAUTION and oracle == NONE:
            return -w.nuisance * dt
        return 0.0

    def _d_imminent(self) -> float:
        est = self._seen.estimates["federated"]
        if not est.valid[0]:
            return float("nan")
        _, d = safety_distances(
            self.config.warning.model,
            np.maximum(self._seen.v_ego, 0.0),
            est.x[:, 1],
            est.x[:, 2],
            self.config.warning.params,
        )
        return float(d[0])

    def _observation(self) -> np.ndarray:
        est, p = self._seen.estimates["federated"], self._seen
        valid = bool(est.valid[0])
        std = np.sqrt(np.clip(np.diag(est.p[0]), 0.0, None)) if valid else np.zeros(3)
        x = est.x[0] if valid else np.array([NO_TRACK_GAP, 0.0, 0.0])
        t = p.frame.t
        per_sensor = []
        for i, m in enumerate(p.measurements):
            nis = est.nis[0, i]
            per_sensor += [
                float(m.valid[0]),
                float(est.isolated[0, i]),
                min(float(nis), NIS_CLIP) if np.isfinite(nis) else 0.0,
                min(t - self._last_seen[i], AGE_CLIP),
            ]
        obs = np.array([*x, *std, max(float(p.v_ego[0]), 0.0), float(valid), *per_sensor])
        return np.clip(obs, _LOW, _HIGH).astype(np.float32)

    def _info(self, collided: bool) -> dict:
        p = self._seen
        return {
            "t": float(p.frame.t),
            "oracle": int(p.oracle[0]),
            "oracle_name": LEVEL_NAMES[int(p.oracle[0])],
            "ttc": float(p.ttc[0]),
            "ego_speed": float(p.frame.ego_speed[0]),
            "gap_true": float(p.frame.gap[0]) if p.frame.has_leader[0] else float("nan"),
            "collided": collided,
            "active": bool(self._source.active[0]),
        }
