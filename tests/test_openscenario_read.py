"""The OpenSCENARIO reader's subset on hand-written files: speed changes of every shape,
entity conditions, lane changes, positions on an arc; and its one-sentence refusals."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.truth.openscenario.read import read_scenario
from acc_fusion.truth.openscenario.road import write_track
from acc_fusion.truth.procedures import TrackSource

TIME0 = ('<ByValueCondition><SimulationTimeCondition value="{}" rule="greaterThan"/>'
         "</ByValueCondition>")  # fmt: skip


def vehicle(name: str, category: str = "car") -> str:
    return (f'<ScenarioObject name="{name}"><Vehicle name="{name}" vehicleCategory="{category}">'
            '<BoundingBox><Center x="0" y="0" z="0.75"/><Dimensions width="1.8" length="4.5" '
            'height="1.5"/></BoundingBox><Performance maxSpeed="60" maxAcceleration="10" '
            'maxDeceleration="10"/><Axles><FrontAxle maxSteering="0.5" wheelDiameter="0.6" '
            'trackWidth="1.5" positionX="1.35" positionZ="0.3"/><RearAxle maxSteering="0" '
            'wheelDiameter="0.6" trackWidth="1.5" positionX="-1.35" positionZ="0.3"/></Axles>'
            "</Vehicle></ScenarioObject>")  # fmt: skip


def place(name: str, position: str, speed) -> str:
    return (f'<Private entityRef="{name}"><PrivateAction><TeleportAction><Position>{position}'
            "</Position></TeleportAction></PrivateAction><PrivateAction><LongitudinalAction>"
            '<SpeedAction><SpeedActionDynamics dynamicsShape="step" value="0" '
            'dynamicsDimension="time"/><SpeedActionTarget><AbsoluteTargetSpeed '
            f'value="{speed}"/></SpeedActionTarget></SpeedAction></LongitudinalAction>'
            "</PrivateAction></Private>")  # fmt: skip


def lane(s: float, lane_id: int = -2, offset: float = 0.0) -> str:
    return f'<LanePosition roadId="1" laneId="{lane_id}" s="{s}" offset="{offset}"/>'


def speed(target: str, shape: str, dimension: str, value: float) -> str:
    return (f'<PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics '
            f'dynamicsShape="{shape}" value="{value}" dynamicsDimension="{dimension}"/>'
            f"<SpeedActionTarget>{target}</SpeedActionTarget></SpeedAction>"
            "</LongitudinalAction></PrivateAction>")  # fmt: skip


def event(name: str, action: str, condition: str, who: str = "") -> str:
    if who:
        condition = (f'<ByEntityCondition><TriggeringEntities triggeringEntitiesRule="any">'
                     f'<EntityRef entityRef="{who}"/></TriggeringEntities><EntityCondition>'
                     f"{condition}</EntityCondition></ByEntityCondition>")  # fmt: skip
    return (f'<Event name="{name}" priority="override"><Action name="{name}">{action}</Action>'
            f'<StartTrigger><ConditionGroup><Condition name="{name}" delay="0" '
            f'conditionEdge="rising">{condition}</Condition></ConditionGroup></StartTrigger>'
            "</Event>")  # fmt: skip


def scenario(path, entities, init, events, duration=20.0, actors=("Lead",), road="track.xodr",
             params="") -> None:  # fmt: skip
    refs = "".join(f'<EntityRef entityRef="{a}"/>' for a in actors)
    path.write_text(
        '<?xml version="1.0" encoding="utf-8"?><OpenSCENARIO><FileHeader revMajor="1" '
        'revMinor="3" date="2026-01-01T00:00:00" description="test" author="test"/>'
        f"<ParameterDeclarations>{params}</ParameterDeclarations><CatalogLocations/>"
        f'<RoadNetwork><LogicFile filepath="{road}"/></RoadNetwork>'
        f"<Entities>{entities}</Entities><Storyboard><Init><Actions>{init}</Actions></Init>"
        '<Story name="S"><Act name="A"><ManeuverGroup maximumExecutionCount="1" name="G">'
        f'<Actors selectTriggeringEntities="false">{refs}</Actors><Maneuver name="M">{events}'
        '</Maneuver></ManeuverGroup><StartTrigger><ConditionGroup><Condition name="go" '
        f'delay="0" conditionEdge="none">{TIME0.format(0)}</Condition></ConditionGroup>'
        '</StartTrigger></Act></Story><StopTrigger><ConditionGroup><Condition name="end" '
        f'delay="0" conditionEdge="rising">{TIME0.format(duration)}</Condition>'
        "</ConditionGroup></StopTrigger></Storyboard></OpenSCENARIO>"
    )


@pytest.fixture
def track(tmp_path):
    write_track(tmp_path / "track.xodr", 1000.0)
    return tmp_path


def two_cars(track, events, lead_s=200.0, lead_speed=20.0, ego_speed=20.0, **kw):
    """Ego's front bumper at s = 100 (scene 0), the lead's centre at ``lead_s``."""
    path = track / "t.xosc"
    scenario(path, vehicle("Ego") + vehicle("Lead"),
             place("Ego", lane(97.75), ego_speed) + place("Lead", lane(lead_s), lead_speed),
             events, **kw)  # fmt: skip
    return read_scenario(path)


def test_speed_changes_follow_their_shapes_and_dimensions(track):
    """cubic over a time, sinusoidal over a distance relative to the ego, linear at a rate:
    speeds and distances against the closed forms (OpenSCENARIO 1.3 DynamicsShape)."""
    scene = two_cars(track, "".join([
        event("slow", speed('<AbsoluteTargetSpeed value="10"/>', "cubic", "time", 4.0),
              TIME0.format(1.0)),
        event("up", speed('<RelativeTargetSpeed entityRef="Ego" value="-5" '
                          'speedTargetValueType="delta" continuous="false"/>',
                          "sinusoidal", "distance", 50.0), TIME0.format(6.0)),
        event("stop", speed('<AbsoluteTargetSpeed value="0"/>', "linear", "rate", 5.0),
              TIME0.format(12.0)),
    ]))  # fmt: skip
    s0 = 200.0 - 100.0
    assert scene.actors.s0[0, 0] == pytest.approx(s0)

    def at(t):
        s, v, a, _, _ = scene.actors.centre(t)
        return s[0, 0] - s0, v[0, 0], a[0, 0]

    # cubic 20 -> 10 m/s over 1-5 s: half way 15 m/s at -1.5 * 10 / 4 m/s²
    assert at(3.0) == pytest.approx((60.0 - 40.0 * (0.125 - 0.5**4 / 2), 15.0, -3.75))
    assert at(5.0) == pytest.approx((20.0 + 4.0 * 15.0, 10.0, 0.0))
    # sinusoidal 10 -> 15 m/s over 50 m: 4 s
    assert at(10.0)[:2] == pytest.approx((90.0 + 50.0, 15.0))
    assert at(8.0)[1] == pytest.approx(12.5)
    # linear at 5 m/s² to a stop from 12 s: 3 s, 22.5 m
    assert at(16.0) == pytest.approx((140.0 + 30.0 + 22.5, 0.0, 0.0))
    assert at(13.0)[2] == pytest.approx(-5.0)


def test_entity_conditions_fire_when_they_first_hold(track):
    """Ego at 20 m/s 50 m behind a lead at 10 m/s: a freespace distance of 30 m after 2 s."""
    rel = ('<RelativeDistanceCondition entityRef="Lead" freespace="true" '
           'relativeDistanceType="longitudinal" value="30" rule="lessThan"/>')  # fmt: skip
    brake = speed('<AbsoluteTargetSpeed value="0"/>', "linear", "rate", 4.0)
    scene = two_cars(track, event("brake", brake, rel, who="Ego"),
                     lead_s=100.0 + 50.0 + 2.25, lead_speed=10.0)  # fmt: skip
    _, v, _, _, _ = scene.actors.centre(np.array([[1.99], [2.5]]))
    assert v[:, 0] == pytest.approx([10.0, 8.0], abs=1e-6)
    # a TTC below 3 s (gap 50 - 10 t over 10 m/s) at 2 s starts a lane change to lane -1
    ttc = ('<TimeToCollisionCondition value="3" freespace="true" rule="lessThan">'
           '<TimeToCollisionConditionTarget><EntityRef entityRef="Lead"/>'
           "</TimeToCollisionConditionTarget></TimeToCollisionCondition>")  # fmt: skip
    change = ('<PrivateAction><LateralAction><LaneChangeAction><LaneChangeActionDynamics '
              'dynamicsShape="sinusoidal" value="2" dynamicsDimension="time"/><LaneChangeTarget>'
              '<AbsoluteTargetLane value="-1"/></LaneChangeTarget></LaneChangeAction>'
              "</LateralAction></PrivateAction>")  # fmt: skip
    scene = two_cars(track, event("out", change, ttc, who="Ego"), lead_s=152.25, lead_speed=10.0)
    assert scene.actors.lc_time[0, 0] == pytest.approx(2.0, abs=1e-8)
    _, _, _, d, _ = scene.actors.centre(np.array([[3.0 + 1e-8], [4.5]]))
    assert d[:, 0] == pytest.approx([1.75, 3.5], abs=1e-6)
    # the lead's centre 10 m from the world point (300, 0) at (300 - 10 - 152.25) / 10 s
    dist = ('<DistanceCondition value="10" freespace="false" rule="lessThan" '
            'relativeDistanceType="cartesian"><Position><WorldPosition x="300" y="0"/>'
            "</Position></DistanceCondition>")  # fmt: skip
    scene = two_cars(track, event("stop", brake, dist, who="Lead"), lead_s=152.25,
                     lead_speed=10.0)  # fmt: skip
    start = scene.actors.speed_changes.start[0, 0, 0]
    assert start == pytest.approx((300.0 - 10.0 - 152.25) / 10.0, abs=1e-8)


def test_a_condition_that_never_holds_never_fires(track):
    """The lead pulls away: a freespace distance below 30 m never comes, the lead never
    brakes, and the file is read all the same."""
    rel = ('<RelativeDistanceCondition entityRef="Lead" freespace="true" '
           'relativeDistanceType="longitudinal" value="30" rule="lessThan"/>')  # fmt: skip
    brake = speed('<AbsoluteTargetSpeed value="0"/>', "linear", "rate", 4.0)
    scene = two_cars(track, event("brake", brake, rel, who="Ego"), lead_s=152.25,
                     lead_speed=25.0)  # fmt: skip
    assert scene.actors.speed_changes is None
    assert scene.actors.centre(19.0)[1][0, 0] == 25.0


ARC = """<?xml version="1.0"?><OpenDRIVE><header revMajor="1" revMinor="8" name="arc"/>
<road id="7" junction="-1" length="300"><planView>
<geometry s="0" x="0" y="0" hdg="0" length="100"><line/></geometry>
<geometry s="100" x="100" y="0" hdg="0" length="200"><arc curvature="0.01"/></geometry>
</planView><lanes><laneSection s="0"><center><lane id="0" type="none"/></center>
<right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
</right></laneSection></lanes></road></OpenDRIVE>"""


def test_a_road_with_an_arc_and_a_world_position_on_it(tmp_path):
    """The ego lane's centre 1.75 m right of the reference line: its curvature
    k / (1 + 1.75 k), its length scaled by (1 + 1.75 k); a WorldPosition 100 m into the arc
    on the lane centre lands at that lane length."""
    (tmp_path / "arc.xodr").write_text(ARC)
    k, t, theta = 0.01, -1.75, 1.0
    x = 100.0 + math.sin(theta) / k - t * math.sin(theta)
    y = (1.0 - math.cos(theta)) / k + t * math.cos(theta)
    lanepos = '<LanePosition roadId="7" laneId="-1" s="47.75" offset="0"/>'
    world = f'<WorldPosition x="{x!r}" y="{y!r}" z="0" h="{theta!r}"/>'
    path = tmp_path / "arc.xosc"
    scenario(path, vehicle("Ego") + vehicle("Lead"), place("Ego", lanepos, 10.0)
             + place("Lead", world, 5.0), "", road="arc.xodr")  # fmt: skip
    scene = read_scenario(path)
    scale = 1.0 - k * t
    assert scene.road.curves == (pytest.approx((50.0, k / scale)),)
    assert scene.road.length == pytest.approx(50.0 + 200.0 * scale)
    assert scene.actors.s0[0, 0] == pytest.approx(50.0 + 100.0 * scale, abs=1e-9)
    assert scene.actors.d0[0, 0] == pytest.approx(0.0, abs=1e-9)
    source = TrackSource(scene, scene.duration)
    source.advance()
    assert source.frame().road_curvature[0] == pytest.approx(0.0)


def _refused(track, **changes):
    parts = {"entities": vehicle("Ego") + vehicle("Lead"),
             "init": place("Ego", lane(97.75), 20.0) + place("Lead", lane(150.0), 10.0),
             "events": ""}  # fmt: skip
    parts.update(changes)
    path = track / "bad.xosc"
    scenario(path, parts.pop("entities"), parts.pop("init"), parts.pop("events"), **parts)
    with pytest.raises(InputError) as info:
        read_scenario(path)
    return str(info.value)


@pytest.mark.parametrize(
    "changes, words",
    [
        ({"entities": vehicle("Ego") + vehicle("Lead", "bicycle")}, ("<Vehicle>", "bicycle")),
        ({"entities": vehicle("Lead") + vehicle("Other")}, ("'Ego'",)),
        ({"events": event("hide", '<PrivateAction><VisibilityAction graphics="false" '
                          'traffic="false" sensors="false"/></PrivateAction>', TIME0.format(1))},
         ("<VisibilityAction>", "outside the subset")),
        ({"events": event("x", speed('<AbsoluteTargetSpeed value="$Nope"/>', "step", "time", 0),
                          TIME0.format(1))}, ("$Nope", "not declared")),
        ({"actors": ("Ego",), "events": event(
            "x", speed('<AbsoluteTargetSpeed value="5"/>', "linear", "rate", 2), TIME0.format(1))},
         ("acts on 'Ego'",)),
        ({"events": event("x", speed('<AbsoluteTargetSpeed value="5"/>', "cubic", "rate", 2),
                          TIME0.format(1))}, ("cubic shape over a rate",)),
        ({"events": event("a", speed('<AbsoluteTargetSpeed value="5"/>', "linear", "time", 4),
                          TIME0.format(1)) + event(
            "b", speed('<AbsoluteTargetSpeed value="8"/>', "linear", "time", 4), TIME0.format(3))},
         ("before its previous change ends",)),
        ({"road": "missing.xodr"}, ("road file", "does not exist")),
    ],
)  # fmt: skip
def test_what_is_outside_the_subset_is_refused_in_one_sentence(track, changes, words):
    message = _refused(track, **changes)
    assert "\n" not in message
    for word in words:
        assert word in message, message
    if "<" in words[0]:
        assert "bad.xosc line " in message


def test_a_spiral_or_a_malformed_file_is_refused(track):
    spiral = '<spiral curvStart="0" curvEnd="0.01"/>'
    (track / "spiral.xodr").write_text(ARC.replace('<arc curvature="0.01"/>', spiral))
    message = _refused(track, road="spiral.xodr")
    assert "spiral.xodr line 4: <spiral>" in message
    (track / "broken.xosc").write_text("<OpenSCENARIO><FileHeader")
    with pytest.raises(InputError, match="broken.xosc is not well-formed XML"):
        read_scenario(track / "broken.xosc")


def test_without_lxml_one_sentence_names_the_extra(track, monkeypatch):
    monkeypatch.setitem(sys.modules, "lxml", None)
    with pytest.raises(ConfigError, match=r"pip install 'acc_fusion\[interop\]'"):
        read_scenario(track / "any.xosc")
