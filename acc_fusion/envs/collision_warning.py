"""A gymnasium environment for testing collision-warning policies."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.levels import NONE
from acc_fusion.core.plots import warning_frame
from acc_fusion.core.validation import check_choice
from acc_fusion.envs.core import _check_step, _Core, _single
from acc_fusion.envs.observation import _HIGH, _LOW
from acc_fusion.envs.options import (
    EXTERNAL_SOURCES,
    SOURCES,
    HighwayOptions,
    RewardConfig,
    SumoOptions,
)
from acc_fusion.envs.traffic import _HighwayTraffic, _open_traffic, _SumoTraffic
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.truth.manoeuvres import SCENARIOS
from acc_fusion.truth.sumo.config import SumoError


class CollisionWarningEnv(gym.Env):
    """Decide, every step, which forward-collision warning the driver hears.

    ## Description

    An equipped ego vehicle follows a lead vehicle, from a truth source: by default
    (``source="scripted"``) one scripted scenario (the randomised suite of
    :mod:`acc_fusion.truth.scripted`: NHTSA and Euro NCAP test manoeuvres, cut-ins, cut-outs,
    stop-and-go, steady following); with ``source="sumo"`` one equipped vehicle in SUMO
    traffic (see *The SUMO source*); with ``source="highway"`` the controlled vehicle of a
    highway-env episode (see *The highway source*).  A radar (20 Hz) and an infrared camera
    (10 Hz) measure the lead; their local Kalman filters and the federated fusion center (with fault
    detection) estimate its motion; the policy sees what the fusion center knows and chooses
    the warning.  The simulated driver reacts to an imminent alert after his reaction time and
    brakes (closed loop).  The oracle, the same warning rule evaluated on ground truth, judges
    the alerts.

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

    Drawn with the environment's random generator ``self.np_random``: the scenario run (the
    manoeuvre and its parameters) or, for SUMO, the followed vehicle, or, for highway-env,
    the seed of its episode; the sensor noise and the driver.  The same seed gives the same episode.

    ## Episode End

    Terminated on a collision or when the scenario's run ends (the ego stopped, the threat
    passed, or its duration ran out; SUMO: the ego left the network); truncated after
    ``max_episode_steps`` steps, and for SUMO when the simulation reaches its end or fails.
    highway: terminated when highway-env terminates its episode (the controlled vehicle
    crashed, into its leader or otherwise; ``merge-v0``: the merge passed), truncated when its
    ``duration`` is reached.

    ## The SUMO source

    ``source="sumo"`` runs one SUMO simulation (libsumo, in-process) for the environment's
    lifetime, set by ``sumo`` (:class:`SumoOptions`: the network, the fraction of equipped
    vehicles, inattentive drivers, the leader's emergency brakings).  An episode follows one
    equipped vehicle, drawn among those that have a leader, until it leaves the network,
    collides, or the step limit; its driver hears the policy's warnings and brakes (the
    vehicle is commanded through SUMO).  ``reset()`` picks the next equipped vehicle in the
    running simulation (advancing SUMO until one has a leader; a vehicle is followed once),
    so SUMO is not restarted per episode: only when the simulation ends (restarted with the
    next seed drawn from ``self.np_random``), after a SUMO failure, and on ``reset(seed=s)``,
    which starts the simulation afresh from ``s`` so that the same seed gives the same episode
    (Gymnasium's rule).  Seed the first reset of a series of episodes only
    (:func:`acc_fusion.envs.evaluation.evaluate` does so for this source:
    :attr:`reseeding_restarts`).  Time in the observations' info restarts at 0 each episode.

    A SUMO failure inside an episode (:class:`~acc_fusion.truth.sumo.config.SumoError`) ends it:
    ``step``
    returns the last observation with reward 0, ``truncated=True`` and the message in
    ``info["sumo_error"]`` (and warns); the next ``reset()`` restarts the simulation.  libsumo
    holds one simulation per process, so a second SUMO environment in the same process fails
    at its first reset with a :class:`~acc_fusion.truth.sumo.config.SumoError`.

    ## The highway source

    ``source="highway"`` runs one highway-env environment
    (:class:`acc_fusion.truth.highway.source.HighwaySource`) for the environment's lifetime, set by
    ``highway`` (:class:`HighwayOptions`: the highway-env id, default ``highway-fast-v0``, the
    episode duration, the traffic density, the simulation frequency).  Every ``reset()``
    starts a new highway-env episode, reset with a seed drawn from ``self.np_random`` (so
    ``reset(seed=s)`` repeats an episode and every reset may be seeded); no highway-env
    environment is built after the first.  The ego is the controlled vehicle, stepped at
    highway-env's simulation frequency (15 Hz: the environment's ``dt`` is 1/15 s, replacing
    ``config.dt``); it holds its lane and speed whatever is ahead (an inattentive driver) until
    the simulated driver brakes for an imminent alert.  Needs highway-env
    (``pip install 'acc_fusion[highway]'``).

    ## Arguments

    ``source`` (``"scripted"``, ``"sumo"`` or ``"highway"``),
    ``scenario`` (a name of :data:`acc_fusion.truth.manoeuvres.SCENARIOS`; scripted source only),
    ``config`` (:class:`acc_fusion.sim.closed_loop.SimConfig`: sensors, fusion, warning model,
    driver, and
    the step ``dt``, which SUMO then runs at; highway-env sets its own), ``reward``
    (:class:`RewardConfig`), ``render_mode`` (``None`` or ``"rgb_array"``),
    ``max_episode_steps``, ``sumo`` (:class:`SumoOptions` or a mapping of its fields; sumo
    source only), ``highway`` (:class:`HighwayOptions` or a mapping of its fields; highway
    source only).

    ## Vectorized environment

    The scripted source has a native vector environment, :class:`CollisionWarningVectorEnv`
    (``gym.make_vec(..., vectorization_mode="vector_entry_point")``).  The SUMO source
    vectorises with one simulation per process: ``gym.make_vec(...,
    vectorization_mode="async", source="sumo", vector_kwargs={"context": "spawn"})``.  The
    highway source vectorises with one highway-env environment per copy:
    ``gym.make_vec(..., vectorization_mode="sync", source="highway")`` (or ``"async"``).

    ## Example

    >>> import gymnasium as gym, acc_fusion
    >>> env = gym.make("acc_fusion/CollisionWarning-v0")
    >>> obs, info = env.reset(seed=1)
    >>> obs.shape
    (16,)
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}
    #: The simulation behind the environment (a subclass adds to what a step does).
    _core_class = _Core

    def __init__(
        self,
        source: str = "scripted",
        scenario: str = "random",
        config: SimConfig | None = None,
        reward: RewardConfig | None = None,
        render_mode: str | None = None,
        max_episode_steps: int = 1200,
        sumo: SumoOptions | dict | None = None,
        highway: HighwayOptions | dict | None = None,
    ) -> None:
        check_choice("source", source, SOURCES)
        check_choice("scenario", scenario, tuple(SCENARIOS))
        if render_mode is not None:
            check_choice("render_mode", render_mode, tuple(self.metadata["render_modes"]))
        if not isinstance(max_episode_steps, int) or max_episode_steps < 1:
            raise ConfigError(
                f"max_episode_steps must be a whole number >= 1, got {max_episode_steps!r}"
            )
        self._traffic: _SumoTraffic | _HighwayTraffic | None = None
        given = {"sumo": sumo, "highway": highway}
        for name, value in given.items():
            if value is not None and name != source:
                raise ConfigError(f"{name} options apply to source {name!r}, not {source!r}")
        if source in EXTERNAL_SOURCES:
            if scenario != "random":
                hint = {
                    "sumo": "its network (sumo={'net': ...})",
                    "highway": "highway-env (highway={'env': ...})",
                }[source]
                raise ConfigError(
                    f"scenario {scenario!r} applies to the scripted source; the {source} "
                    f"source's traffic comes from {hint}"
                )
            self.config = config or SimConfig(runs=1, methods=("federated",))
            self._traffic = _open_traffic(source, given[source], self.config)
            self.config = self._traffic.config
            scenario = self._traffic.name
        else:
            self.config = config or SimConfig(scenario=scenario, runs=1, methods=("federated",))
        self.source_name, self.scenario = source, scenario
        #: Whether ``reset(seed=...)`` restarts a long-running simulation (the sumo source).
        self.reseeding_restarts = bool(getattr(self._traffic, "reseeding_restarts", False))
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
        self._core = None
        source = None
        if self._traffic is not None:
            source = self._traffic.next_episode(self.np_random, restart=seed is not None)
        self._core = self._core_class(
            1, self.scenario, self.config, self.reward_config, self.np_random, source
        )
        self._history = []
        obs, info = self._core.observe(np.zeros(1, dtype=bool))
        return obs[0], _single(info)

    def step(self, action):
        _check_step(self._core is not None, action, self.action_space)
        core = self._core
        level = int(np.asarray(action).reshape(-1)[0])  # the warning (first entry)
        self._history.append((core.t, core.fused_gap[0], core.d_imminent()[0], level))
        del self._history[:-400]
        try:
            reward = core.act(np.array([action], dtype=np.int8))
        except SumoError as exc:
            self._core = None  # the episode is over; reset() restarts the simulation
            warnings.warn(f"{exc}; the next reset() restarts it", RuntimeWarning, stacklevel=2)
            obs, info = core.observe(np.zeros(1, dtype=bool))
            return obs[0], 0.0, False, True, {**_single(info), "sumo_error": str(exc)}
        terminated = core.collided | core.ended
        truncated = core.steps >= self.max_episode_steps
        if self._traffic is not None:  # the external source's own end of the episode
            terminated |= core.source.terminated
            truncated |= core.source.truncated
        truncated &= ~terminated
        obs, info = core.observe(core.collided)
        return obs[0], float(reward[0]), bool(terminated[0]), bool(truncated[0]), _single(info)

    def render(self):
        if self.render_mode != "rgb_array":
            return None

        return warning_frame(self._history, self.scenario)

    @property
    def vehicle_id(self) -> str | None:
        """SUMO id of the vehicle the episode follows (sumo source; ``None`` otherwise)."""
        return getattr(self._core.source, "vehicle_id", None) if self._core else None

    @property
    def sumo_starts(self) -> int:
        """SUMO simulations started so far (sumo source; 0 otherwise)."""
        return self._traffic.starts if self.source_name == "sumo" else 0

    @property
    def highway_episodes(self) -> int:
        """highway-env episodes started so far (highway source; 0 otherwise)."""
        return self._traffic.starts if self.source_name == "highway" else 0

    def close(self):
        if self._traffic is not None:
            self._traffic.close()
        super().close()


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
    #: The single environment it batches.
    _single_class = CollisionWarningEnv

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
        if source == "sumo":
            raise ConfigError(
                "the native vector environment runs the scripted source; vectorise the sumo "
                "source with one simulation per process: gym.make_vec(..., "
                "vectorization_mode='async', source='sumo')"
            )
        if source == "highway":
            raise ConfigError(
                "the native vector environment runs the scripted source; vectorise the highway "
                "source with one highway-env environment per copy: gym.make_vec(..., "
                "vectorization_mode='sync' or 'async', source='highway')"
            )
        if render_mode is not None:
            raise ConfigError("the vector environment does not render; use CollisionWarningEnv")
        single = self._single_class(source, scenario, config, reward, None, max_episode_steps)
        self._core_class = single._core_class
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
        self._core = self._core_class(
            self.num_envs, self.scenario, self.config, self.reward_config, self.np_random
        )
        self._needs_reset[:] = False
        return self._core.observe(np.zeros(self.num_envs, dtype=bool))

    def step(self, actions):
        if self._core is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        actions = self._checked(np.asarray(actions))
        core, restart = self._core, self._needs_reset.copy()
        idle = restart.reshape((-1,) + (1,) * (actions.ndim - 1))
        actions = np.where(idle, NONE, actions).astype(np.int8)
        reward = core.act(actions, restart, self.np_random)
        terminated = (core.collided | core.ended) & ~restart
        truncated = ~terminated & ~restart & (core.steps >= self.max_episode_steps)
        self._needs_reset = terminated | truncated
        obs, info = core.observe(core.collided & ~restart)
        return obs, reward, terminated, truncated, info

    def _checked(self, actions: np.ndarray) -> np.ndarray:
        """``actions``, or gymnasium's error if they are not one warning level per copy."""
        if actions.shape != (self.num_envs,) or not _levels(actions):
            raise gym.error.InvalidAction(
                f"actions must be an array of {self.num_envs} values in {{0, 1, 2}}, "
                f"got shape {actions.shape}"
            )
        return actions


def _levels(actions: np.ndarray) -> bool:
    """Whether every action is a warning level 0, 1 or 2 (as ``np.isin(actions, (0, 1, 2))``,
    a sixth of its time on 1 024 copies)."""
    return bool(((actions == 0) | (actions == 1) | (actions == 2)).all())
