r"""Warning logic: compare the gap with a safety distance, with levels, hysteresis and hold.

Two warning levels follow the two phases of ISO 15623:2013 (forward vehicle collision warning
systems): *caution* (the preliminary collision warning) and *imminent* (the collision warning,
"the need for urgent action").  For each pair and level :math:`L` the safety model
(:mod:`acc_fusion.warning.safety`) gives a distance :math:`d_L`, and the logic compares it with the
gap, or with its lower quantile :math:`\tilde g = g - z\,\sigma_g` when the gap is an estimate
with standard deviation :math:`\sigma_g` (uncertainty-aware warning: a larger σ warns earlier).

Each level is a latch with its own state; at every step, for every pair:

======================  ===================================================================
rule                    condition
======================  ===================================================================
condition               :math:`c_L = \tilde g < d_L`
raise                   :math:`c_L` now, and (with ``confirm = (k, n)``) :math:`c_L` in at
                        least k of the last n steps, this one included; ``persistence``
                        T is ``confirm = (k, k)`` with :math:`k = 1 + \operatorname{round}
                        (T / \Delta t)`: the condition held over T, to the nearest step
hold                    a raised level stays on for at least ``min_on_time`` seconds
lower                   after the hold, only once :math:`\tilde g > d_L(1 + h)`
                        (``hysteresis`` h); between :math:`d_L` and :math:`d_L(1+h)` the
                        level keeps its state
imminent ⇒ caution      the caution latch is on whenever the imminent one is
no track / no leader    ``valid`` False, or the ego slower than ``min_speed``: level none,
                        and the pair's state is cleared
output                  2 (imminent) if its latch is on, else 1 (caution) if on, else 0
======================  ===================================================================

The state is a handful of ``(2, N)`` arrays (latches, steps since raised, confirmation
counts) and a ``(2, N, n)`` ring of the last n conditions, so memory does not grow with the
run and a step costs a few vector operations whatever N.  The same class run on ground truth
(``gap_std=None``, ``valid = frame.has_leader``) is the oracle the metrics compare with.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from acc_fusion.core.arrays import check_array
from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.levels import CAUTION, IMMINENT, NONE
from acc_fusion.core.slots import PairState, pair_mask
from acc_fusion.core.units import KMH
from acc_fusion.core.validation import check_choice, check_mask, check_range
from acc_fusion.warning.safety import SAFETY_MODELS, model_constants
from acc_fusion.warning.safety_kernels import distances_unchecked


@dataclass(frozen=True)
class AdaptiveConfig:
    r"""Driver-state-adaptive timing: a later warning for a driver who is attending to the road.

    Two signals tell the warning that a driver attends: a driver-monitoring camera
    (:class:`acc_fusion.sensors.driver_monitor.DriverMonitor`, ``enabled``) that sees his
    eyes on the road, and his own braking (``braking``): a driver who brakes at
    :math:`-a_\text{ego} \ge` ``braking`` has already reacted.  For the drivers either
    signal reports attentive the warning computes its distances with ``reaction_time`` in
    place of the model's reaction time (or the model's, if shorter: the attentive timing
    never warns earlier); for the others it keeps the model's timing.  So a
    braking driver is still warned when even an attentive reaction would need more than the
    model's deceleration threshold: the braking signal retimes the warning, it does not
    suppress it.  Production systems read the driver's action the same way (e.g. the
    Jaguar I-Pace owner's manual: the forward alert "may not issue the warning if the driver
    has taken the appropriate action (braking, steering or indicating) early enough").  The
    camera only runs where the drivers have a gaze to watch
    (eyes-off-road episodes, ``driver.distraction.rate`` > 0; not in the NHTSA and Euro NCAP
    tests); the braking signal runs wherever the warning sees the ego's acceleration (every
    closed or open loop of :func:`acc_fusion.sim.closed_loop.simulate`, the 2-D world's
    included, and ``acc-fusion tune``), but not in the gymnasium environment's oracle, which
    keeps the model's timing.
    Only a model with a ``reaction_time`` parameter (``required_deceleration``) can adapt:
    enabling the camera with another is a one-line error, and the braking signal leaves the
    others' timing as it is.

    The idea is the adaptive safety warning of NHTSA's SAVE-IT programme (M. R. Smith,
    G. J. Witt, D. L. Bakowski, *SAVE-IT Summary and Benefits Estimation*, Task 15 final
    report, Delphi, 2008; R. Hammoud, M. R. Smith, R. Dufour, D. Bakowski, G. Witt, "Driver
    distraction monitoring and adaptive safety warning systems", SAE, 2008): a warning helps
    a driver who is not looking and annoys one who is.  How much later SAVE-IT warned an
    attentive driver could not be read here; the attentive reaction time below is this
    project's choice.  Every new car sold in the EU from 7 July 2026 has the camera, as its
    advanced driver distraction warning (Regulation (EU) 2019/2144, Art. 6; Commission
    Delegated Regulation (EU) 2023/2590).  The camera is off by default (the braking
    signal is on): what it costs in crashes depends
    on how an attentive driver meets a threat by himself, which the truth sources model
    differently (SUMO's car-following model against the scripted driver's reaction time;
    docs/theory/alert-classes.md).

    Attributes:
        enabled: whether the warning reads the driver-monitoring camera (default False).
        reaction_time: brake reaction time assumed for an attentive driver [s] (default 0.75:
            Green, "How long does it take to stop?", *Transportation Human Factors*
            2(3):195-216, 2000, about 0.7-0.75 s for a driver fully aware of the time and
            place of the signal, against 1.25 s for an unexpected but common one).
        latency: the monitor's detection latency [s] (default 0.2, an assumption; see
            :mod:`acc_fusion.sensors.driver_monitor`).
        recovery: how long a driver still counts as distracted after his eyes come back [s]
            (default 1.0, an assumption; same module).
        braking: the deceleration [m/s²] from which a braking driver counts as attentive,
            read from the vehicle's own (true) acceleration as a brake switch would report
            it; 0: braking is not a signal.  Default 1.0, an assumption of this project (no
            brake-switch threshold for FCW was found published): above the 0.3-0.7 m/s² that
            rolling and air resistance and engine drag give a passenger car coasting at
            motorway speeds, so a driver who decelerates harder is braking.
    """

    enabled: bool = False
    reaction_time: float = 0.75
    latency: float = 0.2
    recovery: float = 1.0
    braking: float = 1.0

    def __post_init__(self) -> None:
        check_range("warning.adaptive.reaction_time", self.reaction_time, 0.0, 10.0)
        check_range("warning.adaptive.latency", self.latency, 0.0, 60.0)
        check_range("warning.adaptive.recovery", self.recovery, 0.0, 60.0)
        check_range("warning.adaptive.braking", self.braking, 0.0, 20.0)

    @property
    def active(self) -> bool:
        """Whether any signal adapts the timing (the camera or braking)."""
        return self.enabled or self.braking > 0

    def attentive(self, looking: np.ndarray | None, ego_accel: np.ndarray) -> np.ndarray | None:
        """``(N,)`` bool, the drivers the warning times as attentive: those the camera reports
        ``looking`` (``(N,)`` bool, or ``None`` without a camera) or who brake at
        ``braking`` or harder (``ego_accel (N,)`` [m/s²]); ``None`` when nothing adapts."""
        if not self.active:
            return None
        braking = np.asarray(ego_accel) <= -self.braking if self.braking > 0 else None
        if looking is None or braking is None:
            return looking if braking is None else braking
        return looking | braking


@dataclass(frozen=True)
class WarningConfig:
    """How the warning is raised and lowered (one typed place for every warning default).

    Attributes:
        model: safety-distance model, a name of :data:`acc_fusion.warning.safety.SAFETY_MODELS`
            (default ``"required_deceleration"``, CAMP's rule, which reads the lead's
            closing speed and deceleration: in the bundled motorway's traffic, 2-D world,
            it raises 8.7 nuisance and sensing-false alerts per 100 km over ten seeds (4.1
            with the camera of ``adaptive``), and 5.8 nuisance alerts on truth against 69
            for the papers' ``"stopping_distance"``, which stays on in close following; see
            docs/theory/alert-classes.md).
        params: that model's parameter dataclass (e.g.
            :class:`~acc_fusion.warning.safety_params.MazdaParams`), a mapping of its fields (from
            TOML or YAML), or ``None`` for its defaults.
        hysteresis: a level is lowered only once the gap exceeds :math:`d(1 + h)` [fraction]
            (default 0.1).
        min_on_time: a raised level is held at least this long [s] (default 0.5).
        confirm: ``(k, n)``: raise only when the condition held in k of the last n steps,
            this one included (``None``, the default: raise at once).
        persistence: raise only when the condition has held this long [s], to the nearest
            step: ``confirm = (k, k)`` with ``k = 1 + round(persistence / dt)``, so the same
            time whatever the step (default 0: raise at once; exclusive with ``confirm``).
            With the camera, 0.3 s brings the bundled motorway's traffic to 1.25 nuisance
            and sensing-false alerts per 100 km over ten seeds, at four in ten of the
            crashes FCW avoids (docs/theory/alert-classes.md); any value is an assumption.
        z: compare the lower quantile :math:`g - z\\sigma_g` of the estimated gap instead of
            the gap (default 0: the gap itself).
        adaptive: driver-state-adaptive timing (:class:`AdaptiveConfig`: the driver's
            braking by default, the driver-monitoring camera on request).
        min_speed: the warning is off below this ego speed [m/s] (default 10 km/h, 2.78):
            FCW is a warning for moving traffic, not for creeping in a queue, where the
            gaps sit at the standstill margin and the estimated closing speed's noise
            would decide the alerts.  ISO 15623:2013 keeps the system in standby, with no
            warning, until the speed is within its operating range; production minimums
            range from 2 km/h (2019 Dodge Durango owner's manual) to 15-16 km/h (Infiniti,
            Chrysler manuals), and China's GB/T 33577-2017 requires a minimum of at most
            11.2 m/s.  10 km/h within that range is this project's choice, an assumption.
    """

    model: str = "required_deceleration"
    params: object | None = None
    hysteresis: float = 0.1
    min_on_time: float = 0.5
    confirm: tuple[int, int] | None = None
    persistence: float = 0.0
    z: float = 0.0
    adaptive: AdaptiveConfig = AdaptiveConfig()
    min_speed: float = 10.0 * KMH

    def __post_init__(self) -> None:
        check_choice("warning.model", self.model, SAFETY_MODELS)
        _, cls = SAFETY_MODELS[self.model]
        if isinstance(self.params, Mapping):
            object.__setattr__(self, "params", from_mapping(cls, self.params, "warning.params."))
        elif self.params is not None and not isinstance(self.params, cls):
            raise ConfigError(
                f"warning.params must be a {cls.__name__} for model {self.model!r}, "
                f"got {type(self.params).__name__}"
            )
        check_range("warning.hysteresis", self.hysteresis, 0.0, 10.0)
        check_range("warning.min_on_time", self.min_on_time, 0.0, 60.0)
        check_range("warning.z", self.z, 0.0, 10.0)
        check_range("warning.persistence", self.persistence, 0.0, 10.0)
        check_range("warning.min_speed", self.min_speed, 0.0, 100.0)
        if self.persistence > 0 and self.confirm is not None:
            raise ConfigError("warning.persistence and warning.confirm exclude each other")
        if self.confirm is not None:
            ok = isinstance(self.confirm, (tuple, list)) and len(self.confirm) == 2
            k, n = self.confirm if ok else (None, None)
            whole = all(isinstance(x, int) and not isinstance(x, bool) for x in (k, n))
            if not (whole and 1 <= k <= n <= 1000):
                raise ConfigError(
                    "warning.confirm must be None or two whole numbers (k, n) with "
                    f"1 <= k <= n <= 1000, got {self.confirm!r}"
                )
            object.__setattr__(self, "confirm", (k, n))
        if self.adaptive.enabled and not hasattr(self.params or cls(), "reaction_time"):
            raise ConfigError(
                "warning.adaptive needs a model with a reaction_time parameter "
                f"(required_deceleration), got model {self.model!r}"
            )


def _per_pair(value: object, n: int) -> np.ndarray:
    """A scalar or ``(N,)`` input as a float array, ``(N,)`` for a scalar (not checked)."""
    arr = np.asarray(value, dtype=float)
    return np.full(n, arr) if arr.ndim == 0 else arr


class WarningLogic(PairState):
    """Batched warning state machine over N pairs (rules in the module docstring).

    Args:
        config: the warning rules.
        n_pairs: number of follower→leader pairs N.
        dt: step of the calls to :meth:`step` [s].
    """

    _PAIR_AXES = dict.fromkeys(("_on", "_steps_on", "_history", "_count"), 1)

    def __init__(self, config: WarningConfig, n_pairs: int, dt: float) -> None:
        if not isinstance(n_pairs, (int, np.integer)) or n_pairs < 1:
            raise ConfigError(f"n_pairs must be a whole number >= 1, got {n_pairs!r}")
        self.config = config
        self.n_pairs = int(n_pairs)
        self.dt = check_range("warning.dt", dt, 0.0, 10.0, lo_open=True)
        self._model, self._constants = model_constants(config.model, config.params)
        self._attentive = None  # the constants for an attentive driver (adaptive timing)
        params = config.params or SAFETY_MODELS[config.model][1]()
        if config.adaptive.active and hasattr(params, "reaction_time"):
            late = min(params.reaction_time, config.adaptive.reaction_time)  # never earlier
            self._attentive = model_constants(config.model, replace(params, reaction_time=late))[1]
        k = 1 + math.floor(config.persistence / self.dt + 0.5)  # to the nearest step
        self._k, self._n = config.confirm or (k, k)
        # Steps a raised level is held: on for at least ceil(min_on_time / dt) steps.
        self._hold = math.ceil(config.min_on_time / self.dt - 1e-9)
        shape = (2, self.n_pairs)
        self._on = np.zeros(shape, dtype=bool)
        self._steps_on = np.zeros(shape, dtype=np.int64)
        self._history = np.zeros((*shape, self._n), dtype=bool)
        self._count = np.zeros(shape, dtype=np.int64)
        self._slot = 0

    def reset(self, pairs: np.ndarray | None = None) -> None:
        """Clear the state of the pairs in ``pairs`` (boolean mask or indices; all if None)."""
        _clear(pair_mask(pairs, self.n_pairs), self._on, self._steps_on, self._history, self._count)

    def _resized(self, m: int) -> None:
        self.n_pairs = m

    @property
    def level(self) -> np.ndarray:
        """Current warning level of every pair, ``(N,)`` int8 (:data:`NONE` … :data:`IMMINENT`)."""
        caution, imminent = self._on
        return np.where(imminent, IMMINENT, np.where(caution, CAUTION, NONE)).astype(np.int8)

    def step(
        self, gap, v_ego, v_rel, a_lead=0.0, gap_std=None, valid=None, attentive=None
    ) -> np.ndarray:
        """Advance one step of ``dt`` and return the warning levels ``(N,)`` int8.

        Args:
            gap: gap [m], ``(N,)`` (may be NaN where not ``valid``).
            v_ego: ego speed [m/s], scalar or ``(N,)``; clipped at 0 (an estimated speed may
                dip below zero at standstill).
            v_rel: range-rate [m/s], negative when closing, scalar or ``(N,)``.
            a_lead: lead acceleration [m/s²], scalar or ``(N,)`` (used by the models that
                need it).
            gap_std: standard deviation of the gap [m], ``(N,)``, or ``None`` for an exact gap.
            valid: ``(N,)`` pairs with a track (or, on truth, a leader); ``None`` = all.
            attentive: ``(N,)`` bool, the drivers timed as attentive
                (:meth:`AdaptiveConfig.attentive`); with :attr:`WarningConfig.adaptive`
                active their distances use the attentive reaction time; ``None``: nobody.
        """
        n = self.n_pairs
        ok = np.ones(n, dtype=bool) if valid is None else check_mask("valid", valid, n)
        cfg = self.config
        g = np.asarray(gap, dtype=float)
        sigma = np.zeros(n) if gap_std is None else _per_pair(gap_std, n)
        v, rel, acc = _per_pair(v_ego, n), _per_pair(v_rel, n), _per_pair(a_lead, n)
        if not (
            g.shape == sigma.shape == v.shape == rel.shape == acc.shape == (n,)
            and _usable(g, sigma, v, rel, acc, ok)
        ):  # the checks raise the error of the first bad input
            check_array("gap", g, (n,), where=ok)
            check_array("gap_std", sigma, (n,), nonnegative=True, where=ok)
            check_array("v_ego", v, (n,), where=ok)
            check_array("v_rel", rel, (n,), where=ok)
            check_array("a_lead", acc, (n,), where=ok)
        if cfg.min_speed > 0:
            ok = ok & (v >= cfg.min_speed)
        d_caution, d_imminent = distances_unchecked(self._model, self._constants, v, rel, acc)
        if self._attentive is not None and attentive is not None:
            looking = check_mask("attentive", attentive, n)
            idx = np.flatnonzero(looking)
            if idx.size:  # the attentive timing, for those drivers only
                late = distances_unchecked(self._model, self._attentive, v[idx], rel[idx], acc[idx])
                d_caution[idx], d_imminent[idx] = late

        level = np.empty(n, dtype=np.int8)
        _latch(
            g, sigma, cfg.z, d_caution, d_imminent, ok, self._on, self._steps_on, self._history,
            self._count, self._slot, self._k, self._hold, cfg.hysteresis, level,
        )  # fmt: skip
        self._slot = (self._slot + 1) % self._n
        return level


@njit(cache=True)
def _usable(gap, gap_std, v_ego, v_rel, a_lead, ok):  # pragma: no cover - compiled
    """True if the inputs ``(N,)`` of :meth:`WarningLogic.step` are finite, and ``gap_std``
    is >= 0, at the pairs in ``ok``."""
    for i in range(ok.size):
        if ok[i] and not (
            np.isfinite(gap[i])
            and np.isfinite(gap_std[i])
            and gap_std[i] >= 0.0
            and np.isfinite(v_ego[i])
            and np.isfinite(v_rel[i])
            and np.isfinite(a_lead[i])
        ):
            return False
    return True


@njit(cache=True)
def _clear(pairs, on, steps_on, history, count):  # pragma: no cover - compiled
    """:func:`_clear_one` of the pairs in ``pairs (N,)``."""
    for i in range(pairs.size):
        if pairs[i]:
            _clear_one(i, on, steps_on, history, count)


@njit(cache=True, inline="always")
def _clear_one(i, on, steps_on, history, count):  # pragma: no cover - compiled
    """Clear pair ``i``'s latches, in place: off, no steps on, no true condition in the
    history ring."""
    for lv in range(2):
        on[lv, i] = False
        steps_on[lv, i] = 0
        if count[lv, i]:  # the ring holds count[lv, i] true conditions
            count[lv, i] = 0
            history[lv, i, :] = False


@njit(cache=True)
def _latch(
    gap, gap_std, z, d_caution, d_imminent, ok, on, steps_on, history, count, slot, k, hold,
    hysteresis, level,
):  # pragma: no cover - compiled  # fmt: skip
    """One step of the latches of every pair, in place (the rules of the module docstring).

    ``gap - z * gap_std (N,)`` is the compared gap, ``d_caution``, ``d_imminent (N,)`` the
    distances, ``ok (N,)`` the pairs with a track; ``history[:, :, slot]`` receives this
    step's conditions; ``level (N,)`` receives the output level.
    """
    now = np.zeros(2, dtype=np.bool_)
    d = np.empty(2)
    for i in range(ok.size):
        if not ok[i]:  # no track: level none, state cleared
            _clear_one(i, on, steps_on, history, count)
            level[i] = NONE
            continue
        lower = gap[i] - z * gap_std[i]
        d[0], d[1] = d_caution[i], d_imminent[i]
        for lv in range(2):
            cond = lower < d[lv] and d[lv] > 0.0  # d = 0: no distance is needed at all
            count[lv, i] += np.int64(cond) - np.int64(history[lv, i, slot])
            history[lv, i, slot] = cond
            steps_on[lv, i] += np.int64(on[lv, i])
            release = steps_on[lv, i] >= hold and lower > d[lv] * (1.0 + hysteresis)
            now[lv] = (on[lv, i] and not release) or (cond and count[lv, i] >= k)
        now[0] = now[0] or now[1]  # imminent => caution
        for lv in range(2):
            if now[lv] and not on[lv, i]:
                steps_on[lv, i] = 0
            on[lv, i] = now[lv]
        level[i] = IMMINENT if now[1] else (CAUTION if now[0] else NONE)
