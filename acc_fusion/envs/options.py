"""The options of the environment: the reward's weights (:class:`RewardConfig`) and the SUMO and
highway-env sources' settings (:class:`SumoOptions`, :class:`HighwayOptions`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.levels import CAUTION, IMMINENT, NONE
from acc_fusion.core.validation import check_range
from acc_fusion.truth.highway.config import HighwayConfig
from acc_fusion.truth.sumo.config import SumoConfig, check_sumocfg
from acc_fusion.truth.sumo.nets import resolve_sumocfg

#: Truth sources of the environment.
SOURCES = ("scripted", "sumo", "highway")


#: The sources simulated by an external traffic simulator, and their options' classes.
EXTERNAL_SOURCES = ("sumo", "highway")


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

    def reward(
        self, action: np.ndarray, oracle: np.ndarray, collided: np.ndarray, dt: float
    ) -> np.ndarray:
        """Rewards ``(n,)`` of one step of ``dt`` seconds: the warning ``action`` judged against
        the ``oracle``'s level at the step's start, and ``collided`` in the step (weights: the
        class docstring)."""
        per_s = np.where(
            oracle >= IMMINENT,
            np.where(action >= IMMINENT, self.timely, -self.missed),
            np.where(
                action >= IMMINENT,
                -self.false_alarm,
                np.where((action == CAUTION) & (oracle == NONE), -self.nuisance, 0.0),
            ),
        )
        return per_s * dt - self.collision * collided


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
            of 1.5 s, :attr:`acc_fusion.truth.sumo.config.SumoConfig.inattentive`), in [0, 1]:
            without
            them SUMO's drivers never need a warning; 1.0.
        lead_hazard: probability, per episode, that the ego's leader brakes at
            ``hazard_decel`` for ``hazard_duration`` at a time drawn uniformly in
            :data:`LEAD_HAZARD_WINDOW`, in [0, 1]; 0.5.
        hazard_rate: emergency brakings of randomly drawn vehicles per vehicle-hour
            (:attr:`acc_fusion.truth.sumo.config.SumoConfig.hazard_rate`); 0.
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
        """The :class:`acc_fusion.truth.sumo.config.SumoConfig` of a simulation with SUMO seed
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
        env: highway-env environment id, one of :data:`acc_fusion.truth.highway.config.SUPPORTED`;
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
        """The :class:`acc_fusion.truth.highway.config.HighwayConfig` of one episode from ``seed``
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
