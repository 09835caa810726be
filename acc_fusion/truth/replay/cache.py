"""A binary copy of each recording's columns, so that a recording replayed again is read, not
parsed.

Parsing is the dearest part of reading a CSV recording: pyarrow tokenizes every column of
every line (about 1.4 µs a row for highD's 25 columns), and a recording whose format keeps
no frame counts in its meta data (NGSIM, mapped CSV) is parsed once to count its frames and
again for each window.  :func:`stream` parses a file once: as the batches of
:func:`acc_fusion.truth.replay.csvfile.stream` go by, it writes them, the columns the
recording reads and nothing else, to an Arrow IPC file (the Feather format) in the cache
folder (:func:`folder`).  The file is renamed into place only once every batch is written,
so a read that stops half-way (an error, an interrupt) leaves nothing behind; a killed
process's unfinished copy, a hidden temporary file, is removed a day later by the next copy
made there.  Every later read of the same columns memory-maps that file: the same float64
values, without parsing (about 15 ms for a 365 000-row highD recording against 0.2 s).

The copy's name is a hash of what it copies: the file's resolved path, size, modification
and change times, inode and first and last MiB, and the columns, types and row filter read
(with :data:`VERSION`).  A file that changes is parsed again into a new copy; the old copy
stays until the folder is deleted, which is always safe.  Where the folder cannot be written
(read-only, full, no home folder), the replay parses as without a cache and says so once.
The copy takes about the CSV's size on disk; ``ReplayConfig(cache=False)`` (``acc-fusion
replay --no-cache``) reads without it.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pyarrow as pa

from acc_fusion.core.outputs import temporary_beside
from acc_fusion.core.paths import cache_dir
from acc_fusion.truth.replay import csvfile

#: The layout of the copies; a new one makes every old copy unused.
VERSION = 1
#: Bytes read at each end of a file for its name.
_PROBE = 1 << 20
#: Age [s] beyond which an unfinished copy is a killed process's, removed.
STALE = 86400.0
#: The folders where no copy could be written, in this process.
_FAILED: set[str] = set()


def folder() -> Path:
    """The folder of the binary copies: ``$ACC_FUSION_REPLAY_CACHE``, else ``replay/`` of
    :func:`~acc_fusion.core.paths.cache_dir`."""
    own = os.environ.get("ACC_FUSION_REPLAY_CACHE")
    return Path(own) if own else cache_dir() / "replay"


def key(path: Path, numbers: dict[str, str], strings: dict[str, str], where) -> str:
    """The name of ``path``'s copy of these columns and row filter (module docstring)."""
    st = path.stat()
    h = hashlib.sha256()
    facts = [VERSION, str(path.resolve()), st.st_size, st.st_mtime_ns, st.st_ctime_ns,
             st.st_ino, sorted(numbers.items()), sorted(strings.items()), where]  # fmt: skip
    h.update(json.dumps(facts).encode())
    with path.open("rb") as fh:
        h.update(fh.read(_PROBE))
        if st.st_size > _PROBE:
            fh.seek(max(st.st_size - _PROBE, _PROBE))
            h.update(fh.read(_PROBE))
    return h.hexdigest()[:32]


def stream(
    path: Path,
    numbers: dict[str, str],
    *,
    strings: dict[str, str] | None = None,
    where: tuple[str, str] | None = None,
) -> Iterator[dict[str, np.ndarray]]:
    """The batches of :func:`acc_fusion.truth.replay.csvfile.stream` (same arguments, same
    values), from the file's binary copy where there is one, else parsed and copied on the
    way (module docstring)."""
    strings = strings or {}
    try:
        target = folder() / f"{key(path, numbers, strings, where)}.arrow"
    except (OSError, RuntimeError) as exc:  # no home folder, an unreadable file
        _failed("the cache folder", exc)
        target = None
    if target is None or str(target.parent) in _FAILED:
        yield from csvfile.stream(path, numbers, strings=strings, where=where)
        return
    try:
        reader = pa.ipc.open_file(pa.memory_map(str(target)))
    except (OSError, pa.ArrowInvalid):
        reader = None
    if reader is not None:
        for i in range(reader.num_record_batches):
            batch = reader.get_batch(i)
            out = {name: batch.column(name).to_numpy() for name in numbers}
            for name in strings:
                out[name] = np.asarray(batch.column(name).to_pylist(), dtype=object)
            yield out
        return
    yield from _copied(path, target, numbers, strings, where)


def _copied(path, target, numbers, strings, where) -> Iterator[dict[str, np.ndarray]]:
    """Parse ``path`` and write each batch to ``target`` on the way, renamed into place once
    the last is written; the batches without a copy (one warning) where the copy cannot be
    written."""
    schema = pa.schema([(n, pa.float64()) for n in numbers] + [(n, pa.string()) for n in strings])
    sink = tmp = writer = None
    try:
        _sweep(target.parent)
        fd, tmp = temporary_beside(target, ".arrow")
        sink = os.fdopen(fd, "wb")
        writer = pa.ipc.new_file(sink, schema)
    except OSError as exc:
        _failed(target.parent, exc)
        writer = None
    done = False
    try:
        for out in csvfile.stream(path, numbers, strings=strings, where=where):
            if writer is not None:
                columns = [pa.array(out[n], pa.float64()) for n in numbers]
                columns += [pa.array(out[n].tolist(), pa.string()) for n in strings]
                try:
                    writer.write_batch(pa.record_batch(columns, schema=schema))
                except OSError as exc:
                    _failed(target.parent, exc)
                    writer = None
            yield out
        if writer is not None:
            try:
                writer.close()
                sink.close()
                os.replace(tmp, target)
                done = True
            except OSError as exc:
                _failed(target.parent, exc)
    finally:
        if not done:
            if sink is not None:
                sink.close()
            if tmp is not None:
                Path(tmp).unlink(missing_ok=True)


def _failed(where, exc: BaseException) -> None:
    """Parse without copies in ``where`` from now on, and say so once per process."""
    if str(where) not in _FAILED:
        _FAILED.add(str(where))
        why = getattr(exc, "strerror", None) or exc
        warnings.warn(f"recordings are parsed at every replay: no binary copy can be kept in "
                      f"{where} ({why})", RuntimeWarning, stacklevel=4)  # fmt: skip


def _sweep(where: Path) -> None:
    """Remove the unfinished copies that a killed process left in ``where`` a day ago or
    more (an unfinished copy is a hidden temporary file; a replay writing one now is
    younger)."""
    if not where.is_dir():
        return
    for old in where.glob(".*.arrow"):
        try:
            if time.time() - old.stat().st_mtime > STALE:
                old.unlink()
        except OSError:
            pass
