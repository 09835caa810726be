"""The README is a short manual whose examples run as written and whose command table is whole."""

from __future__ import annotations

import re
from pathlib import Path

from acc_fusion.cli.main import COMMANDS

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


def test_readme_is_a_short_manual():
    assert README.count("\n") <= 200


def test_readme_examples_run(capsys):
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert len(blocks) >= 2  # the estimation example and the environment example
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out
    rmse = float(re.search(r"gap RMSE after 10 s: ([0-9.]+) m", out).group(1))
    assert rmse < 0.25
    assert re.search(r"return -?[0-9.]+, collided: (True|False)", out)


def test_readme_lists_every_command():
    for name in COMMANDS:
        assert f"`acc-fusion {name}" in README, name


def test_readme_links_resolve():
    root = Path(__file__).resolve().parents[1]
    for target in re.findall(r"\]\(([^)#]+)\)", README):
        if "://" not in target:
            assert (root / target).exists(), target
