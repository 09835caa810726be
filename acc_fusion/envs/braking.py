r"""A gymnasium environment in which the policy warns *and* brakes:
``acc_fusion/CollisionAvoidance-v0`` (:class:`CollisionAvoidanceEnv`, and its native vector
environment :class:`CollisionAvoidanceVectorEnv`).

It is :class:`~acc_fusion.envs.collision_warning.CollisionWarningEnv` on the scripted source
with two changes.

Action
    ``MultiDiscrete([3, 3])``: the warning level the driver hears (0 none, 1 caution, 2
    imminent, as in the warning environment) and a brake stage (0 none, 1 partial, 2 full).
    The stage commands the brake system of :mod:`acc_fusion.braking.aeb` (its dead time and
    build-up, its partial and full decelerations from ``config.aeb``); the ego brakes at the
    stronger of that and the warned driver's braking.

Observation
    ``Box(17,)``: the warning environment's 16 entries, then the deceleration the brakes
    produce now [m/s², 0-15] (:data:`BRAKING_OBS_FIELDS`).

Reward (:class:`BrakingRewardConfig`), from outcomes judged from truth:

.. math::

    r = -\Big(w_c + w_v\,v_\text{impact}\Big)\,[\text{collision}]
        - w_b\,\Delta t\,[\text{braking} \wedge \neg\text{relevant}]
        - w_n\,[\text{nuisance onset}] - w_s\,[\text{sensing-false onset}]

term by term: a collision costs :math:`w_c` plus :math:`w_v` per m/s of closing speed at
contact; every step of braking (a stage engaged) while the situation is not crash-relevant
in truth (:mod:`acc_fusion.metrics.alert_classes`) costs :math:`w_b` per second — a false
activation; and each onset of an imminent warning outside a crash-relevant situation costs
:math:`w_n` when the warning rule on truth fires too (a *nuisance* alert: the lead is real,
the situation not critical) or :math:`w_s` when it does not (*sensing-false*: the estimate was
wrong) — the alert classes of :mod:`acc_fusion.metrics.events`, judged at the onset.  No term
rewards a warning's timing: the policy learns when to warn and brake from what they avoid.
"""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from acc_fusion.braking.aeb import AEB
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.levels import IMMINENT
from acc_fusion.core.validation import check_range
from acc_fusion.envs.collision_warning import CollisionWarningEnv, CollisionWarningVectorEnv
from acc_fusion.envs.core import _Core
from acc_fusion.envs.observation import _HIGH, _LOW, OBS_FIELDS

#: The entries of the braking environment's observation.
BRAKING_OBS_FIELDS = (*OBS_FIELDS, "brake_decel")
#: Highest deceleration the observation reports [m/s²].
MAX_BRAKE_OBS = 15.0


@dataclass(frozen=True)
class BrakingRewardConfig:
    """Weights of the braking environment's reward (module docstring), all >= 0.

    Attributes:
        collision: cost of a collision (once; the episode ends); 100.
        impact: cost per m/s of closing speed at contact; 10.
        false_braking: cost per second of braking outside a crash-relevant situation; 5.
        nuisance: cost of an imminent warning's onset outside a crash-relevant situation,
            the rule on truth firing too; 2.
        sensing_false: cost of such an onset where the rule on truth does not fire; 5.
    """

    collision: float = 100.0
    impact: float = 10.0
    false_braking: float = 5.0
    nuisance: float = 2.0
    sensing_false: float = 5.0

    def __post_init__(self) -> None:
        for name in ("collision", "impact", "false_braking", "nuisance", "sensing_false"):
            check_range(f"reward.{name}", getattr(self, name), 0.0, 1e6)


class _BrakingCore(_Core):
    """:class:`~acc_fusion.envs.core._Core` whose actions are ``(n, 2)``: warning and brake
    stage; it keeps what the reward and the info need of every step."""

    def __init__(self, n, scenario, config, reward, rng, source=None):
        super().__init__(n, scenario, config, reward, rng, source)
        self.brakes = AEB(config.aeb, n, config.dt)
        self.warning = np.zeros(n, dtype=bool)
        self.events = self._no_events()

    def _no_events(self) -> dict[str, np.ndarray]:
        n = self.n
        return {"false_braking": np.zeros(n, bool), "nuisance_onset": np.zeros(n, bool),
                "sensing_false_onset": np.zeros(n, bool),
                "impact_speed": np.zeros(n)}  # fmt: skip

    def _brakes(self, action: np.ndarray) -> np.ndarray:
        level, stage = action[:, 0], action[:, 1]
        by_driver = self.driver.step(level, self.seen.frame)
        return np.maximum(by_driver, self.brakes.actuate(stage, self.source.active))

    def _reward(self, action: np.ndarray) -> np.ndarray:
        w, p = self.reward, self.seen
        warned = action[:, 0] >= IMMINENT
        onset, self.warning = warned & ~self.warning, warned
        calm = ~p.relevant
        impact = np.where(self.collided, self.source.collision_speed, 0.0)
        self.events = {
            "false_braking": (self.brakes.stage > 0) & calm,
            "nuisance_onset": onset & calm & (p.oracle >= IMMINENT),
            "sensing_false_onset": onset & calm & (p.oracle < IMMINENT),
            "impact_speed": impact,
        }
        e = self.events
        return (-(w.collision + w.impact * impact) * self.collided
                - w.false_braking * self.dt * e["false_braking"]
                - w.nuisance * e["nuisance_onset"]
                - w.sensing_false * e["sensing_false_onset"])  # fmt: skip

    def _restart(self, restart: np.ndarray) -> None:
        super()._restart(restart)
        self.brakes.reset(restart)
        self.warning[restart] = False
        for values in self.events.values():
            values[restart] = 0

    def observe(self, collided: np.ndarray) -> tuple[np.ndarray, dict]:
        obs, info = super().observe(collided)
        decel = np.minimum(self.brakes.decel, MAX_BRAKE_OBS)[:, None].astype(np.float32)
        info |= {k: v.copy() for k, v in self.events.items()}
        info |= {"brake_stage": self.brakes.stage.astype(np.int64), "brake_decel": decel[:, 0]}
        return np.hstack([obs, decel]), info


def _spaces() -> tuple[spaces.MultiDiscrete, spaces.Box]:
    low = np.append(_LOW, 0.0).astype(np.float32)
    high = np.append(_HIGH, MAX_BRAKE_OBS).astype(np.float32)
    return spaces.MultiDiscrete([3, 3]), spaces.Box(low, high, dtype=np.float32)


class CollisionAvoidanceEnv(CollisionWarningEnv):
    """Warn and brake, every step (module docstring); the scripted source only.

    Arguments as :class:`~acc_fusion.envs.collision_warning.CollisionWarningEnv`'s, ``reward``
    a :class:`BrakingRewardConfig`.  ``info`` adds, per step, ``false_braking`` (braking
    outside a crash-relevant situation), ``nuisance_onset`` and ``sensing_false_onset`` (an
    imminent warning's onset of that class), ``impact_speed`` (closing speed at a collision
    [m/s], 0 otherwise), ``brake_stage`` and ``brake_decel`` [m/s²].

    >>> import gymnasium as gym, acc_fusion
    >>> env = gym.make("acc_fusion/CollisionAvoidance-v0")
    >>> obs, info = env.reset(seed=1)
    >>> obs.shape, env.action_space
    ((17,), MultiDiscrete([3 3]))
    """

    _core_class = _BrakingCore

    def __init__(
        self,
        source: str = "scripted",
        scenario: str = "random",
        config=None,
        reward: BrakingRewardConfig | None = None,
        render_mode: str | None = None,
        max_episode_steps: int = 1200,
    ) -> None:
        if source != "scripted":
            raise ConfigError(f"the braking environment runs the scripted source, got {source!r}")
        reward = BrakingRewardConfig() if reward is None else reward
        if not isinstance(reward, BrakingRewardConfig):
            raise ConfigError(f"reward must be a BrakingRewardConfig, got {type(reward).__name__}")
        super().__init__(source, scenario, config, reward, render_mode, max_episode_steps)
        self.action_space, self.observation_space = _spaces()

    def step(self, action):
        action = np.asarray(action)
        if self._core is not None and not self.action_space.contains(action.astype(np.int64)):
            raise gym.error.InvalidAction(
                f"action must be [warning 0-2, brake stage 0-2], got {action.tolist()!r}"
            )
        return super().step(action.astype(np.int64))


class CollisionAvoidanceVectorEnv(CollisionWarningVectorEnv):
    """``num_envs`` copies of :class:`CollisionAvoidanceEnv` stepped with array arithmetic
    (as :class:`~acc_fusion.envs.collision_warning.CollisionWarningVectorEnv`); actions
    ``(num_envs, 2)``."""

    _single_class = CollisionAvoidanceEnv

    def _checked(self, actions: np.ndarray) -> np.ndarray:
        ok = actions.shape == (self.num_envs, 2) and np.isin(actions, (0, 1, 2)).all()
        if not ok:
            raise gym.error.InvalidAction(
                f"actions must be an array ({self.num_envs}, 2) of warnings and brake stages "
                f"in {{0, 1, 2}}, got shape {actions.shape}"
            )
        return actions
