"""A bad recording ends in one line naming the file, the line and the column (exit 2), and
nothing is written."""

from __future__ import annotations

import pytest

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
