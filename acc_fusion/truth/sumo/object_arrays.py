"""The arrays of an object frame beyond its source's 1-D truth (:class:`ObjectArrays`), as
:class:`~acc_fusion.truth.sumo.objects.SumoObjects` fills them and SUMO's background process
sends them (:class:`~acc_fusion.truth.sumo.background.BackgroundSumoSource`), and the
:class:`~acc_fusion.truth.objects.ObjectFrame` made of them (:func:`object_frame`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

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
    ``(E,)`` int64, yaw rates and road curvatures ``(E,)``."""

    floats: np.ndarray
    object_id: np.ndarray
    kind: np.ndarray
    lane: np.ndarray
    lead: np.ndarray
    yaw_rate: np.ndarray
    curvature: np.ndarray

    def resized(self, n: int) -> ObjectArrays:
        """A copy of these arrays for the first ``n`` slots: the first ``min(n, E)`` rows,
        and slots after ``E`` that hold no vehicle (no object, no lead, yaw rate and
        curvature 0), as :meth:`~acc_fusion.truth.sumo.objects.SumoObjects.frame` makes an
        inactive slot."""
        e, m = min(n, self.lead.size), self.object_id.shape[1]
        out = object_outputs(n, m)
        floats, object_id, kind, lane, lead = out
        floats[:, :e] = self.floats[:, :e]
        object_id[:e], kind[:e], lane[:e] = self.object_id[:e], self.kind[:e], self.lane[:e]
        lead[:e] = self.lead[:e]
        _empty_egos(e, *out)
        rates = np.zeros((2, n))
        rates[0, :e], rates[1, :e] = self.yaw_rate[:e], self.curvature[:e]
        return ObjectArrays(*out, *rates)


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
