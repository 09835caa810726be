"""The ring of shared memory through which SUMO's background process streams its reads to the
pipeline's process: the frame layout (:func:`_frame_bytes`, :func:`_objects_bytes`), the ring
(:class:`_FrameRing`), the child's writer and per-step snapshots, with the packing kernels
(numba), and the child's outbox of messages on the socket (:class:`_Outbox`)."""

from __future__ import annotations

import mmap
import os
import pickle
import select
import struct
import tempfile
from collections import deque
from itertools import islice
from multiprocessing.connection import Connection
from operator import attrgetter

import numpy as np
from numba import njit

from acc_fusion.truth.sumo.config import SumoError
from acc_fusion.truth.sumo.object_arrays import OBJECT_FLOATS, ObjectArrays
from acc_fusion.truth.sumo.objects import SumoObjects
from acc_fusion.truth.sumo.source import SumoSource

#: Buffers per ``writev`` (POSIX guarantees at least 16).
_IOV_MAX = 16


#: Bytes of messages the child may hold for the parent beyond the socket's buffer before it
#: waits (the frames' arrays travel in the ring; this is the rest of them).
OUTBOX_LIMIT = 16 << 20
#: Frame messages the child writes to the socket at a time (see :class:`_Outbox`).
OUTBOX_BATCH = 8
#: The slot flags of a frame message, in order (empty: False).
_FLAG_ROWS = ("active", "reassigned", "collided", "inattentive")


def _objects_bytes(k: int, m: int, j: int = 0) -> int:
    """Bytes of the object arrays of ``k`` egos with ``m`` object slots and ``j`` map-path
    stations each (:class:`~acc_fusion.truth.sumo.object_arrays.ObjectArrays`, written after
    a frame's arrays): the float fields, object ids and lanes (8 bytes an entry), the lead
    slots, yaw rates, curvatures and shifts (8 bytes an ego), the map paths (8 bytes a
    station), then the kinds (1 byte an entry), rounded up to 8."""
    return 8 * ((len(OBJECT_FLOATS) + 2) * k * m + (4 + j) * k) + -(-(k * m) // 8) * 8


def _frame_bytes(k: int, m: int) -> int:
    """Bytes of a frame's arrays: the collision speeds and the four flags of the slots cut
    after ``k``, and the speeds, leader distances and leader codes of its ``m`` vehicles,
    rounded up to 8 so every frame starts aligned."""
    return -(-((8 + len(_FLAG_ROWS)) * k + 24 * m) // 8) * 8


class _FrameRing:
    """Frames' arrays in memory shared by the child (writing) and the parent (reading).

    A frame takes :func:`_frame_bytes` bytes at a *position* that only grows; it lies at
    ``position % size`` in the memory, and a frame that would cross the end starts at the
    beginning instead.  The child may write up to ``size`` bytes past what the parent has
    returned: the parent returns the room behind the frames it has copied (an ``("ack",
    position)`` message, each time an eighth of the ring has been read; with object frames
    the room behind the frame it reads, whose objects it copies when asked), and the child
    waits for it only when the ring is full.  The memory is a file descriptor passed to
    the child (``memfd``, else an unlinked temporary file), mapped with its pages in place
    so the processes' memory stays flat as the ring fills.
    """

    def __init__(self, fd: int, size: int) -> None:
        flags = mmap.MAP_SHARED | getattr(mmap, "MAP_POPULATE", 0)
        self.size = size
        self._memory = mmap.mmap(fd, size, flags=flags)
        memory = np.frombuffer(self._memory, np.uint8)  # size: a multiple of 8
        self._views = (memory.view(np.float64), memory.view(np.int64), memory.view(np.bool_))
        self._kinds = memory.view(np.int8)

    @staticmethod
    def create(size: int) -> int:
        """A new shared file descriptor of ``size`` bytes (inheritable by ``pass_fds``)."""
        if hasattr(os, "memfd_create"):
            fd = os.memfd_create("acc_fusion_frames")
        else:
            fd, path = tempfile.mkstemp(prefix="acc_fusion_frames_")
            os.unlink(path)
        os.ftruncate(fd, size)
        return fd

    def place(self, position: int, nbytes: int) -> int:
        """Where a frame of ``nbytes`` written after ``position`` starts."""
        offset = position % self.size
        return position if offset + nbytes <= self.size else position + self.size - offset

    def write(self, position: int, frame: tuple[np.ndarray, ...], k: int, m: int) -> None:
        """Write a frame's arrays (the arguments of :func:`_pack` after ``m``: its first ``k``
        slots, its ``m`` vehicles) at ``position``."""
        _pack(*self._views, position % self.size, k, m, *frame)

    def read(self, position: int, k: int, m: int, n: int) -> tuple[np.ndarray, ...]:
        """A copy of the frame of ``k`` slots and ``m`` vehicles written at ``position``: the
        ``(n,)`` collision speeds (NaN beyond ``k``), the ``(m,)`` speeds, leader distances
        and leader codes, and the ``(4, n)`` flags (False beyond ``k``)."""
        return _unpack(*self._views, position % self.size, k, m, n)

    def write_objects(self, position: int, arrays: ObjectArrays) -> None:
        """Write an object frame's arrays at ``position`` (:func:`_objects_bytes`)."""
        views = self._object_views(position, *arrays.object_id.shape, arrays.path.shape[1])
        for room, values in zip(views, arrays, strict=True):
            room[...] = values

    def read_objects(self, position: int, k: int, m: int, n: int, j: int = 0) -> ObjectArrays:
        """A copy of the object arrays of ``k`` egos, ``m`` object slots and ``j`` map-path
        stations written at ``position``, for the first ``n`` egos (those after ``k`` empty:
        :meth:`~acc_fusion.truth.sumo.object_arrays.ObjectArrays.resized`)."""
        return self._object_views(position, k, m, j).resized(n)

    def _object_views(self, position: int, k: int, m: int, j: int) -> ObjectArrays:
        """Views of the ring's memory holding the object arrays at ``position``, in the
        order of :func:`_objects_bytes`."""
        floats, ints = self._views[:2]
        at, km, nf = (position % self.size) // 8, k * m, len(OBJECT_FLOATS)
        rows = floats[at : at + nf * km].reshape(nf, k, m)
        at += nf * km
        object_id, lane = (ints[at + i * km : at + (i + 1) * km].reshape(k, m) for i in (0, 1))
        at += 2 * km
        lead, yaw_rate, curvature, shift = (
            ints[at : at + k],
            *(floats[at + i * k : at + (i + 1) * k] for i in (1, 2, 3)),
        )
        at += 4 * k
        path = floats[at : at + k * j].reshape(k, j)
        at += k * j
        kind = self._kinds[8 * at : 8 * at + km].reshape(k, m)
        return ObjectArrays(rows, object_id, kind, lane, lead, yaw_rate, curvature, shift, path)


@njit(cache=True)
def _pack(
    floats, ints, flags, offset, k, m, collision_speed, speed, dists, codes, active, reassigned,
    collided, inattentive,
):  # pragma: no cover - compiled  # fmt: skip
    """Write a frame at byte ``offset`` (a multiple of 8) of the ring, whose memory
    ``floats``, ``ints`` and ``flags`` view as float64, int64 and bool, each row after the
    other (:func:`_frame_bytes`): the first ``k`` slots' ``collision_speed``, the ``m``
    vehicles' ``speed``, ``dists`` and ``codes``
    (:meth:`acc_fusion.truth.sumo.source.SumoSource._fill`),
    then the first ``k`` slots' flags ``active``, ``reassigned``, ``collided`` and
    ``inattentive & active`` (:data:`_FLAG_ROWS`)."""
    at = offset // 8
    floats[at : at + k] = collision_speed[:k]
    floats[at + k : at + k + m] = speed
    floats[at + k + m : at + k + 2 * m] = dists
    ints[at + k + 2 * m : at + k + 3 * m] = codes
    at = 8 * (at + k + 3 * m)
    flags[at : at + k] = active[:k]
    flags[at + k : at + 2 * k] = reassigned[:k]
    flags[at + 2 * k : at + 3 * k] = collided[:k]
    flags[at + 3 * k : at + 4 * k] = inattentive[:k] & active[:k]


@njit(cache=True)
def _unpack(floats, ints, flags, offset, k, m, n):  # pragma: no cover - compiled
    """The arrays of a frame that :func:`_pack` wrote at ``offset``, copied out of the ring:
    the ``(n,)`` collision speeds (NaN beyond ``k``), the ``(m,)`` speeds, leader distances
    and leader codes, and the ``(4, n)`` flags (False beyond ``k``)."""
    collision_speed = np.full(n, np.nan)
    slot_flags = np.zeros((4, n), dtype=np.bool_)
    at = offset // 8
    collision_speed[:k] = floats[at : at + k]
    speed = floats[at + k : at + k + m].copy()
    dists = floats[at + k + m : at + k + 2 * m].copy()
    codes = ints[at + k + 2 * m : at + k + 3 * m].copy()
    at = 8 * (at + k + 3 * m)
    for row in range(4):
        slot_flags[row, :k] = flags[at : at + k]
        at += k
    return collision_speed, speed, dists, codes, slot_flags


class _RingWriter:
    """The child's side of a :class:`_FrameRing`: where the next frame goes, waiting for the
    parent to return room only when the ring is full (after sending it everything queued,
    which it needs to catch up)."""

    def __init__(self, ring: _FrameRing, conn: Connection, outbox: _Outbox) -> None:
        self._ring, self._conn, self._outbox = ring, conn, outbox
        self._head = self._returned = 0

    def write(
        self, frame: tuple[np.ndarray, ...], k: int, m: int, objects: ObjectArrays | None = None
    ) -> int:
        """Write a frame's arrays (:meth:`_FrameRing.write`: ``k`` slots, ``m`` vehicles),
        followed by its ``objects`` if any (:meth:`_FrameRing.write_objects`); returns its
        position.

        A frame may take a quarter of the ring at most.  The parent returns room an eighth of
        the ring at a time and, with object frames, holds the room of the frame it reads
        until the next; a frame that does not fit before the ring's end starts at its
        beginning.  So the child may find less than an eighth not yet returned, the held
        frame and the padding before a wrap (each under a quarter) in its way: with its
        own quarter, under seven eighths of the ring, it always fits once the parent has
        read every frame before it.

        Raises:
            SumoError: the frame takes more than a quarter of the ring.
        """
        nbytes = _frame_bytes(k, m)
        total = (
            nbytes
            if objects is None
            else nbytes + _objects_bytes(*objects.object_id.shape, objects.path.shape[1])
        )
        if total > self._ring.size // 4:  # the parent could not return the room it needs
            slots = "" if objects is None else f", {objects.object_id.shape[1]} object slots an ego"
            raise SumoError(
                f"a frame of {total / 2**20:.2f} MB ({k} slots, {m} vehicles{slots}) is more "
                f"than a quarter of the ring of {self._ring.size / 2**20:.2f} MB; run this "
                "field or capacity with SumoSource, in process"
            )
        start = self._ring.place(self._head, total)
        while start + total - self._returned > self._ring.size:
            self._await_room()
        self._ring.write(start, frame, k, m)
        if objects is not None:
            self._ring.write_objects(start + nbytes, objects)
        self._head = start + total
        return start

    def _await_room(self) -> None:
        fd = self._conn.fileno()
        if not select.select([fd], [], [], 0)[0]:
            self._outbox.flush()
        os.set_blocking(fd, True)  # the outbox keeps it non-blocking
        try:
            message = self._conn.recv()
        finally:
            os.set_blocking(fd, False)
        if not (isinstance(message, tuple) and message[0] == "ack"):
            raise SumoError(f"the parent sent {message!r} while frames were streaming")
        self._returned = max(self._returned, message[1])


class _Snapshots:
    """The frame messages of a source, step by step (the child's side of :meth:`_take`).

    A message carries what the parent makes the frame of (with its own
    :class:`~acc_fusion.truth.sumo.frames.FrameMaker`): the values the source read
    (:meth:`~acc_fusion.truth.sumo.source.SumoSource._fill`), the slots taken at the step and the
    slot
    flags.  The arrays go into the ring (:class:`_RingWriter`): the vehicles' speeds, leader
    distances and leader codes, then the collision speeds and the four flags cut after the
    last slot that holds a vehicle, a new vehicle or a collision flag (the slots beyond hold
    the values of an empty slot, which the parent fills in); the message gives their
    position.  The slot ids travel as the slots whose id changed, found among the slots that
    got a new vehicle or lost theirs since the last message (the only ways a slot's id
    changes).
    """

    def __init__(self, n_pairs: int, ring: _RingWriter, objects: SumoObjects | None = None) -> None:
        self._known: list[str | None] = [None] * n_pairs  # the slot ids the parent has
        self._was_active = np.zeros(n_pairs, dtype=bool)
        self._ring, self._objects = ring, objects

    def __call__(self, src: SumoSource, caught: list) -> tuple:
        """The message of ``src``'s current step, with the warnings ``caught`` during it,
        its arrays written into the ring from the source's own (no copies)."""
        active = src._active  # replaced, never changed in place
        reassigned, collided = src._reassigned, src._collided
        k, candidates = _extent(active, reassigned, collided, self._was_active)
        ids, known = src._slot_vid, self._known
        changed = {}
        for i in candidates.tolist():
            if ids[i] != known[i]:
                changed[i] = known[i] = ids[i]
        self._was_active = active
        _, speed, dists, codes, others, _ = src._raw
        arrays = (src._collision_speed, speed, dists, codes, active, reassigned, collided)
        objects = None
        if self._objects is not None:  # the object frame of the same k slots
            if src.frame().t != src.t:  # the child's steps do not make frames
                src._make()
            objects = self._objects.arrays(k)
        position = self._ring.write((*arrays, src._inattentive), k, speed.size, objects)
        return (
            "frame",
            src.t,
            k,
            speed.size,
            position,
            changed,
            src._news,
            others,
            src.done,
            _counts(src),
            [(w.category, str(w.message)) for w in caught],
            None if objects is None else objects.object_id.shape[1],
        )


@njit(cache=True)
def _extent(active, reassigned, collided, was_active):  # pragma: no cover - compiled
    """One past the last slot that holds a vehicle, a new vehicle or a collision flag, and
    the slots whose id may have changed since the last message (a new vehicle, or a vehicle
    gone)."""
    k, m = 0, 0
    candidates = np.empty(active.size, dtype=np.intp)
    for i in range(active.size):
        if active[i] or reassigned[i] or collided[i]:
            k = i + 1
        if reassigned[i] or (was_active[i] and not active[i]):
            candidates[m] = i
            m += 1
    return k, candidates[:m]


#: Counters of :class:`~acc_fusion.truth.sumo.source.SumoSource` mirrored by the background source.
COUNTERS = ("n_departed", "n_equipped", "n_inattentive", "n_hazards", "n_collisions")


_counts = attrgetter(*COUNTERS)


class _Outbox:
    """Messages to the parent, written to the socket without blocking SUMO's stepping.

    Messages are written :data:`OUTBOX_BATCH` at a time (one ``writev``), or at once when
    :meth:`put` is told ``now``: a parent waiting for frames is woken once per batch, not
    per frame, and waking a process costs the waker as much as a SUMO step on a virtual
    machine.  A message that does not fit in the socket's buffer waits here, in order, and
    is written as the parent reads; only when more than ``limit`` bytes wait does
    :meth:`put` block until the parent has caught up to ``limit``.  The bytes on the socket
    are those of ``Connection.send`` (a 4-byte big-endian length, then the pickle), so the
    parent reads them with ``Connection.recv``.  The socket is non-blocking while the outbox
    is open.
    """

    def __init__(self, fd: int, limit: int) -> None:
        self._fd, self._limit = fd, limit
        self._queue: deque[memoryview] = deque()
        self._queued = 0
        os.set_blocking(fd, False)

    def put(self, message: tuple, now: bool = False) -> None:
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        for part in (struct.pack("!i", len(data)), data):
            self._queue.append(memoryview(part))
            self._queued += len(part)
        batch = len(self._queue) >= 2 * OUTBOX_BATCH  # two parts a message
        if now or batch or self._queued > self._limit:
            self._write(self._limit)

    def flush(self) -> None:
        """Write everything still waiting (blocking)."""
        self._write(0)

    def close(self) -> None:
        """Write everything still waiting (blocking), and make the socket blocking again."""
        self._write(0)
        os.set_blocking(self._fd, True)

    def _write(self, keep: int) -> None:
        """Write what the socket takes; block while more than ``keep`` bytes wait."""
        queue = self._queue
        while queue:
            try:
                sent = os.writev(self._fd, list(islice(queue, _IOV_MAX)))
            except BlockingIOError:
                if self._queued <= keep:
                    return
                select.select([], [self._fd], [])
                continue
            self._queued -= sent
            while sent >= len(queue[0]):
                sent -= len(queue.popleft())
                if not queue:
                    return
            queue[0] = queue[0][sent:]
