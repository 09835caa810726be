"""The parameters of the scripted manoeuvres (one frozen dataclass per manoeuvre, named as in
the protocols: SV/POV for NHTSA, VUT/GVT for Euro NCAP, in SI units), the IDM parameters of
the car-following ego, and the geometry constants of the scripted world."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np
from numba import njit

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.units import KMH, MPH, G
from acc_fusion.core.validation import check_range

#: Lane width [m] (the 3.5-3.75 m of motorway lanes; assumption).
LANE_WIDTH = 3.5


#: Lateral centre offset [m] below which two 1.8-m-wide cars overlap (assumption: car width).
OVERLAP_OFFSET = 1.8


#: Length of every other vehicle [m] (a mid-size passenger car; assumption).
VEHICLE_LENGTH = 4.5


#: Time after the nominal threat left for braking to finish [s] (sets default durations).
SETTLE_TIME = 10.0


#: Duration of the car-following manoeuvres (``following``, ``stop_and_go``) [s].
FOLLOWING_DURATION = 60.0


#: Number of other-vehicle slots per run (the lead, and a second vehicle for cut-in/out).
SLOTS = 2


@dataclass(frozen=True)
class IDMParameters:
    r"""Intelligent Driver Model of the following ego (Treiber, Hennecke & Helbing 2000).

    .. math::

        a = a_{\max}\left[1 - \left(\frac{v}{v_0}\right)^{\delta}
            - \left(\frac{s^*}{s}\right)^2\right],\qquad
        s^* = s_0 + \max\!\left(0,\ vT + \frac{v\,(v - v_l)}{2\sqrt{a_{\max} b}}\right)

    with gap :math:`s`, leader speed :math:`v_l`, desired speed :math:`v_0` and time headway
    :math:`T` (per run, from the scenario); the interaction term is zero without a leader and
    :math:`s^*` is floored at :math:`s_0` (Treiber & Kesting, *Traffic Flow Dynamics*, 2013,
    ch. 11) so that a faster leader causes no braking.  The result is clipped to
    ``[-max_decel, max_accel]``.

    Attributes:
        max_accel: :math:`a_{\max}` [m/s²]; 0.73 (Treiber et al. 2000, Table I).
        comfortable_decel: :math:`b` [m/s²]; 1.67 (Table I).
        jam_distance: :math:`s_0` [m]; 2 (Table I).
        exponent: :math:`\delta`; 4 (Table I).
        max_decel: physical braking limit [m/s²]; 9 (about 0.9 g on dry asphalt; assumption).

    Source: M. Treiber, A. Hennecke, D. Helbing, "Congested traffic states in empirical
    observations and microscopic simulations", Phys. Rev. E 62, 1805 (2000); the parameter
    values are those of its Table I as commonly reproduced (not re-checked here).
    """

    max_accel: float = 0.73
    comfortable_decel: float = 1.67
    jam_distance: float = 2.0
    exponent: float = 4.0
    max_decel: float = 9.0

    @property
    def constants(self) -> tuple[float, float, float, float, float]:
        r"""The arguments of :func:`idm_accel` after the state: :math:`a_{\max}`,
        :math:`2\sqrt{a_{\max} b}`, :math:`s_0`, :math:`\delta` and the braking limit."""
        root = 2.0 * math.sqrt(self.max_accel * self.comfortable_decel)
        return self.max_accel, root, self.jam_distance, self.exponent, self.max_decel

    def accel(self, v, v_desired, headway, gap, lead_speed, has_leader) -> np.ndarray:
        """IDM acceleration [m/s²] of egos at speed ``v`` (arrays ``(N,)``, or scalars for the
        parameters shared by every ego)."""
        args = [np.asarray(a, dtype=float) for a in (v, v_desired, headway, gap, lead_speed)]
        args.append(np.asarray(has_leader, dtype=bool))
        shape = np.broadcast_shapes(*(a.shape for a in args))
        return _idm_accel_array(*(np.broadcast_to(a, shape) for a in args), *self.constants)

    def equilibrium_gap(self, v, headway, v_desired) -> np.ndarray:
        """Gap [m] at which an IDM ego following a leader at its own speed ``v`` keeps ``a = 0``."""
        return (self.jam_distance + v * headway) / np.sqrt(1.0 - (v / v_desired) ** self.exponent)


@njit(cache=True)
def idm_accel(v, v_desired, headway, gap, lead_speed, has_leader, a_max, root, s0, delta, d_max):
    r"""The acceleration of :class:`IDMParameters` for one ego (``root`` is
    :math:`2\sqrt{a_{\max} b}`): the scripted source's compiled step calls it per run."""
    free = 1.0 - (v / v_desired) ** delta
    dynamic = v * headway + v * (v - lead_speed) / root
    s_star = s0 + np.maximum(dynamic, 0.0)
    interaction = 0.0
    if has_leader:
        q = s_star / np.maximum(gap, 1e-3)
        interaction = q * q
    return np.minimum(np.maximum(a_max * (free - interaction), -d_max), a_max)


@njit(cache=True)
def _idm_accel_array(v, v_desired, headway, gap, lead_speed, has, a_max, root, s0, delta, d_max):
    out = np.empty(v.shape)
    for i in np.ndindex(v.shape):
        out[i] = idm_accel(
            v[i], v_desired[i], headway[i], gap[i], lead_speed[i], has[i],
            a_max, root, s0, delta, d_max,
        )  # fmt: skip
    return out


#: The IDM used by the following manoeuvres.
IDM = IDMParameters()


Number = float | tuple[float, ...]


# (low, high, low excluded) bounds of the parameter fields.
_SPEED = (0.0, 70.0, True)  # moving [m/s]


_SPEED0 = (0.0, 70.0, False)  # may be 0 [m/s]


_DECEL = (0.0, 12.0, True)  # [m/s²]


_DISTANCE = (0.0, 1000.0, True)  # [m]


_DISTANCE_OR_NONE = (0.0, math.inf, True)  # [m]; inf: no such vehicle


_TIME = (0.0, 600.0, False)  # event time [s]


_SPAN = (0.0, 60.0, True)  # positive duration [s]


_AMPLITUDE = (0.0, 10.0, False)  # [m/s]


@dataclass(frozen=True)
class ScenarioParams:
    """Base of the manoeuvres' parameters: every field is a number or a tuple of numbers.

    Tuples give several values: the runs are spread over the grid (Cartesian product, in field
    order) of all tuple-valued fields, run ``i`` taking grid point ``i mod G`` -- e.g.
    ``CCRbParams(headway=(12, 40), gvt_decel=(2, 6))`` with 4 runs gives the protocol's 2x2
    matrix.  Every value is validated against the field's bounds; an error names the field and
    its allowed interval.
    """

    scenario: ClassVar[str] = ""
    BOUNDS: ClassVar[Mapping[str, tuple[float, float, bool]]] = {}

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            many = isinstance(value, (tuple, list))
            label = f"{self.scenario}.{f.name}"
            if many and not value:
                raise ConfigError(
                    f"{label} must be a number or a non-empty tuple of numbers, got ()"
                )
            lo, hi, lo_open = self.BOUNDS[f.name]
            checked = tuple(
                check_range(label, v, lo, hi, lo_open=lo_open)
                for v in (value if many else (value,))
            )
            object.__setattr__(self, f.name, checked if many else checked[0])

    def grid(self, n_runs: int) -> dict[str, np.ndarray]:
        """Per-run values ``{field: (n_runs,) array}`` spread over the grid of tuple fields."""
        names = [f.name for f in fields(self)]
        axes = [v if isinstance(v, tuple) else (v,) for v in (getattr(self, n) for n in names)]
        points = np.array(list(itertools.product(*axes)), dtype=float)
        rows = points[np.arange(n_runs) % len(points)]
        return {name: rows[:, j].copy() for j, name in enumerate(names)}


@dataclass(frozen=True)
class LVSParams(ScenarioParams):
    """NHTSA test 1, lead vehicle stopped.

    Attributes:
        sv_speed: subject-vehicle speed [m/s]; 45 mph (72.4 km/h).
        initial_ttc: time to collision at the start [s] (initial gap = ``sv_speed * initial_ttc``).
    """

    scenario = "nhtsa_lvs"
    BOUNDS = {"sv_speed": _SPEED, "initial_ttc": _SPAN}
    sv_speed: Number = 45 * MPH
    initial_ttc: Number = 6.0


@dataclass(frozen=True)
class LVDParams(ScenarioParams):
    """NHTSA test 2, lead vehicle decelerating.

    Attributes:
        speed: initial speed of both the SV and the POV [m/s]; 45 mph.
        headway: initial gap [m]; 30.
        pov_decel: POV deceleration [m/s²]; 0.3 g.
        brake_time: time the POV starts braking [s]; 3 (steady following before it).
    """

    scenario = "nhtsa_lvd"
    BOUNDS = {"speed": _SPEED, "headway": _DISTANCE, "pov_decel": _DECEL, "brake_time": _TIME}
    speed: Number = 45 * MPH
    headway: Number = 30.0
    pov_decel: Number = 0.3 * G
    brake_time: Number = 3.0


@dataclass(frozen=True)
class LVMParams(ScenarioParams):
    """NHTSA test 3, lead vehicle moving (slower).

    Attributes:
        sv_speed: subject-vehicle speed [m/s]; 45 mph.
        pov_speed: POV speed [m/s]; 20 mph (32.2 km/h).
        initial_ttc: time to collision at the start [s].
    """

    scenario = "nhtsa_lvm"
    BOUNDS = {"sv_speed": _SPEED, "pov_speed": _SPEED0, "initial_ttc": _SPAN}
    sv_speed: Number = 45 * MPH
    pov_speed: Number = 20 * MPH
    initial_ttc: Number = 6.0


@dataclass(frozen=True)
class CCRsParams(ScenarioParams):
    """Euro NCAP Car-to-Car Rear stationary.

    Attributes:
        vut_speed: vehicle-under-test speed [m/s]; 50 km/h (tested at 10-80 km/h).
        initial_ttc: time to collision at the start [s].
    """

    scenario = "ccrs"
    BOUNDS = {"vut_speed": _SPEED, "initial_ttc": _SPAN}
    vut_speed: Number = 50 * KMH
    initial_ttc: Number = 6.0


@dataclass(frozen=True)
class CCRmParams(ScenarioParams):
    """Euro NCAP Car-to-Car Rear moving.

    Attributes:
        vut_speed: vehicle-under-test speed [m/s]; 50 km/h (protocol range 30-80 km/h).
        gvt_speed: target speed [m/s]; 20 km/h.
        initial_ttc: time to collision at the start [s].
    """

    scenario = "ccrm"
    BOUNDS = {"vut_speed": _SPEED, "gvt_speed": _SPEED0, "initial_ttc": _SPAN}
    vut_speed: Number = 50 * KMH
    gvt_speed: Number = 20 * KMH
    initial_ttc: Number = 6.0


@dataclass(frozen=True)
class CCRbParams(ScenarioParams):
    """Euro NCAP Car-to-Car Rear braking.

    Attributes:
        speed: initial speed of both the VUT and the GVT [m/s]; 50 km/h.
        headway: initial gap [m]; the protocol's (12, 40).
        gvt_decel: target deceleration [m/s²]; the protocol's (2, 6).
        brake_time: time the GVT starts braking [s]; 3.
    """

    scenario = "ccrb"
    BOUNDS = {"speed": _SPEED, "headway": _DISTANCE, "gvt_decel": _DECEL, "brake_time": _TIME}
    speed: Number = 50 * KMH
    headway: Number = (12.0, 40.0)
    gvt_decel: Number = (2.0, 6.0)
    brake_time: Number = 3.0


@dataclass(frozen=True)
class CutInParams(ScenarioParams):
    """A vehicle changes from the adjacent lane into the ego lane in front of the ego.

    Attributes:
        ego_speed: constant ego speed [m/s]; 80 km/h.
        cut_in_speed: constant speed of the merging vehicle [m/s]; 60 km/h.
        cut_in_gap: gap to the merging vehicle when its lane change ends [m]; 15.
        lane_change_time: start of its lane change [s]; 2.
        lane_change_duration: duration of its lane change [s]; 3.
        lead_gap: gap to a far lead at the ego speed [m]; 80 (``inf``: none); it must be ahead
            of the merging vehicle (``lead_gap > cut_in_gap + VEHICLE_LENGTH``).
    """

    scenario = "cut_in"
    BOUNDS = {
        "ego_speed": _SPEED,
        "cut_in_speed": _SPEED0,
        "cut_in_gap": _DISTANCE,
        "lane_change_time": _TIME,
        "lane_change_duration": _SPAN,
        "lead_gap": _DISTANCE_OR_NONE,
    }
    ego_speed: Number = 80 * KMH
    cut_in_speed: Number = 60 * KMH
    cut_in_gap: Number = 15.0
    lane_change_time: Number = 2.0
    lane_change_duration: Number = 3.0
    lead_gap: Number = 80.0


@dataclass(frozen=True)
class CutOutParams(ScenarioParams):
    """The ego's lead changes lane, revealing the vehicle ahead of it (or an empty lane).

    The default is the "threat disappears" variant: the ego closes on a slower lead
    (initial TTC 7.2 s) which leaves the lane at about 3.5 s, 20 m ahead (TTC 3.7 s), before a
    collision; the revealed vehicle moves at the ego speed.  ``revealed_speed=0`` gives the
    "stopped vehicle revealed" variant, ``revealed_gap=inf`` an empty lane.

    Attributes:
        ego_speed: constant ego speed [m/s]; 80 km/h.
        lead_speed: constant speed of the lead [m/s]; 60 km/h.
        lead_gap: initial gap to the lead [m]; 40.
        lane_change_time: start of the lead's lane change [s]; 2.
        lane_change_duration: duration of the lead's lane change [s]; 3.
        revealed_speed: speed of the revealed vehicle [m/s]; 80 km/h.
        revealed_gap: gap to the revealed vehicle when the lead's lane change ends [m]; 100
            (``inf``: none).  The lead must stay behind it.
    """

    scenario = "cut_out"
    BOUNDS = {
        "ego_speed": _SPEED,
        "lead_speed": _SPEED0,
        "lead_gap": _DISTANCE,
        "lane_change_time": _TIME,
        "lane_change_duration": _SPAN,
        "revealed_speed": _SPEED0,
        "revealed_gap": _DISTANCE_OR_NONE,
    }
    ego_speed: Number = 80 * KMH
    lead_speed: Number = 60 * KMH
    lead_gap: Number = 40.0
    lane_change_time: Number = 2.0
    lane_change_duration: Number = 3.0
    revealed_speed: Number = 80 * KMH
    revealed_gap: Number = 100.0


@dataclass(frozen=True)
class StopAndGoParams(ScenarioParams):
    """Urban queue: the lead cruises, brakes to a stop, waits, pulls away, and again.

    The ego starts at the IDM equilibrium gap behind the cruising lead; the first cruise lasts
    a random fraction of ``cruise_time`` (drawn per run), so runs are out of phase.

    Attributes:
        cruise_speed: lead cruise speed [m/s]; 30 km/h.
        lead_decel: lead deceleration to the stop [m/s²]; 2.
        lead_accel: lead acceleration back to cruise speed [m/s²]; 1.5.
        stop_time: standstill per cycle [s]; 5.
        cruise_time: cruise per cycle [s]; 10.
        time_headway: IDM time headway of the ego [s]; 1.5.
        ego_desired_speed: IDM desired speed of the ego [m/s]; 60 km/h (above ``cruise_speed``).
    """

    scenario = "stop_and_go"
    BOUNDS = {
        "cruise_speed": _SPEED,
        "lead_decel": _DECEL,
        "lead_accel": _DECEL,
        "stop_time": _TIME,
        "cruise_time": _SPAN,
        "time_headway": _SPAN,
        "ego_desired_speed": _SPEED,
    }
    cruise_speed: Number = 30 * KMH
    lead_decel: Number = 2.0
    lead_accel: Number = 1.5
    stop_time: Number = 5.0
    cruise_time: Number = 10.0
    time_headway: Number = 1.5
    ego_desired_speed: Number = 60 * KMH


@dataclass(frozen=True)
class FollowingParams(ScenarioParams):
    """Steady following at a safe headway; the lead's speed swings mildly (no threat).

    The lead's speed ramps between ``lead_speed ± speed_amplitude`` at ``fluctuation_accel``,
    switching every half ``fluctuation_period`` after a random delay (per run); the ego follows
    with the IDM from its equilibrium gap (headway ≈ 2.5 s with the defaults).

    Attributes:
        lead_speed: mean lead speed [m/s]; 25 (90 km/h).
        speed_amplitude: lead speed swing [m/s]; 1.5.
        fluctuation_period: period of the swing [s]; 20.
        fluctuation_accel: lead acceleration during the swing [m/s²]; 0.3.
        time_headway: IDM time headway of the ego [s]; 2 (safe headways are 1.5-3 s).
        ego_desired_speed: IDM desired speed [m/s]; 120 km/h (Treiber et al. 2000's v0).
    """

    scenario = "following"
    BOUNDS = {
        "lead_speed": _SPEED,
        "speed_amplitude": _AMPLITUDE,
        "fluctuation_period": _SPAN,
        "fluctuation_accel": _DECEL,
        "time_headway": _SPAN,
        "ego_desired_speed": _SPEED,
    }
    lead_speed: Number = 25.0
    speed_amplitude: Number = 1.5
    fluctuation_period: Number = 20.0
    fluctuation_accel: Number = 0.3
    time_headway: Number = 2.0
    ego_desired_speed: Number = 120 * KMH


#: Monte Carlo ranges of :func:`random_suite`: kind -> field -> (low, high, unit, why).
RANDOM_RANGES: dict[str, dict[str, tuple[float, float, str, str]]] = {
    "nhtsa_lvs": {"sv_speed": (30 * MPH, 60 * MPH, "m/s", "30-60 mph around the test's 45 mph")},
    "nhtsa_lvd": {
        "speed": (30 * MPH, 60 * MPH, "m/s", "30-60 mph around the test's 45 mph"),
        "headway": (20.0, 40.0, "m", "around the test's 30 m"),
        "pov_decel": (0.2 * G, 0.5 * G, "m/s²", "0.2-0.5 g around the test's 0.3 g"),
    },
    "nhtsa_lvm": {
        "sv_speed": (30 * MPH, 60 * MPH, "m/s", "30-60 mph around the test's 45 mph"),
        "pov_speed": (10 * MPH, 25 * MPH, "m/s", "10-25 mph around the test's 20, below sv_speed"),
    },
    "ccrs": {"vut_speed": (10 * KMH, 80 * KMH, "m/s", "10-80 km/h, the CCRs span")},
    "ccrm": {"vut_speed": (30 * KMH, 80 * KMH, "m/s", "the protocol's 30-80 km/h")},
    "ccrb": {
        "headway": (12.0, 40.0, "m", "spans the protocol's 12 and 40 m"),
        "gvt_decel": (2.0, 6.0, "m/s²", "spans the protocol's 2 and 6 m/s²"),
    },
    "cut_in": {
        "ego_speed": (60 * KMH, 120 * KMH, "m/s", "60-120 km/h, arterial to motorway (assumption)"),
        "cut_in_speed": (40 * KMH, 100 * KMH, "m/s", "40-100 km/h, mostly slower (assumption)"),
        "cut_in_gap": (5.0, 25.0, "m", "short merges, about 0.2-1.5 s headway (assumption)"),
    },
    "cut_out": {
        "ego_speed": (60 * KMH, 120 * KMH, "m/s", "60-120 km/h, arterial to motorway (assumption)"),
        "lead_speed": (40 * KMH, 80 * KMH, "m/s", "40-80 km/h: mostly a slower lead (assumption)"),
        "revealed_speed": (0.0, 80 * KMH, "m/s", "0-80 km/h: queue end to moving traffic"),
    },
    "stop_and_go": {
        "cruise_speed": (20 * KMH, 50 * KMH, "m/s", "20-50 km/h, urban queues"),
        "time_headway": (1.0, 2.0, "s", "urban headways around the IDM's 1.6 s"),
    },
    "following": {
        "lead_speed": (15.0, 30.0, "m/s", "54-108 km/h, below the ego's 120 km/h desired speed"),
        "time_headway": (1.5, 3.0, "s", "safe time headways"),
    },
}
