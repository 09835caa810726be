"""What a path is, in words, and the check of an input file: so that a folder or a FIFO given
where a file is read is reported as what it is, not as missing; and where the project keeps
what it computes once and reuses (:func:`cache_dir`)."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from acc_fusion.core.errors import AccFusionError, ConfigError


def path_kind(path: Path) -> str:
    """What ``path`` is, in words: ``"a folder"``, ``"a FIFO"``, ``"a file"``…, or
    ``"missing"``; for a message about a path of the wrong kind."""
    try:
        mode = path.stat().st_mode
    except OSError:
        return "missing"
    kinds = (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISREG, "a file"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
    )
    return next((word for test, word in kinds if test(mode)), "a special file")


def existing_file(path: str | Path, what: str, error: type[AccFusionError] = ConfigError) -> Path:
    """``path`` as a :class:`Path` if it is a regular file, else one ``error`` naming ``what``
    and saying what the path is instead (missing, a folder, a FIFO...)."""
    p = Path(path)
    kind = path_kind(p)
    if kind == "missing":
        raise error(f"{what} {str(p)!r} does not exist")
    if kind != "a file":
        raise error(f"{what} {str(p)!r} is {kind}, not a file")
    return p


def cache_dir() -> Path:
    """The project's cache folder: ``$ACC_FUSION_CACHE``, else ``$XDG_CACHE_HOME/acc_fusion``,
    else ``~/.cache/acc_fusion`` (the compiled SUMO reader, the replay's binary copies of
    recordings)."""
    if os.environ.get("ACC_FUSION_CACHE"):
        return Path(os.environ["ACC_FUSION_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "acc_fusion"
