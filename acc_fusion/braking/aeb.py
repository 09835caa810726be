r"""Automatic emergency braking (AEB): staged braking on the fused in-path estimate.

Pipeline: ... → warning → **AEB** → truth source (``advance(brake)``), beside the driver who
reacts to the warning; the source brakes at the stronger of the two requests.

Each of N vehicles runs the same decision on the estimate of its selected in-path object
(gap :math:`g`, range-rate :math:`\dot g`, lead acceleration :math:`a_l`, the ego's speed
:math:`v`), every step:

1. **Threat.**  The lead is predicted over the latency from decision to braking,
   :math:`T = t_c + t_d + a_\text{full}/(2j)` (the confirmation time, the brakes' dead time and
   half the build-up of full braking: the time at which a ramp acts like a step), the lead
   keeping :math:`a_l` until it stops and the ego its speed (as if AEB released now: braking
   that is still needed is never released, and a stage escalates once the braking it gives
   falls short); the deceleration the ego then needs to stop ``stop_margin`` short of the lead,
   :math:`a_\text{req}`, is CAMP's required deceleration
   (:func:`acc_fusion.warning.kinematics.required_deceleration`, the lead keeping its
   deceleration to a stop) — the same kinematics that the warning's default
   ``required_deceleration`` model and the crash-relevant classes of
   :mod:`acc_fusion.metrics.alert_classes` read.
2. **Stages.**  The wanted stage is *full* where :math:`a_\text{req} \ge` ``full_trigger``
   or where the time to collision of the estimate as it is (the lead keeping its deceleration
   to a stop, :func:`acc_fusion.warning.kinematics.time_to_collision_braking_lead`) is at most
   ``ttc_trigger`` — at a low closing speed the required deceleration grows large only a
   metre or two from the lead, closer than the sensors hold it —, *partial* where
   :math:`a_\text{req} \ge` ``partial_trigger``, none below; AEB engages once the wanted
   stage has held for ``confirm`` (a debounce against one noisy estimate), only within
   the operating speed range, and then only escalates: partial braking at ``partial_decel``,
   full braking at ``full_decel`` — also once partial braking no longer suffices
   (:math:`a_\text{req} \ge` ``partial_decel`` while braking partially).  The partial
   trigger lies above the crash-relevant threshold of the alert classes (3.4 m/s²) and the
   TTC trigger below theirs (2 s), but AEB judges the situation a latency ahead and a
   ``stop_margin`` short, so even a true estimate can engage it a moment before truth calls
   the situation crash-relevant: a *nuisance* activation on the true lead.  A sensing-false
   activation is an estimate's error.
3. **Release.**  AEB releases when the ego has stood still for ``standstill_hold``, when its
   object is no longer closing (:math:`\dot g \ge 0`), needs less than ``release_below`` and
   brakes less than that itself (a lead still braking ahead is still a threat), when the object
   has been lost for ``lost_hold``, or when the driver overrides (``override``, e.g. a
   kick-down; the simulated driver of :mod:`acc_fusion.truth.driver` never does).
4. **Brakes.**  The commanded deceleration reaches the wheels after the dead time
   ``delay`` and builds up (and releases) at most at ``jerk``.

The two-stage cascade, partial then full braking, is the production AEB's (Bosch: warning,
"partial braking to reduce the speed and give the driver valuable time to react", then
full braking when the collision is unavoidable; MathWorks, *Autonomous Emergency Braking with
Sensor Fusion*, Automated Driving Toolbox example: partial stages at 3.8 and 5.3 m/s², full
braking at 9.8 m/s²).  The trigger levels and the brake system's figures are this project's
choices (assumptions, see :class:`AEBConfig`); the operating range covers FMVSS 127's
(49 CFR 571.127, S5.1: 10 to 145 km/h for lead vehicles; final rule 89 FR 39686, 9 May 2024).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.slots import PairState
from acc_fusion.core.units import KMH, G
from acc_fusion.core.validation import check_range
from acc_fusion.warning.kinematics import urgency

#: The stages: none, partial braking, full braking.
OFF, PARTIAL, FULL = 0, 1, 2
#: Speed [m/s] under which the ego counts as stopped.
STOPPED = 0.1


@dataclass(frozen=True)
class AEBConfig:
    """Automatic emergency braking (off by default; see the module docstring).

    Attributes:
        enabled: whether the AEB stage brakes (``False``: FCW only).
        method: the method whose in-path estimate AEB reads (``None``: the method the driver
            hears, ``drive``, else the last of ``methods``).
        partial_trigger: required deceleration at which partial braking engages [m/s²]; 4.0,
            above the crash-relevant threshold 3.4 m/s² of the alert classes (assumption).
        full_trigger: required deceleration at which full braking engages [m/s²]; 6.0, two
            thirds of ``full_decel`` so that full braking still avoids the contact with the
            brake system's latency (assumption).
        partial_decel: partial braking [m/s²]; 5.0 (about 0.5 g, between the MathWorks
            example's partial stages of 3.8 and 5.3 m/s²).
        full_decel: full braking [m/s²]; 9.0 (about 0.9 g, a passenger car on a dry road;
            the MathWorks example uses 9.8 m/s²).
        confirm: how long the wanted stage must hold before AEB engages [s]; 0.1
            (assumption, the warning's ``persistence`` figure).
        delay: dead time of the brake system from command to deceleration [s]; 0.1
            (assumption: brake pre-fill and hydraulic delay of a production ESC unit).
        jerk: build-up (and release) rate of the deceleration [m/s³]; 30 (assumption: full
            braking reached in 0.3 s).
        min_speed, max_speed: operating range of the ego's estimated speed [m/s]; 7 and
            145 km/h: FMVSS 127 S5.1 requires 10-145 km/h, and a system that must work at a
            test speed of 10 km/h has to engage below it by its speed estimate's error
            (assumption: 3 km/h of margin).
        standstill_hold: how long AEB holds the stopped ego before it releases [s]; 1.0
            (assumption).
        lost_hold: how long AEB keeps braking after its object is lost [s]; 0.5
            (assumption: a track dropped at close range is not a threat gone).
        stop_margin: the distance short of the lead at which AEB aims to stop [m]; 1.0
            (assumption: test-track AEB stops typically leave about a metre).
        ttc_trigger: time to collision at which full braking engages [s]; 1.2 (assumption,
            below the 2.0 s of the crash-relevant classes).
        release_below: the required deceleration, and the lead's own, under which AEB
            releases once its object no longer closes [m/s²]; 1.0 (assumption: ordinary
            braking, left to the driver).
    """

    enabled: bool = False
    method: str | None = None
    partial_trigger: float = 4.0
    full_trigger: float = 6.0
    partial_decel: float = 5.0
    full_decel: float = 9.0
    confirm: float = 0.1
    delay: float = 0.1
    jerk: float = 30.0
    min_speed: float = 7.0 * KMH
    max_speed: float = 145.0 * KMH
    standstill_hold: float = 1.0
    lost_hold: float = 0.5
    stop_margin: float = 1.0
    ttc_trigger: float = 1.2
    release_below: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.enabled, bool):
            raise ConfigError(f"aeb.enabled must be true or false, got {self.enabled!r}")
        if self.method is not None and not isinstance(self.method, str):
            raise ConfigError(f"aeb.method must be a method's name or None, got {self.method!r}")
        for name in ("partial_trigger", "full_trigger", "partial_decel", "full_decel"):
            check_range(f"aeb.{name}", getattr(self, name), 0.0, 1.5 * G, lo_open=True)
        for name in ("confirm", "delay", "standstill_hold", "lost_hold"):
            check_range(f"aeb.{name}", getattr(self, name), 0.0, 10.0)
        check_range("aeb.jerk", self.jerk, 0.0, 1000.0, lo_open=True)
        check_range("aeb.stop_margin", self.stop_margin, 0.0, 20.0)
        check_range("aeb.ttc_trigger", self.ttc_trigger, 0.0, 10.0)
        check_range("aeb.release_below", self.release_below, 0.0, self.partial_trigger)
        check_range("aeb.min_speed", self.min_speed, 0.0, 100.0)
        check_range("aeb.max_speed", self.max_speed, 0.0, 100.0, lo_open=True)
        if self.full_trigger < self.partial_trigger:
            raise ConfigError(
                f"aeb.full_trigger ({self.full_trigger:g} m/s²) must not be below "
                f"aeb.partial_trigger ({self.partial_trigger:g} m/s²)"
            )
        if self.full_decel < self.partial_decel:
            raise ConfigError(
                f"aeb.full_decel ({self.full_decel:g} m/s²) must not be below "
                f"aeb.partial_decel ({self.partial_decel:g} m/s²)"
            )
        if self.max_speed <= self.min_speed:
            raise ConfigError(
                f"aeb.max_speed ({self.max_speed:g} m/s) must exceed aeb.min_speed "
                f"({self.min_speed:g} m/s)"
            )

    @property
    def latency(self) -> float:
        """The effective latency from decision to braking,
        :math:`t_c + t_d + a_\\text{full}/(2j)` [s]."""
        return self.confirm + self.delay + self.full_decel / (2.0 * self.jerk)


class AEB(PairState):
    """The AEB of N vehicles (:class:`AEBConfig`); :meth:`step` gives their braking [m/s²].

    Attributes (``(N,)``, after a step): ``stage`` the engaged stage (:data:`OFF`,
    :data:`PARTIAL`, :data:`FULL`), ``decel`` the deceleration the brakes produce,
    ``required`` the required deceleration the decision read (0 without an object)."""

    _PAIR_AXES = {"stage": 0, "decel": 0, "required": 0, "_held": 0, "_lost": 0,
                  "_still": 0, "_queue": 0}  # fmt: skip

    def __init__(self, config: AEBConfig, n: int, dt: float) -> None:
        check_range("dt", dt, 0.0, 1.0, lo_open=True)
        self.config, self.n, self.dt = config, n, dt
        self.stage = np.zeros(n, np.int8)
        self.decel = np.zeros(n)
        self.required = np.zeros(n)
        self._held = np.zeros(n, np.int64)  # steps the wanted stage has held
        self._lost = np.zeros(n, np.int64)  # steps without an object while engaged
        self._still = np.zeros(n, np.int64)  # steps stopped while engaged
        # commands on their way to the wheels: the dead time in steps, plus this step's
        self._queue = np.zeros((n, int(round(config.delay / dt)) + 1))
        self._k = 0  # the queue's column of this step's command
        c = config  # the kernel's parameters (_decide)
        self._prm = np.array([c.partial_trigger, c.full_trigger, c.partial_decel, c.full_decel,
                              c.min_speed, c.max_speed, c.jerk * dt, STOPPED])  # fmt: skip
        self._steps = np.array([_steps(c.confirm, dt), _steps(c.standstill_hold, dt),
                                _steps(c.lost_hold, dt)])  # fmt: skip

    def _resized(self, m: int) -> None:
        self.n = m

    def reset(self, pairs: np.ndarray) -> None:
        """Start ``pairs`` (a mask) afresh: not engaged, brakes released."""
        for a in (self.stage, self.decel, self.required, self._held, self._lost, self._still):
            a[pairs] = 0
        self._queue[pairs] = 0.0

    def step(self, gap, v_ego, v_rel, a_lead, valid, active, override=None) -> np.ndarray:
        """One step on each vehicle's estimate of its in-path object (``(N,)`` arrays: gap
        [m], ego speed [m/s], range-rate [m/s], lead acceleration [m/s²], ``valid`` where it
        has one; ``active`` the vehicles being driven; ``override`` where the driver
        overrides): the deceleration [m/s², >= 0] the brakes produce this step."""
        c, n = self.config, self.n
        has = np.asarray(valid, dtype=bool) & np.asarray(active, dtype=bool)
        v = np.maximum(np.asarray(v_ego, dtype=float), 0.0)
        g, vl, al = _predicted(gap, v, v_rel, a_lead, has, c.latency)
        need = urgency(np.where(has, g - c.stop_margin, g), v, vl, al)[0]
        self.required = np.where(has, np.minimum(need, 1e3), 0.0)
        lead_now = np.maximum(np.where(has, v + np.asarray(v_rel), v), 0.0)
        ttc = urgency(np.where(has, gap, 1.0), v, lead_now, np.where(has, a_lead, 0.0))[1]
        urgent = has & (ttc <= c.ttc_trigger)
        overridden = np.zeros(n, bool) if override is None else np.asarray(override, bool)
        # the object no longer closes and needs, and does, no hard braking: the threat is over
        over = has & (np.asarray(v_rel) >= 0.0) & (self.required < c.release_below)
        over &= np.asarray(a_lead) > -c.release_below
        active = np.asarray(active, bool)
        _decide(self.required, has, urgent, active, v, over, overridden, self._prm,
                self._steps, self.stage, self._held, self._lost, self._still)  # fmt: skip
        return self._brake(active)

    def actuate(self, stage, active) -> np.ndarray:
        """The brake system alone, commanded by another decision (e.g. a policy): each
        vehicle's ``stage`` (:data:`OFF`, :data:`PARTIAL`, :data:`FULL`) becomes its
        command; the deceleration [m/s², >= 0] the brakes produce this step."""
        active = np.asarray(active, bool)
        self.stage = np.where(active, np.asarray(stage, np.int8), OFF).astype(np.int8)
        return self._brake(active)

    def _brake(self, active: np.ndarray) -> np.ndarray:
        self._k = (self._k + 1) % self._queue.shape[1]
        _actuate(self.stage, active, self._prm, self._queue, self._k, self.decel)
        return self.decel


def _steps(duration: float, dt: float) -> int:
    """Whole steps covering ``duration`` (at least 1: a step is the shortest hold)."""
    return max(int(round(duration / dt)), 1)


def _predicted(gap, v, v_rel, a_lead, has, t):
    """Gap, lead speed and lead acceleration after ``t`` [s], the lead keeping its
    acceleration until it stops and the ego its speed; where no object (``has`` false), a lead
    1 m ahead at the ego's speed (which needs nothing)."""
    vl = np.maximum(np.where(has, v + v_rel, v), 0.0)
    al = np.where(has, a_lead, 0.0)
    stop = np.where(al < 0.0, vl / np.maximum(-al, 1e-9), np.inf)
    tl = np.minimum(t, stop)
    lead_moves = vl * tl + 0.5 * al * tl**2
    g = np.where(has, gap + lead_moves - v * t, 1.0)
    return g, np.maximum(vl + al * tl, 0.0), al


@njit(cache=True)
def _decide(
    required, has, urgent, active, v, over, override, prm, steps, stage, held, lost, still
):  # pragma: no cover - compiled  # fmt: skip
    """The stage machine of every vehicle (module docstring, steps 2-3).  ``prm``: triggers,
    decelerations, speed range, the deceleration change per step, the speed of a stopped ego;
    ``urgent`` where the TTC trigger holds, ``over`` where the threat is over; ``steps``:
    confirm, standstill hold and lost hold in steps."""
    partial_trigger, full_trigger, partial_decel = prm[0], prm[1], prm[2]
    min_speed, max_speed, stopped = prm[4], prm[5], prm[7]
    confirm, standstill, lost_hold = steps[0], steps[1], steps[2]
    for i in range(required.size):
        if not active[i]:
            stage[i] = 0
            held[i] = lost[i] = still[i] = 0
            continue
        want = 0
        if has[i]:
            if required[i] >= full_trigger or urgent[i]:
                want = 2
            elif required[i] >= partial_trigger:
                want = 1
        if stage[i] == 0:
            in_range = min_speed <= v[i] <= max_speed
            held[i] = held[i] + 1 if want > 0 and in_range and not override[i] else 0
            if held[i] >= confirm:
                stage[i] = want
                lost[i] = still[i] = 0
        else:
            held[i] = 0
            if want == 1 and stage[i] == 1 and required[i] >= partial_decel:
                want = 2  # partial braking no longer suffices
            if want > stage[i]:
                stage[i] = want
            lost[i] = 0 if has[i] else lost[i] + 1
            still[i] = still[i] + 1 if v[i] <= stopped else 0
            if override[i] or over[i] or lost[i] >= lost_hold or still[i] >= standstill:
                stage[i] = 0


@njit(cache=True)
def _actuate(stage, active, prm, queue, k, decel):  # pragma: no cover - compiled
    """The brakes of every vehicle (module docstring, step 4): ``queue[:, k]`` takes the
    command of this step's ``stage``, ``queue[:, k+1]`` (cyclic) is the one that reaches the
    wheels, and the deceleration moves toward it by at most ``prm[6]``; an inactive vehicle's
    brakes are released at once."""
    width = queue.shape[1]
    for i in range(stage.size):
        if not active[i]:
            for j in range(width):
                queue[i, j] = 0.0
            decel[i] = 0.0
            continue
        queue[i, k] = prm[2] if stage[i] == 1 else prm[3] if stage[i] == 2 else 0.0
        target = queue[i, (k + 1) % width]
        decel[i] = min(max(target, decel[i] - prm[6]), decel[i] + prm[6])
