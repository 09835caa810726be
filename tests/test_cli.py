"""The acc-fusion command line: outputs, --help, and errors without tracebacks."""

from __future__ import annotations

import subprocess
import sys

import pytest

from acc_fusion.cli import main


def test_estimation_prints_the_table_and_writes_csv_and_png(tmp_path, capsys):
    assert main(["estimation", "--runs", "20", "--duration", "2", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "Federated fusion vs baselines" in out and "federated + FDI" in out
    assert (tmp_path / "estimation.csv").read_text().startswith("method,rmse_gap_m")
    assert (tmp_path / "estimation.png").stat().st_size > 10_000
    assert not list(tmp_path.glob(".*tmp"))


def test_unwritable_output_folder_is_a_one_line_error(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert (
        main(["estimation", "--runs", "5", "--duration", "1", "--out", str(blocker / "sub")]) == 2
    )
    err = capsys.readouterr().err
    assert (
        err.startswith("acc-fusion: error: cannot create output folder") and "Traceback" not in err
    )


@pytest.mark.parametrize("args", [["--help"], ["estimation", "--help"]])
def test_help(args):
    res = subprocess.run(
        [sys.executable, "-m", "acc_fusion.cli", *args], capture_output=True, text=True
    )
    assert res.returncode == 0 and "usage: acc-fusion" in res.stdout


def test_bad_number_is_reported_by_name():
    res = subprocess.run(
        [sys.executable, "-m", "acc_fusion.cli", "estimation", "--runs", "-3"],
        capture_output=True,
        text=True,
    )
    assert (
        res.returncode == 2
        and "--runs: must be >= 1" in res.stderr
        and "Traceback" not in res.stderr
    )
