r"""How urgent a follower→leader situation is: the deceleration the follower needs to avoid the
lead (:func:`required_deceleration`) and the time to collision when it does not react, the lead
keeping its deceleration until it stops (:func:`time_to_collision_braking_lead`).

Both take the lead's motion as the standard kinematic prediction of collision-warning
algorithms: constant acceleration :math:`a_l` until it stops (CAMP, Kiefer et al., *Development
and validation of functional definitions and evaluation procedures for collision warning/
avoidance systems*, NHTSA DOT HS 808 964, 1999, section 3.3: "lead vehicle decelerating to a
stop"; NHTSA, *Forward Collision Warning System Confirmation Test*, 2013, judges the TTC of its
decelerating-lead test the same way).  Notation: gap :math:`g` (bumper to bumper), follower
speed :math:`v`, lead speed :math:`v_l`, lead acceleration :math:`a_l` (negative braking),
closing speed :math:`v_c = v - v_l`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from acc_fusion.core.arrays import all_finite, check_array
from acc_fusion.core.errors import InputError


def _arrays(gap, v_ego, v_lead, a_lead) -> tuple[np.ndarray, ...]:
    """The four inputs as float ``(N,)`` arrays (scalars broadcast), each checked finite."""
    arrays = [np.atleast_1d(np.asarray(x, dtype=float)) for x in (gap, v_ego, v_lead, a_lead)]
    n = max(a.size for a in arrays)
    if all(a.shape == (n,) and all_finite(a) for a in arrays):
        return tuple(arrays)  # as the checks below would return them
    names = ("gap", "v_ego", "v_lead", "a_lead")
    for name, a in zip(names, arrays, strict=True):
        if a.shape not in ((n,), (1,)):
            raise InputError(f"{name} must be a number or have shape ({n},), got {a.shape}")
    return tuple(
        check_array(name, np.broadcast_to(a, (n,)), (n,))
        for name, a in zip(names, arrays, strict=True)
    )


def urgency(gap, v_ego, v_lead, a_lead) -> tuple[np.ndarray, np.ndarray]:
    """Both :func:`required_deceleration` and :func:`time_to_collision_braking_lead` of the
    same pairs, in one pass: ``(decel, ttc)``, arrays ``(N,)``."""
    g, v, vl, al = _arrays(gap, v_ego, v_lead, a_lead)
    decel, ttc = np.empty(g.size), np.empty(g.size)
    _urgency(g, v, vl, al, decel, ttc)
    return decel, ttc


def required_deceleration(gap, v_ego, v_lead, a_lead) -> np.ndarray:
    r"""The constant deceleration [m/s², >= 0] the follower needs, braking from now on, to
    stay behind the lead (arrays ``(N,)``; ``inf`` where the gap is already closed).

    If the lead stops before the two speeds are equal (it is braking, :math:`a_l < 0`, and
    :math:`v_l/|a_l| \le 2g/v_c`), the follower must stop within the gap plus the lead's
    stopping distance:

    .. math:: a_\mathrm{req} = \frac{v^2}{2\,(g + v_l^2 / (2|a_l|))}

    otherwise it must cancel the closing speed within the gap, with the lead's acceleration
    on its side or against it:

    .. math:: a_\mathrm{req} = \max\!\Big(\frac{v_c^2}{2g} - a_l,\ 0\Big)
        \quad (v_c > 0), \qquad 0 \quad (v_c \le 0,\ a_l \ge 0).

    Source: the required-deceleration parameter of CAMP's crash-alert timing work (Kiefer
    et al. 1999, DOT HS 808 964), with no reaction delay.

    >>> float(required_deceleration(50.0, 20.0, 0.0, 0.0)[0])  # stopped lead: v²/(2g)
    4.0
    """
    return urgency(gap, v_ego, v_lead, a_lead)[0]


def time_to_collision_braking_lead(gap, v_ego, v_lead, a_lead) -> np.ndarray:
    r"""Time [s] until the follower, keeping its speed, reaches the lead, which keeps its
    acceleration until it stops (arrays ``(N,)``; ``inf`` if it never does, 0 if the gap is
    closed).

    While the lead moves, the first positive root of
    :math:`g - v_c t + \tfrac12 a_l t^2 = 0` (as :func:`acc_fusion.warning.ttc.time_to_collision`
    with :math:`\ddot g = a_l`); if the lead stops first, at :math:`t_s = v_l/|a_l|`, the
    follower covers the gap plus the lead's stopping distance:

    .. math:: \mathrm{TTC} = \frac{g + v_l^2/(2|a_l|)}{v}.

    This is the TTC of NHTSA's decelerating-lead test (FCW confirmation test, 2013): in
    ``nhtsa_lvd`` (both at 45 mph, 30 m apart, the lead braking at 0.3 g) the constant-speed
    TTC :math:`g/v_c` is about 10 s at a typical alert while this one is about 3.6 s.

    >>> round(float(time_to_collision_braking_lead(30.0, 20.0, 20.0, -3.0)[0]), 2)
    4.47
    """
    return urgency(gap, v_ego, v_lead, a_lead)[1]


@njit(cache=True, error_model="numpy")
def _urgency(gap, v, vl, al, decel, ttc):  # pragma: no cover - compiled
    """:func:`required_deceleration` into ``decel`` and :func:`time_to_collision_braking_lead`
    into ``ttc`` (inputs checked, ``(N,)``)."""
    for i in range(gap.size):
        g, vi, vli, ali = gap[i], max(v[i], 0.0), max(vl[i], 0.0), al[i]
        vc = vi - vli
        if g <= 0.0:
            decel[i], ttc[i] = np.inf, 0.0
            continue
        lead_stop = vli * vli / (-2.0 * ali) if ali < 0.0 else np.inf
        if ali < 0.0 and (vc <= 0.0 or vli / -ali <= 2.0 * g / vc):
            decel[i] = vi * vi / (2.0 * (g + lead_stop))
        elif vc > 0.0:
            decel[i] = max(vc * vc / (2.0 * g) - ali, 0.0)
        else:
            decel[i] = 0.0
        t_stop = vli / -ali if ali < 0.0 else np.inf
        disc = vc * vc - 2.0 * ali * g
        denom = vc + np.sqrt(max(disc, 0.0))
        t = 2.0 * g / denom if disc >= 0.0 and denom > 0.0 else np.inf
        if t <= t_stop:
            ttc[i] = t
        elif vi > 0.0:
            ttc[i] = (g + lead_stop) / vi
        else:
            ttc[i] = np.inf
