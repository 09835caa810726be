"""Sweeps: config validation, expansion, executors, resume after SIGKILL, report."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from acc_fusion.cli.main import main
from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.metrics.summary import CAUSE_COUNTS, FALSE_CLASSES
from acc_fusion.sim.closed_loop import SimConfig, simulate
from acc_fusion.sweep.config import SweepConfig, load_sweep
from acc_fusion.sweep.executors import check_address
from acc_fusion.sweep.run import run_sweep

# Ray clusters: the tests of this file and of the other Ray user run on one worker, one at a time.
pytestmark = pytest.mark.xdist_group("ray")

ROOT = Path(__file__).resolve().parents[1]

#: A small sweep: 2 thresholds x 2 fault settings x 2 seeds x 12 runs of 3 s, chunks of 6.
SMALL = {
    "name": "small",
    "seeds": [0, 5],
    "runs": 12,
    "chunk_runs": 6,
    "base": {
        "scenario": "random",
        "duration": 3.0,
        "methods": ["radar", "federated"],
        "radar": {"ghost_rate": 0.2},
    },
    "axes": {
        "warning.z": [0.0, 2.0],
        "radar_faults": [[], [{"kind": "spikes", "start": 0.5, "magnitude": 5.0}]],
    },
}


def write_toml(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="session")
def small(tmp_path_factory):
    """The small sweep run once on the local executor."""
    out = tmp_path_factory.mktemp("small")
    return out, run_sweep(SweepConfig.from_mapping(SMALL), out, progress=False)


# ------------------------------------------------------------------------------ validation


@pytest.mark.parametrize(
    "change, match",
    [
        ({"rns": 3}, r"unknown key 'rns' in the sweep config; allowed keys: name, source"),
        ({"runs": 0}, r"runs must be a whole number in \[1, 10000000\], got 0"),
        ({"seeds": [1, 1]}, r"seeds must not repeat"),
        ({"source": "carla"}, r"source must be one of 'scripted', 'sumo', 'world', got 'carla'"),
        ({"base": {"runs": 5}}, r"base.runs is set by the sweep"),
        ({"base": {"scenaro": "ccrs"}}, r"unknown key base.'scenaro' in base; allowed keys"),
        ({"axes": {"wrning.z": [1.0]}}, r"axes key 'wrning.z' must be .*allowed fields: scenario"),
        (
            {"axes": {"warning.z": [20.0]}},
            r"sweep point \(warning.z = 20.0\): warning.z must be in",
        ),
        (
            {"axes": {"warning.zz": [1]}},
            r"unknown key base.warning.'zz' in base.warning; allowed keys: model",
        ),
        ({"axes": {"warning.z": []}}, r"axes.'warning.z' must list at least one value"),
        ({"axes": {"warning.z": {"normal": [0, 1]}}}, r"distribution must be one of 'uniform'"),
        ({"axes": {"warning.z": {"uniform": [2, 1]}}, "n_samples": 2}, r"must have lo <= hi"),
        ({"axes": {"warning.z": {"uniform": [0, 1]}}}, r"n_samples must be >= 1 with random axes"),
        ({"axes": {"sumo.penetratoin": [1]}}, r"sumo field must be one of 'net', 'sumocfg'"),
        ({"report": {"threshold": "warning.y"}}, r"report.threshold must be one of 'warning.z'"),
        ({"report": {"format": "pdf"}}, r"report.format must be one of 'markdown', 'html'"),
    ],
)
def test_invalid_config_names_the_key(change, match):
    data = {**SMALL, "axes": {"warning.z": [0.0, 1.0]}, **change}
    with pytest.raises(ConfigError, match=match):
        SweepConfig.from_mapping(data)


def test_invalid_config_file_is_one_error_line(tmp_path, capsys):
    cfg = write_toml(tmp_path / "bad.toml", '[axes]\n"radar.range_std" = [-1.0]\n')
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(
        "acc-fusion: error: sweep point (radar.range_std = -1.0): radar.range_std"
    )
    assert len(err.splitlines()) == 1


@pytest.mark.parametrize("path", sorted((ROOT / "scripts" / "sweeps").glob("*.*")))
def test_example_configs_are_valid(path):
    cfg = load_sweep(path)
    assert cfg.total_runs == sum(c.n_runs for c in cfg.chunks())


# ------------------------------------------------------------------------------ expansion


def test_grid_and_random_expansion_is_deterministic():
    data = {
        **SMALL,
        "n_samples": 5,
        "axes": {
            "warning.z": [0.0, 1.0],
            "radar.range_std": {"uniform": [0.1, 1.0]},
            "radar.ghost_rate": {"loguniform": [0.001, 0.1]},
            "fusion.fusion_period": {"randint": [1, 3]},
            "fusion.reset": {"choice": ["fusion", "zero", "none"]},
        },
    }
    a, b = SweepConfig.from_mapping(data), SweepConfig.from_mapping(data)
    assert [p.id for p in a.points()] == [p.id for p in b.points()]
    assert [c.id for c in a.chunks()] == [c.id for c in b.chunks()]
    assert [c.sim_seed for c in a.chunks()] == [c.sim_seed for c in b.chunks()]
    assert len(a.points()) == 10 and a.total_runs == 10 * 2 * 12
    draws = pd.DataFrame([p.params for p in a.points()])
    assert draws["radar.range_std"].between(0.1, 1.0).all()
    assert draws["radar.ghost_rate"].between(0.001, 0.1).all()
    assert set(draws["fusion.fusion_period"]) <= {1, 2, 3}
    # Each random draw is combined with every grid value.
    assert draws.groupby("radar.range_std")["warning.z"].nunique().eq(2).all()
    other = SweepConfig.from_mapping({**data, "sample_seed": 1})
    assert {p.id for p in other.points()}.isdisjoint(p.id for p in a.points())
    # Chunks: every run of every point and seed exactly once, ids independent of axis order.
    assert sum(c.n_runs for c in a.chunks()) == a.total_runs
    flipped = SweepConfig.from_mapping({**SMALL, "axes": dict(reversed(SMALL["axes"].items()))})
    assert {p.id for p in flipped.points()} == {
        p.id for p in SweepConfig.from_mapping(SMALL).points()
    }


def test_rows_are_the_per_pair_metrics_of_simulate(small):
    """A chunk's rows split simulate's metrics (on the chunk's seed) run by run."""
    _, result = small
    chunk = SweepConfig.from_mapping(SMALL).chunks()[3]
    assert chunk.point.fault == "radar:spikes" or chunk.point.fault == "none"
    sim = from_mapping(SimConfig, {**chunk.point.sim, "runs": chunk.n_runs, "seed": chunk.sim_seed})
    mine = result.rows[result.rows["chunk_id"] == chunk.id]
    for method, s in simulate(sim).summaries.items():
        got = mine[mine["method"] == method]
        assert list(got["run"]) == list(range(chunk.first, chunk.first + chunk.n_runs))
        for col in ("warnings", "false_alarms", "threats", "detected", "missed", "collisions"):
            assert np.array_equal(got[col].to_numpy(), s.per_pair[col])
            assert got[col].sum() == getattr(s, col)  # per-pair counts add up to the totals
        assert got["hours"].sum() == pytest.approx(s.hours)
        assert got["km"].sum() == pytest.approx(s.km)
        assert got["lead_time_sum_s"].sum() == pytest.approx(
            s.lead_time.mean * s.lead_time.count if s.lead_time.count else 0.0,
            abs=0.01 * s.detected + 1e-9,
        )


# ------------------------------------------------------------------------------ store


def test_rows_one_per_run_and_method_and_tables(small):
    out, result = small
    rows = result.rows
    cfg = SweepConfig.from_mapping(SMALL)
    assert len(rows) == cfg.total_runs * 2
    assert not rows.duplicated(["run_id", "method"]).any()
    assert set(rows["fault"]) == {"none", "radar:spikes"}
    assert rows["warning.z"].dtype == np.float64
    assert (rows["steps"] == 60).all()
    on_disk = pd.read_parquet(out / "runs.parquet")
    pd.testing.assert_frame_equal(on_disk, rows)
    summary = pd.read_csv(out / "summary.csv")
    assert len(summary) == len(cfg.points()) * 2
    assert {"fa_per_hour", "fa_per_hour_lo", "fa_per_hour_hi", "miss_rate_hi"} <= set(summary)
    assert (summary["fa_per_hour_lo"] <= summary["fa_per_hour"]).all()
    assert (summary["fa_per_hour"] <= summary["fa_per_hour_hi"]).all()
    assert summary["false_alarms"].sum() == rows["false_alarms"].sum()


def test_report_files(small, tmp_path):
    out, result = small
    for name in ("roc.png", "faults.png", "faults.csv", "report.md"):
        assert (out / name).stat().st_size > 0, name
    text = (out / "report.md").read_text()
    assert "![ROC and DET curves](roc.png)" in text and "| radar:spikes |" in text
    assert "as warning.z varies" in text
    from acc_fusion.sweep.report import write_report

    cfg = SweepConfig.from_mapping({**SMALL, "report": {"format": "html"}})
    paths = write_report(cfg, result.rows, tmp_path)
    page = (tmp_path / "report.html").read_text()
    assert tmp_path / "report.html" in paths and '<img src="roc.png"' in page


def test_rerun_skips_done_chunks_and_refuses_another_config(small, tmp_path):
    out, first = small
    again = run_sweep(SweepConfig.from_mapping(SMALL), out, progress=False, report=False)
    assert again.ran_chunks == 0 and again.skipped_chunks == len(
        SweepConfig.from_mapping(SMALL).chunks()
    )
    pd.testing.assert_frame_equal(again.rows, first.rows)
    other = SweepConfig.from_mapping({**SMALL, "runs": 13})
    with pytest.raises(ConfigError, match="holds a different sweep"):
        run_sweep(other, out, progress=False)
    html = SweepConfig.from_mapping({**SMALL, "report": {"format": "html"}})
    assert run_sweep(html, out, progress=False).ran_chunks == 0  # the report may change
    assert (out / "report.html").exists()


# ------------------------------------------------------------------------------ executors


def test_ray_gives_the_same_rows_as_local(small, tmp_path):
    pytest.importorskip("ray")
    _, local = small
    ray_result = run_sweep(
        SweepConfig.from_mapping(SMALL),
        tmp_path,
        executor="ray",
        workers=2,
        progress=False,
        report=False,
    )
    pd.testing.assert_frame_equal(ray_result.rows, local.rows)


def test_a_ray_task_runs_its_chunk_on_one_numba_thread(monkeypatch):
    """A Ray task has one CPU: its chunk's parallel kernels must not spread over the cores
    the other tasks run on (the local pool's workers are set so by their initializer)."""
    import numba

    from acc_fusion.sweep import executors

    monkeypatch.setattr(executors, "run_chunk", lambda chunk: numba.get_num_threads())
    threads = numba.get_num_threads()
    try:
        assert executors.run_alone(executors.run_chunk, None) == 1
    finally:
        numba.set_num_threads(threads)


#: Prints :func:`start_method` in a fresh process, then with a second thread running.
START_METHODS = """
import threading
from acc_fusion.sweep.executors import start_method
print(start_method())
threading.Thread(target=threading.Event().wait, args=(60,), daemon=True).start()
print(start_method())
"""

#: Prints the threading layer and :func:`start_method` after a parallel kernel ran on GNU
#: OpenMP ("none" where numba has no OpenMP layer).
AFTER_OPENMP = """
import numba, numpy as np
numba.config.THREADING_LAYER = "omp"
@numba.njit(parallel=True)
def total(x):
    s = 0.0
    for i in numba.prange(x.size):
        s += x[i]
    return s
try:
    total(np.ones(64))
except ValueError:
    print("none none")
    raise SystemExit
from acc_fusion.sweep.executors import start_method
print(numba.threading_layer(), start_method())
"""


@pytest.mark.skipif(sys.platform != "linux", reason="workers are forked on Linux only")
def test_workers_are_forked_only_from_a_process_safe_to_fork():
    def run(code):
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        assert out.returncode == 0, out.stderr[-2000:]
        return out.stdout.split()

    assert run(START_METHODS) == ["fork", "spawn"]
    layer, method = run(AFTER_OPENMP)
    if layer == "none":
        pytest.skip("numba has no OpenMP threading layer here")
    assert (layer, method) == ("omp", "spawn")


def test_unreachable_ray_address_fails_fast(tmp_path, capsys):
    pytest.importorskip("ray")
    port = free_port()  # nothing listens there
    t0 = time.perf_counter()
    with pytest.raises(
        AccFusionError, match=rf"cannot reach the Ray cluster at '127.0.0.1:{port}'"
    ):
        check_address(f"127.0.0.1:{port}")
    cfg = write_toml(tmp_path / "s.toml", "runs = 1\n[base]\nduration = 1.0\n")
    code = main(
        [
            "sweep",
            str(cfg),
            "--executor",
            "ray",
            "--address",
            f"ray://127.0.0.1:{port}",
            "--out",
            str(tmp_path / "o"),
        ]
    )
    assert code == 2
    assert "cannot reach the Ray cluster" in capsys.readouterr().err
    assert time.perf_counter() - t0 < 15.0
    with pytest.raises(ConfigError, match="--address must be HOST:PORT"):
        check_address("localhost")


# ------------------------------------------------------------------------------ SIGKILL


KILL_CONFIG = """
name = "kill"
seeds = [0]
runs = 48
chunk_runs = 4
[base]
scenario = "random"
duration = 2.0
methods = ["radar", "federated"]
[axes]
"warning.z" = [0.0, 1.0]
"""


#: The sweep run by the SIGKILL test: the CLI in a child process whose store kills the process
#: (SIGKILL, no clean-up) right after writing its fifth part: a known point, whatever the speed.
KILL_AFTER_FIVE_PARTS = """
import os, signal, sys
from acc_fusion.cli.main import main
from acc_fusion.sweep.store import SweepStore

write_part = SweepStore.write_part
def write_then_die(self, chunk, columns):
    write_part(self, chunk, columns)
    if len(list((self.out / "parts").glob("*.parquet"))) >= 5:
        os.kill(os.getpid(), signal.SIGKILL)
SweepStore.write_part = write_then_die
sys.exit(main(sys.argv[1:]))
"""


def test_sigkill_then_resume_equals_an_uninterrupted_sweep(tmp_path):
    cfg_path = write_toml(tmp_path / "kill.toml", KILL_CONFIG)
    out = tmp_path / "killed"
    cmd = [sys.executable, "-c", KILL_AFTER_FIVE_PARTS, "sweep", str(cfg_path), "--out", str(out)]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, timeout=300)
    assert proc.returncode == -signal.SIGKILL, proc.stderr.decode()[-2000:]
    parts = out / "parts"
    done = list(parts.glob("*.parquet"))
    n_chunks = len(load_sweep(cfg_path).chunks())
    assert len(done) == 5 < n_chunks, "killed part-way"
    assert not (out / "runs.parquet").exists()
    for part in done:  # every part left is whole
        assert len(pd.read_parquet(part)) == 4 * 2

    resumed = run_sweep(load_sweep(cfg_path), out, progress=False, report=False)
    assert (
        resumed.skipped_chunks >= len(done)
        and resumed.ran_chunks == n_chunks - resumed.skipped_chunks
    )
    whole = run_sweep(load_sweep(cfg_path), tmp_path / "whole", progress=False, report=False)
    assert not resumed.rows.duplicated(["run_id", "method"]).any()
    pd.testing.assert_frame_equal(resumed.rows, whole.rows)


# ------------------------------------------------------------------------------ scale


@pytest.mark.slow
def test_ten_thousand_scripted_runs(tmp_path):
    cfg = load_sweep(ROOT / "scripts" / "sweeps" / "ten_thousand.toml")
    assert cfg.total_runs == 10_000
    result = run_sweep(cfg, tmp_path, progress=False)
    assert result.rows["run_id"].nunique() == 10_000
    assert (tmp_path / "report.md").exists()


@pytest.mark.slow
def test_an_address_that_is_not_ray_is_a_clear_error(tmp_path, capsys, monkeypatch):
    """Something answers TCP at the address but it is not Ray: an error, not a hang (the
    probe's wait shortened: whether it fails or is killed, the error is the same)."""
    pytest.importorskip("ray")
    import threading

    from acc_fusion.sweep import executors

    monkeypatch.setattr(executors, "RAY_PROBE_TIMEOUT", 3.0)

    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]

    def answer() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            conn.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n")
            conn.close()

    threading.Thread(target=answer, daemon=True).start()
    cfg = write_toml(tmp_path / "s.toml", "runs = 1\n[base]\nduration = 1.0\n")
    t0 = time.perf_counter()
    args = ["sweep", str(cfg), "--executor", "ray", "--address", f"127.0.0.1:{port}"]
    try:
        assert main([*args, "--out", str(tmp_path / "o")]) == 2
    finally:
        server.close()
    err = capsys.readouterr().err
    assert f"acc-fusion: error: cannot connect to the Ray cluster at '127.0.0.1:{port}'" in err
    assert time.perf_counter() - t0 < 60.0


def test_a_sumo_sweep_records_the_runs_of_sumo(tmp_path):
    cfg = SweepConfig.from_mapping(
        {
            "name": "sumo-small",
            "source": "sumo",
            "seeds": [0],
            "runs": 1,
            "base": {"methods": ["radar", "federated"]},
            "sumo": {"net": "ring", "end": 5.0},
            "axes": {"sumo.penetration": [0.5, 1.0]},
        }
    )
    result = run_sweep(cfg, tmp_path, progress=False, report=False)
    rows = result.rows
    assert len(rows) == 2 * 2  # two points, one SUMO run each, two methods
    assert (rows["steps"] == 50).all()  # 5 s of the ring's 0.1 s steps
    hours = rows.groupby("sumo.penetration")["hours"].first()
    assert 0 < hours[0.5] < hours[1.0]  # fewer equipped vehicles, less exposure


def test_a_world_sweeps_rows_count_the_false_warnings_by_cause(tmp_path):
    cfg = SweepConfig.from_mapping(
        {
            "name": "world-causes",
            "source": "world",
            "seeds": [0],
            "runs": 6,
            "base": {
                "methods": ["infrared", "radar"],
                # the path from the yaw rate alone runs straight on into the parked car
                "world": {"scene": "parked_curve", "selection": {"path": "yaw_rate"}},
            },
            "axes": {"world.conditions.fog_visibility": [1000.0, 20.0]},
        }
    )
    rows = run_sweep(cfg, tmp_path, progress=False, report=False).rows
    for cls in FALSE_CLASSES:
        by_cause = rows[[c for c in CAUSE_COUNTS if c.startswith(cls + "_")]].sum(axis=1)
        assert (by_cause == rows[cls]).all()
    # The camera takes the parked car for a vehicle in path, unless fog hides it.
    fooled = rows.groupby(["method", "world.conditions.fog_visibility"])[
        "sensing_false_stationary"
    ].sum()
    assert fooled["infrared", 1000.0] >= 5 and fooled["infrared", 20.0] == 0
    assert fooled["radar", 1000.0] == 0
    summary = pd.read_csv(tmp_path / "summary.csv")
    assert summary["sensing_false_stationary"].sum() == rows["sensing_false_stationary"].sum()


def test_the_rows_of_the_1d_pipeline_have_no_causes(small):
    _, result = small
    assert (result.rows[list(CAUSE_COUNTS)] == 0).all().all()


def test_a_folder_of_an_older_version_is_refused(tmp_path):
    cfg = SweepConfig.from_mapping(SMALL)
    (tmp_path / "sweep.json").write_text(json.dumps({"config": cfg.as_dict()}))
    with pytest.raises(ConfigError, match="older version"):
        run_sweep(cfg, tmp_path, progress=False)


def test_a_world_sweep_makes_weather_an_axis(tmp_path):
    cfg = SweepConfig.from_mapping(
        {
            "name": "world-fog",
            "source": "world",
            "seeds": [0],
            "runs": 6,
            "base": {"methods": ["infrared"], "world": {"scene": "cut_out"}},
            "axes": {"world.conditions.fog_visibility": [1000.0, 20.0]},
        }
    )
    rows = run_sweep(cfg, tmp_path, progress=False, report=False).rows
    assert len(rows) == 2 * 6  # two points, six runs, one method
    seen = rows.groupby("world.conditions.fog_visibility")["relevant_detected"].sum()
    assert seen[1000.0] > 0 and seen[20.0] == 0  # dense fog blinds the thermal camera
