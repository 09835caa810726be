"""OSI traces as truth sources of the 2-D world (:class:`OsiTruth`: one trace, its host the
ego; :class:`OsiTraces`: several, one ego each) and of the 1-D pair (:class:`OsiPairs`).

A trace is replayed as recorded, message by message (the step ``dt`` its timestamps' spacing,
uniform within :data:`STEP_TOLERANCE`): open loop only — a recorded driver cannot react, so
brake requests are refused (``accepts_brakes = False``, as
:class:`~acc_fusion.truth.replay.source.ReplaySource`).  Each message's frame:
:func:`~acc_fusion.truth.osi.decode.decode`.  ``collided`` turns on at the first message whose
host overlaps a vehicle.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.core.paths import existing_file
from acc_fusion.truth.frame import TruthFrame
from acc_fusion.truth.objects import OFF_ROAD, ObjectFrame, SlotWorld
from acc_fusion.truth.osi.convention import METADATA, NEW_VEHICLE, RUN_START, seconds
from acc_fusion.truth.osi.decode import HostRow, decode, host_of
from acc_fusion.truth.osi.trace import file_metadata, read_ground_truth
from acc_fusion.truth.sumo.object_arrays import OBJECT_FLOATS

#: Largest difference of a step from the trace's first step, relative to it (a trace's
#: timestamps are rounded to the ns, its frame period need not be).
STEP_TOLERANCE = 1e-3


def uniform_step(times: np.ndarray, label: str) -> float:
    """The step [s] of the timestamps ``times`` of the trace ``label``.

    Raises:
        InputError: fewer than two messages, or a step that differs from the first by more
            than :data:`STEP_TOLERANCE` of it (naming the first such step).
    """
    if times.size < 2:
        raise InputError(f"OSI trace {label} needs at least two messages, has {times.size}")
    steps = np.diff(times)
    dt = float(steps[0])
    bad = np.flatnonzero(~(np.abs(steps - dt) <= STEP_TOLERANCE * dt) | (steps <= 0.0))
    if bad.size:
        k = int(bad[0])
        raise InputError(
            f"OSI trace {label} is not evenly stepped: message {k + 1} (t = {times[k + 1]:.9g} s) "
            f"comes {steps[k]:.9g} s after the one before, its first step is {dt:.9g} s"
        )
    return dt


class OsiTruth:
    """A 2-D world source of ONE ego, the host of an OSI trace (module docstring).

    Args:
        path: a ``.mcap`` trace (``topic``: a channel of GroundTruth or SensorView messages;
            default: the first GroundTruth channel, else SensorView's ``global_ground_truth``)
            or a single-channel ``.osi`` trace (``message_type`` ``"GroundTruth"`` or
            ``"SensorView"``, default from the OSI file-name convention).

    Raises:
        InputError: in one sentence: the file is missing or is not an OSI trace of
            GroundTruth or SensorView (:func:`~acc_fusion.truth.osi.trace.read_ground_truth`),
            a message has no host (:func:`~acc_fusion.truth.osi.decode.host_of`), the steps
            are uneven (:func:`uniform_step`).

    Attributes:
        times: ``(K,)`` every message's timestamp [s].
        dt: the step [s].
        marked: the trace marks its hosts' leads (this project's extension) so far.
        t: the current message's timestamp [s] (after the last: one step beyond).
    """

    accepts_brakes = False

    def __init__(
        self, path: str | Path, *, topic: str | None = None, message_type: str | None = None
    ) -> None:
        self.path = Path(path)
        self._messages = read_ground_truth(path, topic=topic, message_type=message_type)
        for k, message in enumerate(self._messages):  # every message has its host, up front
            host_of(message, k)
        self.times = np.array([seconds(m.timestamp) for m in self._messages])
        self.dt = uniform_step(self.times, repr(str(self.path)))
        self._k = 0
        self.collided = np.zeros(1, dtype=bool)
        self._collision_speed = np.full(1, np.nan)
        self.marked = False
        first = file_metadata(path).get(METADATA, {}).get("first_step", RUN_START)
        self.new_vehicle = first == NEW_VEHICLE
        self.row = self._decode(None)

    def _decode(self, previous: HostRow | None) -> HostRow:
        """The current message's row, marking a collision."""
        row = decode(self._messages[self._k], self._k, previous)
        self.marked |= row.marked
        if not math.isnan(row.collision_speed) and not self.collided[0]:
            self.collided[0], self._collision_speed[0] = True, row.collision_speed
        return row

    @property
    def n_steps(self) -> int:
        """Messages in the trace."""
        return int(self.times.size)

    @property
    def done(self) -> bool:
        """Every message was replayed."""
        return self._k >= self.times.size

    @property
    def active(self) -> np.ndarray:
        """``(1,)`` the trace goes on."""
        return np.array([not self.done])

    @property
    def reassigned(self) -> np.ndarray:
        """``(1,)`` at the first message of a trace whose host was a new vehicle in its
        source's slot there (the trace's metadata ``first_step``): its ego starts afresh, as
        it did in the recorded run."""
        return np.array([self._k == 0 and self.new_vehicle])

    @property
    def t(self) -> float:
        """The current message's time [s]."""
        return float(self.times[self._k]) if not self.done else float(self.times[-1] + self.dt)

    @property
    def collision_speed(self) -> np.ndarray:
        """``(1,)`` closing speed at the first collision [m/s], NaN if none."""
        return self._collision_speed.copy()

    def frame(self) -> ObjectFrame:
        """The host's objects at the current message."""
        return stack_rows(self.row.t, [self.row])

    def advance(self, ego_brake: np.ndarray | None = None) -> None:
        """The next message (``ego_brake`` is ignored: open loop)."""
        if self.done:
            raise InputError(f"OSI trace {str(self.path)!r} has no message after its last")
        self._k += 1
        if not self.done:
            self.row = self._decode(self.row)


#: The suffixes of the trace files a folder is searched for.
TRACE_SUFFIXES = (".mcap", ".osi")


def trace_paths(path: str | Path) -> list[Path]:
    """The traces of ``path``: the file itself, or a folder's ``.mcap`` and ``.osi`` files in
    name order.

    Raises:
        InputError: ``path`` is a folder without traces, or neither a folder nor a file.
    """
    p = Path(path)
    if p.is_dir():
        found = sorted(f for f in p.iterdir() if f.suffix.lower() in TRACE_SUFFIXES)
        if not found:
            raise InputError(f"folder {str(p)!r} holds no OSI trace (.mcap or .osi file)")
        return found
    return [existing_file(p, "OSI trace", InputError)]


class OsiTraces:
    """Several OSI traces as one 2-D world source, each trace's host an ego (module
    docstring), played together from their first messages on one clock ``t = k dt`` (the
    traces' common step); a trace that has ended keeps its last frame and is not
    ``active``.

    Raises:
        InputError: no trace, or traces of different steps (naming the first that differs).
    """

    accepts_brakes = False

    def __init__(self, paths, *, topic: str | None = None) -> None:
        self.traces = [OsiTruth(p, topic=topic) for p in paths]
        if not self.traces:
            raise InputError("give at least one OSI trace")
        self.dt = self.traces[0].dt
        for tr in self.traces[1:]:
            if abs(tr.dt - self.dt) > STEP_TOLERANCE * self.dt:
                raise InputError(
                    f"OSI traces must share one step: {str(tr.path)!r} steps {tr.dt:.9g} s, "
                    f"{str(self.traces[0].path)!r} {self.dt:.9g} s"
                )
        self._k = 0

    @property
    def n_steps(self) -> int:
        """Steps of the longest trace."""
        return max(tr.n_steps for tr in self.traces)

    @property
    def done(self) -> bool:
        """Every trace has ended."""
        return all(tr.done for tr in self.traces)

    @property
    def active(self) -> np.ndarray:
        """``(E,)`` the traces going on."""
        return np.array([not tr.done for tr in self.traces])

    @property
    def reassigned(self) -> np.ndarray:
        """``(E,)`` the traces at a first message that starts their ego afresh
        (:attr:`OsiTruth.reassigned`)."""
        return np.concatenate([tr.reassigned for tr in self.traces])

    @property
    def collided(self) -> np.ndarray:
        """``(E,)`` hosts that ran into a vehicle."""
        return np.concatenate([tr.collided for tr in self.traces])

    @property
    def collision_speed(self) -> np.ndarray:
        """``(E,)`` closing speed at each host's first collision [m/s], NaN where none."""
        return np.concatenate([tr.collision_speed for tr in self.traces])

    @property
    def t(self) -> float:
        """The replay's clock [s]."""
        return self._k * self.dt

    def frame(self) -> ObjectFrame:
        """Every host's objects now (an ended trace's at its last message, with no sideways
        jump: the message's own was taken when it was replayed)."""
        rows = [replace(tr.row, ego_shift=0.0) if tr.done else tr.row for tr in self.traces]
        return stack_rows(self.t, rows)

    def advance(self, ego_brake: np.ndarray | None = None) -> None:
        """One step of every trace going on (``ego_brake`` is ignored: open loop)."""
        for tr in self.traces:
            if not tr.done:
                tr.advance()
        self._k += 1


class OsiPairs(SlotWorld):
    """OSI traces (an :class:`OsiTraces`) as a 1-D source: each host and its true in-path
    lead (:meth:`~acc_fusion.truth.objects.ObjectFrame.lead_frame`)."""

    accepts_brakes = False

    def __init__(self, source: OsiTraces) -> None:
        self.source = source

    def frame(self) -> TruthFrame:
        """Each host's 1-D truth now."""
        return self.source.frame().lead_frame()

    def advance(self, ego_brake: np.ndarray | None = None) -> None:
        """One step (open loop)."""
        self.source.advance()


def stack_rows(t: float, rows: list[HostRow]) -> ObjectFrame:
    """The object frame of one ego per row, at time ``t``."""
    e, m = len(rows), max(r.object_id.size for r in rows)
    floats = np.zeros((len(OBJECT_FLOATS), e, m))
    valid = np.zeros((e, m), dtype=bool)
    ids, kind = np.full((e, m), -1, np.int64), np.zeros((e, m), np.int8)
    lane = np.full((e, m), OFF_ROAD, np.int64)
    for i, r in enumerate(rows):
        n = r.object_id.size
        floats[:, i, :n], valid[i, :n], ids[i, :n] = r.floats, True, r.object_id
        kind[i, :n], lane[i, :n] = r.kind, r.lane
    ego = {name: np.array([getattr(r, name) for r in rows], dtype=float)
           for name in ("ego_speed", "ego_accel", "ego_yaw_rate", "road_curvature",
                        "ego_shift")}  # fmt: skip
    return ObjectFrame(
        t=t, valid=valid, object_id=ids, kind=kind, lane=lane,
        lead=np.array([r.lead for r in rows], dtype=np.int64), **ego,
        **dict(zip(OBJECT_FLOATS, floats, strict=True)),
    )  # fmt: skip
