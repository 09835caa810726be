r"""Track-to-track association of two sensors' trackers (:class:`TrackAssociator`) and the bridge
that feeds each associated object to the 1-D federated filter (:func:`fused_measurements`).

Association
    Per ego, the confirmed tracks :math:`a` of one sensor (the radar) and :math:`b` of the other
    (the infrared camera) are compared by the squared Mahalanobis distance of their positions

    .. math::

        d^2_{ab} = (\mathbf p_a - \mathbf p_b)^\top (P_a + P_b)^{-1} (\mathbf p_a - \mathbf p_b),

    the test statistic of Bar-Shalom, "On the track-to-track correlation problem", *IEEE
    Trans. Automatic Control* 26(2), 1981, *without* its cross-covariance term
    :math:`-P_{ab} - P_{ba}`: the two tracks' errors are treated as independent, although they
    share the object's process noise (so :math:`d^2` is somewhat smaller than the exact
    statistic and the gate somewhat wider than its nominal probability).  Both trackers are
    advanced to the same frame time (the slower sensor's tracks are predicted between its
    samples), so the positions are synchronous.  Pairs with :math:`d^2 \ge \gamma` (the
    chi-square gate of 2 degrees of freedom) are excluded, and the others assigned by GNN
    (:mod:`acc_fusion.fusion.tracking.assignment`, a track left single costing :math:`\gamma`).
    The association is *sticky*: a pair associated at the previous frame stays paired, without
    competing in the assignment, while it still gates; the others compete for the rest.

Fused objects
    Every pair and every confirmed track left single is a fused object in one of
    :math:`F = T_a + T_b` slots per ego (never too few).  An object keeps its slot and its id as
    long as its pairing — the two track ids, or one id and none — is unchanged; a new pairing
    (a track joins, leaves or is replaced) is a new object with a new id (never reused) in a
    free slot.  With ``keep_identity``, a new pairing that is the one successor of an object of
    the last frame that no pairing kept — the only new pairing with one of its tracks, the
    other sensor's track having joined or left it, not replaced by another — takes over that
    object's slot and id (by the radar's track first, then the camera's): the object goes on
    while one sensor's track leaves it or another joins, and an object that splits in two
    passes its id to neither.  Its lateral position and velocity :math:`[y, v_y]` are the
    information-weighted mean of its tracks', :math:`P = (P_a^{-1} + P_b^{-1})^{-1}`,
    :math:`\hat{\mathbf x} = P (P_a^{-1}\hat{\mathbf x}_a + P_b^{-1}\hat{\mathbf x}_b)`
    (independent errors assumed, as above), or the single track's.

Bridge to the 1-D federated filter
    :func:`fused_measurements` turns the N = E·F fused slots into the pairs of an
    :class:`~acc_fusion.fusion.base.Estimator`: for each sensor a
    :class:`~acc_fusion.sensors.sensor.Measurement` whose pair ``e·F + f`` holds the detection
    that updated that sensor's track of the object at this frame, :math:`z = [x,\ \dot r]` with
    :math:`x = r\cos\theta` and :math:`R = \operatorname{diag}(R_{z,xx},\ \sigma_{\dot r}^2)`
    (the converted covariance's x-variance and the declared range-rate variance), and the
    fused object's id as ``target_id`` (-1 in an empty slot).  So the federated filter, its
    fault detection included, fuses every associated object unchanged, and re-initialises a
    slot's filters when it gets a new object id.  Given the slot of each pair (the used slots
    only, :class:`acc_fusion.core.slots.PairPool`), it makes those pairs alone.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numba import njit, prange

from acc_fusion.core.borrow import borrow, keep_alive
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.motion import MEAS_DIM
from acc_fusion.core.slots import PairState, pair_mask
from acc_fusion.core.threads import blocks
from acc_fusion.core.units import TIME_TOL
from acc_fusion.filters.kalman import _inverse
from acc_fusion.fusion.tracking import tracker
from acc_fusion.fusion.tracking.assignment import gnn, scratch_arrays
from acc_fusion.fusion.tracking.identity import place_objects
from acc_fusion.fusion.tracking.kernels import converted, number_new, std_at
from acc_fusion.fusion.tracking.tracker import GateConfig, Tracks
from acc_fusion.sensors.detections import CLUTTER, GHOST, Detections
from acc_fusion.sensors.sensor import Measurement


@dataclass(frozen=True)
class AssociationConfig(GateConfig):
    """Settings of the :class:`TrackAssociator`: the gate of two tracks of one object
    (:class:`~acc_fusion.fusion.tracking.tracker.GateConfig`, default :math:`P_G = 0.99`).

    Attributes:
        keep_identity: a fused object keeps its id when a track joins it or leaves it, not
            when one track replaces another nor when it splits in two (module docstring), so
            its estimator goes on instead of restarting; the system track of a multisensor
            tracker keeps its number as the sensor tracks behind it change (Blackman &
            Popoli, *Design and Analysis of Modern Tracking Systems*, Artech House 1999, on
            multiple-sensor tracking).
            Default False: every pairing is its own object (see docs/theory/tracking.md for
            what it changes).
    """

    _NAME: ClassVar[str] = "association"

    keep_identity: bool = False


@dataclass(frozen=True)
class FusedObjects:
    """The objects of E egos after associating two sensors' tracks, in ``(E, F)`` slots.

    Attributes:
        t: frame time [s].
        sensors: the two sensors' names, in the order of ``track``'s last axis.
        valid: ``(E, F)`` bool, the slot holds an object.
        object_id: ``(E, F)`` int64, the object's id (new whenever its pairing changes), -1 in
            an empty slot.
        track: ``(E, F, 2)`` int64, the slot of each sensor's track in its
            :class:`~acc_fusion.fusion.tracking.tracker.Tracks`, -1 if that sensor has none.
        lateral: ``(E, F, 2)`` fused ``[y, vy]`` [m, m/s].
        lateral_cov: ``(E, F, 2, 2)`` its covariance.
    """

    t: float
    sensors: tuple[str, str]
    valid: np.ndarray
    object_id: np.ndarray
    track: np.ndarray
    lateral: np.ndarray
    lateral_cov: np.ndarray


class TrackAssociator(PairState):
    """Sticky GNN association of two sensors' confirmed tracks (module docstring).

    :meth:`forget` drops the objects of some egos (a slot that got a new vehicle);
    :meth:`resize` makes it associate for the first m egos only (:mod:`acc_fusion.core.slots`).

    Args:
        config: the :class:`AssociationConfig`.
        n_egos: number of egos E.
        max_tracks: the two trackers' ``max_tracks`` ``(T_a, T_b)``; ``F = T_a + T_b``.
    """

    _PAIR_AXES = {"_valid": 0, "_object_id": 0, "_pair": 0}

    def __init__(self, config: AssociationConfig, n_egos: int, max_tracks: tuple[int, int]):
        if not isinstance(config, AssociationConfig):
            raise ConfigError(f"config must be an AssociationConfig, got {type(config).__name__}")
        self.config = config
        self.n_egos = int(n_egos)
        self.max_tracks = (int(max_tracks[0]), int(max_tracks[1]))
        self.n_slots = sum(self.max_tracks)
        self.reset()

    def reset(self) -> None:
        """Forget every object (ids continue to count up)."""
        shape = (self.n_egos, self.n_slots)
        self._valid = np.zeros(shape, bool)
        self._object_id = np.full(shape, -1, np.int64)
        self._pair = np.full(shape + (2,), -1, np.int64)  # the objects' track ids
        self._next_id = getattr(self, "_next_id", np.zeros(1, np.int64))
        self.__dict__.pop("_parked", None)

    def forget(self, egos: np.ndarray) -> None:
        """Drop every object of ``egos`` (a boolean mask ``(E,)`` or indices); their ids are
        never reused, so a later object of the same tracks gets a new one."""
        egos = pair_mask(egos, self.n_egos)
        self._valid[egos] = False
        self._object_id[egos] = -1
        self._pair[egos] = -1

    def _resized(self, m: int) -> None:
        self.n_egos = m

    def step(self, a: Tracks, b: Tracks) -> FusedObjects:
        """Associate the two trackers' tracks of one frame (``a`` and ``b`` at the same time)."""
        for tracks, n in zip((a, b), self.max_tracks, strict=True):
            if not isinstance(tracks, Tracks) or tracks.valid.shape != (self.n_egos, n):
                raise InputError(f"step() needs Tracks of shape ({self.n_egos}, {n})")
        if abs(a.t - b.t) > TIME_TOL:
            raise InputError(f"the tracks must be of one time, got {a.t!r} and {b.t!r}")
        track = np.full((self.n_egos, self.n_slots, 2), -1, np.int64)
        lateral = np.zeros((self.n_egos, self.n_slots, 2))
        lateral_cov = np.zeros((self.n_egos, self.n_slots, 2, 2))
        args = (
            a.confirmed, a.track_id, a.state, a.cov, b.confirmed, b.track_id, b.state, b.cov,
            self.config.gate_value, self.config.keep_identity, self._valid, self._object_id,
            self._pair, self._next_id, track, lateral, lateral_cov,
        )  # fmt: skip
        chunks = blocks(self.n_egos, tracker.PARALLEL_EGOS)
        _associate_parallel(*args, chunks) if chunks else _associate(*args)
        return FusedObjects(
            a.t, (a.sensor, b.sensor), self._valid.copy(), self._object_id.copy(), track,
            lateral, lateral_cov,
        )  # fmt: skip


@njit(cache=True)
def _associate(
    conf_a, id_a, x_a, p_a, conf_b, id_b, x_b, p_b, gate, keep_identity, valid, object_id,
    pair, next_id, track, lateral, lateral_cov,
):  # pragma: no cover - compiled  # fmt: skip
    """:meth:`TrackAssociator.step` of every ego, in place on the objects' ``valid``,
    ``object_id`` and ``pair`` (their two track ids); writes ``track``, ``lateral`` and
    ``lateral_cov``."""
    _associate_egos(0, valid.shape[0], conf_a, id_a, x_a, p_a, conf_b, id_b, x_b, p_b, gate,
                    keep_identity, valid, object_id, pair, track, lateral,
                    lateral_cov)  # fmt: skip
    number_new(object_id, next_id)


@njit(cache=True, parallel=True)
def _associate_parallel(
    conf_a, id_a, x_a, p_a, conf_b, id_b, x_b, p_b, gate, keep_identity, valid, object_id,
    pair, next_id, track, lateral, lateral_cov, chunks,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_associate` on the cores, the egos in ``chunks`` blocks (the egos are
    independent; new objects are numbered after, as the serial kernel would)."""
    n = valid.shape[0]
    for c in prange(chunks):
        _associate_egos(c * n // chunks, (c + 1) * n // chunks, conf_a, id_a, x_a, p_a, conf_b,
                        id_b, x_b, p_b, gate, keep_identity, valid, object_id, pair, track,
                        lateral, lateral_cov)  # fmt: skip
    number_new(object_id, next_id)


@njit(cache=True)
def _associate_egos(
    lo, hi, conf_a, id_a, x_a, p_a, conf_b, id_b, x_b, p_b, gate, keep_identity, valid,
    object_id, pair, track, lateral, lateral_cov,
):  # pragma: no cover - compiled  # fmt: skip
    """The association of egos ``lo`` to ``hi``, with work arrays of its own; new objects are
    left :data:`~acc_fusion.fusion.tracking.kernels.UNNUMBERED`."""
    conf_a, id_a, x_a, p_a, conf_b, id_b, x_b, p_b = borrow(
        (conf_a, id_a, x_a, p_a, conf_b, id_b, x_b, p_b)
    )
    valid, object_id, pair, track, lateral, lateral_cov = borrow(
        (valid, object_id, pair, track, lateral, lateral_cov)
    )
    n_egos, n_a = conf_a.shape
    n_b = conf_b.shape[1]
    floats = (np.empty((n_a, n_b)), np.empty((n_a, n_b)), np.empty(2), np.empty((2, 2)),
              np.empty((2, 2)), np.empty((2, 2)))  # fmt: skip
    d2, free_d2, vec, s, si, work = borrow(floats)
    ints = (np.empty(n_a, np.int64), np.empty(n_b, np.int64), np.empty(n_a, np.int64),
            np.empty(n_b, np.int64), np.empty(n_a, np.int64), np.empty(n_b, np.int64),
            np.empty(n_a, np.int64), np.empty((n_a + n_b, 3), np.int64))  # fmt: skip
    free_a, free_b, all_a, all_b, mate_a, mate_b, out, pending = borrow(ints)
    keep_owner = np.empty(valid.shape[1], np.bool_)
    keep = borrow(keep_owner)
    scratch_owner = scratch_arrays(n_a, n_b)
    scratch = borrow(scratch_owner)
    for e in range(lo, hi):
        mate_a[:] = -1
        mate_b[:] = -1
        n_ca = _unpaired(conf_a[e], mate_a, all_a)
        n_cb = _unpaired(conf_b[e], mate_b, all_b)
        for r in range(n_ca):  # only pairs of confirmed tracks are read below
            i = all_a[r]
            for c in range(n_cb):
                j = all_b[c]
                d2[i, j] = _distance(x_a, p_a, x_b, p_b, e, i, j, gate, s, si, work)
        for f in range(valid.shape[1]):  # sticky: the last frame's pairs that still gate
            if valid[e, f] and pair[e, f, 0] >= 0 and pair[e, f, 1] >= 0:
                i = _find(conf_a[e], id_a[e], pair[e, f, 0])
                j = _find(conf_b[e], id_b[e], pair[e, f, 1])
                if i >= 0 and j >= 0 and d2[i, j] < gate:
                    mate_a[i], mate_b[j] = j, i
        n_r = _unpaired(conf_a[e], mate_a, free_a)
        n_c = _unpaired(conf_b[e], mate_b, free_b)
        for r in range(n_r):
            for c in range(n_c):
                free_d2[r, c] = d2[free_a[r], free_b[c]]
        gnn(free_d2, n_r, n_c, gate, out, scratch)
        for r in range(n_r):
            if out[r] >= 0:
                mate_a[free_a[r]], mate_b[free_b[out[r]]] = free_b[out[r]], free_a[r]
        place_objects(valid[e], object_id[e], pair[e], track[e], conf_a[e], id_a[e], mate_a,
                      conf_b[e], id_b[e], mate_b, keep, pending, keep_identity)  # fmt: skip
        for f in range(valid.shape[1]):
            if valid[e, f]:
                _fuse_lateral(track[e, f], x_a[e], p_a[e], x_b[e], p_b[e], lateral[e, f],
                              lateral_cov[e, f], vec, s, si, work)  # fmt: skip
    keep_alive((floats, ints, keep_owner, scratch_owner))


@njit(cache=True, inline="always")
def _distance(x_a, p_a, x_b, p_b, e, i, j, gate, s, si, work):  # pragma: no cover - compiled
    """Squared Mahalanobis distance of ego ``e``'s tracks ``i`` of ``a`` and ``j`` of ``b``
    by their positions, with covariance ``P_a + P_b`` (``inf`` when the x-difference alone
    puts it outside the gate)."""
    dx, dy = x_a[e, i, 0] - x_b[e, j, 0], x_a[e, i, 2] - x_b[e, j, 2]
    if dx * dx >= gate * (p_a[e, i, 0, 0] + p_b[e, j, 0, 0]):
        return np.inf
    for r in range(2):
        for c in range(2):
            s[r, c] = p_a[e, i, 2 * r, 2 * c] + p_b[e, j, 2 * r, 2 * c]
    _inverse(s, si, work, 2)
    return dx * (si[0, 0] * dx + si[0, 1] * dy) + dy * (si[1, 0] * dx + si[1, 1] * dy)


@njit(cache=True, inline="always")
def _find(confirmed, ids, wanted):  # pragma: no cover - compiled
    """The slot of the confirmed track ``wanted``, -1 if there is none."""
    for i in range(ids.size):
        if confirmed[i] and ids[i] == wanted:
            return i
    return -1


@njit(cache=True, inline="always")
def _unpaired(confirmed, mate, free):  # pragma: no cover - compiled
    """Put the slots of the confirmed tracks without a mate in ``free``; return how many."""
    n = 0
    for i in range(mate.size):
        if confirmed[i] and mate[i] < 0:
            free[n] = i
            n += 1
    return n


@njit(cache=True, inline="always")
def _fuse_lateral(slots, x_a, p_a, x_b, p_b, out, out_cov, vec, s, si, work):  # pragma: no cover
    """Information-weighted ``[y, vy]`` of an object's tracks (the single track's if one;
    ``vec``, ``s``, ``si``, ``work``: scratch)."""
    i, j = slots[0], slots[1]
    if i < 0 or j < 0:
        x, p = (x_a[i], p_a[i]) if i >= 0 else (x_b[j], p_b[j])
        for r in range(2):
            out[r] = x[2 + r]
            for c in range(2):
                out_cov[r, c] = p[2 + r, 2 + c]
        return
    for r in range(2):
        vec[r] = 0.0
        for c in range(2):
            out_cov[r, c] = 0.0
    for x, p in ((x_a[i], p_a[i]), (x_b[j], p_b[j])):
        _inverse(p[2:, 2:], si, work, 2)
        for r in range(2):
            for c in range(2):
                out_cov[r, c] += si[r, c]
                vec[r] += si[r, c] * x[2 + c]
    _inverse(out_cov, s, work, 2)
    for r in range(2):
        out[r] = s[r, 0] * vec[0] + s[r, 1] * vec[1]
        for c in range(2):
            out_cov[r, c] = s[r, c]


def fused_measurements(
    fused: FusedObjects,
    tracks: Sequence[Tracks],
    detections: Sequence[Detections],
    slots: np.ndarray | None = None,
) -> tuple[list[Measurement], np.ndarray]:
    """The fused objects as the pairs of the 1-D federated filter (module docstring): one
    :class:`~acc_fusion.sensors.sensor.Measurement` per sensor, in the order of
    ``fused.sensors``, and ``target_id (N,)``, for ``Estimator.step(measurements, target_id)``.

    ``tracks`` and ``detections`` are the two sensors' of this frame, in the same order.  The
    pairs are the E·F fused slots (ego-major), or, with ``slots (N,)``, the flat slot
    ``e·F + f`` of each pair (-1: a pair without an object, which gets no measurement).
    """
    e, f = fused.valid.shape
    if slots is None:
        slots = np.arange(e * f)
    slots = np.asarray(slots, dtype=np.int64)
    if slots.ndim != 1 or (slots.size and not -1 <= slots.min() <= slots.max() < e * f):
        raise InputError(f"slots must be flat slots in [-1, {e * f}), one per pair")
    n = slots.size
    target = np.empty(n, np.int64)
    _targets(slots, fused.valid, fused.object_id, target)
    out = []
    for s, (trk, det) in enumerate(zip(tracks, detections, strict=True)):
        if trk.sensor != fused.sensors[s] or det.sensor != fused.sensors[s]:
            raise InputError(f"tracks and detections must be given in the order {fused.sensors}")
        if trk.detection.shape[0] != e or det.n_egos != e:
            raise InputError(f"the {trk.sensor} tracks and detections must be of {e} egos")
        z, r = np.empty((n, MEAS_DIM)), np.empty((n, MEAS_DIM, MEAS_DIM))
        valid, ghost = np.empty(n, bool), np.empty(n, bool)
        _measure(slots, fused.track[..., s], trk.detection, trk.state, det.range, det.azimuth,
                 det.range_std, det.azimuth_std, det.range_rate, det.range_rate_std,
                 det.range_std_growth, det.range_rate_std_growth, det.origin, z, r, valid,
                 ghost)  # fmt: skip
        out.append(Measurement(det.t, det.sensor, z, r, valid, ghost, bool(det.online)))
    return out, target


@njit(cache=True)
def _targets(slots, fused_valid, fused_id, target):  # pragma: no cover - compiled
    """Each pair's fused object id, from its flat slot ``e·F + f`` (-1: no slot or no
    object)."""
    f = fused_valid.shape[1]
    for i in range(slots.size):
        q = slots[i]
        ok = q >= 0 and fused_valid[q // f, q % f]
        target[i] = fused_id[q // f, q % f] if ok else -1


@njit(cache=True)
def _measure(
    slots, track, detection, state, rng, azimuth, range_std, azimuth_std, range_rate,
    range_rate_std, growth, rate_growth, origin, z, r, valid, ghost,
):  # pragma: no cover - compiled  # fmt: skip
    """One sensor's measurement of each pair (its flat slot in ``slots``): the detection its
    track in the slot (``track (E, F)``) took at this frame, as the converted ``x`` and the
    range-rate, ``z (N, 2)``, their variances in ``r (N, 2, 2)`` (identity and NaN where it
    has none), ``valid`` and ``ghost`` (a ghost or clutter detection).  Stds that grow with
    range (``growth``, ``rate_growth``) are taken at the range of the track's ``state (E, T,
    4)`` rather than the measured one (:class:`~acc_fusion.sensors.detections.Detections`;
    the track, updated by this detection, is the estimate at hand: its correlation with the
    measurement's error is its gain, small where the std is large)."""
    f = track.shape[1]
    for i in range(slots.size):
        q, k, t = slots[i], -1, -1
        if q >= 0:
            t = track[q // f, q % f]
            if t >= 0:
                k = detection[q // f, t]
        valid[i] = k >= 0
        r[i, 0, 1], r[i, 1, 0] = 0.0, 0.0
        if k < 0:
            z[i, 0], z[i, 1], r[i, 0, 0], r[i, 1, 1], ghost[i] = np.nan, np.nan, 1.0, 1.0, False
            continue
        e, sr, sv = q // f, range_std[k], range_rate_std[k]
        if growth > 0.0 or rate_growth > 0.0:
            r2 = state[e, t, 0] ** 2 + state[e, t, 2] ** 2
            sr, sv = std_at(sr, growth, rng[k], r2), std_at(sv, rate_growth, rng[k], r2)
        x, _, rxx, _, _ = converted(rng[k], azimuth[k], sr, azimuth_std[k])
        z[i, 0], z[i, 1] = x, range_rate[k]
        r[i, 0, 0], r[i, 1, 1] = rxx, sv**2
        ghost[i] = origin[k] == GHOST or origin[k] == CLUTTER
