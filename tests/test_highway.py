"""highway-env truth source: gap geometry against highway-env's own positions and lengths,
new leaders and episodes, closed-loop braking, collisions, the three environments through
the Python API and the CLI (with --out and a rendered replay), the bad-input errors and the
benchmark script.  highway-fast-v0 with few vehicles and short episodes keeps it fast."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("highway_env")

from acc_fusion.cli.main import main  # noqa: E402
from acc_fusion.core.errors import ConfigError, InputError  # noqa: E402
from acc_fusion.sim.closed_loop import SimConfig, simulate  # noqa: E402
from acc_fusion.studies.highway import highway_study
from acc_fusion.truth.distraction import DistractionConfig
from acc_fusion.truth.driver import DriverConfig
from acc_fusion.truth.highway.config import (
    INSTALL,
    SUPPORTED,
    HighwayConfig,
    HighwayError,
    load_highway_env,
)
from acc_fusion.truth.highway.source import HighwaySource

ROOT = Path(__file__).resolve().parents[1]


def expected_pair(road, v, lookahead=250.0):
    """highway-env's own leader of ``v`` (``Road.neighbour_vehicles``, vehicles only) and the
    bumper-to-bumper gap from its lane coordinates and the vehicles' lengths."""
    from highway_env.vehicle.kinematics import Vehicle

    front, _ = road.neighbour_vehicles(v)
    if not isinstance(front, Vehicle):
        return None, np.nan, 0.0
    lane = road.network.get_lane(v.lane_index)
    s_ego, r_ego = lane.local_coordinates(v.position)
    s_lead, r_lead = lane.local_coordinates(front.position)
    gap = s_lead - s_ego - 0.5 * (v.LENGTH + front.LENGTH)
    if gap > lookahead:
        return None, np.nan, 0.0
    return front, gap, r_lead - r_ego


@pytest.mark.parametrize(("env", "steps"), [("highway-fast-v0", 60), ("merge-v0", 150)])
def test_gap_and_leader_match_highway_env(env, steps):
    """Every slot, every step: highway-env's leader (its id), the gap from lane coordinates and
    lengths, the lateral offset; merge-v0 includes the ramp's sine lane."""
    cfg = HighwayConfig(
        env, episodes=1, pairs="all", vehicles_count=12 if "highway" in env else None
    )
    with HighwaySource(cfg) as src:
        road = src.env.road
        compared = leaders = 0
        lanes = set()
        for _ in range(steps):
            frame = src.frame()
            for i, v in enumerate(src.vehicles):
                if not src.active[i]:
                    continue
                lanes.add(type(v.lane).__name__)
                front, gap, lat = expected_pair(road, v)
                if front is None:
                    from highway_env.vehicle.kinematics import Vehicle

                    f, _ = road.neighbour_vehicles(v)
                    if f is not None and not isinstance(f, Vehicle):
                        continue  # merge-v0's obstacle: not a target
                    assert frame.leader_id[i] == -1
                else:
                    assert frame.leader_id[i] == src.id_of(front)
                    assert frame.gap[i] == pytest.approx(gap, abs=1e-9)
                    assert frame.lateral_offset[i] == pytest.approx(lat, abs=1e-9)
                    leaders += 1
                compared += 1
            if src.terminated or src.truncated:
                break
            src.advance()
        assert compared > 100 and leaders > 20
        if env == "merge-v0":
            assert "SineLane" in lanes


def test_speeds_and_accelerations_are_highway_envs():
    with HighwaySource(HighwayConfig("highway-fast-v0", episodes=1, vehicles_count=5)) as src:
        src.advance()
        prev = [v.speed for v in src.vehicles]
        frame = src.advance()
        for i, v in enumerate(src.vehicles):
            lane = src.env.road.network.get_lane(v.lane_index)
            u = v.speed * np.cos(v.heading - lane.heading)
            assert frame.ego_speed[i] == pytest.approx(max(u, 0.0), abs=1e-12)
            assert frame.ego_accel[i] == pytest.approx((v.speed - prev[i]) / src.dt, abs=1e-9)


def test_new_leader_is_a_new_target():
    """A vehicle put between the ego and its leader becomes the leader, with its own id."""
    with HighwaySource(HighwayConfig("highway-fast-v0", episodes=1, vehicles_count=6)) as src:
        ego = src.env.vehicle
        frame = src.frame()
        old = int(frame.leader_id[0])
        other = next(v for v in src.env.road.vehicles if v is not ego and src.id_of(v) != old)
        other.position = ego.position + np.array([12.0, 0.0])
        other.heading, other.speed = ego.heading, ego.speed
        other.on_state_update()
        frame = src.advance()
        assert frame.leader_id[0] == src.id_of(other) != old
        lane = src.env.road.network.get_lane(ego.lane_index)
        expected = (
            lane.local_coordinates(other.position)[0]
            - lane.local_coordinates(ego.position)[0]
            - 0.5 * (ego.LENGTH + other.LENGTH)
        )
        assert frame.gap[0] == pytest.approx(expected, abs=1e-9)


def test_episodes_reassign_slots_with_fresh_ids_and_reproduce():
    cfg = HighwayConfig("highway-fast-v0", episodes=2, duration=1.0, vehicles_count=4, seed=3)
    frames = []
    with HighwaySource(cfg) as src:
        assert src.reassigned.all() and src.n_pairs == 5
        first_ids = set(src.frame().leader_id[src.frame().leader_id >= 0])
        steps = 0
        while not src.done:
            frames.append(src.frame())
            src.advance()
            steps += 1
            if src.episode == 1 and src.reassigned.any():
                assert src.reassigned.all() and not src.collided.any()
                new_ids = set(src.frame().leader_id[src.frame().leader_id >= 0])
                assert new_ids and not new_ids & first_ids
        assert steps == src.n_steps == 2 * (int(round(1.0 / src.dt)) + 1)
        assert not src.active.any()
        with pytest.raises(HighwayError):
            src.advance()
    with HighwaySource(cfg) as again:
        for f in frames:
            np.testing.assert_array_equal(again.frame().gap, f.gap)
            np.testing.assert_array_equal(again.frame().leader_id, f.leader_id)
            if not again.done:
                again.advance()


def test_brake_request_decelerates_the_controlled_vehicle():
    cfg = HighwayConfig("highway-fast-v0", episodes=1, pairs="controlled", vehicles_count=3)
    with HighwaySource(cfg) as src, HighwaySource(cfg) as free:
        v0 = src.frame().ego_speed[0]
        for _ in range(5):
            frame = src.advance(np.array([4.0]))
            free.advance(None)
            assert frame.ego_accel[0] == pytest.approx(-4.0, abs=1e-9)
        assert frame.ego_speed[0] == pytest.approx(v0 - 5 * 4.0 * src.dt, abs=1e-6)
        assert free.frame().ego_speed[0] > frame.ego_speed[0] + 3.0
        src.advance(np.array([0.0]))  # released: keeps the speed braked down to
        assert src.env.vehicle.target_speed == pytest.approx(frame.ego_speed[0], abs=1e-6)
        for _ in range(10):
            src.advance(np.array([np.nan]))
        assert src.frame().ego_speed[0] == pytest.approx(frame.ego_speed[0], abs=0.05)
        with pytest.raises(InputError):
            src.advance(np.array([-1.0]))


def test_forward_collision_is_flagged_on_the_collider_only():
    """highway-fast-v0 seed 0: the cruising ego runs into its leader after about 15 s."""
    with HighwaySource(HighwayConfig("highway-fast-v0", episodes=1, pairs="all")) as src:
        while not (src.terminated or src.truncated):
            before = src.frame()
            src.advance()
        assert src.terminated and src.env.vehicle.crashed
        assert src.collided[0] and src.n_collisions == 1 and src.n_crashes == 2
        assert src.collision_speed[0] == pytest.approx(
            before.ego_speed[0] - before.lead_speed[0], abs=0.5
        )
        assert src.collision_speed[0] > 0
        src.advance()
        assert src.done


def test_restart_for_the_gymnasium_environment():
    cfg = HighwayConfig("highway-fast-v0", episodes=1, pairs="controlled", duration=0.4)
    with HighwaySource(cfg) as src:
        while not src.done:
            src.advance()
        t = src.t
        src.restart(np.array([False]), None)
        assert src.done
        src.restart(np.array([True]), np.random.default_rng(1))
        assert not src.done and src.active.all() and src.reassigned.all()
        assert src.t == t and src.episode == 1
        src.advance()
        assert src.t == pytest.approx(t + src.dt)
        with pytest.raises(InputError):
            src.restart(np.array([1]), 0)


@pytest.mark.parametrize("env", SUPPORTED)
def test_python_api_runs_every_environment(env):
    cfg = HighwayConfig(
        env, episodes=2, duration=2.0, vehicles_count=None if env == "merge-v0" else 8
    )
    study = highway_study(cfg, SimConfig(runs=1))
    table = study.table()
    assert [r["method"] for r in table.rows] == ["radar", "infrared", "centralized", "federated"]
    assert list(study.on.summaries) == ["federated"]
    assert study.off.summaries["federated"].hours > 0
    assert study.off.episodes == 2 and study.off.pairs == (5 if env == "merge-v0" else 9)
    assert "ego-vehicle collisions" in table.format()
    # The benefit pairs every (episode, ego) of both runs; its crashes are the collisions.
    b = study.benefit()
    assert b.vehicles == len(study.off.egos | study.on.egos) >= study.off.pairs
    assert (b.crashes_off, b.crashes_on) == (study.off.collisions, study.on.collisions)
    assert "Crashes FCW avoids" in study.benefits().format()


def test_cli_writes_table_outputs_and_gif(tmp_path, capsys):
    from PIL import Image

    gif = tmp_path / "replay" / "x.gif"
    args = ["highway", "--env", "highway-fast-v0", "--episodes", "1", "--duration", "2"]
    args += ["--vehicles", "4", "--out", str(tmp_path / "out"), "--render", str(gif)]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "FCW in highway-env traffic: highway-fast-v0" in text and "federated" in text
    stem = tmp_path / "out" / "highway_highway-fast-v0_seed0"
    for suffix in (".csv", ".png", ".json"):
        assert Path(str(stem) + suffix).stat().st_size > 0
    benefit = json.loads(Path(str(stem) + ".json").read_text())["benefit"]
    assert {"crashes_off", "crashes_on", "reduction", "reduction_lo", "reduction_hi"} <= set(
        benefit
    )
    with Image.open(gif) as im:
        assert im.n_frames == 11  # 2 s at 5 Hz: frames 0..10 (the end frame included)
        assert im.size == (600, 150 + 34)


def test_unknown_env_lists_the_supported_ones(capsys):
    with pytest.raises(ConfigError) as err:
        HighwayConfig("racetrack-v0")
    assert all(e in str(err.value) for e in SUPPORTED)
    assert main(["highway", "--env", "nope-v0", "--episodes", "1"]) == 2
    assert "highway-fast-v0" in capsys.readouterr().err


def test_missing_highway_env_gives_the_install_command(monkeypatch):
    monkeypatch.setitem(sys.modules, "highway_env", None)  # import highway_env -> ImportError
    with pytest.raises(ConfigError, match=re.escape(INSTALL)):
        load_highway_env()
    with pytest.raises(ConfigError, match=re.escape(INSTALL)):
        HighwaySource(HighwayConfig("highway-fast-v0"))


def test_bad_values_are_one_sentence_errors(monkeypatch, tmp_path, capsys):
    for bad in (
        {"episodes": 0},
        {"pairs": "some"},
        {"duration": -1.0},
        {"seed": -1},
        {"vehicles_count": 2.5},
        {"env_config": {1: 2}},
    ):
        with pytest.raises(ConfigError):
            HighwayConfig(**bad)
    with pytest.raises(ConfigError, match="vehicles_count"):
        HighwaySource(HighwayConfig("merge-v0", vehicles_count=3))
    with pytest.raises(ConfigError, match="no_such_key"):
        HighwaySource(HighwayConfig("highway-fast-v0", env_config={"no_such_key": 1}))
    assert main(["highway", "--render", str(tmp_path / "x.avi")]) == 2
    assert "'.gif', '.mp4'" in capsys.readouterr().err
    assert main(["highway", "--world", "--distraction", "60"]) == 2
    assert "no driver to distract" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "imageio", None)
    from acc_fusion.studies.highway import check_replay_path

    with pytest.raises(ConfigError, match="imageio"):
        check_replay_path(tmp_path / "x.mp4")
    with pytest.raises(HighwayError):
        HighwaySource(HighwayConfig("highway-fast-v0")).render()


def test_bench_script_prints_the_ratio():
    proc = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "bench_highway.py"), "--env", "merge-v0"]
        + ["--episodes", "1", "--duration", "1", "--quick"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr
    assert re.fullmatch(r"overhead_ratio=\d+\.\d+", proc.stdout.strip().splitlines()[-1])


def test_a_distracted_drivers_vehicle_keeps_its_speed_unless_he_brakes():
    cfg = HighwayConfig("highway-v0", episodes=1, duration=2.0, vehicles_count=12)
    with HighwaySource(cfg) as held, HighwaySource(cfg) as free:
        n = held.n_pairs
        brake, hold = np.zeros(n), np.ones(n, dtype=bool)
        brake[0] = 3.0  # braking wins over holding
        free_accel = 0.0
        for _ in range(8):
            frame = held.advance(brake, hold)
            active = held.active[1:n]
            assert frame.ego_accel[0] == pytest.approx(-3.0, abs=1e-9)
            np.testing.assert_allclose(frame.ego_accel[1:n][active], 0.0, atol=1e-9)
            free_accel = max(free_accel, np.abs(free.advance().ego_accel[1:n]).max())
        assert free_accel > 0.1  # their IDMs, in the loop, do accelerate and brake


def test_highway_env_runs_distracted_drivers_in_closed_loop():
    cfg = SimConfig(
        runs=1,
        drive="federated",
        driver=DriverConfig(distraction=DistractionConfig(rate=1800.0)),
    )
    held = []
    with HighwaySource(HighwayConfig("highway-fast-v0", episodes=1, duration=3.0)) as source:
        result = simulate(
            replace(cfg, dt=source.dt),
            source=source,
            on_step=lambda view: held.append(int(view.driver.holding.sum())),
        )
    assert result.steps > 0 and max(held) > 0
