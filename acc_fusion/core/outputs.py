"""Writing results: output folders checked up front, every file written atomically.

A file is written to a temporary name in the same folder, flushed to disk (fsync) and
renamed into place, so a run that is interrupted (even by ``kill -9`` or a power loss) leaves
either the previous file or the complete new one, never half of one.
"""

from __future__ import annotations

import csv
import io
import json
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

from acc_fusion.core.errors import AccFusionError


def output_dir(path: str | Path) -> Path:
    """Create ``path`` if needed and check that it is a writable folder (else a clear error)."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AccFusionError(f"cannot create output folder {str(p)!r}: {exc.strerror}") from None
    if not p.is_dir() or not os.access(p, os.W_OK | os.X_OK):
        raise AccFusionError(f"output folder {str(p)!r} is not a writable folder")
    return p


def file_mode() -> int:
    """The mode a new file gets from ``open()``: 0o666 less the process's umask."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def temporary_beside(path: Path, suffix: str = ".tmp") -> tuple[int, str]:
    """A temporary file in ``path``'s folder (for an atomic rename onto ``path``) with the mode
    a plain ``open()`` would give, not :func:`tempfile.mkstemp`'s 0600."""
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


def write_json_atomic(path: str | Path, data: object) -> Path:
    """Write ``data`` as indented JSON atomically."""
    return write_text_atomic(path, json.dumps(data, indent=2, default=float) + "\n")


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
    output_dir(p.parent)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return write_bytes_atomic(p, buf.getvalue())
