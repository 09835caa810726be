"""Which fused object each pairing of two sensors' tracks is, frame to frame: the objects'
slots and ids (:mod:`acc_fusion.fusion.tracking.association`'s module docstring, "Fused
objects"), as kernels inlined into the association's per-ego loop."""

from __future__ import annotations

from numba import njit

from acc_fusion.fusion.tracking.kernels import UNNUMBERED


@njit(cache=True, inline="always")
def place_objects(
    valid, object_id, pair, track, conf_a, id_a, mate_a, conf_b, id_b, mate_b, keep, pending,
    keep_identity,
):  # pragma: no cover - compiled  # fmt: skip
    """One ego's objects after the association, in place: a pairing that existed keeps its
    slot and id; with ``keep_identity`` a new pairing then takes the slot and id of the object
    it alone continues (:func:`inherit`); the others go to free slots with new ids (module
    docstring; ``keep (F,)``, ``pending (T_a + T_b, 3)``: scratch)."""
    n_a, n_b, n_f = mate_a.size, mate_b.size, valid.size
    keep[:] = False
    n_p = 0
    for i in range(n_a + n_b):
        if i < n_a:
            if not conf_a[i]:
                continue
            ia, ib = i, mate_a[i]
        else:
            if not conf_b[i - n_a] or mate_b[i - n_a] >= 0:
                continue
            ia, ib = -1, i - n_a
        key_a, key_b = track_keys(ia, ib, id_a, id_b)
        found = False
        for f in range(n_f):
            if valid[f] and not keep[f] and pair[f, 0] == key_a and pair[f, 1] == key_b:
                keep[f], found = True, True
                track[f, 0], track[f, 1] = ia, ib
                break
        if not found:
            pending[n_p, 0], pending[n_p, 1] = ia, ib
            n_p += 1
    if keep_identity:
        n_p = inherit(valid, pair, track, id_a, id_b, keep, pending, n_p)
    for f in range(n_f):
        if not keep[f]:
            valid[f], object_id[f], pair[f, 0], pair[f, 1] = False, -1, -1, -1
    f = 0
    for k in range(n_p):
        while valid[f]:
            f += 1
        ia, ib = pending[k, 0], pending[k, 1]
        valid[f], object_id[f] = True, UNNUMBERED
        pair[f, 0], pair[f, 1] = track_keys(ia, ib, id_a, id_b)
        track[f, 0], track[f, 1] = ia, ib


@njit(cache=True, inline="always")
def inherit(valid, pair, track, id_a, id_b, keep, pending, n_p):  # pragma: no cover - compiled
    """The ``n_p`` new pairings in ``pending`` (rows ``[track a, track b, scratch]``) that are
    the one successor of an object no pairing kept — the only new pairing with one of its
    tracks, the other track having joined or left it, not replaced by another — take its
    slot and id, in place (by the radar track first, then the camera's); an object that
    splits in two passes its id to neither.  Return how many pairings stay pending,
    compacted at its start."""
    for k in range(n_p):  # each pairing's candidate: the object it continues, or -1
        key_a, key_b = track_keys(pending[k, 0], pending[k, 1], id_a, id_b)
        pending[k, 2] = -1
        for side in range(2):
            key, other = (key_a, key_b) if side == 0 else (key_b, key_a)
            if key < 0:
                continue
            for f in range(valid.size):
                if (valid[f] and not keep[f] and pair[f, side] == key
                        and (pair[f, 1 - side] < 0 or other < 0)):  # fmt: skip
                    pending[k, 2] = f
                    break
            if pending[k, 2] >= 0:
                break
    n_left = 0
    for k in range(n_p):
        f = pending[k, 2]
        for j in range(n_p):  # another new pairing with one of the object's tracks: a split
            if f >= 0 and j != k:
                key_a, key_b = track_keys(pending[j, 0], pending[j, 1], id_a, id_b)
                if (key_a >= 0 and pair[f, 0] == key_a) or (key_b >= 0 and pair[f, 1] == key_b):
                    f = -1
        if f < 0 or keep[f]:
            pending[n_left, 0], pending[n_left, 1] = pending[k, 0], pending[k, 1]
            n_left += 1
            continue
        keep[f] = True
        pair[f, 0], pair[f, 1] = track_keys(pending[k, 0], pending[k, 1], id_a, id_b)
        track[f, 0], track[f, 1] = pending[k, 0], pending[k, 1]
    return n_left


@njit(cache=True, inline="always")
def track_keys(ia, ib, id_a, id_b):  # pragma: no cover - compiled
    """The track ids ``(a, b)`` of the pairing of track slots ``ia`` and ``ib`` (-1: none)."""
    return (id_a[ia] if ia >= 0 else -1), (id_b[ib] if ib >= 0 else -1)
