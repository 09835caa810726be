"""Property-based tests of bad input (issue 50): Hypothesis draws command lines, config values,
spec files and recorded rows, and every command, run in-process on a tiny workload, must end
with exit code 0 or 2, at most one line on standard error (``acc-fusion: error: …`` or
``acc-fusion: warning: …``; numpy's RuntimeWarnings are errors), and no file written outside
its ``--out``.

The draws are derandomized (the same examples on every run) and bounded, so the tests take
seconds; the values mix the valid, the borderline and the absurd, and the valid workloads are
the smallest each command runs (one run of one or two seconds)."""

from __future__ import annotations

import contextlib
import io
import math
import os
import tempfile
import warnings
from pathlib import Path

import pytest
import yaml

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from acc_fusion.cli.main import main  # noqa: E402


def fuzz(examples: int) -> settings:
    """Hypothesis settings: ``examples`` examples, the same on every run, no deadline (the
    machine may be busy)."""
    return settings(
        max_examples=examples,
        derandomize=True,
        database=None,
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


#: Config keys: real ones of every kind (numbers, names, lists, tables, faults) and wrong ones.
KEYS = (
    "runs", "seed", "dt", "duration", "scenario", "methods", "drive", "tolerance",
    "radar.range_std", "radar.rate_hz", "infrared.max_range", "warning.z", "warning.model",
    "fusion.reset", "fusion.filter.jerk_std", "radar_faults", "infrared_faults",
    "driver.reaction_time_range", "world.conditions.fog_visibility", "world.conditions.light",
    "world.sensors.radar_faults", "nosuch", "radar.nosuch", "warning",
)  # fmt: skip
SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["radar", "federated", "bias", "zero", "ttc", "day", "night", "ccrs", ""]),
    st.text(max_size=8),
)
FAULTS = st.lists(
    st.dictionaries(
        st.sampled_from(["kind", "start", "end", "magnitude", "probability", "bogus"]),
        st.one_of(st.sampled_from(["bias", "dropout", "spikes", "stuck"]), SCALARS),
        max_size=4,
    ),
    max_size=2,
)
VALUES = st.one_of(
    SCALARS,
    FAULTS,
    st.lists(SCALARS, max_size=3),
    st.dictionaries(st.sampled_from(["z", "model", "kind", "x"]), SCALARS, max_size=2),
)
#: Numbers as a user types them: valid, borderline, out of range, not numbers.
NUMBERS = st.sampled_from(["0", "1", "2", "-1", "1.2", "1e9", "nan", "inf", "x", "", "2e7"])


@contextlib.contextmanager
def inside(folder: str):
    """Work in ``folder`` (``contextlib.chdir`` needs Python 3.11)."""
    before = os.getcwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(before)


def run(args: list[str], inputs: dict[str, str | bytes] | None = None) -> None:
    """Run ``acc-fusion args`` in a fresh folder holding ``inputs``; check the exit code, the
    standard error and that nothing was written outside ``out/``."""
    with tempfile.TemporaryDirectory() as tmp, inside(tmp):
        for name, data in (inputs or {}).items():
            path = Path(name)
            if isinstance(data, bytes):
                path.write_bytes(data)
            else:
                path.write_text(data)
        before = set(Path(".").rglob("*"))
        err = io.StringIO()
        with (
            contextlib.redirect_stdout(io.StringIO()),
            contextlib.redirect_stderr(err),
            warnings.catch_warnings(),
        ):
            warnings.simplefilter("error", RuntimeWarning)  # numpy's would be lines on stderr
            code = main(args)
        lines = err.getvalue().splitlines()
        assert code in (0, 2), (args, code, err.getvalue())
        assert len(lines) <= 1, (args, err.getvalue())
        if lines:
            assert lines[0].startswith(("acc-fusion: error: ", "acc-fusion: warning: "))
        new = set(Path(".").rglob("*")) - before
        outside = [p for p in new if p.parts[0] != "out"]
        assert outside == [], (args, outside)


def as_yaml(value: object) -> str:
    """``value`` as one YAML flow value (what ``--set KEY=VALUE`` reads)."""
    return yaml.safe_dump(value, default_flow_style=True, width=math.inf).strip()


@fuzz(60)
@given(st.lists(st.tuples(st.sampled_from(KEYS), VALUES), min_size=1, max_size=3))
def test_config_values(pairs):
    run(["config", "show", *(f"--set={k}={as_yaml(v)}" for k, v in pairs)])


@fuzz(60)
@given(
    st.sampled_from([".yaml", ".toml", ".yml", ".json"]),
    st.one_of(
        st.dictionaries(st.sampled_from(KEYS), VALUES, max_size=4).map(as_yaml),
        st.text(max_size=60),
        st.binary(max_size=60),
        st.sampled_from(["a: [1, 2\n", "a = [1,\n", "runs = 3\n[warning]\nz = 1e400\n", "- 1\n"]),
    ),
)
def test_spec_files(suffix, text):
    run(["config", "show", "--config", f"cfg{suffix}"], {f"cfg{suffix}": text})


@fuzz(25)
@given(
    st.one_of(
        st.tuples(
            st.just("estimation"), st.just("--runs"), NUMBERS, st.just("--duration"), NUMBERS
        ),
        st.tuples(
            st.just("run"),
            st.just("--scenario"),
            st.sampled_from(["ccrs", "nope", ""]),
            st.just("--runs"),
            NUMBERS,
            st.just("--set"),
            st.sampled_from(["duration=1", "duration=-1", "dt=0", "x"]),
        ),
        st.tuples(
            st.just("world"),
            st.just("--runs"),
            NUMBERS,
            st.just("--scene"),
            st.just("lead_brakes"),
            st.just("--set"),
            st.just("duration=1"),
            st.just("--conditions"),
            st.sampled_from(["day", "fog=abc", "fog=5", "rain=600", "night+fog=30", "x=1"]),
        ),
    ),  # fmt: skip
    st.sampled_from(["out", "out/deep/er", "cfg.yaml", "cfg.yaml/x"]),
)
def test_command_lines(args, out):
    """Numbers, names and outputs as a user may type them; ``cfg.yaml`` is a file, so an
    ``--out`` there or below it cannot be written."""
    run([*args, "--out", out], {"cfg.yaml": "runs: 1\n"})


ROWS = [  # t, id, s, y, v, a, length: two vehicles, one behind the other, for three steps
    [0.0, 1, 50.0, 1.75, 20.0, 0.0, 4.5],
    [0.0, 2, 20.0, 1.75, 22.0, 0.0, 4.5],
    [0.1, 1, 52.0, 1.75, 20.0, 0.0, 4.5],
    [0.1, 2, 22.2, 1.75, 22.0, 0.0, 4.5],
    [0.2, 1, 54.0, 1.75, 20.0, 0.0, 4.5],
    [0.2, 2, 24.4, 1.75, 22.0, 0.0, 4.5],
]


@fuzz(15)
@given(
    st.lists(
        st.tuples(
            st.integers(0, len(ROWS) - 1),
            st.integers(0, 6),
            st.one_of(
                st.floats(allow_nan=True, allow_infinity=True).map(repr),
                st.sampled_from(["", "x", "1e400", "-0", "3.5", "1e6"]),
            ),
        ),
        max_size=3,
    ),
    st.sampled_from(["refuse", "drop"]),
)
def test_recorded_rows(edits, bad_rows):
    rows = [[repr(v) for v in row] for row in ROWS]
    for row, column, value in edits:
        rows[row][column] = value
    data = "t,id,s,y,v,a,length\n" + "".join(",".join(r) + "\n" for r in rows)
    mapping = 'frame_rate = 10.0\nlateral = "y"\nlane_width = 3.5\n'
    args = ["replay", "--format", "csv", "--path", "t.csv", "--mapping", "m.toml"]
    run([*args, "--bad-rows", bad_rows, "--out", "out"], {"t.csv": data, "m.toml": mapping})


def test_the_checks_can_fail():
    """``run`` is not empty: a file written beside ``out/`` fails it."""
    with pytest.raises(AssertionError):
        run(["config", "schema", "--out", "schema.json"])
