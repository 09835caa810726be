"""The traffic realism check: its statistics on trajectories with known answers, the reference
check, the collectors of SUMO, highway-env and recordings, and scripts/traffic_realism.py."""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.metrics.realism import (
    MAX_HEADWAY,
    braking_onsets,
    by_odometer,
    lane_changes,
    realism_stats,
    time_headways,
    time_to_collision,
)
from acc_fusion.metrics.realism_references import REFERENCES, check, reference_of
from acc_fusion.truth.trajectories import COLUMNS, Trajectories

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "traffic_realism.py"


def trajectories(**columns) -> Trajectories:
    """Trajectories of one vehicle at 0.1 s steps unless ``columns`` say otherwise; a missing
    column is zeros (NaN for the leader's figures)."""
    n = len(next(iter(columns.values())))
    base = {
        "vehicle": np.zeros(n, dtype=np.int64),
        "time": 0.1 * np.arange(n),
        "speed": np.full(n, 20.0),
        "accel": np.zeros(n),
        "lane": np.zeros(n, dtype=np.int64),
        "road": np.zeros(n, dtype=np.int64),
        "gap": np.full(n, np.nan),
        "lead_speed": np.full(n, np.nan),
        "lead_length": np.full(n, np.nan),
        "odometer": 2.0 * np.arange(n),
    }
    base.update({k: np.asarray(v) for k, v in columns.items()})
    return Trajectories(**base, dt=0.1, label="test")


# ------------------------------------------------------------------ statistics, known answers
def test_an_onset_is_counted_once_per_braking_and_again_after_a_release():
    """Two brakings past 4.4 m/s² (the first held three steps), one release in between, one
    braking only to 4.0: two onsets at 4.4, three at 3.0 and 3.6."""
    a = [0, -5, -5, -5, -1, -4.5, -4.5, 0, -4.0, 0]
    traj = trajectories(accel=a)
    assert np.flatnonzero(braking_onsets(traj, 4.4)).tolist() == [1, 5]
    assert braking_onsets(traj, 3.6).sum() == 3 and braking_onsets(traj, 3.0).sum() == 3
    with pytest.raises(InputError, match="threshold must be > 0"):
        braking_onsets(traj, 0.0)


def test_onsets_follow_each_vehicle_in_time_whatever_the_sample_order():
    """Two vehicles braking at the same steps, their samples shuffled: one onset each; a
    vehicle that reappears after a gap in time starts a new braking."""
    t = np.r_[0.1 * np.arange(4), 0.1 * np.arange(4), 0.1 * np.array([0, 1, 5, 6])]
    v = np.repeat([0, 1, 2], 4)
    a = np.array([0, -5, -5, 0] * 2 + [-5, -5, -5, -5])
    order = np.random.default_rng(0).permutation(t.size)
    traj = trajectories(vehicle=v[order], time=t[order], accel=a[order])
    onset = braking_onsets(traj, 4.4)
    assert onset.sum() == 4  # vehicles 0 and 1 once, vehicle 2 at 0.0 s and again at 0.5 s
    assert sorted(t[order][onset & (v[order] == 2)].round(3).tolist()) == [0.0, 0.5]


def test_onsets_per_100km_and_by_the_distance_driven():
    """1000 steps at 20 m/s = 2 km; two onsets: 100 per 100 km; by odometer, each bin holds
    its share of the kilometres and the onsets where they happened."""
    a = np.zeros(1000)
    a[[100, 700]] = -5.0
    traj = trajectories(accel=a)
    stats = realism_stats(traj)
    assert traj.km == pytest.approx(2.0)
    assert stats.onsets_per_100km(4.4) == pytest.approx(100.0)
    counts, km = by_odometer(traj, braking_onsets(traj, 4.4), (0.0, 1000.0, math.inf))
    assert counts.tolist() == [1.0, 1.0] and km == pytest.approx([1.0, 1.0])


def test_headways_are_front_to_front_and_keep_car_following_only():
    """Headways (gap + leader length) / speed: 20 m gap + 5 m car at 25 m/s = 1 s; 45 m at
    25 m/s = 2 s; 120 m = 5 s (kept), 145 m = 6 s (not car following), a follower at 4 m/s
    (not), no leader (not): median of [1, 1, 2, 5] = 1.5 s, none under 1 s, half under 2 s."""
    gap = [20, 20, 45, 120, 145, 20, np.nan]
    speed = [25, 25, 25, 25, 25, 4, 25]
    traj = trajectories(
        gap=gap, speed=speed, lead_length=[5.0] * 6 + [np.nan], lead_speed=[25.0] * 7
    )
    h = time_headways(traj)
    assert h == pytest.approx([1.0, 1.0, 2.0, 5.0]) and h.max() <= MAX_HEADWAY
    stats = realism_stats(traj)
    assert stats.headway_median == pytest.approx(1.5)
    assert stats.headway_below_1s == 0.0 and stats.headway_below_2s == 0.5
    assert stats.following_share == pytest.approx(4 / 7)


def test_ttc_is_gap_over_closing_speed_and_its_shares_count_car_following():
    """Four car-following samples with gap 20 m: closing at 10 m/s (TTC 2 s), at 5 m/s (4 s),
    at 20 m/s (1 s), opening (inf): TTC < 3 s in half, < 1.5 s in a quarter."""
    speed = np.array([30.0, 30.0, 30.0, 30.0])
    lead = np.array([20.0, 25.0, 10.0, 35.0])
    traj = trajectories(speed=speed, lead_speed=lead, gap=[20.0] * 4, lead_length=[5.0] * 4)
    assert time_to_collision(traj) == pytest.approx([2.0, 4.0, 1.0, np.inf])
    stats = realism_stats(traj)
    assert stats.ttc_below == (0.5, 0.25)


def test_lane_changes_count_changes_on_one_road_only():
    """Lanes 0 0 1 1 2 on road 0, then road 1 lane 0 (a new road renumbers: no change), then
    lane 1 on road 1: three lane changes; an unknown lane (-1) is no change."""
    lane = [0, 0, 1, 1, 2, 0, 1, -1, 1]
    road = [0, 0, 0, 0, 0, 1, 1, 1, 1]
    traj = trajectories(lane=lane, road=road)
    assert np.flatnonzero(lane_changes(traj)).tolist() == [2, 4, 6]
    stats = realism_stats(traj)
    assert stats.lane_changes == 3
    assert stats.figures()[[f.key for f in stats.figures()].index("lane_changes")].value == (
        pytest.approx(100.0 * 3 / traj.km)
    )


def test_speed_and_acceleration_distributions():
    speed = np.linspace(10.0, 30.0, 101)
    accel = np.linspace(-2.0, 2.0, 101)
    stats = realism_stats(trajectories(speed=speed, accel=accel))
    assert stats.speed_mean == pytest.approx(20.0) and stats.accel_mean == pytest.approx(0.0)
    assert stats.speed_percentiles == pytest.approx((11.0, 20.0, 29.0))
    assert stats.accel_percentiles == pytest.approx((-1.96, -1.8, 1.8, 1.96))
    assert stats.speed_sd == pytest.approx(np.std(speed))


def test_trajectories_refuse_columns_of_different_lengths():
    cols = {name: np.zeros(3) for name in COLUMNS}
    cols["speed"] = np.zeros(2)
    with pytest.raises(InputError, match="speed has 2 samples"):
        Trajectories(**cols, dt=0.1)
    with pytest.raises(InputError, match="dt must be > 0"):
        Trajectories(**{name: np.zeros(1) for name in COLUMNS}, dt=0.0)


# ------------------------------------------------------------------ the reference check
def test_every_reference_names_a_figure_cites_its_source_and_holds_its_value():
    keys = {f.key for f in realism_stats(trajectories(speed=[20.0])).figures()}
    for ref in REFERENCES:
        assert ref.key in keys, ref.key
        assert re.search(r"(19|20)\d\d", ref.source) and ref.definition and ref.band
        assert ref.low <= ref.high
        assert math.isnan(ref.value) or ref.low <= ref.value <= ref.high


def test_the_check_passes_fails_and_says_where_there_is_no_reference():
    """A vehicle at 25 m/s for 2 km, following at 1.8 s: its median passes King et al.'s band
    but all its headways are under 2 s (fails 48-68 %); one hard braking (50 per 100 km:
    fails Simons-Morton's 0.57); no lane change (fails highD's 12.4)."""
    n = 800
    a = np.zeros(n)
    a[10] = -5.0
    traj = trajectories(
        speed=np.full(n, 25.0), accel=a, gap=np.full(n, 40.0), lead_length=np.full(n, 5.0),
        lead_speed=np.full(n, 25.0),
    )  # fmt: skip
    rows = {r.figure.key: r for r in check(realism_stats(traj))}
    assert rows["headway_median"].status == "pass"
    assert rows["onsets_4.4"].status == "fail"
    assert rows["lane_changes"].status == "fail"
    assert rows["onsets_3"].status == "no reference" and rows["onsets_3"].reference is None
    assert rows["headway_below_2s"].status == "fail"
    empty = {r.figure.key: r for r in check(realism_stats(trajectories(speed=[2.0])))}
    assert empty["headway_median"].status == "no data"
    assert reference_of("onsets_4.4").high == pytest.approx(0.57)


# ------------------------------------------------------------------ SUMO
def test_the_sumo_collector_reads_every_vehicle_with_its_leader():
    """30 s of the bundled motorway after 20 s: every sample after the warm-up, at SUMO's
    step; gaps bumper to bumper (never negative), leaders' lengths those of the net's types,
    odometers growing; and the counts agree with hard_braking.py's own (per-vehicle) count
    on the same run."""
    pytest.importorskip("libsumo")
    from acc_fusion.truth.sumo.config import SumoConfig
    from acc_fusion.truth.sumo.nets import resolve_sumocfg
    from acc_fusion.truth.sumo.trajectories import sumo_trajectories

    config = SumoConfig(str(resolve_sumocfg("motorway", None)))
    traj = sumo_trajectories(config, 50.0, 20.0, progress=False)
    assert traj.dt == pytest.approx(0.1) and traj.label == "motorway.sumocfg"
    assert traj.time.min() == pytest.approx(20.0) and traj.time.max() == pytest.approx(50.0)
    steps = np.unique(traj.time.round(3)).size
    assert steps == 301 and len(traj) > 100 * steps
    has = np.isfinite(traj.gap)
    assert has.mean() > 0.8 and traj.gap[has].min() >= 0.0
    assert 5.0 in set(np.unique(traj.lead_length[has])) <= {5.0, 12.0, 16.5}
    order = np.lexsort((traj.time, traj.vehicle))
    same = traj.vehicle[order][1:] == traj.vehicle[order][:-1]
    assert np.all(np.diff(traj.odometer[order])[same] >= -1e-9)
    stats = realism_stats(traj)
    assert stats.km > 50 and stats.headways > 0.5 * len(traj)


def run_script(*args: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(SCRIPT), *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def test_the_script_prints_the_table_and_ends_with_the_hard_braking_rate(tmp_path):
    pytest.importorskip("libsumo")
    png = tmp_path / "realism.png"
    proc = run_script("--end", "60", "--warmup", "30", "--plot", str(png))
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    m = re.fullmatch(r"hard_brakes_per_100km=(\d+\.\d{3})", lines[-1])
    assert m, lines[-1]
    row = next(ln for ln in lines if ln.startswith("braking onsets ≥ 4.4 m/s²"))
    assert float(row.split()[8]) == pytest.approx(float(m.group(1)), rel=0.01)
    assert "Simons-Morton et al. 2011" in row and re.search(r"\b(pass|fail)\b", row)
    assert "King et al. 2022" in proc.stdout and "no reference" in proc.stdout
    assert png.stat().st_size > 20_000


def test_the_script_refuses_a_warmup_past_the_end():
    proc = run_script("--end", "10", "--warmup", "20")
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "traffic_realism.py: error: --warmup must be in [0, --end), got 20"
    ]


# ------------------------------------------------------------------ highway-env and recordings
def test_the_highway_collector_reads_every_road_vehicle_of_every_episode():
    """5 s of highway-v0 in episodes of 3 s with 10 vehicles and the controlled one, 1 s of
    warm-up each: two episodes (the second cut at 5 s), ids never reused, time within the
    episode, gaps bumper to bumper between highway-env's 5 m vehicles; a warm-up as long as
    an episode is refused."""
    pytest.importorskip("highway_env")
    from acc_fusion.truth.highway.config import HighwayConfig
    from acc_fusion.truth.highway.trajectories import highway_trajectories

    config = HighwayConfig("highway-v0", duration=3.0, vehicles_count=10, seed=1)
    traj = highway_trajectories(config, 1.0, 5.0, progress=False)
    assert traj.dt == pytest.approx(1 / 15) and traj.label == "highway-v0"
    assert traj.time.min() == pytest.approx(1.0) and traj.time.max() <= 3.0 + 1e-9
    per_vehicle_steps = np.bincount(np.unique(traj.vehicle, return_inverse=True)[1])
    assert np.unique(traj.vehicle).size == 2 * 11 and per_vehicle_steps.max() <= 31
    has = np.isfinite(traj.gap)
    assert has.any() and np.all(traj.lead_length[has] == 5.0) and traj.gap[has].min() >= 0
    assert np.all(traj.lane >= 0) and realism_stats(traj).km > 0.5
    with pytest.raises(ConfigError, match=r"warmup must be in \[0, 3\) s"):
        highway_trajectories(config, 3.0, 4.0, progress=False)


def test_the_replay_collector_reads_a_recording_with_its_leaders_and_lane_change(tmp_path):
    """A synthetic highD recording (IDM traffic, one lane change at 10 s): every row is a
    sample, the gaps are the simulation's, the one lane change is counted, and the warm-up
    and end cut the recording's time."""
    from acc_fusion.truth.replay.source import ReplayConfig
    from acc_fusion.truth.replay.synthetic import simulate_traffic, write_highd
    from acc_fusion.truth.replay.trajectories import replay_trajectories

    sim = simulate_traffic(lanes=2, duration=30.0, dt=0.04, seed=3)
    write_highd(sim, tmp_path, 7)
    config = ReplayConfig("highd", str(tmp_path))
    traj = replay_trajectories(config)
    assert len(traj) == sim.vid.size and traj.dt == pytest.approx(0.04)
    truth = np.sort(sim.gap()[np.isfinite(sim.gap())])
    assert np.sort(traj.gap[np.isfinite(traj.gap)]) == pytest.approx(truth, abs=0.02)
    assert realism_stats(traj).lane_changes == 1
    assert traj.odometer.min() == 0.0 and traj.km == pytest.approx(
        sim.speed.sum() * 0.04 / 1000, rel=1e-3
    )
    cut = replay_trajectories(config, 5.0, 20.0)
    assert cut.time.min() >= 5.0 - 1e-9 and cut.time.max() <= 20.0 + 1e-9
    assert 0 < len(cut) < len(traj)


def test_the_script_checks_a_recording(tmp_path):
    from acc_fusion.truth.replay.synthetic import simulate_traffic, write_highd

    write_highd(simulate_traffic(lanes=2, duration=20.0, dt=0.04, seed=3), tmp_path, 1)
    proc = run_script("--replay", "highd", "--path", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("highD 01: ")
    assert re.fullmatch(r"hard_brakes_per_100km=\d+\.\d{3}", proc.stdout.strip().splitlines()[-1])
