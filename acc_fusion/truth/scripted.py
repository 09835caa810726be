r"""Scripted truth source: the standard FCW/AEB test manoeuvres, batched over N runs.

Pipeline stage 1 (**truth source** → sensors → ...).  :class:`ScenarioSource` scripts the
motion of an ego (subject) vehicle and up to two other vehicles for each of N independent runs
and yields one :class:`~acc_fusion.truth.frame.TruthFrame` per step.  It is closed-loop capable:
:meth:`ScenarioSource.advance` takes the brake request of each run's driver (see
:mod:`acc_fusion.truth.driver`).

Manoeuvres (:data:`SCENARIOS`)
    =============  ==========================================================================
    name           manoeuvre (default parameters; all overridable, see the params classes)
    =============  ==========================================================================
    nhtsa_lvs      NHTSA FCW test 1, lead vehicle stopped: SV at 45 mph (72.4 km/h) toward a
                   stopped POV
    nhtsa_lvd      NHTSA FCW test 2, lead vehicle decelerating: SV and POV at 45 mph, 30 m
                   apart, the POV brakes at 0.3 g to a stop
    nhtsa_lvm      NHTSA FCW test 3, lead vehicle moving: SV at 45 mph, POV at 20 mph
    ccrs           Euro NCAP Car-to-Car Rear stationary: VUT (10-80 km/h; 50) toward a
                   stationary GVT
    ccrm           Euro NCAP Car-to-Car Rear moving: VUT (30-80 km/h; 50) toward a GVT at
                   20 km/h
    ccrb           Euro NCAP Car-to-Car Rear braking: VUT and GVT at 50 km/h, headway 12 or
                   40 m, the GVT brakes at 2 or 6 m/s² (default: the 2x2 matrix)
    cut_in         a slower vehicle changes into the ego lane at a short gap
    cut_out        the ego follows (and closes on) a lead that changes lane before a collision
                   would happen, revealing the vehicle ahead of it (moving, stopped or none)
    stop_and_go    urban queue: the lead alternately brakes to a stop and pulls away; the ego
                   follows it with the Intelligent Driver Model
    following      steady car following at a safe time headway with mild lead speed
                   fluctuations: no threat, pure false-alarm exposure
    random         Monte Carlo mixture of the above (:func:`random_suite`)
    =============  ==========================================================================

    Sources: NHTSA, *Forward Collision Warning System Confirmation Test*, Office of Vehicle
    Safety, February 2013 (tests 1-3: LVS, LVD, LVM; the set-ups above are the widely cited
    ones, the primary text was not readable here); Euro NCAP, *Test Protocol - AEB Car-to-Car
    systems* (v3.0.2, July 2019; v4.x, 2022-2023): CCRm at 30-80 km/h toward 20 km/h, CCRb at
    50 km/h with 12/40 m and 2/6 m/s², and CCRs toward a stationary target are checked against
    BeamNG's implementation of v3.0.2 (``BeamNG/BeamNG_NCAP_Tests``,
    ``src/beamng_ncap/scenarios.py``, which tests CCRs at 10-50 km/h, the AEB speeds); the
    10-80 km/h span of CCRs (AEB plus FCW speeds) is not verified.  That implementation starts
    the measured test at a TTC of 4 s; the scripts start earlier (``initial_ttc`` = 6 s, or a
    steady phase of ``brake_time`` before the lead brakes) so that a tracker has converged and
    a warning earlier than 4 s can be seen.  Parameters are named as in the protocols (SV/POV
    for NHTSA, VUT/GVT for Euro NCAP), in SI units.

State (per run, shape ``(N,)``; :meth:`ScenarioSource.state`)
    Ego front-bumper position, speed, acceleration; the leader's rear-bumper position, speed,
    acceleration and length; ``gap`` = leader rear bumper - ego front bumper (bumper to
    bumper); ``leader_id`` (the vehicle's slot + 1, plus :data:`SLOTS` per restart of the run;
    ``-1`` when there is none); the leader's lateral offset (0 when in lane); ``active``.

Kinematics (exact)
    Every vehicle moves with a constant acceleration within a step; a vehicle's script is a list
    of segments "from time :math:`t_k` on, go to speed :math:`v_k` at :math:`|a| = r_k`, then
    hold it", and within a step of length :math:`\Delta t` a vehicle at speed :math:`v` reaches
    the target after :math:`\tau = \min(|v_k - v| / r_k, \Delta t)`, so

    .. math::

        v' = v + a\tau,\qquad x' = x + v\,\Delta t + \tfrac12 a\tau^2 + a\tau(\Delta t - \tau)

    exactly.  Braking has target speed 0, so a braking vehicle stops exactly and stays stopped:
    speeds are never negative.  A segment starts at the first step boundary at or after its
    time (default event times are multiples of common steps).  The ego follows its scripted
    speed (constant; in ``following`` and ``stop_and_go`` the IDM, see :class:`IDMParameters`)
    unless the run's driver requests a deceleration: then it brakes with that deceleration.
    Once a driver has braked, a scripted constant-speed ego no longer returns to its script:
    it keeps its speed when the driver releases (the IDM ego resumes following).

Leader and lateral offset
    A lane change moves a vehicle's lateral offset from ``from`` to ``to`` along the smooth
    step :math:`3u^2 - 2u^3`, :math:`u = (t - t_0)/T_{lc}` (lanes :data:`LANE_WIDTH` apart).
    The leader is the nearest vehicle ahead whose body overlaps the ego's laterally
    (:math:`|y| <` :data:`OVERLAP_OFFSET`): a cut-in vehicle becomes the leader (new id) when
    it crosses that line, a cut-out lead stops being the leader when it leaves it.

Collisions and the end of a run
    When the gap to the leader reaches 0 the run is marked ``collided`` at that step, the
    closing speed at the end of that step is recorded as ``collision_speed`` (exact when neither
    vehicle accelerates; within :math:`|\Delta a|\,\Delta t` otherwise), both vehicles stop
    at contact (gap 0) and the run ends.  A scripted (non-IDM) run also ends when the threat is
    resolved after its driver braked: ego stopped, or no longer closing on its leader, or no
    leader.  Every run ends at its ``duration``.  An ended run is frozen: later frames repeat
    its final state with ``leader_id = -1`` (so downstream stages ignore it) and ``active`` is
    False; frames stay valid :class:`~acc_fusion.truth.frame.TruthFrame` s.

Restarting runs (:meth:`ScenarioSource.restart`)
    The runs of a mask can start a new run of the same scenario at the current time, while the
    others continue (a vector environment whose copies reset independently).  Every run has
    its own time origin :attr:`~ScenarioSource.t0` (0 at construction, the restart time
    after a restart); its script, ``duration`` and ``end_time`` are in *run time*
    :attr:`~ScenarioSource.run_time` = ``t - t0``, so a restarted run behaves exactly like
    the same run of a fresh source, except that its leader ids are offset by
    :data:`SLOTS` per restart (ids stay unique per run, so downstream stages see a new target;
    see :attr:`~ScenarioSource.generation`) and that ``frame().t`` is the global time.

Randomness and reproducibility
    All randomness (the Monte Carlo draws of :func:`random_suite`, the phases of the lead's
    speed fluctuations and stop-and-go cycles) comes from ``numpy.random.default_rng(seed)``
    and is drawn at construction, so the same seed gives identical frames and closed-loop
    actions never change the random stream.

Example:
    >>> src = make_scenario("nhtsa_lvs", 3, seed=0)
    >>> frame = src.frame()
    >>> while not src.done:
    ...     frame = src.advance()          # no driver: every run hits the stopped POV
    >>> bool(src.collided.all()), round(float(src.collision_speed[0]) * 3.6, 1)
    (True, 72.4)
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from functools import partial
from typing import Any, ClassVar

import numpy as np

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.validation import check_array, check_choice, check_range
from acc_fusion.truth.frame import TruthFrame

#: Standard gravity [m/s²].
G = 9.80665
#: One mile per hour and one kilometre per hour in m/s.
MPH = 0.44704
KMH = 1.0 / 3.6
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
#: Tolerance [s] when comparing the simulation time with event times.
TIME_TOL = 1e-9
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

    def accel(self, v, v_desired, headway, gap, lead_speed, has_leader) -> np.ndarray:
        """IDM acceleration [m/s²] of egos at speed ``v`` (all arrays ``(N,)``)."""
        free = 1.0 - (v / v_desired) ** self.exponent
        dynamic = v * headway + v * (v - lead_speed) / (
            2.0 * math.sqrt(self.max_accel * self.comfortable_decel)
        )
        s_star = self.jam_distance + np.maximum(dynamic, 0.0)
        interaction = np.where(has_leader, (s_star / np.maximum(gap, 1e-3)) ** 2, 0.0)
        return np.clip(self.max_accel * (free - interaction), -self.max_decel, self.max_accel)

    def equilibrium_gap(self, v, headway, v_desired) -> np.ndarray:
        """Gap [m] at which an IDM ego following a leader at its own speed ``v`` keeps ``a = 0``."""
        return (self.jam_distance + v * headway) / np.sqrt(1.0 - (v / v_desired) ** self.exponent)


#: The IDM used by the following manoeuvres.
IDM = IDMParameters()


# --------------------------------------------------------------------------- parameters

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


# --------------------------------------------------------------------------- scripts


@dataclass(frozen=True)
class _Plan:
    """The script of N runs (S = :data:`SLOTS` other vehicles, K speed segments each)."""

    ego_speed: np.ndarray  # (N,) initial ego speed
    idm: np.ndarray  # (N,) bool: the ego follows the IDM
    time_headway: np.ndarray  # (N,) IDM T [s] (NaN where not IDM)
    desired_speed: np.ndarray  # (N,) IDM v0 [m/s] (NaN where not IDM)
    duration: np.ndarray  # (N,) [s]
    present: np.ndarray  # (N, S) bool
    position: np.ndarray  # (N, S) rear bumper, ego front bumper at 0 [m]
    speed: np.ndarray  # (N, S) [m/s]
    seg_t: np.ndarray  # (N, S, K) segment start [s]
    seg_v: np.ndarray  # (N, S, K) target speed [m/s]
    seg_rate: np.ndarray  # (N, S, K) |acceleration| [m/s²]
    lateral: np.ndarray  # (N, S, 4) lane change: start [s], from [m], to [m], duration [s]


@dataclass(frozen=True)
class _Vehicle:
    """One other vehicle of a kind's runs: initial gap (inf: absent), speed, speed events."""

    gap: np.ndarray
    speed: np.ndarray
    events: tuple[tuple[np.ndarray, np.ndarray, np.ndarray], ...] = ()  # (t, target, rate)
    lateral: tuple[Any, Any, Any, Any] = (0.0, 0.0, 0.0, 1.0)


def _plan(ego_speed, vehicles, duration, horizon, idm=None) -> _Plan:
    """Stack the vehicles into a :class:`_Plan`; ``idm`` = (time headway, desired speed)."""
    n = ego_speed.shape[0]
    slots = list(vehicles) + [_Vehicle(np.full(n, np.inf), np.zeros(n))] * (SLOTS - len(vehicles))
    programs = []
    for v in slots:
        columns = [(np.zeros(n), v.speed, np.zeros(n)), *v.events]
        programs.append([np.column_stack([c[i] for c in columns]) for i in range(3)])
    k = max(p[0].shape[1] for p in programs)

    def stack(i: int, fill: float) -> np.ndarray:
        return np.stack([_pad_segments(p[i], k, fill) for p in programs], axis=1)

    present = np.stack([np.isfinite(v.gap) for v in slots], axis=1)
    t_headway, v_desired = (np.full(n, np.nan),) * 2 if idm is None else idm
    return _Plan(
        ego_speed=ego_speed,
        idm=np.full(n, idm is not None),
        time_headway=t_headway,
        desired_speed=v_desired,
        duration=duration if horizon is None else np.full(n, horizon),
        present=present,
        position=np.where(present, np.stack([v.gap for v in slots], axis=1), 0.0),
        speed=np.stack([v.speed for v in slots], axis=1),
        seg_t=stack(0, np.inf),
        seg_v=stack(1, 0.0),
        seg_rate=stack(2, 0.0),
        lateral=np.stack(
            [np.column_stack([np.broadcast_to(x, (n,)) for x in v.lateral]) for v in slots], axis=1
        ),
    )


def _pad_segments(a: np.ndarray, k: int, fill: float) -> np.ndarray:
    """Pad the segment axis (last) of ``a`` to ``k`` entries with ``fill``."""
    return np.pad(a, [(0, 0)] * (a.ndim - 1) + [(0, k - a.shape[-1])], constant_values=fill)


def _cycles(start, phases, horizon):
    """Segments repeating ``phases`` [(duration, target, rate), ...] from ``start`` on."""
    durations = np.stack([p[0] for p in phases], axis=-1)  # (n, P)
    period = durations.sum(axis=-1)
    count = int(np.ceil(np.max((horizon - start) / period))) + 1
    offsets = np.cumsum(durations, axis=-1) - durations
    t = (
        start[:, None, None]
        + np.arange(count)[None, :, None] * period[:, None, None]
        + offsets[:, None, :]
    )
    shape = t.shape
    targets = np.broadcast_to(np.stack([p[1] for p in phases], -1)[:, None, :], shape)
    rates = np.broadcast_to(np.stack([p[2] for p in phases], -1)[:, None, :], shape)
    n = start.shape[0]
    return t.reshape(n, -1), targets.reshape(n, -1), rates.reshape(n, -1)


def _approach(ego_speed, lead_speed, initial_ttc, horizon) -> _Plan:
    """Constant-speed ego toward a slower constant-speed lead, starting at ``initial_ttc``."""
    lead = _Vehicle(initial_ttc * (ego_speed - lead_speed), lead_speed)
    return _plan(ego_speed, [lead], initial_ttc + SETTLE_TIME, horizon)


def _closing(ego_speed, lead_speed, ego_field: str, lead_field: str) -> None:
    """Reject a lead that is not slower than the subject vehicle."""
    if np.any(ego_speed <= lead_speed):
        raise ConfigError(
            f"{ego_field} must exceed {lead_field} (the subject vehicle must close in), "
            f"got {ego_speed[ego_speed <= lead_speed][0]:g} <= "
            f"{lead_speed[ego_speed <= lead_speed][0]:g} m/s"
        )


def _braking_lead(speed, headway, decel, brake_time, horizon) -> _Plan:
    """Ego and lead at ``speed``; the lead brakes to a stop at ``brake_time``."""
    lead = _Vehicle(headway, speed, events=((brake_time, np.zeros_like(speed), decel),))
    return _plan(speed, [lead], brake_time + speed / decel + SETTLE_TIME, horizon)


def _lvs(p, rng, horizon):
    return _approach(p["sv_speed"], np.zeros_like(p["sv_speed"]), p["initial_ttc"], horizon)


def _lvd(p, rng, horizon):
    return _braking_lead(p["speed"], p["headway"], p["pov_decel"], p["brake_time"], horizon)


def _lvm(p, rng, horizon):
    _closing(p["sv_speed"], p["pov_speed"], "nhtsa_lvm.sv_speed", "nhtsa_lvm.pov_speed")
    return _approach(p["sv_speed"], p["pov_speed"], p["initial_ttc"], horizon)


def _ccrs(p, rng, horizon):
    return _approach(p["vut_speed"], np.zeros_like(p["vut_speed"]), p["initial_ttc"], horizon)


def _ccrm(p, rng, horizon):
    _closing(p["vut_speed"], p["gvt_speed"], "ccrm.vut_speed", "ccrm.gvt_speed")
    return _approach(p["vut_speed"], p["gvt_speed"], p["initial_ttc"], horizon)


def _ccrb(p, rng, horizon):
    return _braking_lead(p["speed"], p["headway"], p["gvt_decel"], p["brake_time"], horizon)


def _cut_in(p, rng, horizon):
    v, vc, gap = p["ego_speed"], p["cut_in_speed"], p["cut_in_gap"]
    if np.any(p["lead_gap"] <= gap + VEHICLE_LENGTH):
        raise ConfigError(
            f"cut_in.lead_gap must exceed cut_in.cut_in_gap + {VEHICLE_LENGTH:g} m (the far "
            "lead is ahead of the merging vehicle)"
        )
    t_end = p["lane_change_time"] + p["lane_change_duration"]
    far = _Vehicle(p["lead_gap"], v)
    lane_change = (p["lane_change_time"], LANE_WIDTH, 0.0, p["lane_change_duration"])
    cutter = _Vehicle(gap + (v - vc) * t_end, vc, lateral=lane_change)
    return _plan(v, [far, cutter], t_end + 2 * SETTLE_TIME, horizon)


def _cut_out(p, rng, horizon):
    v, vl, vr = p["ego_speed"], p["lead_speed"], p["revealed_speed"]
    t_end = p["lane_change_time"] + p["lane_change_duration"]
    revealed_start = p["revealed_gap"] + (v - vr) * t_end
    lead_front = p["lead_gap"] + VEHICLE_LENGTH
    if np.any(
        (lead_front >= revealed_start) | (lead_front - (v - vl) * t_end >= p["revealed_gap"])
    ):
        raise ConfigError(
            "cut_out.revealed_gap must keep the revealed vehicle ahead of the lead until the "
            "lead's lane change ends"
        )
    lane_change = (p["lane_change_time"], 0.0, LANE_WIDTH, p["lane_change_duration"])
    lead = _Vehicle(p["lead_gap"], vl, lateral=lane_change)
    return _plan(v, [lead, _Vehicle(revealed_start, vr)], t_end + 2 * SETTLE_TIME, horizon)


def _idm_gap(lead_speed, top_speed, p, label: str) -> np.ndarray:
    """IDM equilibrium gap behind a lead at ``lead_speed``; the ego must want to go faster."""
    if np.any(p["ego_desired_speed"] <= top_speed):
        raise ConfigError(f"{label}.ego_desired_speed must exceed the lead's highest speed")
    return IDM.equilibrium_gap(lead_speed, p["time_headway"], p["ego_desired_speed"])


def _following_duration(shape, horizon) -> np.ndarray:
    return np.full(shape, FOLLOWING_DURATION if horizon is None else horizon)


def _stop_and_go(p, rng, horizon):
    vc, b, a = p["cruise_speed"], p["lead_decel"], p["lead_accel"]
    gap = _idm_gap(vc, vc, p, "stop_and_go")
    duration = _following_duration(vc.shape, horizon)
    first_stop = rng.uniform(0.0, 1.0, vc.shape) * p["cruise_time"]
    phases = [(vc / b + p["stop_time"], np.zeros_like(vc), b), (vc / a + p["cruise_time"], vc, a)]
    lead = _Vehicle(gap, vc, events=(_cycles(first_stop, phases, duration),))
    return _plan(vc, [lead], duration, horizon, idm=(p["time_headway"], p["ego_desired_speed"]))


def _following(p, rng, horizon):
    v, amp, rate = p["lead_speed"], p["speed_amplitude"], p["fluctuation_accel"]
    gap = _idm_gap(v, v + amp, p, "following")
    duration = _following_duration(v.shape, horizon)
    half = p["fluctuation_period"] / 2
    delay = rng.uniform(0.0, 1.0, v.shape) * half
    swing = _cycles(delay, [(half, v + amp, rate), (half, v - amp, rate)], duration)
    lead = _Vehicle(gap, v, events=(swing,))
    return _plan(v, [lead], duration, horizon, idm=(p["time_headway"], p["ego_desired_speed"]))


# --------------------------------------------------------------------------- registry

#: The standard manoeuvres: name -> (parameters class, per-run builder).
_BUILDERS: dict[str, tuple[type[ScenarioParams], Callable[..., _Plan]]] = {
    "nhtsa_lvs": (LVSParams, _lvs),
    "nhtsa_lvd": (LVDParams, _lvd),
    "nhtsa_lvm": (LVMParams, _lvm),
    "ccrs": (CCRsParams, _ccrs),
    "ccrm": (CCRmParams, _ccrm),
    "ccrb": (CCRbParams, _ccrb),
    "cut_in": (CutInParams, _cut_in),
    "cut_out": (CutOutParams, _cut_out),
    "stop_and_go": (StopAndGoParams, _stop_and_go),
    "following": (FollowingParams, _following),
}
#: Names of the standard (non-random) manoeuvres.
STANDARD: tuple[str, ...] = tuple(_BUILDERS)

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


@dataclass(frozen=True)
class RandomSuiteParams:
    """Parameters of the ``random`` mixture (:func:`random_suite`).

    Attributes:
        kinds: the manoeuvres to mix, each drawn with equal probability (a name listed twice is
            drawn twice as often); default: all of :data:`STANDARD`.
    """

    kinds: tuple[str, ...] = STANDARD

    def __post_init__(self) -> None:
        kinds = (self.kinds,) if isinstance(self.kinds, str) else tuple(self.kinds)
        if not kinds:
            raise ConfigError("random.kinds must name at least one of " + ", ".join(STANDARD))
        for kind in kinds:
            check_choice("random.kinds", kind, STANDARD)
        object.__setattr__(self, "kinds", kinds)


@dataclass(frozen=True)
class Manoeuvre:
    """A registry entry: its parameters class and ``build(params, n, rng, horizon)``."""

    params: type
    build: Callable[..., tuple[_Plan, dict[str, np.ndarray], np.ndarray]]


def _build_one(name: str, params: ScenarioParams, n: int, rng, horizon):
    runs = params.grid(n)
    return _BUILDERS[name][1](runs, rng, horizon), runs, np.full(n, name)


def _build_random(params: RandomSuiteParams, n: int, rng, horizon):
    kinds = np.asarray(params.kinds)[rng.integers(len(params.kinds), size=n)]
    parts, runs = [], {}
    for name, (cls, build) in _BUILDERS.items():
        ranges = RANDOM_RANGES[name]
        drawn = {f: rng.uniform(lo, hi, size=n) for f, (lo, hi, _, _) in ranges.items()}
        idx = np.flatnonzero(kinds == name)
        if idx.size:
            p = {**cls().grid(idx.size), **{f: a[idx] for f, a in drawn.items()}}
            parts.append((idx, build(p, rng, horizon)))
            for f, a in p.items():
                runs.setdefault(f, np.full(n, np.nan))[idx] = a
    return _merge(parts, n), runs, kinds


def _merge(parts: list[tuple[np.ndarray, _Plan]], n: int) -> _Plan:
    """One plan from the plans of disjoint sets of runs (speed programs padded to equal K)."""
    k = max(plan.seg_t.shape[-1] for _, plan in parts)
    merged = {}
    for f in fields(_Plan):
        arrays = [getattr(plan, f.name) for _, plan in parts]
        if f.name.startswith("seg_"):
            fill = np.inf if f.name == "seg_t" else 0.0
            arrays = [_pad_segments(a, k, fill) for a in arrays]
        out = np.empty((n, *arrays[0].shape[1:]), dtype=arrays[0].dtype)
        for (idx, _), a in zip(parts, arrays, strict=True):
            out[idx] = a
        merged[f.name] = out
    return _Plan(**merged)


#: Registry of the manoeuvres: name -> :class:`Manoeuvre`.
SCENARIOS: dict[str, Manoeuvre] = {
    **{name: Manoeuvre(cls, partial(_build_one, name)) for name, (cls, _) in _BUILDERS.items()},
    "random": Manoeuvre(RandomSuiteParams, _build_random),
}


# --------------------------------------------------------------------------- the source


def _ramp(x, v, target, rate, dt):
    """Exact motion over ``dt`` toward speed ``target`` at ``|a| = rate``, then holding it."""
    dv = target - v
    with np.errstate(divide="ignore", invalid="ignore"):
        reached = rate * dt >= np.abs(dv)
        tau = np.where(reached, np.abs(dv) / np.where(rate > 0, rate, 1.0), dt)
    a = np.sign(dv) * rate
    x_new = x + v * dt + 0.5 * a * tau**2 + a * tau * (dt - tau)
    return x_new, np.where(reached, target, v + a * dt)


@dataclass(frozen=True)
class ScenarioState:
    """State of every run at time ``t`` (arrays ``(N,)``; leader fields NaN without a leader).

    Attributes:
        t: time [s].
        ego_position: ego front-bumper position [m] (0 at the start).
        ego_speed, ego_accel: ego speed [m/s] and acceleration over the next step [m/s²].
        lead_position: leader rear-bumper position [m].
        lead_speed, lead_accel, lead_length: leader speed [m/s], acceleration [m/s²], length [m].
        gap: ``lead_position - ego_position`` [m] (bumper to bumper).
        leader_id: leader id (its slot + 1, plus :data:`SLOTS` per restart of the run), ``-1``
            without a leader or after the run ended.
        lateral_offset: leader's lateral offset [m] (0 when in lane).
        active: runs that have not ended.
    """

    t: float
    ego_position: np.ndarray
    ego_speed: np.ndarray
    ego_accel: np.ndarray
    lead_position: np.ndarray
    lead_speed: np.ndarray
    lead_accel: np.ndarray
    lead_length: np.ndarray
    gap: np.ndarray
    leader_id: np.ndarray
    lateral_offset: np.ndarray
    active: np.ndarray

    def frame(self) -> TruthFrame:
        """The :class:`~acc_fusion.truth.frame.TruthFrame` of this state."""
        has = self.leader_id >= 0
        return TruthFrame(
            t=self.t,
            ego_speed=self.ego_speed,
            ego_accel=self.ego_accel,
            gap=self.gap,
            lead_speed=self.lead_speed,
            lead_accel=self.lead_accel,
            leader_id=self.leader_id,
            lateral_offset=np.where(has, self.lateral_offset, 0.0),
        )


class ScenarioSource:
    """Truth source scripting a standard manoeuvre for N runs (see the module docstring).

    Args:
        name: a key of :data:`SCENARIOS`.
        n_runs: number of runs N.
        dt: simulation step [s], in (0, 1].
        seed: seed of the generator (``int``, ``numpy.random.Generator`` or ``None``).
        params: the manoeuvre's parameters (its class in :data:`SCENARIOS`); default: defaults.
        duration: length of every run [s]; default: the manoeuvre's own.

    Attributes:
        kind: ``(N,)`` manoeuvre name of each run (mixed for ``random``).
        run_params: ``{field: (N,) array}`` parameters of each run (NaN where a field does not
            apply to the run's kind).
        duration: ``(N,)`` length of each run [s] (its current run after a :meth:`restart`).

    Times of a run's script, ``duration`` and :attr:`end_time` are run times (:attr:`run_time`,
    time since the run's :attr:`t0`); they equal the global time :attr:`t` until the run is
    restarted.
    """

    def __init__(
        self,
        name: str,
        n_runs: int,
        dt: float = 0.05,
        seed: int | np.random.Generator | None = None,
        params: Any = None,
        duration: float | None = None,
    ) -> None:
        manoeuvre = SCENARIOS[check_choice("scenario", name, SCENARIOS)]
        if isinstance(n_runs, bool) or not isinstance(n_runs, (int, np.integer)) or n_runs < 1:
            raise ConfigError(f"n_runs must be an integer >= 1, got {n_runs!r}")
        self.name, self.n_runs = name, int(n_runs)
        self.dt = check_range("dt", dt, 0.0, 1.0, lo_open=True)
        if params is None:
            params = manoeuvre.params()
        elif not isinstance(params, manoeuvre.params):
            raise ConfigError(
                f"params of {name!r} must be a {manoeuvre.params.__name__}, "
                f"got {type(params).__name__}"
            )
        horizon = (
            None if duration is None else check_range("duration", duration, 0.0, 1e6, lo_open=True)
        )
        self.params = params
        self._build, self._horizon = manoeuvre.build, horizon
        plan, self.run_params, self.kind = manoeuvre.build(
            params, self.n_runs, np.random.default_rng(seed), horizon
        )
        self._plan = plan
        self.duration = plan.duration
        self._k = 0
        self._k0 = np.zeros(self.n_runs, dtype=np.int64)  # step at which each run started
        self._run_t = np.zeros(self.n_runs)  # run time (self._k - self._k0) * dt
        self._generation = np.zeros(self.n_runs, dtype=np.int64)
        self._reassigned = np.zeros(self.n_runs, dtype=bool)
        self._ego_x = np.zeros(self.n_runs)
        self._ego_v = plan.ego_speed.astype(float)
        self._x = plan.position.astype(float)
        self._v = plan.speed.astype(float)
        self._brake = np.zeros(self.n_runs)
        self._braked = np.zeros(self.n_runs, dtype=bool)
        self._end_time = np.full(self.n_runs, np.inf)
        self._collided = np.zeros(self.n_runs, dtype=bool)
        self._collision_speed = np.full(self.n_runs, np.nan)
        self._rows = np.arange(self.n_runs)
        self._frame: TruthFrame | None = None  # the frame of this step, built on demand

    # ---- public state
    @property
    def t(self) -> float:
        """Current time [s] (``step * dt``, so event times do not drift)."""
        return self._k * self.dt

    @property
    def t0(self) -> np.ndarray:
        """``(N,)`` start time of each run's current run [s] (0 until :meth:`restart`)."""
        return self._k0 * self.dt

    @property
    def run_time(self) -> np.ndarray:
        """``(N,)`` time since each run started [s] (``t - t0``, computed per step)."""
        return self._run_t.copy()

    @property
    def generation(self) -> np.ndarray:
        """``(N,)`` number of times each run was restarted."""
        return self._generation.copy()

    @property
    def reassigned(self) -> np.ndarray:
        """``(N,)`` runs restarted since the last :meth:`advance` (reset their per-run state).

        The same flag as :attr:`acc_fusion.truth.sumo.source.SumoSource.reassigned`: the current
        frame of
        these runs is the first frame of a new run.
        """
        return self._reassigned.copy()

    @property
    def n_steps(self) -> int:
        """Step count (from construction, like :attr:`t` / ``dt``) at which the longest current
        run reaches its duration.

        Without restarts: the number of steps of the longest run.  After a :meth:`restart` it
        is ``max(t0 + duration) / dt`` over the current runs, so ``n_steps - t / dt`` steps
        remain until every current run has timed out.
        """
        steps = np.ceil(self.duration / self.dt - TIME_TOL).astype(np.int64)
        return int(np.max(self._k0 + steps))

    @property
    def active(self) -> np.ndarray:
        """``(N,)`` runs that have not ended."""
        return np.isinf(self._end_time)

    @property
    def done(self) -> bool:
        """Every run has ended."""
        return not self.active.any()

    @property
    def end_time(self) -> np.ndarray:
        """``(N,)`` run time (:attr:`run_time`) at which each run ended [s] (``inf`` while it
        runs); the global end time is ``t0 + end_time``."""
        return self._end_time.copy()

    @property
    def collided(self) -> np.ndarray:
        """``(N,)`` runs that ended in a collision."""
        return self._collided.copy()

    @property
    def collision_speed(self) -> np.ndarray:
        """``(N,)`` relative (closing) speed at impact [m/s]; NaN where no collision."""
        return self._collision_speed.copy()

    def state(self) -> ScenarioState:
        """The full state of every run now."""
        ego_a, target, rate = self._controls()
        slot, has, gap, lat = self._leader()
        active = self.active
        show = has & (self._run_t <= self._end_time + TIME_TOL)
        moving = active[:, None] & (self._v != target)
        lead_a = np.where(moving, np.sign(target - self._v) * rate, 0.0)[self._rows, slot]

        def lead(values: np.ndarray) -> np.ndarray:
            return np.where(show, values, np.nan)

        return ScenarioState(
            t=self.t,
            ego_position=self._ego_x.copy(),
            ego_speed=self._ego_v.copy(),
            ego_accel=np.where(active & ((self._ego_v > 0) | (ego_a > 0)), ego_a, 0.0),
            lead_position=lead(self._x[self._rows, slot]),
            lead_speed=lead(self._v[self._rows, slot]),
            lead_accel=lead(lead_a),
            lead_length=lead(np.full(self.n_runs, VEHICLE_LENGTH)),
            gap=lead(gap),
            leader_id=np.where(show, slot + 1 + SLOTS * self._generation, -1).astype(np.int64),
            lateral_offset=lead(lat),
            active=active,
        )

    def frame(self) -> TruthFrame:
        """The current truth as a :class:`~acc_fusion.truth.frame.TruthFrame` (built once per step:
        repeated calls return the same object)."""
        if self._frame is None:
            self._frame = self.state().frame()
        return self._frame

    def advance(self, ego_brake: np.ndarray | None = None) -> TruthFrame:
        """Move every active run one step and return the new frame.

        Args:
            ego_brake: ``(N,)`` deceleration requested by each run's driver [m/s², >= 0] for
                this step; 0 or NaN (or ``None`` for all) means no request: the scripted ego.
        """
        if ego_brake is None:
            self._brake = np.zeros(self.n_runs)
        else:
            brake = check_array("ego_brake", ego_brake, (self.n_runs,), finite=False)
            brake = np.where(np.isnan(brake), 0.0, brake)
            self._brake = check_array("ego_brake", brake, nonnegative=True)
        active = self.active
        ego_a, target, rate = self._controls()
        ego_x, ego_v = _ramp(
            self._ego_x, self._ego_v, np.where(ego_a < 0, 0.0, np.inf), np.abs(ego_a), self.dt
        )
        x, v = _ramp(self._x, self._v, target, rate, self.dt)
        self._ego_x, self._ego_v = (
            np.where(active, ego_x, self._ego_x),
            np.where(active, ego_v, self._ego_v),
        )
        self._x, self._v = (
            np.where(active[:, None], x, self._x),
            np.where(active[:, None], v, self._v),
        )
        self._braked |= active & (self._brake > 0)
        self._frame = None
        self._k += 1
        self._run_t = (self._k - self._k0) * self.dt
        self._reassigned.fill(False)
        self._settle(active)
        return self.frame()

    def restart(self, mask: np.ndarray, seed: int | np.random.Generator | None) -> None:
        """Start a new run of the scenario, now, for the runs in ``mask``; the others continue.

        The new runs are drawn exactly as a fresh
        ``ScenarioSource(name, mask.sum(), dt, seed, params, duration)`` would draw its runs
        (the i-th masked run is that source's run i; same params, duration and ``dt``), and
        from now on each follows that fresh run step for step: its frame now is the fresh
        source's first frame, ``k`` steps later its ``k``-th frame, in run time
        :attr:`run_time` (reset to 0).  Its leader ids are offset by :data:`SLOTS` per restart
        (:attr:`generation`); ``frame().t`` stays the global time.  The run's ``kind``,
        ``run_params``, ``duration``, collision and end bookkeeping are replaced (new arrays:
        arrays read before stay unchanged), and :attr:`reassigned` flags it until the next
        :meth:`advance`.  An all-False mask does nothing (and draws nothing from ``seed``).

        Args:
            mask: ``(N,)`` boolean array of the runs to restart.
            seed: seed of the new runs' draws (``int``, ``numpy.random.Generator`` or ``None``).

        Raises:
            InputError: ``mask`` is not a boolean array of shape ``(N,)``.
        """
        mask = np.asarray(mask)
        if mask.shape != (self.n_runs,):
            raise InputError(f"mask must have shape ({self.n_runs},), got {mask.shape}")
        if mask.dtype != bool:
            raise InputError(f"mask must be a boolean array, got dtype {mask.dtype}")
        idx = np.flatnonzero(mask)
        if idx.size == 0:
            return
        sub, runs, kinds = self._build(
            self.params, idx.size, np.random.default_rng(seed), self._horizon
        )
        self._plan = _merge([(self._rows, self._plan), (idx, sub)], self.n_runs)
        self.duration = self._plan.duration
        kind = self.kind.astype(np.promote_types(self.kind.dtype, kinds.dtype))
        kind[idx] = kinds
        self.kind = kind
        run_params = {}
        for name in [*self.run_params, *(f for f in runs if f not in self.run_params)]:
            column = np.array(self.run_params.get(name, np.full(self.n_runs, np.nan)), float)
            column[idx] = runs.get(name, np.nan)
            run_params[name] = column
        self.run_params = run_params
        # per-run state: the fresh source's initial state
        self._frame = None
        self._k0[idx] = self._k
        self._run_t = (self._k - self._k0) * self.dt
        self._generation[idx] += 1
        self._reassigned[idx] = True
        self._ego_x[idx] = 0.0
        self._ego_v[idx] = sub.ego_speed
        self._x[idx] = sub.position
        self._v[idx] = sub.speed
        self._brake[idx] = 0.0
        self._braked[idx] = False
        self._end_time[idx] = np.inf
        self._collided[idx] = False
        self._collision_speed[idx] = np.nan

    # ---- internals
    def _lateral(self) -> np.ndarray:
        start, frm, to, span = np.moveaxis(self._plan.lateral, -1, 0)
        u = np.clip((self._run_t[:, None] - start) / span, 0.0, 1.0)
        return frm + (to - frm) * u * u * (3.0 - 2.0 * u)

    def _leader(self):
        """Leader slot, has-leader mask, gap and lateral offset of every run (``(N,)`` each)."""
        lat = self._lateral()
        ahead = self._x + VEHICLE_LENGTH > self._ego_x[:, None]
        candidate = self._plan.present & (np.abs(lat) < OVERLAP_OFFSET) & ahead
        gaps = np.where(candidate, self._x - self._ego_x[:, None], np.inf)
        slot = np.argmin(gaps, axis=1)
        return slot, candidate.any(axis=1), gaps[self._rows, slot], lat[self._rows, slot]

    def _controls(self):
        """Ego acceleration and the other vehicles' target speeds and rates for the next step."""
        plan = self._plan
        now = self._run_t[:, None, None] + TIME_TOL
        seg = np.sum(plan.seg_t <= now, axis=-1, keepdims=True) - 1
        target = np.take_along_axis(plan.seg_v, seg, axis=-1)[..., 0]
        rate = np.take_along_axis(plan.seg_rate, seg, axis=-1)[..., 0]
        slot, has, gap, _ = self._leader()
        lead_v = self._v[self._rows, slot]
        idm = IDM.accel(self._ego_v, plan.desired_speed, plan.time_headway, gap, lead_v, has)
        ego_a = np.where(self._brake > 0, -self._brake, np.where(plan.idm, idm, 0.0))
        return ego_a, target, rate

    def _settle(self, active: np.ndarray) -> None:
        """Collisions and run ends after a step."""
        slot, has, gap, _ = self._leader()
        hit = active & has & (gap <= 1e-9)
        if hit.any():
            rows, lead = self._rows[hit], slot[hit]
            self._collision_speed[hit] = self._ego_v[hit] - self._v[rows, lead]
            self._ego_x[hit] = self._x[rows, lead]
            self._ego_v[hit] = 0.0
            self._v[rows, lead] = 0.0
            self._collided |= hit
        lead_v = self._v[self._rows, slot]
        resolved = (
            ~self._plan.idm & self._braked & ((self._ego_v <= 0) | ~has | (lead_v >= self._ego_v))
        )
        timeout = self._run_t >= self.duration - TIME_TOL
        ended = active & (hit | resolved | timeout)
        self._end_time[ended] = self._run_t[ended]


def make_scenario(
    name: str, n_runs: int, seed: int | np.random.Generator | None = None, **overrides: Any
) -> ScenarioSource:
    """A :class:`ScenarioSource` with parameters overridden by keyword.

    ``dt`` and ``duration`` go to the source, every other keyword to the manoeuvre's parameters
    class (unknown keys raise :class:`~acc_fusion.core.errors.ConfigError` listing the allowed
    ones).

    >>> src = make_scenario("ccrs", 3, vut_speed=(20 / 3.6, 50 / 3.6, 80 / 3.6))
    >>> [round(v * 3.6) for v in src.run_params["vut_speed"]]
    [20, 50, 80]
    """
    manoeuvre = SCENARIOS[check_choice("scenario", name, SCENARIOS)]
    dt = overrides.pop("dt", 0.05)
    duration = overrides.pop("duration", None)
    params = from_mapping(manoeuvre.params, overrides, prefix=f"{name}.")
    return ScenarioSource(name, n_runs, dt, seed, params, duration)


def random_suite(
    n_runs: int, seed: int | np.random.Generator | None, dt: float = 0.05
) -> ScenarioSource:
    """Monte Carlo mixture: each run draws a manoeuvre type and its parameters.

    The type is uniform over :data:`STANDARD`; the parameters below are uniform over their
    range (all others keep their defaults); units SI.  Draws for every type are made for all N
    runs in a fixed order, so a run's parameters depend only on the seed.  Use
    ``make_scenario("random", n, seed, kinds=(...))`` to mix a subset of the types.

    Ranges (:data:`RANDOM_RANGES`):
    """
    return ScenarioSource("random", n_runs, dt, seed)


def _ranges_table() -> str:
    """The RST table of :data:`RANDOM_RANGES` appended to :func:`random_suite`'s docstring."""
    rows = [("type", "parameter", "range", "unit", "why")]
    for kind, ranges in RANDOM_RANGES.items():
        for field_name, (lo, hi, unit, why) in ranges.items():
            rows.append((kind, field_name, f"{lo:.4g} - {hi:.4g}", unit, why))
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    rule = "    " + "  ".join("=" * w for w in widths)
    lines = [
        "    " + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
        for r in rows
    ]
    return "\n".join([rule, lines[0], rule, *lines[1:], rule, ""])


random_suite.__doc__ = f"{(random_suite.__doc__ or '').rstrip()}\n\n{_ranges_table()}"
