"""A gymnasium environment for testing collision-warning policies."""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.levels import CAUTION, IMMINENT, NONE
from acc_fusion.core.plots import warning_frame
from acc_fusion.core.validation import check_choice, check_range
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.sim.closed_loop import Perception, SimConfig
from acc_fusion.truth.driver import Driver
from acc_fusion.truth.frame import TruthFrame
from acc_fusion.truth.highway.source import HighwayConfig, HighwaySource, load_highway_env
from acc_fusion.truth.manoeuvres import SCENARIOS
from acc_fusion.truth.scripted import make_scenario
from acc_fusion.truth.sumo.nets import resolve_sumocfg
from acc_fusion.truth.sumo.source import SumoConfig, SumoError, SumoSource, check_sumocfg
from acc_fusion.warning.safety import safety_distances

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
#: Truth sources of the environment.
SOURCES = ("scripted", "sumo", "highway")
#: The sources simulated by an external traffic simulator, and their options' classes.
EXTERNAL_SOURCES = ("sumo", "highway")
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


#: Window of simulated time after an episode's start [s] in which the leader's emergency
#: braking of :attr:`SumoOptions.lead_hazard` is drawn (uniformly).
LEAD_HAZARD_WINDOW = (2.0, 20.0)


@dataclass(frozen=True)
class SumoOptions:
    """Settings of the ``sumo`` source (validated on construction; SI units).

    The source runs one SUMO simulation (libsumo) for the environment's lifetime; an episode
    follows one equipped vehicle of it (see :class:`CollisionWarningEnv`).

    Attributes:
        net: a bundled network of ``sumo_nets`` (``motorway``, ``onramp``, ``ring``,
            ``arterial``); ``None``: ``motorway`` unless ``sumocfg`` is given.
        sumocfg: path of a user's ``.sumocfg`` instead of ``net``; ``None``.
        end: simulated seconds of each simulation from its begin time; ``None``: the file's
            end (3600 s for the bundled networks).  A simulation that ends is restarted with
            the next seed.
        warmup: simulated seconds run after each (re)start before the first episode, so that
            the traffic builds up [s]; 60.
        penetration: fraction of the vehicles equipped with FCW, in (0, 1]: the vehicles an
            episode can follow; 0.1.
        inattentive: fraction of the equipped drivers with a late reaction (SUMO's action step
            of 1.5 s, :attr:`acc_fusion.truth.sumo.source.SumoConfig.inattentive`), in [0, 1]:
            without
            them SUMO's drivers never need a warning; 1.0.
        lead_hazard: probability, per episode, that the ego's leader brakes at
            ``hazard_decel`` for ``hazard_duration`` at a time drawn uniformly in
            :data:`LEAD_HAZARD_WINDOW`, in [0, 1]; 0.5.
        hazard_rate: emergency brakings of randomly drawn vehicles per vehicle-hour
            (:attr:`acc_fusion.truth.sumo.source.SumoConfig.hazard_rate`); 0.
        hazard_decel: deceleration of an emergency braking [m/s²]; 8.0.
        hazard_duration: duration of an emergency braking [s]; 3.0.
        capacity: maximum number of equipped vehicles tracked at once; 256.
    """

    net: str | None = None
    sumocfg: str | None = None
    end: float | None = None
    warmup: float = 60.0
    penetration: float = 0.1
    inattentive: float = 1.0
    lead_hazard: float = 0.5
    hazard_rate: float = 0.0
    hazard_decel: float = 8.0
    hazard_duration: float = 3.0
    capacity: int = 256

    def __post_init__(self) -> None:

        if self.net is not None and self.sumocfg is not None:
            raise ConfigError("give one of sumo.net and sumo.sumocfg, not both")
        net = "motorway" if self.net is None and self.sumocfg is None else self.net
        path = check_sumocfg(resolve_sumocfg(net, self.sumocfg))
        object.__setattr__(self, "_path", str(path))
        check_range("sumo.warmup", self.warmup, 0.0, 86400.0)
        check_range("sumo.penetration", self.penetration, 0.0, 1.0, lo_open=True)
        check_range("sumo.lead_hazard", self.lead_hazard, 0.0, 1.0)
        self.sumo_config(seed=0, dt=0.05)  # the SumoConfig checks the rest, naming the field

    @property
    def name(self) -> str:
        """The network's name (the ``.sumocfg``'s stem for a user's file)."""
        return self.net or Path(self._path).stem

    def sumo_config(self, seed: int, dt: float):
        """The :class:`acc_fusion.truth.sumo.source.SumoConfig` of a simulation with SUMO seed
        ``seed`` and
        step ``dt`` [s] (the environment's step)."""

        try:
            return SumoConfig(
                sumocfg=self._path,
                end=self.end,
                penetration=self.penetration,
                seed=seed,
                capacity=self.capacity,
                step_length=dt,
                hazard_rate=self.hazard_rate,
                hazard_decel=self.hazard_decel,
                hazard_duration=self.hazard_duration,
                inattentive=self.inattentive,
            )
        except ConfigError as exc:
            raise ConfigError(f"sumo.{exc}") from None


#: highway-env config entries that :class:`HighwayOptions` sets itself or that would give the
#: environment more than one ego.
HIGHWAY_RESERVED = ("controlled_vehicles", "duration", "simulation_frequency", "vehicles_count")


@dataclass(frozen=True)
class HighwayOptions:
    """Settings of the ``highway`` source (validated on construction; SI units).

    The source runs one highway-env environment for the environment's lifetime
    (:class:`acc_fusion.truth.highway.source.HighwaySource`); an episode is one highway-env episode
    whose
    controlled vehicle is the ego (see :class:`CollisionWarningEnv`).

    Attributes:
        env: highway-env environment id, one of :data:`acc_fusion.truth.highway.source.SUPPORTED`;
            ``"highway-fast-v0"`` (3 lanes, 20 vehicles: about three times cheaper per step
            than ``highway-v0`` and as rich in threats).
        duration: seconds per episode [s]; ``None``: the environment's (30 s in
            ``highway-fast-v0``, 40 s in ``highway-v0``).
        vehicles_count: highway-env's uncontrolled vehicles; ``None``: the environment's.
        simulation_frequency: highway-env's simulation frequency [Hz], whose inverse is the
            environment's step ``dt`` (the sensors need it fine: highway-env's 5 Hz of
            ``highway-fast-v0`` is too coarse); 15.
        lookahead: leaders farther than this are not reported [m]; 250.
        env_config: further highway-env config entries (e.g. ``{"lanes_count": 2}``), checked
            against the environment's config when the source opens; not the entries of
            :data:`HIGHWAY_RESERVED`; {}.
    """

    env: str = "highway-fast-v0"
    duration: float | None = None
    vehicles_count: int | None = None
    simulation_frequency: int = 15
    lookahead: float = 250.0
    env_config: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        f = self.simulation_frequency
        if isinstance(f, bool) or not isinstance(f, (int, np.integer)) or not 5 <= f <= 1000:
            raise ConfigError(
                f"highway.simulation_frequency must be a whole number in [5, 1000] Hz, got {f!r}"
            )
        if isinstance(self.env_config, Mapping):
            taken = sorted(set(self.env_config) & set(HIGHWAY_RESERVED))
            if taken:
                raise ConfigError(
                    f"highway.env_config must not set {taken[0]!r}: the environment follows "
                    "one controlled vehicle; use the options' own fields for the others"
                )
        cfg = self.highway_config(seed=0)  # the HighwayConfig checks the rest, naming the field
        object.__setattr__(self, "env_config", cfg.env_config)

    @property
    def dt(self) -> float:
        """The environment's step [s]: 1 / ``simulation_frequency``."""
        return 1.0 / self.simulation_frequency

    def highway_config(self, seed: int):
        """The :class:`acc_fusion.truth.highway.source.HighwayConfig` of one episode from ``seed``
        with the
        controlled vehicle as the only pair."""

        try:
            return HighwayConfig(
                env=self.env,
                episodes=1,
                seed=seed,
                duration=self.duration,
                pairs="controlled",
                vehicles_count=self.vehicles_count,
                simulation_frequency=int(self.simulation_frequency),
                lookahead=self.lookahead,
                env_config=self.env_config,
            )
        except ConfigError as exc:
            raise ConfigError(f"highway.{exc}") from None


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

    A SUMO failure inside an episode (:class:`~acc_fusion.truth.sumo.source.SumoError`) ends it:
    ``step``
    returns the last observation with reward 0, ``truncated=True`` and the message in
    ``info["sumo_error"]`` (and warns); the next ``reset()`` restarts the simulation.  libsumo
    holds one simulation per process, so a second SUMO environment in the same process fails
    at its first reset with a :class:`~acc_fusion.truth.sumo.source.SumoError`.

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
        self._core = _Core(
            1, self.scenario, self.config, self.reward_config, self.np_random, source
        )
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


def _open_traffic(source: str, options, config: SimConfig) -> _SumoTraffic | _HighwayTraffic:
    """The external traffic of ``source`` (one of :data:`EXTERNAL_SOURCES`) from its
    ``options`` (the options' class, a mapping of its fields, or ``None``: the defaults) and
    the environment's ``config``; the simulator must be installed."""

    traffic = {"sumo": _SumoTraffic, "highway": _HighwayTraffic}[source]
    traffic.check_installed()
    cls = traffic.OPTIONS
    if options is None:
        options = cls()
    elif isinstance(options, Mapping):
        options = from_mapping(cls, options, prefix=f"{source}.")
    elif not isinstance(options, cls):
        raise ConfigError(
            f"{source} must be {cls.__name__} or a mapping, got {type(options).__name__}"
        )
    return traffic(options, config)


class _SlotView:
    """One slot of an external truth source of many pairs as the truth source of one pair,
    with the interface :class:`_Core` drives (``frame``, ``advance``, ``active``,
    ``collided``); time counts from the episode's start.  ``terminated`` / ``truncated``: the
    source ended the episode at this step (besides a collision or the ego leaving)."""

    terminated = truncated = False

    def __init__(self, sim, slot: int) -> None:
        self.sim, self.slot = sim, slot
        self.steps = 0

    @property
    def active(self) -> np.ndarray:
        """``(1,)``: the slot's vehicle still drives."""
        return self.sim.active[self.slot : self.slot + 1]

    @property
    def collided(self) -> np.ndarray:
        """``(1,)``: the ego ran into its leader (or another vehicle)."""
        return self.sim.collided[self.slot : self.slot + 1]

    def frame(self) -> TruthFrame:
        f, k = self.sim.frame(), slice(self.slot, self.slot + 1)
        return TruthFrame(
            t=self.steps * self.sim.dt,  # not f.t - t0: exact whatever the source's clock
            ego_speed=f.ego_speed[k],
            ego_accel=f.ego_accel[k],
            gap=f.gap[k],
            lead_speed=f.lead_speed[k],
            lead_accel=f.lead_accel[k],
            leader_id=f.leader_id[k],
            lateral_offset=f.lateral_offset[k],
        )

    def advance(self, ego_brake: np.ndarray | None = None) -> None:
        """One step of the source with the ego driver's brake request ``(1,)`` [m/s²]."""
        brake = np.zeros(self.sim.n_pairs)
        brake[self.slot] = 0.0 if ego_brake is None else ego_brake[0]
        self.sim.advance(brake)
        self.steps += 1


class _SumoEpisode(_SlotView):
    """One equipped vehicle of a running :class:`~acc_fusion.truth.sumo.source.SumoSource` (a
    :class:`_SlotView`); truncated when the simulation reaches its end.

    ``hazard_step``: the step after which the ego's leader starts an emergency braking
    (``None``: none).
    """

    def __init__(self, sim, slot: int, hazard_step: int | None) -> None:
        super().__init__(sim, slot)
        self.hazard_step = hazard_step
        self.vehicle_id = sim.vehicle_ids[slot]

    @property
    def active(self) -> np.ndarray:
        """``(1,)``: the ego is still in the network (in its slot)."""
        return np.array([self.sim.slot_of(self.vehicle_id) == self.slot])

    @property
    def truncated(self) -> bool:
        return self.sim.done

    def advance(self, ego_brake: np.ndarray | None = None) -> None:
        """One SUMO step with the ego driver's brake request ``(1,)`` [m/s²]."""
        if self.steps == self.hazard_step:
            leader = self.sim.leader_of(self.vehicle_id)
            if leader is not None:
                self.sim.inject_hazard(leader)
        super().advance(ego_brake)


class _HighwayEpisode(_SlotView):
    """The controlled vehicle of a :class:`~acc_fusion.truth.highway.source.HighwaySource` episode
    (a
    :class:`_SlotView`); highway-env ends the episode (a crash, the merge passed: terminated;
    its duration reached: truncated)."""

    def __init__(self, sim) -> None:
        super().__init__(sim, 0)

    @property
    def terminated(self) -> bool:
        return self.sim.terminated

    @property
    def truncated(self) -> bool:
        return self.sim.truncated


class _HighwayTraffic:
    """The highway source's simulation: one :class:`~acc_fusion.truth.highway.source.HighwaySource`
    (one
    highway-env environment) for the environment's lifetime, whose every reset starts a new
    highway-env episode from a seed drawn from the environment's generator."""

    OPTIONS = HighwayOptions
    #: A reset without a seed restarts highway-env too, so every episode can be seeded.
    reseeding_restarts = False

    @staticmethod
    def check_installed() -> None:

        load_highway_env()

    def __init__(self, options: HighwayOptions, config: SimConfig) -> None:

        self.options, self.name = options, options.env
        self.config = replace(config, dt=options.dt)  # the sensors run at highway-env's step
        self.sim = HighwaySource(options.highway_config(seed=0))
        self.starts = 0  # highway-env episodes started so far

    def next_episode(self, rng: np.random.Generator, restart: bool) -> _HighwayEpisode:
        """A new highway-env episode reset with a seed drawn from ``rng``."""
        self.sim.restart(np.ones(self.sim.n_pairs, dtype=bool), rng)
        self.starts += 1
        return _HighwayEpisode(self.sim)

    def close(self) -> None:
        self.sim.close()


class _SumoTraffic:
    """The sumo source's simulation: one :class:`~acc_fusion.truth.sumo.source.SumoSource` for the
    environment's lifetime, started lazily (the first ``reset``), restarted only when it
    ends, fails, or a seeded reset asks for it."""

    OPTIONS = SumoOptions
    #: A seeded reset restarts the long-running simulation (seed the first reset only).
    reseeding_restarts = True
    #: Attempts at (re)starting SUMO and finding an ego before a reset gives up.
    ATTEMPTS = 3

    @staticmethod
    def check_installed() -> None:
        import importlib.util

        if importlib.util.find_spec("libsumo") is None:
            raise ConfigError(
                "source 'sumo' needs eclipse-sumo and libsumo: pip install 'acc_fusion[sumo]'"
            )

    def __init__(self, options: SumoOptions, config: SimConfig) -> None:
        self.options, self.name = options, options.name
        self.config, self.dt = config, config.dt  # SUMO runs at the environment's step
        self.sim = None
        self.starts = 0  # simulations started so far
        self._followed: set[str] = set()

    def next_episode(self, rng: np.random.Generator, restart: bool) -> _SumoEpisode:
        """The next equipped vehicle with a leader, drawn with ``rng`` (in a new simulation
        when ``restart``, or when none runs).  A simulation that fails on the way is
        restarted, at most :attr:`ATTEMPTS` times in all; a load failure is raised at once."""
        attempt = 1
        while True:
            if restart or self.sim is None or self.sim.closed or self.sim.done:
                self._start(rng)
            try:
                return self._pick(rng)
            except SumoError:
                if attempt == self.ATTEMPTS:
                    raise
                attempt, restart = attempt + 1, True

    def _start(self, rng: np.random.Generator) -> None:

        self.close()
        self.sim = SumoSource(self.options.sumo_config(int(rng.integers(2**31)), self.dt))
        self.starts += 1
        self._followed = set()
        self._warmup = int(math.ceil(self.options.warmup / self.sim.dt - 1e-9))

    def _pick(self, rng: np.random.Generator) -> _SumoEpisode:
        """Warm up a new simulation, then advance it until a vehicle not followed yet has a
        leader; a simulation that ends on the way is restarted with the next seed."""
        fresh = not self._followed
        while True:
            sim = self.sim
            if self._warmup > 0 and not sim.done:
                self._warmup -= 1
                sim.advance()
                continue
            ids = sim.vehicle_ids
            slots = np.flatnonzero(sim.active & sim.frame().has_leader)
            slots = [s for s in slots if ids[s] not in self._followed]
            if slots:
                slot = int(slots[rng.integers(len(slots))])
                self._followed.add(ids[slot])
                hazard = None
                if rng.random() < self.options.lead_hazard:
                    hazard = int(round(rng.uniform(*LEAD_HAZARD_WINDOW) / self.dt))
                return _SumoEpisode(sim, slot, hazard)
            if sim.done:
                if fresh:
                    raise ConfigError(
                        f"no equipped vehicle with a leader in SUMO simulation "
                        f"{sim.config.sumocfg!r} before its end at t = {sim.t:g} s (raise "
                        "sumo.penetration or sumo.end)"
                    )
                self._start(rng)
                fresh = True
                continue
            sim.advance()

    def close(self) -> None:
        if self.sim is not None:
            self.sim.close()
            self.sim = None


def _single(info: dict) -> dict:
    """The info of copy 0 of a batched info dict, as plain Python values."""
    return {k: v[0].item() if isinstance(v, np.ndarray) else v for k, v in info.items()}


class _Core:
    """The simulation behind the environments, batched over ``n`` copies (array arithmetic).

    Each copy is one run of the scenario: truth source, sensors, ego-motion filter, the
    federated fusion center, the oracle and the driver, all over arrays of ``n`` pairs.
    ``source`` replaces the scripted scenario by another truth source of ``n`` pairs (the
    SUMO or highway-env episode, a :class:`_SlotView`).
    """

    def __init__(self, n, scenario, config, reward, rng: np.random.Generator, source=None):
        root = np.random.SeedSequence(int(rng.integers(2**63)))
        s_source, s_perception, s_driver = root.spawn(3)
        self.n, self.config, self.reward = n, config, reward
        self.dt = config.dt
        if source is None:
            source = make_scenario(scenario, n, seed=np.random.default_rng(s_source), dt=self.dt)
        self.source = source
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
