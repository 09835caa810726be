"""A mkdocs hook: every equation of the site rendered to MathML when the site is built.

The Markdown pages and the docstrings (through ``rst_roles.py``) write TeX, which the
``pymdownx.arithmatex`` extension keeps out of Markdown's hands as
``<span class="arithmatex">\\(…\\)</span>`` and ``<div class="arithmatex">\\[…\\]</div>``
(``\\(\\displaystyle …\\)`` is a display equation too). This hook replaces each with the
MathML that ``latex2mathml`` makes of it. Browsers lay out MathML themselves (MathML Core:
Chromium, Firefox, Safari), so the site needs no script, no font download and no network to
show its equations, and an equation that cannot be converted fails the build instead of
showing raw TeX to the reader.
"""

from __future__ import annotations

import html
import re

from latex2mathml.converter import convert
from mkdocs.exceptions import PluginError

_MATH = re.compile(
    r'<(?P<tag>span|div) class="arithmatex">\s*'
    r"(?:\\\((?P<inline>.*?)\\\)|\\\[(?P<display>.*?)\\\])\s*</(?P=tag)>",
    re.S,
)

# How the docstrings' display equations start (see rst_roles.py): rendered as blocks.
_DISPLAY = "\\displaystyle"

# TeX that latex2mathml renders badly (a relation it nests in another <mo>), spelt plainly.
_MATHREL = re.compile(r"\\mathrel\{([^{}]*)\}")


def to_mathml(tex: str, display: bool) -> str:
    """The MathML of one TeX formula (``display``: a block equation)."""
    mathml = convert(_MATHREL.sub(r"\1", tex).strip(), display="block" if display else "inline")
    unknown = re.search(r">(\\[a-zA-Z]+)<", mathml)  # latex2mathml prints what it does not know
    if unknown:
        raise ValueError(f"latex2mathml does not know {unknown.group(1)}")
    return mathml


def on_page_content(html_text: str, page, **kwargs) -> str:
    def replace(m: re.Match) -> str:
        tex = html.unescape(m.group("display") or m.group("inline"))
        display = m.group("display") is not None or tex.lstrip().startswith(_DISPLAY)
        try:
            return to_mathml(tex, display)
        except Exception as exc:
            raise PluginError(f"{page.file.src_uri}: cannot render the TeX {tex!r}: {exc}") from exc

    return _MATH.sub(replace, html_text)
