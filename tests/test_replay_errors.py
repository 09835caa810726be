"""A bad recording ends in one line naming the file, the line and the column (exit 2), and
nothing is written."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest
import tomllib

from acc_fusion.cli.main import main
from acc_fusion.truth.replay.synthetic import simulate_traffic, write_csv, write_highd


@pytest.fixture(scope="module")
def traffic():
    return simulate_traffic(lanes=1, duration=8.0, dt=0.04, seed=1, lane_change_at=None)


def _edit_line(path, line: int, edit) -> None:
    """Replace line ``line`` (1-based) of ``path`` by ``edit(fields)`` joined by commas."""
    lines = path.read_text().splitlines()
    lines[line - 1] = ",".join(edit(lines[line - 1].split(",")))
    path.write_text("\n".join(lines) + "\n")


def _replay_error(capsys, *args) -> str:
    assert main(["replay", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("acc-fusion: error: ")
    return err


def _highd(tmp_path, traffic):
    write_highd(traffic, tmp_path / "data", 1)
    return tmp_path / "data", tmp_path / "data" / "01_tracks.csv"


def _column(path, name: str) -> int:
    return path.read_text().splitlines()[0].split(",").index(name)


def test_a_value_that_is_not_a_number(tmp_path, traffic, capsys):
    folder, tracks = _highd(tmp_path, traffic)
    col = _column(tracks, "xVelocity")
    _edit_line(tracks, 40, lambda f: f[:col] + ["fast"] + f[col + 1 :])
    err = _replay_error(
        capsys, "--format", "highd", "--path", str(folder), "--out", str(tmp_path / "o")
    )
    assert f"{tracks}, line 40, column 'xVelocity': 'fast' is not a number" in err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_an_empty_value(tmp_path, traffic, capsys):
    folder, tracks = _highd(tmp_path, traffic)
    col = _column(tracks, "dhw")
    _edit_line(tracks, 12, lambda f: f[:col] + [""] + f[col + 1 :])
    err = _replay_error(capsys, "--format", "highd", "--path", str(folder))
    assert f"{tracks}, line 12, column 'dhw': empty value" in err


def test_a_row_with_too_few_fields(tmp_path, traffic, capsys):
    folder, tracks = _highd(tmp_path, traffic)
    _edit_line(tracks, 25, lambda f: f[:-3])
    err = _replay_error(capsys, "--format", "highd", "--path", str(folder))
    assert f"{tracks}, line 25:" in err and "fields, the header has" in err


def test_a_missing_column(tmp_path, traffic, capsys):
    folder, tracks = _highd(tmp_path, traffic)
    _edit_line(tracks, 1, lambda f: ["LEAD" if x == "precedingId" else x for x in f])
    err = _replay_error(capsys, "--format", "highd", "--path", str(folder))
    assert f"{tracks}, line 1: no column 'precedingId'" in err


def test_bad_lane_markings(tmp_path, traffic, capsys):
    folder, _ = _highd(tmp_path, traffic)
    meta = folder / "01_recordingMeta.csv"
    _edit_line(meta, 2, lambda f: [*f[:-1], "5.75;wide"])  # the last column
    err = _replay_error(capsys, "--format", "highd", "--path", str(folder))
    assert f"{meta}, line 2, column 'lowerLaneMarkings':" in err


def test_a_missing_highd_file(tmp_path, traffic, capsys):
    folder, _ = _highd(tmp_path, traffic)
    (folder / "01_tracksMeta.csv").unlink()
    err = _replay_error(capsys, "--format", "highd", "--path", str(folder))
    assert "01_tracksMeta.csv' does not exist" in err


def test_a_bad_driving_direction(tmp_path, traffic, capsys):
    folder, _ = _highd(tmp_path, traffic)
    meta = folder / "01_tracksMeta.csv"
    col = _column(meta, "drivingDirection")
    _edit_line(meta, 3, lambda f: f[:col] + ["3"] + f[col + 1 :])
    err = _replay_error(capsys, "--format", "highd", "--path", str(folder))
    assert f"{meta}, line 3, column 'drivingDirection': must be 1 or 2, got 3" in err


def test_a_csv_mapping_naming_a_missing_column(tmp_path, traffic, capsys):
    path = write_csv(traffic, tmp_path / "t.csv")
    mapping = tmp_path / "map.toml"
    mapping.write_text('[columns]\nposition = "s_front"\nlane = "y"\n')
    err = _replay_error(capsys, "--format", "csv", "--path", str(path), "--mapping", str(mapping))
    assert f"{path}, line 1: no column 's_front'" in err


def test_a_bad_csv_mapping_key(tmp_path, traffic, capsys):
    path = write_csv(traffic, tmp_path / "t.csv")
    mapping = tmp_path / "map.toml"
    mapping.write_text('[columns]\npositon = "s_mid"\n')
    err = _replay_error(capsys, "--format", "csv", "--path", str(path), "--mapping", str(mapping))
    assert "unknown key" in err and "'positon'" in err and "position" in err


def test_a_missing_ngsim_file(tmp_path, capsys):
    err = _replay_error(capsys, "--format", "ngsim", "--path", str(tmp_path / "nope.csv"))
    assert "nope.csv' does not exist" in err


@pytest.mark.parametrize(
    "column, value, words",
    [
        ("v", "900", "column 'v': speed [m/s] 900 is outside [-10, 100]"),
        ("s_mid", "1e12", "column 's_mid': position [m] 1e+12 is outside"),
        ("a", "-400", "column 'a': acceleration [m/s²] -400 is outside [-30, 30]"),
        ("length", "0", "column 'length': length [m] 0 is outside [0.5, 60]"),
        ("id", "-7", "column 'id': vehicle id -7 is outside"),
        ("id", "1e30", "column 'id': vehicle id"),  # was a RuntimeWarning (tests/test_fuzz.py)
    ],
)
def test_a_physically_impossible_row_is_refused_or_dropped(
    tmp_path, traffic, capsys, column, value, words
):
    """Such rows were accepted and gave absurd exposure figures without a word."""
    path = write_csv(traffic, tmp_path / "t.csv")
    _edit_line(path, 6, lambda f: [value if i == _column(path, column) else x
                                   for i, x in enumerate(f)])  # fmt: skip
    mapping = tmp_path / "m.toml"
    mapping.write_text('position = "s_mid"\nposition_ref = "centre"\nlateral = "y"\n')
    args = ["--format", "csv", "--path", str(path), "--mapping", str(mapping)]
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        err = _replay_error(capsys, *args)
    assert "t.csv', row 5, " in err and words in err and "--bad-rows drop" in err
    assert main(["replay", *args, "--bad-rows", "drop"]) == 0
    assert "t: dropped 1 of its rows, outside the physical bounds" in capsys.readouterr().out


def test_all_rows_at_one_time_are_refused(tmp_path, traffic, capsys):
    path = write_csv(traffic, tmp_path / "t.csv")
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0]] + ["0.0," + x.split(",", 1)[1] for x in lines[1:]]))
    mapping = tmp_path / "m.toml"
    mapping.write_text('position = "s_mid"\nlateral = "y"\n')
    err = _replay_error(capsys, "--format", "csv", "--path", str(path), "--mapping", str(mapping))
    assert f"all {len(lines) - 1} rows are at one time (frame 0); column 't' must advance" in err


def test_the_guides_csv_mapping_replays_the_csv_it_describes(tmp_path, traffic, capsys):
    """The mapping example of docs/guide/replay.md (lateral, no lane: TOML cannot say
    ``lane = null``) asked for a column ``lane``; here it replays a CSV of the columns it
    names."""
    guide = (Path(__file__).resolve().parents[1] / "docs" / "guide" / "replay.md").read_text()
    block = re.search(r"```toml\n(\[columns\].*?)```", guide, flags=re.S).group(1)
    mapping = tmp_path / "mine.toml"
    mapping.write_text(block)
    columns = tomllib.loads(block)["columns"]
    path = write_csv(traffic, tmp_path / "mine.csv")
    ours = {"id": "id", "time": "t", "position": "s_mid", "lateral": "y", "speed": "v",
            "accel": "a", "length": "length", "leader": "lead"}  # fmt: skip
    header = path.read_text().split("\n", 1)
    names = [columns.get(k, k) for k in (dict(zip(ours.values(), ours, strict=True)).get(c, c)
                                         for c in header[0].split(","))]  # fmt: skip
    path.write_text(",".join(names) + "\n" + header[1])
    args = ["replay", "--format", "csv", "--path", str(path), "--mapping", str(mapping)]
    assert main(args) == 0
    assert "Exposure per recording" in capsys.readouterr().out
