"""No traceback and no wasted computation for any bad input (issue 50): each test reproduces
one class of defect, a bad input that used to end in a traceback, a multi-line message or
work thrown away, and checks that it is now one line ``acc-fusion: error: …`` and exit 2."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from acc_fusion.cli.main import COMMANDS, main
from acc_fusion.truth.sumo.nets import bundled_nets


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


@pytest.mark.parametrize(
    "args, words",
    [
        (["--set", "radar_faults=[{kind: bias}]"], ("radar_faults[0] needs the key 'start'",)),
        (
            ["--set", "world.sensors.infrared_faults=[{start: 1}]"],
            ("world.sensors.infrared_faults[0] needs the key 'kind'",),
        ),
        (["--config", "{dir}/faults.yaml"], ("infrared_faults[0] needs the key 'start'",)),
        (["--set", "runs=[1, 2"], ("--set runs is not valid YAML at line 1, column 6",)),
        (
            ["--config", "{dir}/syntax.yaml"],
            ("syntax.yaml' is not valid YAML at line 2, column 2",),
        ),
        (
            ["--config", "{dir}/syntax.toml"],
            ("syntax.toml' is not valid TOML at line 2, column 1",),
        ),
        (["--config", "{dir}/deep.yaml"], ("nests deeper than 32 levels",)),
        (["--config", "{dir}/deep.toml"], ("nests deeper than 32 levels",)),
        (["--config", "{dir}/laughs.yaml"], ("holds more than 100000 values",)),
        (["--config", "{dir}/big.yaml"], ("is larger than 1 MiB",)),
        (["--config", "{dir}"], ("is a folder, not a file",)),
        (["--config", "{dir}/control.yaml"], ("not valid YAML: unacceptable character #x0008",)),
    ],
)
def test_every_spec_is_validated_with_its_key_path(tmp_path, capsys, args, words):
    """A fault without one of its fields was a ``TypeError`` traceback, a syntax error 4-8
    lines, a deep or huge file a ``RecursionError`` or a hang, a folder "does not exist"."""
    (tmp_path / "faults.yaml").write_text("infrared_faults:\n  - kind: dropout\n")
    (tmp_path / "syntax.yaml").write_text("a: [1, 2\nb: 3\n")
    (tmp_path / "syntax.toml").write_text("a = [1, 2\nb = 3\n")
    (tmp_path / "deep.yaml").write_text("a: " + "[" * 3000 + "]" * 3000 + "\n")
    (tmp_path / "deep.toml").write_text("a = " + "[" * 3000 + "]" * 3000 + "\n")
    laughs = ["a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    laughs += [
        f"{b}: &{b} [{', '.join([f'*{a}'] * 10)}]" for a, b in zip("abcde", "bcdef", strict=True)
    ]
    (tmp_path / "laughs.yaml").write_text("\n".join(laughs) + "\n")
    (tmp_path / "big.yaml").write_text("#" * (1 << 20) + "\n")
    (tmp_path / "control.yaml").write_text("a: \x08\n")  # found by tests/test_fuzz.py
    err = one_line_error(
        capsys, "config", "show", *[a.replace("{dir}", str(tmp_path)) for a in args]
    )
    for w in words:
        assert w in err


def test_a_grid_and_a_sweep_axis_are_validated_like_a_config(tmp_path, capsys):
    """``tune --grid`` with a YAML syntax error was a traceback; a sweep axis of faults without
    a start a ``TypeError``."""
    err = one_line_error(capsys, "tune", "--grid", "warning.z=[1, 2")
    assert "--grid warning.z is not valid YAML at line 1, column 6" in err
    spec = tmp_path / "sweep.toml"
    spec.write_text(
        'name = "t"\nseeds = [0]\nruns = 2\nchunk_runs = 2\n[base]\nscenario = "ccrs"\n'
        '[axes]\nradar_faults = [[{kind = "bias"}]]\n'
    )
    err = one_line_error(capsys, "sweep", str(spec), "--out", str(tmp_path / "out"))
    assert "radar_faults[0] needs the key 'start'" in err


@pytest.mark.parametrize("columns", ["[a, b]", "3", "frame"])
def test_a_mapping_whose_columns_is_not_a_table_is_one_line(tmp_path, capsys, columns):
    """Was a ``TypeError`` traceback."""
    mapping = tmp_path / "mapping.yaml"
    mapping.write_text(f"columns: {columns}\n")
    data = tmp_path / "t.csv"
    data.write_text("id,frame,x\n1,0,0\n")
    args = ["replay", "--format", "csv", "--path", str(data), "--mapping", str(mapping)]
    assert "columns must be a table/mapping" in one_line_error(capsys, *args)


@pytest.mark.parametrize(
    "args",
    [
        ["replay", "--format", "csv", "--path", "{input}"],
        ["replay", "--format", "ngsim", "--path", "{input}"],
        ["replay", "--format", "highd", "--path", "{input}"],
        ["sumo", "--sumocfg", "{input}"],
        ["config", "show", "--config", "{input}"],
    ],
)
@pytest.mark.parametrize("kind", ["a folder", "a FIFO"])
def test_an_input_of_the_wrong_kind_says_what_it_is(tmp_path, capsys, args, kind):
    """A folder or a FIFO given as an input file was reported as "does not exist"."""
    path = tmp_path / "input.yaml"
    if kind == "a folder":
        path.mkdir()
    else:
        os.mkfifo(path)
    err = one_line_error(capsys, *[a.format(input=path) for a in args])
    if not (kind == "a folder" and "highd" in args):  # a highD recording is a folder
        assert f"is {kind}, not a" in err


@pytest.mark.parametrize(
    "args, words",
    [
        (["estimation", "--duration", "0.01"], "duration must be in [1.05, 3600]"),
        (["estimation", "--duration", "1e9"], "duration must be in [1.05, 3600]"),
        (["estimation", "--runs", "20000000"], "runs must be a whole number in [1, 1000000]"),
        (["estimation", "--duration", "nan"], "--duration: must be a finite number, got 'nan'"),
        (["world", "--conditions", "fog=abc"], "fog takes a number, got 'abc'"),
        (["world", "--conditions", "fog=1e-300"], "fog_visibility must be in [10, inf]"),
        (["world", "--conditions", "rain=1e300"], "rain_rate must be in [0, 500]"),
    ],
)
def test_numbers_are_bounded_by_physics(capsys, args, words):
    """A tiny estimation duration divided by zero and a huge one hung; a fog of 1e-300 m
    overflowed, and ``fog=abc`` was echoed as "nan"."""
    assert words in one_line_error(capsys, *args)


def test_the_extreme_weather_accepted_raises_no_numpy_warning(capsys):
    """Fog of 1 mm or rain of 1e30 mm/h printed numpy's RuntimeWarning lines (they are now
    refused); the densest fog and heaviest rain accepted compute without one."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        args = ["world", "--runs", "1", "--scene", "lead_brakes", "--scene", "gantry_crest"]
        assert main([*args, "--conditions", "night+fog=10+rain=500", "fog=1e308"]) == 0
    assert capsys.readouterr().err.count("Warning") == 0


@pytest.fixture
def broken_ring(tmp_path):
    """A copy of the bundled ring network whose .net.xml is replaced by ``text``."""
    pytest.importorskip("libsumo")
    ring = tmp_path / "ring"
    shutil.copytree(bundled_nets()["ring"].parent, ring)

    def broken(text: str) -> Path:
        (ring / "ring.net.xml").write_text(text)
        return ring / "ring.sumocfg"

    return broken


@pytest.mark.parametrize(
    "net, words",
    [
        ('<net version="1.20">\n  <edge id="a"', "SUMO could not load"),
        ('<net><edge id="x"><lane id="x_0" shape="0,0 a"/></edge></net>', "ended abruptly"),
    ],
)
def test_a_worker_process_error_is_the_one_line_it_raised(broken_ring, capfd, net, words):
    """A truncated network's SUMO error came with SUMO's own four lines, twice; a network on
    which libsumo crashes gave a ``BrokenProcessPool`` traceback."""
    cfg = broken_ring(net)
    assert main(["sumo", "--sumocfg", str(cfg), "--end", "5"]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and err.startswith("acc-fusion: error: ") and words in err, err


def test_a_sumo_error_in_a_sweep_has_no_second_traceback(broken_ring, tmp_path, capfd):
    """Every SUMO error in a sweep was followed by an 11-line "Exception in thread"
    traceback from the pool's manager thread."""
    cfg = broken_ring('<net version="1.20">\n  <edge id="a"')
    spec = tmp_path / "sweep.toml"
    spec.write_text(
        f'name = "s"\nsource = "sumo"\nseeds = [0]\nruns = 2\n[sumo]\nsumocfg = "{cfg}"\n'
        "end = 5.0\n"
    )
    assert main(["sweep", str(spec), "--out", str(tmp_path / "out")]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and "SUMO could not load" in err, err


def test_a_damaged_sweep_resumes_recomputing_only_the_damage(tmp_path, capsys):
    """A truncated part was a pyarrow ``ArrowInvalid`` traceback, a truncated sweep.json
    "holds a different sweep"; now one warning line names them, the damaged part is run
    again and the rows are those of the undamaged sweep."""
    pq = pytest.importorskip("pyarrow.parquet")
    spec = tmp_path / "q.toml"
    spec.write_text(
        'name = "q"\nseeds = [0]\nruns = 4\nchunk_runs = 2\n[base]\nscenario = "ccrs"\n'
        'methods = ["radar"]\n[axes]\n"warning.z" = [0.0, 1.0]\n'
    )
    out = tmp_path / "out"
    args = ["sweep", str(spec), "--out", str(out), "--workers", "1"]
    assert main(args) == 0
    before = pq.read_table(out / "runs.parquet")
    part = sorted((out / "parts").glob("*.parquet"))[0]
    part.write_bytes(part.read_bytes()[:100])
    meta = out / "sweep.json"
    meta.write_text(meta.read_text()[:50])
    capsys.readouterr()
    assert main(args) == 0
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and captured.err.startswith("acc-fusion: warning: ")
    assert "sweep.json (not valid JSON: rewritten)" in captured.err
    assert f"parts/{part.name} (unreadable: recomputed)" in captured.err
    assert "ran 1 chunks (2 runs" in captured.out and "3 were already done" in captured.out
    assert pq.read_table(out / "runs.parquet").equals(before)


@pytest.mark.parametrize("args", [["config", "show", "--json"], ["config", "schema"]])
def test_json_output_is_strict_json(capsys, args):
    """``config show --json`` (and the schema) wrote ``Infinity``, which strict JSON readers
    reject; infinities are now the strings "inf" and "-inf", NaN null."""
    assert main(args) == 0

    def refuse(constant):
        raise ValueError(f"not strict JSON: {constant}")

    text = capsys.readouterr().out
    json.loads(text, parse_constant=refuse)
    assert '"inf"' in text
