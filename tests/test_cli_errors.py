"""No traceback and no wasted computation for any bad input (issue 50): each test reproduces
one class of defect, a bad input that used to end in a traceback, a multi-line message or
work thrown away, and checks that it is now one line ``acc-fusion: error: …`` and exit 2."""

from __future__ import annotations

import pytest

from acc_fusion.cli.main import main


def one_line_error(capsys, *args: str) -> str:
    """Run ``acc-fusion args`` in-process; check exit 2, one line on stderr, and return it."""
    assert main(list(args)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("acc-fusion: error: "), err
    return err


@pytest.fixture
def blocker(tmp_path):
    """A plain file, so that ``blocker / "sub"`` is a folder that cannot be created."""
    path = tmp_path / "file"
    path.write_text("x")
    return path


@pytest.mark.parametrize(
    "args",
    [
        ["run", "--scenario", "ccrs", "--out", "{bad}/out"],
        ["run", "--scenario", "ccrs", "--out", "/proc/x"],
        ["world", "--runs", "1", "--out", "{bad}/out"],
        ["world", "--runs", "1", "--plot", "{bad}/x.png"],
        ["estimation", "--out", "{bad}/out"],
        ["compare", "--out", "{bad}"],
        ["config", "schema", "--out", "{tmp}"],
        ["highway", "--render", "{bad}/x.gif"],
        ["sweep", "missing.toml", "--out", "{bad}/out"],
    ],
)
def test_an_unwritable_output_is_refused_before_the_work(args, blocker, tmp_path, capsys):
    """Used to be found after the whole computation, with a PermissionError or
    IsADirectoryError traceback."""
    args = [a.format(bad=blocker, tmp=tmp_path) for a in args]
    err = one_line_error(capsys, *args)
    assert "argument --" in err and ("output folder" in err or "output file" in err)
    assert capsys.readouterr().out == ""


def test_a_bad_output_leaves_no_other_output(blocker, tmp_path, capsys):
    """``world --out BAD --plot ok.png`` used to write the figure, then lose the tables."""
    plot = tmp_path / "ok.png"
    one_line_error(capsys, "world", "--runs", "1", "--plot", str(plot), "--out", str(blocker))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]
