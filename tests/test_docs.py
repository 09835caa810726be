"""The documentation's code stays true to the code: every import in a docs page's Python blocks
resolves (the pages are not run whole: some start SUMO for minutes)."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
IMPORT = re.compile(r"^from (acc_fusion[\w.]*) import ([\w, ]+)$", flags=re.M)


def _imports() -> list[tuple[str, str, str]]:
    found = []
    for page in sorted(DOCS.rglob("*.md")):
        for block in re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S):
            for module, names in IMPORT.findall(block):
                for name in names.split(","):
                    found.append((page.name, module, name.strip()))
    return found


@pytest.mark.parametrize("page, module, name", _imports())
def test_docs_imports_resolve(page, module, name):
    assert hasattr(importlib.import_module(module), name), f"{page}: {module}.{name}"
