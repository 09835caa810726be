"""OSI traces of the 2-D world: written per ego with its ground truth, readings, detections,
tracks and estimates, read by asam-osi-utilities, and replayed to the same alerts."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("osi3")
pytest.importorskip("osi_utilities")

from acc_fusion.cli.main import main  # noqa: E402
from acc_fusion.core.errors import InputError  # noqa: E402
from acc_fusion.fusion.tracking.tracker import Tracker, TrackerConfig  # noqa: E402
from acc_fusion.sensors.suite2d import sensors_2d  # noqa: E402
from acc_fusion.sim.closed_loop import SimConfig  # noqa: E402
from acc_fusion.sim.osi_codec import (  # noqa: E402
    ESTIMATE_TOPIC,
    HOST_TOPIC,
    SENSOR_TOPIC,
    decode_detections,
    encode_sensor,
)
from acc_fusion.sim.osi_trace import (  # noqa: E402
    GROUND_TRUTH_TOPIC,
    OsiRecorder,
    read_channels,
    replay_trace,
    topics,
)
from acc_fusion.sim.world import simulate_world  # noqa: E402
from acc_fusion.truth.conditions import Conditions  # noqa: E402
from acc_fusion.truth.scenes import SceneConfig, SceneSource  # noqa: E402

METHODS = ("radar", "infrared", "centralized", "federated")


class Levels:
    """Every method's warning level and cause of every ego at every step."""

    def __init__(self) -> None:
        self.steps: list[tuple[float, dict[str, np.ndarray], dict[str, np.ndarray]]] = []

    def __call__(self, view) -> None:
        causes = view.perceived.causes
        self.steps.append((view.frame.t, {m: v.copy() for m, v in view.levels.items()},
                           {m: c.copy() for m, c in causes.items()}))  # fmt: skip

    def of(self, e: int) -> list:
        return [(lv[m][e], cs[m][e]) for _, lv, cs in self.steps for m in METHODS]


def _record(tmp_path, scene: str, runs: int = 2, seed: int = 3):
    cfg = SimConfig(runs=runs, methods=METHODS, seed=seed)
    cfg = replace(cfg, world=replace(cfg.world, scene=scene))
    seen = Levels()
    with OsiRecorder(tmp_path, cfg, prefix=f"{scene}_") as recorder:

        def both(view):
            recorder(view)
            seen(view)

        result = simulate_world(cfg, on_step=both)
    return cfg, result, seen, recorder.written


@pytest.mark.parametrize("scene", ["cut_in", "lead_brakes"])
def test_a_replayed_trace_gives_its_egos_alerts_step_for_step(tmp_path, scene):
    """Each ego's trace, replayed alone, gives the recorded run's warning levels and causes at
    every step for every method, and the runs' summaries add up to the recorded run's."""
    cfg, result, seen, traces = _record(tmp_path, scene)
    assert [p.name for p in traces] == [f"{scene}_run000.mcap", f"{scene}_run001.mcap"]
    replays = []
    for e, path in enumerate(traces):
        again = Levels()
        replays.append(replay_trace(replace(cfg, runs=1), path, on_step=again))
        assert [t for t, _, _ in again.steps] == pytest.approx([t for t, _, _ in seen.steps])
        assert again.of(0) == seen.of(e)
    for m in METHODS:
        for name in ("warnings", "nuisance", "sensing_false", "relevant", "relevant_missed"):
            total = sum(getattr(r.summaries[m], name) for r in replays)
            assert total == getattr(result.summaries[m], name), (m, name)
        for cls, causes in result.summaries[m].by_cause.items():
            for cause, count in causes.items():
                assert sum(r.summaries[m].by_cause[cls][cause] for r in replays) == count
        assert result.summaries[m].km == pytest.approx(sum(r.summaries[m].km for r in replays))
    assert sum(result.summaries[m].warnings for m in METHODS) > 0  # warnings were compared


def test_a_trace_holds_every_channel_at_every_step(tmp_path):
    """asam-osi-utilities reads a trace back: one ground truth, host reading, sensor frame per
    sensor and estimate per method at each step, the detections' ids in the ground truth."""
    cfg, result, _, traces = _record(tmp_path, "gantry_crest", runs=1)
    wanted = [GROUND_TRUTH_TOPIC, HOST_TOPIC, *(SENSOR_TOPIC.format(s) for s in ("radar",
              "infrared")), *(ESTIMATE_TOPIC.format(m) for m in METHODS)]  # fmt: skip
    assert sorted(topics(traces[0])) == sorted(wanted)
    channels = read_channels(traces[0], wanted)
    assert {len(v) for v in channels.values()} == {result.steps}
    truth_ids = {o.id.value for gt in channels[GROUND_TRUTH_TOPIC] for o in gt.moving_object}
    truth_ids |= {o.id.value for gt in channels[GROUND_TRUTH_TOPIC] for o in gt.stationary_object}
    radar = channels[SENSOR_TOPIC.format("radar")]
    seen = {d.object_id.value for sd in radar for d in sd.feature_data.radar_sensor[0].detection
            if d.HasField("object_id")}  # fmt: skip
    assert seen and seen <= truth_ids
    assert any(len(sd.moving_object) for sd in radar)  # the tracks are there
    fused = channels[ESTIMATE_TOPIC.format("federated")]
    objects = [o for sd in fused for o in sd.moving_object]
    assert objects and all(o.base_rmse.position.x > 0 for o in objects)


def test_detections_round_trip_through_sensor_data():
    """Range, azimuth, their stds, ids and origins come back exactly; the camera's range-rate
    and its std within ulps (a dot product with the line of sight)."""
    src = SceneSource(SceneConfig(scene="cut_in", runs=3), np.random.default_rng(1))
    for _ in range(40):
        src.advance()
    frame = src.frame()
    kind_of = dict(zip(frame.object_id[frame.valid].tolist(), frame.kind[frame.valid].tolist(),
                       strict=True))  # fmt: skip
    checked = 0
    for sensor in sensors_2d(None, seed=5):
        det = sensor.detect(frame, Conditions())
        tracks = Tracker(det.sensor, TrackerConfig(), frame.n_egos).step(
            det, frame.ego_speed, frame.ego_yaw_rate, 0.05
        )
        for e in range(frame.n_egos):
            data = encode_sensor(det, tracks, e, 1, (2.4, 0.0, 0.5))
            growth = (det.range_std_growth, det.range_rate_std_growth)
            back = decode_detections(data, det.sensor, det.t, kind_of, growth)
            lo, hi = det.rows()[e : e + 2]
            for name in ("range", "azimuth", "range_std", "azimuth_std", "object_id", "origin"):
                assert np.array_equal(getattr(back, name), getattr(det, name)[lo:hi]), name
            for name in ("range_rate", "range_rate_std"):
                assert np.allclose(getattr(back, name), getattr(det, name)[lo:hi], rtol=1e-15,
                                   atol=1e-14), name  # fmt: skip
            assert back.online == det.online
            checked += hi - lo
    assert checked > 0


def test_a_trace_without_sensor_channels_is_refused_in_one_sentence(tmp_path):
    cfg, _, _, traces = _record(tmp_path, "cut_in", runs=1)
    with pytest.raises(InputError, match="no channel"):
        read_channels(traces[0], ["sensor/lidar"])


def test_the_commands_write_traces_and_replay_them_to_the_same_alerts(tmp_path, capsys):
    """``acc-fusion world --osi DIR`` writes a trace per run; ``acc-fusion replay --format osi``
    on them prints the world run's alerts again, class by class and cause by cause."""
    traces, world_out, replay_out = tmp_path / "osi", tmp_path / "world", tmp_path / "replay"
    args = ["world", "--runs", "2", "--scene", "lead_brakes", "--conditions", "day"]
    assert main([*args, "--osi", str(traces), "--out", str(world_out)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote 2 OSI traces in {traces}"
    recorded = json.loads((world_out / "world.json").read_text())["lead_brakes / day"]
    assert main(["replay", "--format", "osi", "--path", str(traces), "--out", str(replay_out)]) == 0
    (summary,) = replay_out.glob("replay_*.json")
    replayed = json.loads(summary.read_text())
    for m in METHODS:
        for key in ("warnings", "nuisance", "sensing_false", "relevant_missed", "by_cause"):
            assert replayed[m][key] == recorded[m][key], (m, key)
    assert sum(recorded[m]["warnings"] for m in METHODS) > 0


def test_an_openscenario_file_runs_into_an_osi_trace(tmp_path, capsys):
    """An exported OpenSCENARIO test, run in the 2-D world with ``--osi``, leaves a trace per
    run that replays to the run's warnings: the two standards meet in one command line."""
    pytest.importorskip("scenariogeneration")
    assert main(["scenarios", "export", "--protocol", "nhtsa-fcw", "--out", str(tmp_path)]) == 0
    (scenario,) = tmp_path.glob("*_lvd_*.xosc")
    traces, out = tmp_path / "osi", tmp_path / "world"
    args = ["world", "--scenario", str(scenario), "--runs", "2", "--conditions", "day"]
    assert main([*args, "--osi", str(traces), "--out", str(out)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote 2 OSI traces in {traces}"
    (recorded,) = json.loads((out / "world.json").read_text()).values()
    assert main(["replay", "--format", "osi", "--path", str(traces), "--out", str(out)]) == 0
    (summary,) = out.glob("replay_*.json")
    replayed = json.loads(summary.read_text())
    for m in METHODS:
        assert replayed[m]["warnings"] == recorded[m]["warnings"], m
        assert replayed[m]["by_cause"] == recorded[m]["by_cause"], m
    assert sum(recorded[m]["warnings"] for m in METHODS) > 0


def test_a_replay_writes_its_own_traces(tmp_path, capsys):
    """``replay --format osi --osi DIR`` traces the replay: a ground truth alone comes out with
    this project's detections, tracks and estimates, and those replay to the same alerts."""
    cfg, result, _, traces = _record(tmp_path / "first", "lead_brakes")
    again = tmp_path / "again"
    args = ["replay", "--format", "osi", "--path", str(tmp_path / "first")]
    assert main([*args, "--osi", str(again), "--out", str(tmp_path / "r1")]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote 2 OSI traces in {again}"
    assert sorted(p.name for p in again.glob("*.mcap")) == [p.name for p in traces]
    assert (
        main(["replay", "--format", "osi", "--path", str(again), "--out", str(tmp_path / "r2")])
        == 0
    )
    first, second = (
        json.loads(next((tmp_path / d).glob("*.json")).read_text()) for d in ("r1", "r2")
    )
    for m in METHODS:
        assert first[m]["warnings"] == second[m]["warnings"] == result.summaries[m].warnings
    assert main([*args, "--pair", "--osi", str(tmp_path / "no")]) == 2
    assert "--osi writes the 2-D world's traces" in capsys.readouterr().err
