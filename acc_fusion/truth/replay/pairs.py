r"""The follower→leader pairs of a window of rows, in track order.

Every vehicle of the window is an ego, frame by frame (its *track*, cut into *segments* where
a frame is missing); where it has a leader at a frame, that frame is a pair-step with

.. math::

    g = s_l - \ell_l - s_f, \qquad \dot g = u_l - u_f,

bumper to bumper (:mod:`acc_fusion.truth.replay.rows`).  The leader is the data set's own
(``precedingId``, ``Preceding``, a mapped ``leader`` column) or, when the file has none or
``recompute`` is asked for, the nearest vehicle ahead in the same group and lane at that frame
(:func:`recomputed_leaders`).  A leader that the window does not hold at that frame (it left
the recorded section, or the window) counts as no leader.  A new leader is a new target: its
id is the ``leader_id`` of the :class:`~acc_fusion.truth.frame.TruthFrame`, so the filters
re-initialise on it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from acc_fusion.truth.replay.rows import Rows


@dataclass
class Pairs:
    """Per row of a window, in track order (vehicle by vehicle, frame by frame), ``(M,)``.

    Attributes:
        vid: the ego vehicle's id.
        start: the row starts a segment (a new vehicle, or a frame missing before it).
        ego_speed, ego_accel: the ego's speed [m/s] and acceleration [m/s²].
        leader_id: the leader's vehicle id, -1 where none.
        gap: bumper-to-bumper gap [m] (NaN where no leader).
        lead_speed, lead_accel, lead_length: the leader's speed, acceleration, length.
        lateral_offset: the leader's lateral position minus the ego's [m] (0 where unknown).
        ref: the data set's own figures (:data:`~acc_fusion.truth.replay.rows.REFERENCE_COLUMNS`).
        duplicates: rows dropped because their (frame, vehicle) came before.
        agree, either: with a leader column, the rows whose file and recomputed leaders
            agree, of the rows with a leader in either (0, 0 without one).
    """

    vid: np.ndarray
    start: np.ndarray
    ego_speed: np.ndarray
    ego_accel: np.ndarray
    leader_id: np.ndarray
    gap: np.ndarray
    lead_speed: np.ndarray
    lead_accel: np.ndarray
    lead_length: np.ndarray
    lateral_offset: np.ndarray
    ref: dict[str, np.ndarray] = field(default_factory=dict)
    duplicates: int = 0
    agree: int = 0
    either: int = 0

    def __len__(self) -> int:
        return int(self.vid.shape[0])

    @property
    def has_leader(self) -> np.ndarray:
        """Rows with a leader."""
        return self.leader_id >= 0

    #: The per-row arrays, in the order of the constructor.
    ARRAYS = (
        "vid", "start", "ego_speed", "ego_accel", "leader_id", "gap", "lead_speed",
        "lead_accel", "lead_length", "lateral_offset",
    )  # fmt: skip

    @classmethod
    def concat(cls, parts: list[Pairs]) -> Pairs:
        """The rows of ``parts`` one after the other (each part's first row starts a
        segment); the data set's figures and the counts are left out."""
        return cls(*(np.concatenate([getattr(p, a) for p in parts]) for a in cls.ARRAYS))


def in_track_order(rows: Rows) -> tuple[Rows, np.ndarray, int]:
    """``rows`` sorted by vehicle then frame (not moved if they already are, as highD's and
    NGSIM's files are), repeats of a (vehicle, frame) dropped; also the ascending keys
    ``vehicle index * frames + frame`` of the rows and the number of repeats."""
    vid, frame = rows.vid, rows.frame
    ordered = bool(
        np.all((vid[1:] > vid[:-1]) | ((vid[1:] == vid[:-1]) & (frame[1:] > frame[:-1])))
    )
    if not ordered:
        order = np.lexsort((frame, vid))
        vid, frame = vid[order], frame[order]
        keep = np.ones(order.size, dtype=bool)
        keep[1:] = (vid[1:] != vid[:-1]) | (frame[1:] != frame[:-1])
        rows = rows.take(order[keep])
        duplicates = int((~keep).sum())
    else:
        duplicates = 0
    return rows, _track_keys(rows), duplicates


def _track_keys(rows: Rows) -> np.ndarray:
    """``vehicle index * frames + frame - first frame`` of rows in track order (ascending)."""
    vehicles, first, span = _vehicles(rows)
    return np.searchsorted(vehicles, rows.vid) * span + (rows.frame - first)


def _vehicles(rows: Rows) -> tuple[np.ndarray, np.int64, np.int64]:
    """The vehicle ids of rows in track order (ascending), the first frame and the frames
    spanned."""
    new = np.ones(len(rows), dtype=bool)
    new[1:] = rows.vid[1:] != rows.vid[:-1]
    first = rows.frame.min()
    return rows.vid[new], first, np.int64(rows.frame.max() - first + 1)


def file_leaders(rows: Rows, key: np.ndarray) -> np.ndarray:
    """Row index of each row's leader from the file's leader column (-1: none, or not held
    at that frame); ``rows`` and ``key`` as :func:`in_track_order` returns them."""
    vehicles, first, span = _vehicles(rows)
    lead = rows.leader
    j = np.minimum(np.searchsorted(vehicles, lead), vehicles.size - 1)
    known = (lead >= 0) & (vehicles[j] == lead)
    pos = np.minimum(np.searchsorted(key, j * span + (rows.frame - first)), key.size - 1)
    return np.where(known & (key[pos] == j * span + (rows.frame - first)), pos, -1)


def recomputed_leaders(rows: Rows) -> np.ndarray:
    """Row index of each row's leader recomputed from positions and lanes: the vehicle with
    the next larger front position :math:`s` in the same frame, group and lane (-1: none)."""
    groups, g = np.unique(rows.group, return_inverse=True)
    lanes, ln = np.unique(rows.lane, return_inverse=True)
    place = (rows.frame * np.int64(groups.size) + g.ravel()) * np.int64(lanes.size) + ln.ravel()
    order = np.lexsort((rows.s, place))
    same = place[order][1:] == place[order][:-1]
    leader = np.full(len(rows), -1, dtype=np.int64)
    leader[order[:-1][same]] = order[1:][same]
    return leader


def build_pairs(rows: Rows, recompute: bool = False) -> Pairs:
    """The pairs of ``rows`` in track order; leaders from the file's column unless it has
    none or ``recompute`` (with a leader column, both are found and compared)."""
    rows, key, duplicates = in_track_order(rows)
    lead = recomputed_leaders(rows)
    agree = either = 0
    if rows.leader is not None:
        named = file_leaders(rows, key)
        some = (named >= 0) | (lead >= 0)
        agree, either = int((some & (named == lead)).sum()), int(some.sum())
        if not recompute:
            lead = named
    has = lead >= 0
    lr = np.where(has, lead, 0)
    start = np.ones(len(rows), dtype=bool)
    start[1:] = (rows.vid[1:] != rows.vid[:-1]) | (rows.frame[1:] != rows.frame[:-1] + 1)

    def lead_of(x: np.ndarray) -> np.ndarray:
        return np.where(has, x[lr], np.nan)

    lateral = np.nan_to_num(lead_of(rows.lat) - rows.lat, nan=0.0)
    return Pairs(
        vid=rows.vid,
        start=start,
        ego_speed=rows.speed,
        ego_accel=rows.accel,
        leader_id=np.where(has, rows.vid[lr], -1),
        gap=lead_of(rows.s - rows.length) - rows.s,
        lead_speed=lead_of(rows.speed),
        lead_accel=lead_of(rows.accel),
        lead_length=lead_of(rows.length),
        lateral_offset=lateral,
        ref=rows.ref,
        duplicates=duplicates,
        agree=agree,
        either=either,
    )
