"""A mkdocs hook: the citation keys of the text (kong2011, hu2005, …) linked to their entries
on the references page.

The keys are the anchors ``<a id="key"></a>`` of ``docs/references.md``, so a key is linked
wherever the pages or the docstrings name it, in prose, never inside code, a link or a heading.
"""

from __future__ import annotations

import re
from pathlib import Path

REFERENCES = Path(__file__).resolve().parents[1] / "references.md"
KEYS = re.findall(r'<a id="([\w-]+)"></a>', REFERENCES.read_text(encoding="utf-8"))
_KEY = re.compile(r"(?<![\w/#-])(" + "|".join(map(re.escape, KEYS)) + r")(?![\w-])")
_TAG = re.compile(r"(<[^>]*>)")
_SKIP = re.compile(r"<(/?)(a|code|pre|h[1-6]|script|style|math)\b")


def on_page_content(html: str, page, **kwargs) -> str:
    if page.file.src_uri == "references.md":
        return html
    up = "../" * page.url.count("/")
    depth, out = 0, []
    for part in _TAG.split(html):
        tag = _SKIP.match(part) if part.startswith("<") else None
        if tag:
            depth += -1 if tag.group(1) else 1
        elif not part.startswith("<") and depth == 0:
            part = _KEY.sub(rf'<a href="{up}references/#\1">\1</a>', part)
        out.append(part)
    return "".join(out)
