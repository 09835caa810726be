"""The stepping shared by the single and the vector environment: the FCW pipeline over a batch
of episodes, the observation, the reward and the episode's end (:class:`_Core`)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from acc_fusion.envs.observation import track_entries
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.sim.closed_loop import Perception
from acc_fusion.truth.driver import Driver
from acc_fusion.truth.scripted import ScenarioSource, make_scenario
from acc_fusion.warning.safety import safety_distances

#: Runs of the scripted scenario drawn at a time for the copies' new episodes: a few copies end
#: at almost every step, and drawing a handful of runs costs about as much as drawing 256.
DRAW_BLOCK = 256


def _single(info: dict) -> dict:
    """The info of copy 0 of a batched info dict, as plain Python values."""
    return {k: v[0].item() if isinstance(v, np.ndarray) else v for k, v in info.items()}


def _check_step(started: bool, action, space) -> None:
    """Gymnasium's errors for a ``step(action)`` before ``reset()`` or with an ``action`` that
    is not in ``space`` (the warning levels)."""
    if not started:
        raise gym.error.ResetNeeded("call reset() before step()")
    if not space.contains(action):
        raise gym.error.InvalidAction(
            f"action must be 0, 1 or 2 (none, caution, imminent), got {action!r}"
        )


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
        self._drawn, self._next = None, 0  # the scripted runs drawn ahead, the next to start
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
        """Apply the actions (the warnings) and advance one step; the copies in ``restart``
        then start a new run (drawn from ``rng``) while the others continue.  Returns the
        rewards."""
        was = self.source.collided
        brakes = self._brakes(action)
        if isinstance(self.source, ScenarioSource):  # its frame is built after the restarts
            self.source.move(brakes)
        else:
            self.source.advance(brakes)
        self.steps += 1
        self.collided = self.source.collided & ~was
        reward = self._reward(action)
        if restart is not None and restart.any():
            self._new_episodes(restart, np.random.default_rng(int(rng.integers(2**63))))
            self._restart(restart)
            self.steps[restart] = 0
            self.last_seen[:, restart] = -np.inf
            self.collided[restart] = False
            reward[restart] = 0.0
        self._perceive(restart)
        return reward

    def _new_episodes(self, restart: np.ndarray, seed: np.random.Generator) -> None:
        """Start new runs in the copies ``restart``: a scripted source's next runs of those it
        drew ahead (:data:`DRAW_BLOCK` at a time, from ``seed``), any other source's restart."""
        if not isinstance(self.source, ScenarioSource):
            self.source.restart(restart, seed)
            return
        k = int(restart.sum())
        if self._drawn is None or self._next + k > self._drawn.n_runs:
            self._drawn, self._next = self.source.draw(max(DRAW_BLOCK, k), seed), 0
        self.source.start(restart, self._drawn.take(slice(self._next, self._next + k)))
        self._next += k

    def _brakes(self, action: np.ndarray) -> np.ndarray:
        """The brake requests [m/s²] of the step: the drivers', who hear the warnings."""
        return self.driver.step(action, self.seen.frame)

    def _reward(self, action: np.ndarray) -> np.ndarray:
        """The rewards of the step (:class:`~acc_fusion.envs.options.RewardConfig`)."""
        return self.reward.reward(action, self.seen.oracle, self.collided, self.dt)

    def _restart(self, restart: np.ndarray) -> None:
        """Start the copies ``restart`` afresh beyond the source (their drivers)."""
        self.driver.reset(restart)

    def _perceive(self, reassigned) -> None:
        frame = self.source.frame()
        self.seen = self.perception.step(frame, self.source.active, reassigned)
        for i, m in enumerate(self.seen.measurements):
            self.last_seen[i, m.valid] = frame.t

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
        age = p.frame.t - self.last_seen
        reporting = [m.valid for m in p.measurements]
        obs = track_entries(est.x, est.p, est.valid, p.v_ego, reporting, est.isolated, est.nis, age)
        info = truth_info(p.frame, p.oracle, p.ttc, p.relevant, collided, self.source.active)
        return obs.astype(np.float32), info


def truth_info(frame, oracle, ttc, relevant, collided, active) -> dict[str, np.ndarray]:
    """The info arrays of every environment: what truth says at ``frame`` (the 1-D truth of
    the egos and their leads), from :func:`acc_fusion.sim.closed_loop.judge`'s ``oracle``,
    ``ttc`` and ``relevant``, and which copies ``collided`` in the step and are ``active``."""
    return {
        "t": np.full(frame.ego_speed.shape, frame.t),
        "oracle": oracle.astype(np.int64),
        "ttc": ttc.astype(float),
        "crash_relevant": relevant.copy(),
        "ego_speed": frame.ego_speed.copy(),
        "gap_true": np.where(frame.has_leader, frame.gap, np.nan),
        "collided": collided.copy(),
        "active": active.copy(),
    }
