"""A recording read in windows of frames: the base of the format readers.

A recording is read twice, each time streamed (:mod:`~acc_fusion.truth.replay.csvfile`): once
for its frame column only, to count the rows of every frame (:meth:`Recording.windows` then
cuts the frames into windows of at most ``max_rows`` rows), then once per window for the rows
of that window's frames.  With :attr:`Recording.cache` the first read parses every column
into a binary copy, and the reads after it, in this replay and the next, read the copy
(:mod:`~acc_fusion.truth.replay.cache`).  A window is the unit the replay batches: all its
vehicles are packed into the pipeline's slots at once, and no more than one window's rows are
in memory.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.truth.replay import cache, csvfile
from acc_fusion.truth.replay.rows import BOUNDS, ReplayError, Rows

#: Rows of a window by default (about 0.2 GB of arrays).
MAX_ROWS = 2_000_000


class Recording(ABC):
    """One recording of a data set (a highD recording, an NGSIM location, a CSV file).

    Subclasses set ``label`` (its name in the tables), ``dt`` (the frame period [s]),
    ``path`` (the trajectory file), ``numbers`` / ``strings`` / ``where`` (what
    :func:`~acc_fusion.truth.replay.csvfile.stream` reads) and implement :meth:`_frames` and
    :meth:`_rows`.
    """

    label: str
    dt: float
    #: What the data set's headway columns measure: ``"gap"`` (bumper to bumper) or
    #: ``"spacing"`` (front to front, the gap plus the leader's length).
    headway_basis: str = "gap"
    path: Path
    #: The file's column behind each field of :data:`~acc_fusion.truth.replay.rows.BOUNDS`,
    #: and behind the frame index (``"frame"``).
    sources: dict[str, str]
    #: A row outside :data:`~acc_fusion.truth.replay.rows.BOUNDS`: ``"refuse"`` it (a
    #: :class:`ReplayError` naming the file, row and column) or ``"drop"`` it, counted in
    #: :attr:`dropped`.
    bad_rows: str = "refuse"
    dropped: int = 0
    numbers: dict[str, str]
    strings: dict[str, str] | None = None
    where: tuple[str, str] | None = None
    #: Read through the binary copy of :mod:`~acc_fusion.truth.replay.cache` (made on the
    #: first read) instead of parsing the CSV at every read.
    cache: bool = False

    def _stream(self, names: tuple[str, ...] | None = None) -> Iterator[dict[str, np.ndarray]]:
        """The file's batches, of the columns ``names`` at least (default: all of
        :attr:`numbers`); with :attr:`cache`, of all of them, from the file's binary copy."""
        if self.cache:  # one copy of every column serves the frame pass and every window
            yield from cache.stream(self.path, self.numbers, strings=self.strings, where=self.where)
            return
        numbers = self.numbers if names is None else {k: self.numbers[k] for k in names}
        yield from csvfile.stream(self.path, numbers, strings=self.strings, where=self.where)

    @abstractmethod
    def _frames(self, batch: dict[str, np.ndarray]) -> np.ndarray:
        """The integer frame index of every row of ``batch``."""

    @abstractmethod
    def _rows(self, batch: dict[str, np.ndarray], frame: np.ndarray) -> Rows:
        """The rows of ``batch`` (their frames ``frame``) as :class:`Rows`."""

    #: The columns :meth:`_frames` needs.
    frame_columns: tuple[str, ...] = ("frame",)

    def windows(self, max_rows: int = MAX_ROWS) -> list[tuple[int, int, int]]:
        """Frame ranges ``[f0, f1)`` covering every row, each of at most ``max_rows`` rows
        (or one frame, if a single frame has more), with their row counts (computed once)."""
        if getattr(self, "_windows", None) is None or self._windows[0] != max_rows:
            self._windows = (max_rows, self._cut(max_rows))
        return self._windows[1]

    def frame_counts(self) -> np.ndarray:
        """Rows per frame index, from one pass over the frame column (a format whose meta
        data tells it overrides this)."""
        counts = np.zeros(0, dtype=np.int64)
        for batch in self._stream(self.frame_columns):
            frame = self._frames(batch)
            if frame.size and frame.min() < 0:
                raise ConfigError(f"{self.path}: frame indices must be >= 0")
            c = np.bincount(frame, minlength=counts.size)
            c[: counts.size] += counts
            counts = c
        at = np.flatnonzero(counts)
        if at.size == 1 and counts[at[0]] > 1:
            raise ReplayError(
                f"{str(self.path)!r}: all {counts[at[0]]} rows are at one time (frame {at[0]}); "
                f"column {self.sources['frame']!r} must advance with the recording"
            )
        return counts

    def _cut(self, max_rows: int) -> list[tuple[int, int, int]]:
        """The windows of :meth:`windows`; the first starts at frame 0 and the last never
        ends, so that no row is left out whatever the counts say."""
        counts = self.frame_counts()
        cum = np.cumsum(counts)
        bounds, start, base = [], 0, 0
        while start < counts.size:
            end = int(np.searchsorted(cum, base + max_rows, side="right"))
            end = min(max(end, start + 1), counts.size)
            bounds.append((start, end, int(cum[end - 1]) - base))
            base = int(cum[end - 1])
            start = end
        sized = [w for w in bounds if w[2] > 0] or [(0, 1, 0)]
        starts = [0] + [w[0] for w in sized[1:]]
        ends = starts[1:] + [2**62]
        return [(a, b, w[2]) for a, b, w in zip(starts, ends, sized, strict=True)]

    def rows(self, f0: int, f1: int) -> Rows | None:
        """The rows of frames ``[f0, f1)`` (``None`` if there are none)."""
        parts = []
        read = 0  # rows of the file before this batch
        for batch in self._stream():
            frame = self._frames(batch)
            keep = (frame >= f0) & (frame < f1)
            if keep.any():
                part = {k: v[keep] for k, v in batch.items()}
                rows = self._rows(part, frame[keep])
                parts.append(self._physical(rows, read + np.flatnonzero(keep)))
            read += frame.size
        return Rows.concat(parts) if parts else None

    def _physical(self, rows: Rows, index: np.ndarray) -> Rows:
        """``rows`` (at ``index`` among the file's rows) within
        :data:`~acc_fusion.truth.replay.rows.BOUNDS`: a row outside them is refused (one
        :class:`ReplayError` naming the file, the row and the column) or, with
        :attr:`bad_rows` ``"drop"``, dropped and counted in :attr:`dropped`."""
        bad = {
            name: ~((lo <= getattr(rows, name)) & (getattr(rows, name) <= hi))
            for name, (_, lo, hi) in BOUNDS.items()
        }
        out = np.logical_or.reduce(list(bad.values()))
        if not out.any():
            return rows
        if self.bad_rows == "drop":
            self.dropped += int(out.sum())
            return rows.take(~out)
        first = int(np.argmax(out))
        name = next(n for n, b in bad.items() if b[first])
        words, lo, hi = BOUNDS[name]
        of = f" of {self.where[1]}" if self.where else ""
        raise ReplayError(
            f"{str(self.path)!r}, row {int(index[first]) + 1}{of}, column "
            f"{self.sources[name]!r}: {words} {getattr(rows, name)[first]:g} is outside "
            f"[{lo:g}, {hi:g}] (--bad-rows drop skips such rows)"
        )
