"""Smoke tests of the scripts under ``scripts/``: each runs as a subprocess with small inputs."""

from __future__ import annotations

import ast
import json
import re
import runpy
import statistics
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def run(script: str, *args: str, ok: bool = True) -> subprocess.CompletedProcess:
    """Run ``scripts/<script>`` with ``args``; with ``ok``, assert it exits with 0."""
    proc = subprocess.run(
        [sys.executable, str(SCRIPTS / script), *args], capture_output=True, text=True, timeout=120
    )
    if ok:
        assert proc.returncode == 0, proc.stderr
    return proc


def assert_png(path: Path) -> None:
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    assert path.stat().st_size > 10_000  # a figure, not an empty canvas


@pytest.mark.parametrize(
    "script",
    [
        "reproduce_kong2011.py",
        "reproduce_cn103196450a.py",
        "fault_tolerance.py",
        "federated_breakdown.py",
        "steady_state_vs_full.py",
        "bench_filters.py",
    ],
)
def test_help(script):
    out = run(script, "--help").stdout
    assert out.startswith("usage:") and "--seed" in out


@pytest.mark.parametrize(
    ("script", "args", "message"),
    [
        ("reproduce_kong2011.py", ["--runs", "0"], "--runs: must be >= 1"),
        ("steady_state_vs_full.py", ["--sensor", "lidar"], "invalid choice: 'lidar'"),
        ("bench_filters.py", ["--sizes", "0"], "must be a whole number >= 1"),
        ("profile_sumo_process.py", ["--repeat", "0"], "--repeat must be at least 1"),
        ("fault_tolerance.py", ["--set", "warning.model=ttc"], "takes fusion.fdi.KEY=VALUE"),
        ("fault_tolerance.py", ["--set", "fusion.fdi.window=-3"], "fdi.window must be"),
        ("fault_tolerance.py", ["--set", "fusion.fdi.nope=1"], "unknown config key"),
    ],
)
def test_bad_arguments_are_argparse_errors(script, args, message):
    proc = run(script, *args, ok=False)
    assert proc.returncode == 2
    assert message in proc.stderr and "Traceback" not in proc.stderr


def test_reproduce_kong2011(tmp_path):
    png = tmp_path / "plots" / "kong2011.png"
    out = run("reproduce_kong2011.py", "--runs", "20", "--seed", "3", "--plot", str(png)).stdout
    assert "kong2011 set-up: target closing at 3 m/s, T = 1 s, 20 Monte Carlo runs" in out
    for row in ("radar raw", "infrared raw", "radar KF", "infrared KF", "federated"):
        assert row in out
    assert_png(png)


def test_fault_tolerance(tmp_path):
    png = tmp_path / "fault_tolerance.png"
    out = run("fault_tolerance.py", "--runs", "20", "--plot", str(png)).stdout
    assert "Fault tolerance: fused gap RMSE, 20 runs of 10 s" in out
    for sensor in ("radar", "infrared"):
        for kind in ("dropout", "stuck", "bias +5 m", "2% spikes", "noise x10"):
            assert f"\n{sensor} {kind} " in out
    assert "both 2% spikes" in out and "false isolations" in out and "detected_by" in out
    assert "1.1x infrared alone" in out and "1.5x healthy" in out
    assert re.fullmatch(r"worst_ratio_to_bound=[0-9.]+", out.strip().splitlines()[-1])
    assert "camera_blamed_runs" in out
    assert_png(png)
    # --set reaches every table: a shorter window changes each where the window test acts.
    short = run("fault_tolerance.py", "--runs", "20", "--set", "fusion.fdi.window=4").stdout
    for table, label in ((0, "radar bias +5 m"), (1, "all rows"), (2, "on")):
        assert _row(short, table, label) != _row(out, table, label)
    assert _row(short, 0, "healthy") == _row(out, 0, "healthy")


def test_fault_tolerance_over_seeds(tmp_path):
    """``--seeds 2`` gives, per fault, the worst of the two seeds' ratios and the alerts
    summed over them."""
    one = [run("fault_tolerance.py", "--runs", "10", "--seed", str(s)).stdout for s in (3, 4)]
    both = run("fault_tolerance.py", "--runs", "10", "--seed", "3", "--seeds", "2").stdout
    assert "Fault tolerance over seeds 3-4" in both and "(seeds 3-4 summed)" in both
    worst = [float(out.strip().splitlines()[-1].split("=")[1]) for out in one]
    assert both.strip().splitlines()[-1] == f"worst_ratio_to_bound={max(worst):.3f}"
    for label in ("radar bias +5 m", "all rows"):
        cells = [_row(out, 1, label).split()[-4:] for out in one]
        summed = [
            "/".join(str(int(a) + int(b)) for a, b in zip(x.split("/"), y.split("/"), strict=True))
            for x, y in zip(*cells, strict=True)
        ]
        assert _row(both, 1, label).split()[-4:] == summed
    assert _row(both, 2, "on") == _row(one[0], 2, "on")  # the lasting bias: one fixed seed
    bad = run("fault_tolerance.py", "--seeds", "2", "--plot", str(tmp_path / "x.png"), ok=False)
    assert bad.returncode == 2 and "leave out --seeds or --plot" in bad.stderr


def _row(out: str, table: int, label: str) -> str:
    """The line of the ``table``-th table of ``out`` (tables are separated by blank lines)
    whose first column is ``label``."""
    lines = out.split("\n\n")[table].splitlines()
    return next(line for line in lines if line.startswith(f"{label}  "))


def test_steady_state_vs_full():
    out = run("steady_state_vs_full.py", "--runs", "20").stdout
    assert "Steady-state vs full Kalman filter (radar), 20 runs" in out
    assert "Steady-state vs full Kalman filter (infrared), 20 runs" in out
    one = run("steady_state_vs_full.py", "--runs", "20", "--sensor", "infrared").stdout
    assert "(infrared)" in one and "(radar)" not in one


def test_bench_filters_quick():
    out = run(
        "bench_filters.py", "--quick", "--sizes", "200", "--steps", "2", "--reference-steps", "2"
    ).stdout
    assert "Cost per pair-step" in out and "filterpy" in out and "steady-state" in out
    assert re.fullmatch(r"speedup_vs_filterpy=[0-9.]+", out.strip().splitlines()[-1])


@pytest.mark.slow
def test_profile_sumo_process_prints_the_parts_and_their_total():
    out = run("profile_sumo_process.py", "--net", "ring", "--end", "20", "--repeat", "1").stdout
    line, last = out.strip().splitlines()
    number = r"[0-9]+\.[0-9]{3}"
    parts = ", ".join(f"{p} ({number})" for p in ("reads", "fill", "snapshot", "message", "rest"))
    match = re.fullmatch(rf"run 1: SUMO step [0-9]+ µs; {parts}; total ({number})", line)
    assert match, line
    *shares, total = (float(x) for x in match.groups())
    assert all(x >= 0 for x in shares) and abs(sum(shares) - total) < 0.01
    assert last == f"besides_step={total:.3f}"


@pytest.mark.slow
def test_bench_sumo_prints_the_floor_and_the_overhead_ratio():
    out = run("bench_sumo.py", "--net", "ring", "--end", "20").stdout
    lines = out.strip().splitlines()
    assert lines[0].startswith("network ring: 20 s simulated, peak ")
    for run_name in ("bare SUMO", "SUMO + reads only", "SUMO source alone", "SUMO + FCW pipeline"):
        assert any(line.startswith(run_name) for line in lines), run_name
    assert re.fullmatch(r"source_ratio=[0-9.]+", lines[-3])
    assert re.fullmatch(r"floor_ratio=[0-9.]+", lines[-2])
    assert re.fullmatch(r"overhead_ratio=[0-9.]+", lines[-1])


def test_federated_breakdown_attributes_every_seen_alert():
    out = run("federated_breakdown.py", "--net", "motorway", "--end", "30", "--by-age").stdout
    assert "federated only:" in out and "centralized only:" in out
    assert out.count("the run's own metrics") == 2
    assert out.count("mean NIS of the reports against its prediction") == 2
    # By age: the kilometres of the bins add up to the exposure; none is older than the run.
    exposure = float(re.search(r"exposure ([0-9.]+) km", out).group(1))
    rows = re.findall(r"^ +([0-9.]+-[0-9.inf]+) s +([0-9.]+) km", out, flags=re.M)
    assert len(rows) == 2 * 5
    km = {label: float(v) for label, v in rows}
    assert sum(km.values()) == pytest.approx(exposure, rel=1e-3)
    assert km["40-80"] == km["80-inf"] == 0.0 < km["0-10"]


def test_bench_all_tabulates_the_benchmarks_it_runs(tmp_path):
    """``make bench``'s table: each chosen benchmark run as its own script, its figure read
    from its last ``NAME=value``, judged against its target, written as JSON and Markdown."""
    json_path, md_path = tmp_path / "bench.json", tmp_path / "bench.md"
    args = ["--only", "replay", "--repeat", "2", "--json", str(json_path), "--markdown"]
    out = run("bench_all.py", *args, str(md_path)).stdout.splitlines()
    assert out[0].startswith("Benchmarks, ")
    assert re.match(r"^benchmarks_passed=[01]/1$", out[-1])
    data = json.loads(json_path.read_text())
    (row,) = data["rows"]
    figure = "replay pair-steps/s (recordings replayed before)"
    assert row["figure"] == figure and len(row["values"]) == 2
    assert row["value"] == statistics.median(row["values"]) > 0
    assert row["pass"] == ("yes" if row["value"] >= 1e6 else "no")
    table = md_path.read_text()
    assert f"| {figure} |" in table and "`python scripts/bench_replay.py --quick`" in table
    assert run("bench_all.py", "--repeat", "0", ok=False).returncode == 2


def test_alert_onsets_prints_what_the_false_alerts_were_at_their_onsets():
    out = run("alert_onsets.py", "--net", "motorway", "--end", "40").stdout
    assert re.fullmatch(r"adjacent=\d+ on_lead=\d+", out.strip().splitlines()[-1])
    assert "motorway.sumocfg, seed 0, federated, path fused, FCW off" in out
    # every onset on another vehicle is sorted into one place of the true lead
    adjacent = int(re.search(r"adjacent=(\d+)", out)[1])
    places = re.findall(r"^    ([a-z ,]+): (\d+)", out, flags=re.M)
    assert adjacent > 0 and len(places) == 5 and sum(int(k) for _, k in places) == adjacent
    bad = run(
        "alert_onsets.py", "--net", "motorway", "--set", "world.selection.path=nope", ok=False
    )
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1


def test_each_benchmark_states_the_target_make_bench_judges_it_on():
    """A script's docstring and ``make bench``'s table hold the same target for its figure."""
    benches = runpy.run_path(str(SCRIPTS / "bench_all.py"), run_name="bench_all")["BENCHES"]
    number = r"([0-9][0-9 ]*(?:\.[0-9]+)?(?:e[0-9]+)?)"
    for bench in benches:
        doc = ast.get_docstring(ast.parse((SCRIPTS / bench.script).read_text()))
        found = re.search(rf"(?:target|goal):?\s*(>=|<=)\s*{number}", doc, flags=re.I)
        assert found, bench.script
        assert found[1] == (">=" if bench.at_least else "<="), bench.script
        assert float(found[2].replace(" ", "")) == bench.target, bench.script


def test_bench_env_times_its_stages():
    lines = run("bench_env.py", "--quick", "--num-envs", "16", "--stages").stdout.splitlines()
    assert re.fullmatch(r"median step of 16 copies: [0-9.]+ ms \(50 steps\)", lines[0])
    for row in ("new episodes", "perception", "its compiled step", "observation and info"):
        assert any(re.fullmatch(rf"\s+{row}\s+[0-9.]+ ms a step", ln) for ln in lines), row
    assert re.fullmatch(r"vector_env_steps_per_s=[0-9.]+ ratio_vs_highway_env=[0-9.]+", lines[-1])
