"""A small result table shared by the studies, the sweeps and the command line."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field


@dataclass
class Table:
    """A small result table: a title, column names and rows (dicts keyed by column)."""

    title: str
    columns: Sequence[str]
    rows: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def row(self, value: object, column: str | None = None) -> dict:
        """The first row whose ``column`` (default: the first column) equals ``value``."""
        col = column or self.columns[0]
        return next(r for r in self.rows if r[col] == value)

    def format(self) -> str:
        """The table as aligned plain text (a table without rows keeps its header).

        >>> print(Table("t", ("a", "bb")).format())
        t
        a  bb
        -  --
        """

        def cell(v: object) -> str:
            if isinstance(v, float):
                return f"{v:.4g}"
            return str(v)

        body = [[cell(r.get(c, "")) for c in self.columns] for r in self.rows]
        widths = [max([len(c), *(len(b[i]) for b in body)]) for i, c in enumerate(self.columns)]
        lines = [
            self.title,
            "  ".join(c.ljust(w) for c, w in zip(self.columns, widths, strict=True)),
        ]
        lines.append("  ".join("-" * w for w in widths))
        lines += ["  ".join(v.ljust(w) for v, w in zip(b, widths, strict=True)) for b in body]
        return "\n".join(lines + self.notes)
