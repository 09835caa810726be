"""Streaming a large CSV file in record batches (pyarrow), only the columns asked for.

A file is never read whole: :func:`stream` yields one batch (about ``block_size`` bytes of the
file) at a time as numpy arrays.  Column names match without regard to case (NGSIM's exports
spell ``v_Length`` and ``v_length``).  A bad file ends in one :class:`ReplayError` sentence
that names the file, the line and the column: a missing file or column is found before any
row is read; a malformed row (too few or too many fields, a value that is not a number, an
empty value) is located, on that error path only, by rereading the file line by line with
:mod:`csv` up to the first bad line.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pcsv

from acc_fusion.core.paths import existing_file
from acc_fusion.truth.replay.rows import ReplayError

#: Bytes of the file per batch (pyarrow's block size).
BLOCK_SIZE = 1 << 24


def existing(path: str | Path, what: str) -> Path:
    """``path`` as a :class:`Path`, or a :class:`ReplayError` naming ``what`` if it is missing
    or not a regular file."""
    return existing_file(path, what, ReplayError)


def header(path: Path) -> list[str]:
    """The column names on the first line of ``path``."""
    with path.open(newline="", encoding="utf-8", errors="replace") as fh:
        first = next(csv.reader(fh), None)
    if not first:
        raise ReplayError(f"{path}, line 1: the file is empty (a header line is needed)")
    return [name.strip() for name in first]


def resolve(path: Path, wanted: Sequence[str], optional: Sequence[str] = ()) -> dict[str, str]:
    """Map each wanted column name to the file's spelling (case-insensitive).

    Raises:
        ReplayError: a name of ``wanted`` is not on the header line (``optional`` ones may be
            missing: they are left out of the map).
    """
    names = header(path)
    lower = {n.lower(): n for n in names}
    out = {}
    for name in (*wanted, *optional):
        actual = lower.get(name.lower())
        if actual is None and name in wanted:
            raise ReplayError(
                f"{path}, line 1: no column {name!r} (the header has {', '.join(names)})"
            )
        if actual is not None:
            out[name] = actual
    return out


def stream(
    path: Path,
    numbers: dict[str, str],
    *,
    strings: dict[str, str] | None = None,
    where: tuple[str, str] | None = None,
    block_size: int = BLOCK_SIZE,
) -> Iterator[dict[str, np.ndarray]]:
    """Yield the file's rows batch by batch: ``{name: float64 array}`` for ``numbers`` and
    ``{name: str array}`` for ``strings`` (both map our name to the file's column).

    ``where = (name, value)``: only the rows whose string column ``name`` equals ``value``.

    Raises:
        ReplayError: a malformed row (see the module docstring), naming file, line and column.
    """
    strings = strings or {}
    types = {col: pa.float64() for col in numbers.values()} | {
        col: pa.string() for col in strings.values()
    }
    options = pcsv.ConvertOptions(column_types=types, include_columns=list(types))
    try:
        reader = pcsv.open_csv(
            path, read_options=pcsv.ReadOptions(block_size=block_size), convert_options=options
        )
        for batch in reader:
            if where is not None:
                batch = batch.filter(pc.equal(batch.column(strings[where[0]]), where[1]))
            out = {}
            for name, col in numbers.items():
                array = batch.column(col)
                values = array.to_numpy(zero_copy_only=False)
                if array.null_count or not np.isfinite(values).all():
                    raise _located(path, numbers)
                out[name] = values
            for name, col in strings.items():
                out[name] = np.asarray(batch.column(col).to_pylist(), dtype=object)
            yield out
    except pa.ArrowInvalid as exc:
        raise _located(path, numbers, str(exc)) from None


def _located(path: Path, numbers: dict[str, str], message: str = "") -> ReplayError:
    """The :class:`ReplayError` of the first malformed line of ``path`` (rereading it with
    :mod:`csv`); pyarrow's ``message`` if no line is found."""
    with path.open(newline="", encoding="utf-8", errors="replace") as fh:
        rows = csv.reader(fh)
        names = [n.strip() for n in next(rows)]
        index = {col: names.index(col) for col in numbers.values()}
        for line, row in enumerate(rows, start=2):
            if not row:
                continue
            if len(row) != len(names):
                return ReplayError(
                    f"{path}, line {line}: {len(row)} fields, the header has {len(names)}"
                )
            for col, i in index.items():
                text = row[i].strip()
                if not text:
                    return ReplayError(f"{path}, line {line}, column {col!r}: empty value")
                try:
                    value = float(text)
                except ValueError:
                    return ReplayError(
                        f"{path}, line {line}, column {col!r}: {text!r} is not a number"
                    )
                if not math.isfinite(value):
                    return ReplayError(
                        f"{path}, line {line}, column {col!r}: {text!r} is not finite"
                    )
    return ReplayError(f"{path}: cannot be read as CSV ({message.splitlines()[0]})")
