r"""When truth says the driver must act: the crash-relevant situations that the alert classes
of :mod:`acc_fusion.metrics.events` are judged against, independently of the warning rule.

A pair is in a *crash-relevant situation* at a step when it has a lead and either

* the follower, braking from now on, needs at least ``decel_threshold`` to stay behind the
  lead (:func:`acc_fusion.warning.kinematics.required_deceleration`, the lead keeping its
  deceleration to a stop), or
* without reacting (keeping its speed) it would reach the lead within ``ttc_threshold``
  (:func:`acc_fusion.warning.kinematics.time_to_collision_braking_lead`).

Both are judged on the true state of the step, with the standard kinematic prediction of the
lead (constant acceleration until it stops), which is what a driver, or an ideal alert, could
know at that moment: a lead that brakes hard and then releases made a crash-relevant
situation while it braked.

Thresholds (assumptions anchored in published figures, see :class:`AlertClassConfig`): a
required deceleration of 3.4 m/s² (0.35 g) is the deceleration that about 90 % of drivers
exceed when they must stop for an unexpected object (AASHTO, *A Policy on Geometric Design of
Highways and Streets*, 2004, chapter 3, "Braking distance": "approximately 90 percent of all
drivers decelerate at rates greater than 3.4 m/s²", the basis of stopping sight distance, kept
in later editions): needing more
than that is an emergency, not ordinary driving, and lies in the 0.3-0.4 g range of the
"crash-imminent" braking that CAMP's alert-timing studies elicited (Kiefer et al., DOT HS
808 964, 1999).  A TTC of 2.0 s is the shortest TTC at which NHTSA's FCW confirmation test
(2013) still requires the alert (its moving-lead test): a situation that close to contact
needs the driver now.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acc_fusion.core.units import G
from acc_fusion.core.validation import check_range
from acc_fusion.warning.kinematics import urgency


@dataclass(frozen=True)
class AlertClassConfig:
    """When a situation is crash-relevant in truth (see the module docstring for the sources).

    Attributes:
        decel_threshold: required deceleration from which the driver must act [m/s²]; 3.4
            (0.35 g, AASHTO 2004).
        ttc_threshold: time to collision without reaction (the lead keeping its deceleration)
            below which the driver must act [s]; 2.0 (NHTSA FCW confirmation test, 2013).
    """

    decel_threshold: float = 3.4
    ttc_threshold: float = 2.0

    def __post_init__(self) -> None:
        name = "alert_classes.decel_threshold"
        check_range(name, self.decel_threshold, 0.0, 2.0 * G, lo_open=True)
        check_range("alert_classes.ttc_threshold", self.ttc_threshold, 0.0, 60.0)


def crash_relevant(
    config: AlertClassConfig,
    has_leader: np.ndarray,
    gap: np.ndarray,
    ego_speed: np.ndarray,
    lead_speed: np.ndarray,
    lead_accel: np.ndarray,
) -> np.ndarray:
    """``(N,)`` pairs in a crash-relevant situation (arrays ``(N,)``; the values of pairs
    without a leader are ignored)."""
    # Without a leader: a lead 1 m ahead at the ego's speed (needs nothing), then masked.
    g = np.where(has_leader, gap, 1.0)
    vl = np.where(has_leader, lead_speed, ego_speed)
    al = np.where(has_leader, lead_accel, 0.0)
    decel, ttc = urgency(g, ego_speed, vl, al)
    return has_leader & ((decel >= config.decel_threshold) | (ttc <= config.ttc_threshold))
