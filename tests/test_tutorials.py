"""Every tutorial of the docs site runs as written, and prints what its page shows.

A page's ``python`` blocks run in one namespace, its ``bash`` blocks line by line in a shell
(with this interpreter's ``python`` and ``acc-fusion`` first on the PATH), all in a fresh
folder beside a link to the repository's ``scripts/``. Each ``text`` block is the output
the block before it prints: every line shown (``…`` stands for lines left out) must be printed,
with any numbers in its place, so a page goes stale when a table gains or loses a column or a
row, not when a figure moves.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = ROOT / "docs" / "tutorials"
PAGES = sorted(p.name for p in TUTORIALS.glob("*.md") if p.name != "index.md")
# What each page needs beyond the base install.
NEEDS = {"train-a-policy.md": "stable_baselines3"}

_BLOCK = re.compile(r"^```(\w+)\n(.*?)^```", re.S | re.M)
_NUMBER = re.compile(r"-?(?:\d+(?:\.\d*)?|\.\d+)(?:e[+-]?\d+)?%?|\bnan\b")


def shape(line: str) -> str:
    """A line with its numbers replaced and its spacing collapsed."""
    return " ".join(_NUMBER.sub("#", line).split())


def run_bash(code: str, cwd: Path) -> str:
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    out = []
    for line in code.splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            proc = subprocess.run(
                line, shell=True, cwd=cwd, env=env, capture_output=True, text=True, timeout=300
            )
            assert proc.returncode == 0, f"{line}\n{proc.stderr[-3000:]}"
            out.append(proc.stdout)
    return "".join(out)


def test_every_tutorial_is_listed_on_the_index():
    index = (TUTORIALS / "index.md").read_text()
    assert PAGES and all(f"({page})" in index for page in PAGES)


@pytest.mark.parametrize("page", PAGES)
def test_tutorial_runs_and_prints_what_its_page_shows(page, tmp_path, monkeypatch):
    if page in NEEDS and importlib.util.find_spec(NEEDS[page]) is None:
        pytest.skip(f"needs {NEEDS[page]}")
    (tmp_path / "scripts").symlink_to(ROOT / "scripts")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__tutorial__"}
    printed, checked = "", 0
    for kind, body in _BLOCK.findall((TUTORIALS / page).read_text()):
        if kind == "python":
            buffer = io.StringIO()
            with contextlib.redirect_stdout(buffer):
                exec(compile(body, page, "exec"), namespace)
            printed = buffer.getvalue()
        elif kind == "bash":
            printed = run_bash(body, tmp_path)
        elif kind == "text":
            shapes = {shape(line) for line in printed.splitlines()}
            for line in body.splitlines():
                if line.strip() and line.strip() != "…":
                    assert shape(line) in shapes, f"{page}: not printed: {line!r}\n{printed}"
            checked += 1
    assert checked, f"{page} shows no output to check"
