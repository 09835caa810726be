"""``acc-fusion replay --format osi``: OSI traces of the scripted world replayed through the 1-D
pair and the 2-D world, every trace's host an ego, with the other replays' tables; the same
replay as the scene's own open-loop run; bad paths in one line."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("osi3")
pytest.importorskip("osi_utilities")

from acc_fusion.cli.main import main  # noqa: E402
from acc_fusion.sim.closed_loop import SimConfig  # noqa: E402
from acc_fusion.sim.world import simulate_world  # noqa: E402
from acc_fusion.studies.replay import replay_study  # noqa: E402
from acc_fusion.truth.osi.ground_truth import GroundTruthEncoder  # noqa: E402
from acc_fusion.truth.osi.trace import write_ground_truth_trace  # noqa: E402
from acc_fusion.truth.replay.source import ReplayConfig  # noqa: E402
from acc_fusion.truth.scenes import SceneConfig, SceneSource  # noqa: E402

RUNS, DT = 2, 0.05


@pytest.fixture(scope="module")
def traces(tmp_path_factory):
    """The folder of the lead_brakes scene's two runs, one MCAP trace per ego."""
    folder = tmp_path_factory.mktemp("osi")
    src = SceneSource(SceneConfig(scene="lead_brakes", runs=RUNS, dt=DT), seed=11)
    enc, messages = GroundTruthEncoder(RUNS), [[] for _ in range(RUNS)]
    while not src.done:
        for e, m in enumerate(enc.encode(src.frame(), np.arange(RUNS))):
            messages[e].append(m)
        src.advance()
    for e in range(RUNS):
        write_ground_truth_trace(folder / f"run_{e}.mcap", messages[e])
    return folder


def test_the_world_replay_of_the_traces_is_the_scenes_open_loop_run(traces):
    """Open loop, the 2-D world on the traces sees what it saw on the scene itself: the same
    warnings by class and cause (the traces carry every object the frames had)."""
    sim = SimConfig(dt=DT, seed=5, drive=None)
    own = simulate_world(sim, source=SceneSource(SceneConfig("lead_brakes", RUNS, DT), seed=11))
    study = replay_study(ReplayConfig(format="osi", path=str(traces)), sim, world=True)
    assert study.steps == own.steps
    for m, s in own.summaries.items():
        r = study.summaries[m]
        assert (r.warnings, r.false_alarms, r.by_cause) == (s.warnings, s.false_alarms,
                                                           s.by_cause), m  # fmt: skip
        assert r.km == pytest.approx(s.km, rel=1e-9)
    assert sum(s.warnings for s in own.summaries.values()) > 0
    rows = study.exposure().rows
    assert [r["recording"] for r in rows] == ["run_0.mcap", "run_1.mcap"]
    assert all(r["leaders"] == "file" and r["pair_steps"] > 0 for r in rows)
    assert study.causes() is not None
    pair = replay_study(ReplayConfig(format="osi", path=str(traces / "run_0.mcap")),
                        replace(sim, methods=("radar",)))  # fmt: skip
    assert pair.causes() is None and list(pair.summaries) == ["radar"]


def test_the_command_prints_the_replay_tables(traces, capsys, tmp_path):
    out = tmp_path / "out"
    args = ["replay", "--format", "osi", "--path", str(traces), "--out", str(out)]
    assert main(args) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].startswith("FCW on recorded traffic (run_0.mcap, run_1.mcap), open loop")
    assert any(line.startswith("Exposure per recording") for line in lines)
    assert "Cross-check against the data set's headway columns: none" in lines
    assert any(line.startswith("Nuisance and sensing-false alerts by cause") for line in lines)
    assert lines[-1].startswith("wrote ") and lines[-1].endswith(
        "replay_run_0_mcap_run_1_mcap.json"
    )
    assert (out / "replay_run_0_mcap_run_1_mcap_causes.csv").is_file()
    assert main(["replay", "--format", "osi", "--path", str(traces / "run_1.mcap"), "--pair"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1] == "Cross-check against the data set's headway columns: none"
    assert any(line.startswith("run_1.mcap ") and " file " in line for line in lines)


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda p: p, "holds no OSI trace"),
        (lambda p: p / "missing.mcap", "does not exist"),
        (lambda p: (p / "x.mcap").write_bytes(b"junk") and p / "x.mcap", "not an MCAP file"),
    ],
)
def test_bad_osi_paths_are_one_line(tmp_path, capsys, make, words):
    path = make(tmp_path)
    assert main(["replay", "--format", "osi", "--path", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err, err
