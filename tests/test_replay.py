"""Recorded traffic as truth: the readers of highD, NGSIM and mapped CSV files (written here
from a simulated ground truth), the pairs, the cross-check and the replay source."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from acc_fusion.cli.main import main
from acc_fusion.sim.closed_loop import SimConfig, simulate
from acc_fusion.truth.replay.crosscheck import CrossCheck
from acc_fusion.truth.replay.generic import CsvMapping, CsvRecording
from acc_fusion.truth.replay.highd import HighDRecording
from acc_fusion.truth.replay.ngsim import NgsimRecording
from acc_fusion.truth.replay.pairs import build_pairs
from acc_fusion.truth.replay.source import ReplayConfig, ReplaySource, pack
from acc_fusion.truth.replay.synthetic import (
    simulate_traffic,
    write_csv,
    write_highd,
    write_ngsim,
)


@pytest.fixture(scope="module")
def traffic():
    """40 s of two lanes per carriageway at 25 Hz, one lane change."""
    return simulate_traffic(lanes=2, duration=40.0, dt=0.04, seed=3)


@pytest.fixture(scope="module")
def ngsim_traffic():
    return simulate_traffic(lanes=2, duration=40.0, dt=0.1, seed=4)


def _rows(recording):
    (f0, f1, _), *_ = recording.windows()
    return recording.rows(f0, f1)


def _truth_gap_by_row(traffic, pairs, keep=None):
    """The simulated gap of each replayed row (matched by vehicle and order)."""
    keep = np.ones(traffic.vid.size, dtype=bool) if keep is None else keep
    gap = traffic.gap()[keep]
    order = np.lexsort((traffic.frame[keep], traffic.vid[keep]))
    assert np.array_equal(traffic.vid[keep][order], pairs.vid)
    return gap[order]


def test_highd_gaps_are_the_simulated_ones_in_both_directions(traffic, tmp_path):
    write_highd(traffic, tmp_path, 7)
    pairs = build_pairs(_rows(HighDRecording(tmp_path, 7)))
    truth = _truth_gap_by_row(traffic, pairs)
    has = np.isfinite(truth)
    assert np.array_equal(has, pairs.has_leader)
    for direction in (1, 2):  # upper (driving left) and lower (driving right) carriageway
        sel = has & (traffic.direction[np.lexsort((traffic.frame, traffic.vid))] == direction)
        assert sel.sum() > 1000
        assert np.abs(pairs.gap[sel] - truth[sel]).max() < 0.02  # files round to 0.01 m
    assert pairs.ego_speed.min() >= 0.0  # speeds along the driving direction


def test_highd_cross_check_against_dhw_thw_ttc(traffic, tmp_path):
    write_highd(traffic, tmp_path, 1)
    check = CrossCheck("gap")
    check.add(build_pairs(_rows(HighDRecording(tmp_path, 1))))
    for name in ("headway", "thw", "ttc"):
        figure = check.figures[name]
        assert figure.compared > 500, name
        assert figure.share_within == 1.0, name
    assert abs(check.figures["headway"].mean_diff) < 0.005  # dhw is bumper to bumper here


def test_highd_cross_check_sees_a_front_to_front_headway(traffic, tmp_path):
    """Had highD's dhw been measured front to front, the cross-check would show it."""
    write_highd(traffic, tmp_path, 1)
    rec = HighDRecording(tmp_path, 1)
    pairs = build_pairs(_rows(rec))
    pairs.ref["headway"] = pairs.ref["headway"] + pairs.lead_length  # front to front
    check = CrossCheck("gap")
    check.add(pairs)
    mean_length = np.nanmean(pairs.lead_length)
    assert check.figures["headway"].share_within < 0.01
    assert check.figures["headway"].mean_diff == pytest.approx(-mean_length, rel=1e-3)


@pytest.mark.parametrize("lanes", [2, 3])
def test_highd_leaders_from_the_file_agree_with_the_recomputed_ones(lanes, tmp_path):
    traffic = simulate_traffic(lanes=lanes, duration=40.0, dt=0.04, seed=3)
    write_highd(traffic, tmp_path, 1)
    rows = _rows(HighDRecording(tmp_path, 1))
    a, b = build_pairs(rows), build_pairs(rows, recompute=True)
    assert a.either > 5000 and a.agree == a.either
    assert np.array_equal(a.leader_id, b.leader_id)


def test_a_lane_change_is_a_new_target(traffic, tmp_path):
    write_highd(traffic, tmp_path, 1)
    pairs = build_pairs(_rows(HighDRecording(tmp_path, 1)))
    lanes = {}
    for vid, lane in zip(traffic.vid, traffic.lane, strict=True):
        lanes.setdefault(int(vid), set()).add(int(lane))
    changers = [v for v, s in lanes.items() if len(s) > 1]
    assert len(changers) == 1
    leaders = pairs.leader_id[(pairs.vid == changers[0]) & pairs.has_leader]
    assert np.unique(leaders).size >= 2  # the leader in the old lane, then the new one


def test_ngsim_feet_are_converted_and_space_headway_is_front_to_front(ngsim_traffic, tmp_path):
    path = write_ngsim(ngsim_traffic, tmp_path / "ngsim.csv")
    rec = NgsimRecording(path)
    assert rec.dt == pytest.approx(0.1)
    pairs = build_pairs(_rows(rec))
    keep = ngsim_traffic.direction == 2
    truth = _truth_gap_by_row(ngsim_traffic, pairs, keep)
    has = np.isfinite(truth)
    assert np.abs(pairs.gap[has] - truth[has]).max() < 0.01
    check = CrossCheck(rec.headway_basis)
    check.add(pairs)
    for name in ("headway", "thw"):
        assert check.figures[name].compared > 1000
        assert check.figures[name].share_within == 1.0
    assert check.figures["ttc"].compared == 0  # NGSIM has no TTC column


def test_generic_csv_centre_positions_lanes_from_lateral(ngsim_traffic, tmp_path):
    """Positions measured at the vehicle's centre; the lanes come from the lateral positions
    and the leaders are recomputed (no leader column)."""
    path = write_csv(ngsim_traffic, tmp_path / "curve.csv", leader=False)
    mapping = CsvMapping(position="s_mid", position_ref="centre", lane=None, lateral="y",
                         lane_width=3.75)  # fmt: skip
    rec = CsvRecording(path, mapping)
    rows = _rows(rec)
    assert rows.leader is None
    pairs = build_pairs(rows)
    truth = _truth_gap_by_row(ngsim_traffic, pairs, ngsim_traffic.direction == 2)
    has = np.isfinite(truth)
    assert np.array_equal(has, pairs.has_leader)
    assert np.abs(pairs.gap[has] - truth[has]).max() < 1e-3


def test_pack_plays_every_row_once_segment_by_segment():
    start = np.zeros(20, dtype=bool)
    start[[0, 7, 9, 15]] = True  # segments of 7, 2, 6, 5 rows
    index, begins = pack(start, 2)
    assert index.shape == (11, 2)  # LPT: 7 + 2 and 6 + 5
    played = index[index >= 0]
    assert np.array_equal(np.sort(played), np.arange(20))
    for j in range(2):
        col = index[:, j][index[:, j] >= 0]
        assert np.all(np.diff(col)[~start[col[1:]]] == 1)  # a segment plays in order
    assert begins.sum() == 4 and np.all(start[index[begins]])


def test_windows_give_the_same_pairs_as_one(traffic, tmp_path):
    write_highd(traffic, tmp_path, 1)
    one = ReplaySource(ReplayConfig("highd", str(tmp_path), slots=64))
    many = ReplaySource(ReplayConfig("highd", str(tmp_path), slots=64, max_rows=5000))
    assert len(many._plan) > 5 and len(one._plan) == 1
    while not many.done:
        many.advance()
    a, b = one.stats["highD 01"], many.stats["highD 01"]
    assert a.hours == pytest.approx(b.hours) and a.km == pytest.approx(b.km)
    assert a.pair_steps == b.pair_steps


def test_the_replay_runs_open_loop_through_the_pipeline(traffic, tmp_path):
    write_highd(traffic, tmp_path, 1)
    source = ReplaySource(ReplayConfig("highd", str(tmp_path), slots=64))
    stats = source.stats["highD 01"]
    sim = SimConfig(dt=source.dt, methods=("radar", "federated"))
    result = simulate(sim, source=source)
    for summary in result.summaries.values():
        assert summary.hours == pytest.approx(stats.hours)  # every row replayed once
        assert summary.km == pytest.approx(stats.km, rel=1e-9)
    with pytest.raises(Exception, match="cannot apply brake requests"):
        closed = ReplaySource(ReplayConfig("highd", str(tmp_path), slots=64))
        simulate(SimConfig(dt=closed.dt, drive="federated"), source=closed)


def test_the_command_replays_each_format_and_writes_its_outputs(traffic, tmp_path, capsys):
    write_highd(traffic, tmp_path / "highd", 1)
    out = tmp_path / "out"
    args = ["replay", "--format", "highd", "--path", str(tmp_path / "highd"), "--slots", "64"]
    assert main([*args, "--recording", "1", "--out", str(out), "--set", "methods=[federated]"]) == 0
    text = capsys.readouterr().out
    assert "Alert classes (judged from truth), highD 01" in text
    assert "Exposure per recording" in text and "headway (gap)" in text
    assert (out / "replay_highD_01_headways.png").stat().st_size > 10_000
    assert (out / "replay_highD_01_crosscheck.csv").read_text().count("\n") == 4
    ngsim = write_ngsim(simulate_traffic(duration=10.0, dt=0.1), tmp_path / "n.csv")
    assert main(["replay", "--format", "ngsim", "--path", str(ngsim), "--slots", "64"]) == 0
    assert "headway (spacing)" in capsys.readouterr().out
    generic = write_csv(simulate_traffic(duration=10.0, dt=0.1), tmp_path / "g.csv")
    mapping = tmp_path / "m.yaml"
    mapping.write_text("position: s_mid\nposition_ref: centre\nlane: null\nlateral: y\n"
                       "leader: lead\nlane_width: 3.75\n")  # fmt: skip
    argv = ["replay", "--format", "csv", "--path", str(generic), "--mapping", str(mapping)]
    assert main([*argv, "--slots", "64"]) == 0
    assert "g    " in capsys.readouterr().out  # the recording's name in the exposure table


def test_ngsim_locations_of_a_combined_export_are_recordings_of_their_own(ngsim_traffic, tmp_path):
    path = write_ngsim(ngsim_traffic, tmp_path / "one.csv")
    header, *lines = path.read_text().splitlines()
    located = [header + ",Location"] + [
        f"{line},{'us-101' if int(line.split(',')[0]) % 2 else 'i-80'}" for line in lines
    ]
    combined = tmp_path / "combined.csv"
    combined.write_text("\n".join(located) + "\n")
    config = ReplayConfig("ngsim", str(combined), recordings=("us-101", "i-80"), slots=64)
    source = ReplaySource(config)
    odd = sum(int(line.split(",")[0]) % 2 for line in lines)
    stats = source.stats
    assert list(stats) == ["NGSIM us-101", "NGSIM i-80"]
    assert stats["NGSIM us-101"].hours == pytest.approx(odd * 0.1 / 3600)
    assert stats["NGSIM i-80"].hours == pytest.approx((len(lines) - odd) * 0.1 / 3600)


def test_rows_in_any_order_with_repeats_give_the_same_pairs(traffic, tmp_path):
    write_highd(traffic, tmp_path, 1)
    rows = _rows(HighDRecording(tmp_path, 1))
    shuffled = np.random.default_rng(0).permutation(len(rows))
    repeated = rows.take(np.concatenate([shuffled, shuffled[:100]]))
    a, b = build_pairs(rows), build_pairs(repeated)
    assert b.duplicates == 100 and a.duplicates == 0
    for name in ("vid", "start", "leader_id", "gap", "lead_speed", "lateral_offset"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name


def test_the_benchmark_prints_its_figure_last():
    script = Path(__file__).resolve().parents[1] / "scripts" / "bench_replay.py"
    proc = subprocess.run(
        [sys.executable, str(script), "--quick"], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert lines[-3].startswith("first replay: ") and lines[-2].startswith("replay again: ")
    assert lines[-1].startswith("pair_steps_per_s=") and float(lines[-1].split("=")[1]) > 0
    bad = subprocess.run(
        [sys.executable, str(script), "--slots", "0"], capture_output=True, text=True
    )
    assert bad.returncode == 2 and "must be >= 1" in bad.stderr


def _braking_csv(path: Path, brake: bool = True) -> Path:
    """Two vehicles at 25 m/s, 30.5 m apart; the lead brakes at 6 m/s² to a stop from 5 s,
    the (recorded) follower brakes at 8 m/s² only from 6.5 s: a late reaction, no crash
    (without ``brake`` both cruise)."""
    t = np.round(np.arange(0.0, 15.0, 0.1), 10)

    def motion(s0, t_brake, decel):
        tb = np.clip(t - t_brake, 0.0, 25.0 / decel)
        v = np.where(t < t_brake, 25.0, 25.0 - decel * tb)
        a = np.where((t >= t_brake) & (v > 0), -decel, 0.0)
        return s0 + 25.0 * np.minimum(t, t_brake) + 25.0 * tb - 0.5 * decel * tb**2, v, a

    lines = ["k,id,s,lane,v,a,length,lead"]
    late = 5.0 if brake else 99.0
    for vid, (s0, t_brake, decel), lead in (
        (1, (60.0, late, 6.0), 0),
        (2, (25.0, late + 1.5, 8.0), 1),
    ):
        s, v, a = motion(s0, t_brake, decel)
        lines += [f"{k},{vid},{s[k]:.4f},1,{v[k]:.4f},{a[k]:.4f},4.5,{lead}" for k in range(t.size)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("brake", [True, False])
def test_a_recorded_late_reaction_to_a_braking_lead_is_warned(tmp_path, brake):
    """The replayed truth has the right signs: the oracle and the federated warning fire on a
    lead braking hard in front of a follower that reacts late, and stay silent when both
    cruise."""
    path = _braking_csv(tmp_path / "brake.csv", brake)
    mapping = tmp_path / "brake.toml"
    mapping.write_text('frame = "k"\nleader = "lead"\n')
    source = ReplaySource(ReplayConfig("csv", str(path), mapping=str(mapping), slots=4))
    result = simulate(SimConfig(dt=source.dt, methods=("federated",), seed=1), source=source)
    s = result.summaries["federated"]
    if brake:
        assert s.threats == s.detected == 1 and s.false_alarms == 0
        assert s.relevant == s.relevant_detected == 1 and s.crash_relevant == 1
    else:
        assert s.threats == s.warnings == s.relevant == 0


def test_a_curve_in_road_coordinates_gives_gaps_along_the_lane(tmp_path):
    """Vehicles on a ring road of radius 200 m, two lanes: the CSV gives each vehicle's arc
    length along its lane and its lateral offset; the gap is along the arc, not the chord."""
    radius, width, length, dt = 200.0, 3.75, 4.5, 0.1
    t = np.arange(0.0, 10.0, dt)
    lines = ["t,id,s,y,v,a,length"]
    angles = {}
    for vid, (lane, theta0, speed) in enumerate(
        [(0, 0.0, 25.0), (0, 0.2, 22.0), (1, 0.05, 24.0), (1, 0.3, 20.0)], start=1
    ):
        r = radius + (lane - 0.5) * width
        theta = theta0 + speed * t / r
        angles[vid] = (r, theta)
        lines += [f"{tk:.1f},{vid},{r * th:.6f},{(lane - 0.5) * width},{speed},0,{length}"
                  for tk, th in zip(t, theta, strict=True)]  # fmt: skip
    path = tmp_path / "ring.csv"
    path.write_text("\n".join(lines) + "\n")
    mapping = CsvMapping(lane=None, lateral="y", lane_width=width)
    pairs = build_pairs(_rows(CsvRecording(path, mapping)))
    for follower, leader in ((1, 2), (3, 4)):
        (r, th_f), (_, th_l) = angles[follower], angles[leader]
        rows = pairs.vid == follower
        assert np.all(pairs.leader_id[rows] == leader)
        arc = r * (th_l - th_f) - length
        chord = 2 * r * np.sin((th_l - th_f) / 2) - length
        assert np.abs(pairs.gap[rows] - arc).max() < 1e-4
        assert arc[0] - chord[0] > 0.05  # 35 m apart the two differ: the replay follows the lane
    assert not pairs.has_leader[(pairs.vid == 2) | (pairs.vid == 4)].any()
