"""Policies that warn and brake, and their evaluation on ``acc_fusion/CollisionAvoidance-v0``
(:mod:`acc_fusion.envs.braking`): collisions, impact speed, false activations and false
warnings, with intervals.

A braking policy maps an observation ``(17,)`` (:data:`~acc_fusion.envs.braking.BRAKING_OBS_FIELDS`)
to ``[warning level, brake stage]``; it has ``reset()`` (a new episode) and a ``name``.  The
baselines (:func:`braking_baselines`):

==============  ================================================================================
policy          warns / brakes
==============  ================================================================================
never           never / never
safety_distance the papers' rule (:class:`~acc_fusion.envs.policies.SafetyDistancePolicy`) /
                never
rule            acc_fusion's warning rule (:class:`~acc_fusion.envs.policies.WarningLogicPolicy`)
                / never
rule+aeb        the rule / AEB as configured (:mod:`acc_fusion.braking.aeb`) on the same
                fused estimate
==============  ================================================================================

A Stable-Baselines3 model is a policy through :class:`ModelPolicy`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from tqdm.auto import tqdm

from acc_fusion.braking.aeb import AEB, AEBConfig
from acc_fusion.core.table import Table
from acc_fusion.envs.evaluation import episode_seed, policy_name
from acc_fusion.envs.observation import OBS_FIELDS
from acc_fusion.envs.policies import (
    Policy,
    SafetyDistancePolicy,
    WarningLogicPolicy,
    _tracked,
    obs_field,
)
from acc_fusion.metrics.stats import poisson_rate_interval, wilson_interval

#: The braking environment's id.
BRAKING_ENV_ID = "acc_fusion/CollisionAvoidance-v0"


class WarnAndBrake:
    """A warning policy (:class:`~acc_fusion.envs.policies.Policy`) with AEB as configured
    (``aeb``; ``None``: it never brakes), both on the observation's fused estimate."""

    def __init__(self, warning: Policy, aeb: AEBConfig | None = None, dt: float = 0.05,
                 name: str | None = None) -> None:  # fmt: skip
        self.warning, self.aeb, self.dt = warning, aeb, dt
        self.name = name or warning.name + ("" if aeb is None else "+aeb")
        self._brakes: AEB | None = None

    def reset(self) -> None:
        self.warning.reset()
        self._brakes = None

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        batch = np.atleast_2d(np.asarray(obs, dtype=float))
        level = np.atleast_1d(self.warning(batch[:, : len(OBS_FIELDS)]))
        stage = np.zeros(len(batch), np.int8)
        if self.aeb is not None:
            if self._brakes is None or self._brakes.n != len(batch):
                self._brakes = AEB(self.aeb, len(batch), self.dt)
            valid = _tracked(batch)
            self._brakes.step(
                np.where(valid, obs_field(batch, "gap"), 0.0), obs_field(batch, "ego_speed"),
                np.where(valid, obs_field(batch, "range_rate"), 0.0),
                np.where(valid, obs_field(batch, "lead_accel"), 0.0), valid,
                np.ones(len(batch), bool),
            )  # fmt: skip
            stage = self._brakes.stage
        out = np.stack([level, stage], axis=1).astype(np.int64)
        return out[0] if np.ndim(obs) == 1 else out


class NeverAct(WarnAndBrake):
    """Never warns, never brakes: the reference without assistance."""

    def __init__(self) -> None:
        super().__init__(_Never(), None, name="never")


class _Never(Policy):
    name = "never"

    def levels(self, obs: np.ndarray) -> np.ndarray:
        return np.zeros(len(obs), np.int8)


class ModelPolicy:
    """A Stable-Baselines3 model as a braking policy (its deterministic action)."""

    def __init__(self, model, name: str = "ppo") -> None:
        self.model, self.name = model, name

    def reset(self) -> None:
        """Nothing to forget (the policy is a feed-forward network)."""

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return np.asarray(self.model.predict(obs, deterministic=True)[0])


def braking_baselines(aeb: AEBConfig | None = None, dt: float = 0.05) -> dict[str, object]:
    """The baselines of the module docstring, by name (AEB: ``aeb``, default settings)."""
    aeb = AEBConfig() if aeb is None else aeb
    return {
        "never": NeverAct(),
        "safety_distance": WarnAndBrake(SafetyDistancePolicy(), None, dt, "safety_distance"),
        "rule": WarnAndBrake(WarningLogicPolicy(dt=dt), None, dt, "rule"),
        "rule+aeb": WarnAndBrake(WarningLogicPolicy(dt=dt), aeb, dt, "rule+aeb"),
    }


@dataclass
class BrakingEvaluation:
    """What a policy did over ``episodes`` episodes: collisions, the closing speed of each
    [m/s], false activations (braking onsets outside a crash-relevant situation), nuisance and
    sensing-false warning onsets, the simulated hours and the mean return."""

    name: str
    episodes: int
    collisions: int
    impact_speeds: list[float]
    false_activations: int
    nuisance: int
    sensing_false: int
    hours: float
    mean_return: float

    def row(self) -> dict[str, str]:
        """The policy's row of :func:`braking_table`, 95 % intervals."""
        lo, hi = wilson_interval(self.collisions, self.episodes)
        f_lo, f_hi = poisson_rate_interval(self.false_activations, self.hours)
        w = self.nuisance + self.sensing_false
        w_lo, w_hi = poisson_rate_interval(w, self.hours)
        speed = np.median(self.impact_speeds) if self.impact_speeds else float("nan")
        return {
            "policy": self.name,
            "collisions": f"{self.collisions}/{self.episodes}",
            "collision_share": f"{self.collisions / self.episodes:.3g} [{lo:.3g}, {hi:.3g}]",
            "impact_speed_median_mps": "-" if np.isnan(speed) else f"{speed:.3g}",
            "false_activations_per_h": f"{self.false_activations / self.hours:.3g} "
            f"[{f_lo:.3g}, {f_hi:.3g}]",
            "false_warnings_per_h": f"{w / self.hours:.3g} [{w_lo:.3g}, {w_hi:.3g}]",
            "mean_return": f"{self.mean_return:.4g}",
        }


def evaluate_braking(
    policy, episodes: int = 100, seed: int = 0, *, progress: bool = False, **env_kwargs
) -> BrakingEvaluation:
    """Run ``policy`` for ``episodes`` episodes of the braking environment (``env_kwargs``:
    its arguments), episode ``i`` reset with :func:`~acc_fusion.envs.evaluation.episode_seed`
    ``(seed, i)``: every policy meets the same episodes."""
    env = gym.make(BRAKING_ENV_ID, **env_kwargs).unwrapped
    counts = dict.fromkeys(("collisions", "false", "nuisance", "sensing_false", "steps"), 0)
    speeds, returns = [], []
    name = policy_name(policy)
    for i in tqdm(range(episodes), desc=name, disable=None if progress else True, leave=False):
        obs, _ = env.reset(seed=episode_seed(seed, i))
        policy.reset()
        stage, total, done = 0, 0.0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(policy(obs))
            total += reward
            counts["steps"] += 1
            onset = info["brake_stage"] > 0 and stage == 0
            stage = info["brake_stage"]
            counts["false"] += bool(onset and info["false_braking"])
            counts["nuisance"] += bool(info["nuisance_onset"])
            counts["sensing_false"] += bool(info["sensing_false_onset"])
            if info["collided"]:
                counts["collisions"] += 1
                speeds.append(float(info["impact_speed"]))
            done = terminated or truncated
        returns.append(total)
    env.close()
    hours = counts["steps"] * env.dt / 3600.0
    return BrakingEvaluation(name, episodes, counts["collisions"], speeds, counts["false"],
                             counts["nuisance"], counts["sensing_false"], hours,
                             float(np.mean(returns)))  # fmt: skip


def braking_table(evaluations: Mapping[str, BrakingEvaluation] | list[BrakingEvaluation],
                  title: str) -> Table:  # fmt: skip
    """The evaluations side by side, ranked by collisions, then false activations."""
    evals = list(evaluations.values()) if isinstance(evaluations, Mapping) else evaluations
    ranked = sorted(evals, key=lambda e: (e.collisions, e.false_activations))
    rows = [e.row() for e in ranked]
    columns = tuple(rows[0]) if rows else ("policy",)
    return Table(title, columns, rows, [
        "collision share: Wilson interval over episodes; rates: exact Poisson per simulated "
        "hour; false activation: a braking onset outside a crash-relevant situation in truth; "
        "false warnings: nuisance and sensing-false imminent-warning onsets"])  # fmt: skip
