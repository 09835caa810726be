"""Writing results: output folders and files checked up front, every file written atomically.

The commands check every path they will write (:func:`check_output_dir`,
:func:`check_output_file`) when their arguments are parsed, leaving nothing behind, so an
output that cannot be written is a one-line error before any work, and a run never ends with
only some of its files written for want of a folder; the folders are made as the files are
written.

A file is written to a temporary name in the same folder, flushed to disk (fsync) and
renamed into place, so a run that is interrupted (even by ``kill -9`` or a power loss) leaves
either the previous file or the complete new one, never half of one.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

from acc_fusion.core.errors import AccFusionError
from acc_fusion.core.paths import path_kind


def check_output_dir(path: str | Path) -> Path:
    """Check, before any work, that ``path`` is a folder files can be written into, or one that
    can be created: the missing folders are made, a probe file is written into the last, and
    all of it is removed again, so a check that fails (or a command that fails later) leaves
    nothing behind.  One :class:`AccFusionError` naming the folder if not."""
    p = Path(path)
    missing = []
    first = p
    while path_kind(first) == "missing" and first != first.parent:
        missing.append(first)
        first = first.parent
    kind = path_kind(first)
    if kind != "a folder":
        what = "is" if first == p else f"cannot be created: {str(first)!r} is"
        raise AccFusionError(f"output folder {str(p)!r} {what} {kind}, not a folder")
    made = []
    try:
        for folder in reversed(missing):
            folder.mkdir()
            made.append(folder)
        with tempfile.TemporaryFile(dir=p):
            pass
    except OSError as exc:
        doing = "write into" if len(made) == len(missing) else "create"
        raise AccFusionError(f"cannot {doing} output folder {str(p)!r}: {exc.strerror}") from None
    finally:
        for folder in reversed(made):
            folder.rmdir()
    return p


def check_output_file(path: str | Path) -> Path:
    """Check, before any work and leaving nothing behind, that a file can be written at
    ``path``: its folder passes :func:`check_output_dir` and ``path`` is not a folder, FIFO or
    device."""
    p = Path(path)
    kind = path_kind(p)
    if kind not in ("missing", "a file"):
        raise AccFusionError(f"output file {str(p)!r} is {kind}, not a file")
    check_output_dir(p.parent)
    return p


def output_dir(path: str | Path) -> Path:
    """Create the folder ``path`` (and its parents) after :func:`check_output_dir`."""
    p = check_output_dir(path)
    p.mkdir(parents=True, exist_ok=True)
    return p


def file_mode() -> int:
    """The mode a new file gets from ``open()``: 0o666 less the process's umask."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def temporary_beside(path: Path, suffix: str = ".tmp") -> tuple[int, str]:
    """A temporary file in ``path``'s folder (for an atomic rename onto ``path``; the folder is
    created if missing) with the mode a plain ``open()`` would give, not
    :func:`tempfile.mkstemp`'s 0600."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
    os.fchmod(fd, file_mode())
    return fd, tmp


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (temporary file + fsync + rename); the file's mode
    respects the umask."""
    p = Path(path)
    fd, tmp = temporary_beside(p)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return p


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return write_bytes_atomic(path, text.encode())


def json_text(data: object) -> str:
    """``data`` as indented strict JSON, which has no NaN or infinity: ``inf`` and ``-inf``
    become the strings ``"inf"`` and ``"-inf"``, NaN becomes ``null`` (Python's ``json``
    would write ``Infinity`` and ``NaN``, which strict readers reject); numpy numbers as
    numbers."""
    return json.dumps(_strict(data), indent=2, default=float, allow_nan=False)


def _strict(x: object) -> object:
    if isinstance(x, dict):
        return {k: _strict(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_strict(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):  # numpy floats are floats too
        return None if math.isnan(x) else ("inf" if x > 0 else "-inf")
    return x


def write_json_atomic(path: str | Path, data: object) -> Path:
    """Write ``data`` as indented strict JSON (:func:`json_text`) atomically."""
    return write_text_atomic(path, json_text(data) + "\n")


def write_csv_atomic(path: str | Path, columns: Sequence[str], rows: Sequence[dict]) -> Path:
    """Write rows (dicts keyed by ``columns``) as CSV atomically."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(columns), extrasaction="ignore")
    writer.writeheader()
    writer.writerows(rows)
    return write_text_atomic(path, buf.getvalue())


def save_figure_atomic(fig, path: str | Path, dpi: int = 120) -> Path:
    """Save a matplotlib figure as PNG atomically (creating its folder) and close it."""
    import matplotlib.pyplot as plt

    p = Path(path)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return write_bytes_atomic(p, buf.getvalue())
