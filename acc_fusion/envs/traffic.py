"""The environment's traffic sources: one long SUMO simulation or highway-env run per process,
of which each episode takes one vehicle and its leader (a slot), restarted only when needed."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.envs.options import (
    LEAD_HAZARD_WINDOW,
    HighwayOptions,
    SumoOptions,
)
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.truth.frame import TruthFrame
from acc_fusion.truth.highway.config import load_highway_env
from acc_fusion.truth.highway.source import HighwaySource
from acc_fusion.truth.sumo.config import SumoError
from acc_fusion.truth.sumo.source import SumoSource


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
