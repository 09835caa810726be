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

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.validation import check_choice
from acc_fusion.warning.safety_kernels import distances_unchecked
from acc_fusion.warning.safety_params import (
    BerkeleyParams,
    HondaParams,
    MazdaParams,
    RequiredDecelerationParams,
    RSSParams,
    StoppingDistanceParams,
    TimeHeadwayParams,
    TTCParams,
)

Distances = tuple[np.ndarray, np.ndarray]


# --------------------------------------------------------------------------------------------
# Shared helpers: parameter checks, input checks, the caution/imminent invariant.
# --------------------------------------------------------------------------------------------


# Kernels that divide use error_model="numpy": IEEE division as in numpy, without the checks
# for a zero divisor that would raise ZeroDivisionError (and keep loops from vectorising).


# --------------------------------------------------------------------------------------------
# Time headway
# --------------------------------------------------------------------------------------------


def time_headway(v_ego, v_rel, a_lead=0.0, params: TimeHeadwayParams | None = None) -> Distances:
    r"""Constant time-headway distance (the two-second rule).

    .. math:: d_L = d_0 + h_L\, v

    Ignores the lead's motion: it warns whenever the ego follows closer than ``h`` seconds.
    Source: the two-second rule of driver training (Vogel 2003, §1; see
    :class:`TimeHeadwayParams` for the defaults).
    """
    return _distances("time_headway", v_ego, v_rel, a_lead, params)


# --------------------------------------------------------------------------------------------
# Time to collision
# --------------------------------------------------------------------------------------------


def ttc(v_ego, v_rel, a_lead=0.0, params: TTCParams | None = None) -> Distances:
    r"""Time-to-collision threshold in distance form.

    .. math:: d_L = T_L \max(v_c, 0) + d_0

    With :math:`d_0 = 0`, ``gap < d_L`` is exactly :math:`\mathrm{TTC} = g / v_c < T_L`;
    nothing is raised while the gap opens.  With ``lead_braking`` the lead (deceleration
    :math:`b = \max(-a_l, 0)`) keeps braking until it stops, as NHTSA's confirmation test
    (2013) judges its decelerating-lead test:

    .. math::

        d_L = \begin{cases} \max(v_c T_L + \tfrac12 b T_L^2, 0) + d_0 & v_l \ge b T_L \\
        \max(v T_L - v_l^2 / (2b), 0) + d_0 & \text{otherwise,} \end{cases}

    so that ``gap < d_L`` is exactly
    :func:`~acc_fusion.warning.kinematics.time_to_collision_braking_lead` :math:`< T_L`.
    Sources: see :class:`TTCParams`.
    """
    return _distances("ttc", v_ego, v_rel, a_lead, params)


# --------------------------------------------------------------------------------------------
# Stopping distance
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Mazda (Doi et al. 1994)
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Honda (Fujita et al. 1995)
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Berkeley / PATH (Seiler, Song & Hedrick 1998)
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Responsibility-Sensitive Safety (Shalev-Shwartz, Shammah & Shashua 2017)
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Required deceleration (CAMP)
# --------------------------------------------------------------------------------------------


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

        d_L = d_0 + \max_{t \ge 0}\left[x_\text{ego}(t; t_r, a_L) - x_\text{lead}(t; b)\right]
        \text{ where that maximum is positive, else } d_L = 0,

    where both vehicles stop at zero speed.  The maximum (the closest approach) is where the
    speeds become equal, :math:`t^* = (v_l - v - a_L t_r)/(b - a_L)`, or at a stop; e.g. for a
    stopped lead :math:`d_L = d_0 + v t_r + v^2/(2a_L)`.  Where the gap would not shrink at
    all (the maximum is 0: steady or opening range, :math:`v_l \ge v`, and a lead that does
    not brake) no deceleration is required, so :math:`d_L = 0` and the rule is off whatever
    the gap (:class:`~acc_fusion.warning.logic.WarningLogic` raises no level where
    :math:`d_L = 0`, even where the compared lower quantile of the gap is below 0): the
    margin :math:`d_0` is what an approach must leave, not a gap a driver must keep.
    Without that, a gap just under :math:`d_0` raised the imminent level however it moved: a
    car that cut in close and pulls away, a queue at standstill (SUMO's drivers keep exactly
    ``minGap`` = :math:`d_0` = 2.5 m there, and the estimated gap's noise dipped under it;
    most sensing-false alerts of ``make run``'s traffic, docs/theory/alert-classes.md).
    Defaults in :class:`RequiredDecelerationParams`.
    """
    return _distances("required_deceleration", v_ego, v_rel, a_lead, params)


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

# Every model's constants go to compiled code as a tuple of this length, padded with zeros
# (one compiled signature for all the models).
_N_CONSTANTS = 6


def model_constants(name: str, params: object | None = None) -> tuple[int, tuple[float, ...]]:
    """The safety model ``name`` with ``params`` (``None``: its defaults) as the arguments
    ``(model, c)`` of :func:`distances_unchecked`."""
    _, cls = SAFETY_MODELS[name]
    c = tuple(map(float, _resolve(params, cls, name)._constants()))
    return list(SAFETY_MODELS).index(name), c + (0.0,) * (_N_CONSTANTS - len(c))


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
