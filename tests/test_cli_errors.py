"""No traceback and no wasted computation for any bad input (issue 50): each test reproduces
one class of defect, a bad input that used to end in a traceback, a multi-line message or
work thrown away, and checks that it is now one line ``acc-fusion: error: …`` and exit 2."""

from __future__ import annotations

import subprocess
import sys

import pytest

from acc_fusion.cli.main import COMMANDS, main


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
    new = tmp_path / "new" / "deep"
    one_line_error(capsys, "run", "--scenario", "nowhere", "--out", str(new))  # checked, not made
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


#: What a command's work loads and its arguments must not: compiled kernels, the simulators,
#: Ray, torch, the plots.
HEAVY = ("numba", "libsumo", "ray", "torch", "highway_env", "gymnasium", "matplotlib", "filterpy")


def loaded_by(*args: str) -> tuple[int, list[str]]:
    """Run ``acc-fusion args`` in a fresh interpreter: its exit code and the heavy modules it
    imported (measured by what is imported, not by the time taken, which a busy machine
    stretches)."""
    code = (
        "import sys; from acc_fusion.cli.main import main; code = main(sys.argv[1:]); "
        f"print(code, *[m for m in {HEAVY!r} if m in sys.modules])"
    )
    res = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, check=True
    )
    code, *heavy = res.stdout.split("\n")[-2].split()
    return int(code), heavy


@pytest.mark.parametrize(
    "args",
    [
        ["--help"],
        ["no_such_command"],
        ["run", "--scenario", "ccrs", "--out", "/proc/x"],
        ["estimation", "--runs", "0"],
        ["config", "schema", "--out", "/proc/x/schema.json"],
        *([name, "--help"] for name in COMMANDS if name != "world"),
    ],
)
def test_the_command_line_answers_before_loading_the_pipeline(args):
    """``--help``, a usage error or a bad output used to wait 2.5 s for every command's
    imports (numba kernels, SUMO, Ray, torch); now only the command given is loaded, and its
    work only after its arguments are checked.  (``world``'s parser lists the scenes, whose
    module compiles numba kernels.)"""
    code, heavy = loaded_by(*args)
    assert code == (0 if "--help" in args else 2) and heavy == []
