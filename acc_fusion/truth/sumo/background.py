"""SUMO in a background process, streaming frames ahead of the FCW pipeline (open loop).

:class:`BackgroundSumoSource` offers the read side of
:class:`~acc_fusion.truth.sumo.source.SumoSource`
(``frame()``, ``advance()``, ``t``, ``n_steps``, ``done``, ``active``, ``reassigned``,
``collided``, ``collision_speed``, ``inattentive``, ``vehicle_ids``, the counters and
:meth:`~BackgroundSumoSource.ssm_min_ttc`) while the
:class:`~acc_fusion.truth.sumo.source.SumoSource`
itself runs in a child process.  The child steps SUMO, reads the frame and sends it, without
waiting to be asked, so the SUMO steps and the libsumo reads run on one core while the
pipeline processes earlier frames on the other.  The child never waits for the parent to
read while its :class:`_FrameRing` has room (:data:`RING_BYTES`, about 1 600 frames of the
motorway at its peak).  That matters because the two sides' costs move in opposite phases:
SUMO's step grows with the traffic (0.15 ms per step while the motorway fills, 1 ms at its
peak) while the pipeline's is nearly fixed, so the child runs hundreds of frames ahead early
and the parent catches up later.
Nothing waits for a request per step: on a virtual machine, waking a sleeping process costs
a quarter of a millisecond or more, as much as a SUMO step, and a request-reply per frame
paid it twice per step.

Object frames (the 2-D world)
    Opened with ``objects`` (an :class:`~acc_fusion.truth.sumo.objects.ObjectFieldConfig`),
    the child also makes each step's object arrays
    (:meth:`SumoObjects.arrays <acc_fusion.truth.sumo.objects.SumoObjects.arrays>`) and writes
    them into the ring after the frame's; :attr:`BackgroundSumoSource.objects`
    (:class:`ReceivedObjects`) makes the object frames of them, for
    :class:`~acc_fusion.truth.sumo.world.SumoWorld`.  There the pipeline is the slower side by
    far, so the child runs at the lowest priority (:data:`OBJECTS_NICE`) and the ring holds a
    few frames (:data:`OBJECT_RING_FRAMES`).

Why this is exact, and only in open loop
    The frames are those of a :class:`~acc_fusion.truth.sumo.source.SumoSource` with the same
    config,
    bit for bit (the child *is* one, and the parent makes each frame with the same
    :class:`~acc_fusion.truth.sumo.frames.FrameMaker` of the same values), because nothing the
    pipeline
    does reaches SUMO when no driver hears the warnings: hazards, inattentive drivers and
    slots are drawn inside the source.  A closed loop sends each step's brake requests to
    SUMO *before* the next step, which a source running ahead cannot honour, so
    :meth:`BackgroundSumoSource.advance` refuses them and
    :func:`acc_fusion.sim.closed_loop.simulate`
    refuses a closed loop on a source whose ``accepts_brakes`` is false.  ``gui`` (sumo-gui,
    coloured by warning) needs the pipeline's levels in SUMO too and is refused as well.

Processes
    The child is a fresh interpreter (``python -c``, not ``multiprocessing``: a user's script
    without a ``__main__`` guard is not re-imported), connected by a socket pair; libsumo
    holds one simulation per process, so any number of background sources can run in one
    parent process, each with its own child.  The child sends what it read at each step
    (:meth:`~acc_fusion.truth.sumo.source.SumoSource._fill`) and the parent makes the frame of it:
    SUMO's
    process, which sets the pace, does only what needs SUMO.  The arrays (the vehicles'
    speeds and leaders, the slot flags cut after the last slot in use; :class:`_Snapshots`)
    are written into a ring of memory shared by the two processes (:class:`_FrameRing`) and
    copied out by the parent: no pickling and no copy through the kernel for the bulk of a
    frame, which cost the child a tenth of a SUMO step on the motorway.  The rest (time,
    slot ids that changed, the new vehicles' minGap and acceleration, the leaders without a
    slot, counters, warnings) and the arrays' place in the ring cross the socket pickled;
    the parent returns the ring's room as it reads.  The source's ``RuntimeWarning`` s (e.g. more
    equipped vehicles than slots) are re-issued in the parent.  A SUMO failure in the
    child reaches the parent as the same :class:`~acc_fusion.truth.sumo.config.SumoError` at the
    frame
    where it happened (the frames before it were delivered); a child that dies is a
    :class:`~acc_fusion.truth.sumo.config.SumoError` naming its exit code.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import warnings
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.memory import release_free_heap
from acc_fusion.truth.frame import SlotSource, TruthFrame
from acc_fusion.truth.objects import PATH_STATIONS
from acc_fusion.truth.sumo.config import SumoConfig, SumoError
from acc_fusion.truth.sumo.frames import FrameMaker
from acc_fusion.truth.sumo.object_arrays import ObjectArrays, ObjectFrames
from acc_fusion.truth.sumo.objects import ObjectFieldConfig, SumoObjects
from acc_fusion.truth.sumo.ring import (
    COUNTERS,
    OUTBOX_LIMIT,
    _frame_bytes,
    _FrameRing,
    _objects_bytes,
    _Outbox,
    _RingWriter,
    _Snapshots,
)
from acc_fusion.truth.sumo.source import TRIM_PERIOD, SumoSource

#: Bytes of the ring of shared memory the child writes frames into (at least 16 frames of
#: every slot): about 1 600 frames of the motorway at its peak, more while it fills.  SUMO's
#: step costs grow with the traffic while the pipeline's are fixed, so the child runs ahead
#: while the network fills and the parent catches up later; a buffer of a few frames made
#: each process wait on the other's slow steps instead.
RING_BYTES = 32 << 20
#: Frames the ring holds of a source that sends object frames, each of every slot with
#: :data:`OBJECT_RING_SLOTS` object slots (an object frame is hundreds of times a frame's
#: size, and the pipeline that reads it is the slower side: a few frames ahead suffice).
OBJECT_RING_FRAMES = 6
#: Object slots per ego the ring of a source that sends object frames is sized for: 102 MB
#: for the default 1 024 slots, so a frame of every slot may have up to about 190 objects
#: in an ego's field (a frame of more than a quarter of the ring is a
#: :class:`~acc_fusion.truth.sumo.config.SumoError`).  With the default field (200 m ahead,
#: 15 m either side) A10KW's densest half hour had at most 111 (the frame of 845 egos
#: took 12 MB); a field much larger than the default needs the in-process source.
OBJECT_RING_SLOTS = 128
#: Niceness the child of a source that sends object frames adds to its own: the 2-D
#: pipeline it feeds needs several times its time per step and runs compiled kernels on every
#: core; at the same priority the child took a core from them mid-kernel (each kernel then
#: waits for its slowest thread), at the lowest it runs in the pipeline's serial stretches.
#: ``python scripts/bench_world.py``, 2026-11-27, one run each: ``overhead_ratio`` 12.0 at
#: niceness 0, 11.6 at 19 with libgomp's default spin, 9.0 at 19 with
#: :mod:`acc_fusion.core.threads`' (five runs: median 10.3, docs/theory/world-sumo.md).
OBJECTS_NICE = 19
#: Seconds the parent waits for the child to exit after ``close`` before it is terminated.
CLOSE_TIMEOUT = 30.0


#: Stations of a map path (:data:`~acc_fusion.truth.objects.PATH_STATIONS`).
STATIONS = PATH_STATIONS.size


def _ring_bytes(n_pairs: int, objects: bool = False) -> int:
    """Bytes of the ring of a source of ``n_pairs`` slots (see :data:`RING_BYTES`), with
    room for :data:`OBJECT_RING_FRAMES` frames of every slot with :data:`OBJECT_RING_SLOTS`
    objects each if it sends ``objects``."""
    frame = _frame_bytes(n_pairs, n_pairs)
    if not objects:
        return max(RING_BYTES, 16 * frame)
    return OBJECT_RING_FRAMES * (frame + _objects_bytes(n_pairs, OBJECT_RING_SLOTS, STATIONS))


#: What the child's reads and writes on the socket raise once the parent has gone.
_PARENT_GONE = (EOFError, BrokenPipeError, ConnectionResetError)


def _failure(exc: BaseException) -> tuple:
    """An error message for the parent: the exception's type if it is ours, else SumoError."""
    kind = type(exc) if isinstance(exc, AccFusionError) else SumoError
    return ("error", kind, str(exc) or type(exc).__name__)


def _child(fd: int, ring_fd: int, ring_size: int) -> None:
    """Entry point of the child process: serve the config it receives on socket ``fd``,
    writing the frames' arrays into the ring of ``ring_size`` bytes shared as ``ring_fd``.
    Ctrl-C is the parent's to handle: the child ends when the parent closes the socket, and
    quietly when the parent is gone (a pool that stopped its workers after another's error):
    there is nobody left to tell."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    conn = Connection(fd)
    ring = _FrameRing(ring_fd, ring_size)
    os.close(ring_fd)  # the mapping stays
    try:
        _serve(*conn.recv(), conn, ring)
    except (BrokenPipeError, ConnectionResetError, EOFError):
        return


def _serve(
    config: SumoConfig, objects: ObjectFieldConfig | None, conn: Any, ring: _FrameRing
) -> None:
    """Run a :class:`SumoSource` to its end, sending every frame as soon as it is read
    (its arrays through ``ring``, the rest through an :class:`_Outbox`), with the object
    frame of its slots in use if ``objects`` is given; then answer ``"ssm"`` requests until
    the parent closes the socket."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            src = SumoSource(config)
        except Exception as exc:  # a bad config or SUMO not loading: the parent raises it
            conn.send(_failure(exc))
            return
        try:
            if objects is not None:  # the pipeline is the slower side: it has the cores first
                os.nice(OBJECTS_NICE)
            try:
                field = None if objects is None else SumoObjects(src, objects)
            except Exception as exc:  # e.g. a network without lanes to place objects on
                conn.send(_failure(exc))
                return
            outbox = _Outbox(conn.fileno(), OUTBOX_LIMIT)
            meta = {k: getattr(src, k) for k in ("dt", "begin", "end_time", "n_pairs", "n_steps")}
            outbox.put(("meta", meta))
            snapshot = _Snapshots(src.n_pairs, _RingWriter(ring, conn, outbox), field)
            first = True
            while first or not src.done:
                try:
                    if not first:
                        caught.clear()
                        src._step()
                    message = snapshot(src, caught)
                except _PARENT_GONE:  # the outer handler
                    raise
                except Exception as exc:  # SUMO failed: the parent raises it at this frame
                    outbox.put(_failure(exc), now=True)
                    break
                outbox.put(message, now=first)  # the parent waits for the first
                first = False
            outbox.close()
            while True:
                request = conn.recv()
                if request == "ssm":
                    conn.send(("ssm", src.ssm_min_ttc()))
                elif request[0] != "ack":  # acks: the room returned after the last frames
                    break
        except (EOFError, OSError):  # the parent closed the socket (or went away)
            pass
        finally:
            src.close()


class BackgroundSumoSource(SlotSource):
    """A :class:`~acc_fusion.truth.sumo.source.SumoSource` run in a child process that streams its
    frames
    ahead of the caller (see the module docstring).  Open loop only: ``advance`` takes no
    brake requests.

    Example:
        >>> from acc_fusion.sim.closed_loop import SimConfig, simulate
        >>> from acc_fusion.truth.sumo.nets import bundled_nets
        >>> with BackgroundSumoSource(SumoConfig(str(bundled_nets()["ring"]), end=5.0)) as src:
        ...     result = simulate(SimConfig(runs=1, dt=src.dt), source=src)
        >>> result.steps
        50

    Args:
        config: the source's :class:`~acc_fusion.truth.sumo.config.SumoConfig` (``gui`` must be
            false).

    Raises:
        ConfigError: ``gui`` is set, or the config is invalid (as ``SumoSource`` raises it).
        SumoError: SUMO could not load the configuration.
    """

    #: Closed loops need a source that applies brake requests before its next step.
    accepts_brakes = False

    def __init__(self, config: SumoConfig, objects: ObjectFieldConfig | None = None) -> None:
        if not isinstance(config, SumoConfig):
            raise ConfigError(f"config must be a SumoConfig, got {type(config).__name__}")
        if objects is not None and not isinstance(objects, ObjectFieldConfig):
            raise ConfigError(
                f"objects must be an ObjectFieldConfig or None, got {type(objects).__name__}"
            )
        if config.gui:
            raise ConfigError(
                "gui needs the warning levels in SUMO at every step; run it with SumoSource"
            )
        self.config = config
        self._closed = True
        mine, theirs = socket.socketpair()
        fd, size = theirs.fileno(), _ring_bytes(int(config.capacity), objects is not None)
        ring_fd = _FrameRing.create(size)
        # The parent's imports (also from a checkout), and not the working directory that
        # ``python -c`` puts first: a package there would shadow the parent's.
        code = (
            "import sys; sys.path[:] = [p for p in sys.path if p]; "
            f"from acc_fusion.truth.sumo.background import _child; _child({fd}, {ring_fd}, {size})"
        )
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
        try:
            self._ring = _FrameRing(ring_fd, size)
            self._proc = subprocess.Popen(
                [sys.executable, "-c", code], pass_fds=(fd, ring_fd), env=env
            )
        finally:
            theirs.close()
            os.close(ring_fd)
        self._returned = 0  # the ring's room given back to the child, up to this position
        self._conn = Connection(mine.detach())
        self._closed = False
        try:
            self._conn.send((config, objects))
            self.objects = None if objects is None else ReceivedObjects(self, objects)
            meta = self._receive("meta")[1]
            self.dt, self.begin, self.end_time = meta["dt"], meta["begin"], meta["end_time"]
            self.n_pairs, self._n_steps = meta["n_pairs"], meta["n_steps"]
            self._vehicle_ids: list[str | None] = [None] * self.n_pairs
            self._maker = FrameMaker(self.n_pairs, self.dt, float(config.lookahead))
            self._k = 0
            self._trim_steps = max(1, round(TRIM_PERIOD / self.dt))
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
        """Take a frame message of :class:`_Snapshots`: copy its arrays out of the ring, fill
        in the empty slots beyond them and make the frame.  Its object arrays stay in the
        ring, their room held until the next frame, for :class:`ReceivedObjects` to copy out
        as many slots as the pipeline asks for."""
        (_, t, k, m, position, ids, news, others, done, counts, caught, objects_m) = message
        self._collision_speed, speed, dists, codes, flags = self._ring.read(
            position, k, m, self.n_pairs
        )
        if objects_m is None:
            self._give_back(position + _frame_bytes(k, m))
        else:
            self._objects_at = (position + _frame_bytes(k, m), k, objects_m)
            self._give_back(position)
        self._active, self._reassigned, self._collided, self._inattentive = flags
        slots = np.flatnonzero(self._active)
        self._frame = self._maker.make(t, slots, speed, dists, codes, news, others)
        self._done = done
        for slot, vehicle in ids.items():
            self._vehicle_ids[slot] = vehicle
        for name, value in zip(COUNTERS, counts, strict=True):
            setattr(self, name, value)
        for category, text in caught:
            warnings.warn(text, category, stacklevel=3)

    def _give_back(self, position: int) -> None:
        """Return the ring's room up to ``position`` (the frames before it are copied), an
        eighth of the ring at a time.  A child that is gone is reported by the next
        receive."""
        if position - self._returned >= self._ring.size // 8:
            self._returned = position
            try:
                self._conn.send(("ack", position))
            except OSError:
                pass

    # ---------------------------------------------------------------- the source interface
    def advance(
        self, ego_brake: np.ndarray | None = None, hold: np.ndarray | None = None
    ) -> TruthFrame:
        """The next frame (usually already computed and waiting in the socket).

        Raises:
            ConfigError: a brake request (any value > 0) or a held vehicle: this source runs
                ahead of them.
            SumoError: SUMO failed at this step, the run has ended, or the source is closed.
        """
        requests = (("ego_brake", ego_brake, "apply brake requests"),
                    ("hold", hold, "hold a distracted driver's vehicle"))  # fmt: skip
        for name, value, what in requests:
            if value is not None and np.any(
                check_array(name, value, (self.n_pairs,), finite=False) > 0
            ):
                raise ConfigError(
                    f"a BackgroundSumoSource runs ahead of the pipeline and cannot {what}; "
                    "use SumoSource for a closed loop"
                )
        if self._closed:
            raise SumoError("the SUMO simulation is closed; open a new source")
        if self._done:
            raise SumoError(f"the SUMO run has ended at t = {self.t:g} s")
        self._take(self._receive("frame"))
        self._k += 1
        if self._k % self._trim_steps == 0:  # the pipeline's heap, as SumoSource trims it
            release_free_heap()
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


class ReceivedObjects(ObjectFrames):
    """The object frames a :class:`BackgroundSumoSource` opened with ``objects`` receives:
    :meth:`frame` as :meth:`SumoObjects.frame <acc_fusion.truth.sumo.objects.SumoObjects.frame>`
    gives it in process, bit for bit.

    The child makes each step's object arrays for the slots its frame message covers (up to
    the last slot holding a vehicle, a new vehicle or a collision flag); a frame of more
    slots adds empty ones, one of fewer leaves the rest out (the slots beyond hold no
    vehicle, so neither changes a value), as it copies them out of the ring
    (:meth:`~acc_fusion.truth.sumo.object_arrays.ObjectArrays.resized`).

    Attributes:
        config: the :class:`~acc_fusion.truth.sumo.objects.ObjectFieldConfig` the child uses.
    """

    def __init__(self, source: BackgroundSumoSource, config: ObjectFieldConfig) -> None:
        self._source, self.config = source, config
        self._stations = STATIONS if config.map_path else 0

    def _current(self) -> tuple:
        return self._source.frame(), self._source._active

    def _arrays(self, truth, n: int) -> ObjectArrays:
        src = self._source
        return src._ring.read_objects(*src._objects_at, n, self._stations)
