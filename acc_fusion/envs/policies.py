r"""Baseline warning policies for the collision-warning environment.

A *policy* maps what the fusion center knows (an observation of
:class:`acc_fusion.envs.collision_warning.CollisionWarningEnv`, the entries named by
:data:`~acc_fusion.envs.observation.OBS_FIELDS`, which also begin an observation of the world
environment :class:`acc_fusion.envs.world.CollisionWarningWorldEnv`) to a warning level: 0 none,
1 caution, 2 imminent (:data:`~acc_fusion.core.levels.NONE`,
:data:`~acc_fusion.core.levels.CAUTION`, :data:`~acc_fusion.core.levels.IMMINENT`).  Every
baseline here is a small class with

* ``policy(obs) -> int`` for one observation ``(F,)``, and an ``(B,)`` int8 array for a batch
  ``(B, F)`` (e.g. the observations of a vector environment);
* ``reset()``, called by :func:`acc_fusion.envs.evaluation.evaluate` at the start of every episode;
* ``name``, the label of its row in a comparison.

Every policy reads the observation by field name (:func:`obs_field`), never by position, and
raises no warning where ``track_valid`` is 0 (the fusion center has no track).

======================  =================================================================
policy                  warns imminent (caution) when
======================  =================================================================
SafetyDistancePolicy    :math:`\hat g < d_I` (:math:`\hat g < d_C`): the fused gap against a
                        safety model of :mod:`acc_fusion.warning.safety` (the papers' FCW rule)
UncertaintyAwarePolicy  :math:`\hat g - z\,\sigma_g < d_I` (:math:`< d_C`): the lower
                        one-sided quantile of the gap (z = 1.645: 95 %)
RSSPolicy               the same rule with RSS's safe distance (Shalev-Shwartz et al. 2017)
TTCPolicy               :math:`\mathrm{TTC} = \hat g / (-\dot{\hat g}) < 2.4` s (:math:`< 3.0`
                        s), constant range-rate (the test protocols' TTC)
WarningLogicPolicy      :class:`acc_fusion.warning.logic.WarningLogic` on the estimate: hysteresis,
                        minimum on-time, confirmation (acc_fusion's rule, the oracle's on truth)
AlwaysWarn, NeverWarn   always (while there is a track) / never: sanity anchors
======================  =================================================================

Here :math:`\hat g`, :math:`\dot{\hat g}`, :math:`\hat a_l` and :math:`\sigma_g` are the fused
gap [m], range-rate [m/s], lead acceleration [m/s²] and gap standard deviation [m], and the
safety distances :math:`(d_C, d_I) = ` :func:`acc_fusion.warning.safety.safety_distances` (model,
:math:`\hat v_\text{ego}`, :math:`\dot{\hat g}`, :math:`\hat a_l`) use the ego speed of the
ego-motion filter.  :data:`BASELINES` holds one ready instance of each.

>>> import numpy as np
>>> from acc_fusion.envs.observation import OBS_FIELDS, WORLD_OBS_FIELDS
>>> obs = np.zeros(len(OBS_FIELDS), dtype=np.float32)
>>> obs[[OBS_FIELDS.index(f) for f in ("gap", "range_rate", "ego_speed", "track_valid")]] = (
...     10.0, -10.0, 20.0, 1.0)
>>> SafetyDistancePolicy()(obs), TTCPolicy()(obs), NeverWarn()(obs)
(2, 2, 0)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.levels import CAUTION, IMMINENT, NONE
from acc_fusion.core.validation import check_choice, check_range
from acc_fusion.envs.observation import OBS_FIELDS, WORLD_OBS_FIELDS
from acc_fusion.warning.logic import WarningConfig, WarningLogic
from acc_fusion.warning.safety import SAFETY_MODELS, safety_distances
from acc_fusion.warning.ttc import time_to_collision

_INDEX = {name: i for i, name in enumerate(OBS_FIELDS)}


def obs_field(obs: np.ndarray, name: str) -> np.ndarray:
    """The entry ``name`` of :data:`OBS_FIELDS` of a batch of observations ``(B, F)`` → ``(B,)``.

    >>> obs = np.arange(2 * len(OBS_FIELDS)).reshape(2, -1)
    >>> obs_field(obs, "gap_std").tolist()
    [3, 19]
    """
    check_choice("observation field", name, OBS_FIELDS)
    return np.asarray(obs)[..., _INDEX[name]]


def _as_batch(obs: object) -> tuple[np.ndarray, bool]:
    """``obs`` as a float ``(B, F)`` array, and whether it was a single observation.  An
    observation of the world environment (:data:`WORLD_OBS_FIELDS`) starts with the
    :data:`OBS_FIELDS` of its selected object, which the baselines read."""
    arr = np.asarray(obs, dtype=float)
    n, m = len(OBS_FIELDS), len(WORLD_OBS_FIELDS)
    if arr.ndim not in (1, 2) or arr.shape[-1] not in (n, m):
        raise InputError(
            f"obs must be one observation ({n},) or ({m},) or a batch (B, {n}) or (B, {m}) of "
            f"the collision-warning environments, got shape {arr.shape}"
        )
    return arr.reshape(-1, arr.shape[-1]), arr.ndim == 1


class Policy:
    """Base class of the baselines: subclasses implement :meth:`levels` on a batch."""

    #: Label of the policy in a comparison table.
    name: str = "policy"

    def __call__(self, obs: np.ndarray) -> int | np.ndarray:
        """The warning level for ``obs`` ``(F,)`` (an int), or for a batch ``(B, F)`` (``(B,)``)."""
        batch, single = _as_batch(obs)
        out = self.levels(batch).astype(np.int8)
        return int(out[0]) if single else out

    def reset(self) -> None:
        """Forget any state (a new episode starts); the stateless baselines have none."""

    def levels(self, obs: np.ndarray) -> np.ndarray:
        """Warning levels ``(B,)`` of a batch of observations ``(B, F)``."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name}>"


def _tracked(obs: np.ndarray) -> np.ndarray:
    """Observations with a fused track (and a finite gap)."""
    return (obs_field(obs, "track_valid") > 0.5) & np.isfinite(obs_field(obs, "gap"))


def _grade(valid: np.ndarray, imminent: np.ndarray, caution: np.ndarray) -> np.ndarray:
    """Level 2 where ``imminent``, else 1 where ``caution``, else 0; 0 where not ``valid``."""
    level = np.where(imminent, IMMINENT, np.where(caution, CAUTION, NONE))
    return np.where(valid, level, NONE).astype(np.int8)


class SafetyDistancePolicy(Policy):
    r"""The papers' rule: the fused gap against a safety distance.

    Imminent when :math:`\hat g - z\sigma_g < d_I`, caution when :math:`< d_C`, with
    :math:`(d_C, d_I)` from :func:`acc_fusion.warning.safety.safety_distances`; stateless (no
    hysteresis: see :class:`WarningLogicPolicy` for the latched rule).

    Args:
        model: a name of :data:`acc_fusion.warning.safety.SAFETY_MODELS` (default
            ``"stopping_distance"``).
        params: that model's parameter dataclass, or ``None`` for its defaults.
        z: compare the lower quantile :math:`\hat g - z\sigma_g` (default 0: the gap itself).
    """

    def __init__(self, model: str = "stopping_distance", params: object | None = None, z=0.0):
        check_choice("model", model, SAFETY_MODELS)
        # Validates params against the model (a mapping becomes the model's dataclass).
        self.model, self.params = model, WarningConfig(model=model, params=params).params
        self.z = check_range("z", z, 0.0, 10.0)
        self.name = f"safety_distance({model})" if self.z == 0 else f"{model}(z={self.z:g})"

    def levels(self, obs: np.ndarray) -> np.ndarray:
        valid = _tracked(obs)
        gap = obs_field(obs, "gap") - self.z * obs_field(obs, "gap_std")
        d_caution, d_imminent = safety_distances(
            self.model,
            np.maximum(np.where(valid, obs_field(obs, "ego_speed"), 0.0), 0.0),
            np.where(valid, obs_field(obs, "range_rate"), 0.0),
            np.where(valid, obs_field(obs, "lead_accel"), 0.0),
            self.params,
        )
        return _grade(valid, gap < d_imminent, gap < d_caution)


class UncertaintyAwarePolicy(SafetyDistancePolicy):
    r"""The papers' rule on the lower quantile of the gap, :math:`\hat g - z\sigma_g`.

    A less certain estimate warns earlier.  ``z = 1.645`` is the one-sided 95 % quantile of a
    Gaussian: the true gap is below the compared value with probability 5 %.
    """

    def __init__(self, z: float = 1.645, model: str = "stopping_distance", params=None) -> None:
        super().__init__(model, params, z)
        self.name = f"uncertainty_aware(z={self.z:g})"


class RSSPolicy(SafetyDistancePolicy):
    """The papers' rule with the RSS safe longitudinal distance (Shalev-Shwartz et al. 2017).

    Args:
        params: :class:`~acc_fusion.warning.safety_params.RSSParams` or ``None`` for Intel's
            defaults.
    """

    def __init__(self, params: object | None = None) -> None:
        super().__init__("rss", params)
        self.name = "rss"


class TTCPolicy(Policy):
    r"""Time-to-collision thresholds on the fused track.

    :math:`\mathrm{TTC} = \hat g / (-\dot{\hat g})` while closing (constant range-rate, as
    the test protocols define it; :func:`acc_fusion.warning.ttc.time_to_collision`), ``inf``
    otherwise.  Imminent when :math:`\mathrm{TTC} < T_I`, caution when :math:`< T_C`.

    Args:
        caution: :math:`T_C` [s] (default 3.0).
        imminent: :math:`T_I` [s] (default 2.4: the NHTSA FCW confirmation test asks for an
            alert at a TTC of at least 2.1 s in its stopped-lead test, plus a margin).
    """

    def __init__(self, caution: float = 3.0, imminent: float = 2.4) -> None:
        self.caution = check_range("caution", caution, 0.0, 60.0, lo_open=True)
        self.imminent = check_range("imminent", imminent, 0.0, 60.0, lo_open=True)
        if self.imminent > self.caution:
            raise ConfigError(
                f"imminent must be <= caution (TTC thresholds [s]), got {imminent!r} > {caution!r}"
            )
        self.name = f"ttc({self.caution:g}/{self.imminent:g} s)"

    def levels(self, obs: np.ndarray) -> np.ndarray:
        valid = _tracked(obs)
        ttc = time_to_collision(
            np.where(valid, obs_field(obs, "gap"), 1.0),
            np.where(valid, obs_field(obs, "range_rate"), 0.0),
        )
        return _grade(valid, ttc < self.imminent, ttc < self.caution)


class WarningLogicPolicy(Policy):
    """acc_fusion's shipped warning rule on the fused estimate (the oracle's rule on truth).

    :class:`acc_fusion.warning.logic.WarningLogic` with hysteresis, minimum on-time and optional
    k-of-n confirmation: stateful, so :meth:`reset` starts it afresh.  The batch size is
    taken from the first call after a reset.

    Args:
        config: the warning rule (default :class:`~acc_fusion.warning.logic.WarningConfig`, the
            environment's oracle rule).
        dt: the environment's step [s] (default 0.05, the environment's default).
    """

    def __init__(self, config: WarningConfig | None = None, dt: float = 0.05) -> None:
        self.config = config or WarningConfig()
        if not isinstance(self.config, WarningConfig):
            raise ConfigError(f"config must be a WarningConfig, got {type(config).__name__}")
        self.dt = check_range("dt", dt, 0.0, 10.0, lo_open=True)
        self.name = f"warning_logic({self.config.model})"
        self._logic: WarningLogic | None = None

    def reset(self) -> None:
        self._logic = None

    def levels(self, obs: np.ndarray) -> np.ndarray:
        if self._logic is None or self._logic.n_pairs != len(obs):
            self._logic = WarningLogic(self.config, len(obs), self.dt)
        valid = _tracked(obs)
        return self._logic.step(
            np.where(valid, obs_field(obs, "gap"), 0.0),
            obs_field(obs, "ego_speed"),
            np.where(valid, obs_field(obs, "range_rate"), 0.0),
            np.where(valid, obs_field(obs, "lead_accel"), 0.0),
            gap_std=np.where(valid, obs_field(obs, "gap_std"), 0.0),
            valid=valid,
        )


class AlwaysWarn(Policy):
    """Warns at ``level`` (default imminent) whenever there is a track: a sanity anchor."""

    def __init__(self, level: int = IMMINENT) -> None:
        if level not in (CAUTION, IMMINENT) or isinstance(level, bool):
            raise ConfigError(f"level must be 1 (caution) or 2 (imminent), got {level!r}")
        self.level = int(level)
        self.name = "always_warn"

    def levels(self, obs: np.ndarray) -> np.ndarray:
        return np.where(_tracked(obs), self.level, NONE).astype(np.int8)


class NeverWarn(Policy):
    """Never warns: a sanity anchor (the system switched off)."""

    name = "never_warn"

    def levels(self, obs: np.ndarray) -> np.ndarray:
        return np.zeros(len(obs), dtype=np.int8)


#: One ready instance of every baseline, by name (they are reset at every episode start, so
#: one instance serves any number of evaluations, one at a time).
BASELINES: dict[str, Callable[[np.ndarray], int | np.ndarray]] = {
    "safety_distance": SafetyDistancePolicy(),
    "warning_logic": WarningLogicPolicy(),
    "ttc": TTCPolicy(),
    "rss": RSSPolicy(),
    "uncertainty_aware": UncertaintyAwarePolicy(),
    "always_warn": AlwaysWarn(),
    "never_warn": NeverWarn(),
}
