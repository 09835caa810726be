"""OpenSCENARIO out and back in: the protocols' files pass ASAM's quality checkers, and read
back they reproduce the built-in procedures' truth at every step; the ``scenarios export`` and
``world --scenario`` commands."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import sys

import numpy as np
import pytest
from lxml import etree

from acc_fusion.cli.main import main
from acc_fusion.cli.parsers.scenarios import PROTOCOLS as CLI_PROTOCOLS
from acc_fusion.core.errors import ConfigError
from acc_fusion.studies.scenarios import PROTOCOLS, export_protocol, protocol_points
from acc_fusion.truth.objects import ObjectFrame
from acc_fusion.truth.openscenario.check import check_files
from acc_fusion.truth.openscenario.export import write_points
from acc_fusion.truth.openscenario.read import read_scenario
from acc_fusion.truth.procedures import ProcedureSource, TrackSource

#: Round-trip tolerance [m, m/s, m/s², rad]: the file carries positions as sums written in
#: decimal (``${$Gap + 102.25}``) and the road's length as the track's plus 100 m, so a
#: read-back position differs from the built-in one by the rounding of those sums, about
#: 1e-13 m; 1e-9 leaves room and is far below any sensor's resolution.
TOLERANCE = 1e-9


@pytest.fixture(scope="module")
def fmvss127(tmp_path_factory):
    """FMVSS 127's files, checked by ASAM's checkers as they are written."""
    return export_protocol("fmvss127", tmp_path_factory.mktemp("fmvss127"), check=True)


def test_fmvss127_files_pass_asams_checkers_with_zero_issues(fmvss127):
    report = fmvss127.check
    assert report.files == {".xosc": 39, ".xodr": 1}
    assert report.findings == () and report.passed
    assert report.completed >= 17 * 39  # every xosc check ran on every file


def test_the_checkers_see_a_broken_file(fmvss127, tmp_path):
    """A file that leaves the schema fails, so the passing verdict above means something."""
    good = fmvss127.scenarios[0]
    bad = tmp_path / good.name
    bad.write_text(good.read_text().replace("<Init>", "<Init><Bogus/>"))
    (tmp_path / fmvss127.road.name).write_text(fmvss127.road.read_text())
    report = check_files([bad])
    assert not report.passed
    assert [f.checker for f in report.findings] == ["check_asam_xosc_xml_valid_schema"]


def test_every_figure_is_a_parameter_the_storyboard_uses(fmvss127):
    for path in fmvss127.scenarios:
        root = etree.parse(str(path)).getroot()
        names = [d.get("name") for d in root.iterfind("ParameterDeclarations/*")]
        body = etree.tostring(root.find("Storyboard")).decode()
        assert {"SubjectSpeed", "Gap", "Duration"} <= set(names)
        for name in names:
            assert f"${name}" in body, (path.name, name)


def test_a_parameter_changed_in_the_file_moves_the_pov(fmvss127):
    path = fmvss127.scenarios[0]
    text = path.read_text()
    before = read_scenario(path)
    gap = float(etree.parse(str(path)).find("ParameterDeclarations/*[@name='Gap']").get("value"))
    moved = path.with_name("moved.xosc")
    declaration = 'name="Gap" parameterType="double" value="{!r}"'
    moved.write_text(text.replace(declaration.format(gap), declaration.format(gap + 7.0)))
    after = read_scenario(moved)
    assert after.actors.s0[0, 0] == pytest.approx(before.actors.s0[0, 0] + 7.0, abs=1e-12)


def _sample():
    """Every FMVSS 127 point, the NHTSA tests and every tenth Euro NCAP point (CCRs, CCRm at
    each overlap, CCRb)."""
    grid = protocol_points("euroncap-aeb")
    ncap = [p for i, p in enumerate(grid) if i % 10 == 0 or i >= len(grid) - 4]
    return protocol_points("fmvss127") + protocol_points("nhtsa-fcw") + ncap


FIELDS = [f.name for f in dataclasses.fields(ObjectFrame)]


def _same_frames(built, read, brake_from: int) -> int:
    """Step both sources to the end, a brake request of 3 m/s² from step ``brake_from`` on;
    assert equal frames at every step and return the steps."""
    steps = 0
    while True:
        a, b = built.frame(), read.frame()
        for name in FIELDS:
            x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
            same = np.abs(x - y) <= TOLERANCE if x.dtype.kind == "f" else x == y
            assert x.shape == y.shape and np.all(same), (name, steps, x, y)
        assert built.done == read.done
        if built.done:
            return steps
        brake = np.full(1, 3.0 if steps >= brake_from else 0.0)
        built.advance(brake)
        read.advance(brake)
        steps += 1


def test_read_back_the_procedures_reproduce_their_truth_at_every_step(tmp_path):
    """For every FMVSS 127 point, NHTSA's three tests and a sample of Euro NCAP's grid, the
    ObjectFrame of the scene read back from its file (:class:`TrackSource`) equals the
    built-in :class:`ProcedureSource`'s within :data:`TOLERANCE` (1e-9 m, m/s, m/s², rad;
    integers and masks exactly) at every step of dt = 0.05 s, to the run's end (its duration
    or the contact), once with no braking and once with the ego braking halfway."""
    points = _sample()
    written = write_points(points, tmp_path)
    for i, (point, path) in enumerate(zip(points, written.scenarios, strict=True)):
        scene = read_scenario(path)
        assert scene.duration == pytest.approx(point.duration, abs=1e-12)
        brake_from = 10**6 if i % 2 else 60
        steps = _same_frames(ProcedureSource([point]), TrackSource(scene, scene.duration),
                             brake_from)  # fmt: skip
        assert steps >= 50, point.label


def test_protocol_names_agree_and_labels_give_distinct_files():
    assert CLI_PROTOCOLS == PROTOCOLS
    for protocol in PROTOCOLS:
        labels = [p.label for p in protocol_points(protocol)]
        assert len(set(labels)) == len(labels) and all(labels)


def test_without_scenariogeneration_one_sentence_names_the_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "scenariogeneration", None)
    with pytest.raises(ConfigError, match=r"pip install 'acc_fusion\[interop\]'"):
        write_points(protocol_points("nhtsa-fcw"), tmp_path / "out")
    assert list(tmp_path.iterdir()) == []  # neither the folder nor a temporary one


def _run(*args: str) -> tuple[int, list[str]]:
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(list(args))
    return code, printed.getvalue().splitlines()


def test_scenarios_export_prints_its_table_and_the_count(tmp_path):
    code, lines = _run("scenarios", "export", "--protocol", "nhtsa-fcw", "--out",
                       str(tmp_path), "--check")  # fmt: skip
    assert code == 0
    assert lines[-1] == "scenarios_written=3"
    assert any("pass: 0 issues" in line for line in lines)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "nhtsa_fcw_test_1_lvs_72_kmh.xosc", "nhtsa_fcw_test_2_lvd_72_kmh_30_m_0_3_g.xosc",
        "nhtsa_fcw_test_3_lvm_72_kmh_to_32_kmh.xosc", "test_track.xodr"]  # fmt: skip


def test_world_runs_a_scenario_file(tmp_path, capsys):
    written = write_points(protocol_points("nhtsa-fcw")[1:2], tmp_path)
    code, lines = _run("world", "--scenario", str(written.scenarios[0]), "--runs", "2",
                       "--conditions", "day")  # fmt: skip
    assert code == 0
    text = "\n".join(lines)
    assert "Alerts by scene (judged from truth)" in text
    assert written.scenarios[0].name in text
    # the lead brakes hard 30 m ahead: every method warns in both runs
    rows = [line.split() for line in lines if line.startswith(written.scenarios[0].stem)]
    assert len(rows) == 4 and all(r[4] == "2" for r in rows)
    assert main(["world", "--scenario", str(tmp_path / "missing.xosc"), "--runs", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not exist" in err
