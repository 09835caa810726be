"""highway-env as a truth source: loading it (an optional dependency), the run's settings
(:class:`HighwayConfig`) and the environment they make (:func:`make_env`).

Episodes
    The source runs ``episodes`` highway-env episodes one after another; episode *k* is
    ``env.reset(seed=seed + k)``, so FCW off and FCW on runs see the same initial traffic.  An
    episode ends when highway-env terminates it (the controlled vehicle crashed; in
    ``merge-v0`` also when it has passed the merge) or after ``duration`` seconds.  That end
    frame is delivered (with its collision flags); the next :meth:`~HighwaySource.advance`
    starts the next episode and flags its slots in :attr:`~HighwaySource.reassigned`, so the
    FCW loop resets their filters, warning logic and driver.  Time :attr:`~HighwaySource.t`
    runs on across episodes (one step per reset), so the metrics see one timeline.

Reproducibility
    highway-env draws everything from ``env.np_random``, seeded by ``env.reset(seed=...)``; the
    source draws nothing, so a run is reproducible from its config.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.validation import check_choice, check_range

#: highway-env environments with a road carrying traffic that the source supports.
SUPPORTED = ("highway-v0", "highway-fast-v0", "merge-v0")


#: Which vehicles are egos: the controlled vehicles only, or every vehicle on the road.
PAIRS = ("controlled", "all")


#: How to install the optional dependency.
INSTALL = "pip install 'acc_fusion[highway]'"


#: Episode length [s] when neither the config nor the environment gives a ``duration``.
DEFAULT_DURATION = 40.0


class HighwayError(AccFusionError, RuntimeError):
    """The source was used out of order (advanced after it ended, rendered without
    ``render=True``) or highway-env changed its vehicles in a way the source does not follow."""


def load_highway_env() -> Any:
    """Import highway-env (registering its environments) and return the module.

    Raises:
        ConfigError: highway-env is not installed (the message gives the install command).
    """
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        import highway_env
    except ImportError:
        raise ConfigError(f"the highway backend needs highway-env: {INSTALL}") from None
    return highway_env


def _whole(name: str, value: object, low: int, high: int) -> int:
    """``value`` as an int in ``[low, high]`` (bools refused), else a ConfigError."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ConfigError(f"{name} must be a whole number, got {value!r}")
    if not low <= value <= high:
        raise ConfigError(f"{name} must be in [{low}, {high}], got {value!r}")
    return int(value)


@dataclass(frozen=True)
class HighwayConfig:
    """Settings of a :class:`HighwaySource` (validated on construction; SI units).

    Attributes:
        env: highway-env environment id, one of :data:`SUPPORTED`; ``"highway-v0"``.
        episodes: episodes run one after another; 10.
        seed: episode *k* is reset with seed ``seed + k``; 0.
        duration: seconds per episode [s]; ``None``: the environment's ``duration`` (40 s in
            ``highway-v0``, 30 s in ``highway-fast-v0``), else :data:`DEFAULT_DURATION`
            (``merge-v0``, which usually ends earlier when the ego has passed the merge).
        pairs: ``"all"`` (every vehicle is an ego; default) or ``"controlled"`` (only the
            controlled vehicles), see :data:`PAIRS`.
        vehicles_count: highway-env's ``vehicles_count`` (uncontrolled vehicles); ``None``
            keeps the environment's (50 in ``highway-v0``, 20 in ``highway-fast-v0``;
            ``merge-v0`` has a fixed population and refuses it).
        simulation_frequency: highway-env's ``simulation_frequency`` [Hz], the source's step
            is its inverse; ``None`` keeps the environment's (15 Hz, ``highway-fast-v0`` 5 Hz).
        lookahead: leaders farther than this are not reported [m]; 250 (long-range radar).
        env_config: further highway-env config entries (e.g. ``{"lanes_count": 3}``); keys
            must exist in the environment's ``default_config()`` (checked when the source
            opens); {}.
    """

    env: str = "highway-v0"
    episodes: int = 10
    seed: int = 0
    duration: float | None = None
    pairs: str = "all"
    vehicles_count: int | None = None
    simulation_frequency: int | None = None
    lookahead: float = 250.0
    env_config: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_choice("env", self.env, SUPPORTED)
        _whole("episodes", self.episodes, 1, 10_000_000)
        _whole("seed", self.seed, 0, 2**63 - 1)
        if self.duration is not None:
            check_range("duration", self.duration, 0.0, 1e6, lo_open=True)
        check_choice("pairs", self.pairs, PAIRS)
        if self.vehicles_count is not None:
            _whole("vehicles_count", self.vehicles_count, 0, 10_000)
        if self.simulation_frequency is not None:
            _whole("simulation_frequency", self.simulation_frequency, 1, 1000)
        check_range("lookahead", self.lookahead, 0.0, math.inf, lo_open=True, hi_open=True)
        if not isinstance(self.env_config, Mapping) or not all(
            isinstance(k, str) for k in self.env_config
        ):
            raise ConfigError(f"env_config must be a mapping of names, got {self.env_config!r}")
        object.__setattr__(self, "env_config", dict(self.env_config))

    def overrides(self) -> dict[str, Any]:
        """The highway-env config entries this config sets."""
        out = dict(self.env_config)
        if self.vehicles_count is not None:
            out["vehicles_count"] = int(self.vehicles_count)
        if self.simulation_frequency is not None:
            out["simulation_frequency"] = int(self.simulation_frequency)
        return out


def make_env(config: HighwayConfig, render: bool = False) -> Any:
    """The unwrapped highway-env environment of ``config``, configured (not yet reset with
    the episode seed).  ``render``: with the ``rgb_array`` renderer.

    Raises:
        ConfigError: highway-env is missing, or an override names no entry of the
            environment's config.
    """
    load_highway_env()
    import gymnasium as gym

    if render:
        _check_video_driver()
    with warnings.catch_warnings():  # merge-v0 is "out of date" (merge-v1 adds connected lanes)
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(config.env, render_mode="rgb_array" if render else None).unwrapped
    overrides = config.overrides()
    unknown = sorted(set(overrides) - set(env.config))
    if unknown:
        env.close()
        raise ConfigError(
            f"{config.env} has no config entry {unknown[0]!r}; its entries are "
            f"{', '.join(sorted(env.config))}"
        )
    env.configure(overrides)
    return env


def _check_video_driver() -> None:
    """highway-env's viewer draws nothing under SDL's ``dummy`` driver; SDL picks its
    ``offscreen`` driver by itself when there is no display."""
    if os.environ.get("SDL_VIDEODRIVER") == "dummy":
        raise ConfigError(
            "SDL_VIDEODRIVER=dummy makes highway-env render blank frames; unset it (or set "
            "it to 'offscreen') to render"
        )
