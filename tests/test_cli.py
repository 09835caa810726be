"""The acc-fusion command line: outputs, --help, and errors without tracebacks."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from acc_fusion.cli.main import main


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
        err.startswith("acc-fusion: error: argument --out: output folder")
        and "Traceback" not in err
    )


@pytest.mark.parametrize("args", [["--help"], ["estimation", "--help"]])
def test_help(args):
    res = subprocess.run(
        [sys.executable, "-m", "acc_fusion.cli.main", *args], capture_output=True, text=True
    )
    assert res.returncode == 0 and "usage: acc-fusion" in res.stdout


def test_bad_number_is_reported_by_name():
    res = subprocess.run(
        [sys.executable, "-m", "acc_fusion.cli.main", "estimation", "--runs", "-3"],
        capture_output=True,
        text=True,
    )
    assert (
        res.returncode == 2
        and "--runs: must be >= 1" in res.stderr
        and "Traceback" not in res.stderr
    )


def test_run_writes_png_csv_and_json(tmp_path, capsys):
    assert main(["run", "--scenario", "nhtsa_lvs", "--seed", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "drives the closed loop" in out and "false alarms / h" in out
    stem = tmp_path / "run_nhtsa_lvs_seed1"
    assert stem.with_suffix(".png").stat().st_size > 20_000
    header = stem.with_suffix(".csv").read_text().splitlines()[0]
    assert "federated_gap" in header and "radar_range" in header and "d_imminent" in header
    summary = json.loads(stem.with_suffix(".json").read_text())
    assert summary["scenario"] == "nhtsa_lvs" and "federated" in summary["methods"]


def test_compare_and_config_file(tmp_path, capsys):
    cfg = tmp_path / "cfg.toml"
    cfg.write_text('runs = 12\nseed = 3\n[warning]\nmodel = "ttc"\n')
    assert main(["compare", "--config", str(cfg), "--runs", "10", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "FCW comparison: 10 runs of 'random', seed 3" in out
    assert (tmp_path / "compare.png").stat().st_size > 10_000
    assert (tmp_path / "compare.json").exists() and (tmp_path / "compare.csv").exists()
    # The benefit pairs each run with FCW off and on; its crashes are the closed loops'.
    data = json.loads((tmp_path / "compare.json").read_text())
    benefit, collisions = data["benefit"], data["collisions"]
    assert "Crashes FCW avoids, 10 runs of 'random'" in out
    assert benefit["vehicles"] == 10
    assert (benefit["crashes_off"], benefit["crashes_on"]) == (collisions["off"], collisions["on"])
    assert benefit["avoided"] + benefit["mitigated"] <= benefit["crashes_off"]
    assert set(data["benefit_by_method"]) == {"federated"}


def test_conformance_exit_code(capsys):
    assert main(["conformance", "--trials", "3"]) == 0
    out = capsys.readouterr().out
    assert "nhtsa_lvs" in out and "PASS" in out


@pytest.mark.parametrize(
    "args, message",
    [
        (["run", "--scenario", "nowhere"], "scenario must be one of"),
        (["compare", "--config", "missing.toml"], "config file 'missing.toml' does not exist"),
    ],
)
def test_user_mistakes_are_one_line_errors(args, message, capsys, tmp_path):
    assert main([*args, "--out", str(tmp_path)] if args[0] == "run" else args) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_bad_config_key_names_the_key(tmp_path, capsys):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("runs: 5\nwarnings:\n  model: ttc\n")
    assert main(["compare", "--config", str(cfg)]) == 2
    assert "unknown key 'warnings'" in capsys.readouterr().err
