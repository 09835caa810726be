"""The arrays of an object frame beyond its source's 1-D truth (:class:`ObjectArrays`), as
:class:`~acc_fusion.truth.sumo.objects.SumoObjects` fills them and SUMO's background process
sends them (:class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource`), and the
:class:`~acc_fusion.truth.objects.ObjectFrame` made of them (:func:`object_frame`)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import NamedTuple

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.truth.objects import ObjectFrame
from acc_fusion.truth.sumo.object_kernels import _empty_egos

#: The float fields of an :class:`~acc_fusion.truth.objects.ObjectFrame`, in the order of the
#: rows of :attr:`ObjectArrays.floats` (and of ``object_kernels._fill``'s output).
OBJECT_FLOATS = ("x", "y", "elevation", "vx", "vy", "speed", "accel", "heading", "length",
                 "width", "height", "rcs", "thermal_contrast", "lateral_speed")  # fmt: skip


class ObjectArrays(NamedTuple):
    """The arrays of an object frame of ``E`` egos and ``M`` object slots each beyond those of
    its source's :class:`~acc_fusion.truth.frame.TruthFrame` (:func:`object_frame`): the
    float fields :data:`OBJECT_FLOATS` ``(len(OBJECT_FLOATS), E, M)``, object ids ``(E, M)``
    int64 (-1: empty), kinds ``(E, M)`` int8, relative lanes ``(E, M)`` int64, lead slots
    ``(E,)`` int64, yaw rates, road curvatures and sideways shifts ``(E,)``
    (:attr:`~acc_fusion.truth.objects.ObjectFrame.ego_shift`), and the map paths ``(E, J)``
    (:attr:`~acc_fusion.truth.objects.ObjectFrame.road_path`; ``J = 0`` without a map)."""

    floats: np.ndarray
    object_id: np.ndarray
    kind: np.ndarray
    lane: np.ndarray
    lead: np.ndarray
    yaw_rate: np.ndarray
    curvature: np.ndarray
    shift: np.ndarray
    path: np.ndarray

    def resized(self, n: int) -> ObjectArrays:
        """A copy of these arrays for the first ``n`` slots: the first ``min(n, E)`` rows,
        and slots after ``E`` that hold no vehicle (no object, no lead, yaw rate, curvature
        and shift 0, no map path), as
        :meth:`~acc_fusion.truth.sumo.objects.SumoObjects.frame` makes an inactive slot."""
        e, m = min(n, self.lead.size), self.object_id.shape[1]
        out = object_outputs(n, m)
        floats, object_id, kind, lane, lead = out
        floats[:, :e] = self.floats[:, :e]
        object_id[:e], kind[:e], lane[:e] = self.object_id[:e], self.kind[:e], self.lane[:e]
        lead[:e] = self.lead[:e]
        _empty_egos(e, *out)
        rates = np.zeros((3, n))
        rates[0, :e], rates[1, :e] = self.yaw_rate[:e], self.curvature[:e]
        rates[2, :e] = self.shift[:e]
        path = np.full((n, self.path.shape[1]), np.nan)
        path[:e] = self.path[:e]
        return ObjectArrays(*out, *rates, path)


def object_frame(truth, arrays: ObjectArrays) -> ObjectFrame:
    """The :class:`~acc_fusion.truth.objects.ObjectFrame` of ``arrays`` (their E egos) at the
    step of ``truth`` (the source's :class:`~acc_fusion.truth.frame.TruthFrame`, which gives
    the egos' speed and acceleration), without the constructor's checks."""
    n = arrays.lead.size
    return ObjectFrame.from_arrays(
        truth.t,
        ego_speed=truth.ego_speed[:n],
        ego_accel=truth.ego_accel[:n],
        ego_yaw_rate=arrays.yaw_rate,
        road_curvature=arrays.curvature,
        road_path=arrays.path,
        ego_shift=arrays.shift,
        valid=arrays.object_id >= 0,
        object_id=arrays.object_id,
        kind=arrays.kind,
        lane=arrays.lane,
        lead=arrays.lead,
        **dict(zip(OBJECT_FLOATS, arrays.floats, strict=True)),
    )


def object_outputs(n: int, m: int) -> tuple[np.ndarray, ...]:
    """The outputs of :func:`_fill` for ``n`` egos and ``m`` object slots, uninitialised
    (it writes every entry): the float fields of :data:`OBJECT_FLOATS`, object ids, kinds,
    relative lanes and lead slots."""
    return (
        np.empty((len(OBJECT_FLOATS), n, m)),
        np.empty((n, m), dtype=np.int64),
        np.empty((n, m), dtype=np.int8),
        np.empty((n, m), dtype=np.int64),
        np.empty(n, dtype=np.int64),
    )


def check_prefix(egos: int, active: np.ndarray) -> int:
    """``egos`` checked as the length of a prefix of the slots ``active (N,)`` that holds
    every active one.

    Raises:
        InputError: ``egos`` is not an integer in ``[0, N]`` or leaves out an active slot.
    """
    n = active.size
    if isinstance(egos, bool) or not (isinstance(egos, (int, np.integer)) and 0 <= egos <= n):
        raise InputError(f"egos must be an integer in [0, {n}], got {egos!r}")
    if active[egos:].any():
        raise InputError(f"egos = {egos} leaves out active slots; give at least "
                         f"{int(np.flatnonzero(active)[-1]) + 1}")  # fmt: skip
    return int(egos)


class ObjectFrames(ABC):
    """Object frames of a source's steps, made once per step for the slots asked
    (:meth:`frame`); a subclass gives the step's truth and active slots (``_current``) and makes
    the arrays of a prefix of slots (``_arrays``)."""

    _frame: ObjectFrame | None = None

    def frame(self, egos: int | None = None) -> ObjectFrame:
        """The :class:`~acc_fusion.truth.objects.ObjectFrame` of the source's current step.

        Args:
            egos: make the frame of the first ``egos`` slots only (``frame().head(egos)``
                without the work on the others); they must include every active slot.
                ``None``: every slot.  Asked again in the step for as many slots or fewer,
                it gives (a view of) the same frame; for more, it makes the frame anew.

        Raises:
            InputError: ``egos`` is out of range or leaves out an active slot.
        """
        truth, active = self._current()
        n = active.size if egos is None else check_prefix(egos, active)
        cached = self._frame
        if cached is None or cached.t != truth.t or cached.n_egos < n:
            self._frame = object_frame(truth, self._arrays(truth, n))
        return self._frame.head(n)

    @abstractmethod
    def _current(self) -> tuple:
        """The source's :class:`~acc_fusion.truth.frame.TruthFrame` of the current step and
        its ``(N,)`` active slots."""

    @abstractmethod
    def _arrays(self, truth, n: int) -> ObjectArrays:
        """The :class:`ObjectArrays` of the first ``n`` slots at ``truth``'s step."""
