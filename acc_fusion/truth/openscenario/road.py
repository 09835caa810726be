r"""The OpenDRIVE road of the scenario files: written for the test track, read back into the
2-D world's :class:`~acc_fusion.truth.scenes.Road`.

ASAM OpenDRIVE 1.8: the reference line's coordinates :math:`s` along it and :math:`t` to its
left; the plan view's ``line`` and ``arc`` geometries; ``laneOffset``; lane ``width``.

The test track (:func:`write_track`) is one straight road of :data:`TRACK_LANES` lanes of
:data:`~acc_fusion.truth.manoeuvre_params.LANE_WIDTH`, all on the right of the reference line
(right-hand traffic, driven in :math:`+s`), shifted left by a ``laneOffset`` of 1.5 lanes so
that the middle lane, :data:`EGO_LANE`, is centred on the reference line: the 2-D world's
:math:`(s, d)` is OpenDRIVE's :math:`(s, t)` less the ego's start (assumption: three lanes, so
that the pass-through test's POVs stand in lanes of their own).

What :func:`read_road` accepts: one road, geometries ``line`` and ``arc`` (constant
curvature), a flat elevation profile, one constant ``laneOffset`` record at most, one lane
section of constant-width lanes.  The 2-D world's centreline is the ego's lane centre at
:math:`t_e`: a piece of curvature :math:`\kappa` becomes
:math:`\kappa / (1 - \kappa t_e)` and its length scales by :math:`1 - \kappa t_e`
(the parallel curve), exact for lines and arcs.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.truth.manoeuvre_params import LANE_WIDTH
from acc_fusion.truth.openscenario.document import INSTALL, number, parse_xml, refusal
from acc_fusion.truth.scenes import Road

#: Lanes of the test track, and the lane (OpenDRIVE id) the subject vehicle drives in.
TRACK_LANES, EGO_LANE = 3, -2
_XODR_FIELDS = ("a", "b", "c", "d")


def scenariogeneration():
    """The ``scenariogeneration`` package's ``xodr`` and ``xosc`` modules, or one ConfigError
    naming the install command."""
    try:
        from scenariogeneration import xodr, xosc
    except ImportError:
        raise ConfigError(f"writing scenario files needs scenariogeneration: {INSTALL}") from None
    return xodr, xosc


def write_track(path: Path, length: float) -> None:
    """Write the test track (module docstring), ``length`` [m] long, to ``path`` (.xodr)."""
    xodr, _ = scenariogeneration()
    plan = xodr.PlanView(0.0, 0.0, 0.0)
    plan.add_geometry(xodr.Line(length))
    centre = xodr.Lane()
    centre.add_roadmark(xodr.std_roadmark_solid())
    section = xodr.LaneSection(0, centre)
    for k in range(TRACK_LANES):
        lane = xodr.Lane(a=LANE_WIDTH)
        last = k == TRACK_LANES - 1
        lane.add_roadmark(xodr.std_roadmark_solid() if last else xodr.std_roadmark_broken())
        section.add_right_lane(lane)
    lanes = xodr.Lanes()
    lanes.add_lanesection(section)
    lanes.add_laneoffset(xodr.LaneOffset(0, (TRACK_LANES / 2) * LANE_WIDTH, 0, 0, 0))
    road = xodr.Road(1, plan, lanes)
    road.add_elevation(0, 0, 0, 0, 0)
    odr = xodr.OpenDrive("acc_fusion test track", revMinor=8)
    odr.add_road(road)
    odr.adjust_roads_and_lanes()
    odr.write_xml(str(path))


@dataclass(frozen=True)
class OpenDriveRoad:
    """The one road of an OpenDRIVE file, as far as the 2-D world uses it.

    Attributes:
        road_id: its ``id``.
        pieces: ``(s, x, y, hdg, length, curvature)`` of each geometry [m, m, m, rad, m, 1/m].
        lane_offset: the constant lane offset [m].
        widths: lane id -> width [m] (no 0).
    """

    road_id: str
    pieces: tuple[tuple[float, float, float, float, float, float], ...]
    lane_offset: float
    widths: dict[int, float]

    @property
    def length(self) -> float:
        """The road's length [m]."""
        s, *_, length, _ = self.pieces[-1]
        return s + length

    def lane_centre(self, lane: int, where: str) -> float:
        """:math:`t` [m] of lane ``lane``'s centre; one InputError (``where`` tells from where)
        if the road has no such lane."""
        if lane not in self.widths:
            raise InputError(f"{where}: road {self.road_id} has no lane {lane}")
        side = 1 if lane > 0 else -1
        inner = sum(self.widths[side * k] for k in range(1, abs(lane)))
        return self.lane_offset + side * (inner + self.widths[lane] / 2)

    def lane_at(self, t: float) -> int:
        """The id of the lane at lateral position ``t`` [m] (the outermost lane beyond)."""
        side = 1 if t >= self.lane_offset else -1
        edge, lane = self.lane_offset, 0
        while side * lane + side in self.widths:
            lane += side
            edge += side * self.widths[lane]
            if side * (t - edge) <= 0.0:
                break
        return lane

    def st(self, x: float, y: float) -> tuple[float, float]:
        """The road coordinates :math:`(s, t)` of the world point ``(x, y)``: its projection on
        the nearest piece."""
        best = (np.inf, 0.0, 0.0)
        for s0, x0, y0, hdg, length, k in self.pieces:
            dx, dy = x - x0, y - y0
            if k == 0.0:
                u = dx * np.cos(hdg) + dy * np.sin(hdg)
                t = -dx * np.sin(hdg) + dy * np.cos(hdg)
            else:  # the arc's centre is 1/k to the left of its start
                cx, cy = x0 - np.sin(hdg) / k, y0 + np.cos(hdg) / k
                ang = np.arctan2(y - cy, x - cx) - np.arctan2(y0 - cy, x0 - cx)
                ang = (ang + np.pi) % (2 * np.pi) - np.pi
                u, t = ang / k, 1.0 / k - np.sign(k) * np.hypot(x - cx, y - cy)
            off = max(-u, u - length, 0.0)
            if off + abs(t) < best[0]:
                best = (off + abs(t), s0 + u, t)
        return float(best[1]), float(best[2])

    def scene_s(self, s: float, t_ego: float) -> float:
        """The 2-D world's arc length along the ego lane's centre (at ``t_ego``) [m] of the
        reference line's ``s``, from the road's start (module docstring)."""
        total = 0.0
        for s0, *_, length, k in self.pieces:
            total += (1.0 - k * t_ego) * min(max(s - s0, 0.0), length)
        return total + max(s - self.length, 0.0)

    def scene_road(self, t_ego: float, zero: float) -> Road:
        """The 2-D world's road along the ego lane (``t_ego`` [m]), its arc length measured
        from ``zero`` (:meth:`scene_s` of the ego's front bumper) [m]."""
        curves, last = [], 0.0
        for s0, *_, k in self.pieces:
            if k != last:
                curves.append((self.scene_s(s0, t_ego) - zero, k / (1.0 - k * t_ego)))
                last = k
        return Road(curves=tuple(curves), length=self.scene_s(self.length, t_ego) - zero)


def read_road(path: Path) -> OpenDriveRoad:
    """Read the road of the OpenDRIVE file ``path`` (the subset of the module docstring); one
    InputError naming the file and the element (and its line) for anything else."""
    root = parse_xml(path, "road")
    roads = root.findall("road")
    if root.tag != "OpenDRIVE" or len(roads) != 1:
        raise InputError(f"{path.name}: the 2-D world reads an OpenDRIVE file of one road, "
                         f"found {len(roads)} <road> in <{root.tag}>")  # fmt: skip
    road = roads[0]

    def refuse(el, what: str) -> InputError:
        return refusal(path.name, el, what)

    def num(el, name: str) -> float:
        return number(el, name, path.name, 0.0)

    pieces = []
    for g in road.iterfind("planView/geometry"):
        shape = g[0] if len(g) else g
        if shape.tag not in ("line", "arc"):
            raise refuse(shape, "is outside the roads the 2-D world reads (line and arc)")
        k = num(shape, "curvature") if shape.tag == "arc" else 0.0
        pieces.append(tuple(num(g, a) for a in ("s", "x", "y", "hdg", "length")) + (k,))
    if not pieces:
        raise InputError(f"{path.name}: road {road.get('id')} has no planView geometry")
    for el in road.iterfind("elevationProfile/elevation"):
        if any(num(el, c) != 0.0 for c in _XODR_FIELDS):
            raise refuse(el, "is not flat; the 2-D world reads flat roads only")
    offsets = road.findall("lanes/laneOffset")
    if len(offsets) > 1 or any(num(o, c) != 0.0 for o in offsets for c in _XODR_FIELDS[1:]):
        raise refuse(offsets[-1], "varies along the road; the 2-D world reads a constant one")
    sections = road.findall("lanes/laneSection")
    if len(sections) != 1:
        raise InputError(f"{path.name}: road {road.get('id')} has {len(sections)} lane "
                         "sections; the 2-D world reads one")  # fmt: skip
    widths = {}
    for lane in sections[0].iterfind("*/lane"):
        if lane.get("id") == "0":
            continue
        w = lane.findall("width")
        if len(w) != 1 or any(num(w[0], c) != 0.0 for c in _XODR_FIELDS[1:]):
            raise refuse(lane, "has no constant width; the 2-D world reads constant widths")
        widths[int(lane.get("id"))] = num(w[0], "a")
    offset = num(offsets[0], "a") if offsets else 0.0
    return OpenDriveRoad(road.get("id", ""), tuple(pieces), offset, widths)
