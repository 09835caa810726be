r"""Reinforcement learning on the collision-warning environment with Stable-Baselines3.

Needs the ``rl`` extra (``pip install 'acc_fusion[rl]'``: Stable-Baselines3 and torch).

:class:`GymVectorToSB3` presents a gymnasium :class:`~gymnasium.vector.VectorEnv` (such as the
native :class:`~acc_fusion.envs.collision_warning.CollisionWarningVectorEnv`, which steps all
copies with array arithmetic) as a Stable-Baselines3 :class:`VecEnv`;
:class:`BoxScaler` maps the observation box onto ``[-1, 1]`` inside the policy, so a saved
model takes the environment's raw observations (as :func:`acc_fusion.envs.evaluation.evaluate`
gives them), and :class:`FCWFeatures` adds kinematic threat features to it;
:class:`WallClockLimit` stops training after a wall-clock budget;
:func:`make_vec_env` builds the wrapped native vector environment, :func:`make_ppo` the PPO
agent and :func:`train_ppo` trains it (``scripts/train_ppo.py`` is its command line).

Autoreset: gymnasium ``NEXT_STEP`` against Stable-Baselines3
    Stable-Baselines3 expects a finished copy to be reset *within* the step that ends its
    episode: ``done[i]`` is true, ``obs[i]`` is already the first observation of the next
    episode and ``infos[i]["terminal_observation"]`` holds the last one.  A gymnasium vector
    environment with ``NEXT_STEP`` autoreset (gymnasium's default, and the native vector
    environment's only mode) delivers that first observation one step later: the step after
    copy *i* terminates or truncates ignores its action, restarts it and returns the new
    run's first observation with reward 0.  That first observation cannot be had earlier
    through the ``VectorEnv`` API (the next step needs every copy's action, chosen on the
    observations this step returns, and there is no per-copy reset), so the adapter reports
    the end of an episode one step late, on the step that carries the reset:

    ======================  ==================================  ===========================
    inner step              copy *i* in the gymnasium env        what SB3 sees for copy *i*
    ======================  ==================================  ===========================
    *k* (episode ends)      ``obs=o_T, r_T, terminated`` or      ``obs=o_T, r_T,
                            ``truncated``                        done=False``
    *k+1* (reset)           action ignored, ``obs=o_0`` of the   ``obs=o_0, reward 0,
                            next run, reward 0                   done=True``, info
                                                                 ``terminal_observation=o_T``
                                                                 (and ``TimeLimit.truncated``)
    ======================  ==================================  ===========================

    So every step SB3 sees is a real step of the environment, ``done`` comes with the reset
    observation and ``terminal_observation`` as SB3 requires, and no transition crosses two
    episodes.  The one difference from an environment reset within the step is that every
    episode ends with an extra *absorbing* step: in its last observation :math:`o_T` the
    agent's action is ignored, the reward is 0 and the episode then ends (terminated, or
    truncated with the time-limit flag, so SB3 bootstraps from :math:`o_T`).  Returns are
    unchanged and episode lengths grow by one; after a termination the value of
    :math:`o_T` is learnt as 0, which is its true value, and as the reward of the ignored
    action does not depend on it its policy gradient has zero mean.  After a truncation the
    absorbing step's target is :math:`\gamma V(o_T)` instead of :math:`V(o_T)`, a small bias
    on the states where runs hit ``max_episode_steps`` (in the scripted source, steady
    following after 60 s).

    With ``SAME_STEP`` autoreset (e.g. ``SyncVectorEnv(..., autoreset_mode=SAME_STEP)``) the
    adapter is exact: ``done`` on the step that ends the episode, ``terminal_observation``
    from the ``final_obs`` info.  ``DISABLED`` autoreset is refused.
"""

from __future__ import annotations

import sys
import time
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from gymnasium import spaces
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import HumanOutputFormat, Logger
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from stable_baselines3.common.vec_env import VecEnv

import acc_fusion  # noqa: F401  (registers the environment)
from acc_fusion.core.errors import ConfigError
from acc_fusion.envs.observation import OBS_FIELDS

ENV_ID = "acc_fusion/CollisionWarning-v0"


class GymVectorToSB3(VecEnv):
    """A gymnasium :class:`~gymnasium.vector.VectorEnv` as a Stable-Baselines3 ``VecEnv``.

    See the module docstring for the autoreset semantics (``NEXT_STEP``: the end of an episode
    is reported on the step that returns the reset observation; ``SAME_STEP``: exact).

    The copies share one vector environment: :meth:`get_attr` reads the vector environment's
    attribute (the same value for every index), :meth:`set_attr` sets it there and
    :meth:`env_method` calls the method once and repeats its result for every index.
    ``seed(s)`` seeds the next :meth:`reset` of the vector environment with ``s`` (the copies
    then get their own streams from it, as gymnasium's vector environments do).

    Args:
        venv: the vector environment (Discrete or Box single spaces); it is closed with the
            adapter.
    """

    def __init__(self, venv: gym.vector.VectorEnv) -> None:
        if not isinstance(venv, gym.vector.VectorEnv):
            raise ConfigError(
                f"venv must be a gymnasium VectorEnv, got {type(venv).__name__} "
                "(wrap single environments in stable_baselines3's DummyVecEnv instead)"
            )
        mode = venv.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP)
        mode = AutoresetMode(mode) if isinstance(mode, str) else mode
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ConfigError(
                f"GymVectorToSB3 needs NEXT_STEP or SAME_STEP autoreset, the vector environment "
                f"has {mode!r}"
            )
        self.venv, self.autoreset_mode = venv, mode
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        n = venv.num_envs
        #: Copies whose episode ended on the last inner step (NEXT_STEP): SB3 hears of it now.
        self._pending = np.zeros(n, dtype=bool)
        self._pending_truncated = np.zeros(n, dtype=bool)
        self._terminal_obs: list[Any] = [None] * n
        self._actions: np.ndarray | None = None

    # ------------------------------------------------------------------ VecEnv API
    def reset(self):
        seed = self._seeds[0]
        options = self._options[0] or None
        obs, info = self.venv.reset(seed=seed, options=options)
        self.reset_infos = _split_info(info, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        self._pending[:] = False
        self._pending_truncated[:] = False
        self._terminal_obs = [None] * self.num_envs
        return np.array(obs, copy=True)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self):
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        actions, self._actions = self._actions, None
        obs, reward, terminated, truncated, info = self.venv.step(actions)
        obs = np.array(obs, copy=True)
        terminated = np.asarray(terminated, dtype=bool)
        truncated = np.asarray(truncated, dtype=bool)
        infos = _split_info(info, self.num_envs)
        if self.autoreset_mode == AutoresetMode.SAME_STEP:
            dones = terminated | truncated
            final_obs = info.get("final_obs")
            for i in np.flatnonzero(dones):
                infos[i]["terminal_observation"] = final_obs[i]
                infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                infos[i].pop("final_obs", None)
                infos[i].pop("final_info", None)
            return obs, np.asarray(reward, dtype=np.float32), dones, infos
        # NEXT_STEP: the copies that ended on the last step were restarted by this one.
        dones = self._pending.copy()
        for i in np.flatnonzero(dones):
            infos[i]["terminal_observation"] = self._terminal_obs[i]
            infos[i]["TimeLimit.truncated"] = bool(self._pending_truncated[i])
            self._terminal_obs[i] = None
        ended = (terminated | truncated) & ~dones
        for i in np.flatnonzero(ended):
            self._terminal_obs[i] = obs[i].copy()
        self._pending = ended
        self._pending_truncated = truncated & ~terminated & ended
        return obs, np.asarray(reward, dtype=np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs):
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


def _split_info(info: dict, n: int) -> list[dict]:
    """Gymnasium's batched info dict (arrays over copies) as one dict per copy."""
    out: list[dict] = [{} for _ in range(n)]
    for key, value in info.items():
        if key.startswith("_"):
            continue
        if isinstance(value, np.ndarray) and value.shape[:1] == (n,):
            mask = info.get("_" + key)
            for i in range(n):
                if mask is None or mask[i]:
                    v = value[i]
                    out[i][key] = v.item() if isinstance(v, np.generic) else v
        elif isinstance(value, dict):
            for i, sub in enumerate(_split_info(value, n)):
                if sub:
                    out[i][key] = sub
    return out


def make_vec_env(num_envs: int = 64, env_id: str = ENV_ID, **env_kwargs) -> GymVectorToSB3:
    """The native vector environment (``num_envs`` copies) of ``env_id`` (the warning
    environment, or ``acc_fusion/CollisionAvoidance-v0`` that also brakes) as a
    Stable-Baselines3 VecEnv.

    ``env_kwargs`` go to :class:`~acc_fusion.envs.collision_warning.CollisionWarningVectorEnv`
    (``scenario``, ``config``, ``reward``, ``max_episode_steps``).
    """

    venv = gym.make_vec(
        env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **env_kwargs
    )
    return GymVectorToSB3(venv)


class BoxScaler(BaseFeaturesExtractor):
    """Maps a bounded ``Box`` observation linearly onto ``[-1, 1]`` (then flattens it).

    The collision-warning observation mixes a gap of up to 250 m with 0/1 flags; scaling it
    inside the policy (rather than with ``VecNormalize``) keeps a saved model usable on raw
    observations, as the evaluation harness passes them.
    """

    def __init__(self, observation_space: spaces.Box) -> None:
        low = np.asarray(observation_space.low, dtype=np.float64).reshape(-1)
        high = np.asarray(observation_space.high, dtype=np.float64).reshape(-1)
        if not (np.isfinite(low).all() and np.isfinite(high).all()):
            raise ConfigError("BoxScaler needs a bounded observation space")
        super().__init__(observation_space, features_dim=low.size)
        half = np.where(high > low, (high - low) / 2.0, 1.0)
        self.register_buffer("obs_center", torch.as_tensor((high + low) / 2.0, dtype=torch.float32))
        self.register_buffer("obs_half", torch.as_tensor(half, dtype=torch.float32))

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        return (observations.flatten(1) - self.obs_center) / self.obs_half


class FCWFeatures(BoxScaler):
    r""":class:`BoxScaler` plus three kinematic threat features of the fused track.

    With the closing speed :math:`c = \max(-\dot g, 0)`, the gap :math:`g` (at least 0.5 m)
    and the ego speed :math:`v` (at least 1 m/s): the inverse time-to-collision :math:`c/g`
    (1/s, capped at 5, divided by 2.5), the deceleration that would just avoid a collision
    :math:`c^2/(2g)` (m/s², capped at 20, divided by 10) and the time headway :math:`g/v` (s,
    capped at 5, divided by 2.5); all 0 without a track.  They are the quantities the
    safety-distance and TTC rules threshold, so the policy need not learn the ratios from the
    scaled gap and range-rate; like the scaling they are computed inside the policy, on raw
    observations.
    """

    def __init__(self, observation_space: spaces.Box) -> None:

        super().__init__(observation_space)
        shape = observation_space.shape
        if len(shape) != 1 or shape[0] < len(OBS_FIELDS):
            raise ConfigError(
                f"FCWFeatures needs an observation that begins with the collision-warning "
                f"one ({len(OBS_FIELDS)},), got shape {shape}"
            )
        self._idx = tuple(OBS_FIELDS.index(f) for f in ("gap", "range_rate", "ego_speed"))
        self._valid = OBS_FIELDS.index("track_valid")
        self._features_dim = shape[0] + 3

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        obs = observations.flatten(1)
        i_gap, i_rate, i_speed = self._idx
        gap = obs[:, i_gap].clamp(min=0.5)
        closing = (-obs[:, i_rate]).clamp(min=0.0)
        speed = obs[:, i_speed].clamp(min=1.0)
        extra = torch.stack(
            [
                (closing / gap).clamp(max=5.0) / 2.5,
                (closing**2 / (2.0 * gap)).clamp(max=20.0) / 10.0,
                (gap / speed).clamp(max=5.0) / 2.5,
            ],
            dim=1,
        ) * (obs[:, self._valid : self._valid + 1] > 0.5)
        return torch.cat([super().forward(observations), extra], dim=1)


class WallClockLimit(BaseCallback):
    """Stops training once ``minutes`` of wall-clock time have passed since training began."""

    def __init__(self, minutes: float, verbose: int = 0) -> None:
        super().__init__(verbose)
        if not minutes > 0:
            raise ConfigError(f"minutes must be > 0, got {minutes!r}")
        self.seconds = 60.0 * float(minutes)
        self.start = 0.0
        self.stopped = False

    def _on_training_start(self) -> None:
        self.start = time.perf_counter()

    def _on_step(self) -> bool:
        if time.perf_counter() - self.start >= self.seconds:
            self.stopped = True
            if self.verbose:
                print(f"wall-clock limit of {self.seconds / 60:g} min reached")
            return False
        return True


class _ProgressBar(BaseCallback):
    """A tqdm bar over the training steps (Stable-Baselines3's own bar needs ``rich``)."""

    def __init__(self, total: int) -> None:
        super().__init__()
        self.total = total
        self.bar = None

    def _on_training_start(self) -> None:
        from tqdm.auto import tqdm

        self.bar = tqdm(total=self.total, desc="PPO", unit="step")

    def _on_step(self) -> bool:
        self.bar.update(self.training_env.num_envs)
        return True

    def _on_training_end(self) -> None:
        self.bar.close()


#: PPO hyper-parameters of :func:`make_ppo` (tuned for a few minutes on 64 copies).  What
#: made PPO learn within minutes, where it otherwise stayed at never-warn: the threat features
#: of :class:`FCWFeatures`; a discount of 0.97 (a horizon of about 1.6 s at 20 Hz) with
#: ``gae_lambda`` 0.95, which carries the credit of a warning over the driver's reaction time
#: (about 1.1 s) to the braking it causes while keeping out most of the noise of the rare large
#: collision penalty (with 0.99 the greedy policy stayed at never-warn); and an entropy bonus
#: of 0.01, without which early training (when random warnings make every single one
#: redundant) drives the policy to never-warn, from which some seeds did not recover.
PPO_DEFAULTS: dict[str, Any] = {
    "learning_rate": 3e-4,
    "n_epochs": 10,
    "gamma": 0.97,
    "gae_lambda": 0.95,
    "ent_coef": 0.01,
    "clip_range": 0.2,
}


def make_ppo(venv, seed: int | None = 0, n_steps: int = 128, verbose: int = 0, **overrides):
    """A Stable-Baselines3 PPO agent for ``venv`` (a vector environment, or one gymnasium
    environment): a 64-64 MLP (separate actor and critic) on :class:`FCWFeatures`,
    minibatches of a quarter of the rollout, :data:`PPO_DEFAULTS` (``overrides`` replace them
    and may set ``batch_size`` and ``policy_kwargs``)."""
    from stable_baselines3 import PPO

    kwargs = {**PPO_DEFAULTS, **overrides}
    rollout = n_steps * getattr(venv, "num_envs", 1)
    kwargs.setdefault("batch_size", max(64, rollout // 4))
    kwargs.setdefault(
        "policy_kwargs", {"features_extractor_class": FCWFeatures, "net_arch": [64, 64]}
    )
    model = PPO(
        "MlpPolicy", venv, n_steps=n_steps, seed=seed, device="cpu", verbose=verbose, **kwargs
    )
    if kwargs.get("tensorboard_log") is None:
        # SB3's default logger makes an empty directory in the temporary directory per
        # learn(); the same outputs without it (stdout when verbose).
        outputs = [HumanOutputFormat(sys.stdout)] if verbose >= 1 else []
        model.set_logger(Logger(None, outputs))
    return model


def train_ppo(
    timesteps: int = 200_000,
    minutes: float = 5.0,
    seed: int = 0,
    num_envs: int = 64,
    n_steps: int = 128,
    verbose: int = 0,
    progress: bool = False,
    threads: int | None = 1,
    env_kwargs: dict | None = None,
    env_id: str = ENV_ID,
    **ppo_kwargs,
):
    """Train PPO on the native vector environment for ``timesteps`` steps or ``minutes`` of
    wall-clock time, whichever comes first.

    The environment is ``num_envs`` copies of ``env_id`` (default
    ``acc_fusion/CollisionWarning-v0``, its default reward and scenario mixture) behind
    :class:`GymVectorToSB3`, with ``VecMonitor`` and a reward-only ``VecNormalize`` (training
    only: the saved model takes raw observations). ``env_kwargs`` go to :func:`make_vec_env`
    (e.g. ``config``, whose warning rule is the oracle the reward follows); ``ppo_kwargs`` go to
    :func:`make_ppo`.

    ``threads``: torch's intra-op threads during training (restored afterwards; ``None``:
    leave torch's setting).  One by default: the 64-64 MLP gains little from more, and the
    environment's own stepping needs the other core (on a loaded 2-core machine one training
    ran at 130 steps/s with torch's default threads and later ones at about 2 000 with one;
    not a controlled comparison).

    Returns:
        ``(model, stats)``; ``stats`` holds ``timesteps`` done, ``seconds``, ``steps_per_s``
        and ``stopped_by_clock``.
    """
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    venv = make_vec_env(num_envs, env_id, **(env_kwargs or {}))
    venv.seed(seed)
    gamma = ppo_kwargs.get("gamma", PPO_DEFAULTS["gamma"])
    venv = VecNormalize(VecMonitor(venv), norm_obs=False, norm_reward=True, gamma=gamma)
    model = make_ppo(venv, seed, n_steps, verbose, **ppo_kwargs)
    limit = WallClockLimit(minutes, verbose)
    saved_threads = torch.get_num_threads()
    if threads is not None:
        torch.set_num_threads(threads)
    t0 = time.perf_counter()
    try:
        callback = [limit, _ProgressBar(timesteps)] if progress else limit
        model.learn(total_timesteps=timesteps, callback=callback)
    finally:
        torch.set_num_threads(saved_threads)
        venv.close()
    seconds = time.perf_counter() - t0
    steps = int(model.num_timesteps)
    stats = {
        "timesteps": steps,
        "seconds": seconds,
        "steps_per_s": steps / seconds if seconds > 0 else float("nan"),
        "stopped_by_clock": limit.stopped,
    }
    return model, stats
