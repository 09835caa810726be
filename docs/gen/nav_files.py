"""A mkdocs hook: the literate-nav files (``SUMMARY.md``, the generated ones included) give the
navigation and are not pages of their own."""

from __future__ import annotations

from mkdocs.structure.files import InclusionLevel


def on_files(files, **kwargs):
    for file in files:
        if file.src_uri.endswith("SUMMARY.md"):
            file.inclusion = InclusionLevel.EXCLUDED
    return files
