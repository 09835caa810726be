"""2-D object truth from SUMO (acc_fusion.truth.sumo.objects) on a straight motorway: the lead is
SUMO's leader at the 1-D gap, relative lanes, the forward field, stationary objects, stable ids,
the roadside placement and its config.  One short SUMO run (45 s + 4 recorded steps) serves
every test of the module."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

libsumo = pytest.importorskip("libsumo")

from acc_fusion.cli.main import build_parser, main  # noqa: E402
from acc_fusion.cli.sumo import run as sumo_command  # noqa: E402
from acc_fusion.core.errors import ConfigError, InputError  # noqa: E402
from acc_fusion.sim.world import LANE_CHANGE_SPEED  # noqa: E402
from acc_fusion.truth.objects import OFF_ROAD, ObjectFrame, ObjectKind  # noqa: E402
from acc_fusion.truth.sumo.config import SumoConfig  # noqa: E402
from acc_fusion.truth.sumo.nets import bundled_nets  # noqa: E402
from acc_fusion.truth.sumo.object_kernels import _path_offset  # noqa: E402
from acc_fusion.truth.sumo.objects import (  # noqa: E402
    LANE_CHANGE_DURATION,
    ObjectFieldConfig,
    SumoObjects,
)
from acc_fusion.truth.sumo.roadside import (  # noqa: E402
    ROADSIDE_ID_BASE,
    LaneTable,
    RoadsideConfig,
    _lane_geometry,
    curvature_at,
    place_roadside,
)
from acc_fusion.truth.sumo.source import SumoSource  # noqa: E402
from acc_fusion.truth.sumo.world import SumoWorld  # noqa: E402

#: A straight motorway (the former bundled one: one edge per direction, along x), where the
#: objects' positions are differences of SUMO's coordinates.
STRAIGHT = Path(__file__).parent / "data" / "straight_motorway" / "straight.sumocfg"

#: Straight-road tolerance of positions [m]: x and the gap are differences of the same SUMO
#: coordinates (below 5 km, rounding about 1e-12 m); 1 µm leaves room for float sums.
TOL = 1e-6


@pytest.fixture(scope="module")
def run():
    """Frames of 4 consecutive steps after 45 s, with SUMO's own view of each step."""
    config = SumoConfig(str(STRAIGHT), end=60, seed=3)
    with SumoSource(config) as src:
        objects = SumoObjects(src)
        for _ in range(450):
            src.advance()
        steps = []
        for _ in range(4):
            src.advance()
            frame = objects.frame()
            veh = libsumo.vehicle
            state = {
                src._info[v][0]: (v, veh.getRoadID(v), veh.getLaneIndex(v), veh.getPosition(v))
                for v in veh.getIDList()
            }
            leaders = {
                slot: src.leader_of(v) for slot, v in enumerate(src.vehicle_ids) if v is not None
            }
            steps.append((frame, src.frame(), list(src.vehicle_ids), state, leaders))
        return {"steps": steps, "lanes": objects.lanes, "roadside": objects.roadside,
                "dt": src.dt, "info": dict(src._info)}  # fmt: skip


def test_the_frame_validates_and_empty_slots_have_nothing(run):
    frame, truth, vids, _, _ = run["steps"][-1]
    assert isinstance(frame, ObjectFrame) and frame.n_egos == truth.n_pairs
    empty = np.array([v is None for v in vids])
    assert empty.any() and not frame.valid[empty].any() and np.all(frame.lead[empty] == -1)
    assert frame.valid[~empty].sum(axis=1).mean() > 5
    assert np.all(frame.x[frame.valid] >= 0) and np.all(frame.x[frame.valid] <= 200)
    assert np.all(np.abs(frame.y[frame.valid]) <= 15)


def test_the_lead_is_sumo_s_leader_at_the_gap(run):
    info = run["info"]
    for frame, truth, _, _, leaders in run["steps"]:
        one_d = frame.lead_frame()
        n_checked = 0
        for slot, leader in leaders.items():
            if leader is None or truth.gap[slot] > 200.0:
                assert frame.lead[slot] == -1
                continue
            n_checked += 1
            assert one_d.leader_id[slot] == info[leader][0] == truth.leader_id[slot]
            # Straight lanes: the rear face's x is the bumper-to-bumper gap.
            assert one_d.gap[slot] == pytest.approx(truth.gap[slot], abs=TOL)
            assert one_d.lead_speed[slot] == truth.lead_speed[slot]
        assert n_checked > 50


def test_relative_lanes_from_sumo_s_lane_indices(run):
    frame, _, vids, state, _ = run["steps"][-1]
    seen = set()
    for slot, vid in enumerate(vids):
        if vid is None:
            continue
        ego = state[run["info"][vid][0]]
        for k in np.flatnonzero(frame.valid[slot]):
            if frame.kind[slot, k] != ObjectKind.VEHICLE:
                assert frame.lane[slot, k] == OFF_ROAD
                continue
            other = state[frame.object_id[slot, k]]
            assert other[1] == ego[1]  # the motorway has one edge per direction
            assert frame.lane[slot, k] == other[2] - ego[2]
            # Lanes are 3.5 m apart: the lateral offset says the same.
            assert frame.y[slot, k] == pytest.approx(3.5 * frame.lane[slot, k], abs=TOL)
            seen.add(int(frame.lane[slot, k]))
    assert {-1, 0, 1} <= seen


def test_vehicles_behind_are_not_in_the_field_and_those_ahead_are(run):
    frame, _, vids, state, _ = run["steps"][-1]
    checked = 0
    for slot, vid in enumerate(vids):
        if vid is None:
            continue
        _, edge, _, (ex, ey) = state[run["info"][vid][0]]
        sign = 1.0 if edge == "east" else -1.0  # east drives towards +x, west towards -x
        ids = set(frame.object_id[slot, frame.valid[slot]].tolist())
        for oid, (_, o_edge, _, (ox, _)) in state.items():
            if o_edge != edge or oid == run["info"][vid][0]:
                continue
            ahead = sign * (ox - ex)  # front bumper to front bumper
            if ahead < 0:  # its front is behind ours: its rear too
                assert oid not in ids
                checked += 1
            elif 20.0 < ahead < 190.0:  # its rear face (length < 20 m) is in the field
                assert oid in ids
    assert checked > 100


def test_stationary_objects_stand_still_at_minus_ego_speed(run):
    frame, _, _, _, _ = run["steps"][-1]
    still = frame.valid & frame.stationary
    assert still.sum() > 100  # guardrail posts at least
    assert np.all(frame.speed[still] == 0.0) and np.all(frame.object_id[still] >= ROADSIDE_ID_BASE)
    ego = np.broadcast_to(frame.ego_speed[:, None], still.shape)[still]
    assert np.allclose(frame.vx[still], -ego, atol=1e-9)
    assert np.allclose(frame.vy[still], 0.0, atol=1e-9)
    assert np.all(frame.lane[still] == OFF_ROAD)
    gantry = still & (frame.kind == ObjectKind.GANTRY)
    assert np.all(frame.elevation[gantry] == 5.18)
    # A straight road: no yaw, no curvature.
    assert np.all(frame.ego_yaw_rate == 0.0) and np.all(frame.road_curvature == 0.0)


def test_ids_are_stable_and_positions_continue_over_steps(run):
    dt = run["dt"]
    steps = run["steps"]
    for (a, _, vids_a, _, _), (b, _, vids_b, _, _) in zip(steps, steps[1:], strict=False):
        matched = 0
        for slot, vid in enumerate(vids_b):
            if vid is None or vids_a[slot] != vid:
                continue
            seen = a.valid[slot]
            before = dict(zip(a.object_id[slot][seen], a.x[slot][seen], strict=True))
            for k in np.flatnonzero(b.valid[slot]):
                oid = b.object_id[slot, k]
                if oid in before:  # SUMO's Euler step: x' = x + v' dt for both vehicles
                    assert b.x[slot, k] - before[oid] == pytest.approx(b.vx[slot, k] * dt, abs=TOL)
                    matched += 1
        assert matched > 1000


def test_the_compiled_reader_and_libsumo_s_getters_give_the_same_frames():
    frames = []
    for native in (True, False):
        config = SumoConfig(str(bundled_nets()["motorway"]), end=20, seed=5, native=native)
        with SumoSource(config) as src:
            objects = SumoObjects(src, ObjectFieldConfig(ahead=120.0, lateral=8.0, map_path=True))
            assert (objects._native is not None) == native
            for _ in range(150):
                src.advance()
                frame = objects.frame()
            assert objects.frame() is frame  # asked again in the step: the same frame
            frames.append(frame)
    a, b = frames
    assert a.valid.sum() > 100 and np.all(a.x[a.valid] <= 120) and np.all(np.abs(a.y[a.valid]) <= 8)
    for name in ObjectFrame.__dataclass_fields__:
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name


def test_the_frame_of_a_prefix_of_slots_is_the_head_of_the_whole_frame():
    """Two object truths of one source, one asked for every slot, the other for the prefix
    that holds the egos (the pipeline's way): the same frames, yaw rates included (their
    memory of the slots beyond the prefix), and the same frame when asked again in the step."""
    config = SumoConfig(str(bundled_nets()["ring"]), end=40, seed=4, capacity=256)
    with SumoSource(config) as src:
        a, b = SumoObjects(src), SumoObjects(src)
        prefixes, turning = set(), 0
        while not src.done:
            src.advance()
            active = src.active
            top = int(np.flatnonzero(active)[-1]) + 1 if active.any() else 0
            k = top + int(src.t) % 3  # prefixes longer than the egos' too
            full, head = a.frame(), b.frame(k)
            prefixes.add(k)
            assert head.n_egos == k and b.frame(k) is head
            again = b.frame(top)  # asked again in the step, for fewer slots: a view
            assert again.n_egos == top and np.shares_memory(again.x, head.x) == (top > 0)
            if int(src.t) % 5 == 0:  # and for more: made anew, the same as the whole's
                head = b.frame(k + 7)
            cut = full.head(head.n_egos)
            for name in ObjectFrame.__dataclass_fields__:
                assert np.array_equal(getattr(cut, name), getattr(head, name), equal_nan=True)
            empty = ~head.valid  # what a slot without an object holds
            assert np.isnan(head.x[empty]).all() and np.isnan(head.rcs[empty]).all()
            assert (head.object_id[empty] == -1).all() and (head.kind[empty] == 0).all()
            assert (head.lane[empty] == OFF_ROAD).all()
            assert (head.lead[~head.valid.any(axis=1)] == -1).all()
            turning += int(np.count_nonzero(head.ego_yaw_rate))
        assert len(prefixes) >= 3 and turning > 1000, (prefixes, turning)
        with pytest.raises(InputError, match="leaves out active slots"):
            b.frame(0)
        with pytest.raises(InputError, match="egos must be an integer"):
            b.frame(True)
        with pytest.raises(InputError, match="egos must be an integer"):
            b.frame(config.capacity + 1)


def test_a_frame_before_any_vehicle_is_empty():
    config = SumoConfig(str(bundled_nets()["ring"]), end=10, seed=2, capacity=8)
    with SumoSource(config) as src:  # the ring's vehicles depart after its first step
        frame = SumoObjects(src).frame()
    assert frame.n_egos == 8 and frame.max_objects == 0 and (frame.lead == -1).all()


def test_on_the_ring_curvature_and_yaw_rate_follow_the_circle():
    radius = 366.06  # the ring's centreline, counter-clockwise: a left turn
    config = SumoConfig(str(bundled_nets()["ring"]), end=30, seed=2)
    with SumoSource(config) as src:
        objects = SumoObjects(src)
        yaw, expected, curvature = [], [], []
        for _ in range(200):
            src.advance()
            frame = objects.frame()
            road = [libsumo.vehicle.getRoadID(v) if v else "" for v in src.vehicle_ids]
            on_edge = np.array([r.startswith("ring") for r in road])  # not in a junction
            curvature.append(frame.road_curvature[on_edge])
            yaw.append(frame.ego_yaw_rate[on_edge])
            expected.append(frame.ego_speed[on_edge] / radius)
        # A one-lane road gets no roadside objects.
        assert len(objects.roadside) == 0 and frame.valid.sum() > 50
    curvature = np.concatenate(curvature)
    # 5 degree chords (0.03 % high), the two at a lane's ends shortened by the junctions.
    assert np.allclose(curvature, 1.0 / radius, rtol=1e-2)
    # The heading turns by 5 degrees at each chord's end: the mean yaw rate is v / R.
    yaw, expected = np.concatenate(yaw), np.concatenate(expected)
    assert np.mean(yaw) == pytest.approx(np.mean(expected), rel=0.03)


def test_roadside_placement_is_reproducible_from_its_seed(run):
    lanes, placed = run["lanes"], run["roadside"]
    again = place_roadside(lanes, RoadsideConfig())
    for name in ("object_id", "kind", "x", "y", "heading"):
        assert np.array_equal(getattr(again, name), getattr(placed, name))
    other = place_roadside(lanes, RoadsideConfig(seed=1, parked_per_km=5.0))
    assert not np.array_equal(other.x[: len(placed)], placed.x[: len(other)])
    # Two 5 km carriageways: a post every 25 m on each, about one parked car per 2 km.
    assert placed.count(ObjectKind.GUARDRAIL) == 400
    assert 2 <= placed.count(ObjectKind.GANTRY) <= 6 and placed.count(ObjectKind.BRIDGE) == 0
    assert other.count(ObjectKind.PARKED) > placed.count(ObjectKind.PARKED)
    east = placed.y < 0  # the east carriageway lies south of the axis (right-hand traffic)
    assert np.all(np.isin(placed.y[east & (placed.kind == ObjectKind.GUARDRAIL)], -13.0))
    bridges = place_roadside(lanes, RoadsideConfig(bridge_spacing=1000.0))
    assert bridges.count(ObjectKind.BRIDGE) == 10


def _table(lanes: dict[str, list[np.ndarray]]) -> LaneTable:
    """A :class:`LaneTable` of edges given as their lanes' polylines (3.5 m wide, 36 m/s)."""
    shapes = [shape for edge in lanes.values() for shape in edge]
    geometry = [_lane_geometry(shape) for shape in shapes]
    counts = [len(edge) for edge in lanes.values()]
    sizes = [len(shape) for shape in shapes]
    return LaneTable(
        edge_code={e: i for i, e in enumerate(lanes)}, edge_ids=tuple(lanes),
        first_lane=np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64),
        n_lanes=np.array(counts, np.int64), internal=np.zeros(len(lanes), bool),
        width=np.full(len(shapes), 3.5), speed=np.full(len(shapes), 36.0),
        start=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
        vx=np.concatenate([sh[:, 0] for sh in shapes]),
        vy=np.concatenate([sh[:, 1] for sh in shapes]),
        vs=np.concatenate([g[0] for g in geometry]), vh=np.concatenate([g[1] for g in geometry]),
    )  # fmt: skip


def test_no_guardrail_post_or_parked_car_stands_in_a_diverging_ramps_lane():
    """A 1 km two-lane carriageway with an exit ramp leaving beside its right lane at 400 m
    and swinging 60 m out over 300 m: the shoulder objects along the ramp's first 30 m,
    where it runs over the shoulder, are left out; the others stay, the posts 4.25 m right of
    the right lane's centre."""
    x = np.linspace(0.0, 1000.0, 201)
    main = [np.column_stack([x, np.zeros_like(x)]), np.column_stack([x, np.full_like(x, 3.5)])]
    t = np.linspace(0.0, 1.0, 61)
    ramp = np.column_stack([400.0 + 300.0 * t, -3.5 - 60.0 * (3 * t**2 - 2 * t**3)])
    lanes = _table({"main": main, "exit": [ramp]})
    placed = place_roadside(lanes, RoadsideConfig(parked_per_km=20.0))
    shoulder = np.isin(placed.kind, [ObjectKind.GUARDRAIL, ObjectKind.PARKED])
    posts = placed.kind == ObjectKind.GUARDRAIL
    assert np.allclose(placed.y[posts], -4.25)
    crossing = (placed.x > 400.0) & (placed.x < 430.0)
    assert shoulder.sum() > 40 and not (shoulder & crossing).any()
    assert (shoulder & (placed.x > 450.0)).sum() > 20
    everywhere = place_roadside(_table({"main": main}), RoadsideConfig(parked_per_km=20.0))
    assert everywhere.count(ObjectKind.GUARDRAIL) > placed.count(ObjectKind.GUARDRAIL)


def test_lane_curvature_of_an_arc_is_its_inverse_radius():
    radius = 500.0
    phi = np.linspace(0.0, 0.5, 251)  # a vertex per metre
    arc = np.column_stack([radius * np.sin(phi), radius * (1 - np.cos(phi))])  # turning left
    for sign in (1.0, -1.0):  # the mirrored arc turns right
        s, heading = _lane_geometry(arc * [1.0, sign])
        assert s[-1] == pytest.approx(radius * 0.5, rel=1e-4)
        pos = np.array([0.0, 5.0, 100.0, s[-1]])
        start = np.array([0, len(s)])
        kappa = curvature_at(np.zeros(4, np.int64), pos, start, s, heading)
        assert np.allclose(kappa, sign / radius, rtol=1e-6)
    assert curvature_at(np.array([-1]), np.zeros(1), start, s, heading)[0] == 0.0


def test_the_lateral_offset_from_a_curved_path():
    """Off the ego's edge the relative lane is the offset from the circle of the ego's road
    curvature, in lane widths."""
    assert _path_offset(150.0, 3.5, 0.0) == 3.5  # straight: y itself
    radius, phi = 400.0, 0.6
    for kappa, sign in ((1 / radius, 1.0), (-1 / radius, -1.0)):
        # A point 3.5 m inside (left of) a left turn, right of a right turn, 240 m along it.
        r = radius - 3.5
        x, y = r * np.sin(phi), sign * (radius - r * np.cos(phi))
        assert _path_offset(x, y, kappa) == pytest.approx(sign * 3.5, abs=1e-9)
    # Near the origin: y - kappa x^2 / 2.
    assert _path_offset(20.0, 1.0, 1e-4) == pytest.approx(1.0 - 1e-4 * 200.0, abs=1e-5)


@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: ObjectFieldConfig(ahead=-1.0), "field.ahead"),
        (lambda: ObjectFieldConfig(lateral=float("nan")), "field.lateral"),
        (lambda: ObjectFieldConfig(roadside={"seed": 1}), "field.roadside"),
        (lambda: RoadsideConfig(guardrail_spacing=0.5), "roadside.guardrail_spacing"),
        (lambda: RoadsideConfig(seed=-1), "roadside.seed"),
        (lambda: RoadsideConfig(parked_per_km="many"), "roadside.parked_per_km"),
    ],
)
def test_bad_config_is_a_one_line_error(make, name):
    with pytest.raises(ConfigError) as err:
        make()
    assert str(err.value).startswith(name) and "\n" not in str(err.value)


def test_the_world_benchmark_runs_and_ends_with_the_overhead_ratio():
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(root)}  # this checkout's package in the workers
    motorway = str(bundled_nets()["motorway"])
    cmd = [sys.executable, str(root / "scripts" / "bench_world.py"), "--sumocfg", motorway]
    cmd += ["--end", "40", "--warmup", "35"]
    out = subprocess.run(
        [*cmd, "--sample", "1"], capture_output=True, text=True, timeout=300, check=True, env=env
    ).stdout
    lines = out.strip().splitlines()
    assert "50 steps" in lines[0] and lines[-1].startswith("overhead_ratio=")
    assert float(lines[-1].split("=")[1]) > 1.0 and "objects per ego" in out
    # Memory against traffic: one sample per simulated second, fitted (finite figures).
    fit = [line for line in lines if line.strip().startswith("pipeline ") and "MB/h" in line]
    assert len(fit) == 1 and "5 samples" in fit[0] and "nan" not in fit[0]
    bad = subprocess.run([*cmd[:2], "--warmup", "50", "--end", "40"], capture_output=True,
                         text=True, timeout=60, env=env)  # fmt: skip
    assert bad.returncode == 2 and "--warmup < --end" in bad.stderr


def test_a_lane_change_gives_lateral_speed_for_the_lane_change_duration():
    config = SumoConfig(str(bundled_nets()["motorway"]), end=120, seed=3)
    with SumoSource(config) as src:
        world = SumoWorld(src)
        moving: dict[int, dict[float, float]] = {}  # object id -> {t: lateral speed}
        while not world.done:
            world.advance()
            frame = world.frame()
            side = frame.valid & (frame.lateral_speed != 0)
            for oid, v in zip(frame.object_id[side], frame.lateral_speed[side], strict=True):
                moving.setdefault(int(oid), {})[frame.t] = float(v)
        dt = src.dt
    assert moving, "no lane change in 120 s of motorway"
    speeds = np.abs([v for seen in moving.values() for v in seen.values()])
    assert np.all((speeds > LANE_CHANGE_SPEED) & (speeds < 1.0))  # w / 4.6 s, w about 3-4 m
    # a lane change lasts LANE_CHANGE_DURATION: seen moving sideways over several steps (a
    # vehicle may change lanes again meanwhile)
    assert max(map(len, moving.values())) >= round(LANE_CHANGE_DURATION / dt)


def test_an_egos_lane_change_is_its_sideways_shift_and_every_object_moves_by_it():
    """On the straight motorway an ego that changes lanes within a step sees every object that
    kept its lane move sideways by minus its ``ego_shift``, the distance between the two lanes'
    centrelines; an ego that kept its lane has no shift and sees them keep their offsets."""
    config = SumoConfig(str(STRAIGHT), end=120, seed=3)
    shifted, kept = [], []
    with SumoSource(config) as src:
        world = SumoWorld(src)
        world.advance()
        a, ids_a = world.frame(), list(src.vehicle_ids)
        while not world.done:
            world.advance()
            b, ids_b = world.frame(), list(src.vehicle_ids)
            for e in range(min(a.n_egos, b.n_egos)):
                if ids_b[e] is None or ids_a[e] != ids_b[e]:
                    continue
                before = dict(zip(a.object_id[e][a.valid[e]], a.y[e][a.valid[e]], strict=True))
                still = b.valid[e] & (b.lateral_speed[e] == 0)  # not changing lanes themselves
                moved = [b.y[e, k] - before[o] for k, o in zip(np.flatnonzero(still),
                         b.object_id[e][still], strict=True) if o in before]  # fmt: skip
                if moved:
                    (shifted if b.ego_shift[e] else kept).append((b.ego_shift[e], moved))
            a, ids_a = b, ids_b
    assert len(shifted) >= 3, "too few egos changed lanes in 120 s"
    for shift, moved in shifted:
        assert abs(shift) == pytest.approx(3.5)  # the straight net's lanes are 3.5 m wide
        np.testing.assert_allclose(moved, -shift, atol=TOL)
    assert all(np.allclose(moved, 0.0, atol=TOL) for _, moved in kept)


def test_a_simulation_whose_lane_changes_take_time_gives_no_shift():
    config = SumoConfig(str(STRAIGHT), end=40, seed=3, extra_args=("--lanechange.duration", "3"))
    with SumoSource(config) as src:
        world = SumoWorld(src)
        shifts = []
        while not world.done:
            world.advance()
            shifts.append(np.abs(world.frame().ego_shift).max(initial=0.0))
    assert not world.objects._jumps and max(shifts) == 0.0


def test_sumo_world_command_prints_the_tables_and_every_warning_has_a_cause(tmp_path, capsys):
    args = ["sumo", "--open-loop", "--net", "motorway", "--end", "45", "--warmup", "60",
            "--conditions", "day",
            "night+fog=60", "--out", str(tmp_path)]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    for title in ("Alerts by class, motorway, day", "Alerts by class, motorway, night, fog 60 m",
                  "Nuisance and sensing-false alerts by cause, SUMO motorway"):  # fmt: skip
        assert title in out
    data = json.loads((tmp_path / "sumo_world_motorway_seed0.json").read_text())
    for label in ("day", "night, fog 60 m"):
        assert_causes_add_up(data[label], label)
    for name in ("causes.csv", "cause_rates.csv"):
        assert (tmp_path / f"sumo_world_motorway_seed0_{name}").exists()
    assert (tmp_path / "sumo_world_motorway_seed0_causes.png").read_bytes()[:4] == b"\x89PNG"


def test_conditions_need_the_world():
    args = build_parser().parse_args(["sumo", "--net", "motorway", "--pair", "--conditions", "day"])
    with pytest.raises(ConfigError, match="drop --pair"):
        sumo_command(args)


def test_sumo_world_closed_loop_prints_the_study_with_the_causes(tmp_path, capsys):
    args = ["sumo", "--net", "motorway", "--end", "40", "--warmup", "60",
            "--conditions", "fog=60", "--out", str(tmp_path)]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    for title in ("Alert classes (judged from truth), motorway.sumocfg",
                  "Nuisance and sensing-false alerts by cause, SUMO motorway, FCW off",
                  "Crashes FCW avoids, motorway.sumocfg"):  # fmt: skip
        assert title in out
    assert "day, fog 60 m" in out
    data = json.loads((tmp_path / "sumo_motorway_seed0.json").read_text())
    assert set(data["fcw_off"]) == {"radar", "infrared", "centralized", "federated"}
    assert set(data["fcw_on"]) == {"federated"}  # the drivers heard the federated warnings
    for run in ("fcw_off", "fcw_on"):
        assert_causes_add_up(data[run], run)
    for name in ("causes", "cause_rates"):
        assert (tmp_path / f"sumo_motorway_seed0_{name}.csv").exists()


@pytest.mark.parametrize(
    ("flags", "match"),
    [
        (["--pair", "--open-loop"], "drop --pair"),
        (["--conditions", "day", "night"], "one condition"),
        (["--open-loop", "--all-drives"], "drop --all-drives"),
        (["--ssm"], "add --pair"),
        (["--open-loop", "--set", "drive=federated"], "drop it"),
        (["--seeds", "0-1", "--seed", "3"], "drop --gui and --seed"),
        (["--address", "auto"], "settings of --seeds"),
        (["--seeds", "3-1"], "lo <= hi"),
    ],
)
def test_bad_world_flags_are_one_error(flags, match):
    args = build_parser().parse_args(["sumo", "--net", "motorway", *flags])
    with pytest.raises(ConfigError, match=match):
        sumo_command(args)


def assert_causes_add_up(summaries: dict, label: str) -> None:
    """Every method's summary in ``summaries`` (one run's, ``label``) drove some distance and
    splits each alert class by cause without losing or adding an alert."""
    for method, s in summaries.items():
        assert s["km"] > 0, method
        for c in ("crash_relevant", "nuisance", "sensing_false"):
            assert sum(s["by_cause"][c].values()) == s[c], (label, method, c)
