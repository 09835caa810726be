"""AEB on the test track and in traffic: ``acc-fusion conformance --protocol fmvss127`` and
``euroncap-aeb``, and the FCW + AEB run of ``acc-fusion sumo --aeb``."""

from __future__ import annotations

import re

import pytest

from acc_fusion.cli.main import main
from acc_fusion.core.units import KMH
from acc_fusion.sim.closed_loop import SimConfig
from acc_fusion.studies.aeb_tests import FALSE_ACTIVATION_LIMIT, fmvss127


def test_fmvss127_passes_every_test_point_with_the_default_configuration(capsys):
    assert main(["conformance", "--protocol", "fmvss127", "--trials", "2"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out[-1] == "fmvss127_passed=39/39"
    assert any("S9.2 plate" in line and "pass" in line for line in out)
    assert not any("FAIL" in line for line in out)


def test_without_aeb_the_lead_vehicle_tests_end_in_contact():
    """The same points with AEB made too weak to matter: the lead tests fail, the
    false-activation tests (nothing to brake for) still pass."""
    from acc_fusion.braking.aeb import AEBConfig

    weak = AEBConfig(partial_trigger=14.0, full_trigger=14.5, partial_decel=0.1, full_decel=0.2,
                     ttc_trigger=0.0)  # fmt: skip
    result = fmvss127(SimConfig(aeb=weak), 1, speed_step=40 * KMH)
    for point, (trial,) in zip(result.points, result.trials, strict=True):
        if point.kind in ("plate", "pass_through"):
            assert trial.passed and trial.peak_additional < FALSE_ACTIVATION_LIMIT
        elif not point.manual_brake:
            assert trial.contact and not trial.passed, point.label


def test_euroncap_prints_the_rating_sheet_and_the_score(tmp_path, capsys):
    assert main(["conformance", "--protocol", "euroncap-aeb", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    match = re.fullmatch(r"euroncap_aeb_score=([0-9.]+)/3\.5", out[-1])
    assert match and 2.0 <= float(match.group(1)) <= 3.5
    assert any(line.startswith("CCRb") and "green" in line for line in out)
    assert (tmp_path / "euroncap_aeb.png").stat().st_size > 10_000
    assert (tmp_path / "euroncap_aeb.csv").read_text().count("\n") == 135  # 134 points


def test_euroncap_takes_no_trials(capsys):
    assert main(["conformance", "--protocol", "euroncap-aeb", "--trials", "2"]) == 2
    assert "drop --trials" in capsys.readouterr().err


def test_sumo_aeb_adds_the_fcw_plus_aeb_run(tmp_path, capsys):
    pytest.importorskip("libsumo")
    args = ["sumo", "--net", "motorway", "--end", "40", "--warmup", "60", "--aeb"]
    args += ["--out", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "federated + AEB" in out
    assert "AEB activations and FCW alerts" in out and "AEB activations (federated)" in out
    rows = (tmp_path / "sumo_motorway_seed0_aeb.csv").read_text().splitlines()
    assert rows[0].startswith("method,") and len(rows) == 3
