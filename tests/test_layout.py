"""The package's shape: subpackages by pipeline stage, no import cycles, no hidden imports.

The layers contract itself (a stage imports only the stages below it) is checked by
``lint-imports`` in ``make test`` (``[tool.importlinter]`` in pyproject.toml); these tests check
what the contract cannot: cycles inside a stage, and imports hidden inside functions.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "acc_fusion"
STAGES = (
    "core",
    "truth",
    "sensors",
    "filters",
    "fusion",
    "warning",
    "metrics",
    "braking",
    "sim",
    "studies",
    "envs",
    "sweep",
    "cli",
)
#: A module longer than this must say why in its docstring (a set of numba kernels that must
#: stay together).
MAX_LINES = 500
KERNEL_SET = "numba kernels that must stay together"


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "sumo_nets" not in p.parts)


def test_every_module_lives_in_a_stage():
    loose = [p.name for p in PACKAGE.glob("*.py") if p.name != "__init__.py"]
    assert loose == []
    subpackages = sorted(
        p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()
    )
    assert sorted(STAGES + ("sumo_nets",)) == subpackages


def test_no_acc_fusion_import_inside_a_function():
    """Function-local imports of the package hide cycles; only the root's lazy ``evaluate``
    (so that a low stage, as SUMO's child process, does not import the pipeline) may."""
    found = []
    for path in _modules():
        if path == PACKAGE / "__init__.py":
            continue
        functions = [
            n
            for n in ast.walk(ast.parse(path.read_text()))
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
        ]
        for node in (n for f in functions for n in ast.walk(f)):
            names = []
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            if any(n.startswith("acc_fusion") for n in names):
                found.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}")
    assert found == []


def test_no_import_cycles():
    grimp = pytest.importorskip("grimp")
    graph = grimp.build_graph("acc_fusion", exclude_type_checking_imports=True)
    modules = sorted(graph.modules)
    edges = {m: sorted(graph.find_modules_directly_imported_by(m)) for m in modules}
    # Tarjan's strongly connected components: any component of two or more modules is a cycle.
    index, low, stack, on_stack, cycles, counter = {}, {}, [], set(), [], [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for m in modules:
        if m not in index:
            visit(m)
    # The root package registers the env and lazily exposes evaluate: it is not a cycle member.
    assert [c for c in cycles if c != ["acc_fusion"]] == []


def test_long_modules_say_why():
    long = []
    for path in _modules():
        text = path.read_text()
        n = text.count("\n")
        doc = ast.get_docstring(ast.parse(text)) or ""
        if n > MAX_LINES and KERNEL_SET not in " ".join(doc.split()):
            long.append(str(path.relative_to(PACKAGE.parent)))
    assert long == []
