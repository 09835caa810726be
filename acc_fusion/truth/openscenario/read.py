r"""Read an ASAM OpenSCENARIO XML 1.x file (and its OpenDRIVE road, :mod:`.road`) into a
scripted :class:`~acc_fusion.truth.scenes.Scene` of the 2-D world: the longitudinal and
lane-keeping subset this project simulates; anything else is refused with one
:class:`~acc_fusion.core.errors.InputError` naming the element and its line.

The subset (ASAM OpenSCENARIO XML 1.3, by the schema's element names)
    - parameters and arithmetic expressions (:mod:`.parameters`);
    - entities: the subject vehicle, a ``Vehicle`` named :data:`EGO`; other vehicles
      (``vehicleCategory`` car, van, truck, bus: the world's ``VEHICLE``) and ``MiscObject``
      of category ``obstacle`` (the world's flat ``PLATE``), ``gantry`` and ``railing``
      (a guardrail post); the world gives each its kind's signature
      (:data:`~acc_fusion.truth.scenes.SIGNATURES`: size, RCS, thermal contrast), the file's
      ``BoundingBox`` places its centre and measures the triggers' distances;
    - ``Init``: a ``TeleportAction`` to a ``WorldPosition``, ``LanePosition`` or
      ``RoadPosition`` on the road, and an ``AbsoluteTargetSpeed``; every entity is aligned
      with the road (a heading is not read);
    - the storyboard: stories, acts (a start trigger, no stop trigger), maneuver
      groups, maneuvers, events run once, whose actions act on every actor of the group:
      a ``SpeedAction`` (absolute or relative target; ``step``, ``linear``, ``cubic``,
      ``sinusoidal`` dynamics over a ``time``, a ``distance``, or for ``linear`` a
      ``rate``: :mod:`acc_fusion.truth.speed_changes`), the jerk-limited brake to standstill
      that :mod:`.export` writes as a ``SpeedProfileAction`` (its reading is stated there),
      one ``LaneChangeAction`` per entity (absolute or relative target lane, a target lane
      offset, ``sinusoidal`` over a ``time``: the world's cosine blend);
    - start triggers (:mod:`.triggers`) and a stop trigger at a simulation time (the
      scenario's duration).

The subject vehicle drives as the world's test driver (``ego_model = "cruise"``): at its
initial speed, braking only when a driver or AEB asks; actions on it are refused.  The 2-D
world's road is its lane's centre (:mod:`.road`); its arc length is measured from its front
bumper at the start, and every scene has the world's guardrail posts
(:data:`~acc_fusion.truth.scenes.GUARDRAIL_SPACING`).  The in-path lead is the vehicle whose body
overlaps the ego's laterally (``lead_rule = "overlap"``, as on the test track).  A speed
change must start after the entity's previous one has ended, and actions are read in the
file's order (assumptions: the 2-D world scripts motion as functions of time).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.truth.objects import ObjectKind
from acc_fusion.truth.openscenario.document import number, parse_xml, refusal
from acc_fusion.truth.openscenario.parameters import substitute
from acc_fusion.truth.openscenario.road import read_road
from acc_fusion.truth.openscenario.triggers import Conditions
from acc_fusion.truth.scenes import Scene, _actors, _guardrail
from acc_fusion.truth.speed_changes import SHAPES, SpeedChanges

#: The subject vehicle's name in a scenario file.
EGO = "Ego"
_VEHICLES = ("car", "van", "truck", "bus")
_MISC = {"obstacle": ObjectKind.PLATE, "gantry": ObjectKind.GANTRY,
         "railing": ObjectKind.GUARDRAIL}  # fmt: skip
_TOP = ("FileHeader", "ParameterDeclarations", "CatalogLocations", "RoadNetwork", "Entities",
        "Storyboard")  # fmt: skip


@dataclass
class _Entity:
    """An entity as read: kind (``None``: the ego), its bounding box (length, width, centre
    offset along it [m]), its start on the reference line (s, t [m]) and speed [m/s], and its
    script (speed changes, the ramped brake, the lane change)."""

    name: str
    kind: ObjectKind | None
    box: tuple[float, float, float]
    s: float = math.nan
    t: float = math.nan
    speed: float = 0.0
    changes: list[tuple[float, float, float, int]] = field(default_factory=list)
    brake: tuple[float, float, float] | None = None
    lane_change: tuple[float, float, float] | None = None


class _Reader:
    """One file read into a scene (module docstring)."""

    def __init__(self, path: Path) -> None:
        self.path, self.name = path, path.name
        root = parse_xml(path, "scenario")
        if root.tag != "OpenSCENARIO" or root.find("FileHeader") is None:
            raise InputError(f"{self.name} is not an OpenSCENARIO XML file (root <{root.tag}>)")
        header = root.find("FileHeader")
        if header.get("revMajor") != "1":
            raise self.refuse(header, "is not of OpenSCENARIO XML 1.x")
        self.only(root, _TOP)
        substitute(root, self.name)
        for el in root.iter("CatalogReference", "ParameterDeclarations"):
            if el.tag == "CatalogReference" or el.getparent() is not root:
                raise self.refuse(el, "is outside the subset the 2-D world reads (catalogues "
                                  "and parameters below the top level)")  # fmt: skip
        logic = root.find("RoadNetwork/LogicFile")
        if logic is None:
            raise InputError(f"{self.name}: the 2-D world needs a road (RoadNetwork/LogicFile)")
        self.road = read_road(path.parent / logic.get("filepath", ""))
        self.entities = self._entities(root.find("Entities"))
        board = root.find("Storyboard")
        self.only(board, ("Init", "Story", "StopTrigger"))
        self._init(board.find("Init"))
        ego = self.entities.get(EGO)
        if ego is None or ego.kind is not None or math.isnan(ego.s):
            raise InputError(f"{self.name}: the subject vehicle must be a Vehicle named "
                             f"{EGO!r} placed in Init")  # fmt: skip
        self.ego = ego
        self.zero = self.road.scene_s(ego.s, ego.t) + ego.box[2] + ego.box[0] / 2
        for e in self.entities.values():
            if math.isnan(e.s):
                raise InputError(f"{self.name}: entity {e.name!r} has no position in Init")
        self.duration = self._stop(board.find("StopTrigger"))
        boxes = {n: e.box for n, e in self.entities.items()}
        self.conditions = Conditions(self.name, self.state, boxes, self.point, self.duration)
        for story in board.iterfind("Story"):
            self._story(story)

    def refuse(self, el, what: str) -> InputError:
        """The one-sentence error for element ``el``."""
        return refusal(self.name, el, what)

    def only(self, el, allowed) -> None:
        """Refuse any child element of ``el`` not in ``allowed``."""
        for child in el:
            if isinstance(child.tag, str) and child.tag not in allowed:
                raise self.refuse(child, "is outside the subset the 2-D world reads")

    def num(self, el, attr: str, default: float | None = None) -> float:
        """Attribute ``attr`` of ``el`` as a number (:func:`.document.number`)."""
        return number(el, attr, self.name, default)

    def _entities(self, el) -> dict[str, _Entity]:
        self.only(el, ("ScenarioObject",))
        out = {}
        for obj in el.iterfind("ScenarioObject"):
            name = obj.get("name", "")
            self.only(obj, ("Vehicle", "MiscObject", "ObjectController"))
            body = obj.find("Vehicle")
            if body is not None:
                if body.get("vehicleCategory") not in _VEHICLES:
                    raise self.refuse(body, f"of category {body.get('vehicleCategory')!r} is "
                                      f"outside the subset ({', '.join(_VEHICLES)})")  # fmt: skip
                kind = None if name == EGO else ObjectKind.VEHICLE
            elif (body := obj.find("MiscObject")) is not None:
                if body.get("miscObjectCategory") not in _MISC:
                    raise self.refuse(body, f"of category {body.get('miscObjectCategory')!r} "
                                      f"is outside the subset ({', '.join(_MISC)})")  # fmt: skip
                kind = _MISC[body.get("miscObjectCategory")]
            else:
                raise self.refuse(obj, "has no Vehicle or MiscObject")
            box = body.find("BoundingBox")
            dims, centre = box.find("Dimensions"), box.find("Center")
            out[name] = _Entity(name, kind, (self.num(dims, "length"), self.num(dims, "width"),
                                             self.num(centre, "x")))  # fmt: skip
        return out

    def entity(self, el, name: str | None) -> _Entity:
        if name not in self.entities:
            raise self.refuse(el, f"refers to {name!r}, which is not an entity")
        return self.entities[name]

    def position(self, el) -> tuple[float, float]:
        """(s, t) on the reference line of a ``Position`` element."""
        pos = el[0] if el is not None and len(el) else el
        if pos is None or pos.tag not in ("WorldPosition", "LanePosition", "RoadPosition"):
            raise self.refuse(pos if pos is not None else el, "is outside the positions "
                              "read (WorldPosition, LanePosition, RoadPosition)")  # fmt: skip
        if pos.tag == "WorldPosition":
            return self.road.st(self.num(pos, "x"), self.num(pos, "y"))
        if pos.get("roadId") != self.road.road_id:
            raise self.refuse(pos, f"is on road {pos.get('roadId')!r}, not the road of the file")
        if pos.tag == "RoadPosition":
            return self.num(pos, "s"), self.num(pos, "t")
        where = f"{self.name} line {pos.sourceline}"
        lane = self.road.lane_centre(int(self.num(pos, "laneId")), where)
        return self.num(pos, "s"), lane + self.num(pos, "offset", 0.0)

    def point(self, el) -> tuple[float, float]:
        """(s, d) in the 2-D world of a ``Position`` element."""
        s, t = self.position(el)
        return self.road.scene_s(s, self.ego.t) - self.zero, t - self.ego.t

    def _init(self, init) -> None:
        actions = init.find("Actions") if init is not None else None
        if actions is None:
            raise InputError(f"{self.name}: the storyboard has no Init actions")
        self.only(actions, ("Private",))
        for private in actions.iterfind("Private"):
            e = self.entity(private, private.get("entityRef"))
            for action in private.iterfind("PrivateAction"):
                self.only(action, ("TeleportAction", "LongitudinalAction"))
                teleport = action.find("TeleportAction")
                if teleport is not None:
                    e.s, e.t = self.position(teleport.find("Position"))
                    continue
                speed = action.find("LongitudinalAction/SpeedAction")
                target = (
                    speed.find("SpeedActionTarget/AbsoluteTargetSpeed")
                    if speed is not None
                    else None
                )
                if target is None:
                    raise self.refuse(action[0], "in Init must set an absolute target speed")
                e.speed = self.num(target, "value")

    def _stop(self, trigger) -> float:
        conditions = [] if trigger is None else trigger.findall("ConditionGroup/Condition")
        path = "ByValueCondition/SimulationTimeCondition"
        cond = conditions[0].find(path) if len(conditions) == 1 else None
        if cond is None:
            raise InputError(f"{self.name}: the storyboard must stop at a simulation time (one "
                             "StopTrigger SimulationTimeCondition)")  # fmt: skip
        return self.num(cond, "value") + self.num(conditions[0], "delay", 0.0)

    def _story(self, story) -> None:
        self.only(story, ("Act",))
        for act in story.iterfind("Act"):
            self.only(act, ("ManeuverGroup", "StartTrigger", "StopTrigger"))
            stop = act.find("StopTrigger")
            if stop is not None and len(stop):
                raise self.refuse(stop, "of an act is outside the subset the 2-D world reads")
            start = self.conditions.time(act.find("StartTrigger"), 0.0)
            for group in act.iterfind("ManeuverGroup"):
                self.only(group, ("Actors", "Maneuver"))
                actors = [self.entity(r, r.get("entityRef"))
                          for r in group.iterfind("Actors/EntityRef")]  # fmt: skip
                for event in group.iterfind("Maneuver/Event"):
                    self.only(event, ("Action", "StartTrigger"))
                    if self.num(event, "maximumExecutionCount", 1.0) != 1.0:
                        raise self.refuse(event, "must run once (maximumExecutionCount 1)")
                    t = self.conditions.time(event.find("StartTrigger"), start)
                    for action in event.iterfind("Action"):
                        self._action(action, actors, t)

    def _action(self, action, actors: list[_Entity], t: float) -> None:
        self.only(action, ("PrivateAction",))
        private = action.find("PrivateAction")
        self.only(private, ("LongitudinalAction", "LateralAction"))
        inner = private[0][0] if len(private) and len(private[0]) else private
        if inner.tag not in ("SpeedAction", "SpeedProfileAction", "LaneChangeAction"):
            raise self.refuse(inner, "is outside the actions the 2-D world reads")
        for e in actors:
            if e.kind is None:
                raise self.refuse(inner, f"acts on {EGO!r}, whose motion is its test driver's "
                                  "and AEB's in the 2-D world")  # fmt: skip
            if t >= self.duration:
                continue
            {"SpeedAction": self._speed, "SpeedProfileAction": self._profile,
             "LaneChangeAction": self._lane}[inner.tag](inner, e, t)  # fmt: skip

    def _speed(self, el, e: _Entity, t: float) -> None:
        self._free(el, e, t)
        v = float(self.state(e.name, np.array([t]))[2][0])
        absolute = el.find("SpeedActionTarget/AbsoluteTargetSpeed")
        if absolute is not None:
            target = self.num(absolute, "value")
        else:
            rel = el.find("SpeedActionTarget/RelativeTargetSpeed")
            if rel.get("continuous", "false") == "true":
                raise self.refuse(rel, "is continuous, outside the subset")
            ref = float(
                self.state(self.entity(rel, rel.get("entityRef")).name, np.array([t]))[2][0]
            )
            value = self.num(rel, "value")
            target = ref + value if rel.get("speedTargetValueType") == "delta" else ref * value
        if target < 0.0:
            raise self.refuse(el, f"targets a negative speed ({target:g} m/s)")
        dyn = el.find("SpeedActionDynamics")
        shape, dimension = dyn.get("dynamicsShape"), dyn.get("dynamicsDimension")
        value = self.num(dyn, "value")
        if shape not in SHAPES:
            raise self.refuse(dyn, f"has dynamicsShape {shape!r}, outside {', '.join(SHAPES)}")
        if shape == "step" or target == v:
            duration = 0.0
        elif dimension == "time":
            duration = value
        elif dimension == "rate" and shape == "linear":
            duration = abs(target - v) / value
        elif dimension == "distance":
            duration = value / (0.5 * (v + target))
        else:
            raise self.refuse(dyn, f"has a {shape} shape over a {dimension}, outside the subset")
        e.changes.append((t, duration, target - v, SHAPES.index(shape)))

    def _free(self, el, e: _Entity, t: float) -> None:
        busy = [c[0] + c[1] for c in e.changes] + ([math.inf] if e.brake else [])
        if busy and t < max(busy):
            raise self.refuse(el, f"changes {e.name!r}'s speed before its previous change ends")

    def _profile(self, el, e: _Entity, t: float) -> None:
        entries, limits = el.findall("SpeedProfileEntry"), el.find("DynamicConstraints")
        if (el.get("followingMode") != "follow" or el.get("entityRef") or len(entries) != 1
                or entries[0].get("time") is not None or self.num(entries[0], "speed") != 0.0
                or limits is None or e.changes or e.brake):  # fmt: skip
            raise self.refuse(el, "is read only as a jerk-limited brake to standstill from the "
                              "initial speed (one entry of speed 0, followingMode follow, "
                              "DynamicConstraints)")  # fmt: skip
        decel = self.num(limits, "maxDeceleration")
        jerk = self.num(limits, "maxDecelerationRate", math.inf)
        e.brake = (t, decel, decel / jerk)

    def _lane(self, el, e: _Entity, t: float) -> None:
        if e.lane_change is not None:
            raise self.refuse(el, f"is a second lane change of {e.name!r}, outside the subset")
        dyn = el.find("LaneChangeActionDynamics")
        if dyn.get("dynamicsShape") != "sinusoidal" or dyn.get("dynamicsDimension") != "time":
            raise self.refuse(dyn, "is read for sinusoidal dynamics over a time only")
        target = el.find("LaneChangeTarget")[0]
        where = f"{self.name} line {target.sourceline}"
        if target.tag == "AbsoluteTargetLane":
            lane = int(self.num(target, "value"))
        else:
            ref = self.entity(target, target.get("entityRef"))
            d_ref = self.state(ref.name, np.array([t]))[1][0]
            order = sorted(self.road.widths, reverse=True)  # left to right
            index = order.index(self.road.lane_at(d_ref + self.ego.t)) - int(
                self.num(target, "value")
            )
            if not 0 <= index < len(order):
                raise self.refuse(target, "leads off the road")
            lane = order[index]
        t_target = self.road.lane_centre(lane, where) + self.num(el, "targetLaneOffset", 0.0)
        e.lane_change = (t, t_target, self.num(dyn, "value"))

    def specs(self) -> tuple[list[dict[str, object]], list[_Entity]]:
        """The actors' specs for :func:`~acc_fusion.truth.scenes._actors` (every entity but
        the ego, in the file's order) and those entities."""
        others = [e for e in self.entities.values() if e.kind is not None]
        specs = []
        for e in others:
            spec = {"kind": int(e.kind), "v0": e.speed, "d0": e.t - self.ego.t,
                    "s0": self.road.scene_s(e.s, self.ego.t) + e.box[2] - self.zero}  # fmt: skip
            if e.brake is not None:
                spec.update(brake_time=e.brake[0], brake_decel=e.brake[1], brake_rise=e.brake[2])
            if e.lane_change is not None:
                start, t_target, duration = e.lane_change
                spec.update(lc_time=start, d1=t_target - self.ego.t, lc_duration=duration)
            specs.append(spec)
        return specs, others

    def changes(self, n: int, others: list[_Entity], total: int) -> SpeedChanges | None:
        """The actors' speed changes ``(n, total, K)`` (the guardrail posts have none)."""
        k = max((len(e.changes) for e in others), default=0)
        if k == 0:
            return None
        table = np.zeros((4, total, k))
        table[0] = np.inf
        for a, e in enumerate(others):
            for j, change in enumerate(e.changes):
                table[:, a, j] = change
        start, duration, delta, shape = (np.broadcast_to(x, (n, total, k)) for x in table)
        return SpeedChanges(start, duration, delta, shape.astype(np.int8))

    def state(self, name: str, ts: np.ndarray):
        """(s centre, d, v) of entity ``name`` at times ``ts`` [s] as read so far (the ego at
        its initial speed)."""
        if name == EGO:
            length = self.ego.box[0]
            return (
                self.ego.speed * ts - length / 2,
                np.zeros_like(ts),
                np.full_like(ts, self.ego.speed),
            )
        specs, others = self.specs()
        index = [e.name for e in others].index(name)
        actors = _actors(1, specs, self.changes(1, others, len(others)))
        s, v, _, d, _ = actors.centre(ts[:, None])
        return s[:, index], d[:, index], v[:, index]


def read_scenario(path: str | Path, runs: int = 1) -> Scene:
    """The 2-D world's scene of the OpenSCENARIO file ``path`` (module docstring), batched over
    ``runs`` identical runs (the sensors' noise differs); its ``duration`` the stop trigger's.
    Run it with :class:`~acc_fusion.truth.procedures.TrackSource`."""
    reader = _Reader(Path(path))
    specs, others = reader.specs()
    ego = reader.ego
    road = reader.road.scene_road(ego.t, reader.zero)
    specs += _guardrail(runs, road)
    actors = _actors(runs, specs, reader.changes(runs, others, len(specs)))
    speed = np.full(runs, ego.speed)
    return Scene(Path(path).stem, road, actors, speed, speed.copy(), np.full(runs, 1.5),
                 reader.duration, ego_model="cruise", lead_rule="overlap")  # fmt: skip
