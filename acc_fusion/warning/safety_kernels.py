"""The compiled safety-distance models: one kernel per model of
:data:`acc_fusion.warning.safety.SAFETY_MODELS` and the dispatch kernel that evaluates the
configured model per pair (:func:`distances_unchecked`). A set of numba kernels that must stay
together: the dispatch inlines every model's kernel."""

from __future__ import annotations

import numpy as np
from numba import njit

#: Model codes of :func:`distances_unchecked` (the registry order of
#: :data:`acc_fusion.warning.safety.SAFETY_MODELS`).
_TIME_HEADWAY, _TTC, _STOPPING_DISTANCE, _MAZDA, _HONDA, _BERKELEY, _RSS, _REQ_DECEL = range(8)


@njit(cache=True)
def _time_headway(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`time_headway` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    headway_caution, headway_imminent, d0 = c[:3]
    return d0 + headway_caution * v, d0 + headway_imminent * v


@njit(cache=True, error_model="numpy")
def _ttc(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`ttc` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    ttc_caution, ttc_imminent, d0, lead_braking = c[:4]
    if lead_braking:
        return (
            _braking_gap(v, vl, vc, b, ttc_caution) + d0,
            _braking_gap(v, vl, vc, b, ttc_imminent) + d0,
        )
    closing = _maximum(vc, 0.0)
    return ttc_caution * closing + d0, ttc_imminent * closing + d0


@njit(cache=True, error_model="numpy")
def _braking_gap(v, vl, vc, b, t):  # pragma: no cover - compiled
    """The gap [m] the follower, keeping ``v``, closes within ``t`` on a lead braking at
    ``b`` (>= 0) until it stops: :math:`v_c t + b t^2/2` while the lead moves, else
    :math:`v t - v_l^2/(2b)` (at least 0)."""
    if vl >= b * t:
        return _maximum(vc * t + 0.5 * b * t * t, 0.0)
    return _maximum(v * t - vl * vl / (2.0 * b), 0.0)


@njit(cache=True, error_model="numpy")
def _stopping_distance(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`stopping_distance` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    reaction_caution, decel_caution, reaction_imminent, decel_imminent, lead_decel, d0 = c
    lead_stop = vl * vl / (2.0 * lead_decel)
    return (
        _maximum(v * reaction_caution + v * v / (2.0 * decel_caution) - lead_stop, 0.0) + d0,
        _maximum(v * reaction_imminent + v * v / (2.0 * decel_imminent) - lead_stop, 0.0) + d0,
    )


@njit(cache=True, error_model="numpy")
def _mazda(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`mazda` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    alpha1, alpha2, tau1, tau2, tau2_imminent, d0 = c
    base = 0.5 * (v * v / alpha1 - vl * vl / alpha2) + v * tau1 + d0
    return base + vc * tau2, base + vc * tau2_imminent


@njit(cache=True, error_model="numpy")
def _honda(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`honda` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    warning_gain, warning_offset, a2, tau2, ego_braking, lead_braking = c
    ego_travel = v * tau2 - ego_braking
    moving = vl >= a2 * tau2
    lead_travel = vl * tau2 - lead_braking if moving else vl * vl / (2.0 * a2)
    return warning_gain * vc + warning_offset, ego_travel - lead_travel


@njit(cache=True, error_model="numpy")
def _berkeley(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`berkeley` of one pair, before :func:`_levels` (``c``: its ``_constants``)."""
    decel, tau, d0, lead_braking = c[:4]
    d_w = 0.5 * (v * v - vl * vl) / decel + v * tau + d0
    d_br = vc * tau + lead_braking
    return d_w, d_br


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


@njit(cache=True)
def _required_deceleration(v, vl, vc, b, c):  # pragma: no cover - compiled
    """:func:`required_deceleration` of one pair, before :func:`_levels` (``c``: its
    ``_constants``)."""
    reaction_time, decel_caution, decel_imminent, d0 = c[:4]
    return (
        _approach_margin(d0, _closest_approach(v, vl, b, reaction_time, decel_caution)),
        _approach_margin(d0, _closest_approach(v, vl, b, reaction_time, decel_imminent)),
    )


@njit(cache=True)
def _approach_margin(d0, closing):  # pragma: no cover - compiled
    """The distance of :func:`_required_deceleration` for a largest ``closing`` [m]: ``d0``
    more than the closing where the gap would shrink, 0 where it would not (no deceleration
    is required there, whatever the gap)."""
    return d0 + closing if closing > 0.0 else 0.0


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
