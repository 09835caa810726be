"""``acc-fusion world``: the tables it prints, the rates by cause and the figure it writes,
and its one-line errors."""

import contextlib
import csv
import io
import json

import pytest

from acc_fusion.cli.main import main
from acc_fusion.metrics.summary import CAUSE_COUNTS, CAUSES, FALSE_CLASSES

METHODS = ("radar", "infrared", "centralized", "federated")

# One worker runs the study once (a session fixture: pytest tears a module one down whenever
# another module's tests run between this module's on the worker).
pytestmark = pytest.mark.xdist_group("world_cli")


@pytest.fixture(scope="session")
def written(tmp_path_factory):
    """One run of two scenes under two conditions, with ``--plot`` and ``--out``."""
    out = tmp_path_factory.mktemp("world")
    args = ["world", "--scene", "cut_in", "--scene", "parked_curve", "--runs", "20",
            "--conditions", "day", "fog=25", "--plot", str(out / "causes.png"),
            "--out", str(out)]  # fmt: skip
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(args)
    return code, out, printed.getvalue()


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_it_prints_both_tables_and_writes_every_file(written):
    code, out, printed = written
    assert code == 0
    for title in ("Alerts by scene (judged from truth)",
                  "Nuisance and sensing-false alerts by cause, all scenes"):  # fmt: skip
        assert title in printed
    header = next(line for line in printed.splitlines() if line.startswith("conditions"))
    assert header.split()[3:-1] == list(CAUSES)
    for name in ("world_scenes.csv", "world_causes.csv", "world_cause_rates.csv", "world.json"):
        assert (out / name).stat().st_size > 0
    assert (out / "causes.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    scenes = _rows(out / "world_scenes.csv")
    assert {(r["scene"], r["conditions"]) for r in scenes} == {
        (s, c) for s in ("cut_in", "parked_curve") for c in ("day", "day, fog 25 m")
    }
    summaries = json.loads((out / "world.json").read_text())
    assert set(summaries) == {f"{s} / {c}" for s, c in {(r["scene"], r["conditions"])
                                                         for r in scenes}}  # fmt: skip


def test_the_rates_by_cause_are_the_counts_over_the_distance_with_their_intervals(written):
    _, out, _ = written
    rates = _rows(out / "world_cause_rates.csv")
    assert len(rates) == 2 * len(METHODS) * len(CAUSE_COUNTS)
    counts = {
        (r["conditions"], r["method"], r["class"]): r for r in _rows(out / "world_causes.csv")
    }
    assert len(counts) == 2 * len(METHODS) * len(FALSE_CLASSES)
    for r in rates:
        k, km = int(r["warnings"]), float(r["km"])
        value, lo, hi = (float(r[c]) for c in ("per_100km", "per_100km_lo", "per_100km_hi"))
        assert value == pytest.approx(100.0 * k / km, rel=1e-3)
        assert lo <= value <= hi and hi > 0.0  # an upper bound also where none was counted
        assert k == int(counts[(r["conditions"], r["method"], r["class"])][r["cause"]])
    # The parked car fools the camera; the cut-in every method: both show in the rates.
    seen = {(r["method"], r["cause"]) for r in rates if int(r["warnings"]) > 0}
    assert ("infrared", "stationary") in seen
    assert {("radar", "cut_in_out"), ("infrared", "cut_in_out")} <= seen


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--conditions", "dusk"], "--conditions"),
        (["--conditions", "fog=-3"], "fog_visibility"),
        (["--runs", "0"], "runs"),
    ],
)
def test_bad_input_is_a_one_line_error(args, message, capsys):
    try:
        code = main(["world", "--scene", "cut_in", *args])
    except SystemExit as exit_:  # argparse's own checks exit
        code = exit_.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
