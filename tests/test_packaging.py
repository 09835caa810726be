"""Every module, envs/ and sumo_nets/ are part of the installed package, not only of the
checkout."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest


@pytest.mark.slow
def test_wheel_contains_every_module_envs_and_sumo_nets(tmp_path):
    root = Path(__file__).resolve().parents[1]
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            str(root),
            "--no-deps",
            "-w",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    (wheel,) = tmp_path.glob("acc_fusion-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "acc_fusion/envs/__init__.py" in names
    assert "acc_fusion/sumo_nets/README.md" in names
    modules = {
        p.relative_to(root).as_posix()
        for p in (root / "acc_fusion").rglob("*.py")
        if "__pycache__" not in p.parts
    }
    assert modules - names == set()


def test_installed_package_resources():
    from importlib.resources import files

    import acc_fusion.envs  # noqa: F401

    assert files("acc_fusion.sumo_nets").joinpath("README.md").is_file()
