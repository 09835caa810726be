r"""Test points (:class:`~acc_fusion.truth.procedures.TestPoint`) written as ASAM OpenSCENARIO
XML 1.3 files, one per point, with the OpenDRIVE 1.8 test track they drive on (:mod:`.road`).

Each file (:func:`scenario_tree`) declares the point's figures as ``ParameterDeclarations``
(SI units) and uses them in its storyboard: ``$SubjectSpeed``, ``$PovSpeed``, ``$Gap``,
``$Overlap``, ``$PovDeceleration``, ``$PovDecelerationRise``, ``$PovBrakeTime``, ``$Duration``
(those the point's kind has).  Entities: the subject vehicle :data:`EGO` (the name the reader
knows it by), the POV ``Pov`` (a ``Vehicle``), the steel trench plate ``Plate`` (a
``MiscObject`` of category ``obstacle``) or the pass-through POVs ``PovLeft`` and
``PovRight``, each with the bounding box of the 2-D world's signature
(:data:`~acc_fusion.truth.scenes.SIGNATURES`) centred on its reference point
(``BoundingBox/Center`` x = y = 0: the reference point is the footprint's centre, an
assumption the reader undoes for any centre).  The SV's front bumper starts at
:math:`s` = :data:`START_S` on the track's middle lane (``LanePosition``), the POV's rear
``$Gap`` ahead, laterally ``(1 - |overlap|)`` SV widths off-centre
(``${($Overlap - 1) * 1.8}`` to the right, ``${($Overlap + 1) * 1.8}`` to the left).

Manoeuvre (the decelerating POV; the schema's ``TransitionDynamics``, ``SpeedProfileAction``,
``DynamicConstraints`` and ``SimulationTimeCondition``):
an event started by ``SimulationTimeCondition`` ``$PovBrakeTime`` (the procedure's run-in
ends, L0).  A step to the deceleration (``pov_decel_rise`` = 0, NHTSA's LVD) is an
``AbsoluteTargetSpeed`` 0 with ``linear`` dynamics at the ``rate`` ``$PovDeceleration``:
exact.  The ramped braking of FMVSS 127 and Euro NCAP (the deceleration rising linearly over
``$PovDecelerationRise``, :func:`~acc_fusion.truth.scenes.ramp_braking`) has no
``DynamicsShape``: speed is quadratic in time while the deceleration rises, which neither
``linear``, ``cubic`` nor ``sinusoidal`` is.  It is written as a ``SpeedProfileAction`` to
standstill (one ``SpeedProfileEntry`` of speed 0, ``followingMode="follow"``) whose
``DynamicConstraints`` are ``maxDeceleration`` = ``$PovDeceleration`` and
``maxDecelerationRate`` = ``$PovDeceleration / $PovDecelerationRise`` (the jerk): braking as
hard as the constraints allow, its deceleration rising at the jerk limit, then held to the
stop.  This reading is ours (assumption): the standard leaves how a controller follows the
constraints to the simulator, and one that also limits the jerk when the car comes to rest
would differ over the last :math:`D/J` seconds of the stop.  The storyboard stops at
``SimulationTimeCondition`` ``$Duration``.
"""

from __future__ import annotations

import re
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.truth.manoeuvre_params import LANE_WIDTH
from acc_fusion.truth.objects import ObjectKind
from acc_fusion.truth.openscenario.road import EGO_LANE, scenariogeneration, write_track
from acc_fusion.truth.procedures import PASS_THROUGH_OFFSET, TestPoint, procedure_scene
from acc_fusion.truth.scenes import EGO_WIDTH, SIGNATURES

#: The subject vehicle's name in the files.
EGO = "Ego"
#: The road file the scenarios reference (relative to them).
TRACK_FILE = "test_track.xodr"
#: Where the SV's front bumper starts, along the track [m] (the track starts 100 m behind it,
#: as the 2-D world's roads do).
START_S = 100.0
#: The OpenSCENARIO XML minor version written (1.3).
OSC_MINOR = 3
_AUTHOR = "acc_fusion"
#: The trench plate's mass [kg]: 3.7 m × 2.4 m × 25 mm of steel at 7850 kg/m³ (ASTM A36).
PLATE_MASS = 7850.0 * float(np.prod(SIGNATURES[ObjectKind.PLATE][:3]))


def file_stem(label: str) -> str:
    """A point's file name (without suffix) from its label: lower case, ``km/h`` as ``kmh``,
    ``%`` as ``pct``, a minus sign as ``m``, every other run of non-alphanumerics one ``_``."""
    text = label.lower().replace("km/h", "kmh").replace("m/s²", "ms2").replace("%", "pct")
    return re.sub(r"[^a-z0-9]+", "_", re.sub(r"-(?=\d)", "m", text)).strip("_")


def _parameters(point: TestPoint) -> dict[str, float]:
    """The point's figures by parameter name (module docstring), SI units."""
    params = {"SubjectSpeed": point.sv_speed, "Gap": point.gap}
    if point.kind in ("stopped", "slower", "decelerating"):
        params["PovSpeed"] = point.pov_speed
    if point.kind != "pass_through":
        params["Overlap"] = point.overlap
    if point.kind == "decelerating":
        params["PovDeceleration"] = point.pov_decel
        if point.pov_decel_rise > 0.0:
            params["PovDecelerationRise"] = point.pov_decel_rise
        params["PovBrakeTime"] = point.pov_brake_time
    params["Duration"] = float(point.duration)
    return params


def _box(xosc, kind: ObjectKind):
    length, width, height = SIGNATURES[kind][:3]
    return xosc.BoundingBox(width, length, height, 0.0, 0.0, height / 2)


def _vehicle(xosc, name: str):
    """A car of the 2-D world's size (axles and performance: assumptions, the world has
    none)."""
    length = SIGNATURES[ObjectKind.VEHICLE][0]
    front = xosc.Axle(0.5, 0.65, 1.55, length / 2 - 0.9, 0.325)
    rear = xosc.Axle(0.0, 0.65, 1.55, -length / 2 + 0.9, 0.325)
    return xosc.Vehicle(name, xosc.VehicleCategory.car, _box(xosc, ObjectKind.VEHICLE),
                        front, rear, 60.0, 10.0, 12.0)  # fmt: skip


def scenario_tree(point: TestPoint, road_file: str = TRACK_FILE):
    """The OpenSCENARIO document of ``point`` (a ``scenariogeneration`` Scenario)."""
    xodr, xosc = scenariogeneration()
    params = _parameters(point)
    declarations = xosc.ParameterDeclarations()
    for name, value in params.items():
        declarations.add_parameter(xosc.Parameter(name, xosc.ParameterType.double, repr(value)))
    step = xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0.0)
    entities, init = xosc.Entities(), xosc.Init()
    half = SIGNATURES[ObjectKind.VEHICLE][0] / 2

    def place(name, obj, s, offset, lane=EGO_LANE, speed=None):
        entities.add_scenario_object(name, obj)
        init.add_init_action(name, xosc.TeleportAction(xosc.LanePosition(s, offset, lane, 1)))
        if speed is not None:
            init.add_init_action(name, xosc.AbsoluteSpeedAction(speed, step))

    place(EGO, _vehicle(xosc, EGO), START_S - half, 0.0, speed="$SubjectSpeed")
    side = "-" if point.overlap >= 0 else "+"
    offset = f"${{($Overlap {side} 1) * {EGO_WIDTH!r}}}"
    if point.kind == "plate":
        plate = xosc.MiscObject("Plate", PLATE_MASS, xosc.MiscObjectCategory.obstacle,
                                _box(xosc, ObjectKind.PLATE))  # fmt: skip
        place("Plate", plate, f"${{$Gap + {START_S + SIGNATURES[ObjectKind.PLATE][0] / 2!r}}}",
              offset)  # fmt: skip
        actors = ["Plate"]
    elif point.kind == "pass_through":
        s = f"${{$Gap + {START_S + half!r}}}"
        off = PASS_THROUGH_OFFSET - LANE_WIDTH  # from the adjacent lanes' centres
        place("PovLeft", _vehicle(xosc, "PovLeft"), s, off, EGO_LANE + 1, speed=0.0)
        place("PovRight", _vehicle(xosc, "PovRight"), s, -off, EGO_LANE - 1, speed=0.0)
        actors = ["PovLeft", "PovRight"]
    else:
        place("Pov", _vehicle(xosc, "Pov"), f"${{$Gap + {START_S + half!r}}}", offset,
              speed="$PovSpeed")  # fmt: skip
        actors = ["Pov"]
    group = xosc.ManeuverGroup("TestObjects")
    for name in actors:
        group.add_actor(name)
    if point.kind == "decelerating":
        group.add_maneuver(_braking(xosc, point.pov_decel_rise > 0.0))
    begin = xosc.SimulationTimeCondition(0, xosc.Rule.greaterOrEqual)
    start = xosc.ValueTrigger("Start", 0, xosc.ConditionEdge.none, begin)
    act = xosc.Act("Trial", start)
    act.add_maneuver_group(group)
    story = xosc.Story("Procedure")
    story.add_act(act)
    stop = xosc.ValueTrigger("End", 0, xosc.ConditionEdge.none,
                             xosc.SimulationTimeCondition("$Duration", xosc.Rule.greaterOrEqual),
                             "stop")  # fmt: skip
    board = xosc.StoryBoard(init, stop)
    board.add_story(story)
    return xosc.Scenario(point.label or "test point", _AUTHOR, declarations, entities, board,
                         xosc.RoadNetwork(roadfile=road_file), xosc.Catalog(),
                         osc_minor_version=OSC_MINOR)  # fmt: skip


def _braking(xosc, ramped: bool):
    """The POV's braking manoeuvre (module docstring)."""
    if ramped:
        limits = xosc.DynamicsConstraints(
            max_deceleration="$PovDeceleration",
            max_deceleration_rate="${$PovDeceleration / $PovDecelerationRise}",
        )
        action = xosc.SpeedProfileAction([0.0], xosc.FollowingMode.follow,
                                         dynamics_constraint=limits)  # fmt: skip
    else:
        rate = xosc.TransitionDynamics(xosc.DynamicsShapes.linear, xosc.DynamicsDimension.rate,
                                       "$PovDeceleration")  # fmt: skip
        action = xosc.AbsoluteSpeedAction(0.0, rate)
    event = xosc.Event("PovBrakes", xosc.Priority.override)
    event.add_action("BrakeToStandstill", action)
    event.add_trigger(xosc.ValueTrigger(
        "L0", 0, xosc.ConditionEdge.none,
        xosc.SimulationTimeCondition("$PovBrakeTime", xosc.Rule.greaterOrEqual)))  # fmt: skip
    maneuver = xosc.Maneuver("PovBraking")
    maneuver.add_event(event)
    return maneuver


@dataclass(frozen=True)
class Written:
    """What :func:`write_points` wrote: the folder, the scenario files (in the points' order),
    the road file, and what the ``check`` given returned (``None``: none given)."""

    folder: Path
    scenarios: tuple[Path, ...]
    road: Path
    check: object = None


def write_points(points: Sequence[TestPoint], folder: Path, check=None) -> Written:
    """Write one ``.xosc`` per point (:func:`file_stem` of its label) and the track they share
    (:data:`TRACK_FILE`, long enough for every point: the 2-D world's procedure road) into
    ``folder`` (made if missing).  All files are written into a temporary folder beside it
    first, and ``check``
    (a callable of that folder, e.g. :func:`acc_fusion.truth.openscenario.check.check_folder`)
    runs there, so nothing is half-written into ``folder`` on an error.  One ConfigError if two
    points' labels give the same name."""
    stems = [file_stem(p.label) for p in points]
    clash = sorted({s for s in stems if stems.count(s) > 1 or not s})
    if clash:
        raise ConfigError(f"test points need distinct, non-empty labels; {clash[0]!r} repeats")
    road_length = procedure_scene(points).road.length + START_S
    folder = Path(folder)
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}-", dir=folder.parent))
    try:
        write_track(tmp / TRACK_FILE, road_length)
        for point, stem in zip(points, stems, strict=True):
            scenario_tree(point).write_xml(str(tmp / f"{stem}.xosc"))
        result = check(tmp) if check is not None else None
        folder.mkdir(exist_ok=True)
        for name in [TRACK_FILE, *(f"{s}.xosc" for s in stems)]:
            (tmp / name).replace(folder / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return Written(folder, tuple(folder / f"{s}.xosc" for s in stems), folder / TRACK_FILE, result)
