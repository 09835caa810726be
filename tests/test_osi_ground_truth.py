"""ASAM OSI ground truth out and in (acc_fusion.truth.osi): the scripted scenes' and a SUMO run's
object frames encoded per ego, written as MCAP traces and read back to the same frames; a
foreign trace built with osi3 read by hand-computed values; the encoder's host and extension;
atomic trace files; bad input in one sentence."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

osi3 = pytest.importorskip("osi3")
osi_utilities = pytest.importorskip("osi_utilities")

from osi3.osi_groundtruth_pb2 import GroundTruth  # noqa: E402
from osi3.osi_object_pb2 import MovingObject, StationaryObject  # noqa: E402
from osi3.osi_sensordata_pb2 import SensorData  # noqa: E402
from osi3.osi_sensorview_pb2 import SensorView  # noqa: E402

from acc_fusion.core.errors import InputError  # noqa: E402
from acc_fusion.truth.objects import OFF_ROAD, ObjectFrame, ObjectKind  # noqa: E402
from acc_fusion.truth.osi.convention import (  # noqa: E402
    EXTENSION_TYPE,
    HOST_ID_BASE,
    lane_id,
    read_extension,
)
from acc_fusion.truth.osi.ground_truth import GroundTruthEncoder  # noqa: E402
from acc_fusion.truth.osi.source import OsiTruth  # noqa: E402
from acc_fusion.truth.osi.trace import TraceFile, write_ground_truth_trace  # noqa: E402
from acc_fusion.truth.scenes import SCENES, SIGNATURES, SceneConfig, SceneSource  # noqa: E402
from acc_fusion.truth.sumo.object_arrays import OBJECT_FLOATS  # noqa: E402
from acc_fusion.truth.sumo.objects import VCLASS_SIGNATURE  # noqa: E402

#: Round-trip tolerance of lengths [m], speeds [m/s], accelerations and angles: the pose
#: transform and back costs a few ulps of the global coordinates (hundreds of metres: 1e-13).
TOL = 1e-9


def _encode_all(frames: list[ObjectFrame], egos: int, **kw) -> list[list]:
    """Every ego's GroundTruth messages of ``frames``."""
    enc = GroundTruthEncoder(egos, **kw)
    out: list[list] = [[] for _ in range(egos)]
    for f in frames:
        for e, m in enumerate(enc.encode(f, np.arange(egos))):
            out[e].append(m)
    return out


def _assert_round_trip(path: Path, frames: list[ObjectFrame], e: int) -> None:
    """The trace ``path`` read back gives ego ``e``'s row of every frame."""
    src = OsiTruth(path)
    assert src.n_steps == len(frames) and not src.done
    np.testing.assert_allclose(src.times, [f.t for f in frames], rtol=0, atol=1e-9)
    for f in frames:
        g, v = src.frame(), f.valid[e]
        assert g.n_egos == 1 and abs(g.t - f.t) <= 1e-9
        assert g.object_id[0].tolist() == f.object_id[e, v].tolist()
        assert g.kind[0].tolist() == f.kind[e, v].tolist()
        assert g.lane[0].tolist() == f.lane[e, v].tolist()
        lead = f.lead[e]
        want = -1 if lead < 0 else int(f.object_id[e, lead])
        assert (-1 if g.lead[0] < 0 else int(g.object_id[0, g.lead[0]])) == want
        for name in OBJECT_FLOATS:
            np.testing.assert_allclose(getattr(g, name)[0], getattr(f, name)[e, v], rtol=0,
                                       atol=TOL, err_msg=name)  # fmt: skip
        for name in ("ego_speed", "ego_accel", "ego_yaw_rate", "road_curvature", "ego_shift"):
            assert abs(getattr(g, name)[0] - getattr(f, name)[e]) <= TOL, name
        src.advance()
    assert src.done and not src.active[0]


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_a_scene_round_trips_through_an_mcap_trace(scene, tmp_path):
    src = SceneSource(SceneConfig(scene=scene, runs=2, dt=0.1), seed=7)
    frames = []
    while not src.done:
        frames.append(src.frame())
        src.advance()
    assert any(f.valid.any() for f in frames)
    for e, messages in enumerate(_encode_all(frames, 2)):
        path = write_ground_truth_trace(tmp_path / f"{scene}_{e}.mcap", messages)
        _assert_round_trip(path, frames, e)


def test_a_sumo_run_round_trips_with_the_sources_ids(tmp_path):
    pytest.importorskip("libsumo")
    from acc_fusion.truth.sumo.config import SumoConfig
    from acc_fusion.truth.sumo.source import SumoSource
    from acc_fusion.truth.sumo.world import SumoWorld

    straight = Path(__file__).parent / "data" / "straight_motorway" / "straight.sumocfg"
    with SumoSource(SumoConfig(str(straight), end=60, seed=3)) as src:
        world = SumoWorld(src)
        for _ in range(300):
            src.advance()
        frames, held = [], []
        for _ in range(20):
            frames.append(world.frame())
            held.append(list(src.vehicle_ids[: frames[-1].n_egos]))
            src.advance()
        info = dict(src._info)
    # the slots that held one vehicle with objects ahead throughout
    n = min(f.n_egos for f in frames)
    frames = [f.head(n) for f in frames]
    egos = [e for e in range(n) if held[0][e] is not None
            and all(h[e] == held[0][e] for h in held) and frames[0].valid[e].any()][:4]  # fmt: skip
    assert egos and any(f.lead[e] >= 0 for f in frames for e in egos)
    host_ids = np.array([info[held[0][e]][0] if e in egos else HOST_ID_BASE + e
                         for e in range(n)])  # fmt: skip
    messages = _encode_all(frames, n, host_ids=host_ids)
    for e in egos:
        assert messages[e][0].host_vehicle_id.value == info[held[0][e]][0]
        path = write_ground_truth_trace(tmp_path / f"sumo_{e}.mcap", messages[e])
        _assert_round_trip(path, frames, e)


def _frame(t: float, v: float, yaw_rate: float, **objects) -> ObjectFrame:
    """One ego's frame with the objects given as ``name=[values]`` (defaults: one vehicle)."""
    m = len(objects.get("x", [0.0]))
    base = {name: np.zeros((1, m)) for name in OBJECT_FLOATS}
    base.update(length=np.full((1, m), 4.5), width=np.full((1, m), 1.8),
                height=np.full((1, m), 1.5))  # fmt: skip
    base.update({k: np.array([val], dtype=float) for k, val in objects.items() if k in base})
    return ObjectFrame(
        t=t, ego_speed=np.array([v]), ego_accel=np.array([0.5]), ego_yaw_rate=np.array([yaw_rate]),
        road_curvature=np.array([0.0]), valid=np.ones((1, m), bool),
        object_id=np.array([objects.get("ids", list(range(m)))]),
        kind=np.array([objects.get("kind", [0] * m)]),
        lane=np.array([objects.get("lane", [0] * m)]),
        lead=np.array([objects.get("lead", 0)]), **base,
    )  # fmt: skip


def test_the_host_is_dead_reckoned_and_the_extension_is_exact():
    enc = GroundTruthEncoder(1)
    rcs = 0.1 + 0.2  # not a short decimal: its repr must survive
    first = _frame(0.0, 10.0, 0.0, x=[30.0], rcs=[rcs], thermal_contrast=[7.25])
    (gt0,) = enc.encode(first, np.array([0]))
    (gt1,) = enc.encode(_frame(1.0, 12.0, 0.2, x=[28.0]), np.array([0]))
    assert gt0.version.version_major == 3 and gt0.version.version_minor >= 8
    assert gt1.timestamp.seconds == 1 and gt1.timestamp.nanos == 0
    assert gt0.host_vehicle_id.value == HOST_ID_BASE
    host = next(m for m in gt1.moving_object if m.id.value == HOST_ID_BASE)
    # trapezoid: heading 0.1 rad, 11 m along the mean heading 0.05 rad; the centre 2.25 m back
    psi, mid = 0.1, 0.05
    assert host.base.orientation.yaw == pytest.approx(psi, abs=1e-15)
    assert host.base.position.x == pytest.approx(11 * math.cos(mid) - 2.25 * math.cos(psi))
    assert host.base.position.y == pytest.approx(11 * math.sin(mid) - 2.25 * math.sin(psi))
    assert host.base.position.z == pytest.approx(0.75)
    assert host.base.orientation_rate.yaw == 0.2
    assert host.base.velocity.x == pytest.approx(12 * math.cos(psi))
    lead = next(m for m in gt0.moving_object if m.id.value == 0)
    assert lead.base.position.x == pytest.approx(32.25)  # rear face 30 m ahead, length 4.5
    ext = read_extension(lead.source_reference)
    assert lead.source_reference[0].type == EXTENSION_TYPE
    assert float(ext["rcs"]) == rcs and ext["rcs"] == repr(rcs)
    assert ext["thermal_contrast"] == "7.25" and ext["kind"] == "VEHICLE" and ext["lead"] == "1"
    assert lead.moving_object_classification.assigned_lane_id[0].value == lane_id(0)
    lanes = {la.id.value: la.classification for la in gt0.lane}
    assert set(lanes) == {lane_id(k) for k in (-1, 0, 1)}
    assert lanes[lane_id(0)].is_host_vehicle_lane
    assert lanes[lane_id(0)].left_adjacent_lane_id[0].value == lane_id(1)
    assert lanes[lane_id(0)].right_adjacent_lane_id[0].value == lane_id(-1)
    # a new vehicle in the slot starts at the origin again
    enc.reset(np.array([True]))
    (gt2,) = enc.encode(_frame(2.0, 12.0, 0.2, x=[28.0]), np.array([0]))
    host = next(m for m in gt2.moving_object if m.id.value == HOST_ID_BASE)
    assert (host.base.position.x, host.base.orientation.yaw) == (-2.25, 0.0)


def test_a_hosts_sideways_jump_moves_its_pose_and_is_read_back(tmp_path):
    """SUMO's lane change within a step: the host's pose jumps 3.5 m to the left of its
    heading, the jump travels in the host's extension, and the reader gives it back."""
    frames = [_frame(t, 10.0, 0.0, x=[30.0], speed=[10.0]) for t in (0.0, 1.0, 2.0)]
    frames[1] = replace(frames[1], ego_shift=np.array([3.5]))
    (messages,) = _encode_all(frames, 1)
    hosts = [next(m for m in gt.moving_object if m.id.value == HOST_ID_BASE) for gt in messages]
    np.testing.assert_allclose([h.base.position.y for h in hosts], [0.0, 3.5, 3.5])
    np.testing.assert_allclose([h.base.position.x for h in hosts], [-2.25, 7.75, 17.75])
    assert [read_extension(h.source_reference) for h in hosts] == [None, {"ego_shift": "3.5"},
                                                                   None]  # fmt: skip
    _assert_round_trip(write_ground_truth_trace(tmp_path / "jump.mcap", messages), frames, 0)
    # turning at 0.2 rad/s, the jump at t = 2 s is along the left normal of the heading at the
    # step's start (0.2 rad), after the trapezoid's 10 m along the mean heading (0.3 rad)
    turning = [_frame(t, 10.0, 0.2, x=[30.0], speed=[10.0]) for t in (0.0, 1.0, 2.0)]
    turning[2] = replace(turning[2], ego_shift=np.array([3.5]))
    (messages,) = _encode_all(turning, 1)
    host = next(m for m in messages[2].moving_object if m.id.value == HOST_ID_BASE)
    front = (10 * math.cos(0.1) + 10 * math.cos(0.3) - 3.5 * math.sin(0.2),
             10 * math.sin(0.1) + 10 * math.sin(0.3) + 3.5 * math.cos(0.2))  # fmt: skip
    assert host.base.position.x == pytest.approx(front[0] - 2.25 * math.cos(0.4))
    assert host.base.position.y == pytest.approx(front[1] - 2.25 * math.sin(0.4))


def test_stationary_kinds_map_to_osi_types():
    kinds = [ObjectKind.GANTRY, ObjectKind.BRIDGE, ObjectKind.GUARDRAIL, ObjectKind.SIGN,
             ObjectKind.PLATE, ObjectKind.PARKED]  # fmt: skip
    f = _frame(0.0, 20.0, 0.0, x=[50.0, 80.0, 20.0, 30.0, 60.0, 40.0],
               y=[0.0, 0.0, -5.0, -6.0, 0.0, -5.0], kind=[int(k) for k in kinds],
               lane=[OFF_ROAD, OFF_ROAD, OFF_ROAD, OFF_ROAD, 0, OFF_ROAD], lead=-1)  # fmt: skip
    (gt,) = GroundTruthEncoder(1).encode(f, np.array([0]))
    t = StationaryObject.Classification
    types = [t.Type.Name(s.classification.type) for s in gt.stationary_object]
    assert types == ["TYPE_OVERHEAD_STRUCTURE", "TYPE_BRIDGE", "TYPE_BARRIER", "TYPE_POLE",
                     "TYPE_SPEED_BUMP"]  # fmt: skip
    parked = [m for m in gt.moving_object if m.id.value == 5]
    assert parked and parked[0].type == MovingObject.TYPE_VEHICLE
    assert not parked[0].moving_object_classification.assigned_lane_id
    assert gt.stationary_object[4].classification.assigned_lane_id[0].value == lane_id(0)


def _object(gt: GroundTruth, ident: int, x, y, yaw, size, speed=0.0, moving=True):
    obj = gt.moving_object.add() if moving else gt.stationary_object.add()
    obj.id.value = ident
    b = obj.base
    b.position.x, b.position.y, b.position.z = x, y, size[2] / 2
    b.orientation.yaw = yaw
    b.dimension.length, b.dimension.width, b.dimension.height = size
    if moving:
        obj.type = MovingObject.TYPE_VEHICLE
        b.velocity.x, b.velocity.y = speed * math.cos(yaw), speed * math.sin(yaw)
    return obj


def _foreign(t: float, host_speed: float) -> GroundTruth:
    """A host heading 0.3 rad at (100, 50) with a truck 30 m ahead in its lane, a car 50 m
    ahead one lane left, a pole 40 m ahead 6 m right, a car behind and one 400 m ahead; no
    lanes, no extension, no acceleration, no yaw rate."""
    gt = GroundTruth()
    gt.timestamp.seconds, gt.timestamp.nanos = int(t), round((t % 1) * 1e9)
    gt.host_vehicle_id.value = 7
    th = 0.3
    u, n = np.array([math.cos(th), math.sin(th)]), np.array([-math.sin(th), math.cos(th)])
    centre = np.array([100.0, 50.0])
    front = centre + 2.3 * u
    _object(gt, 7, *centre, th, (4.6, 1.9, 1.5), host_speed)
    truck = _object(gt, 11, *(front + 36.0 * u), th, (12.0, 2.5, 3.5), 15.0)
    truck.vehicle_classification.type = MovingObject.VehicleClassification.TYPE_HEAVY_TRUCK
    _object(gt, 12, *(front + 52.25 * u + 3.5 * n), th, (4.5, 1.8, 1.5), 25.0)
    pole = _object(gt, 13, *(front + 40.0 * u - 6.0 * n), 0.0, (0.2, 0.2, 3.0), moving=False)
    pole.classification.type = StationaryObject.Classification.TYPE_POLE
    _object(gt, 14, *(front - 20.0 * u), th, (4.5, 1.8, 1.5), 20.0)
    _object(gt, 15, *(front + 400.0 * u), th, (4.5, 1.8, 1.5), 20.0)
    return gt


def test_a_foreign_trace_is_read_by_the_geometry_rules(tmp_path):
    path = write_ground_truth_trace(tmp_path / "foreign.mcap", [_foreign(0.0, 20.0),
                                                                 _foreign(0.1, 21.0)])  # fmt: skip
    src = OsiTruth(path)
    assert src.dt == pytest.approx(0.1)
    f = src.frame()
    assert f.object_id[0].tolist() == [11, 12, 13]  # moving, then stationary; 14, 15 out
    assert f.kind[0].tolist() == [ObjectKind.VEHICLE, ObjectKind.VEHICLE, ObjectKind.SIGN]
    assert f.lane[0].tolist() == [0, 1, OFF_ROAD]
    assert f.lead[0] == 0
    pole_x = 40.0 - 0.1 * math.cos(0.3)  # its face nearer the host, of a box yawed -0.3 rad
    np.testing.assert_allclose(f.x[0], [30.0, 50.0, pole_x], atol=1e-9)
    np.testing.assert_allclose(f.y[0], [0.0, 3.5, -6.0 + 0.1 * math.sin(0.3)], atol=1e-9)
    np.testing.assert_allclose(f.vx[0], [-5.0, 5.0, -20.0], atol=1e-9)
    np.testing.assert_allclose(f.vy[0], [0.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(f.speed[0], [15.0, 25.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(f.heading[0], [0.0, 0.0, -0.3], atol=1e-12)
    np.testing.assert_allclose(f.elevation[0], [0.0, 0.0, 0.0], atol=1e-12)
    assert f.rcs[0].tolist() == [VCLASS_SIGNATURE["truck"][0], VCLASS_SIGNATURE["passenger"][0],
                                 SIGNATURES[ObjectKind.SIGN][3]]  # fmt: skip
    assert f.thermal_contrast[0, 2] == SIGNATURES[ObjectKind.SIGN][4]
    assert (f.ego_speed[0], f.ego_accel[0], f.ego_yaw_rate[0]) == (20.0, 0.0, 0.0)
    src.advance()
    f = src.frame()
    assert f.ego_accel[0] == pytest.approx(10.0)  # the speed difference over the step
    assert f.ego_yaw_rate[0] == 0.0 and f.road_curvature[0] == 0.0
    lead = f.lead_frame()
    assert lead.leader_id.tolist() == [11] and lead.gap[0] == pytest.approx(30.0)


def test_a_sensor_view_and_a_single_channel_osi_file_are_read(tmp_path):
    views = []
    for t, v in ((0.0, 20.0), (0.1, 21.0)):
        sv = SensorView()
        sv.global_ground_truth.CopyFrom(_foreign(t, v))
        sv.global_ground_truth.ClearField("host_vehicle_id")
        sv.host_vehicle_id.value = 7
        views.append(sv)
    with TraceFile(tmp_path / "sv.mcap") as trace:
        trace.add_channel("view", SensorView)
        for sv in views:
            trace.write("view", sv)
    assert OsiTruth(tmp_path / "sv.mcap").frame().object_id[0].tolist() == [11, 12, 13]
    single = tmp_path / "20260101T000000Z_gt_3.8.0_4.25_2_foreign.osi"
    writer = osi_utilities.SingleTraceWriter()
    assert writer.open(single)
    for t, v in ((0.0, 20.0), (0.1, 21.0)):
        writer.write_message(_foreign(t, v))
    writer.close()
    src = OsiTruth(single)
    assert src.n_steps == 2 and src.frame().lead[0] == 0


def test_a_trace_file_is_all_or_nothing(tmp_path):
    path = tmp_path / "t.mcap"
    with pytest.raises(RuntimeError, match="boom"):
        with TraceFile(path) as trace:
            trace.add_channel("ground_truth", GroundTruth)
            trace.write("ground_truth", _foreign(0.0, 20.0))
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(InputError, match="written as .mcap"):
        TraceFile(tmp_path / "t.osi")
    with pytest.raises(InputError, match="channel 'nope'"):
        with TraceFile(path) as trace:
            trace.write("nope", _foreign(0.0, 20.0))
    assert list(tmp_path.iterdir()) == []


def _gt_trace(path: Path, messages) -> Path:
    return write_ground_truth_trace(path, messages)


def test_bad_traces_are_refused_in_one_sentence(tmp_path):
    def refused(path, match, **kw):
        with pytest.raises(InputError, match=match) as info:
            OsiTruth(path, **kw)
        assert "\n" not in str(info.value)

    refused(tmp_path / "missing.mcap", "does not exist")
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file at all")
    refused(tmp_path / "junk.mcap", "not an MCAP file")
    (tmp_path / "x.csv").write_text("a,b\n")
    refused(tmp_path / "x.csv", "must be a .mcap or .osi")
    with TraceFile(tmp_path / "sd.mcap") as trace:
        trace.add_channel("sensor", SensorData)
        trace.write("sensor", SensorData())
    refused(tmp_path / "sd.mcap", "no GroundTruth or SensorView channel")
    refused(tmp_path / "sd.mcap", "channel 'sensor' .* is not GroundTruth", topic="sensor")
    no_host = _foreign(0.0, 20.0)
    no_host.ClearField("host_vehicle_id")
    refused(_gt_trace(tmp_path / "nohost.mcap", [no_host, _foreign(0.1, 20.0)]),
            "message 0 .* names no host_vehicle_id")  # fmt: skip
    lost = _foreign(0.1, 20.0)
    lost.host_vehicle_id.value = 99
    refused(_gt_trace(tmp_path / "lost.mcap", [_foreign(0.0, 20.0), lost]), "host's id 99")
    uneven = [_foreign(t, 20.0) for t in (0.0, 0.1, 0.2, 0.35)]
    refused(_gt_trace(tmp_path / "uneven.mcap", uneven), "message 3 .* 0.15 s after")
    refused(_gt_trace(tmp_path / "one.mcap", [_foreign(0.0, 20.0)]), "at least two messages")
    (tmp_path / "trace.osi").write_bytes(b"")
    refused(tmp_path / "trace.osi", "cannot tell the message type")


def test_a_host_overlapping_a_vehicle_has_collided(tmp_path):
    """A car 3 m ahead of the host's centre (the boxes overlap), 10 m/s slower, in the second
    message: a collision at 10 m/s, though the car is behind the host's bumper (out of the
    field)."""
    crash = _foreign(0.1, 20.0)
    _object(crash, 20, 100.0 + 3.0 * math.cos(0.3), 50.0 + 3.0 * math.sin(0.3), 0.3,
            (4.5, 1.8, 1.5), 10.0)  # fmt: skip
    src = OsiTruth(write_ground_truth_trace(tmp_path / "c.mcap", [_foreign(0.0, 20.0), crash]))
    assert not src.collided[0] and np.isnan(src.collision_speed[0])
    src.advance()
    assert src.collided[0] and src.collision_speed[0] == pytest.approx(10.0)
    assert 20 not in src.frame().object_id[0].tolist()


def test_the_encoder_refuses_a_host_id_its_ego_sees_and_too_many_egos():
    f = _frame(0.0, 20.0, 0.0, x=[30.0], ids=[42])
    with pytest.raises(InputError, match="host id 42 of ego 0 is also the id of an object"):
        GroundTruthEncoder(1, host_ids=np.array([42])).encode(f, np.array([0]))
    two = SceneSource(SceneConfig(scene="cut_in", runs=2, dt=0.1), seed=1).frame()
    with pytest.raises(InputError, match="the frame has 2 egos, the encoder was made for 1"):
        GroundTruthEncoder(1).encode(two, np.array([0]))
