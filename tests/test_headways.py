"""scripts/headways.py: the car-following headways of a bundled network against the published
distribution it was calibrated to."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("libsumo")

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "headways.py"


def run(*args: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(SCRIPT), *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def test_the_motorway_headways_are_near_the_reference(tmp_path):
    proc = run("--end", "200", "--warmup", "120", "--plot", str(tmp_path / "hw.png"))
    assert proc.returncode == 0, proc.stderr
    last = proc.stdout.strip().splitlines()[-1]
    m = re.fullmatch(r"median_s=(\S+) share_below_1s=(\S+) share_below_2s=(\S+)", last)
    assert m, last
    median, below1, below2 = map(float, m.groups())
    # Calibrated over 300 s to 1.72 s and 63 % (King et al. 2022: 1.74 s, 58.3 %); with
    # every driver at SUMO's default tau 1 s it was 1.35 s, 77 % and 1 % under 1 s.
    assert 1.55 < median < 1.9 and 0.5 < below2 < 0.72 and below1 > 0.04
    assert (tmp_path / "hw.png").stat().st_size > 10_000


def test_a_warmup_past_the_end_is_a_one_line_error():
    proc = run("--end", "10", "--warmup", "20")
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "headways.py: error: --warmup must be in [0, --end), got 20"
    ]
