"""A gymnasium environment on the 2-D object world (:class:`CollisionWarningWorldEnv`)."""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from dataclasses import replace

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_choice
from acc_fusion.envs.core import _check_step, _single, truth_info
from acc_fusion.envs.observation import (
    _WORLD_HIGH,
    _WORLD_LOW,
    NO_TRACK_GAP,
    track_entries,
)
from acc_fusion.envs.options import RewardConfig
from acc_fusion.metrics.summary import CAUSES
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.sim.world import WorldPerception, alert_cause
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.driver import Driver
from acc_fusion.truth.scenes import SCENES, SceneConfig, SceneSource

#: The fusion methods whose estimates the observation can show: those that fuse the radar
#: with the thermal camera, whose vehicle classification confirms stationary objects.
METHODS = ("centralized", "federated")
#: The ``scene`` that draws one of :data:`~acc_fusion.truth.scenes.SCENES` per episode.
RANDOM = "random"
#: The keys of ``reset(options=...)``.
RESET_OPTIONS = ("scene", "conditions")


def _conditions(value) -> tuple[Conditions, ...]:
    """``conditions`` as the tuple to draw from: one :class:`Conditions` or mapping of its
    fields, or a non-empty sequence of them."""
    items = [value] if isinstance(value, (Conditions, Mapping)) else value
    if isinstance(items, (str, bytes)) or not isinstance(items, Sequence) or not items:
        raise ConfigError(
            "conditions must be a Conditions, a mapping of its fields or a non-empty list of "
            f"them, got {value!r}"
        )
    out = []
    for item in items:
        if isinstance(item, Mapping):
            unknown = sorted(set(item) - set(Conditions.__dataclass_fields__))
            if unknown:
                raise ConfigError(f"conditions have no field {unknown[0]!r}")
            item = Conditions(**item)
        if not isinstance(item, Conditions):
            raise ConfigError(f"conditions must be Conditions or mappings, got {item!r}")
        out.append(item)
    return tuple(out)


class _SeenPerception(WorldPerception):
    """:class:`WorldPerception` that keeps, in ``seen``, what its selection saw at the last
    step: the method's :class:`~acc_fusion.fusion.base.Estimate` over the E·F object slots,
    the :class:`~acc_fusion.fusion.tracking.association.FusedObjects` and both sensors'
    :class:`~acc_fusion.fusion.tracking.tracker.Tracks`."""

    def _select(self, method, est, fused, tracks, *rest):
        # the tracks are views of the trackers' arrays (WorldPerception.step): keep a copy
        self.seen = (self.per_slot(est), fused, copy.deepcopy(tracks))
        return super()._select(method, est, fused, tracks, *rest)


class _Episode:
    """One run of a scene for one ego: the 2-D pipeline under one method, the oracle on the
    true in-path lead, the driver, and the per-slot memory the observation needs."""

    def __init__(self, config: SimConfig, reward: RewardConfig, rng: np.random.Generator):
        root = np.random.SeedSequence(int(rng.integers(2**63)))
        s_source, s_perception, s_driver = root.spawn(3)
        self.config, self.reward, self.dt = config, reward, config.dt
        self.method = config.methods[0]
        scene = SceneConfig(scene=config.world.scene, runs=1, dt=config.dt)
        self.source = SceneSource(scene, np.random.default_rng(s_source), config.world.map_path)
        self.perception = _SeenPerception(config, 1, s_perception)
        self.selector = self.perception.selectors[self.method]
        self.driver = Driver(1, config.driver, seed=np.random.default_rng(s_driver))
        slots = self.perception.slots
        self.object_id = np.full((1, slots), -1, dtype=np.int64)
        self.last_seen = np.full((len(SENSOR_NAMES), 1, slots), -np.inf)
        self.selected_id = np.full(1, -1, dtype=np.int64)
        self.selected_since = np.zeros(1)
        self.steps = 0
        self.collided = np.zeros(1, dtype=bool)
        self._perceive()

    def act(self, action: np.ndarray) -> np.ndarray:
        """Let the driver hear the warnings, advance one step; the rewards (the warnings
        judged against this step's oracle)."""
        brake = self.driver.step(action, self.lead)
        was = self.source.collided.copy()
        self.source.advance(brake)
        self.steps += 1
        self.collided = self.source.collided & ~was
        reward = self.reward.reward(action, self.level, self.collided, self.dt)
        self._perceive()
        return reward

    @property
    def terminated(self) -> np.ndarray:
        """A collision in the last step, or the scene's end."""
        return self.collided | self.source.done

    def _perceive(self) -> None:
        frame = self.source.frame()
        p = self.perception.step(frame, self.source.active)
        self.frame, self.truth_id, self.v_ego = frame, p.truth_id[self.method], p.v_ego
        self.lead, self.level, self.ttc, self.relevant = p.frame, p.oracle, p.ttc, p.relevant
        _, fused, tracks = self.perception.seen
        self.last_seen[:, fused.object_id != self.object_id] = -np.inf
        self.object_id = fused.object_id
        # a sensor measured an object when its track of it took a detection at this frame
        # (the measurement the estimators fused)
        self.reporting = np.empty(self.last_seen.shape, dtype=bool)
        for s, trk in enumerate(tracks):
            slot = fused.track[..., s]
            det = np.take_along_axis(trk.detection, np.maximum(slot, 0), axis=1)
            self.reporting[s] = fused.valid & (slot >= 0) & (det >= 0)
        self.last_seen[self.reporting] = frame.t
        sel = self.selector.selected
        rows = np.arange(sel.size)
        selected_id = np.where(sel >= 0, fused.object_id[rows, np.maximum(sel, 0)], -1)
        self.selected_since[selected_id != self.selected_id] = frame.t
        self.selected_id = selected_id

    def observe(self) -> tuple[np.ndarray, dict]:
        """The observation ``(1, 24)`` and the info arrays."""
        est, fused, _ = self.perception.seen
        sel, t, n = self.selector, self.frame.t, self.frame.n_egos
        rows, has = np.arange(n), sel.selected >= 0
        k = np.maximum(sel.selected, 0)
        flat = rows * fused.valid.shape[1] + k
        x = est.x[flat]
        entries = track_entries(
            x,
            est.p[flat],
            has,
            self.v_ego,
            self.reporting[:, rows, k] & has,
            est.isolated[flat] & has[:, None],
            np.where(has[:, None], est.nis[flat], np.nan),
            t - self.last_seen[:, rows, k],
        )
        gaps = np.where(sel.in_path, est.x[:, 0].reshape(fused.valid.shape), np.inf)
        second = np.sort(gaps, axis=1)[:, 1] if gaps.shape[1] > 1 else np.full(n, np.inf)
        world = np.column_stack(
            [
                np.where(has, sel.offset[rows, k], 0.0),
                np.where(has, fused.lateral[rows, k, 1], 0.0),
                np.where(has, self.v_ego + x[:, 1], 0.0),  # ground speed, as the selection's
                has & (fused.track[rows, k, fused.sensors.index("infrared")] >= 0),
                sel.in_path.sum(axis=1),
                np.where(np.isfinite(second), second, NO_TRACK_GAP),
                sel.curvature,
                t - self.selected_since,
            ]
        )
        obs = np.clip(np.column_stack([entries, world]), _WORLD_LOW, _WORLD_HIGH)
        info = truth_info(
            self.lead, self.level, self.ttc, self.relevant, self.collided, self.source.active
        )
        cause = np.asarray(CAUSES)[alert_cause(self.frame, self.truth_id)]
        info["cause"] = np.where(has, cause, "none")
        return obs.astype(np.float32), info


class CollisionWarningWorldEnv(gym.Env):
    r"""Decide, every step, which forward-collision warning the driver hears, in the 2-D world.

    ## Description

    An episode is one run of a scripted 2-D scene (:mod:`acc_fusion.truth.scenes`: a lead
    that brakes, an adjacent-lane car before a curve, a cut-in, a cut-out revealing a stopped
    car, a gantry on a crest, a car parked before a curve) under weather and light
    conditions.  The 2-D pipeline of :mod:`acc_fusion.sim.world` runs on it: a 77 GHz radar
    and a thermal camera detect every object ahead, a tracker per sensor and the
    track-to-track association make the object list, the fusion method (``method``,
    federated by default) estimates every object, and the in-path selection picks the object
    the warning judges.  The policy sees that selected object as the 1-D environment
    (:class:`~acc_fusion.envs.collision_warning.CollisionWarningEnv`) sees its lead, plus
    what the object list adds, and chooses the warning.  The oracle, the same warning rule on
    the true in-path lead, judges the alerts.

    The ego is the scene's attentive IDM driver behind its true in-path lead, and the 1-D
    environment's simulated driver (:class:`~acc_fusion.truth.driver.Driver`, settings
    ``config.driver``) hears the warnings: after his reaction time he brakes for an imminent
    alert, at least as hard as his deceleration, until he no longer closes on his true lead
    (closed loop; so an alert with no lead ahead costs no braking).  The attentive IDM leaves
    warnings little to prevent: the scenes have no distracted driver yet.

    ## Action Space

    ``Discrete(3)``: 0 no warning, 1 caution, 2 imminent.

    ## Observation Space

    ``Box(24,)`` float32, the entries named by
    :data:`acc_fusion.envs.observation.WORLD_OBS_FIELDS` (the first 16 are the 1-D
    environment's :data:`~acc_fusion.envs.observation.OBS_FIELDS`):

    | index | name               | meaning                               | unit | min  | max  |
    |-------|--------------------|---------------------------------------|------|------|------|
    | 0     | gap                | estimated gap (250: none selected)    | m    | 0    | 250  |
    | 1     | range_rate         | estimated range-rate                  | m/s  | -60  | 60   |
    | 2     | lead_accel         | estimated acceleration                | m/s² | -15  | 15   |
    | 3     | gap_std            | standard deviation of 0               | m    | 0    | 100  |
    | 4     | range_rate_std     | standard deviation of 1               | m/s  | 0    | 60   |
    | 5     | lead_accel_std     | standard deviation of 2               | m/s² | 0    | 30   |
    | 6     | ego_speed          | ego speed (ego-motion filter)         | m/s  | 0    | 70   |
    | 7     | track_valid        | 1 when an object is selected          | –    | 0    | 1    |
    | 8     | radar_reporting    | 1 when the radar measured it now      | –    | 0    | 1    |
    | 9     | radar_isolated     | 1 when the FDI isolates the radar     | –    | 0    | 1    |
    | 10    | radar_nis          | the radar's last NIS                  | –    | 0    | 100  |
    | 11    | radar_age          | time since the radar last measured it | s    | 0    | 10   |
    | 12-15 | infrared_…         | the thermal camera's, as 8-11         | –, s | 0    | as 8-11 |
    | 16    | lateral_offset     | lateral offset from the path          | m    | -20  | 20   |
    | 17    | lateral_speed      | fused lateral velocity (left +)       | m/s  | -10  | 10   |
    | 18    | ground_speed       | estimated ground speed                | m/s  | -70  | 70   |
    | 19    | confirmed          | 1 when the thermal camera tracks it   | –    | 0    | 1    |
    | 20    | in_path_count      | objects the selection could pick      | –    | 0    | 10   |
    | 21    | second_gap         | gap to the second of them (250: none) | m    | 0    | 250  |
    | 22    | path_curvature     | curvature of the predicted path       | 1/m  | -0.1 | 0.1  |
    | 23    | selection_age      | time since the selection changed      | s    | 0    | 10   |

    0-15 describe the selected object as the 1-D environment describes its lead (isolated: by
    the fault detection; age: seconds since the sensor's last measurement of the object).
    16: :math:`y - y_p(x)` of the selection (:mod:`acc_fusion.warning.selection`), ``x``
    and ``y`` the object's position in the ego frame, :math:`y_p` the predicted path, whose
    curvature at the ego is entry 22 (:mod:`acc_fusion.warning.path`).  18: ego speed +
    range-rate, the ground speed the selection judges stationary objects by.  19: the
    camera's vehicle classifier confirms the object (both sensors track it when the radar
    does too).  20: the objects in the corridor that the
    stationary policy admits, the selected one included.  23: seconds since the selected object
    last changed, appeared or was lost (0 at the change).

    Entries beyond their bounds are clipped.

    ## Rewards

    Those of the 1-D environment (:meth:`RewardConfig.reward`), judged against the oracle on
    the true in-path lead (:meth:`~acc_fusion.truth.objects.ObjectFrame.lead_frame`), which
    the driver watches too: an
    imminent warning on a parked car, a gantry or an adjacent vehicle while the true lead is
    no threat costs ``false_alarm`` per second.

    ## Starting State

    Drawn with ``self.np_random``: the scene when ``scene="random"``, the conditions when
    several are given, then the scene's run (its jitter), the sensor noise and the driver.
    The same seed gives the same episode.

    ## Episode End

    Terminated on a collision or when the scene's duration ends (8-14 s); truncated after
    ``max_episode_steps``.

    ## Arguments

    ``scene`` (a name of :data:`~acc_fusion.truth.scenes.SCENES`, or ``"random"``: one drawn
    per episode), ``conditions`` (a :class:`~acc_fusion.truth.conditions.Conditions`, a
    mapping of its fields, or a list of them to draw one per episode; ``None``:
    ``config.world.conditions``), ``method`` (one of :data:`METHODS`), ``config``
    (:class:`~acc_fusion.sim.closed_loop.SimConfig`: its ``world`` section sets the sensors,
    trackers, association and selection, its ``driver`` the driver, its ``warning`` the
    oracle; its scene and conditions are the episode's),
    ``reward`` (:class:`RewardConfig`), ``max_episode_steps``.  ``reset(options=...)`` takes
    ``scene`` and ``conditions`` in the same forms for that episode.

    ## Info

    The 1-D environment's (``t``, ``oracle``, ``ttc``, ``crash_relevant``, ``ego_speed``,
    ``gap_true``, ``collided``, ``active``), ``cause`` (what the selected object is in truth,
    one of :data:`acc_fusion.metrics.summary.CAUSES` other than ``noise``, which only a
    warning's class gives, or ``"none"``), ``scene`` and ``conditions`` (its label).

    ## Example

    >>> import gymnasium as gym, acc_fusion
    >>> env = gym.make("acc_fusion/CollisionWarningWorld-v0", scene="cut_out")
    >>> obs, info = env.reset(seed=1)
    >>> obs.shape, info["scene"]
    ((24,), 'cut_out')
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        scene: str = RANDOM,
        conditions: Conditions | Mapping | Sequence | None = None,
        method: str = "federated",
        config: SimConfig | None = None,
        reward: RewardConfig | None = None,
        max_episode_steps: int = 1200,
    ) -> None:
        if config is not None and not isinstance(config, SimConfig):
            raise ConfigError(f"config must be a SimConfig, got {type(config).__name__}")
        if reward is not None and not isinstance(reward, RewardConfig):
            raise ConfigError(f"reward must be a RewardConfig, got {type(reward).__name__}")
        if not isinstance(max_episode_steps, int) or max_episode_steps < 1:
            raise ConfigError(
                f"max_episode_steps must be a whole number >= 1, got {max_episode_steps!r}"
            )
        check_choice("method", method, METHODS)
        self.scene = check_choice("scene", scene, (RANDOM, *SCENES))
        self.config = replace(config or SimConfig(), runs=1, methods=(method,), drive=None)
        self.conditions = _conditions(
            self.config.world.conditions if conditions is None else conditions
        )
        self.method = method
        #: The labels :func:`acc_fusion.envs.evaluation.evaluate` gives its table.
        self.source_name, self.scenario = "world", scene
        self.reward_config = reward or RewardConfig()
        self.max_episode_steps = max_episode_steps
        self.dt = self.config.dt
        self.action_space = spaces.Discrete(3)
        self.observation_space = spaces.Box(
            _WORLD_LOW.astype(np.float32), _WORLD_HIGH.astype(np.float32), dtype=np.float32
        )
        self._episode: _Episode | None = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = sorted(set(options) - set(RESET_OPTIONS))
        if unknown:
            raise ConfigError(f"reset options are {RESET_OPTIONS}, got {unknown[0]!r}")
        scene = check_choice("scene", options.get("scene", self.scene), (RANDOM, *SCENES))
        drawn = _conditions(options["conditions"]) if "conditions" in options else self.conditions
        self._episode = None
        if scene == RANDOM:
            scene = str(self.np_random.choice(list(SCENES)))
        conditions = drawn[int(self.np_random.integers(len(drawn)))]
        world = replace(self.config.world, scene=scene, conditions=conditions)
        config = replace(self.config, world=world)
        self._episode = _Episode(config, self.reward_config, self.np_random)
        return self._observe()

    def step(self, action):
        _check_step(self._episode is not None, action, self.action_space)
        episode = self._episode
        reward = episode.act(np.array([action], dtype=np.int8))
        terminated = bool(episode.terminated[0])
        truncated = not terminated and episode.steps >= self.max_episode_steps
        obs, info = self._observe()
        return obs, float(reward[0]), terminated, truncated, info

    def _observe(self) -> tuple[np.ndarray, dict]:
        obs, info = self._episode.observe()
        world = self._episode.config.world
        info = {**_single(info), "scene": world.scene, "conditions": world.conditions.label}
        return obs[0], info
