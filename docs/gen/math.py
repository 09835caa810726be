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


# MathML Core (what Chromium renders) ignores mathvariant but "normal": bold, bold italic and
# script letters are Unicode's mathematical alphanumerics instead. Per variant, the code
# points of A, a, 0, Alpha and alpha, and the letters Unicode placed elsewhere.
_ALPHANUMERICS = {
    "bold": (0x1D400, 0x1D41A, 0x1D7CE, 0x1D6A8, 0x1D6C2, {}),
    "bold-italic": (0x1D468, 0x1D482, None, 0x1D71C, 0x1D736, {}),
    "script": (
        0x1D49C,
        0x1D4B6,
        None,
        None,
        None,
        dict(zip("BEFHILMRego", "ℬℰℱℋℐℒℳℛℯℊℴ", strict=True)),
    ),
}
_VARIANT = re.compile(r'<mi mathvariant="(bold|bold-italic|script)">([^<]*)</mi>')


def _alphanumeric(variant: str, char: str) -> str:
    upper, lower, digit, greek_upper, greek_lower, moved = _ALPHANUMERICS[variant]
    for first, last, base in (
        ("A", "Z", upper),
        ("a", "z", lower),
        ("0", "9", digit),
        ("Α", "Ω", greek_upper),
        ("α", "ω", greek_lower),
    ):
        if base is not None and first <= char <= last:
            return moved.get(char, chr(base + ord(char) - ord(first)))
    return char


def _variants(mathml: str) -> str:
    return _VARIANT.sub(
        lambda m: (
            "<mi>"
            + "".join(_alphanumeric(m.group(1), c) for c in html.unescape(m.group(2)))
            + "</mi>"
        ),
        mathml,
    )


def to_mathml(tex: str, display: bool) -> str:
    """The MathML of one TeX formula (``display``: a block equation)."""
    tex = _MATHREL.sub(r"\1", tex).strip()
    mathml = _variants(convert(tex, display="block" if display else "inline"))
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
