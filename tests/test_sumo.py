"""SUMO truth source on a generated 2-lane road: slots, gap geometry, penetration, arrivals,
hazards, closed-loop braking, collisions, the SSM cross-check, errors, reproducibility, and
the one-simulation-per-process rule; SUMO in a background process (``BackgroundSumoSource``):
the same frames step for step, open loop only, errors, warnings, a script without a
``__main__`` guard.  Each test runs at most a few short SUMO simulations."""

from __future__ import annotations

import os
import select
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
from dataclasses import replace
from multiprocessing.connection import Connection

import numpy as np
import pytest

libsumo = pytest.importorskip("libsumo")

import acc_fusion.sim.closed_loop as fcw  # noqa: E402
import acc_fusion.truth.sumo.background as background_mod  # noqa: E402
from acc_fusion.core.errors import ConfigError  # noqa: E402
from acc_fusion.core.levels import WARNING_COLORS  # noqa: E402
from acc_fusion.core.slots import Extent  # noqa: E402
from acc_fusion.sim.closed_loop import SimConfig, simulate  # noqa: E402
from acc_fusion.truth.sumo import launch  # noqa: E402
from acc_fusion.truth.sumo.background import BackgroundSumoSource  # noqa: E402
from acc_fusion.truth.sumo.config import SumoConfig, SumoError, check_sumocfg  # noqa: E402
from acc_fusion.truth.sumo.ring import COUNTERS, OUTBOX_BATCH, _Outbox  # noqa: E402
from acc_fusion.truth.sumo.source import SumoSource  # noqa: E402

ROUTES = """<routes>
  <vType id="car" length="4.5" minGap="2.5" accel="2.6" decel="4.5" sigma="0.5" tau="1.0"/>
  <vType id="truck" length="12.0" minGap="3.0" accel="1.2" decel="4.0" sigma="0.5"
         maxSpeed="25"/>
  <route id="r0" edges="A0B0 B0C0"/>
  <flow id="c" type="car" route="r0" begin="0" end="3600" vehsPerHour="1800"
        departLane="random" departSpeed="max"/>
  <flow id="t" type="truck" route="r0" begin="0" end="3600" vehsPerHour="300"
        departLane="0" departSpeed="max"/>
</routes>
"""

LATE_BAD = """<routes>
  <vehicle id="ok1" depart="10"><route edges="A0B0 B0C0"/></vehicle>
  <vehicle id="ok2" depart="15"><route edges="A0B0 B0C0"/></vehicle>
  <vehicle id="bad" depart="30"><route edges="no_such_edge"/></vehicle>
</routes>
"""


def sumocfg(net: str, routes: str, end: float = 600.0, step: float = 0.1) -> str:
    return f"""<configuration>
  <input><net-file value="{net}"/><route-files value="{routes}"/></input>
  <time><begin value="0"/><end value="{end}"/><step-length value="{step}"/></time>
</configuration>
"""


@pytest.fixture(scope="module")
def road(tmp_path_factory):
    """A straight 2 km road with 2 lanes per direction (netgenerate), cars and trucks."""
    import sumo

    d = tmp_path_factory.mktemp("sumo_road")
    exe = os.path.join(sumo.SUMO_HOME, "bin", "netgenerate")
    cmd = [exe, "--grid", "--grid.x-number", "3", "--grid.y-number", "1"]
    cmd += ["--grid.x-length", "1000", "-L", "2", "--default.speed", "30"]
    cmd += ["--no-turnarounds", "true", "-o", str(d / "road.net.xml")]
    env = {**os.environ, "SUMO_HOME": sumo.SUMO_HOME}
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    (d / "road.rou.xml").write_text(ROUTES)
    (d / "late_bad.rou.xml").write_text(LATE_BAD)
    (d / "road.sumocfg").write_text(sumocfg("road.net.xml", "road.rou.xml"))
    (d / "late_bad.sumocfg").write_text(
        sumocfg("road.net.xml", "road.rou.xml,late_bad.rou.xml", end=100.0)
    )
    return d


def config(road, **kw) -> SumoConfig:
    kw.setdefault("end", 60.0)
    kw.setdefault("capacity", 64)
    return SumoConfig(str(road / "road.sumocfg"), **kw)


def same_lane_gap(follower: str, leader: str) -> float | None:
    """Bumper-to-bumper gap from lane positions and length, when both share a lane."""
    veh = libsumo.vehicle
    if veh.getLaneID(follower) != veh.getLaneID(leader):
        return None
    return veh.getLanePosition(leader) - veh.getLength(leader) - veh.getLanePosition(follower)


# ---------------------------------------------------------------- no SUMO needed
def test_missing_and_invalid_files_are_clear_errors(road, tmp_path):
    missing = tmp_path / "nowhere.sumocfg"
    with pytest.raises(ConfigError, match="nowhere.sumocfg.*does not exist"):
        SumoSource(SumoConfig(str(missing)))
    bad_xml = tmp_path / "broken.sumocfg"
    bad_xml.write_text("<configuration><input>")
    with pytest.raises(ConfigError, match="broken.sumocfg.*not valid XML"):
        check_sumocfg(bad_xml)
    no_net = tmp_path / "no_net.sumocfg"
    no_net.write_text(sumocfg("missing.net.xml", str(road / "road.rou.xml")))
    with pytest.raises(ConfigError, match="net-file .*missing.net.xml.*does not exist"):
        SumoSource(SumoConfig(str(no_net)))
    with pytest.raises(ConfigError, match="penetration must be in"):
        SumoConfig(str(road / "road.sumocfg"), penetration=1.5)
    with pytest.raises(ConfigError, match="collision_action must be one of"):
        SumoConfig(str(road / "road.sumocfg"), collision_action="explode")
    assert not libsumo.simulation.isLoaded()


def test_net_sumo_rejects_is_a_clear_error(road, tmp_path):
    """A file SUMO cannot load (routes given as the net) fails with SUMO's reason."""
    cfg = tmp_path / "wrong.sumocfg"
    cfg.write_text(sumocfg(str(road / "road.rou.xml"), str(road / "road.rou.xml")))
    with pytest.raises(SumoError, match="SUMO could not load .*wrong.sumocfg"):
        SumoSource(SumoConfig(str(cfg)))
    with SumoSource(config(road, end=1.0)) as src:  # the process can still run SUMO
        assert src.n_steps == 10


def test_route_error_after_the_net_loaded_leaves_the_process_usable(road, tmp_path):
    """A route with an unknown edge fails after the net loaded; libsumo is closed again."""
    (tmp_path / "bad.rou.xml").write_text(
        '<routes><vehicle id="v" depart="0"><route edges="no_such_edge"/></vehicle></routes>'
    )
    cfg = tmp_path / "bad_route.sumocfg"
    cfg.write_text(sumocfg(str(road / "road.net.xml"), str(tmp_path / "bad.rou.xml")))
    with pytest.raises(SumoError, match="SUMO could not load .*bad_route.sumocfg"):
        SumoSource(SumoConfig(str(cfg)))
    assert not libsumo.simulation.isLoaded()
    with SumoSource(config(road, end=1.0)) as src:
        assert src.n_steps == 10


# ---------------------------------------------------------------- one simulation each
@pytest.mark.parametrize("penetration", [1.0, 0.5])
def test_frames_shapes_and_gap_geometry(road, penetration):
    """Every kept leader's gap, speed and acceleration are SUMO's; at a partial penetration,
    also those of the leaders that hold no slot (read with their own getters)."""
    with SumoSource(config(road, end=40.0, seed=1, penetration=penetration)) as src:
        assert src.dt == pytest.approx(0.1) and src.n_steps == 400
        n, checked, steps, slotless = src.n_pairs, 0, 0, 0
        frame = src.frame()
        while not src.done:
            frame = src.advance()
            steps += 1
            active, ids = src.active, src.vehicle_ids
            assert frame.n_pairs == n and active.shape == (n,) and len(ids) == n
            for arr in (frame.ego_speed, frame.gap, frame.lead_speed, src.collided):
                assert arr.shape == (n,)
            assert np.array_equal(active, np.array([v is not None for v in ids]))
            assert np.all(frame.leader_id[~active] == -1) and np.all(frame.ego_speed[~active] == 0)
            for slot in np.flatnonzero(frame.has_leader):
                leader = libsumo.vehicle.getLeader(ids[slot], 250.0)
                geo = same_lane_gap(ids[slot], leader[0])
                if geo is not None:
                    assert frame.gap[slot] == pytest.approx(geo, abs=1e-6)
                    checked += 1
                assert frame.lead_speed[slot] == pytest.approx(
                    libsumo.vehicle.getSpeed(leader[0]), abs=1e-12
                )
                assert frame.lead_accel[slot] == pytest.approx(
                    libsumo.vehicle.getAcceleration(leader[0]), abs=1e-9
                )
                slotless += leader[0] not in ids
            for slot in np.flatnonzero(active):
                assert frame.ego_accel[slot] == pytest.approx(
                    libsumo.vehicle.getAcceleration(ids[slot]), abs=1e-9
                )
        assert steps == 400 and src.t == pytest.approx(40.0)
        assert checked > 2000 and src.active.sum() > 5
        assert (slotless > 500) == (penetration < 1)
        assert np.all(frame.gap[frame.has_leader] <= 250.0)


def test_the_warm_up_fills_the_network_before_the_first_frame(road):
    """``warmup``: SUMO runs that long first; the first frame holds the vehicles already on
    the road, equipped as they would be at departure, and ``end`` counts after it."""
    with SumoSource(config(road, end=10.0, warmup=30.0, seed=1)) as src:
        assert src.t == pytest.approx(30.0) and src.n_steps == 100
        assert src.active.sum() == len(libsumo.vehicle.getIDList()) > 5
        while not src.done:
            src.advance()
        assert src.t == pytest.approx(40.0)
    with pytest.raises(ConfigError, match="warmup"):
        config(road, warmup=-1.0)


def test_penetration_equips_about_half(road):
    with SumoSource(config(road, end=120.0, penetration=0.5, seed=4)) as src:
        while not src.done:
            src.advance()
        present = libsumo.vehicle.getIDList()
        equipped_present = [v for v in present if src._info[v][1]]
        assert sorted(v for v in src.vehicle_ids if v) == sorted(equipped_present)
        share = src.n_equipped / src.n_departed
        assert src.n_departed > 60 and 0.35 < share < 0.65


def test_arrival_frees_the_slot_and_a_later_vehicle_is_reassigned(road):
    with (
        pytest.warns(RuntimeWarning, match="capacity = 6"),  # more equipped vehicles wait
        SumoSource(config(road, end=120.0, capacity=6, seed=2)) as src,
    ):
        seen_free, reassigned_after = {}, set()
        while not src.done:
            before = src.vehicle_ids
            src.advance()
            after, arrived = src.vehicle_ids, set(libsumo.simulation.getArrivedIDList())
            frame = src.frame()
            assert src.active.tolist() == [v is not None for v in after]  # kept as slots change
            for slot, vid in enumerate(after):  # each slot's values are its vehicle's
                if vid is not None:
                    assert frame.ego_speed[slot] == libsumo.vehicle.getSpeed(vid)
            for slot, (old, new) in enumerate(zip(before, after, strict=True)):
                if old is not None and old in arrived:
                    assert new is None and not src.active[slot]  # freed, not reused at once
                    assert frame.leader_id[slot] == -1
                    seen_free[slot] = old
                elif slot in seen_free and src.reassigned[slot]:
                    assert new is not None and new != seen_free[slot]
                    reassigned_after.add(slot)
            assert not np.any(src.reassigned & ~src.active)
        assert seen_free and reassigned_after


def test_vehicle_removed_behind_our_back_frees_its_slot(road):
    """``vehicle.remove`` by another TraCI user is not in the next step's arrivals."""
    with SumoSource(config(road, end=30.0, penetration=0.5, seed=6)) as src:
        for _ in range(150):
            src.advance()
        slot = int(np.flatnonzero(src.active)[0])
        vid = src.vehicle_ids[slot]
        libsumo.vehicle.remove(vid)
        f = src.advance()
        assert src.vehicle_ids[slot] is None and not src.active[slot] and f.leader_id[slot] == -1
        assert vid not in src._info
        assert src.active.tolist() == [v is not None for v in src.vehicle_ids]
        while not src.done:
            src.advance()


def test_hazard_makes_a_leader_brake_at_hazard_decel(road):
    decel = 6.5
    with SumoSource(config(road, end=60.0, hazard_rate=150.0, hazard_decel=decel)) as src:
        hits = 0
        while not src.done:
            frame = src.advance()
            hits += int(np.sum(np.isclose(frame.lead_accel, -decel, atol=1e-6)))
        assert src.n_hazards > 5 and hits > 10
        assert not src._hazards or all(h.end > src.t for h in src._hazards.values())


def test_a_vehicles_hazards_do_not_move_when_other_traffic_changes(road):
    """Common random numbers: a vehicle's hazards are a function of the seed and its id, so
    taking one car off the road (as a crash does) leaves the other vehicles' hazards."""

    def run(remove_one: bool) -> set[tuple[float, str]]:
        starts, braking = set(), set()
        with SumoSource(config(road, end=60.0, seed=5, hazard_rate=200.0)) as src:
            while not src.done:
                if remove_one and abs(src.t - 5.0) < 1e-6:
                    libsumo.vehicle.remove(libsumo.vehicle.getIDList()[0])
                src.advance()
                now = set(src._hazards)
                starts |= {(round(src.t, 1), vid) for vid in now - braking}
                braking = now
        return starts

    plain, disturbed = run(False), run(True)
    assert len(plain) > 20
    assert len(plain & disturbed) >= 0.9 * len(plain)


def test_closed_loop_brake_and_hand_back(road):
    with SumoSource(config(road, end=60.0, seed=3)) as src:
        for _ in range(250):
            src.advance()
        f = src.frame()
        free_road = src.active & (f.ego_speed > 15) & (~f.has_leader | (f.gap > 80))
        slot = int(np.flatnonzero(free_road)[0])
        vid = src.vehicle_ids[slot]
        mode = libsumo.vehicle.getSpeedMode(vid)
        brake = np.zeros(src.n_pairs)
        brake[slot] = 3.0
        for _ in range(10):
            v0 = src.frame().ego_speed[slot]
            f = src.advance(brake)
            assert src.vehicle_ids[slot] == vid
            assert f.ego_speed[slot] == pytest.approx(v0 - 3.0 * src.dt, abs=1e-9)
            assert f.ego_accel[slot] == pytest.approx(-3.0, abs=1e-9)
            assert libsumo.vehicle.getSpeedMode(vid) == mode & ~0b100
        f = src.advance(np.zeros(src.n_pairs))  # request ends: control handed back
        assert libsumo.vehicle.getSpeedMode(vid) == mode and not src._ctrl
        for _ in range(10):
            f = src.advance()
        assert f.ego_accel[slot] > -3.0 + 1e-6  # SUMO drives it again (re-accelerates)


def test_collision_of_an_inattentive_follower_is_detected(road):
    cfg = config(road, end=60.0, seed=5, inattentive=1.0, inattentive_action_step=2.0)
    with SumoSource(cfg) as src:
        close = np.zeros(src.n_pairs, dtype=bool)
        while not close.any():  # a follower close behind its leader at speed
            f = src.advance()
            close = f.has_leader & (f.gap < 35) & (f.ego_speed > 15) & (src.t > 10)
        ids = src.vehicle_ids
        slot = int(np.flatnonzero(close)[np.argmin(f.gap[close])])
        follower = ids[slot]
        leader = libsumo.vehicle.getLeader(follower, 250.0)[0]
        assert src.inattentive[slot] and libsumo.vehicle.getActionStepLength(follower) == 2.0
        for vid in (follower, leader):
            libsumo.vehicle.setLaneChangeMode(vid, 0)
        assert src.inject_hazard(leader, decel=40.0, duration=10.0)
        for _ in range(60):
            src.advance()
            if src.collided[slot]:
                break
        assert src.collided[slot] and src.n_collisions >= 1
        assert 5.0 < src.collision_speed[slot] < 40.0
        assert not src.active[slot] and src.vehicle_ids[slot] is None  # removed
        while not src.reassigned[slot] and not src.done:
            src.advance()
        assert src.reassigned[slot] and not src.collided[slot]


def test_a_held_follower_keeps_its_speed_into_a_braking_leader(road):
    # An attentive follower (SUMO's car following) never hits a leader braking at 6 m/s²;
    # a held one (eyes off the road) keeps its speed and does, and SUMO reports it.
    with SumoSource(config(road, end=60.0, seed=5)) as src:
        close = np.zeros(src.n_pairs, dtype=bool)
        while not close.any():
            f = src.advance()
            close = f.has_leader & (f.gap < 30) & (f.ego_speed > 15) & (src.t > 10)
        slot = int(np.flatnonzero(close)[np.argmin(f.gap[close])])
        follower = src.vehicle_ids[slot]
        leader = libsumo.vehicle.getLeader(follower, 250.0)[0]
        for vid in (follower, leader):
            libsumo.vehicle.setLaneChangeMode(vid, 0)
        mode = libsumo.vehicle.getSpeedMode(follower)
        assert src.inject_hazard(leader, decel=6.0, duration=10.0)
        hold = np.zeros(src.n_pairs, dtype=bool)
        hold[slot] = True
        v0 = f.ego_speed[slot]
        for _ in range(100):
            f = src.advance(None, hold)
            if src.collided[slot]:
                break
            assert f.ego_speed[slot] == pytest.approx(v0, abs=1e-9)
            assert libsumo.vehicle.getSpeedMode(follower) == mode & ~0b101
        assert src.collided[slot] and src.collision_speed[slot] > 3.0


def test_ssm_min_ttc_cross_check(road):
    cfg = config(road, end=90.0, seed=2, ssm=True, hazard_rate=60.0)
    ours: dict[str, tuple[float, float]] = {}
    with SumoSource(cfg) as src:
        while not src.done:
            f = src.advance()
            ids = src.vehicle_ids
            closing = f.has_leader & (f.ego_speed - f.lead_speed > 1e-9)
            for slot in np.flatnonzero(closing):
                ttc = f.gap[slot] / (f.ego_speed[slot] - f.lead_speed[slot])
                if ttc < ours.get(ids[slot], (np.inf, 0.0))[0]:
                    ours[ids[slot]] = (ttc, f.gap[slot])
        ssm = src.ssm_min_ttc()
    assert set(ssm) >= {v for v in ours} and any(np.isfinite(list(ssm.values())))
    # SSM's minimum is over every encounter within its 50 m range, ours over the leader only.
    near = {v: ttc for v, (ttc, gap) in ours.items() if gap < 40.0}
    assert near and all(ssm[v] <= ttc + 0.01 for v, ttc in near.items())
    assert sum(abs(ssm[v] - ttc) < 0.01 for v, ttc in near.items()) >= 3


def test_reproducible_from_the_seed(road):
    def run(seed):
        cfg = config(road, end=30.0, seed=seed, penetration=0.7, hazard_rate=100.0)
        out = []
        with SumoSource(cfg) as src:
            while not src.done:
                f = src.advance()
                out.append(np.concatenate([f.leader_id, np.nan_to_num(f.gap), f.ego_speed]))
            return np.array(out), src.n_hazards

    (a, ha), (b, hb), (c, _) = run(7), run(7), run(8)
    assert np.array_equal(a, b) and ha == hb and ha > 0
    assert a.shape != c.shape or not np.array_equal(a, c)


def test_one_simulation_per_process(road):
    with SumoSource(config(road, end=5.0)) as first:
        with pytest.raises(SumoError, match="already open in this process"):
            SumoSource(config(road, end=5.0))
        first.advance()  # the first one is untouched
        assert first.t == pytest.approx(0.1)
    with SumoSource(config(road, end=5.0)) as second:  # closed: the next may open
        second.advance()


def test_sumo_failing_mid_run_is_a_clear_error(road):
    cfg = SumoConfig(str(road / "late_bad.sumocfg"), capacity=16, extra_args=("--route-steps", "5"))
    src = SumoSource(cfg)
    with pytest.raises(SumoError, match=r"SUMO failed at t = .*no_such_edge"):
        while not src.done:
            src.advance()
    assert src.closed and src.done and 5.0 <= src.t < 30.0
    assert src.frame().n_pairs == 16  # the results so far stay readable
    with pytest.raises(SumoError, match="closed"):
        src.advance()
    with SumoSource(config(road, end=1.0)):  # and the process can run SUMO again
        pass


def test_traci_path_gives_the_same_frames(road, monkeypatch):
    """``gui=True`` drives SUMO through TraCI (here the plain ``sumo`` binary stands in for
    ``sumo-gui``): same frames as libsumo, warning colours set."""

    def frames(gui):
        cfg = config(road, end=15.0, seed=9, penetration=0.6, hazard_rate=100.0, gui=gui)
        out = []
        with SumoSource(cfg) as src:
            while not src.done:
                brake = np.where(src.active & (np.arange(src.n_pairs) % 4 == 0), 2.0, 0.0)
                f = src.advance(brake)
                src.set_warning_colors(np.arange(src.n_pairs) % 3)
                out.append(np.concatenate([f.leader_id, np.nan_to_num(f.gap), f.ego_accel]))
        return np.array(out)

    real = launch.sumo_binary
    monkeypatch.setattr(launch, "sumo_binary", lambda gui: real(False))
    monkeypatch.setattr(launch, "has_display", lambda: True)
    np.testing.assert_allclose(frames(True), frames(False), atol=1e-9)


def test_gui_without_display_is_a_clear_error(road, monkeypatch):
    monkeypatch.setattr(launch, "has_display", lambda: False)
    with pytest.raises(ConfigError, match="gui needs a display"):
        SumoSource(config(road, gui=True))


@pytest.fixture
def virtual_display(monkeypatch):
    """An Xvfb display for sumo-gui (skips where Xvfb is not installed)."""
    import shutil
    import time

    exe = shutil.which("Xvfb")
    if exe is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb)")
    display = f":{90 + os.getpid() % 400}"
    proc = subprocess.Popen(
        [exe, display, "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    time.sleep(1.0)
    if proc.poll() is not None:
        pytest.skip(f"Xvfb could not start on {display}")
    monkeypatch.setenv("DISPLAY", display)
    yield display
    proc.terminate()
    proc.wait(timeout=10)


def test_real_sumo_gui_colours_vehicles_by_warning_level(road, virtual_display):
    """The real sumo-gui (on a virtual display) runs the source and shows warning colours."""
    cfg = config(road, end=10.0, seed=3, penetration=1.0, gui=True)
    with SumoSource(cfg) as src:
        assert os.path.basename(launch.sumo_binary(True)).startswith("sumo-gui")
        levels = np.arange(src.n_pairs) % 3
        while not src.done and src.active.sum() < 3:
            src.advance()
        assert src.active.sum() >= 3
        src.set_warning_colors(levels)
        src.advance()
        for slot in np.flatnonzero(src.active)[:6]:
            vid = src.vehicle_ids[slot]
            colour = tuple(src._api.vehicle.getColor(vid))[:3]
            assert colour == tuple(WARNING_COLORS[levels[slot]])[:3]


# ---------------------------------------------------------------- background process
def trace(src) -> list[tuple]:
    """Everything the FCW loop reads of a source, step by step, to the end."""
    out = []
    while True:
        f = src.frame()
        out.append(
            (
                f.t,
                np.stack([f.ego_speed, f.ego_accel, f.gap, f.lead_speed, f.lead_accel]),
                f.leader_id,
                np.stack([src.active, src.reassigned, src.collided, src.inattentive]),
                src.collision_speed,
                src.vehicle_ids,
                tuple(getattr(src, c) for c in COUNTERS),
            )
        )
        if src.done:
            return out
        src.advance()


def test_same_frames_and_ssm_as_the_in_process_source(road):
    cfg = config(
        road, end=40.0, seed=4, penetration=0.7, hazard_rate=200.0, inattentive=0.5, ssm=True
    )
    with SumoSource(cfg) as src:
        inline, ssm = trace(src), src.ssm_min_ttc()
    with BackgroundSumoSource(cfg) as src:
        assert (src.dt, src.n_pairs, src.n_steps) == (0.1, 64, 400)
        background, ssm_bg = trace(src), src.ssm_min_ttc()
    assert len(background) == len(inline) == 401
    for a, b in zip(inline, background, strict=True):
        assert a[0] == b[0] and a[5] == b[5] and a[6] == b[6]
        for x, y in zip(a[1:5], b[1:5], strict=True):
            np.testing.assert_array_equal(x, y)
    assert inline[-1][6][3] > 0 and ssm_bg == ssm and any(np.isfinite(list(ssm.values())))


def test_the_child_imports_the_parents_package_whatever_the_working_directory(
    road, tmp_path, monkeypatch
):
    """``python -c`` puts the working directory first on ``sys.path``: a package there (an old
    checkout, say) must not shadow the parent's in the child."""
    shadow = tmp_path / "acc_fusion"
    shadow.mkdir()
    (shadow / "__init__.py").write_text("raise ImportError('the shadowing copy was imported')\n")
    monkeypatch.chdir(tmp_path)
    with BackgroundSumoSource(config(road, end=1.0)) as src:
        while not src.done:
            src.advance()
    assert src.t == pytest.approx(1.0)


def test_sumo_s_process_imports_neither_filterpy_nor_scipy_stats():
    """The child needs neither (about 0.9 s of its imports and 44 MB): the modules it imports
    (the source's, the truth frame's, the models') must leave them to the filters."""
    code = (
        "import sys, acc_fusion.truth.sumo.background; "
        "print([m for m in ('filterpy', 'scipy.stats') if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_open_loop_only(road):
    with BackgroundSumoSource(config(road, end=5.0)) as src:
        src.advance(np.zeros(src.n_pairs))  # no request: fine
        with pytest.raises(ConfigError, match="cannot apply brake requests"):
            src.advance(np.full(src.n_pairs, 2.0))
        with pytest.raises(SumoError, match="once it is done"):
            src.ssm_min_ttc()
        with pytest.raises(ConfigError, match="cannot run a closed loop"):
            simulate(SimConfig(runs=1, dt=src.dt, drive="federated"), source=src)
        open_loop = simulate(SimConfig(runs=1, dt=src.dt, methods=("radar",)), source=src)
        assert src.done and open_loop.steps == 49
        with pytest.raises(SumoError, match="has ended"):
            src.advance()
    with pytest.raises(ConfigError, match="gui needs"):
        BackgroundSumoSource(config(road, gui=True))


def test_errors_reach_the_parent_as_the_in_process_source_raises_them(road, tmp_path):
    with pytest.raises(ConfigError, match="nowhere.sumocfg.*does not exist"):
        BackgroundSumoSource(SumoConfig(str(tmp_path / "nowhere.sumocfg")))
    late = SumoConfig(
        str(road / "late_bad.sumocfg"), capacity=16, extra_args=("--route-steps", "5")
    )
    src = BackgroundSumoSource(late)
    with pytest.raises(SumoError, match=r"SUMO failed at t = .*no_such_edge") as failure:
        simulate(SimConfig(runs=1, dt=src.dt, methods=("radar",)), source=src)
    assert src.closed and src.done and 5.0 <= src.t < 30.0
    assert failure.value.summaries["radar"].hours > 0  # the metrics so far are kept
    with pytest.raises(SumoError, match="closed"):
        src.advance()


def test_the_childs_outbox_never_waits_below_its_limit_and_keeps_the_order():
    parent_end, child_end = socket.socketpair()
    outbox = _Outbox(child_end.fileno(), limit=64 << 20)
    payload = np.arange(100_000.0)  # 800 kB a message: more than the socket's buffer holds
    for k in range(20):
        outbox.put(("frame", k, payload))  # returns at once although nobody reads yet
    assert outbox._queued > 10 * payload.nbytes
    reader = Connection(parent_end.detach())
    got = []
    thread = threading.Thread(target=lambda: got.extend(reader.recv() for _ in range(20)))
    thread.start()
    outbox.close()  # writes the rest as the reader reads (blocking)
    thread.join()
    assert [m[1] for m in got] == list(range(20))
    assert np.array_equal(got[-1][2], payload)
    assert outbox._queued == 0 and os.get_blocking(child_end.fileno())


def test_the_childs_outbox_writes_frames_in_batches_or_at_once_when_told():
    parent_end, child_end = socket.socketpair()
    outbox = _Outbox(child_end.fileno(), limit=64 << 20)
    readable = lambda: bool(select.select([parent_end], [], [], 0.05)[0])  # noqa: E731
    for k in range(OUTBOX_BATCH - 1):
        outbox.put(("frame", k))
    assert not readable()  # a waiting parent is not woken per frame
    outbox.put(("frame", "last of the batch"))
    assert readable()
    reader = Connection(parent_end.detach())
    assert [reader.recv()[1] for _ in range(OUTBOX_BATCH)][-1] == "last of the batch"
    outbox.put(("meta",), now=True)
    assert reader.recv() == ("meta",)


def test_a_frame_written_into_the_ring_reads_back_with_empty_slots_beyond_its_extent():
    n, k, m = 16, 5, 3
    rng = np.random.default_rng(0)
    collision_speed, speed, dists = rng.normal(size=n), rng.normal(size=m), rng.normal(size=m)
    codes = rng.integers(-1, 100, m)
    active, reassigned, collided, inattentive = rng.random((4, n)) < 0.5
    size = 4 * background_mod._frame_bytes(n, n)
    ring = background_mod._FrameRing(background_mod._FrameRing.create(size), size)
    position = ring.place(size + 8, background_mod._frame_bytes(k, m))  # past a wrap
    frame = (collision_speed, speed, dists, codes, active, reassigned, collided, inattentive)
    ring.write(position, frame, k, m)
    collisions, *values, flags = ring.read(position, k, m, n)
    np.testing.assert_array_equal(collisions, np.where(np.arange(n) < k, collision_speed, np.nan))
    for got, sent in zip(values, (speed, dists, codes), strict=True):
        np.testing.assert_array_equal(got, sent)
        assert got.dtype == sent.dtype
    expected = np.vstack([active, reassigned, collided, inattentive & active])
    np.testing.assert_array_equal(flags, np.where(np.arange(n) < k, expected, False))


def test_a_full_ring_makes_the_child_wait_and_the_frames_stay_exact(waves, monkeypatch):
    """The smallest ring (16 frames of every slot): the child, far ahead of a parent that
    dawdles, waits for the room the parent gives back, and the ring wraps many times; the
    frames are still those of the in-process source."""
    monkeypatch.setattr(background_mod, "RING_BYTES", 0)  # the parent passes its size on
    cfg = SumoConfig(waves, capacity=64, hazard_rate=200.0, inattentive=0.5, seed=5)
    with SumoSource(cfg) as src:
        inline = trace(src)
    with BackgroundSumoSource(cfg) as src:
        assert src._ring.size == 16 * background_mod._frame_bytes(64, 64)
        time.sleep(0.5)  # the child fills the ring and waits
        background = trace(src)
        assert src._returned > 20 * src._ring.size
    for a, b in zip(inline, background, strict=True):
        assert a[0] == b[0] and a[5] == b[5] and a[6] == b[6]
        for x, y in zip(a[1:5], b[1:5], strict=True):
            np.testing.assert_array_equal(x, y)


def test_a_dead_child_is_a_clear_error(road, tmp_path, monkeypatch):
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # the child's temporary directory
    src = BackgroundSumoSource(config(road, end=600.0))
    os.kill(src.pid, signal.SIGINT)  # Ctrl-C is the parent's: the child carries on
    for _ in range(30):
        src.advance()
    assert src.t == pytest.approx(3.0)
    os.kill(src.pid, signal.SIGKILL)
    with pytest.raises(SumoError, match=r"ended unexpectedly \(exit code -9\)"):
        while True:  # the frames already in the socket come first
            src.advance()
    assert src.closed
    assert not any(tmp_path.iterdir())  # a killed child leaves no files behind


def test_warnings_are_forwarded_and_sources_run_side_by_side(road):
    with pytest.warns(RuntimeWarning, match="more than capacity = 2"):
        with BackgroundSumoSource(config(road, end=20.0, capacity=2)) as small:
            with BackgroundSumoSource(config(road, end=20.0, seed=1)) as other:
                while not small.done:
                    small.advance()
                    other.advance()
                assert small.active.sum() == 2 and other.active.sum() > 2


def test_a_script_without_a_main_guard_can_use_it(road, tmp_path):
    script = tmp_path / "user.py"
    script.write_text(
        textwrap.dedent(
            f"""
            from acc_fusion.truth.sumo.source import SumoConfig
            from acc_fusion.truth.sumo.background import BackgroundSumoSource
            src = BackgroundSumoSource(SumoConfig({str(road / "road.sumocfg")!r}, end=2.0))
            while not src.done:
                src.advance()
            print("ended at", round(src.t, 3))
            src.close()
            """
        )
    )
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ended at 2.0"


def test_simulate_gives_the_same_summary(road):
    cfg = config(road, end=30.0, seed=3, hazard_rate=300.0)
    sim = SimConfig(runs=1, dt=0.1, methods=("radar", "federated"))
    with SumoSource(cfg) as src:
        inline = simulate(replace(sim), source=src).summaries
    with BackgroundSumoSource(cfg) as src:
        background = simulate(replace(sim), source=src).summaries
    assert background == inline and inline["federated"].warnings > 0


def _run_recording_the_occupied_slots(sim, source):
    """``simulate`` ``sim`` on ``source``; returns the result, every step's output on the
    slots that hold a vehicle, the prefix lengths the stages worked on and how many slots
    were given to new vehicles."""
    steps, sizes, new = [], set(), 0

    def record(view):
        nonlocal new
        m = view.frame.n_pairs
        sizes.add(m)
        new += int(source.reassigned.sum())
        act = source.active[:m]
        assert not source.active[m:].any()
        out = [view.oracle[act], view.ttc[act]]
        out += [meas.z[act] for meas in view.measurements]
        for name, est in view.estimates.items():
            ok = est.valid[act]
            out += [ok, est.x[act][ok], est.p[act][ok], view.levels[name][act]]
        steps.append(out)

    with source:
        result = simulate(replace(sim), source=source, on_step=record)
    return result, steps, sizes, new


#: Two waves of cars: the first has left the road before the second comes, so the slots
#: of the first are set aside and then given to the cars of the second.
WAVES = (
    ROUTES[: ROUTES.index("  <flow")]
    + """  <flow id="a" type="car" route="r0" begin="0" end="20" vehsPerHour="3600"
        departLane="random" departSpeed="max"/>
  <flow id="b" type="car" route="r0" begin="140" end="200" vehsPerHour="2400"
        departLane="random" departSpeed="max"/>
</routes>
"""
)


@pytest.fixture
def waves(road, tmp_path) -> str:
    """The ``.sumocfg`` of :data:`WAVES` on the road (200 s)."""
    (tmp_path / "waves.rou.xml").write_text(WAVES)
    cfg = tmp_path / "waves.sumocfg"
    cfg.write_text(sumocfg(str(road / "road.net.xml"), "waves.rou.xml", end=200.0))
    return str(cfg)


def test_same_frames_as_the_in_process_source_as_slots_empty_and_fill_again(waves):
    """The background source sends only the slots up to the last one in use, and the slot
    ids that changed: the parent's frames are still those of the in-process source."""
    cfg = SumoConfig(waves, capacity=64, hazard_rate=200.0, inattentive=0.5, seed=5)
    with SumoSource(cfg) as src:
        inline = trace(src)
    with BackgroundSumoSource(cfg) as src:
        background = trace(src)
    for a, b in zip(inline, background, strict=True):
        assert a[0] == b[0] and a[5] == b[5] and a[6] == b[6]
        for x, y in zip(a[1:5], b[1:5], strict=True):
            np.testing.assert_array_equal(x, y)
    empty = [not step[3][0].any() for step in inline]  # between the waves
    assert any(empty) and not empty[-1] and inline[-1][6][4] > 0  # and some collisions


@pytest.mark.parametrize("drive", [None, "federated"])
def test_the_run_on_the_occupied_slots_equals_the_run_on_every_slot(waves, monkeypatch, drive):
    """Open loop and closed loop (the warned drivers brake, so the traffic itself depends on
    every warning): the same measurements, estimates, levels, metrics and collisions, as the
    slots of vehicles that left are set aside and later given to new vehicles."""
    cfg = SumoConfig(waves, capacity=64, hazard_rate=60.0, seed=2)
    methods = ("radar", "infrared", "centralized", "federated")
    sim = SimConfig(
        runs=1, dt=0.1, methods=methods if drive is None else (drive,), drive=drive,
        radar={"ghost_rate": 2.0},
    )  # fmt: skip
    runs = []
    for quantum in (8, 64):  # 64 = the capacity: every slot at every step
        monkeypatch.setattr(fcw, "Extent", lambda n, q=quantum: Extent(n, quantum=q))
        runs.append(_run_recording_the_occupied_slots(sim, SumoSource(cfg)))
    (prefix, steps_prefix, sizes, new), (full, steps_full, _, _) = runs
    assert len(sizes) > 3 and new > 30  # the prefix moved; slots were given to new vehicles
    for a, b in zip(steps_prefix, steps_full, strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)
    assert prefix.summaries == full.summaries
    np.testing.assert_array_equal(prefix.collided, full.collided)
    assert prefix.summaries[methods[-1]].warnings > 0
    assert prefix.summaries[methods[-1]].per_pair["hours"].shape == (64,)
