"""highway-env as the 2-D world's truth source (acc_fusion.truth.highway.world): positions and
velocities against highway-env's own vehicles rotated into the ego frame here, the lead and the
1-D frame, the sign of the relative lane, the sine lane's curvature, the yaw rate, merge-v0's
obstacle, the roadside placement, the pipeline and the ``highway --world`` command.  Two short
recordings (highway-fast-v0 with 8 vehicles, merge-v0) serve most tests."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import pytest

pytest.importorskip("highway_env")

from acc_fusion.cli.main import main  # noqa: E402
from acc_fusion.core.errors import ConfigError  # noqa: E402
from acc_fusion.sim.closed_loop import SimConfig  # noqa: E402
from acc_fusion.sim.world import simulate_world  # noqa: E402
from acc_fusion.truth.frame import TruthFrame  # noqa: E402
from acc_fusion.truth.highway.config import HighwayConfig  # noqa: E402
from acc_fusion.truth.highway.source import HighwaySource  # noqa: E402
from acc_fusion.truth.highway.world import DEFAULT_FIELD, HighwayWorld  # noqa: E402
from acc_fusion.truth.objects import OFF_ROAD, ObjectFrame, ObjectKind  # noqa: E402
from acc_fusion.truth.sumo.objects import ObjectFieldConfig  # noqa: E402
from acc_fusion.truth.sumo.roadside import RoadsideConfig  # noqa: E402

AHEAD, LATERAL = DEFAULT_FIELD.ahead, DEFAULT_FIELD.lateral


@dataclass
class Step:
    """One recorded step: the frames and a copy of highway-env's state."""

    frame: ObjectFrame
    truth: TruthFrame
    active: np.ndarray
    reassigned: np.ndarray
    veh: np.ndarray  # (V, 6): x, y, heading, speed, LENGTH, WIDTH
    vid: np.ndarray  # (V,) the source's integer ids
    lanes: list  # (V,) lane_index
    lateral: np.ndarray  # (V,) speed across the own lane, from highway-env's lane heading
    obstacles: np.ndarray  # (O, 5): x, y, heading, LENGTH, WIDTH
    slot_vid: np.ndarray  # (N,) id of each slot's vehicle
    kappa: np.ndarray  # (N,) finite difference of heading_at at each slot's vehicle
    on_sine: np.ndarray  # (N,) the slot's vehicle is on a SineLane
    off_segment: dict  # (slot, id) -> lane offset of a vehicle on another segment (below)
    dt: float


def _kappa(lane, position, h=0.05):
    """Curvature of ``lane`` at ``position`` by a central difference of ``heading_at`` over the
    arc between ``s - h`` and ``s + h`` (highway-env's own geometry)."""
    s, _ = lane.local_coordinates(position)
    turn = lane.heading_at(s + h) - lane.heading_at(s - h)
    arc = np.linalg.norm(lane.position(s + h, 0.0) - lane.position(s - h, 0.0))
    return math.atan2(math.sin(turn), math.cos(turn)) / arc


def _across(v) -> float:
    """Speed of vehicle ``v`` across its lane, left positive."""
    s, _ = v.lane.local_coordinates(v.position)
    return v.speed * math.sin(v.heading - v.lane.heading_at(s))


def _off_segment(src) -> dict:
    """(slot, id) -> the offset of each vehicle on another segment than the slot's (on a
    straight lane) in lane widths, rounded: from highway-env's ``local_coordinates``."""
    from highway_env.road.lane import StraightLane

    out = {}
    for e, v in enumerate(src.vehicles):
        if type(v.lane) is not StraightLane:
            continue
        r_e = v.lane.local_coordinates(v.position)[1]
        for u in src.env.road.vehicles:
            if u.lane_index[:2] != v.lane_index[:2]:
                r = v.lane.local_coordinates(u.position)[1]
                out[e, src.id_of(u)] = round((r - r_e) / v.lane.width)
    return out


def record(cfg: HighwayConfig) -> list[Step]:
    from highway_env.road.lane import SineLane

    steps = []
    with HighwaySource(cfg) as src:
        world = HighwayWorld(src)
        while not world.done:
            road = src.env.road
            vs = road.vehicles
            steps.append(
                Step(
                    frame=world.frame(),
                    truth=src.frame(),
                    active=src.active,
                    reassigned=src.reassigned,
                    veh=np.array(
                        [(*v.position, v.heading, v.speed, v.LENGTH, v.WIDTH) for v in vs]
                    ),
                    vid=np.array([src.id_of(v) for v in vs]),
                    lanes=[v.lane_index for v in vs],
                    lateral=np.array([_across(v) for v in vs]),
                    obstacles=np.array(
                        [(*o.position, o.heading, o.LENGTH, o.WIDTH) for o in road.objects]
                    ).reshape(-1, 5),
                    slot_vid=np.array([src.id_of(v) for v in src.vehicles]),
                    kappa=np.array([_kappa(v.lane, v.position) for v in src.vehicles]),
                    on_sine=np.array([isinstance(v.lane, SineLane) for v in src.vehicles]),
                    off_segment=_off_segment(src),
                    dt=src.dt,
                )
            )
            world.advance()
    return steps


@pytest.fixture(scope="module")
def fast() -> list[Step]:
    return record(HighwayConfig("highway-fast-v0", episodes=2, duration=6.0, vehicles_count=8))


@pytest.fixture(scope="module")
def merge() -> list[Step]:
    return record(HighwayConfig("merge-v0", episodes=1, duration=12.0, seed=2))


def in_ego_frame(step: Step, e: int) -> dict:
    """Every vehicle and road object in slot ``e``'s field, rotated into its frame here:
    key the vehicle's id (road objects: ``("obstacle", k)``), value (x, y, vx, vy, heading)."""
    i = int(np.flatnonzero(step.vid == step.slot_vid[e])[0])
    x0, y0, h0, v0, length0, _ = step.veh[i]
    rot = np.array([[math.cos(h0), math.sin(h0)], [-math.sin(h0), math.cos(h0)]])
    bumper = np.array([x0, y0]) + 0.5 * length0 * np.array([math.cos(h0), math.sin(h0)])
    things = [(step.vid[j], *step.veh[j, :5]) for j in range(len(step.vid)) if j != i]
    for k, (x, y, h, length, _) in enumerate(step.obstacles):
        things.append((("obstacle", k), x, y, h, 0.0, length))
    out = {}
    for key, x, y, h, v, length in things:
        u = np.array([math.cos(h), math.sin(h)])
        faces = [np.array([x, y]) + sign * 0.5 * length * u for sign in (-1, 1)]
        q = min(faces, key=lambda f: np.linalg.norm(f - bumper))
        px, py = rot @ (q - bumper)
        if 0.0 <= px <= AHEAD and abs(py) <= LATERAL:
            vx, vy = rot @ (v * u) - np.array([v0, 0.0])
            out[key] = (px, py, vx, vy, math.atan2(math.sin(h - h0), math.cos(h - h0)))
    return out


def rows(frame: ObjectFrame, e: int) -> dict:
    """Slot ``e``'s objects by id: their column."""
    return {int(frame.object_id[e, k]): k for k in np.flatnonzero(frame.valid[e])}


@pytest.mark.parametrize("name", ["fast", "merge"])
def test_vehicles_and_road_objects_are_highway_envs_in_the_ego_frame(name, request):
    steps = request.getfixturevalue(name)
    checked = obstacles = changing = 0
    for step in steps:
        f = step.frame
        assert f.n_egos == step.active.size
        for e in range(f.n_egos):
            if not step.active[e]:
                assert not f.valid[e].any() and f.lead[e] == -1
                continue
            want, got = in_ego_frame(step, e), rows(f, e)
            vehicles = {k for k in got if f.kind[e, got[k]] == ObjectKind.VEHICLE}
            assert vehicles == {int(k) for k in want if not isinstance(k, tuple)}
            for oid in vehicles:
                across = step.lateral[step.vid == oid][0]
                assert f.lateral_speed[e, got[oid]] == pytest.approx(across, abs=1e-9)
                changing += abs(across) > 0.5
            for key, (x, y, vx, vy, heading) in want.items():
                if isinstance(key, tuple):  # the obstacle: the one 2 m wide guardrail object
                    ks = [k for k in got.values() if f.kind[e, k] == ObjectKind.GUARDRAIL
                          and f.width[e, k] == step.obstacles[key[1], 4]]  # fmt: skip
                    assert len(ks) == 1
                    k = ks[0]
                    obstacles += 1
                else:
                    k = got[int(key)]
                got_state = (f.x[e, k], f.y[e, k], f.vx[e, k], f.vy[e, k], f.heading[e, k])
                np.testing.assert_allclose(got_state, (x, y, vx, vy, heading), atol=1e-9)
                checked += 1
            ego = step.veh[step.vid == step.slot_vid[e]][0]
            assert f.ego_speed[e] == pytest.approx(ego[3])
            vehicle = f.valid[e] & (f.kind[e] == ObjectKind.VEHICLE)
            assert np.all(f.length[e, vehicle] == 5.0) and np.all(f.width[e, vehicle] == 2.0)
    assert checked > 200
    assert (changing > 0) == (name == "fast")  # lane changes (merge-v0's follow their lanes)
    assert (obstacles > 0) == (name == "merge")


def test_lead_frame_is_the_sources_truth_on_straight_lanes(fast):
    aligned = 0
    for step in fast:
        lead = step.frame.lead_frame()
        for e in np.flatnonzero(step.active):
            leader = step.truth.leader_id[e]
            if leader < 0 or leader not in in_ego_frame(step, e):
                assert lead.leader_id[e] == -1
                continue
            assert lead.leader_id[e] == leader
            i = int(np.flatnonzero(step.vid == step.slot_vid[e])[0])
            j = int(np.flatnonzero(step.vid == leader)[0])
            if step.veh[i, 2] == 0.0 and step.veh[j, 2] == 0.0:  # both along the lane
                np.testing.assert_allclose(
                    [lead.gap[e], lead.lead_speed[e], lead.lead_accel[e], lead.lateral_offset[e]],
                    [step.truth.gap[e], step.truth.lead_speed[e], step.truth.lead_accel[e],
                     step.truth.lateral_offset[e]],
                    atol=1e-9,
                )  # fmt: skip
                assert lead.ego_speed[e] == pytest.approx(step.truth.ego_speed[e], abs=1e-12)
                aligned += 1
    assert aligned > 50


def test_the_higher_lane_id_is_to_the_left(fast):
    """highway-env puts lane k at y = 4k (drawn downward); read right-handed, the higher id is
    to the left: positive ``lane`` and positive ``y``."""
    seen = set()
    for step in fast:
        f = step.frame
        for e in np.flatnonzero(step.active):
            i = int(np.flatnonzero(step.vid == step.slot_vid[e])[0])
            for oid, k in rows(f, e).items():
                if f.kind[e, k] != ObjectKind.VEHICLE:
                    continue
                j = int(np.flatnonzero(step.vid == oid)[0])
                assert f.lane[e, k] == step.lanes[j][2] - step.lanes[i][2]  # one segment
                centred = step.veh[i, 1] % 4.0 == 0.0 and step.veh[j, 1] % 4.0 == 0.0
                if centred and step.veh[i, 2] == 0.0 and f.lane[e, k] != 0:
                    assert f.y[e, k] == pytest.approx(4.0 * f.lane[e, k])
                    seen.add(int(np.sign(f.lane[e, k])))
    assert seen == {-1, 1}


def test_lane_off_the_egos_segment_is_the_rounded_offset(merge):
    checked, lanes = 0, set()
    for step in merge:
        f = step.frame
        for (e, oid), want in step.off_segment.items():
            k = rows(f, e).get(oid)
            if step.active[e] and k is not None:
                assert f.lane[e, k] == want
                checked += 1
                lanes.add(want)
    assert checked > 20 and max(lanes) >= 2  # the ramp: lanes to the left of the motorway


def test_sine_lane_curvature_is_the_derivative_of_its_heading(merge):
    on_sine = 0
    for step in merge:
        act = step.active
        kappa = step.frame.road_curvature
        sine = act & step.on_sine
        np.testing.assert_allclose(kappa[sine], step.kappa[sine], rtol=1e-3, atol=1e-7)
        assert np.all(kappa[act & ~step.on_sine] == 0.0)
        on_sine += int(sine.sum())
        assert np.all(np.abs(kappa[sine]) > 0) or not sine.any()
    assert on_sine >= 10
    # the ramp turns right (towards the motorway) first, then left into the merge lane
    signs = {
        int(np.sign(s.frame.road_curvature[e]))
        for s in merge
        for e in np.flatnonzero(s.on_sine & s.active)
    }
    assert signs == {-1, 1}


def test_a_circular_lane_has_its_curvature_and_a_relative_lane():
    """A lane type the supported environments lack, put on the road by hand: its geometry is
    highway-env's own (curvature 1/R, left positive where highway-env's ``direction`` is +1)."""
    from highway_env.road.lane import CircularLane

    cfg = HighwayConfig("highway-fast-v0", episodes=1, duration=1.0, vehicles_count=2)
    with HighwaySource(cfg) as src:
        world = HighwayWorld(src)
        # a left turn of 1 km radius leaving the road's lane 1 at x = 100 m
        lane = CircularLane([100.0, 1004.0], 1000.0, -np.pi / 2, 0.0, clockwise=True)
        src.env.road.network.add_lane("p", "q", lane)
        ego = src.vehicles[0]
        ego.position, ego.heading = lane.position(40.0, 0.5), lane.heading_at(40.0)
        ego.lane_index, ego.lane = ("p", "q", 0), lane
        frame = world.frame()
        assert frame.road_curvature[0] == pytest.approx(0.001)
        assert frame.road_curvature[0] == pytest.approx(_kappa(lane, ego.position), rel=1e-4)
        # the other vehicles, on the straight road: offsets in the circle's own coordinates
        seen = {i: k for i, k in rows(frame, 0).items() if frame.kind[0, k] == ObjectKind.VEHICLE}
        for oid, k in seen.items():
            u = next(v for v in src.env.road.vehicles if src.id_of(v) == oid)
            r = lane.local_coordinates(u.position)[1] - 0.5
            assert frame.lane[0, k] == round(r / lane.width)
        assert seen


def test_yaw_rate_is_the_heading_change_of_the_slots_vehicle(fast):
    turning = 0
    for prev, step in zip(fast, fast[1:], strict=False):
        yaw = step.frame.ego_yaw_rate
        assert np.all(yaw[~step.active | step.reassigned] == 0.0)
        for e in np.flatnonzero(step.active & ~step.reassigned):
            h = step.veh[step.vid == step.slot_vid[e], 2][0]
            h0 = prev.veh[prev.vid == prev.slot_vid[e], 2][0]
            want = math.atan2(math.sin(h - h0), math.cos(h - h0)) / step.dt
            assert yaw[e] == pytest.approx(want, abs=1e-9)
            turning += abs(want) > 0.01
    assert turning > 0
    assert np.all(fast[0].frame.ego_yaw_rate == 0.0)
    assert sum(s.reassigned.all() for s in fast) == 2  # both episodes' first frames


def test_merge_obstacle_is_a_stationary_guardrail_object_on_a_lane(merge):
    seen = 0
    for step in merge:
        f = step.frame
        hit = f.valid & (f.kind == ObjectKind.GUARDRAIL) & (f.width == 2.0)
        for e, k in zip(*np.nonzero(hit), strict=True):
            assert f.speed[e, k] == 0.0 and f.vx[e, k] == -f.ego_speed[e] and f.vy[e, k] == 0.0
            assert f.lane[e, k] != OFF_ROAD and f.stationary[e, k]
            seen += 1
    assert seen > 0


def test_roadside_posts_line_both_edges_and_stand_on_no_lane():
    for env, kw in (("merge-v0", {}), ("highway-fast-v0", {"vehicles_count": 3})):
        cfg = HighwayConfig(env, episodes=1, duration=1.0, **kw)
        with HighwaySource(cfg) as src:
            world = HighwayWorld(src)
            side = world.roadside
            posts = side.kind == ObjectKind.GUARDRAIL
            lanes = [x for tos in src.env.road.network.graph.values() for ls in tos.values()
                     for x in ls]  # fmt: skip
            main_road = next(iter(next(iter(src.env.road.network.graph.values())).values()))
            top = max(lane.start[1] for lane in main_road)  # lane ids grow with y
            # right of lane 0's edge and left of the top lane's edge
            assert np.any(posts & (side.y < -2.0)) and np.any(posts & (side.y > top + 2.0))
            for x, y in zip(side.x[posts], side.y[posts], strict=True):
                for lane in lanes:
                    s, r = lane.local_coordinates(np.array([x, y]))
                    assert not (abs(r) <= lane.width / 2 and 0 <= s <= lane.length)
            frame = world.frame()
            seen = frame.valid & (frame.kind == ObjectKind.GUARDRAIL) & (frame.width < 1.0)
            assert seen.any() and np.all(frame.lane[seen] == OFF_ROAD)
            if env == "highway-fast-v0":  # 10 km of road: gantries every 2 km, 5.18 m clear
                gantry = side.kind == ObjectKind.GANTRY
                assert gantry.sum() == 5 and np.all(side.elevation[gantry] == 5.18)
            again = HighwayWorld(src).roadside  # the same episode: the same placement
            np.testing.assert_array_equal(again.x, side.x)
            other = ObjectFieldConfig(roadside=RoadsideConfig(seed=1, min_speed=0.0))
            assert not np.array_equal(HighwayWorld(src, other).roadside.x, side.x)


def test_simulate_world_runs_on_highway_env_open_and_closed_loop():
    cfg = HighwayConfig("highway-fast-v0", episodes=1, duration=4.0, vehicles_count=5)
    with HighwaySource(cfg) as src:
        result = simulate_world(SimConfig(runs=1, dt=src.dt), source=HighwayWorld(src))
    assert set(result.summaries) == {"radar", "infrared", "centralized", "federated"}
    for method, s in result.summaries.items():
        assert s.km > 0, method
        for c in ("crash_relevant", "nuisance", "sensing_false"):
            assert sum(s.by_cause[c].values()) == getattr(s, c), (method, c)
    with HighwaySource(cfg) as src:  # the drivers hear the federated warnings
        closed = SimConfig(runs=1, dt=src.dt, drive="federated")
        result = simulate_world(closed, source=HighwayWorld(src))
    assert result.summaries["federated"].km > 0 and result.collided.shape == (6,)


def test_brake_requests_reach_the_slots_vehicles():
    cfg = HighwayConfig("highway-fast-v0", episodes=1, duration=2.0, vehicles_count=3)
    with HighwaySource(cfg) as src:
        world = HighwayWorld(src)
        before = np.array([v.speed for v in src.vehicles])
        world.advance(np.array([4.0, 0.0, 0.0, 0.0]))
        assert src.vehicles[0].speed == pytest.approx(before[0] - 4.0 * src.dt)
        assert world.frame().ego_speed[0] == pytest.approx(before[0] - 4.0 * src.dt)
        assert world.t == pytest.approx(src.dt) and world.n_steps == src.n_steps


def test_a_restarted_episode_gets_its_own_frame_at_the_same_time():
    """``restart`` starts a new episode without advancing the time: the frame is the new
    episode's, its ego motion starting afresh."""
    cfg = HighwayConfig("highway-fast-v0", episodes=3, duration=2.0, vehicles_count=3)
    with HighwaySource(cfg) as src:
        world = HighwayWorld(src)
        world.advance()
        before = world.frame()
        src.restart(np.ones(src.n_pairs, dtype=bool), 7)
        after = world.frame()
        assert after is not before and after.t == before.t
        speeds = [v.speed for v in src.vehicles]
        np.testing.assert_allclose(after.ego_speed[: len(speeds)], speeds)
        assert not after.ego_yaw_rate.any() and not after.ego_accel.any()


def test_highway_world_command_prints_and_writes_the_tables(tmp_path, capsys):
    args = ["highway", "--world", "--env", "highway-fast-v0", "--episodes", "1", "--duration",
            "2", "--vehicles", "3", "--conditions", "day", "night+fog=60",
            "--out", str(tmp_path)]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    for title in (
        "Alerts by class, highway-fast-v0, day (judged from truth)",
        "Alerts by class, highway-fast-v0, night, fog 60 m",
        "Nuisance and sensing-false alerts by cause, highway-env highway-fast-v0",
    ):
        assert title in out
    stem = "highway_world_highway-fast-v0_seed0"
    data = json.loads((tmp_path / f"{stem}.json").read_text())
    assert data["env"] == "highway-fast-v0" and data["episodes"] == 1
    for label in ("day", "night, fog 60 m"):
        for s in data[label].values():
            assert s["km"] > 0 and set(s["by_cause"]) >= {"nuisance", "sensing_false"}
    for name in ("causes", "cause_rates", "classes_0", "classes_1"):
        assert (tmp_path / f"{stem}_{name}.csv").stat().st_size > 0
    assert (tmp_path / f"{stem}_causes.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--conditions", "day"], "add --world"),
        (["--world", "--render", "x.gif"], "drop --render"),
        (["--world", "--set", "drive=federated"], "remove drive"),
        (["--world", "--conditions", "dusk"], "--conditions takes"),
    ],
)
def test_bad_world_flags_are_one_sentence_errors(extra, message, capsys):
    assert main(["highway", "--env", "highway-fast-v0", "--episodes", "1", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


def test_an_empty_field_and_the_end_of_the_run():
    bare = RoadsideConfig(gantry_spacing=0.0, guardrail_spacing=0.0, parked_per_km=0.0)
    cfg = HighwayConfig("highway-fast-v0", episodes=1, duration=0.4, vehicles_count=0)
    with HighwaySource(cfg) as src:  # the controlled vehicle alone on a bare road
        world = HighwayWorld(src, ObjectFieldConfig(roadside=bare))
        frame = world.frame()
        assert world.active.all() and frame.max_objects == 0 and frame.lead[0] == -1
        assert frame.lead_frame().leader_id[0] == -1
        while not world.done:
            world.advance()
        frame = world.frame()  # after the last episode: every slot inactive
        assert not world.active.any() and frame.ego_speed[0] == 0.0 and frame.max_objects == 0


def test_bad_sources_and_configs_are_refused():
    cfg = HighwayConfig("highway-fast-v0", episodes=1, duration=1.0, vehicles_count=2)
    with pytest.raises(ConfigError, match="HighwaySource"):
        HighwayWorld(object())
    with HighwaySource(cfg) as src:
        with pytest.raises(ConfigError, match="ObjectFieldConfig"):
            HighwayWorld(src, RoadsideConfig())
    with pytest.raises(ConfigError, match="closed"):
        HighwayWorld(src)
