"""SUMO in a background process, streaming frames ahead of the FCW pipeline (open loop).

:class:`BackgroundSumoSource` offers the read side of :class:`~acc_fusion.sumo.SumoSource`
(``frame()``, ``advance()``, ``t``, ``n_steps``, ``done``, ``active``, ``reassigned``,
``collided``, ``collision_speed``, ``inattentive``, ``vehicle_ids``, the counters and
:meth:`~BackgroundSumoSource.ssm_min_ttc`) while the :class:`~acc_fusion.sumo.SumoSource`
itself runs in a child process.  The child steps SUMO, reads the frame and sends it, without
waiting to be asked, so the SUMO steps and the libsumo reads run on one core while the
pipeline processes earlier frames on the other.  The child never waits for the parent to
read, up to :data:`OUTBOX_LIMIT` bytes of frames: what the socket does not take waits in the
child's memory (:class:`_Outbox`).  That matters because the two sides' costs move in
opposite phases: SUMO's step grows with the traffic (0.15 ms per step while the motorway
fills, 1 ms at its peak) while the pipeline's is nearly fixed, so the child runs hundreds of
frames ahead early and the parent catches up later.
Nothing waits for a request per step: on a virtual machine, waking a sleeping process costs
a quarter of a millisecond or more, as much as a SUMO step, and a request-reply per frame
paid it twice per step.

Why this is exact, and only in open loop
    The frames are those of a :class:`~acc_fusion.sumo.SumoSource` with the same config,
    bit for bit (the child *is* one), because nothing the pipeline does reaches SUMO when no
    driver hears the warnings: hazards, inattentive drivers and slots are drawn inside the
    source.  A closed loop sends each step's brake requests to SUMO *before* the next step,
    which a source running ahead cannot honour, so :meth:`BackgroundSumoSource.advance`
    refuses them and :func:`acc_fusion.fcw.simulate` refuses a closed loop on a source whose
    ``accepts_brakes`` is false.  ``gui`` (sumo-gui, coloured by warning) needs the pipeline's
    levels in SUMO too and is refused as well.

Processes
    The child is a fresh interpreter (``python -c``, not ``multiprocessing``: a user's script
    without a ``__main__`` guard is not re-imported), connected by a socket pair; libsumo
    holds one simulation per process, so any number of background sources can run in one
    parent process, each with its own child.  Frames cross the socket pickled, their ``(N,)``
    arrays packed into one byte string up to the last slot in use (:class:`_Snapshots`):
    about 60 µs of the child's time per step on the motorway's 300 to 600 vehicles.  The
    source's ``RuntimeWarning`` s (e.g. more equipped vehicles than slots) are re-issued in
    the parent.  A SUMO failure in the child reaches the parent as the same
    :class:`~acc_fusion.sumo.SumoError` at the frame where it happened (the frames before it
    were delivered); a child that dies is a :class:`~acc_fusion.sumo.SumoError` naming its
    exit code.
"""

from __future__ import annotations

import os
import pickle
import select
import signal
import socket
import struct
import subprocess
import sys
import warnings
from collections import deque
from multiprocessing.connection import Connection
from typing import Any

import numpy as np
from numba import njit

from acc_fusion.errors import AccFusionError, ConfigError
from acc_fusion.sumo import SumoConfig, SumoError, SumoSource
from acc_fusion.truth import SlotSource, TruthFrame
from acc_fusion.validation import check_array

#: Counters of :class:`~acc_fusion.sumo.SumoSource` mirrored by the background source.
COUNTERS = ("n_departed", "n_equipped", "n_inattentive", "n_hazards", "n_collisions")
#: Bytes of frames the child may hold for the parent beyond the socket's buffer before it
#: waits: about 800 frames of 1 024 slots.  SUMO's step costs grow with the traffic while the
#: pipeline's are fixed, so the child runs ahead while the network fills and the parent
#: catches up later; a buffer of a few frames made each process wait on the other's slow
#: steps instead.
OUTBOX_LIMIT = 64 << 20
#: Seconds the parent waits for the child to exit after ``close`` before it is terminated.
CLOSE_TIMEOUT = 30.0


#: The values of an empty slot (with no collision to report) in the float rows of a frame
#: message: the rows of the source's frame block (ego speed and acceleration, gap, lead speed
#: and acceleration, lateral offset), then the collision speed.
_EMPTY_FLOATS = (0.0, 0.0, np.nan, np.nan, np.nan, 0.0, np.nan)
#: The slot flags of a frame message, in order (empty: False).
_FLAG_ROWS = ("active", "reassigned", "collided", "inattentive")


class _Snapshots:
    """The frame messages of a source, step by step (the child's side of :meth:`_take`).

    The ``(N,)`` arrays travel packed into one byte string (pickling costs per array, not
    per byte, at these sizes): the seven float rows, the leader ids and the four flags,
    each cut after the last slot that holds a vehicle, a new vehicle or a collision flag
    (the slots beyond hold the values of an empty slot, which the parent fills in).  The
    slot ids travel as the slots whose id changed, found among the slots that got a new
    vehicle or lost theirs since the last message (the only ways a slot's id changes).
    """

    def __init__(self, n_pairs: int) -> None:
        self._known: list[str | None] = [None] * n_pairs  # the slot ids the parent has
        self._was_active = np.zeros(n_pairs, dtype=bool)

    def __call__(self, src: SumoSource, caught: list) -> tuple:
        """The message of ``src``'s current step, with the warnings ``caught`` during it.
        It reads the source's own arrays (no copies): the frame's block of float rows
        (:func:`acc_fusion.sumo._frame_arrays`) and the slot flags."""
        frame, active = src.frame(), src.active
        reassigned, collided = src._reassigned, src._collided
        k, candidates = _extent(active, reassigned, collided, self._was_active)
        ids, known = src._slot_vid, self._known
        changed = {}
        for i in candidates.tolist():
            if ids[i] != known[i]:
                changed[i] = known[i] = ids[i]
        self._was_active = active
        rows = (src._block, src._collision_speed, frame.leader_id, active, reassigned, collided)
        return (
            "frame",
            frame.t,
            k,
            b"".join([row[..., :k].tobytes() for row in (*rows, src._inattentive & active)]),
            changed,
            src.done,
            tuple(getattr(src, c) for c in COUNTERS),
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


def _failure(exc: BaseException) -> tuple:
    """An error message for the parent: the exception's type if it is ours, else SumoError."""
    kind = type(exc) if isinstance(exc, AccFusionError) else SumoError
    return ("error", kind, str(exc) or type(exc).__name__)


def _child(fd: int) -> None:
    """Entry point of the child process: serve the config it receives on socket ``fd``.
    Ctrl-C is the parent's to handle: the child ends when the parent closes the socket."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    conn = Connection(fd)
    _serve(conn.recv(), conn)


class _Outbox:
    """Messages to the parent, written to the socket without blocking SUMO's stepping.

    A message that does not fit in the socket's buffer waits here, in order, and is written
    as the parent reads; only when more than ``limit`` bytes wait does :meth:`put` block until
    the parent has caught up to ``limit``.  The bytes on the socket are those of
    ``Connection.send`` (a 4-byte big-endian length, then the pickle), so the parent reads
    them with ``Connection.recv``.  The socket is non-blocking while the outbox is open.
    """

    def __init__(self, fd: int, limit: int) -> None:
        self._fd, self._limit = fd, limit
        self._queue: deque[memoryview] = deque()
        self._queued = 0
        os.set_blocking(fd, False)

    def put(self, message: tuple) -> None:
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        for part in (struct.pack("!i", len(data)), data):
            self._queue.append(memoryview(part))
            self._queued += len(part)
        self._write(self._limit)

    def close(self) -> None:
        """Write everything still waiting (blocking), and make the socket blocking again."""
        self._write(0)
        os.set_blocking(self._fd, True)

    def _write(self, keep: int) -> None:
        """Write what the socket takes; block while more than ``keep`` bytes wait."""
        while self._queue:
            try:
                sent = os.write(self._fd, self._queue[0])
            except BlockingIOError:
                if self._queued <= keep:
                    return
                select.select([], [self._fd], [])
                continue
            self._queued -= sent
            if sent == len(self._queue[0]):
                self._queue.popleft()
            else:
                self._queue[0] = self._queue[0][sent:]


def _serve(config: SumoConfig, conn: Any) -> None:
    """Run a :class:`SumoSource` to its end, sending every frame as soon as it is read
    (through an :class:`_Outbox`); then answer ``"ssm"`` requests until the parent closes
    the socket."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            src = SumoSource(config)
        except Exception as exc:  # a bad config or SUMO not loading: the parent raises it
            conn.send(_failure(exc))
            return
        try:
            outbox = _Outbox(conn.fileno(), OUTBOX_LIMIT)
            meta = {k: getattr(src, k) for k in ("dt", "begin", "end_time", "n_pairs", "n_steps")}
            outbox.put(("meta", meta))
            snapshot = _Snapshots(src.n_pairs)
            outbox.put(snapshot(src, caught))
            while not src.done:
                caught.clear()
                try:
                    src.advance()
                except Exception as exc:  # SUMO failed: the parent raises it at this frame
                    outbox.put(_failure(exc))
                    break
                outbox.put(snapshot(src, caught))
            outbox.close()
            while conn.recv() == "ssm":
                conn.send(("ssm", src.ssm_min_ttc()))
        except (EOFError, OSError):  # the parent closed the socket (or went away)
            pass
        finally:
            src.close()


class BackgroundSumoSource(SlotSource):
    """A :class:`~acc_fusion.sumo.SumoSource` run in a child process that streams its frames
    ahead of the caller (see the module docstring).  Open loop only: ``advance`` takes no
    brake requests.

    Example:
        >>> from acc_fusion.fcw import SimConfig, simulate
        >>> from acc_fusion.traffic import bundled_nets
        >>> with BackgroundSumoSource(SumoConfig(str(bundled_nets()["ring"]), end=5.0)) as src:
        ...     result = simulate(SimConfig(runs=1, dt=src.dt), source=src)
        >>> result.steps
        50

    Args:
        config: the source's :class:`~acc_fusion.sumo.SumoConfig` (``gui`` must be false).

    Raises:
        ConfigError: ``gui`` is set, or the config is invalid (as ``SumoSource`` raises it).
        SumoError: SUMO could not load the configuration.
    """

    #: Closed loops need a source that applies brake requests before its next step.
    accepts_brakes = False

    def __init__(self, config: SumoConfig) -> None:
        if not isinstance(config, SumoConfig):
            raise ConfigError(f"config must be a SumoConfig, got {type(config).__name__}")
        if config.gui:
            raise ConfigError(
                "gui needs the warning levels in SUMO at every step; run it with SumoSource"
            )
        self.config = config
        self._closed = True
        mine, theirs = socket.socketpair()
        fd = theirs.fileno()
        # The parent's imports (also from a checkout), and not the working directory that
        # ``python -c`` puts first: a package there would shadow the parent's.
        code = (
            "import sys; sys.path[:] = [p for p in sys.path if p]; "
            f"from acc_fusion.sumo_background import _child; _child({fd})"
        )
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
        self._proc = subprocess.Popen([sys.executable, "-c", code], pass_fds=(fd,), env=env)
        theirs.close()
        self._conn = Connection(mine.detach())
        self._closed = False
        try:
            self._conn.send(config)
            meta = self._receive("meta")[1]
            self.dt, self.begin, self.end_time = meta["dt"], meta["begin"], meta["end_time"]
            self.n_pairs, self._n_steps = meta["n_pairs"], meta["n_steps"]
            self._vehicle_ids: list[str | None] = [None] * self.n_pairs
            self._empty_floats = np.array(_EMPTY_FLOATS)[:, None].repeat(self.n_pairs, axis=1)
            self._k = 0
            self._take(self._receive("frame"))
        except BaseException:
            self.close()
            raise

    # ---------------------------------------------------------------- the child's answers
    def _receive(self, kind: str) -> tuple:
        try:
            message = self._conn.recv()
        except (EOFError, OSError):
            try:
                code = self._proc.wait(timeout=CLOSE_TIMEOUT)
            except subprocess.TimeoutExpired:
                code = None
            self.close()
            raise SumoError(
                f"the SUMO process running {self.config.sumocfg!r} ended unexpectedly "
                f"(exit code {code})"
            ) from None
        if message[0] == "error":
            _, error_type, text = message
            self.close()
            raise error_type(text)
        if message[0] != kind:  # a protocol slip would silently shift every frame
            self.close()
            raise SumoError(f"the SUMO process answered {message[0]!r} to a {kind!r} request")
        return message

    def _take(self, message: tuple) -> None:
        """Take a frame message of :class:`_Snapshots`: fill in the empty slots beyond it."""
        (_, t, k, packed, ids, done, counts, caught) = message
        n, n_float, n_flag = self.n_pairs, len(_EMPTY_FLOATS), len(_FLAG_ROWS)
        floats, leader_id = self._empty_floats.copy(), np.full(n, -1, dtype=np.int64)
        flags = np.zeros((n_flag, n), dtype=bool)
        floats[:, :k] = np.frombuffer(packed, float, n_float * k).reshape(n_float, k)
        leader_id[:k] = np.frombuffer(packed, np.int64, k, offset=8 * n_float * k)
        flags[:, :k] = np.frombuffer(packed, bool, offset=8 * (n_float + 1) * k).reshape(n_flag, k)
        *values, self._collision_speed = floats
        self._frame = TruthFrame.from_arrays(t, *values[:5], leader_id, lateral_offset=values[5])
        self._active, self._reassigned, self._collided, self._inattentive = flags
        self._done = done
        for slot, vehicle in ids.items():
            self._vehicle_ids[slot] = vehicle
        for name, value in zip(COUNTERS, counts, strict=True):
            setattr(self, name, value)
        for category, text in caught:
            warnings.warn(text, category, stacklevel=3)

    # ---------------------------------------------------------------- the source interface
    def advance(self, ego_brake: np.ndarray | None = None) -> TruthFrame:
        """The next frame (usually already computed and waiting in the socket).

        Raises:
            ConfigError: a brake request (any value > 0): this source runs ahead of them.
            SumoError: SUMO failed at this step, the run has ended, or the source is closed.
        """
        if ego_brake is not None:
            brake = check_array("ego_brake", ego_brake, (self.n_pairs,), finite=False)
            if np.any(brake > 0):
                raise ConfigError(
                    "a BackgroundSumoSource runs ahead of the pipeline and cannot apply brake "
                    "requests; use SumoSource for a closed loop"
                )
        if self._closed:
            raise SumoError("the SUMO simulation is closed; open a new source")
        if self._done:
            raise SumoError(f"the SUMO run has ended at t = {self.t:g} s")
        self._take(self._receive("frame"))
        self._k += 1
        return self._frame

    @property
    def pid(self) -> int:
        """Process id of the child running SUMO."""
        return self._proc.pid

    @property
    def t(self) -> float:
        """Current simulation time [s]."""
        return self._frame.t

    @property
    def n_steps(self) -> int:
        """Number of steps from the begin time to the end time."""
        return self._n_steps

    @property
    def done(self) -> bool:
        """The run has ended (as :attr:`SumoSource.done`), or the source is closed."""
        return self._closed or self._done

    @property
    def closed(self) -> bool:
        """Whether the child process has been closed (by :meth:`close` or a failure)."""
        return self._closed

    @property
    def inattentive(self) -> np.ndarray:
        """``(N,)`` slots whose vehicle has an inattentive driver."""
        return self._inattentive.copy()

    @property
    def vehicle_ids(self) -> list[str | None]:
        """SUMO id of each slot's vehicle (``None`` for an empty slot)."""
        return list(self._vehicle_ids)

    def slot_of(self, vehicle_id: str) -> int | None:
        """The slot of an equipped vehicle, or ``None``."""
        try:
            return self._vehicle_ids.index(vehicle_id)
        except ValueError:
            return None

    def ssm_min_ttc(self) -> dict[str, float]:
        """As :meth:`SumoSource.ssm_min_ttc`, once the run is done (the child is ahead of the
        parent before that).

        Raises:
            SumoError: the run is not done yet, or the source is closed.
        """
        if self._closed:
            raise SumoError("the SUMO process is closed; ask for ssm_min_ttc() before close()")
        if not self._done:
            raise SumoError("ssm_min_ttc() of a background source is available once it is done")
        self._conn.send("ssm")
        return self._receive("ssm")[1]

    def close(self) -> None:
        """Stop the child process (idempotent); the last frame and counters stay readable."""
        if self._closed:
            return
        self._closed = True
        self._conn.close()  # the child, reading or sending, sees the socket closed and exits
        try:
            self._proc.wait(timeout=CLOSE_TIMEOUT)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
