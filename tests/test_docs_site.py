"""The documentation site as a reader gets it: built once (strict), then every page read.

Every equation must have become MathML (no raw TeX left for the reader, no empty equation, no
matrix whose rows lost their cells), every link inside the site must reach a page and the
anchor it names, nothing a page shows may come from the network (the site works offline),
and every repository path a page names must exist in the repository.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

# One worker builds the site once (session fixtures: pytest tears module ones down whenever
# another module's tests run between them on the worker).
pytestmark = pytest.mark.xdist_group("docs")

ROOT = Path(__file__).resolve().parents[1]
# The path of the site's root on its server, from mkdocs.yml's site_url.
_BASE = urlsplit(
    re.search(r"^site_url:\s*(\S+)", (ROOT / "mkdocs.yml").read_text(), re.M).group(1)
).path

# A path into the repository as the pages name them: `acc_fusion/fusion/fdi.py`, `scripts/x.py`.
_REPO_PATH = re.compile(
    r"(?<![\w./-])((?:acc_fusion|scripts|tests|examples|docs|sumo_nets|envs|shared)"
    r"/[\w./-]*[\w/])"
)
_GYM_ID = r"acc_fusion/\w+-v\d+"  # acc_fusion/CollisionWarning-v0 is no path
# TeX a reader should never see: a control word, or the \( \[ delimiters.
_RAW_TEX = re.compile(r"\\(?:[a-zA-Z]{2,}|[()\[\]])")
# The docstrings' reST a reader should never see: a role, a simple table's rule.
_RAW_REST = re.compile(r":(?:class|func|meth|mod|attr|data|exc|math):`|={4,} +={4,}")


class _Page(HTMLParser):
    """Collects a page's ids, links, prose text, and its equations' structure."""

    _SKIP = {"code", "pre", "script", "style"}

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.ids: set[str] = set()
        self.links: list[str] = []
        self.loads: list[str] = []  # what the browser fetches to show the page
        self.text: list[str] = []  # prose, outside code and equations
        self.code: list[str] = []  # code spans and blocks
        self.maths: list[str] = []  # the text of each <math>
        self.tables: list[list[int]] = []  # per <mtable>: cells in each row
        self._skip = 0
        self._math = 0

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "a" and a.get("href"):
            self.links.append(a["href"])
        if tag in ("script", "img", "iframe") and a.get("src"):
            self.loads.append(a["src"])
        if tag == "link" and a.get("rel") not in ("canonical", "alternate") and a.get("href"):
            self.loads.append(a["href"])
        if tag in self._SKIP:
            self._skip += 1
        if tag == "math":
            self._math += 1
            self.maths.append("")
        elif tag == "mtable":
            self.tables.append([])
        elif tag == "mtr":
            self.tables[-1].append(0)
        elif tag == "mtd":
            self.tables[-1][-1] += 1

    def handle_endtag(self, tag):
        if tag in self._SKIP:
            self._skip -= 1
        if tag == "math":
            self._math -= 1

    def handle_data(self, data):
        if self._math:
            self.maths[-1] += data
        elif self._skip:
            self.code.append(data)
        else:
            self.text.append(data)


@pytest.fixture(scope="session")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, DISABLE_MKDOCS_2_WARNING="true", NO_MKDOCS_2_WARNING="1")
    mkdocs = [sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "-d", str(out)]
    run = subprocess.run(mkdocs, cwd=ROOT, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return out


@pytest.fixture(scope="session")
def pages(site) -> dict[Path, _Page]:
    parsed = {}
    for path in sorted(site.rglob("*.html")):
        page = _Page()
        page.feed(path.read_text(encoding="utf-8"))
        parsed[path] = page
    return parsed


def _where(site: Path, path: Path) -> str:
    return path.relative_to(site).as_posix()


def test_every_equation_and_docstring_is_rendered(site, pages):
    problems = []
    for path, page in pages.items():
        prose = " ".join(page.text)
        for m in (*_RAW_TEX.finditer(prose), *_RAW_REST.finditer(prose)):
            problems.append(f"{_where(site, path)}: raw {prose[m.start() : m.end() + 40]!r}")
        problems += [
            f"{_where(site, path)}: an empty equation" for t in page.maths if not t.strip()
        ]
        problems += [
            f"{_where(site, path)}: a matrix with rows of {rows} cells"
            for rows in page.tables
            if not rows or len(set(rows)) > 1
        ]
        if "arithmatex" in path.read_text(encoding="utf-8"):
            problems.append(f"{_where(site, path)}: an equation left to a script")
    assert not problems, "\n".join(problems)
    assert sum(len(p.maths) for p in pages.values()) > 500  # the docstrings' maths is there


def test_every_internal_link_reaches_its_page_and_anchor(site, pages):
    dead = []
    for path, page in pages.items():
        for href in page.links:
            url = urlsplit(href)
            if url.scheme or url.netloc or href.startswith("mailto:"):
                continue
            if url.path.startswith("/"):  # absolute, under the site_url (the 404 page)
                target = (site / unquote(url.path).removeprefix(_BASE)).resolve()
            else:
                target = (path.parent / unquote(url.path)).resolve() if url.path else path
            if target.is_dir():
                target = target / "index.html"
            if site.resolve() not in target.parents and target != site.resolve():
                dead.append(f"{_where(site, path)}: {href} leaves the site")
            elif target not in pages and not target.exists():
                dead.append(f"{_where(site, path)}: {href} has no page")
            elif url.fragment and target in pages and url.fragment not in pages[target].ids:
                dead.append(f"{_where(site, path)}: {href} has no anchor #{url.fragment}")
    assert not dead, "\n".join(dead)


def test_nothing_is_loaded_from_the_network(site, pages):
    remote = [
        f"{_where(site, path)}: {url}"
        for path, page in pages.items()
        for url in page.loads
        if urlsplit(url).scheme or url.startswith("//")
    ]
    assert not remote, "\n".join(sorted(set(remote)))


def test_every_repository_path_named_exists(site, pages):
    missing = []
    for path, page in pages.items():
        if _where(site, path) == "benchmarks/index.html":
            continue  # written by `make bench`, whose issue owns the page
        for chunk in page.text + page.code:
            for m in _REPO_PATH.finditer(chunk):
                name = m.group(1).split("::")[0].rstrip("./")
                if not re.fullmatch(_GYM_ID, name) and not (ROOT / name).exists():
                    missing.append(f"{_where(site, path)}: {name}")
    assert not missing, "\n".join(sorted(set(missing)))


def test_the_group_holds(request):
    """Under ``make test`` (``--dist loadgroup``) this module's tests run on one worker: xdist
    marks their ids with the group (a pytest that xdist cannot group, pytest-dev/pytest-xdist
    #1386, fails here instead of building the site once per worker)."""
    if not getattr(request.config.option, "loadgroup", False):
        pytest.skip("not run with --dist loadgroup")
    assert request.node.nodeid.endswith("@docs")
