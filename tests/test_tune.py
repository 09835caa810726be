"""``acc-fusion tune``: the test margin against the nuisance of each warning setting."""

from __future__ import annotations

import csv

import pytest

pytest.importorskip("libsumo")

from acc_fusion.cli.main import main  # noqa: E402
from acc_fusion.metrics.stats import Rate  # noqa: E402
from acc_fusion.studies.tune import TunePoint, grid_points, mark_pareto  # noqa: E402


def test_tune_prints_the_tradeoff_and_writes_csv_and_plot(tmp_path, capsys):
    code = main(
        [
            "tune", "--net", "motorway", "--end", "60", "--trials", "3",
            "--set", "warning.model=required_deceleration",
            "--grid", "warning.params.decel_imminent=[4.0, 6.0]",
            "--out", str(tmp_path),
        ]
    )  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0
    assert "Warning tuning on motorway.sumocfg" in out and "perfect sensing" in out
    rows = list(csv.DictReader((tmp_path / "tune.csv").open()))
    assert [r["warning.params.decel_imminent"] for r in rows] == ["4.0", "6.0"]
    # A later imminent threshold can only warn less and later: less nuisance, smaller margin.
    nuisance = [float(r["nuisance_per_100km"].split()[0]) for r in rows]
    margin = [float(r["nhtsa_margin_s"]) for r in rows]
    assert nuisance[1] <= nuisance[0] and margin[1] < margin[0]
    assert (tmp_path / "tune.png").stat().st_size > 10_000


@pytest.mark.parametrize(
    "grid, words",
    [
        ("warning.z", ("--grid", "KEY=")),
        ("warning.z=3", ("--grid warning.z", "non-empty list")),
        ("warning.bogus=[1, 2]", ("bogus", "allowed keys")),
    ],
)
def test_a_bad_grid_is_one_line(grid, words, capsys):
    code = main(["tune", "--end", "10", "--grid", grid])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("acc-fusion: error: ")
    assert all(w in err[0] for w in words), err[0]


def test_grid_points_and_pareto_front():
    assert grid_points({"a": [1, 2], "b": ["x"]}) == [{"a": 1, "b": "x"}, {"a": 2, "b": "x"}]

    def point(margin, nuisance):
        rate = Rate(nuisance, nuisance, nuisance)
        traffic = type("S", (), {"alerts_per_100km": {"nuisance": rate}})()
        return TunePoint({}, margin, margin >= 0, True, traffic)

    points = [point(0.5, 10.0), point(0.3, 2.0), point(0.2, 5.0), point(0.5, 12.0)]
    mark_pareto(points)
    assert [p.pareto for p in points] == [True, True, False, False]


def test_the_recording_is_the_traffic_whose_classes_acc_fusion_sumo_prints():
    """With distracted drivers (the default of the traffic commands) the recording is the
    FCW-off closed loop of ``acc-fusion sumo``: the rule on it fires as that run's oracle."""
    from dataclasses import replace

    from acc_fusion.cli.common import traffic_config, traffic_sim_config
    from acc_fusion.cli.main import build_parser
    from acc_fusion.studies.traffic import _run
    from acc_fusion.studies.tune import record_sumo, rule_on_truth
    from acc_fusion.truth.sumo.nets import resolve_sumocfg

    args = build_parser().parse_args(["sumo", "--net", "motorway", "--end", "60"])
    sumo = traffic_config(args, resolve_sumocfg("motorway", None), seed=0)
    sim = traffic_sim_config(args)
    assert sim.driver.distraction.rate > 0
    off = _run(sumo, replace(sim, drive=sim.methods[-1]), False, False, False)
    oracle = off.summaries[sim.methods[-1]]
    recording = record_sumo(sumo, sim)
    rule = rule_on_truth(recording, sim)
    assert recording.distraction == sim.driver.distraction.rate
    assert rule.warnings == oracle.threats > 0
    assert rule.relevant == oracle.relevant > 0
    assert rule.km == pytest.approx(oracle.km)


def test_the_recording_keeps_the_gaze_the_adaptive_warning_reads():
    """The drivers' gaze is recorded: the rule with the driver monitor fires on the recording
    as the oracle of the FCW-off run with the monitor, and less than the rule alone; and so
    is their braking."""
    from dataclasses import replace

    from acc_fusion.cli.common import traffic_config, traffic_sim_config
    from acc_fusion.cli.main import build_parser
    from acc_fusion.studies.traffic import _run
    from acc_fusion.studies.tune import record_sumo, rule_on_truth
    from acc_fusion.truth.sumo.nets import resolve_sumocfg
    from acc_fusion.warning.logic import AdaptiveConfig

    args = build_parser().parse_args(["sumo", "--net", "motorway", "--end", "40"])
    sumo = traffic_config(args, resolve_sumocfg("motorway", None), seed=0)
    plain = traffic_sim_config(args)
    sim = replace(plain, warning=replace(plain.warning, adaptive=AdaptiveConfig(enabled=True)))
    off = _run(sumo, replace(sim, drive=sim.methods[-1]), False, False, False)
    oracle = off.summaries[sim.methods[-1]]
    recording = record_sumo(sumo, sim)
    rule = rule_on_truth(recording, sim)
    assert rule.warnings == oracle.threats > 0
    assert rule_on_truth(recording, plain).warnings > rule.warnings
    # The recording keeps the egos' accelerations too: without the braking signal the
    # rule fires more.
    still = replace(plain.warning.adaptive, braking=0.0)
    unbraked = replace(plain, warning=replace(plain.warning, adaptive=still))
    assert rule_on_truth(recording, unbraked).warnings > rule_on_truth(recording, plain).warnings
