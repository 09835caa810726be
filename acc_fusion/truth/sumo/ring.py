"""The ring of shared memory through which SUMO's background process streams its reads to the
pipeline's process: the frame layout (:func:`_frame_bytes`), the ring (:class:`_FrameRing`), the
child's writer and per-step snapshots, with the packing kernels (numba)."""

from __future__ import annotations

import mmap
import os
import select
import tempfile
from multiprocessing.connection import Connection
from operator import attrgetter
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from acc_fusion.truth.sumo.config import SumoError
from acc_fusion.truth.sumo.source import SumoSource

#: Buffers per ``writev`` (POSIX guarantees at least 16).
_IOV_MAX = 16

if TYPE_CHECKING:
    from acc_fusion.truth.sumo.background import _Outbox


#: The slot flags of a frame message, in order (empty: False).
_FLAG_ROWS = ("active", "reassigned", "collided", "inattentive")


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
    position)`` message, each time an eighth of the ring has been read), and the child
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

    def write(self, frame: tuple[np.ndarray, ...], k: int, m: int) -> int:
        """Write a frame's arrays (:meth:`_FrameRing.write`: ``k`` slots, ``m`` vehicles);
        returns its position."""
        nbytes = _frame_bytes(k, m)
        start = self._ring.place(self._head, nbytes)
        while start + nbytes - self._returned > self._ring.size:
            self._await_room()
        self._ring.write(start, frame, k, m)
        self._head = start + nbytes
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

    def __init__(self, n_pairs: int, ring: _RingWriter) -> None:
        self._known: list[str | None] = [None] * n_pairs  # the slot ids the parent has
        self._was_active = np.zeros(n_pairs, dtype=bool)
        self._ring = ring

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
        position = self._ring.write((*arrays, src._inattentive), k, speed.size)
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
