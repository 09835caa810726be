"""The compiled search and fill of :class:`~acc_fusion.truth.sumo.objects.SumoObjects`: each
ego's forward field found on a uniform grid of the object centres, and the frame's arrays
filled in the ego frame (the method: that module's docstring)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from acc_fusion.core.borrow import borrow
from acc_fusion.truth.objects import OFF_ROAD, ObjectKind

_OFFSET = 1 << 20  # grid cells from the origin a key can hold on either side
_VEHICLE, _OFF_ROAD = int(ObjectKind.VEHICLE), int(OFF_ROAD)
#: The fields copied from the objects' properties (rows of ``props``, in this order).
_PROPS = (2, 5, 6, 8, 9, 10, 11, 12, 13)


#: Side of a cell of the search grid [m]: a field of 200 m x 30 m spans a few cells.
GRID_CELL = 50.0


def _grid(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Grid keys of the object centres (cells of :data:`GRID_CELL`), sorted, and the order."""
    ix = np.floor(x / GRID_CELL).astype(np.int64)
    keys = _cell_key(ix, np.floor(y / GRID_CELL).astype(np.int64))
    order = np.argsort(keys, kind="stable")
    return keys[order], order


@njit(cache=True)
def _cell_key(ix, iy):  # pragma: no cover - compiled
    """One int64 key of grid cell ``(ix, iy)``: the cells of a column ``ix`` are consecutive."""
    return (ix + _OFFSET) * (2 * _OFFSET) + (iy + _OFFSET)


@njit(cache=True)
def _search(
    ego, ox, oy, cos_h, sin_h, olen, keys, order, ahead, lateral, counts, hit_j, hit_x, hit_y
):  # pragma: no cover - compiled
    """Find each ego's objects in the field (module docstring): the grid columns under the
    field's bounding box (widened by the longest object's half length), one key range per
    column.  Writes each ego's count into ``counts`` and its hits (object index, near face
    ``x``, ``y``) ego after ego into ``hit_*`` as far as they hold; returns the number of hits.
    """
    ego, ox, oy, cos_h, sin_h, olen, keys, order, counts, hit_j, hit_x, hit_y = borrow(
        (ego, ox, oy, cos_h, sin_h, olen, keys, order, counts, hit_j, hit_x, hit_y)
    )
    margin = 0.5 * olen.max() if olen.shape[0] else 0.0
    room, total = hit_j.shape[0], 0
    for e in range(ego.shape[0]):
        i = ego[e]
        counts[e] = 0
        if i < 0:
            continue
        c, s = cos_h[i], sin_h[i]
        px, py = ox[i] + 0.5 * olen[i] * c, oy[i] + 0.5 * olen[i] * s
        # The field's corners p + a u + b n, a in {0, ahead}, b in {-lateral, lateral}.
        x_lo = px + min(0.0, ahead * c) - lateral * abs(s) - margin
        x_hi = px + max(0.0, ahead * c) + lateral * abs(s) + margin
        y_lo = py + min(0.0, ahead * s) - lateral * abs(c) - margin
        y_hi = py + max(0.0, ahead * s) + lateral * abs(c) + margin
        iy0, iy1 = math.floor(y_lo / GRID_CELL), math.floor(y_hi / GRID_CELL)
        for ix in range(math.floor(x_lo / GRID_CELL), math.floor(x_hi / GRID_CELL) + 1):
            lo = np.searchsorted(keys, _cell_key(ix, iy0), side="left")
            hi = np.searchsorted(keys, _cell_key(ix, iy1), side="right")
            for t in range(lo, hi):
                j = order[t]
                if j == i:
                    continue
                hl = 0.5 * olen[j]
                rx, ry = ox[j] - hl * cos_h[j] - px, oy[j] - hl * sin_h[j] - py
                fx, fy = ox[j] + hl * cos_h[j] - px, oy[j] + hl * sin_h[j] - py
                if fx * fx + fy * fy < rx * rx + ry * ry:
                    rx, ry = fx, fy
                x = rx * c + ry * s
                y = -rx * s + ry * c
                if x < 0.0 or x > ahead or abs(y) > lateral:
                    continue
                if total < room:
                    hit_j[total], hit_x[total], hit_y[total] = j, x, y
                total += 1
                counts[e] += 1
    return total


@njit(cache=True)
def _fill(
    ego, counts, hit_j, hit_x, hit_y, lead_id, ego_speed, curvature, lane_width, cos_h, sin_h,
    okind, oid, oedge, olane, props, out, out_id, out_kind, out_lane, lead,
):  # pragma: no cover - compiled  # fmt: skip
    """Write the hits of :func:`_search` into the outputs (``object_arrays.object_outputs``,
    uninitialised), the slots after each ego's hits empty (NaN, id -1, kind 0, off-road), and
    ``lead``: the slot of the vehicle whose id is ``lead_id`` (-1: none)."""
    ego, counts, hit_j, hit_x, hit_y, lead_id, ego_speed, curvature, lane_width = borrow(
        (ego, counts, hit_j, hit_x, hit_y, lead_id, ego_speed, curvature, lane_width)
    )
    cos_h, sin_h, okind, oid, oedge, olane, props, out = borrow(
        (cos_h, sin_h, okind, oid, oedge, olane, props, out)
    )
    out_id, out_kind, out_lane, lead = borrow((out_id, out_kind, out_lane, lead))
    h = 0
    for e in range(ego.shape[0]):
        i = ego[e]
        lead[e] = -1
        _clear(e, counts[e], out, out_id, out_kind, out_lane)
        for k in range(counts[e]):
            j = hit_j[h]
            _put(e, k, j, hit_x[h], hit_y[h], cos_h[i], sin_h[i], ego_speed[e], cos_h, sin_h,
                 props, out)  # fmt: skip
            out_id[e, k], out_kind[e, k] = oid[j], okind[j]
            if okind[j] != _VEHICLE:  # stationary: on no lane
                out_lane[e, k] = _OFF_ROAD
            elif oedge[j] >= 0 and oedge[j] == oedge[i]:
                out_lane[e, k] = olane[j] - olane[i]
            else:
                off = _path_offset(hit_x[h], hit_y[h], curvature[e]) / lane_width[e]
                out_lane[e, k] = np.int64(np.round(off))
            if oid[j] == lead_id[e] and okind[j] == _VEHICLE:
                lead[e] = k
            h += 1


@njit(cache=True)
def _clear(e, start, out, out_id, out_kind, out_lane):  # pragma: no cover - compiled
    """Empty the object slots of ego ``e`` from ``start`` on: NaN, id -1, kind 0, off-road."""
    for k in range(start, out_id.shape[1]):
        for r in range(out.shape[0]):
            out[r, e, k] = np.nan
        out_id[e, k], out_kind[e, k], out_lane[e, k] = -1, 0, _OFF_ROAD


@njit(cache=True)
def _empty_egos(start, out, out_id, out_kind, out_lane, lead):  # pragma: no cover - compiled
    """Make the egos from ``start`` on egos without a vehicle: every object slot empty
    (:func:`_clear`), no lead."""
    for e in range(start, out_id.shape[0]):
        lead[e] = -1
        _clear(e, 0, out, out_id, out_kind, out_lane)


@njit(cache=True)
def _put(e, k, j, x, y, c, s, v_ego, cos_h, sin_h, props, out):  # pragma: no cover - compiled
    """Write object ``j`` into slot ``(e, k)`` of ``out`` (:data:`_FIELDS`): its near face at
    ``(x, y)``, its heading and velocity relative to an ego of heading ``(c, s)`` and speed
    ``v_ego``, and its properties."""
    cos_rel = cos_h[j] * c + sin_h[j] * s  # cos and sin of the heading difference
    sin_rel = sin_h[j] * c - cos_h[j] * s
    v = props[1, j]
    out[0, e, k], out[1, e, k] = x, y
    out[3, e, k], out[4, e, k] = v * cos_rel - v_ego, v * sin_rel
    out[7, e, k] = math.atan2(sin_rel, cos_rel)
    for r in range(len(_PROPS)):
        out[_PROPS[r], e, k] = props[r, j]


@njit(cache=True)
def _path_offset(x, y, kappa):  # pragma: no cover - compiled
    r"""Signed distance [m] of ``(x, y)`` to the left of the circle of curvature ``kappa``
    tangent to the x axis at the origin (the ego's path; a straight line for ``kappa`` 0):
    :math:`\operatorname{sign}(\kappa)(1/|\kappa| - \lVert (x, y - 1/\kappa) \rVert)`,
    :math:`\approx y - \kappa x^2/2` near the origin."""
    if abs(kappa) < 1e-9:
        return y
    r = 1.0 / kappa
    return (abs(r) - math.hypot(x, y - r)) * (1.0 if kappa > 0 else -1.0)
