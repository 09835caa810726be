r"""Safety-distance models: the gaps below which a forward-collision warning is raised.

Every model is a pure, vectorised function of the kinematics of N follower→leader pairs,

``model(v_ego, v_rel, a_lead=0.0, params=None) -> (d_caution, d_imminent)``

with SI units and the conventions of acc_fusion: ``v_ego`` the ego (follower) speed [m/s],
``>= 0``; ``v_rel`` the range-rate :math:`\dot g = v_\text{lead} - v_\text{ego}` [m/s],
negative when closing; ``a_lead`` the lead's acceleration [m/s²], negative when it brakes
(only :func:`required_deceleration` uses it; the other models take it for a uniform
signature).  Scalars broadcast against arrays of shape ``(N,)``.  Symbols used below:

.. math::

    v = v_\text{ego}, \qquad v_l = \max(v + v_\text{rel}, 0), \qquad
    v_c = -v_\text{rel} \ \text{(closing speed)}, \qquad b = \max(-a_\text{lead}, 0).

(The lead speed is clipped at zero: a noisy range-rate of a stopped lead may say otherwise.)

Each model returns two distances [m], arrays ``(N,)``: the system warns *caution* while the
gap is below ``d_caution`` and *imminent* while it is below ``d_imminent``, the two warning
phases of ISO 15623:2013 (a preliminary collision warning, and the collision warning that asks
for urgent action).  Both are clipped at 0 and ``d_caution`` is raised to ``d_imminent`` where a
model's two formulas cross, so ``0 <= d_imminent <= d_caution`` always (imminent implies
caution).

=========================  ===================================================================
name                       model (defaults in the parameter class)
=========================  ===================================================================
``time_headway``           :math:`d_0 + h v` (two-second rule)
``ttc``                    :math:`T v_c + d_0` (time-to-collision threshold)
``stopping_distance``      reaction + ego braking vs the lead's emergency stop
``mazda``                  Doi et al. 1994 (Mazda)
``honda``                  Fujita et al. 1995 (Honda)
``berkeley``               Seiler, Song & Hedrick 1998 (PATH)
``rss``                    Shalev-Shwartz, Shammah & Shashua 2017 (RSS)
``required_deceleration``  gap at which the deceleration needed after a reaction delay
                           reaches a threshold (CAMP required-deceleration approach)
=========================  ===================================================================

:func:`safety_distances` calls a model by name (:data:`SAFETY_MODELS`), and
:func:`time_to_collision` gives the time to collision used by the "TTC at warning" metrics.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.validation import check_array, check_choice, check_range

Distances = tuple[np.ndarray, np.ndarray]


# --------------------------------------------------------------------------------------------
# Shared helpers: parameter checks, input checks, the caution/imminent invariant.
# --------------------------------------------------------------------------------------------


def _check_times(prefix: str, obj: object, *names: str) -> None:
    for name in names:
        check_range(f"{prefix}.{name}", getattr(obj, name), 0.0, 10.0)


def _check_decels(prefix: str, obj: object, *names: str) -> None:
    for name in names:
        check_range(f"{prefix}.{name}", getattr(obj, name), 0.0, 20.0, lo_open=True)


def _check_lengths(prefix: str, obj: object, *names: str) -> None:
    for name in names:
        check_range(f"{prefix}.{name}", getattr(obj, name), 0.0, 100.0)


def _check_order(prefix: str, obj: object, low: str, high: str) -> None:
    lo, hi = getattr(obj, low), getattr(obj, high)
    if lo > hi:
        raise ConfigError(f"{prefix}.{low} must be <= {prefix}.{high}, got {lo!r} > {hi!r}")


def _resolve(params: object | None, cls: type, model: str):
    """The model's parameters: ``params``, or the defaults when it is ``None``."""
    if params is None:
        return cls()
    if not isinstance(params, cls):
        raise ConfigError(
            f"params of safety model {model!r} must be a {cls.__name__}, "
            f"got {type(params).__name__}"
        )
    return params


def _kinematics(v_ego, v_rel, a_lead) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate and broadcast the inputs; return them as arrays ``(N,)``."""
    v = check_array("v_ego", v_ego, nonnegative=True)
    rel = check_array("v_rel", v_rel)
    acc = check_array("a_lead", a_lead)
    try:
        shape = np.broadcast(v, rel, acc).shape or (1,)  # scalars give (1,)
    except ValueError:
        raise InputError(
            "v_ego, v_rel and a_lead must be scalars or arrays of one length N, got shapes "
            f"{np.shape(v_ego)}, {np.shape(v_rel)} and {np.shape(a_lead)}"
        ) from None
    if len(shape) != 1:
        raise InputError(f"v_ego, v_rel and a_lead must be 1-D (N,), got shape {shape}")
    return np.broadcast_to(v, shape), np.broadcast_to(rel, shape), np.broadcast_to(acc, shape)


def _distances(name: str, v_ego, v_rel, a_lead, params: object | None) -> Distances:
    """The safety model ``name`` on checked inputs (the body of every model function)."""
    model, c = model_constants(name, params)
    return distances_unchecked(model, c, *_kinematics(v_ego, v_rel, a_lead))


# Kernels that divide use error_model="numpy": IEEE division as in numpy, without the checks
# for a zero divisor that would raise ZeroDivisionError (and keep loops from vectorising).


@njit(cache=True)
def _maximum(a, b):  # pragma: no cover - compiled
    """``np.maximum`` of two floats: NaN if either is NaN, else the larger (``b`` if equal)."""
    return a if a > b or a != a else b


@njit(cache=True)
def _minimum(a, b):  # pragma: no cover - compiled
    """``np.minimum`` of two floats: NaN if either is NaN, else the smaller (``b`` if equal)."""
    return a if a < b or a != a else b


@njit(cache=True)
def _levels(d_caution, d_imminent):  # pragma: no cover - compiled
    """Clip at 0 and make imminent imply caution: ``0 <= d_imminent <= d_caution``."""
    d_imminent = _maximum(d_imminent, 0.0)
    return _maximum(d_caution, d_imminent), d_imminent


# --------------------------------------------------------------------------------------------
# Time headway
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TimeHeadwayParams:
    """Parameters of :func:`time_headway`.

    Attributes:
        headway_caution: time headway h of the caution level [s] (default 2.0: the
            "two-second rule" of driver training, quoted by Vogel, *Accid. Anal. Prev.*
            35:427, 2003, §1).
        headway_imminent: time headway of the imminent level [s] (default 1.0: half the
            two-second rule, the "small headway" class of Vogel 2003).
        d0: standstill distance [m] (default 2.5: SUMO's default ``minGap``).
    """

    headway_caution: float = 2.0
    headway_imminent: float = 1.0
    d0: float = 2.5

    def __post_init__(self) -> None:
        _check_times("time_headway", self, "headway_caution", "headway_imminent")
        _check_lengths("time_headway", self, "d0")
        _check_order("time_headway", self, "headway_imminent", "headway_caution")

    def _constants(self) -> tuple[float, ...]:
        return self.headway_caution, self.headway_imminent, self.d0


def time_headway(v_ego, v_rel, a_lead=0.0, params: TimeHeadwayParams | None = None) -> Distances:
    r"""Constant time-headway distance (the two-second rule).

    .. math:: d_L = d_0 + h_L\, v

    Ignores the lead's motion: it warns whenever the ego follows closer than ``h`` seconds.
    Source: the two-second rule of driver training (Vogel 2003, §1; see
    :class:`TimeHeadwayParams` for the defaults).
    """
    return _distances("time_headway", v_ego, v_rel, a_lead, params)


@njit(cache=True)
def _time_headway(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`time_headway` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    headway_caution, headway_imminent, d0 = c[:3]
    return d0 + headway_caution * v, d0 + headway_imminent * v


# --------------------------------------------------------------------------------------------
# Time to collision
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TTCParams:
    """Parameters of :func:`ttc`.

    Attributes:
        ttc_caution: TTC threshold of the caution level [s] (default 2.4: the latest alert
            NHTSA's NCAP "Forward Collision Warning System Confirmation Test" (2013) accepts
            in its lead-vehicle-decelerating test; 2.1 s and 2.0 s for a stopped and a slower
            lead).
        ttc_imminent: TTC threshold of the imminent level [s] (default 1.5: van der Horst's
            minimum TTC separating critical from normal approaches, discussed for collision
            avoidance systems by van der Horst & Hogema, "Time-to-collision and collision
            avoidance systems", Proc. 6th ICTCT workshop, 1994).
        d0: distance added to both thresholds [m] (default 0: the pure TTC criterion).
    """

    ttc_caution: float = 2.4
    ttc_imminent: float = 1.5
    d0: float = 0.0

    def __post_init__(self) -> None:
        _check_times("ttc", self, "ttc_caution", "ttc_imminent")
        _check_lengths("ttc", self, "d0")
        _check_order("ttc", self, "ttc_imminent", "ttc_caution")

    def _constants(self) -> tuple[float, ...]:
        return self.ttc_caution, self.ttc_imminent, self.d0


def ttc(v_ego, v_rel, a_lead=0.0, params: TTCParams | None = None) -> Distances:
    r"""Time-to-collision threshold in distance form.

    .. math:: d_L = T_L \max(v_c, 0) + d_0

    With :math:`d_0 = 0`, ``gap < d_L`` is exactly :math:`\mathrm{TTC} = g / v_c < T_L`;
    nothing is raised while the gap opens.  Sources: see :class:`TTCParams`.
    """
    return _distances("ttc", v_ego, v_rel, a_lead, params)


@njit(cache=True)
def _ttc(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`ttc` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    ttc_caution, ttc_imminent, d0 = c[:3]
    closing = _maximum(vc, 0.0)
    return ttc_caution * closing + d0, ttc_imminent * closing + d0


# --------------------------------------------------------------------------------------------
# Stopping distance
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StoppingDistanceParams:
    """Parameters of :func:`stopping_distance`.

    Attributes:
        reaction_caution: driver reaction time of the caution level [s] (default 1.5: brake
            reaction to a surprise event, Green, "How long does it take to stop?",
            *Transportation Human Factors* 2(3):195, 2000).
        decel_caution: ego deceleration of the caution level [m/s²] (default 4.9 ≈ 0.5 g,
            firm braking).
        reaction_imminent: reaction time of the imminent level [s] (default 1.0: between
            Green's 0.75 s for an expected signal and 1.25 s for an unexpected one; an FCW
            alert is a signal the driver knows but does not expect).
        decel_imminent: ego deceleration of the imminent level [m/s²] (default 6.0 ≈ 0.6 g,
            hard braking of an alerted driver; below the 0.8 g full braking of Fujita et al.
            1995, which few drivers reach).
        lead_decel: deceleration of the lead's emergency stop [m/s²] (default 6.0: as hard
            as the ego's imminent braking, the equal-braking assumption of kinematic FCW
            models such as Berkeley's; then steady following at a constant gap raises no
            imminent alert above a headway of ``reaction_imminent`` + d0/v).
        d0: standstill distance [m] (default 2.5: SUMO's default ``minGap``).
    """

    reaction_caution: float = 1.5
    decel_caution: float = 4.9
    reaction_imminent: float = 1.0
    decel_imminent: float = 6.0
    lead_decel: float = 6.0
    d0: float = 2.5

    def __post_init__(self) -> None:
        p = "stopping_distance"
        _check_times(p, self, "reaction_caution", "reaction_imminent")
        _check_decels(p, self, "decel_caution", "decel_imminent", "lead_decel")
        _check_lengths(p, self, "d0")
        _check_order(p, self, "reaction_imminent", "reaction_caution")
        _check_order(p, self, "decel_caution", "decel_imminent")

    def _constants(self) -> tuple[float, ...]:
        return (
            self.reaction_caution,
            self.decel_caution,
            self.reaction_imminent,
            self.decel_imminent,
            self.lead_decel,
            self.d0,
        )


def stopping_distance(
    v_ego, v_rel, a_lead=0.0, params: StoppingDistanceParams | None = None
) -> Distances:
    r"""Kinematic stopping-distance model: the ego must stop behind the lead's stopping point.

    .. math::

        d_L = \max\!\left(v\,t_{r,L} + \frac{v^2}{2 a_L} - \frac{v_l^2}{2 a_\text{lead}}, 0
        \right) + d_0

    The ego reacts after :math:`t_{r,L}` and brakes at :math:`a_L` while the lead makes an
    emergency stop at :math:`a_\text{lead}`; only the two stopping points are compared (the
    classic safe-following-distance formula, e.g. the minimum safe headway
    :math:`T = t_r + \tfrac{V}{2}(1/a_f - 1/a_l)` of the "Headway" literature, here with
    separate ego and lead speeds).  Caution: a surprised driver braking firmly; imminent: an
    alert driver braking fully (defaults and sources in :class:`StoppingDistanceParams`).
    """
    return _distances("stopping_distance", v_ego, v_rel, a_lead, params)


@njit(cache=True, error_model="numpy")
def _stopping_distance(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`stopping_distance` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    reaction_caution, decel_caution, reaction_imminent, decel_imminent, lead_decel, d0 = c
    lead_stop = vl * vl / (2.0 * lead_decel)
    return (
        _maximum(v * reaction_caution + v * v / (2.0 * decel_caution) - lead_stop, 0.0) + d0,
        _maximum(v * reaction_imminent + v * v / (2.0 * decel_imminent) - lead_stop, 0.0) + d0,
    )


# --------------------------------------------------------------------------------------------
# Mazda (Doi et al. 1994)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MazdaParams:
    """Parameters of :func:`mazda` (Doi et al. 1994, as reproduced by Lee & Peng 2005).

    Attributes:
        alpha1: ego deceleration α1 [m/s²] (default 6).
        alpha2: lead deceleration α2 [m/s²] (default 8).
        tau1: system delay τ1 [s] (default 0.1).
        tau2: driver delay τ2 [s] (default 0.6), used by the caution level.
        tau2_imminent: driver delay of the imminent level [s] (default 0: no driver delay,
            only the system's; an acc_fusion choice, the published algorithm has one level).
        d0: headway offset [m] (default 5).
    """

    alpha1: float = 6.0
    alpha2: float = 8.0
    tau1: float = 0.1
    tau2: float = 0.6
    tau2_imminent: float = 0.0
    d0: float = 5.0

    def __post_init__(self) -> None:
        _check_decels("mazda", self, "alpha1", "alpha2")
        _check_times("mazda", self, "tau1", "tau2", "tau2_imminent")
        _check_lengths("mazda", self, "d0")
        _check_order("mazda", self, "tau2_imminent", "tau2")

    def _constants(self) -> tuple[float, ...]:
        return self.alpha1, self.alpha2, self.tau1, self.tau2, self.tau2_imminent, self.d0


def mazda(v_ego, v_rel, a_lead=0.0, params: MazdaParams | None = None) -> Distances:
    r"""Mazda's critical braking distance (Doi, Butsuen, Niibe, Takagi, Yamamoto & Seni,
    "Development of a rear-end collision avoidance system with automatic brake control",
    *JSAE Review* 15(4):335, 1994; form and constants as in Lee & Peng, *Vehicle System
    Dynamics* 43(10):735, 2005).

    .. math::

        d = \tfrac12\left(\frac{v^2}{\alpha_1} - \frac{(v - v_c)^2}{\alpha_2}\right)
            + v\,\tau_1 + v_c\,\tau_2 + d_0

    The published relative speed is the closing speed :math:`v_c = -v_\text{rel}`, so
    :math:`v - v_c` is the lead speed :math:`v_l`.  Caution uses the driver delay
    :math:`\tau_2`, imminent ``tau2_imminent`` (see :class:`MazdaParams`).
    """
    return _distances("mazda", v_ego, v_rel, a_lead, params)


@njit(cache=True, error_model="numpy")
def _mazda(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`mazda` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    alpha1, alpha2, tau1, tau2, tau2_imminent, d0 = c
    base = 0.5 * (v * v / alpha1 - vl * vl / alpha2) + v * tau1 + d0
    return base + vc * tau2, base + vc * tau2_imminent


# --------------------------------------------------------------------------------------------
# Honda (Fujita et al. 1995)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class HondaParams:
    """Parameters of :func:`honda` (Fujita, Akuzawa & Sato 1995, via Lee & Peng 2005).

    Attributes:
        warning_gain: closing-speed gain of the warning distance [s] (default 2.2).
        warning_offset: offset of the warning distance [m] (default 6.2).
        a1: ego deceleration [m/s²] (default 7.8).
        a2: lead deceleration [m/s²] (default 7.8).
        tau1: system delay before the ego brakes [s] (default 0.5).
        tau2: time horizon of the braking distance [s] (default 1.5).
    """

    warning_gain: float = 2.2
    warning_offset: float = 6.2
    a1: float = 7.8
    a2: float = 7.8
    tau1: float = 0.5
    tau2: float = 1.5

    def __post_init__(self) -> None:
        _check_times("honda", self, "warning_gain", "tau1", "tau2")
        _check_lengths("honda", self, "warning_offset")
        _check_decels("honda", self, "a1", "a2")
        _check_order("honda", self, "tau1", "tau2")

    def _constants(self) -> tuple[float, ...]:
        """The parameters, then the ego's braking term and the lead's travel term of
        :math:`d_{br}` (parameters only, computed once)."""
        return (
            self.warning_gain,
            self.warning_offset,
            self.a2,
            self.tau2,
            0.5 * self.a1 * (self.tau2 - self.tau1) ** 2,
            0.5 * self.a2 * self.tau2**2,
        )


def honda(v_ego, v_rel, a_lead=0.0, params: HondaParams | None = None) -> Distances:
    r"""Honda's warning and braking distances (Fujita, Akuzawa & Sato, "Radar brake system",
    *Proc. 1995 Annual Meeting of ITS America*, 1995; as reproduced by Lee & Peng 2005).

    Caution is the warning distance, imminent the braking distance:

    .. math::

        d_w &= 2.2\, v_c + 6.2 \\
        d_{br} &= \begin{cases}
            v_c\,\tau_2 + \tau_1\tau_2 a_1 - \tfrac12 a_1\tau_1^2 & v_l / a_2 \ge \tau_2 \\
            v\,\tau_2 - \tfrac12 a_1(\tau_2 - \tau_1)^2 - \dfrac{v_l^2}{2 a_2}
                & v_l / a_2 < \tau_2 \end{cases}

    :math:`d_{br}` is how much the gap closes within :math:`\tau_2` when the lead brakes at
    :math:`a_2` from now and the ego brakes at :math:`a_1` after :math:`\tau_1`.  The first case
    (the lead still moving at :math:`\tau_2`) is coded in its general form
    :math:`v\tau_2 - \tfrac12 a_1(\tau_2-\tau_1)^2 - (v_l\tau_2 - \tfrac12 a_2\tau_2^2)`, which
    is Fujita's expression when :math:`a_1 = a_2` (the published 7.8 m/s²).
    """
    return _distances("honda", v_ego, v_rel, a_lead, params)


@njit(cache=True, error_model="numpy")
def _honda(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`honda` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    warning_gain, warning_offset, a2, tau2, ego_braking, lead_braking = c
    ego_travel = v * tau2 - ego_braking
    moving = vl >= a2 * tau2
    lead_travel = vl * tau2 - lead_braking if moving else vl * vl / (2.0 * a2)
    return warning_gain * vc + warning_offset, ego_travel - lead_travel


# --------------------------------------------------------------------------------------------
# Berkeley / PATH (Seiler, Song & Hedrick 1998)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BerkeleyParams:
    """Parameters of :func:`berkeley` (Seiler, Song & Hedrick 1998, via Lee & Peng 2005).

    Attributes:
        decel: deceleration a of both vehicles [m/s²] (default 6).
        tau: delay τ, system plus driver [s] (default 1.2).
        d0: headway offset [m] (default 5).
    """

    decel: float = 6.0
    tau: float = 1.2
    d0: float = 5.0

    def __post_init__(self) -> None:
        _check_decels("berkeley", self, "decel")
        _check_times("berkeley", self, "tau")
        _check_lengths("berkeley", self, "d0")

    def _constants(self) -> tuple[float, ...]:
        r"""The parameters, then :math:`\tfrac12 a\tau^2` (computed once)."""
        return self.decel, self.tau, self.d0, 0.5 * self.decel * self.tau**2


def berkeley(v_ego, v_rel, a_lead=0.0, params: BerkeleyParams | None = None) -> Distances:
    r"""The PATH warning and braking distances (Seiler, Song & Hedrick, "Development of a
    collision avoidance system", SAE 980853, 1998; as reproduced by Lee & Peng 2005).

    Caution is the warning distance, imminent the braking distance:

    .. math::

        d_w &= \tfrac12\left(\frac{v^2}{a} - \frac{(v - v_c)^2}{a}\right) + v\,\tau + d_0 \\
        d_{br} &= v_c\,\tau + \tfrac12 a\,\tau^2

    :math:`d_w` compares both vehicles braking at ``a`` after the ego's delay ``τ``;
    :math:`d_{br}` is how much the gap closes during ``τ`` when the lead brakes at ``a``.
    """
    return _distances("berkeley", v_ego, v_rel, a_lead, params)


@njit(cache=True, error_model="numpy")
def _berkeley(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`berkeley` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    decel, tau, d0, lead_braking = c[:4]
    d_w = 0.5 * (v * v - vl * vl) / decel + v * tau + d0
    d_br = vc * tau + lead_braking
    return d_w, d_br


# --------------------------------------------------------------------------------------------
# Responsibility-Sensitive Safety (Shalev-Shwartz, Shammah & Shashua 2017)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RSSParams:
    """Parameters of :func:`rss`.

    The defaults are those of Intel's reference implementation of RSS, ``ad-rss-lib``
    (``cResponseTimeEgoVehicle``, ``cMaximumLongitudinalAcceleration``,
    ``cMinimumLongitudinalBrakingDeceleleration``, ``cMaximumLongitudinalBrakingDeceleleration``
    of its test support).

    Attributes:
        response_time: response time ρ of the ego [s] (default 1.0).
        accel_max: maximum acceleration of the ego during ρ [m/s²] (default 3.5).
        brake_min: minimum braking the ego applies after ρ, caution level [m/s²] (default 4).
        brake_min_imminent: the same for the imminent level [m/s²] (default 8: the ego commits
            to the full braking the lead is assumed capable of; an acc_fusion choice).
        brake_max: maximum braking of the lead [m/s²] (default 8).
    """

    response_time: float = 1.0
    accel_max: float = 3.5
    brake_min: float = 4.0
    brake_min_imminent: float = 8.0
    brake_max: float = 8.0

    def __post_init__(self) -> None:
        _check_times("rss", self, "response_time")
        check_range("rss.accel_max", self.accel_max, 0.0, 20.0)
        _check_decels("rss", self, "brake_min", "brake_min_imminent", "brake_max")
        _check_order("rss", self, "brake_min", "brake_min_imminent")

    def _constants(self) -> tuple[float, ...]:
        r"""The parameters, then the distance :math:`\tfrac12 a_\text{accel,max}\rho^2` the
        acceleration adds during ρ (computed once)."""
        return (
            self.response_time,
            self.accel_max,
            self.brake_min,
            self.brake_min_imminent,
            self.brake_max,
            0.5 * self.accel_max * self.response_time**2,
        )


def rss(v_ego, v_rel, a_lead=0.0, params: RSSParams | None = None) -> Distances:
    r"""RSS minimal safe longitudinal distance (Shalev-Shwartz, Shammah & Shashua, "On a formal
    model of safe and scalable self-driving cars", arXiv:1708.06374, 2017, Definition 1).

    .. math::

        d_\text{min} = \left[v\rho + \tfrac12 a_\text{accel,max}\rho^2
            + \frac{(v + \rho\, a_\text{accel,max})^2}{2 a_\text{brake,min}}
            - \frac{v_l^2}{2 a_\text{brake,max}}\right]_+

    The rear car may accelerate at :math:`a_\text{accel,max}` during its response time
    :math:`\rho`, then brakes at no less than :math:`a_\text{brake,min}`; the front car brakes
    at up to :math:`a_\text{brake,max}`.  Caution uses ``brake_min``, imminent the harder
    ``brake_min_imminent`` (defaults in :class:`RSSParams`).
    """
    return _distances("rss", v_ego, v_rel, a_lead, params)


@njit(cache=True, error_model="numpy")
def _rss(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`rss` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    response_time, accel_max, brake_min, brake_min_imminent, brake_max, accel_travel = c
    reaction = v * response_time + accel_travel
    v_after = v + response_time * accel_max
    lead_stop = vl * vl / (2.0 * brake_max)
    return (
        reaction + v_after * v_after / (2.0 * brake_min) - lead_stop,
        reaction + v_after * v_after / (2.0 * brake_min_imminent) - lead_stop,
    )


# --------------------------------------------------------------------------------------------
# Required deceleration (CAMP)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RequiredDecelerationParams:
    """Parameters of :func:`required_deceleration`.

    Attributes:
        reaction_time: delay before the ego brakes [s] (default 1.25: brake reaction to an
            unexpected but common signal such as the lead's brake lights, Green 2000).
        decel_caution: required-deceleration threshold of the caution level [m/s²]
            (default 3.4 ≈ 0.35 g: the deceleration most drivers exceed when stopping for an
            unexpected object, AASHTO, *A Policy on Geometric Design of Highways and Streets*,
            stopping sight distance, 2011).
        decel_imminent: threshold of the imminent level [m/s²] (default 6.0 ≈ 0.6 g: the
            ego's hard braking in the Mazda (α1) and PATH (a) algorithms).
        d0: margin left at the closest approach [m] (default 2.5: SUMO's default ``minGap``).
    """

    reaction_time: float = 1.25
    decel_caution: float = 3.4
    decel_imminent: float = 6.0
    d0: float = 2.5

    def __post_init__(self) -> None:
        p = "required_deceleration"
        _check_times(p, self, "reaction_time")
        _check_decels(p, self, "decel_caution", "decel_imminent")
        _check_lengths(p, self, "d0")
        _check_order(p, self, "decel_caution", "decel_imminent")

    def _constants(self) -> tuple[float, ...]:
        return self.reaction_time, self.decel_caution, self.decel_imminent, self.d0


@njit(cache=True, error_model="numpy")
def _closest_approach(v, vl, b, t_r, a):  # pragma: no cover - compiled
    r"""Largest closing :math:`\max_t [x_\text{ego}(t) - x_\text{lead}(t)]` of one pair (>= 0).

    The ego keeps ``v`` for ``t_r`` then brakes at ``a`` to a stop; the lead brakes at ``b``
    (``0`` = constant speed) from ``vl`` to a stop.  The closing is piecewise quadratic in t,
    so its maximum lies at a breakpoint (``t_r``, the lead's stop, the ego's stop) or where
    both brake at equal speed, :math:`t^* = (v_l - v - a t_r)/(b - a)`.
    """
    t_ego_stop = t_r + v / a
    t_lead_stop = vl / b if b > 0 else np.inf
    t_star = (vl - v - a * t_r) / (b - a) if b != a else t_r
    t_star = _minimum(_maximum(t_star, t_r), t_ego_stop)
    closing = _closing(t_r, v, vl, b, t_r, a, t_lead_stop)
    for t in (_minimum(t_lead_stop, t_ego_stop), t_ego_stop, t_star):
        closing = _maximum(closing, _closing(t, v, vl, b, t_r, a, t_lead_stop))
    return _maximum(closing, 0.0)


@njit(cache=True, error_model="numpy")
def _closing(t, v, vl, b, t_r, a, t_lead_stop):  # pragma: no cover - compiled
    r""":math:`x_\text{ego}(t) - x_\text{lead}(t)` of :func:`_closest_approach`."""
    braking = _minimum(_maximum(t - t_r, 0.0), v / a)
    x_ego = v * _minimum(t, t_r) + v * braking - 0.5 * a * (braking * braking)
    s = _minimum(t, t_lead_stop)
    return x_ego - (vl * s - 0.5 * b * (s * s))


def required_deceleration(
    v_ego, v_rel, a_lead=0.0, params: RequiredDecelerationParams | None = None
) -> Distances:
    r"""Gap at which the deceleration needed to avoid the lead reaches a threshold.

    The required-deceleration approach of the CAMP forward-collision-warning programme
    (Kiefer et al., "Development and validation of functional definitions and evaluation
    procedures for collision warning/avoidance systems", DOT HS 808 964, 1999; LeBlanc et al.,
    SAE 2001-01-0462): warn when the constant deceleration :math:`a_\text{req}` the ego needs,
    after a reaction delay :math:`t_r`, to stay behind a lead that keeps decelerating at
    :math:`b = \max(-a_\text{lead}, 0)` exceeds a threshold.  :math:`a_\text{req}` falls as the
    gap grows, so ``gap < d_L`` is exactly :math:`a_\text{req} > a_L` with

    .. math::

        d_L = d_0 + \max_{t \ge 0}\left[x_\text{ego}(t; t_r, a_L) - x_\text{lead}(t; b)\right]_+

    where both vehicles stop at zero speed.  The maximum (the closest approach) is where the
    speeds become equal, :math:`t^* = (v_l - v - a_L t_r)/(b - a_L)`, or at a stop; e.g. for a
    stopped lead :math:`d_L = d_0 + v t_r + v^2/(2a_L)`, and for steady following
    (:math:`v_l = v`, :math:`b = 0`) :math:`d_L = d_0`.  Defaults in
    :class:`RequiredDecelerationParams`.
    """
    return _distances("required_deceleration", v_ego, v_rel, a_lead, params)


@njit(cache=True)
def _required_deceleration(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`required_deceleration` of one pair, before :func:`_levels` (``c``: its
    ``_constants``)."""
    reaction_time, decel_caution, decel_imminent, d0 = c[:4]
    return (
        d0 + _closest_approach(v, vl, b, reaction_time, decel_caution),
        d0 + _closest_approach(v, vl, b, reaction_time, decel_imminent),
    )


# --------------------------------------------------------------------------------------------
# Registry and time to collision
# --------------------------------------------------------------------------------------------

#: Every safety model by name: ``(function, parameter class)``.
SAFETY_MODELS: dict[str, tuple[Callable[..., Distances], type]] = {
    "time_headway": (time_headway, TimeHeadwayParams),
    "ttc": (ttc, TTCParams),
    "stopping_distance": (stopping_distance, StoppingDistanceParams),
    "mazda": (mazda, MazdaParams),
    "honda": (honda, HondaParams),
    "berkeley": (berkeley, BerkeleyParams),
    "rss": (rss, RSSParams),
    "required_deceleration": (required_deceleration, RequiredDecelerationParams),
}
# The number of each model in compiled code: its place in SAFETY_MODELS.
_TIME_HEADWAY, _TTC, _STOPPING_DISTANCE, _MAZDA, _HONDA, _BERKELEY, _RSS, _REQ_DECEL = range(8)
# Every model's constants go to compiled code as a tuple of this length, padded with zeros
# (one compiled signature for all the models).
_N_CONSTANTS = 6


def model_constants(name: str, params: object | None = None) -> tuple[int, tuple[float, ...]]:
    """The safety model ``name`` with ``params`` (``None``: its defaults) as the arguments
    ``(model, c)`` of :func:`distances_unchecked`."""
    _, cls = SAFETY_MODELS[name]
    c = tuple(map(float, _resolve(params, cls, name)._constants()))
    return list(SAFETY_MODELS).index(name), c + (0.0,) * (_N_CONSTANTS - len(c))


@njit(cache=True)
def distances_unchecked(model, c, v_ego, v_rel, a_lead):  # pragma: no cover - compiled
    """``(d_caution, d_imminent)`` [m], arrays ``(N,)``, of the model ``(model, c)`` of
    :func:`model_constants` at inputs ``(N,)`` that are not checked.

    ``v_ego`` is clipped at 0: the model functions check that it is >= 0, and
    :class:`~acc_fusion.warning.logic.WarningLogic` passes an estimated speed that may dip below.
    """
    d_caution = np.empty(v_ego.size)
    d_imminent = np.empty(v_ego.size)
    for i in range(v_ego.size):
        v = _maximum(v_ego[i], 0.0)
        vl = _maximum(v + v_rel[i], 0.0)
        vc = -v_rel[i]
        b = _maximum(-a_lead[i], 0.0)
        if model == _TIME_HEADWAY:
            d = _time_headway(v, vl, vc, b, c)
        elif model == _TTC:
            d = _ttc(v, vl, vc, b, c)
        elif model == _STOPPING_DISTANCE:
            d = _stopping_distance(v, vl, vc, b, c)
        elif model == _MAZDA:
            d = _mazda(v, vl, vc, b, c)
        elif model == _HONDA:
            d = _honda(v, vl, vc, b, c)
        elif model == _BERKELEY:
            d = _berkeley(v, vl, vc, b, c)
        elif model == _RSS:
            d = _rss(v, vl, vc, b, c)
        else:
            d = _required_deceleration(v, vl, vc, b, c)
        d_caution[i], d_imminent[i] = _levels(d[0], d[1])
    return d_caution, d_imminent


def safety_distances(
    name: str, v_ego, v_rel, a_lead=0.0, params: object | None = None
) -> Distances:
    """``(d_caution, d_imminent)`` [m] of the safety model ``name`` (see :data:`SAFETY_MODELS`).

    >>> d_c, d_i = safety_distances("time_headway", [20.0], [0.0])
    >>> float(d_c[0]), float(d_i[0])
    (42.5, 22.5)
    """
    check_choice("safety model", name, SAFETY_MODELS)
    model, _ = SAFETY_MODELS[name]
    return model(v_ego, v_rel, a_lead, params)


def time_to_collision(gap, v_rel, a_rel=None) -> np.ndarray:
    r"""Time until the gap closes [s], ``inf`` where it never does (arrays ``(N,)``).

    Without ``a_rel`` (constant range-rate): :math:`\mathrm{TTC} = g / (-\dot g)` where
    :math:`\dot g < 0`.  With the relative acceleration :math:`\ddot g` = ``a_rel`` [m/s²]
    (constant-acceleration TTC), the first positive root of
    :math:`g + \dot g t + \tfrac12 \ddot g t^2 = 0`, computed in the cancellation-free form

    .. math::

        \mathrm{TTC} = \frac{2 g}{-\dot g + \sqrt{\dot g^2 - 2 \ddot g g}},

    ``inf`` where the discriminant is negative or the denominator is not positive (the gap
    never closes).  A gap that is already ``<= 0`` has a TTC of 0.
    """
    g = np.asarray(gap, dtype=float)
    rate = np.asarray(v_rel, dtype=float)
    acc = np.zeros(()) if a_rel is None else np.asarray(a_rel, dtype=float)
    try:
        shape = np.broadcast(g, rate, acc).shape or (1,)  # scalars give (1,)
    except ValueError:
        shape = None
    if shape is not None:
        out = np.empty(shape)
        size = out.size
        if _time_to_collision(
            _flat(g, shape, size), _flat(rate, shape, size), _flat(acc, shape, size), out.ravel()
        ):
            return out
    # An input is not finite (the checks raise), or the shapes do not broadcast.
    check_array("gap", g)
    check_array("v_rel", rate)
    check_array("a_rel", acc)
    raise InputError(
        "gap, v_rel and a_rel must be scalars or arrays of one length N, got shapes "
        f"{np.shape(gap)}, {np.shape(v_rel)} and {np.shape(a_rel)}"
    )


def _flat(x: np.ndarray, shape: tuple[int, ...], size: int) -> np.ndarray:
    """``x`` flat for :func:`_time_to_collision`: itself if it has 1 or ``size`` entries, or
    if ``size`` is 0 (then it is only checked), else broadcast to ``shape``."""
    if x.size in (1, size) or size == 0:
        return x.ravel()
    return np.broadcast_to(x, shape).ravel()


@njit(cache=True, error_model="numpy")
def _time_to_collision(g, rate, acc, out):  # pragma: no cover - compiled
    """:func:`time_to_collision` of flat inputs of ``out.size`` entries (or 1, broadcast) into
    ``out``; False, before writing, if an input is not finite."""
    if not (_finite(g) and _finite(rate) and _finite(acc)):
        return False
    for i in range(out.size):
        gi = g[i if g.size > 1 else 0]
        ri = rate[i if rate.size > 1 else 0]
        ai = acc[i if acc.size > 1 else 0]
        gap_pos = _maximum(gi, 0.0)
        disc = ri * ri - 2.0 * ai * gap_pos
        denom = -ri + np.sqrt(_maximum(disc, 0.0))
        if gi <= 0.0:
            out[i] = 0.0
        elif disc >= 0.0 and denom > 0.0:
            out[i] = 2.0 * gap_pos / denom
        else:
            out[i] = np.inf
    return True


@njit(cache=True)
def _finite(x):  # pragma: no cover - compiled
    """True if every entry of the flat array ``x`` is finite."""
    for i in range(x.size):
        if not np.isfinite(x[i]):
            return False
    return True
