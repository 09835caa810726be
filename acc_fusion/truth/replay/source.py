r"""Recorded traffic as a truth source: :class:`ReplaySource` replays the pairs of highD,
NGSIM or mapped CSV recordings through the FCW pipeline.

Open loop only
    A recorded driver cannot react to a warning: the source replays what was recorded, and
    :func:`~acc_fusion.sim.closed_loop.simulate` refuses to close the loop on it
    (``accepts_brakes = False``).  The figures are false alarms and alert classes on human
    driving, not collisions avoided.

Batching: slots play tracks back to back
    The pairs of a recording are independent in open loop, so the source does not replay the
    recording's clock, where only the 50 to 100 vehicles in view at a time would be
    batched.  It groups the windows of the recordings
    (:mod:`~acc_fusion.truth.replay.recording`) into *batches* of at most ``max_rows`` rows
    (:func:`batches`: short recordings play together), cuts each batch into *segments* (one
    vehicle's consecutive frames) and packs them into the slots, longest first, each into the
    slot that frees first (the LPT rule of Graham, *Bounds on multiprocessing timing
    anomalies*, SIAM J. Appl. Math. 17, 1969).  The number of slots N is chosen once, from
    the first batch (:func:`best_slots`, at most ``slots``).  While a batch plays, a thread
    reads and pairs the next (pyarrow parses without holding the GIL).  A slot plays its
    segments one after the other; each new segment is a new vehicle in that slot
    (:attr:`reassigned`, so every stage starts afresh), every step advances all slots by one
    frame of the data (``dt`` = the recording's frame period).  The frame's ``t`` is the
    replay's clock, not the recording's.  A vehicle crossing a window's end continues as a new
    segment in the next window (its filters re-initialise); windows hold millions of rows,
    so this touches a few vehicles per window.

Each slot's truth at a step is its row's :class:`~acc_fusion.truth.replay.pairs.Pairs` entry:
ego speed and acceleration, and, where the ego has a leader, the gap, the leader's speed,
acceleration and id, and the lateral offset.
"""

from __future__ import annotations

import heapq
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from tqdm.auto import tqdm

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_choice
from acc_fusion.truth.frame import SlotSource, TruthFrame
from acc_fusion.truth.replay import BAD_ROWS, FORMATS
from acc_fusion.truth.replay.crosscheck import CrossCheck
from acc_fusion.truth.replay.generic import CsvMapping, CsvRecording
from acc_fusion.truth.replay.highd import highd_recordings
from acc_fusion.truth.replay.ngsim import ngsim_recordings
from acc_fusion.truth.replay.pairs import Pairs, build_pairs
from acc_fusion.truth.replay.recording import MAX_ROWS, Recording


@dataclass(frozen=True)
class ReplayConfig:
    """What to replay and how.

    Attributes:
        format: ``highd``, ``ngsim`` or ``csv``.
        path: highD: the folder of the ``NN_*.csv`` files (or one ``NN_tracks.csv``); NGSIM
            and csv: the trajectory file.
        recordings: highD: the recording numbers (default: all in the folder); NGSIM: the
            values of the ``Location`` column to replay, one recording each (default: the
            whole file as one); csv: unused.
        mapping: csv: the TOML/YAML file of the column mapping
            (:class:`~acc_fusion.truth.replay.generic.CsvMapping`; default: its defaults).
        recompute_leaders: recompute the leaders from lanes and positions even where the
            file names them.
        slots: pairs replayed at once (the batch width N).
        max_rows: rows of a window (what is in memory at once).
        bad_rows: a row outside the physical bounds
            (:data:`~acc_fusion.truth.replay.rows.BOUNDS`): ``"refuse"`` the recording (one
            error naming the file, row and column) or ``"drop"`` the row, counted in the
            exposure table's notes.
        cache: read each CSV recording through its binary copy
            (:mod:`~acc_fusion.truth.replay.cache`), made at its first replay: a recording
            replayed again is read, not parsed.
    """

    format: str
    path: str
    recordings: tuple[str, ...] = ()
    mapping: str | None = None
    recompute_leaders: bool = False
    slots: int = 2048
    max_rows: int = MAX_ROWS
    bad_rows: str = "refuse"
    cache: bool = True

    def __post_init__(self) -> None:
        check_choice("format", self.format, FORMATS)
        check_choice("bad_rows", self.bad_rows, BAD_ROWS)
        if not isinstance(self.cache, bool):
            raise ConfigError(f"cache must be true or false, got {self.cache!r}")
        if not 1 <= self.slots <= 1_000_000:
            raise ConfigError(f"slots must be in [1, 1000000], got {self.slots}")
        if self.max_rows < 1:
            raise ConfigError(f"max_rows must be >= 1, got {self.max_rows}")
        object.__setattr__(self, "recordings", tuple(str(r) for r in self.recordings))

    def open(self) -> list[Recording]:
        """The recordings to replay (their files checked and their headers read)."""
        if self.format == "highd":
            numbers = []
            for r in self.recordings:
                if not r.isdigit():
                    raise ConfigError(f"a highD recording is a number, got {r!r}")
                numbers.append(int(r))
            recs: list[Recording] = list(highd_recordings(self.path, numbers))
        elif self.format == "ngsim":
            recs = list(ngsim_recordings(self.path, list(self.recordings)))
        else:
            recs = [CsvRecording(self.path, CsvMapping.load(self.mapping))]
        for r in recs:
            r.bad_rows, r.cache = self.bad_rows, self.cache
        rates = {round(1.0 / r.dt, 6) for r in recs}
        if len(rates) > 1:
            raise ConfigError(
                f"the recordings have different frame rates ({', '.join(map(str, rates))} Hz); "
                "replay them separately"
            )
        return recs


@dataclass
class RecordingStats:
    """What was replayed of one recording.

    Attributes:
        label: the recording's name.
        leaders: ``"file"`` (the data set's leader column) or ``"recomputed"``.
        hours, km: driving replayed (every vehicle, with or without a leader).
        vehicles: vehicles (a vehicle in two windows counts twice).
        pairs: distinct follower→leader pairs.
        pair_steps: rows with a leader.
        duplicates: rows dropped for repeating a (frame, vehicle).
        dropped: rows dropped for a value outside the physical bounds (``bad_rows="drop"``).
        agree, either: rows whose file and recomputed leaders agree, of those with a leader
            in either (only with a leader column).
        crosscheck: the cross-check and headway distribution.
    """

    label: str
    leaders: str
    hours: float = 0.0
    km: float = 0.0
    vehicles: int = 0
    pairs: int = 0
    pair_steps: int = 0
    duplicates: int = 0
    dropped: int = 0
    agree: int = 0
    either: int = 0
    crosscheck: CrossCheck = field(default_factory=CrossCheck)


#: The cost of one pipeline step in slot-steps (its fixed part: about 0.6 ms of Python and
#: kernel launches against about 1.2 µs per slot, measured with ``scripts/bench_replay.py``).
STEP_COST_SLOTS = 500


def segment_lengths(start: np.ndarray) -> np.ndarray:
    """The lengths of the segments of a track-ordered window (``start``: a segment begins)."""
    return np.diff(np.append(np.flatnonzero(start), start.size))


def schedule(length: np.ndarray, slots: int) -> tuple[np.ndarray, np.ndarray, int]:
    """LPT: each segment, longest first, into the slot that frees first.  Returns each
    segment's first step and slot, and the steps of the whole (the makespan)."""
    heap = [(0, j) for j in range(slots)]
    at = np.empty(length.size, dtype=np.int64)
    slot = np.empty(length.size, dtype=np.int64)
    for i in np.argsort(-length, kind="stable"):
        load, j = heapq.heappop(heap)
        at[i], slot[i] = load, j
        heapq.heappush(heap, (load + int(length[i]), j))
    return at, slot, int((at + length).max()) if length.size else 0


def best_slots(length: np.ndarray, rows: int, most: int) -> int:
    """The slot count (at most ``most``) that plays ``rows`` rows of segments like
    ``length`` at the least cost, ``steps * (STEP_COST_SLOTS + slots)``: enough slots that
    the longest segment sets the steps, not so many that idle slots cost more."""
    base = rows / max(int(length.max()), 1)
    candidates = {min(most, max(1, math.ceil(base * f))) for f in (1.0, 1.25, 1.5, 2.0, 3.0)}
    cost = {n: schedule(length, n)[2] * (STEP_COST_SLOTS + n) for n in sorted(candidates)}
    return min(cost, key=cost.get)


def pack(start: np.ndarray, slots: int) -> tuple[np.ndarray, np.ndarray]:
    """Pack the segments of a track-ordered window (``start``: a segment begins at that row)
    into ``slots`` (:func:`schedule`): the row index each slot plays at each step,
    ``(T, slots)`` with -1 where idle, and where a segment begins, ``(T, slots)`` bool."""
    first = np.flatnonzero(start)
    length = segment_lengths(start)
    at, slot, steps = schedule(length, slots)
    index = np.full((steps, slots), -1, dtype=np.int64)
    begins = np.zeros((steps, slots), dtype=bool)
    within = np.arange(start.size) - np.repeat(first, length)
    index[np.repeat(at, length) + within, np.repeat(slot, length)] = np.arange(start.size)
    begins[at, slot] = True
    return index, begins


class ReplaySource(SlotSource):
    """The recordings of ``config`` replayed as ``config.slots`` slots (see the module
    docstring); the interface :func:`~acc_fusion.sim.closed_loop.simulate` drives.

    Attributes:
        stats: per recording label, its :class:`RecordingStats` (complete when :attr:`done`).
    """

    accepts_brakes = False

    def __init__(self, config: ReplayConfig, *, progress: bool = False) -> None:
        self.config = config
        recordings = config.open()
        self.dt = recordings[0].dt
        self.stats = {
            r.label: RecordingStats(r.label, "file", crosscheck=CrossCheck(r.headway_basis))
            for r in recordings
        }
        self._plan = batches(recordings, config.max_rows)
        sizes = [sum(m for *_, m in batch) for batch in self._plan]
        #: An upper bound of the steps: every step plays at least one row.
        self.n_steps = sum(sizes)
        self._t = 0.0
        self._k = 0
        self._done = False
        self._bar = tqdm(
            total=len(self._plan), unit="batch", desc="replay", disable=None if progress else True
        )
        self._reader = ThreadPoolExecutor(max_workers=1, thread_name_prefix="replay-reader")
        self._next = 0
        self._ahead = self._read_ahead()
        first = self._ahead.result() if self._ahead is not None else []
        if not first:
            self.close()
            raise ConfigError(f"{config.path}: the recording holds no rows")
        # The batch width for the largest batch, judged on the first one's segments.
        lengths = segment_lengths(first[0][1].start)
        self.n_pairs = best_slots(lengths, max(sizes), config.slots)
        self._collided = np.zeros(self.n_pairs, dtype=bool)
        self._collision_speed = np.full(self.n_pairs, np.nan)
        self._load()

    @property
    def t(self) -> float:
        return self._t

    @property
    def done(self) -> bool:
        return self._done

    def close(self) -> None:
        self._bar.close()
        self._reader.shutdown(wait=True, cancel_futures=True)

    def _read_ahead(self):
        """Start reading and pairing the next batch of windows in the reader thread
        (``None`` after the last)."""
        if self._next >= len(self._plan):
            return None
        batch = self._plan[self._next]
        self._next += 1
        return self._reader.submit(self._prepare, batch)

    def _prepare(self, batch: list[tuple[Recording, int, int, int]]) -> list[tuple]:
        """Read and pair the windows of ``batch`` (in the reader thread): ``(recording,
        pairs)`` for each window that has rows."""
        out = []
        for rec, f0, f1, _ in batch:
            rows = rec.rows(f0, f1)
            if rows is not None:
                recompute = self.config.recompute_leaders or rows.leader is None
                out.append((rec, build_pairs(rows, recompute=recompute)))
        return out

    def _load(self) -> bool:
        """Take the next batch with rows (read while the last one played), count it and
        pack its windows together; ``False`` after the last one."""
        while self._ahead is not None:
            ready = self._ahead.result()
            self._ahead = self._read_ahead()
            self._bar.update(1)
            if not ready:
                continue
            for rec, pairs in ready:
                stats = self.stats[rec.label]
                named = pairs.either and not self.config.recompute_leaders
                stats.leaders = "file" if named else "recomputed"
                self._account(stats, pairs, rec.dt)
                stats.dropped = rec.dropped
            self._pairs = Pairs.concat([p for _, p in ready] + [_idle_row()])
            idle = len(self._pairs) - 1
            self._index, self._begins = pack(self._pairs.start[:idle], self.n_pairs)
            self._index[self._index < 0] = idle
            self._k = 0
            self._set_frame()
            return True
        return False

    @staticmethod
    def _account(stats: RecordingStats, p: Pairs, dt: float) -> None:
        has = p.has_leader
        stats.hours += len(p) * dt / 3600.0
        stats.km += float(np.maximum(p.ego_speed, 0.0).sum()) * dt / 1000.0
        stats.vehicles += int(np.unique(p.vid).size)
        key = p.vid[has] * (int(p.leader_id.max()) + 1) + p.leader_id[has]
        stats.pairs += int(np.unique(key).size)
        stats.pair_steps += int(has.sum())
        stats.duplicates += p.duplicates
        stats.agree += p.agree
        stats.either += p.either
        stats.crosscheck.add(p)

    def _set_frame(self) -> None:
        """The frame of step ``_k`` of the current window."""
        rows = self._index[self._k]
        p = self._pairs
        self._active = rows < len(p.vid) - 1
        self._reassigned = self._begins[self._k].copy()
        self._frame = TruthFrame.from_arrays(
            self._t,
            p.ego_speed[rows],
            p.ego_accel[rows],
            p.gap[rows],
            p.lead_speed[rows],
            p.lead_accel[rows],
            p.leader_id[rows],
            p.lateral_offset[rows],
        )

    def advance(self, ego_brake: np.ndarray | None = None) -> TruthFrame:
        """The next step (the next window's first, after a window's last)."""
        self._t += self.dt
        self._k += 1
        if self._k < self._index.shape[0]:
            self._set_frame()
        elif not self._load():
            self._done = True
            self._bar.close()
            self._index = np.full((1, self.n_pairs), len(self._pairs.vid) - 1)
            self._begins = np.zeros((1, self.n_pairs), dtype=bool)
            self._k = 0
            self._set_frame()
        return self._frame


def _idle_row() -> Pairs:
    """The row an idle slot plays: no leader, standing still."""
    idle = {"vid": -1, "start": True, "ego_speed": 0.0, "ego_accel": 0.0, "leader_id": -1,
            "lateral_offset": 0.0}  # fmt: skip
    return Pairs(*(np.array([idle.get(a, np.nan)]) for a in Pairs.ARRAYS))


def batches(recordings: list[Recording], max_rows: int) -> list[list[tuple]]:
    """The windows of ``recordings`` (``(recording, f0, f1, rows)``) in batches of at most
    ``max_rows`` rows (a window of more is a batch of its own): several short recordings
    play together, in one wide batch."""
    out: list[list[tuple]] = []
    size = max_rows + 1
    for rec in recordings:
        for f0, f1, rows in rec.windows(max_rows):
            if size + rows > max_rows:
                out.append([])
                size = 0
            out[-1].append((rec, f0, f1, rows))
            size += rows
    return out
