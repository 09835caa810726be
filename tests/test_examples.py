"""Every script in examples/ runs as a user would run it (small sizes), and prints its result."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def run_example(name: str, *args: str, timeout: float = 600) -> str:
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


def test_every_example_is_tested():
    tested = {"scripted_study.py", "sumo_study.py", "gym_sb3.py", "sweep.py", "rllib_sumo_ppo.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


def test_scripted_study():
    out = run_example("scripted_study.py", "--runs", "10")
    assert "federated" in out and "collisions:" in out


def test_sumo_study():
    pytest.importorskip("libsumo")
    out = run_example("sumo_study.py", "--end", "40")
    assert "federated" in out


def test_gym_sb3():
    pytest.importorskip("stable_baselines3")
    out = run_example("gym_sb3.py", "--timesteps", "1024", "--episodes", "1", "--num-envs", "4")
    assert "trained" in out and "ppo" in out and "never_warn" in out


def test_sweep(tmp_path):
    out = run_example("sweep.py", "--out", str(tmp_path / "sweep"), "--runs", "4")
    assert "federated" in out and (tmp_path / "sweep" / "runs.parquet").exists()


def test_rllib_trains_ppo_on_sumo_with_two_env_runners():
    pytest.importorskip(
        "ray.rllib", reason="needs the rllib extra: pip install 'acc_fusion[rllib]'"
    )
    pytest.importorskip("libsumo")
    out = run_example("rllib_sumo_ppo.py", "--iterations", "1", "--runners", "2")
    assert "iteration 1: 400" in out
