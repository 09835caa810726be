"""The replay's binary copies of recordings (acc_fusion.truth.replay.cache): a recording replayed
again is read from its copy with the same values; a file is parsed once per replay whatever
its windows; a changed file, an interrupted read and an unwritable folder."""

from __future__ import annotations

import json
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from acc_fusion.core.errors import ConfigError
from acc_fusion.sim.closed_loop import SimConfig, simulate
from acc_fusion.truth.replay import cache, csvfile
from acc_fusion.truth.replay.source import ReplayConfig, ReplaySource
from acc_fusion.truth.replay.synthetic import simulate_traffic, write_highd, write_ngsim


@pytest.fixture
def folder(tmp_path, monkeypatch) -> Path:
    """An empty cache folder of the test's own."""
    out = tmp_path / "cache"
    monkeypatch.setenv("ACC_FUSION_REPLAY_CACHE", str(out))
    return out


@pytest.fixture
def parses(monkeypatch) -> list[Path]:
    """The files parsed from now on, one entry per parse."""
    seen, original = [], csvfile.stream

    def counted(path, *args, **kwargs):
        seen.append(Path(path))
        yield from original(path, *args, **kwargs)

    monkeypatch.setattr(csvfile, "stream", counted)
    return seen


def _replay(config: ReplayConfig) -> str:
    """The federated filter's summary of the replay, as JSON."""
    source = ReplaySource(config)
    result = simulate(SimConfig(dt=source.dt, methods=("federated",)), source=source)
    return json.dumps(result.summaries["federated"].as_dict(), sort_keys=True, default=str)


def test_a_recording_replayed_again_is_read_from_its_copy_with_the_same_results(
    tmp_path, folder, parses
):
    write_highd(simulate_traffic(lanes=2, duration=30.0, dt=0.04, seed=5), tmp_path, 1)
    config = ReplayConfig("highd", str(tmp_path), slots=64)
    tracks = tmp_path / "01_tracks.csv"
    first = _replay(config)
    assert parses.count(tracks) == 1 and len(list(folder.glob("*.arrow"))) == 1
    again = _replay(config)
    assert parses.count(tracks) == 1  # read from the copy
    assert again == first
    assert _replay(replace(config, cache=False)) == first
    assert parses.count(tracks) == 2 and len(list(folder.iterdir())) == 1  # no copy, no temporary


def test_a_file_is_parsed_once_whatever_its_windows_and_its_filter(tmp_path, folder, parses):
    plain = write_ngsim(
        simulate_traffic(lanes=2, duration=40.0, dt=0.1, seed=4), tmp_path / "n.csv"
    )
    lines = plain.read_text().splitlines()
    both = tmp_path / "both.csv"  # the combined export: the same rows at two locations
    both.write_text("\n".join([lines[0] + ",Location"] + [f"{ln},us-101" for ln in lines[1:]]
                              + [f"{ln},i-80" for ln in lines[1:20]]) + "\n")  # fmt: skip
    config = ReplayConfig("ngsim", str(both), recordings=("us-101",), max_rows=1000)
    cached = config.open()[0]
    windows = cached.windows(1000)
    assert len(windows) > 3
    rows = [cached.rows(f0, f1) for f0, f1, _ in windows]
    assert len(parses) == 1  # the frame pass made the copy; every window read it
    direct = replace(config, cache=False).open()[0]
    assert direct.windows(1000) == windows
    for (f0, f1, _), got in zip(windows, rows, strict=True):
        want = direct.rows(f0, f1)
        for name in ("frame", "vid", "s", "speed", "accel", "length", "leader"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    other = replace(config, recordings=("i-80",)).open()[0]  # another filter, another copy
    assert other.rows(*other.windows()[0][:2]).frame.size == 19
    assert len(list(folder.glob("*.arrow"))) == 2


def test_a_changed_file_is_parsed_again_and_a_stopped_read_leaves_nothing(tmp_path, folder):
    path = write_ngsim(simulate_traffic(lanes=1, duration=20.0, dt=0.1, seed=6), tmp_path / "n.csv")
    numbers = {"Frame_ID": "Frame_ID", "v_Vel": "v_Vel"}
    batches = cache.stream(path, numbers)
    next(batches)
    batches.close()  # stopped after the first batch: no copy
    assert not folder.exists() or not list(folder.iterdir())
    first = [b["v_Vel"] for b in cache.stream(path, numbers)]
    assert len(list(folder.glob("*.arrow"))) == 1
    text = path.read_text().splitlines()
    head, row = text[0], text[1].split(",")
    col = head.split(",").index("v_Vel")
    row[col] = "99.5"
    path.write_text("\n".join([head, ",".join(row), *text[2:]]) + "\n")
    second = np.concatenate([b["v_Vel"] for b in cache.stream(path, numbers)])
    assert second[0] == 99.5 and np.concatenate(first)[0] != 99.5
    assert len(list(folder.glob("*.arrow"))) == 2


def test_an_unwritable_cache_folder_parses_with_one_warning(tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "_FAILED", set())
    write_highd(simulate_traffic(lanes=1, duration=10.0, dt=0.04, seed=7), tmp_path, 1)
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    monkeypatch.setenv("ACC_FUSION_REPLAY_CACHE", str(blocker / "cache"))  # under a file
    config = ReplayConfig("highd", str(tmp_path), slots=16)
    with pytest.warns(RuntimeWarning, match="no binary copy can be kept in") as caught:
        got = _replay(config)
        ngsim = write_ngsim(simulate_traffic(duration=20.0, dt=0.1, seed=8), tmp_path / "n.csv")
        recording = ReplayConfig("ngsim", str(ngsim)).open()[0]
        assert len(recording.windows(500)) > 2
        for f0, f1, _ in recording.windows(500):
            recording.rows(f0, f1)
    assert len([w for w in caught if w.category is RuntimeWarning]) == 1  # once per process
    assert got == _replay(replace(config, cache=False))


def test_without_a_home_folder_the_replay_parses(tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "_FAILED", set())

    def no_home():
        raise RuntimeError("Could not determine home directory.")

    monkeypatch.setattr(cache, "folder", no_home)
    write_highd(simulate_traffic(lanes=1, duration=10.0, dt=0.04, seed=7), tmp_path, 1)
    config = ReplayConfig("highd", str(tmp_path), slots=16)
    with pytest.warns(RuntimeWarning, match="Could not determine home directory"):
        assert _replay(config) == _replay(replace(config, cache=False))


def test_a_killed_replays_unfinished_copy_is_removed_a_day_later(tmp_path, folder):
    path = write_ngsim(simulate_traffic(lanes=1, duration=10.0, dt=0.1, seed=6), tmp_path / "n.csv")
    folder.mkdir(parents=True)
    old, new = folder / ".abc.arrow.x1.arrow", folder / ".def.arrow.x2.arrow"
    old.write_bytes(b"half"), new.write_bytes(b"half")
    day_ago = time.time() - cache.STALE - 60.0
    os.utime(old, (day_ago, day_ago))
    list(cache.stream(path, {"Frame_ID": "Frame_ID"}))
    copies = [p for p in folder.glob("*.arrow") if not p.name.startswith(".")]
    assert not old.exists() and new.exists() and len(copies) == 1


def test_the_cache_setting_is_checked():
    with pytest.raises(ConfigError, match="cache must be true or false"):
        ReplayConfig("highd", ".", cache="yes")
