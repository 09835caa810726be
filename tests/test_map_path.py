"""The road ahead from a map (the ``"map"`` path): the lanes along the route in the ego frame
(acc_fusion.truth.sumo.lane_path), the localisation error that places them
(acc_fusion.sensors.localization) and the selection on them (acc_fusion.warning.selection)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.sensors.localization import MapLocalization
from acc_fusion.truth.objects import PATH_STATIONS
from acc_fusion.truth.road import sample_lanes
from acc_fusion.truth.sumo.lane_path import RoutePaths
from acc_fusion.truth.sumo.roadside import LaneTable, _lane_geometry
from acc_fusion.warning.selection import InPathSelector, SelectionConfig


def sample(shapes: list[np.ndarray], pos: float, front, heading: float) -> np.ndarray:
    """The path at the stations of an ego at lane position ``pos`` of the first of the lanes
    ``shapes`` (each ``(k, 2)``, driven in order), its front bumper at ``front``."""
    geometry = [_lane_geometry(s) for s in shapes]
    sizes = [len(s) for s in shapes]
    start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    vx, vy = (np.concatenate([s[:, i] for s in shapes]) for i in (0, 1))
    vs = np.concatenate([g[0] for g in geometry])
    out = np.full((1, PATH_STATIONS.size), np.nan)
    sample_lanes(np.arange(len(shapes), dtype=np.int64), np.array([len(shapes)]),
                 np.array([pos]), np.array([front[0]]), np.array([front[1]]),
                 np.array([heading]), start, vx, vy, vs, PATH_STATIONS, out)  # fmt: skip
    return out[0]


def arc(radius: float, start: float, stop: float, step_deg: float = 0.5) -> np.ndarray:
    """Points of a left-turning circle of ``radius`` centred at (0, radius), from angle
    ``start`` to ``stop`` [rad] (0: the origin, heading east)."""
    a = np.arange(start, stop + 1e-12, math.radians(step_deg))
    return np.column_stack([radius * np.sin(a), radius * (1.0 - np.cos(a))])


def test_the_path_of_a_curved_lane_is_its_circle_in_the_ego_frame():
    r = 400.0
    lane = arc(r, -0.1, 1.0)
    # the ego's front bumper on the lane at the origin, heading east (the tangent)
    pos = r * 0.1
    path = sample([lane[: len(lane) // 2], lane[len(lane) // 2 - 1 :]], pos, (0.0, 0.0), 0.0)
    x = PATH_STATIONS
    circle = r - np.sqrt(r * r - x * x)
    # a 0.5° chord strays r (1 - cos 0.25°) = 4 mm from its arc
    np.testing.assert_allclose(path, circle, atol=0.01)


def test_past_the_last_lane_the_path_goes_straight_on_and_a_loop_stops_at_its_turn():
    straight = np.array([[0.0, 0.0], [60.0, 0.0], [100.0, 10.0]])
    path = sample([straight], 0.0, (0.0, 0.0), 0.0)
    np.testing.assert_allclose(path[PATH_STATIONS <= 60], 0.0, atol=1e-12)
    np.testing.assert_allclose(path[PATH_STATIONS >= 100], (PATH_STATIONS[PATH_STATIONS >= 100]
                                                           - 60.0) / 4.0)  # fmt: skip
    loop = sample([arc(30.0, 0.0, 3.0)], 0.0, (0.0, 0.0), 0.0)  # turns back after x = 30 m
    assert np.isfinite(loop[PATH_STATIONS < 30]).all() and np.isnan(loop[PATH_STATIONS > 30]).all()


def test_the_path_is_in_the_ego_frame_wherever_the_ego_stands_and_heads():
    """The same lane seen from an ego moved and turned with it: the same path."""
    lane = arc(400.0, 0.0, 0.8)
    turn, shift = 2.0, np.array([1234.0, -567.0])
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    moved = lane @ rot.T + shift
    np.testing.assert_allclose(sample([moved], 0.0, shift, turn), sample([lane], 0.0, (0, 0), 0),
                               atol=1e-9)  # fmt: skip


def select(config, x, y, road_path=None, curvature=0.0):
    x, y = np.atleast_2d(np.asarray(x, float)), np.atleast_2d(np.asarray(y, float))
    sel = InPathSelector(config, *x.shape)
    return sel.step(np.arange(x.shape[1])[None, :], x, y, np.full(x.shape, 20.0),
                    np.zeros(x.shape, bool), np.array([25.0]), np.array([0.0]),
                    np.array([curvature]), road_path=road_path)  # fmt: skip


def test_past_the_end_of_its_last_lane_the_path_goes_on_along_the_lane():
    lane = np.array([[0.0, 0.0], [100.0, 0.0]])
    h = 0.1  # the ego 10 m past the lane's end, 1 m to its left, heading 0.1 rad to it
    got = sample([lane], 110.0, (110.0, 1.0), h)
    want = (-1.0 - PATH_STATIONS * math.sin(h)) / math.cos(h)  # the lane's line, y = 0
    np.testing.assert_allclose(got, want, atol=1e-9)


def test_the_map_path_follows_a_lane_that_bends_away_where_the_curvature_at_the_ego_is_zero():
    """The ego's lane splits off to the left 50 m ahead; a car 100 m ahead straight on is on
    the lane it leaves, a car on the bend is the ego's."""
    bend = np.where(PATH_STATIONS > 50, (PATH_STATIONS - 50) ** 2 / 800.0, 0.0)[None, :]
    on_bend = float(np.interp(100.0, PATH_STATIONS, bend[0]))  # 3.1 m to the left
    config = SelectionConfig(path="map", stationary="all")
    assert select(config, [100.0, 110.0], [0.0, on_bend + 0.6], bend)[0] == 1
    assert select(SelectionConfig(path="lane", stationary="all"), [100.0, 110.0],
                  [0.0, on_bend + 0.6])[0] == 0  # fmt: skip
    # where the map gives no path (an ego on no lane), the lane's curvature at the ego
    unknown = np.full_like(bend, np.nan)
    assert select(config, [100.0], [0.5 * 100.0**2 / 400.0], unknown, 1 / 400.0)[0] == 0


def test_where_the_map_path_turns_back_an_object_beyond_its_reach_is_not_in_it():
    """A loop ramp of 30 m radius: the path reaches x = 30 m and turns back.  A car 45 m
    ahead on the circle of the lane's curvature at the ego (what an ego on no lane falls back
    to) is where the ego's lane never goes; nearer than the next station, the path goes on
    along its last interval."""
    loop = sample([arc(30.0, 0.0, 3.0)], 0.0, (0.0, 0.0), 0.0)[None, :]
    config, kappa = SelectionConfig(path="map", stationary="all"), 1 / 400.0
    on_circle = 0.5 * kappa * 45.0**2
    assert select(config, [45.0], [on_circle], loop, kappa)[0] == -1
    unknown = np.full_like(loop, np.nan)  # an ego on no lane: the circle, as before
    assert select(config, [45.0], [on_circle], unknown, kappa)[0] == 0
    near = loop[0, 3] + 0.5 * (loop[0, 3] - loop[0, 2])  # 35 m, along the 20-30 m interval
    assert select(config, [35.0], [near], loop, kappa)[0] == 0
    assert select(config, [35.0], [near - 3.5], loop, kappa)[0] == -1
    # a lane that turns back before the first station: the circle short of it, nothing beyond
    tight = np.full_like(loop, np.nan)
    tight[0, 0] = 0.0
    assert select(config, [5.0], [0.5 * kappa * 25.0], tight, kappa)[0] == 0
    assert select(config, [45.0], [on_circle], tight, kappa)[0] == -1


def test_the_map_path_needs_a_source_that_gives_it_and_its_settings_are_checked():
    with pytest.raises(InputError, match="SUMO, highway-env and the scripted scenes give"):
        select(SelectionConfig(path="map"), [50.0], [0.0])
    with pytest.raises(InputError, match="road_path must have shape"):
        select(SelectionConfig(path="map"), [50.0], [0.0], np.zeros((1, 3)))
    for name, value in (("map_lateral_std", -0.1), ("map_error_time", 0.0)):
        with pytest.raises(ConfigError, match=name):
            SelectionConfig(**{name: value})


def test_the_localisation_error_has_its_spread_and_correlation_and_restarts_per_slot():
    n, dt, tau = 4000, 0.1, 2.0
    loc = MapLocalization(0.1, 0.0045, tau, n, np.random.default_rng(0))
    flat = np.zeros((n, PATH_STATIONS.size))
    first = loc.step(flat, dt)
    second = loc.step(flat, dt)
    lateral, heading = first[:, 0], (first[:, -1] - first[:, 0]) / PATH_STATIONS[-1]
    assert np.std(lateral) == pytest.approx(0.1, rel=0.05)
    assert np.std(heading) == pytest.approx(0.0045, rel=0.05)
    rho = np.corrcoef(first[:, 0], second[:, 0])[0, 1]
    assert rho == pytest.approx(math.exp(-dt / tau), abs=0.01)
    egos = np.zeros(n, bool)
    egos[: n // 2] = True
    loc.forget(egos)
    third = loc.step(flat, dt)
    assert abs(np.corrcoef(second[: n // 2, 0], third[: n // 2, 0])[0, 1]) < 0.06
    assert np.corrcoef(second[n // 2 :, 0], third[n // 2 :, 0])[0, 1] > 0.9


@pytest.mark.filterwarnings("ignore:more than capacity")
def test_on_the_bundled_motorway_the_true_lead_drives_on_the_map_path():
    """SUMO's leader of each ego, wherever it is ahead (ramps, curves of 900 and 1 300 m
    radius, lanes that merge), lies on the ego's map path."""
    pytest.importorskip("libsumo")
    from acc_fusion.truth.sumo.config import SumoConfig
    from acc_fusion.truth.sumo.nets import bundled_nets
    from acc_fusion.truth.sumo.objects import ObjectFieldConfig, SumoObjects
    from acc_fusion.truth.sumo.source import SumoSource

    config = SumoConfig(str(bundled_nets()["motorway"]), end=40.0, seed=2, capacity=64)
    offsets, start = [], []
    with SumoSource(config) as src:
        objects = SumoObjects(src, ObjectFieldConfig(map_path=True))
        while not src.done:
            src.advance()
            frame = objects.frame()
            active = src.active[: frame.n_egos]
            start.append(frame.road_path[active, 0])
            e = np.flatnonzero(active & (frame.lead >= 0))
            for ego, k in zip(e.tolist(), frame.lead[e].tolist(), strict=True):
                path = np.interp(frame.x[ego, k], PATH_STATIONS, frame.road_path[ego])
                offsets.append(frame.y[ego, k] - path)
    offsets, start = np.abs(offsets), np.abs(np.concatenate(start))
    assert offsets.size > 3000 and np.isfinite(offsets).all()
    assert np.median(offsets) < 0.01 and np.percentile(offsets, 95) < 0.1
    assert np.percentile(start, 99) < 0.01  # the ego drives on its lane's centreline


def test_a_scene_gives_its_road_as_the_map_and_the_map_path_keeps_the_parked_car_out():
    """``parked_curve``: straight for 150 m, then a left curve; the car parked on the right
    shoulder where the straight extension crosses it is the yaw-rate path's false target,
    and the fused path's in some runs; on the map's path it is beside the lane in every run."""
    from acc_fusion.sim.closed_loop import SimConfig
    from acc_fusion.sim.world import simulate_world
    from acc_fusion.sim.world_config import WorldConfig
    from acc_fusion.truth.scenes import SceneConfig, SceneSource

    scene = SceneConfig(scene="parked_curve", runs=2)
    assert SceneSource(scene, 0).frame().road_path.shape == (2, 0)  # no map
    source = SceneSource(scene, 0, map_path=True)
    path = source.frame().road_path
    kappa = source.scene.road.curves[0][1]
    np.testing.assert_allclose(path[:, PATH_STATIONS <= 150.0], 0.0, atol=1e-9)
    beyond = PATH_STATIONS[-1] - 150.0  # on the circle past the curve's start, to 2nd order
    assert path[0, -1] == pytest.approx(0.5 * kappa * beyond**2, rel=0.05)

    def false_alerts(path: str) -> int:
        world = WorldConfig(scene="parked_curve", selection=SelectionConfig(path=path))
        config = SimConfig(runs=20, methods=("federated",), world=world)
        return simulate_world(config).summaries["federated"].sensing_false

    assert false_alerts("map") == 0 < false_alerts("fused")


class _Api:
    """What :class:`RoutePaths` reads of libsumo, for a junction where lane ``a_0`` (1 km east)
    splits into ``b_0`` (a left curve of 300 m radius) and ``c_0`` (a right turn-off)."""

    def __init__(self, route: tuple[str, ...]) -> None:
        links = {"a_0": [("b_0", ":j_0_0"), ("c_0", ":j_1_0")], ":j_0_0": [("b_0", "")],
                 ":j_1_0": [("c_0", "")], "b_0": [], "c_0": []}  # fmt: skip
        self.lane = type("Lane", (), {"getLinks": staticmethod(
            lambda name: [(to, True, True, False, via, "M", "s", 1.0) for to, via in links[name]]
        )})  # fmt: skip
        vehicle = {"getRoute": staticmethod(lambda vid: route),
                   "getRouteIndex": staticmethod(lambda vid: 0)}  # fmt: skip
        self.vehicle = type("Vehicle", (), vehicle)


def _junction() -> LaneTable:
    shapes = {":j_0": np.array([[1000.0, 0.0], [1010.0, 0.0]]),
              ":j_1": np.array([[1000.0, 0.0], [1010.0, -5.0]]),
              "a": np.array([[0.0, 0.0], [1000.0, 0.0]]),
              "b": arc(300.0, 0.0, 0.8) + [1010.0, 0.0],
              "c": np.array([[1010.0, -5.0], [1200.0, -100.0]])}  # fmt: skip
    edges = tuple(sorted(shapes))
    geometry = [_lane_geometry(shapes[e]) for e in edges]
    sizes = [len(shapes[e]) for e in edges]
    return LaneTable(
        edge_code={e: i for i, e in enumerate(edges)}, edge_ids=edges,
        first_lane=np.arange(len(edges)), n_lanes=np.ones(len(edges), np.int64),
        internal=np.array([e.startswith(":") for e in edges]), width=np.full(len(edges), 3.5),
        speed=np.full(len(edges), 30.0),
        start=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
        vx=np.concatenate([shapes[e][:, 0] for e in edges]),
        vy=np.concatenate([shapes[e][:, 1] for e in edges]),
        vs=np.concatenate([g[0] for g in geometry]), vh=np.concatenate([g[1] for g in geometry]),
    )  # fmt: skip


def test_the_path_follows_the_route_through_the_junction_from_anywhere_on_a_long_lane():
    lanes = _junction()
    a = lanes.edge_code["a"]
    x = PATH_STATIONS
    for pos in (0.0, 950.0):  # the lane is longer than the path's reach
        ahead = x + pos - 1010.0  # along the curve, past the junction
        curve = np.where(ahead > 0, 300.0 - np.sqrt(300.0**2 - np.maximum(ahead, 0) ** 2), 0.0)
        paths = RoutePaths(_Api(("a", "b")), lanes)
        path = paths.paths(["v"], np.array([7]), np.array([a]), np.array([pos]),
                           np.array([pos]), np.array([0.0]), np.array([0.0]))[0]  # fmt: skip
        np.testing.assert_allclose(path, curve, atol=0.05)
    right = RoutePaths(_Api(("a", "c")), lanes).paths(
        ["v"], np.array([7]), np.array([a]), np.array([950.0]), np.array([950.0]),
        np.array([0.0]), np.array([0.0]))[0]  # fmt: skip
    assert right[-1] < -50.0  # the turn-off, not the curve


# highway-env's lanes ahead, by hand for merge-v0: a lane and the lanes it joins. The
# acceleration lane ("b", "c", 2) ends (its obstacle closes it), so the path goes straight on.
_MERGE_CHAINS = {
    ("a", "b", 0): [("a", "b", 0), ("b", "c", 0), ("c", "d", 0)],
    ("a", "b", 1): [("a", "b", 1), ("b", "c", 1), ("c", "d", 1)],
    ("b", "c", 0): [("b", "c", 0), ("c", "d", 0)],
    ("b", "c", 1): [("b", "c", 1), ("c", "d", 1)],
    ("b", "c", 2): [("b", "c", 2)],
    ("c", "d", 0): [("c", "d", 0)],
    ("c", "d", 1): [("c", "d", 1)],
    ("j", "k", 0): [("j", "k", 0), ("k", "b", 0), ("b", "c", 2)],
    ("k", "b", 0): [("k", "b", 0), ("b", "c", 2)],
}


def _dense_path(network, chain, front, heading) -> np.ndarray:
    """The path at the stations from highway-env's centreline points every 5 cm along
    ``chain`` from the front bumper's projection, then straight on for 300 m."""
    first = network.get_lane(chain[0])
    s0 = first.local_coordinates(np.asarray(front))[0]
    pts = []
    for k, index in enumerate(chain):
        lane = network.get_lane(index)
        s = np.arange(max(s0, 0.0) if k == 0 else 0.0, lane.length, 0.05)
        pts += [lane.position(v, 0.0) for v in s]
    end = network.get_lane(chain[-1])
    pts.append(end.position(end.length, 0.0))
    d = end.position(end.length, 0.0) - end.position(end.length - 0.05, 0.0)
    pts += [pts[-1] + d / np.linalg.norm(d) * u for u in np.arange(0.05, 300.0, 0.05)]
    q = np.asarray(pts) - np.asarray(front)
    c, s = math.cos(heading), math.sin(heading)
    x, y = q[:, 0] * c + q[:, 1] * s, -q[:, 0] * s + q[:, 1] * c
    return np.interp(PATH_STATIONS, x, y)


def test_highway_env_gives_the_lanes_ahead_as_the_map_on_merge_v0():
    pytest.importorskip("highway_env")
    from dataclasses import replace

    from acc_fusion.truth.highway.config import HighwayConfig
    from acc_fusion.truth.highway.lane_path import NetworkPaths
    from acc_fusion.truth.highway.lanes import LaneRows
    from acc_fusion.truth.highway.source import HighwaySource
    from acc_fusion.truth.highway.world import DEFAULT_FIELD, HighwayWorld

    seen = set()
    with HighwaySource(HighwayConfig("merge-v0", episodes=1, duration=20.0, seed=2)) as src:
        world = HighwayWorld(src, replace(DEFAULT_FIELD, map_path=True))
        network = src.env.road.network
        k = 0
        while not world.done:
            frame = world.frame()
            assert frame.road_path.shape == (src.n_pairs, PATH_STATIONS.size)
            assert np.all(np.isnan(frame.road_path[~src.active]))
            for e in np.flatnonzero(src.active) if k % 5 == 0 else ():
                v = src.vehicles[e]
                front = v.position + 0.5 * v.LENGTH * np.array(
                    [np.cos(v.heading), np.sin(v.heading)]
                )
                want = _dense_path(network, _MERGE_CHAINS[v.lane_index], front, v.heading)
                np.testing.assert_allclose(frame.road_path[e], want, atol=0.01)
                seen.add(v.lane_index[:2])
            world.advance()
            k += 1
    assert {("a", "b"), ("j", "k"), ("k", "b"), ("b", "c")} <= seen  # the ramp and the merge
    paths = NetworkPaths(LaneRows(network))  # every lane, near its ends and past the last
    for index, chain in _MERGE_CHAINS.items():
        lane = network.get_lane(index)
        for s, r, turn in ((5.0, 0.0, 0.0), (lane.length - 3.0, 1.2, 0.05),
                           (lane.length + 5.0, -0.8, -0.04)):  # fmt: skip
            front, heading = lane.position(s, r), lane.heading_at(min(s, lane.length)) + turn
            got = paths.paths([index], [s], [front[0]], [front[1]], [heading])[0]
            want = _dense_path(network, chain, front, heading)
            np.testing.assert_allclose(got, want, atol=0.01, err_msg=f"{index} at {s} m")
    with HighwaySource(HighwayConfig("merge-v0", episodes=1, duration=1.0)) as src:
        assert HighwayWorld(src).frame().road_path.shape == (src.n_pairs, 0)  # no map asked


def test_the_highway_world_command_selects_on_highway_envs_map(capsys):
    pytest.importorskip("highway_env")
    from acc_fusion.cli.main import main

    args = ["highway", "--world", "--env", "merge-v0", "--episodes", "1", "--duration", "2",
            "--set", "world.selection.path=map"]  # fmt: skip
    assert main(args) == 0  # without the map in the frames, the selection refuses (above)
    assert "Alerts by class, merge-v0, day" in capsys.readouterr().out
