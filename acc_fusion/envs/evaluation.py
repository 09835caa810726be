r"""Evaluation harness: run a warning policy in the collision-warning environment and judge it.

:func:`evaluate` runs a policy for a number of episodes of
:class:`acc_fusion.envs.collision_warning.CollisionWarningEnv` and feeds every step into one
streaming :class:`acc_fusion.metrics.events.FCWMetrics` (false alarms per hour and per 100 km with
exact Poisson intervals, miss rate with Wilson intervals, lead time, TTC at warning), counting
collisions and reward on the way.  :func:`compare_policies` does it for several policies and
returns a :class:`~acc_fusion.core.table.Table`; :func:`load_policy` imports a user's
policy from
a ``MODULE:CALLABLE`` spec; the ``acc-fusion evaluate`` command is :mod:`acc_fusion.cli.evaluate`.

Same episodes for every policy
    Episode *i* is reset with the seed :func:`episode_seed` ``(seed, i)`` (the *i*-th child of
    ``numpy.random.SeedSequence(seed)``), and the environment draws the scenario, its
    parameters, the sensor noise and the driver from it.  So every policy starts from the same
    situations; the runs then differ only through the policy's warnings, because the loop is
    closed (the simulated driver brakes for imminent alerts).  Exposure (hours, km) may thus
    differ between policies: compare rates, not counts.

    The ``sumo`` source runs one long simulation whose seeded reset restarts it (the
    environment's ``reseeding_restarts``): there only episode 0 is reset with its seed, so every
    policy starts in the same simulation, and the following episodes are the next equipped
    vehicles of that simulation (the same ones while the policies' warnings have not changed
    the traffic).  The ``highway`` source starts a highway-env episode at every reset, so
    there, as for the scripted source, every episode is reset with its seed.

Judging a step
    ``env.step(action)`` rewards the action against the oracle of the observation it was
    chosen on (the info of the previous ``reset``/``step``), then moves on.  The harness pairs
    them the same way: the action taken on observation *k* is recorded at that observation's
    time :math:`t_k` with its oracle level, true TTC, true ego speed and ``active`` flag, and
    with the ``collided`` flag of the transition that follows.  ``FCWMetrics.finish`` closes
    every episode, and the next one starts again at its own :math:`t = 0`.

A policy is any of
    * a callable ``policy(obs) -> action`` (action 0, 1 or 2, as an int, a numpy integer or
      a one-element array), optionally with ``reset()``, called at every episode start, and a
      ``name``;
    * an object with ``predict(obs, deterministic=True) -> (action, state)``, such as a
      Stable-Baselines3 model (recurrent ones get their ``state`` and ``episode_start``);
    * a class, instantiated with no arguments.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.table import Table
from acc_fusion.envs.collision_warning import CollisionWarningEnv
from acc_fusion.metrics.events import FCWMetrics
from acc_fusion.metrics.summary import FCWSummary


def episode_seed(seed: int, episode: int) -> int:
    """The reset seed of episode ``episode`` of an evaluation seeded with ``seed``.

    The ``episode``-th child of ``numpy.random.SeedSequence(seed)`` (as ``spawn`` would give),
    so it does not depend on how many episodes are run.

    >>> episode_seed(0, 3) == episode_seed(0, 3) != episode_seed(1, 3)
    True
    """
    child = np.random.SeedSequence(seed, spawn_key=(episode,))
    return int(child.generate_state(1, dtype=np.uint64)[0])


def policy_name(policy: object) -> str:
    """A label for ``policy``: its ``name``, else its function or class name."""
    name = getattr(policy, "name", None)
    if isinstance(name, str) and name:
        return name
    if inspect.isfunction(policy) or inspect.ismethod(policy) or isinstance(policy, type):
        return policy.__name__
    return type(policy).__name__


class _Runner:
    """Uniform ``reset()`` / ``act(obs) -> int`` over the kinds of policy the harness accepts."""

    def __init__(self, policy: object) -> None:
        if isinstance(policy, type):
            try:
                policy = policy()
            except TypeError as exc:
                raise ConfigError(
                    f"policy class {policy.__name__} must be constructible with no arguments: {exc}"
                ) from None
        predict = getattr(policy, "predict", None)
        self.policy = policy
        self.name = policy_name(policy)
        self._predict = predict if callable(predict) else None
        if self._predict is None and not callable(policy):
            raise ConfigError(
                "policy must be a callable obs -> action or have .predict(obs, "
                f"deterministic=True), got {type(policy).__name__}"
            )
        self._recurrent = False
        if self._predict is not None:
            try:
                params = inspect.signature(self._predict).parameters
            except (TypeError, ValueError):
                params = {}
            self._recurrent = "state" in params and "episode_start" in params
        reset = getattr(policy, "reset", None)
        self._reset = reset if self._predict is None and callable(reset) else None
        self._state = None
        self._start = True

    def reset(self) -> None:
        self._state, self._start = None, True
        if self._reset is not None:
            self._reset()

    def act(self, obs: np.ndarray) -> int:
        if self._predict is None:
            action = self.policy(obs)
        else:
            if self._recurrent:
                out = self._predict(
                    obs,
                    state=self._state,
                    episode_start=np.array([self._start]),
                    deterministic=True,
                )
            else:
                out = self._predict(obs, deterministic=True)
            if isinstance(out, tuple) and len(out) == 2:
                action, self._state = out
            else:
                action = out
        self._start = False
        return self._level(action)

    def _level(self, action: object) -> int:
        arr = np.asarray(action)
        ok = arr.size == 1 and arr.dtype.kind in "iuf"
        value = arr.reshape(-1)[0] if ok else None
        if not ok or value not in (0, 1, 2):
            raise InputError(
                f"policy {self.name!r} returned {action!r}: an action must be 0, 1 or 2 "
                "(none, caution, imminent)"
            )
        return int(value)


@dataclass(frozen=True)
class Evaluation:
    """The result of :func:`evaluate`.

    Attributes:
        policy: the policy's label.
        source, scenario: the environment's truth source and scenario.
        episodes, seed: episodes run and the seed their reset seeds derive from.
        summary: the FCW metrics over all episodes (:class:`acc_fusion.metrics.summary.FCWSummary`).
        total_reward: the environment's reward summed over all steps of all episodes.
        collisions: episodes that ended in a collision.
        steps: environment steps taken.
    """

    policy: str
    source: str
    scenario: str
    episodes: int
    seed: int
    summary: FCWSummary
    total_reward: float
    collisions: int
    steps: int

    @property
    def mean_reward(self) -> float:
        """Reward per episode."""
        return self.total_reward / self.episodes

    def row(self) -> dict:
        """This evaluation's row of :func:`comparison_table`."""
        s = self.summary
        return {
            "policy": self.policy,
            "warnings": s.warnings,
            "false_alarms": s.false_alarms,
            "fa_per_hour": s.false_alarms_per_hour.format(),
            "missed": f"{s.missed}/{s.threats}",
            "miss_rate": s.miss_rate.format(),
            "lead_time_median_s": s.lead_time.median,
            "nuisance_per_100km": s.alerts_per_100km["nuisance"].format(),
            "sensing_false_per_100km": s.alerts_per_100km["sensing_false"].format(),
            "relevant_missed": f"{s.relevant_missed}/{s.relevant}",
            "collisions": f"{self.collisions}/{self.episodes}",
            "mean_reward": self.mean_reward,
        }

    def as_dict(self) -> dict:
        """Plain dicts for JSON (undefined figures become ``None``)."""
        return {
            "policy": self.policy,
            "source": self.source,
            "scenario": self.scenario,
            "episodes": self.episodes,
            "seed": self.seed,
            "steps": self.steps,
            "total_reward": self.total_reward,
            "mean_reward": self.mean_reward,
            "collisions": self.collisions,
            "metrics": self.summary.as_dict(),
        }


def _whole(name: str, value: object, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
        raise ConfigError(f"{name} must be a whole number >= {lo}, got {value!r}")
    return int(value)


def make_env(
    source: str = "scripted",
    scenario: str = "random",
    config=None,
    reward=None,
    max_episode_steps: int = 1200,
    sumo=None,
    highway=None,
):
    """The :class:`~acc_fusion.envs.collision_warning.CollisionWarningEnv` evaluations run in."""

    return CollisionWarningEnv(
        source=source,
        scenario=scenario,
        config=config,
        reward=reward,
        max_episode_steps=max_episode_steps,
        sumo=sumo,
        highway=highway,
    )


def evaluate(
    policy: Any,
    source: str = "scripted",
    episodes: int = 100,
    seed: int = 0,
    scenario: str = "random",
    warn_level: int = 2,
    tolerance: float = 1.0,
    progress: bool = False,
    *,
    name: str | None = None,
    config=None,
    reward=None,
    max_episode_steps: int = 1200,
    sumo=None,
    highway=None,
    env=None,
) -> Evaluation:
    """Run ``policy`` for ``episodes`` episodes and judge its warnings against the oracle.

    Args:
        policy: a callable ``obs -> action``, an object with ``predict`` (Stable-Baselines3),
            or a class to instantiate (see the module docstring).
        source, scenario: the environment's truth source and scenario.
        episodes: number of episodes; episode i is reset with :func:`episode_seed` (seed, i).
        seed: seed of the evaluation (a whole number >= 0).
        warn_level: the level that counts as a warning in the metrics: 2 imminent (the FCW
            alert the driver brakes for; default) or 1 caution.
        tolerance: the matching window of warnings and threats [s] (default 1).
        progress: show a progress bar over the episodes (on a terminal).
        name: the policy's label (default :func:`policy_name`).
        config, reward, max_episode_steps, sumo, highway: passed to the environment
            (:class:`~acc_fusion.sim.closed_loop.SimConfig`,
            :class:`~acc_fusion.envs.collision_warning.
            RewardConfig`, step limit, :class:`~acc_fusion.envs.options.SumoOptions`
            of the ``sumo`` source, :class:`~acc_fusion.envs.options.HighwayOptions`
            of the ``highway`` source).
        env: an environment to run in instead of a new one (``source``, ``scenario``,
            ``config``, ``reward``, ``max_episode_steps``, ``sumo`` and ``highway`` are then
            ignored); it
            is not closed, so one environment can serve several evaluations.

    >>> from acc_fusion.envs.policies import TTCPolicy
    >>> ev = evaluate(TTCPolicy(), episodes=2, seed=1)
    >>> ev.episodes, ev.summary.warn_level
    (2, 2)
    """
    from tqdm.auto import tqdm

    episodes = _whole("episodes", episodes, 1)
    seed = _whole("seed", seed, 0)
    runner = _Runner(policy)
    label = name or runner.name
    FCWMetrics(1, 1.0, tolerance, warn_level)  # check them before building anything
    own_env = env is None
    if own_env:
        env = make_env(source, scenario, config, reward, max_episode_steps, sumo, highway)
    base = env.unwrapped
    seed_first_only = bool(getattr(base, "reseeding_restarts", False))
    source = getattr(base, "source_name", source)
    scenario = getattr(base, "scenario", scenario)
    total_reward, collisions, steps = 0.0, 0, 0
    try:
        metrics = FCWMetrics(1, base.dt, tolerance, warn_level)
        for i in tqdm(
            range(episodes),
            disable=None if progress else True,
            desc=label,
            unit="episode",
            leave=False,
        ):
            seeded = i == 0 or not seed_first_only
            obs, info = env.reset(seed=episode_seed(seed, i) if seeded else None)
            runner.reset()
            done = False
            while not done:
                action = runner.act(obs)
                obs, r, terminated, truncated, after = env.step(action)
                collided = bool(after["collided"])
                metrics.update(
                    info["t"],
                    np.array([action], dtype=np.int8),
                    np.array([info["oracle"]], dtype=np.int8),
                    np.array([info["ttc"]]),
                    np.array([info["ego_speed"]]),
                    np.array([bool(info["active"])]),
                    np.array([collided]),
                    np.array([bool(info["crash_relevant"])]),
                )
                total_reward += float(r)
                collisions += collided
                steps += 1
                done = terminated or truncated
                info = after
            metrics.finish(info["t"])
    finally:
        if own_env:
            env.close()
    return Evaluation(
        policy=label,
        source=source,
        scenario=scenario,
        episodes=episodes,
        seed=seed,
        summary=metrics.summary(),
        total_reward=total_reward,
        collisions=collisions,
        steps=steps,
    )


#: Columns of :func:`comparison_table`.
COLUMNS = (
    "policy",
    "warnings",
    "false_alarms",
    "fa_per_hour",
    "missed",
    "miss_rate",
    "lead_time_median_s",
    "nuisance_per_100km",
    "sensing_false_per_100km",
    "relevant_missed",
    "collisions",
    "mean_reward",
)


def comparison_table(evaluations: Sequence[Evaluation]) -> Table:
    """One row per evaluation: false alarms per hour and miss rate with 95 % intervals,
    median lead time, nuisance and sensing-false alerts per 100 km and the missed
    crash-relevant situations (:mod:`acc_fusion.metrics.alert_classes`), collisions
    (episodes), mean reward per episode."""

    if not evaluations:
        raise ConfigError("comparison_table needs at least one evaluation")
    first = evaluations[0]
    s = first.summary
    level = "imminent" if s.warn_level == 2 else "caution"
    table = Table(
        f"Warning policies: {first.episodes} episodes of '{first.scenario}' ({first.source} "
        f"source), seed {first.seed}, {level} alerts, tolerance {s.tolerance:g} s, "
        f"{round(100 * s.confidence)}% intervals",
        COLUMNS,
        [e.row() for e in evaluations],
    )
    hours = [e.summary.hours for e in evaluations]
    km = [e.summary.km for e in evaluations]
    table.notes += [
        "the same episodes and seeds for every policy; closed loop: the driver brakes for "
        "each policy's imminent alerts, so exposure differs between policies",
        f"exposure per policy: {min(hours):.3g}-{max(hours):.3g} h, {min(km):.3g}-{max(km):.3g} km",
    ]
    return table


def compare_policies(policies: Mapping[str, Any], *args: Any, **kwargs: Any) -> Table:
    """:func:`evaluate_many` (same arguments: ``source``, ``episodes``, ``seed``, ...) turned
    into the table of :func:`comparison_table`: every policy (keys are the labels) on the same
    episodes, one environment serving every policy one after the other."""
    return comparison_table(evaluate_many(policies, *args, **kwargs))


def evaluate_many(
    policies: Mapping[str, Any],
    source: str = "scripted",
    episodes: int = 100,
    seed: int = 0,
    scenario: str = "random",
    warn_level: int = 2,
    tolerance: float = 1.0,
    progress: bool = False,
    **env_kwargs,
) -> list[Evaluation]:
    """:func:`evaluate` every policy of ``policies`` (keys are the labels) in one environment."""
    if not policies:
        raise ConfigError("policies must hold at least one policy")
    env = make_env(source, scenario, **env_kwargs)
    try:
        return [
            evaluate(
                policy,
                episodes=episodes,
                seed=seed,
                warn_level=warn_level,
                tolerance=tolerance,
                progress=progress,
                name=label,
                env=env,
            )
            for label, policy in policies.items()
        ]
    finally:
        env.close()


# --------------------------------------------------------------------------------------------
# Loading a user's policy
# --------------------------------------------------------------------------------------------


# --------------------------------------------------------------------------------------------
# acc-fusion evaluate
# --------------------------------------------------------------------------------------------
