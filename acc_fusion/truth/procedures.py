r"""Test-track AEB procedures as 2-D scenes: one batched :class:`~acc_fusion.truth.scenes.Scene`
whose run ``i`` is test point ``i`` (:func:`procedure_scene`, :class:`ProcedureSource`).

A :class:`TestPoint` is one trial: the subject vehicle (SV, the ego) at a constant test speed
(``ego_model = "cruise"``: a robot driver that brakes only at a requested deceleration, the
AEB's or the manual brake's) on a straight road with guardrail posts, toward a principal other
vehicle (POV, an ``ObjectKind.VEHICLE``) that is ``"stopped"``, ``"slower"`` (constant speed)
or ``"decelerating"`` (braking from ``pov_brake_time``, its deceleration rising linearly to
``pov_decel`` over ``pov_decel_rise``) at a lateral offset given by ``overlap``; or over a
steel trench plate lying flat in its lane (``"plate"``, ``ObjectKind.PLATE``); or between two
POVs parked in the adjacent lanes (``"pass_through"``).  The in-path lead is the vehicle whose
body overlaps the SV's laterally (``lead_rule = "overlap"``).

Runs end one by one (:class:`ProcedureSource`): at the point's ``duration``, at the first
contact, or once the SV has stood still for :data:`REST_TIME`; an ended run is frozen (its
actors stay at its end time, its frames have ``lead = -1``) and inactive, the others go on.
Contact is the SV's body (its front bumper at ``s``, centred on its lane) overlapping a
vehicle's laterally, :math:`|d| < (w + W)/2`, and its front having passed the vehicle's rear
within the step (none missed at any speed); the SV is put at the vehicle's rear and
``collision_speed`` is the closing speed at the end of that step (exact when neither vehicle
accelerates, as :attr:`acc_fusion.truth.scripted.ScenarioSource.collision_speed`; NaN where no
contact).  The plate and the pass-through POVs (beside the SV) are never a contact.

FMVSS No. 127 (49 CFR 571.127; final rule 89 FR 39686, 9 May 2024; amended 89 FR 93199,
26 November 2024)
    Figures gathered from the rule (Table 1 to S5.1.3 and the test procedures); its
    regulatory text could not be read here (the stored Federal Register copies hold the
    preambles only), so the section numbers are as recalled, to be checked against S7 and S9.

    ========================  ================================================================
    test                      figures
    ========================  ================================================================
    stopped lead (S7.2)       SV 10-80 km/h without manual braking, 70-100 km/h with it
    slower lead (S7.3)        POV 20 km/h; SV 40-80 km/h without, 70-100 km/h with manual
                              braking
    decelerating lead (S7.4)  SV and POV at 50 or 80 km/h, headway 12-40 m, the POV braking at
                              0.3-0.5 g, reached within 1.5 s
    lead tests (S7.1)         SV speed ±1.6 km/h; the trial starts (L0) at a TTC of 5 s; manual
                              braking 1.0 ± 0.1 s after the FCW onset at a mean 0.4 g
    trench plate (S9.2)       ASTM A36 steel, 2.4 m × 3.7 m × 25 mm, flat in the SV's lane; the
                              SV drives over it at 80 km/h
    pass-through (S9.3)       two POVs side by side in the adjacent lanes, 4.5 ± 0.1 m between
                              their inner sides; the SV drives between them at 80 km/h
    ========================  ================================================================

    Assumptions: the plate's 3.7 m side lies along the SV's path, centred in the lane; the
    pass-through POVs' rears are level; a false-activation trial starts like a lead trial (a
    TTC of 5 s to the plate's near edge or the POVs' rears) and has no manual braking; the
    decelerating POV's ramp takes :data:`POV_DECEL_RISE` = 1 s; every trial has a run-in of
    :data:`RUN_IN` = 3 s at the test speed before L0 (so that the sensors' tracks are confirmed
    by L0), and L0 of a decelerating-lead trial is the POV's brake onset after that run-in.

Euro NCAP Car-to-Car Rear (AEB C2C test protocol)
    :func:`procedure_scene` takes any SV and POV speed, headway, deceleration and overlap, so
    CCRs (stationary target), CCRm (target at 20 km/h) and CCRb (both at 50 km/h, the target
    braking at 2 or 6 m/s² 12 or 40 m ahead) run as well (their grid is not defined here).
    ``overlap`` is the fraction of the SV's width overlapping the POV, whose centre is offset by
    :math:`(1 - |o|)\,W`, :math:`W` = 1.8 m the SV's width; sign (assumption, Euro NCAP's
    figure was not readable here): a negative overlap puts the POV to the SV's **left**
    (``y > 0``), a positive one to its right.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.units import KMH, G
from acc_fusion.core.validation import check_choice, check_range
from acc_fusion.truth.manoeuvre_params import SETTLE_TIME, LVDParams, LVMParams, LVSParams
from acc_fusion.truth.objects import ObjectKind
from acc_fusion.truth.scenes import (
    EGO_WIDTH,
    FIELD_RANGE,
    SIGNATURES,
    Road,
    Scene,
    SceneSource,
    _actors,
    _guardrail,
    ramp_braking,
)

#: The kinds of test point.
KINDS = ("stopped", "slower", "decelerating", "plate", "pass_through")
#: Time to collision at which a lead-vehicle trial starts, L0 [s] (FMVSS 127 S7).
L0_TTC = 5.0
#: Run-in at the test speed before L0 [s] (assumption: the sensors' tracks are confirmed).
RUN_IN = 3.0
#: How long a run's SV stands still before the run ends [s].
REST_TIME = 1.0
#: Tolerance of the SV's test speed [m/s] (FMVSS 127: ±1.6 km/h).
SV_SPEED_TOLERANCE = 1.6 * KMH
#: Manual braking: onset after the FCW onset [s], its tolerance [s], mean deceleration [m/s²].
MANUAL_BRAKE_DELAY, MANUAL_BRAKE_DELAY_TOLERANCE, MANUAL_BRAKE_DECEL = 1.0, 0.1, 0.4 * G
#: Longest rise of the decelerating POV's deceleration FMVSS 127 allows, and the helpers'
#: (assumption: a brake robot, well within it) [s].
POV_DECEL_RISE_MAX, POV_DECEL_RISE = 1.5, 1.0
#: SV test speeds [m/s] (lo, hi) of the stopped-lead tests without and with manual braking.
STOPPED_SPEEDS, STOPPED_MANUAL_SPEEDS = (10 * KMH, 80 * KMH), (70 * KMH, 100 * KMH)
#: SV test speeds [m/s] (lo, hi) of the slower-lead tests without and with manual braking.
SLOWER_SPEEDS, SLOWER_MANUAL_SPEEDS = (40 * KMH, 80 * KMH), (70 * KMH, 100 * KMH)
#: Speed of the slower-moving POV [m/s] (20 km/h).
SLOWER_POV_SPEED = 20 * KMH
#: Speeds of SV and POV [m/s], headways [m], POV decelerations [m/s²] of the decelerating-lead
#: tests (the ranges' ends).
DECEL_SPEEDS, DECEL_HEADWAYS, DECEL_DECELS = (50 * KMH, 80 * KMH), (12.0, 40.0), (0.3 * G, 0.5 * G)
#: SV speed of the false-activation tests [m/s] (80 km/h).
FALSE_ACTIVATION_SPEED = 80 * KMH
#: Length (along the road), width and thickness of the steel trench plate [m].
PLATE_LENGTH, PLATE_WIDTH, PLATE_THICKNESS = SIGNATURES[ObjectKind.PLATE][:3]
#: Length and width of a POV and of the SV [m] (a vehicle's).
POV_LENGTH, POV_WIDTH = SIGNATURES[ObjectKind.VEHICLE][:2]
#: Distance between the inner sides of the pass-through POVs [m] (FMVSS 127: 4.5 ± 0.1 m).
PASS_THROUGH_SPACING = 4.5
#: Lateral offset of the pass-through POVs' centres from the SV's lane centre [m].
PASS_THROUGH_OFFSET = PASS_THROUGH_SPACING / 2 + POV_WIDTH / 2
#: Time a lead trial's default duration leaves after the no-braking contact [s]: an SV braking
#: from within a TTC of :data:`L0_TTC` stops within that TTC after it, then stands still.
SETTLE = L0_TTC + REST_TIME
_SPEED, _TIME = 60.0, 600.0  # highest speed [m/s] and longest time [s] accepted


@dataclass(frozen=True)
class TestPoint:
    """One trial of a test-track procedure (validated on construction; SI units).

    Attributes:
        sv_speed: the SV's test speed [m/s], ``> 0``.
        pov_speed: the POV's initial speed [m/s]; 0 for a stopped POV, the plate and the
            pass-through POVs.
        gap: initial distance [m] from the SV's front bumper to the POV's rear (bumper to
            bumper), the plate's near edge or the pass-through POVs' rears; ``> 0``.
        pov_decel: the POV's deceleration [m/s², positive]; ``> 0`` only if ``"decelerating"``.
        pov_brake_time: when the POV starts braking [s]; ``inf``: never.
        pov_decel_rise: time over which the POV's deceleration rises linearly from 0 to
            ``pov_decel`` [s], in [0, 5] (FMVSS 127: within 1.5 s); 0: a step.
        overlap: the fraction of the SV's width overlapping the POV, in [-1, 1] (1.0: 100 %;
            negative: the POV to the left, module docstring); the plate is offset alike; 1
            for ``"pass_through"``.
        kind: one of :data:`KINDS`.
        duration: the trial's duration [s]; ``None``: until the SV at its test speed reaches
            the POV, plus :data:`SETTLE` (a lead trial), or has passed the plate or the
            pass-through POVs, plus 1 s.
        manual_brake: a trial with manual braking (FMVSS 127: 1.0 ± 0.1 s after the FCW onset,
            0.4 g); the test runner brakes, not the scene.
        label: a name for reports, e.g. ``"FMVSS 127 S7.2 stopped 40 km/h"``.
    """

    __test__ = False  # not a pytest test class despite its name

    sv_speed: float
    pov_speed: float
    gap: float
    pov_decel: float = 0.0
    pov_brake_time: float = math.inf
    pov_decel_rise: float = 0.0
    overlap: float = 1.0
    kind: str = "stopped"
    duration: float | None = None
    manual_brake: bool = False
    label: str = ""

    def __post_init__(self) -> None:
        kind = check_choice("kind", self.kind, KINDS)
        sv = check_range("sv_speed", self.sv_speed, 0.0, _SPEED, lo_open=True)
        pov = check_range("pov_speed", self.pov_speed, 0.0, _SPEED)
        check_range("gap", self.gap, 0.0, 5000.0, lo_open=True)
        decel = check_range("pov_decel", self.pov_decel, 0.0, 1.5 * G)
        brake = check_range("pov_brake_time", self.pov_brake_time, 0.0)
        check_range("pov_decel_rise", self.pov_decel_rise, 0.0, 5.0)
        check_range("overlap", self.overlap, -1.0, 1.0)
        if not isinstance(self.manual_brake, bool) or not isinstance(self.label, str):
            raise ConfigError("manual_brake must be true or false and label a string")
        if kind in ("stopped", "plate", "pass_through") and pov > 0.0:
            raise ConfigError(f"pov_speed must be 0 for a {kind} point, got {self.pov_speed!r}")
        if kind == "slower" and not 0.0 < pov < sv:
            raise ConfigError(f"pov_speed of a slower point must be in (0, sv_speed = {sv:g}) "
                              f"m/s, got {self.pov_speed!r}")  # fmt: skip
        if kind == "decelerating" and (pov <= 0.0 or decel <= 0.0 or not math.isfinite(brake)):
            raise ConfigError(
                "a decelerating point needs pov_speed > 0, pov_decel > 0 and a finite "
                f"pov_brake_time, got {pov:g} m/s, {decel:g} m/s² and {brake:g} s"
            )
        if kind != "decelerating" and decel > 0.0:
            raise ConfigError(f"pov_decel must be 0 for a {kind} point, got {self.pov_decel!r}")
        if kind == "pass_through" and self.overlap != 1.0:
            raise ConfigError(f"overlap must be 1 for a pass_through point, got {self.overlap!r}")
        if self.duration is None:
            object.__setattr__(self, "duration", self._default_duration())
        else:
            check_range("duration", self.duration, 0.0, _TIME, lo_open=True)

    def _default_duration(self) -> float:
        """The duration when none is given (class docstring)."""
        sv = float(self.sv_speed)
        if self.kind in ("plate", "pass_through"):
            length = PLATE_LENGTH if self.kind == "plate" else POV_LENGTH
            return (self.gap + length + POV_LENGTH) / sv + REST_TIME
        if self.kind == "decelerating":
            x_stop, _, _, t_stop = (float(x) for x in ramp_braking(
                self.pov_speed, self.pov_decel, self.pov_decel_rise, np.inf))  # fmt: skip
            t_b = float(self.pov_brake_time)
            reach = (self.gap + self.pov_speed * t_b + x_stop) / sv
            return max(reach, t_b + t_stop) + SETTLE
        return self.gap / (sv - self.pov_speed) + SETTLE

    @property
    def lateral_offset(self) -> float:
        """The POV's (or the plate's) centre offset from the SV's lane centre [m], left
        positive (module docstring); 0 for ``"pass_through"`` (its POVs are at
        ±:data:`PASS_THROUGH_OFFSET`)."""
        if self.kind == "pass_through":
            return 0.0
        offset = (1.0 - abs(self.overlap)) * EGO_WIDTH
        return offset if self.overlap < 0 else -offset

    @property
    def l0_time(self) -> float:
        """When the trial proper starts, L0 [s]: the POV's brake onset if ``"decelerating"``,
        else when the SV at its test speed is :data:`L0_TTC` from the POV (the plate, the
        pass-through POVs); negative if the point starts closer."""
        if self.kind == "decelerating":
            return float(self.pov_brake_time)
        closing = self.sv_speed - self.pov_speed
        return (self.gap - L0_TTC * closing) / closing


def start_gap(sv_speed: float, pov_speed: float = 0.0, *, run_in: float = RUN_IN) -> float:
    """The initial gap [m] at which an SV at ``sv_speed`` closing on a POV at constant
    ``pov_speed`` reaches a TTC of :data:`L0_TTC` (L0) after ``run_in`` [s]."""
    sv = check_range("sv_speed", sv_speed, 0.0, _SPEED, lo_open=True)
    pov = check_range("pov_speed", pov_speed, 0.0, _SPEED)
    if pov >= sv:
        raise ConfigError(f"pov_speed ({pov:g} m/s) must be below sv_speed ({sv:g} m/s)")
    return (L0_TTC + check_range("run_in", run_in, 0.0, _TIME)) * (sv - pov)


def stopped_lead(
    sv_speed: float, *, overlap: float = 1.0, manual_brake: bool = False, run_in: float = RUN_IN
) -> TestPoint:
    """A stopped-lead trial (FMVSS 127 S7.2; Euro NCAP CCRs): the SV at ``sv_speed`` starts
    :data:`L0_TTC` + ``run_in`` seconds from a stopped POV."""
    label = f"stopped {sv_speed / KMH:.0f} km/h{' manual' if manual_brake else ''}"
    return TestPoint(sv_speed, 0.0, start_gap(sv_speed, run_in=run_in), overlap=overlap,
                     kind="stopped", manual_brake=manual_brake, label=label)  # fmt: skip


def slower_lead(
    sv_speed: float,
    pov_speed: float = SLOWER_POV_SPEED,
    *,
    overlap: float = 1.0,
    manual_brake: bool = False,
    run_in: float = RUN_IN,
) -> TestPoint:
    """A slower-lead trial (FMVSS 127 S7.3, POV at 20 km/h; Euro NCAP CCRm): the SV at
    ``sv_speed`` starts :data:`L0_TTC` + ``run_in`` seconds (closing) from the POV."""
    label = (f"slower {sv_speed / KMH:.0f} km/h to {pov_speed / KMH:.0f} km/h"
             f"{' manual' if manual_brake else ''}")  # fmt: skip
    return TestPoint(sv_speed, pov_speed, start_gap(sv_speed, pov_speed, run_in=run_in),
                     overlap=overlap, kind="slower", manual_brake=manual_brake,
                     label=label)  # fmt: skip


def decelerating_lead(
    speed: float,
    headway: float,
    decel: float,
    *,
    pov_speed: float | None = None,
    rise: float = POV_DECEL_RISE,
    overlap: float = 1.0,
    manual_brake: bool = False,
    run_in: float = RUN_IN,
) -> TestPoint:
    """A decelerating-lead trial (FMVSS 127 S7.4; Euro NCAP CCRb): SV and POV at ``speed``
    (the POV at ``pov_speed`` if given), ``headway`` [m] apart bumper to bumper; after
    ``run_in`` [s] (L0) the POV brakes to a stop at ``decel`` [m/s²], reached over ``rise``."""
    label = (f"decelerating {speed / KMH:.0f} km/h {headway:g} m {decel / G:.2g} g"
             f"{' manual' if manual_brake else ''}")  # fmt: skip
    return TestPoint(speed, speed if pov_speed is None else pov_speed, headway, pov_decel=decel,
                     pov_brake_time=run_in, pov_decel_rise=rise, overlap=overlap,
                     kind="decelerating", manual_brake=manual_brake, label=label)  # fmt: skip


def plate_point(sv_speed: float = FALSE_ACTIVATION_SPEED, *, run_in: float = RUN_IN) -> TestPoint:
    """A steel-trench-plate false-activation trial (FMVSS 127 S9.2): the plate flat, centred
    in the SV's lane, :data:`L0_TTC` + ``run_in`` seconds ahead of the SV."""
    return TestPoint(sv_speed, 0.0, start_gap(sv_speed, run_in=run_in), kind="plate",
                     label=f"plate {sv_speed / KMH:.0f} km/h")  # fmt: skip


def pass_through_point(
    sv_speed: float = FALSE_ACTIVATION_SPEED, *, run_in: float = RUN_IN
) -> TestPoint:
    """A pass-through false-activation trial (FMVSS 127 S9.3): two POVs parked side by side in
    the adjacent lanes, :data:`PASS_THROUGH_SPACING` between their inner sides, their rears
    :data:`L0_TTC` + ``run_in`` seconds ahead of the SV."""
    return TestPoint(sv_speed, 0.0, start_gap(sv_speed, run_in=run_in), kind="pass_through",
                     label=f"pass-through {sv_speed / KMH:.0f} km/h")  # fmt: skip


def fmvss127_points(
    *,
    speed_step: float = 10 * KMH,
    headways: Sequence[float] = DECEL_HEADWAYS,
    decels: Sequence[float] = DECEL_DECELS,
    rise: float = POV_DECEL_RISE,
    run_in: float = RUN_IN,
) -> list[TestPoint]:
    """The FMVSS 127 test matrix (module docstring), labelled by test: stopped lead at 10-80
    km/h without and 70-100 km/h with manual braking, slower lead (20 km/h) at 40-80 and
    70-100 km/h, every ``speed_step`` [m/s]; decelerating lead at 50 and 80 km/h for every
    ``headways`` × ``decels`` (default the ranges' corners), with and without manual braking
    (assumption: the table allows both); the plate and pass-through trials at 80 km/h."""
    step = check_range("speed_step", speed_step, 0.0, 100 * KMH, lo_open=True)
    points: list[TestPoint] = []
    for make, section, ranges in (
        (stopped_lead, "S7.2", (STOPPED_SPEEDS, STOPPED_MANUAL_SPEEDS)),
        (slower_lead, "S7.3", (SLOWER_SPEEDS, SLOWER_MANUAL_SPEEDS)),
    ):
        for manual, (lo, hi) in zip((False, True), ranges, strict=True):
            for v in lo + step * np.arange(int(round((hi - lo) / step)) + 1):
                points.append(
                    _labelled(make(float(v), manual_brake=manual, run_in=run_in), section)
                )
    for manual in (False, True):
        for v in DECEL_SPEEDS:
            for headway in headways:
                for decel in decels:
                    p = decelerating_lead(v, float(headway), float(decel), rise=rise,
                                          manual_brake=manual, run_in=run_in)  # fmt: skip
                    points.append(_labelled(p, "S7.4"))
    points.append(_labelled(plate_point(run_in=run_in), "S9.2"))
    points.append(_labelled(pass_through_point(run_in=run_in), "S9.3"))
    return points


def nhtsa_fcw_points() -> list[TestPoint]:
    """NHTSA's FCW confirmation tests (February 2013; :mod:`acc_fusion.truth.manoeuvres`) as
    test points with the 1-D manoeuvres' defaults and durations: test 1, a stopped lead (LVS,
    :class:`~acc_fusion.truth.manoeuvre_params.LVSParams`); test 2, a lead braking with a step
    to its deceleration (LVD, no ramp); test 3, a slower lead (LVM); no manual braking."""
    lvs, lvd, lvm = LVSParams(), LVDParams(), LVMParams()
    v, decel, brake = float(lvd.speed), float(lvd.pov_decel), float(lvd.brake_time)
    closing = float(lvm.sv_speed) - float(lvm.pov_speed)
    return [
        TestPoint(float(lvs.sv_speed), 0.0, float(lvs.initial_ttc * lvs.sv_speed),
                  duration=float(lvs.initial_ttc) + SETTLE_TIME,
                  label=f"NHTSA FCW test 1 LVS {lvs.sv_speed / KMH:.0f} km/h"),
        TestPoint(v, v, float(lvd.headway), pov_decel=decel, pov_brake_time=brake,
                  kind="decelerating", duration=brake + v / decel + SETTLE_TIME,
                  label=f"NHTSA FCW test 2 LVD {v / KMH:.0f} km/h {lvd.headway:g} m "
                  f"{decel / G:.2g} g"),
        TestPoint(float(lvm.sv_speed), float(lvm.pov_speed), float(lvm.initial_ttc) * closing,
                  kind="slower", duration=float(lvm.initial_ttc) + SETTLE_TIME,
                  label=f"NHTSA FCW test 3 LVM {lvm.sv_speed / KMH:.0f} km/h to "
                  f"{lvm.pov_speed / KMH:.0f} km/h"),
    ]  # fmt: skip


def _labelled(point: TestPoint, section: str) -> TestPoint:
    return replace(point, label=f"FMVSS 127 {section} {point.label}")


def _check_points(points: Sequence[TestPoint]) -> tuple[TestPoint, ...]:
    if isinstance(points, (str, TestPoint)) or not isinstance(points, Sequence) or not points:
        raise ConfigError("points must be a non-empty sequence of TestPoint")
    if not all(isinstance(p, TestPoint) for p in points):
        raise ConfigError("points must hold TestPoint only")
    return tuple(points)


def procedure_scene(points: Sequence[TestPoint]) -> Scene:
    """One :class:`~acc_fusion.truth.scenes.Scene` whose run ``i`` is ``points[i]`` (module
    docstring; its ``duration`` the longest point's).  Actor slot 0 is each run's POV (or the
    plate, or the left pass-through POV), slot 1 the right pass-through POV (absent in the
    other runs; only if some point is a pass-through one), then the guardrail posts."""
    pts = _check_points(points)
    n = len(pts)

    def column(name: str) -> np.ndarray:
        return np.array([float(getattr(p, name)) for p in pts])

    kind = np.array([p.kind for p in pts])
    sv, pov, gap, duration = (column(k) for k in ("sv_speed", "pov_speed", "gap", "duration"))
    plate, through = kind == "plate", kind == "pass_through"
    offset = np.array([p.lateral_offset for p in pts])
    primary = {
        "kind": np.where(plate, int(ObjectKind.PLATE), int(ObjectKind.VEHICLE)),
        "s0": gap + np.where(plate, PLATE_LENGTH, POV_LENGTH) / 2,
        "v0": pov,
        "d0": np.where(through, PASS_THROUGH_OFFSET, offset),
        "brake_time": column("pov_brake_time"),
        "brake_decel": column("pov_decel"),
        "brake_rise": column("pov_decel_rise"),
    }
    specs: list[dict[str, object]] = [primary]
    if through.any():
        specs.append({"kind": int(ObjectKind.VEHICLE), "s0": gap + POV_LENGTH / 2,
                      "d0": -PASS_THROUGH_OFFSET, "present": through})  # fmt: skip
    reach = float(np.max((sv + pov) * duration + gap))
    road = Road(length=max(Road().length, reach + FIELD_RANGE + 200.0))
    actors = _actors(n, [*specs, *_guardrail(n, road)])
    return Scene("procedure", road, actors, sv, sv.copy(), np.full(n, 1.5),
                 float(duration.max()), ego_model="cruise", lead_rule="overlap")  # fmt: skip


class TrackSource(SceneSource):
    """A test-track scene as a truth source stepped by ``dt`` [s], with the interface of
    :class:`~acc_fusion.truth.scenes.SceneSource` (``frame()``, ``advance(ego_brake)``,
    ``active``, ``collided``, ``collision_speed``, ``t``, ``done``, ``n_steps``); its runs end
    one by one (module docstring), run ``i`` at ``run_duration[i]`` [s] at the latest (a
    scalar: every run's).  The scene of test points (:class:`ProcedureSource`) or of a scenario
    file (:func:`acc_fusion.truth.openscenario.read.read_scenario`)."""

    def __init__(self, scene: Scene, run_duration: float | np.ndarray, dt: float = 0.05) -> None:
        self.config = None
        self._setup(scene, check_range("dt", dt, 0.0, 1.0, lo_open=True))
        n = scene.ego_speed.shape[0]
        self.run_duration = np.broadcast_to(np.asarray(run_duration, dtype=float), (n,)).copy()
        self._rest = np.zeros(n)  # how long each SV has stood still [s]

    def advance(self, ego_brake: np.ndarray | None = None) -> None:
        """One step of the running SVs (at constant speed, or braking at ``ego_brake (N,)``
        [m/s²] where it is positive; :meth:`SceneSource.advance`); then contacts and run ends
        (module docstring)."""
        dt, act, run = self.dt, self.scene.actors, self.active.copy()
        t0 = self.t if run.all() else np.minimum(self.t, self._end_t)[:, None]
        s, v, _, d, _ = act.centre(t0)
        lead, gap = self._lead(s, d, act.kind)
        has = lead >= 0
        v_lead = np.where(has, v[np.arange(len(lead)), np.maximum(lead, 0)], self._v)
        v_new = np.maximum(self._v + self._accel(gap, v_lead, has, ego_brake) * dt, 0.0)
        s_old = self._s
        self._a = np.where(run, (v_new - self._v) / dt, 0.0)
        self._v = np.where(run, v_new, self._v)
        self._s = np.where(run, self._s + self._v * dt, self._s)
        self.t += dt
        # contact: bodies overlapping laterally, the SV's front past the rear within the step
        length, width = self._sig[..., 0], self._sig[..., 1]
        s1, v1, _, d1, _ = act.centre(np.where(run, self.t, self._end_t)[:, None])
        beside = np.abs(d1) >= (width + EGO_WIDTH) / 2
        body = (act.kind == ObjectKind.VEHICLE) & self._present & ~beside & run[:, None]
        before = s_old[:, None] - (s - length / 2)
        touch = body & (self._s[:, None] >= s1 - length / 2) & (before <= length + POV_LENGTH)
        hit = touch.any(axis=1)
        if hit.any():
            r = np.flatnonzero(hit)
            k = np.argmax(np.where(touch, before, -np.inf), axis=1)[r]  # the nearest
            self._collision_speed[r] = self._v[r] - v1[r, k]
            self._s[r] = s1[r, k] - length[r, k] / 2  # the SV at its rear
            self.collided[r] = True
        self._rest = np.where(run & (self._v <= 0.0), self._rest + dt, 0.0)
        over = (self.t >= self.run_duration - 1e-9) | (self._rest >= REST_TIME - 1e-9)
        ended = run & (hit | over)
        self._end_t = np.where(ended, self.t, self._end_t)
        self._a = np.where(ended, 0.0, self._a)
        self.active = run & ~ended


class ProcedureSource(TrackSource):
    """The truth source of test points (:func:`procedure_scene`), a :class:`TrackSource`.

    Attributes:
        points: the test points, run ``i`` is ``points[i]``.
        run_duration: ``(N,)`` each run's duration [s].
        l0_time: ``(N,)`` each run's L0 [s] (:attr:`TestPoint.l0_time`).
        manual_brake: ``(N,)`` the runs whose trial has manual braking.
    """

    def __init__(self, points: Sequence[TestPoint], dt: float = 0.05) -> None:
        self.points = _check_points(points)
        durations = np.array([p.duration for p in self.points], dtype=float)
        super().__init__(procedure_scene(self.points), durations, dt)
        self.l0_time = np.array([p.l0_time for p in self.points])
        self.manual_brake = np.array([p.manual_brake for p in self.points])
