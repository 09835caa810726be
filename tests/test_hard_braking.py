"""scripts/hard_braking.py: how often SUMO's drivers brake hard, and what the cars' decel
does to it."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("libsumo")

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "hard_braking.py"


def run(*args: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(SCRIPT), *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def rate(*args: str) -> tuple[float, float, float]:
    proc = run("--net", "onramp", "--end", "150", "--warmup", "30", *args)
    assert proc.returncode == 0, proc.stderr
    last = proc.stdout.strip().splitlines()[-1]
    m = re.fullmatch(r"onsets_per_100km=(\S+) share_of_time=(\S+) km=(\S+)", last)
    assert m, last
    return tuple(map(float, m.groups()))


def test_krauss_cars_brake_hard_often_and_a_lower_decel_makes_it_rare():
    """SUMO's default decel of 4.5 m/s² is the Krauss drivers' ordinary braking limit: on the
    on-ramp network (Krauss, SUMO's defaults; the bundled motorway's EIDM drivers brake so
    about never) they brake at 0.35 g or harder tens of times per 100 km; with the cars' decel
    at 3.0 m/s² only emergencies reach it."""
    default, share, km = rate()
    gentle, gentle_share, _ = rate("--car-decel", "3.0")
    assert km > 300 and default > 50 and 0 < share < 0.05
    assert gentle < default / 2 and gentle_share < share


def test_the_onsets_by_distance_add_up_and_crowd_near_the_entry():
    """With ``--by-distance`` the bins add up to the totals, and the first 500 m after SUMO
    inserts its vehicles brake hard more often than the traffic 1-2 km downstream (Krauss
    drivers of the on-ramp network)."""
    proc = run("--net", "onramp", "--end", "150", "--warmup", "30", "--by-distance")
    assert proc.returncode == 0, proc.stderr
    rows = re.findall(r"^  (\S+) m: (\d+) km, (\d+) onsets", proc.stdout, flags=re.M)
    assert [r[0] for r in rows] == ["0-500", "500-1000", "1000-2000", "2000-4000", "4000-inf"]
    total = re.search(r"(\d+) onsets, [0-9.]+ per 100 km, ", proc.stdout)
    assert sum(int(r[2]) for r in rows) == int(total.group(1))
    km = float(proc.stdout.strip().splitlines()[-1].rsplit("km=", 1)[1])
    assert sum(int(r[1]) for r in rows) == pytest.approx(km, abs=len(rows))
    per = {r[0]: int(r[2]) / int(r[1]) for r in rows if int(r[1]) > 0}
    assert per["0-500"] > per["1000-2000"]


def test_bad_input_is_a_one_line_error():
    proc = run("--threshold", "0")
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "hard_braking.py: error: --threshold must be > 0 m/s², got 0"
    ]
