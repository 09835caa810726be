"""Every script of examples/ runs as a user runs it (a subprocess, small sizes) and prints its
result.  Measured on 2 shared cores: scripted 7 s, SUMO 8-23 s, SB3 30 s, sweep 12 s, RLlib 51 s."""

from __future__ import annotations

import importlib.util
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

# Ray clusters: the tests of this file and of the other Ray user run on one worker, one at a time.
pytestmark = pytest.mark.xdist_group("ray")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def run_example(name: str, *args: str, timeout: float = 900) -> str:
    """The example's output; it runs in a session of its own, so that on a timeout it is
    killed with every process it started (Ray's among them, which would otherwise outlive it
    holding its pipes)."""
    proc = subprocess.Popen(
        [sys.executable, str(EXAMPLES / name), *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"{name} ran longer than {timeout:g} s; its last output:\n{err[-3000:]}")
    assert proc.returncode == 0, err[-3000:]
    return out


def needs(*modules: str) -> None:
    for module in modules:
        if importlib.util.find_spec(module.split(".")[0]) is None:
            pytest.skip(f"needs {module}")


TESTED = (
    "gym_braking_ppo.py",
    "gym_sb3.py",
    "osi_trace.py",
    "rllib_sumo_ppo.py",
    "scripted_study.py",
    "sumo_study.py",
    "sweep.py",
)


def test_every_example_is_tested_and_says_how_to_run_it():
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == list(TESTED)
    for name in TESTED:
        doc = (EXAMPLES / name).read_text().split('"""')[1]
        assert f"python examples/{name}" in doc, name


def test_scripted_study():
    out = run_example("scripted_study.py", "--runs", "10")
    assert "FCW comparison: 10 runs of 'random'" in out
    for method in ("radar", "infrared", "centralized", "federated"):
        assert re.search(rf"^{method}\s+\d+", out, flags=re.M), method
    assert re.search(r"\d+ collisions in 10 runs with warnings, \d+ without", out)


def test_sumo_study():
    needs("libsumo")
    out = run_example("sumo_study.py", "--end", "20")
    assert "FCW in SUMO traffic: ring.sumocfg" in out
    assert re.search(r"^federated\s+\d+", out, flags=re.M)
    assert "collisions: " in out and "SUMO failed" not in out


def test_osi_trace(tmp_path):
    needs("libsumo", "osi3", "osi_utilities")
    out = run_example("osi_trace.py", "--end", "5", "--vehicles", "1", "--out", str(tmp_path))
    assert f"wrote 1 OSI traces in {tmp_path}" in out
    assert re.search(r"^\S+\.mcap: 8 channels, \d+ steps, objects ahead", out, flags=re.M)
    assert "Nuisance and sensing-false alerts by cause" in out


def test_gym_sb3():
    needs("stable_baselines3")
    out = run_example("gym_sb3.py", "--timesteps", "512", "--episodes", "1")
    assert "trained PPO for 512 steps" in out
    for policy in ("ppo", "ttc", "never_warn"):
        assert re.search(rf"^{policy}\s+\d+", out, flags=re.M), policy


def test_gym_braking_ppo():
    needs("stable_baselines3")
    out = run_example("gym_braking_ppo.py", "--timesteps", "4096", "--episodes", "2")
    assert re.search(r"trained PPO for \d+ steps", out)
    for policy in ("ppo", "never", "safety_distance", "rule", "rule\\+aeb"):
        assert re.search(rf"^{policy}\s+\d+/2", out, flags=re.M), policy


def test_sweep(tmp_path):
    out = run_example("sweep.py", "--runs", "4", "--out", str(tmp_path / "sweep"))
    assert "sweep 'quick': 4 points x 4 runs" in out
    assert len(re.findall(r"^0\.05\s+1\s+federated\s+4\s", out, flags=re.M)) == 1
    assert (tmp_path / "sweep" / "runs.parquet").is_file()


def test_rllib_trains_ppo_on_sumo_with_two_env_runner_processes():
    needs("libsumo", "torch")
    pytest.importorskip("ray.rllib", reason="needs RLlib: pip install 'acc_fusion[rllib]'")
    out = run_example(
        "rllib_sumo_ppo.py",
        *("--iterations", "2", "--batch", "200", "--episode-steps", "50", "--warmup", "10"),
    )
    assert re.search(r"^iteration 1: 200 steps sampled, [1-9]\d* episodes done", out, re.M)
    assert re.search(r"^iteration 2: 400 steps sampled", out, flags=re.M)
    returns = re.findall(r"mean return (\S+)$", out, flags=re.M)
    assert len(returns) == 2 and all(r != "nan" for r in returns), out
    where = re.search(
        r"^main process (\d+); env runners \(process, SUMO starts\): (.*)$", out, re.M
    )
    runners = [tuple(map(int, p)) for p in re.findall(r"\((\d+), (\d+)\)", where.group(2))]
    pids = {pid for pid, _ in runners}
    # Two runner processes, apart from the main one, each running its own SUMO.
    assert len(runners) == 2 and len(pids) == 2 and int(where.group(1)) not in pids
    assert all(starts >= 1 for _, starts in runners)
