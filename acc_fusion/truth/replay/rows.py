r"""The rows of a recording in road coordinates and SI units, whatever the file's format.

Every reader (:mod:`~acc_fusion.truth.replay.highd`, :mod:`~acc_fusion.truth.replay.ngsim`,
:mod:`~acc_fusion.truth.replay.generic`) turns its file into :class:`Rows`: one row per vehicle
per frame, with the position :math:`s` of the vehicle's **front bumper** along its driving
direction (so that :math:`s` grows as it drives, whichever way the file's axis points), its
speed and acceleration along that direction, its length, lane and lateral position, and the
*group* of lanes it drives in (a carriageway: highD's upper and lower halves drive opposite
ways and never lead each other).  The bumper-to-bumper gap of a follower :math:`f` behind a
leader :math:`l` is then

.. math::

    g = s_l - \ell_l - s_f

with :math:`\ell_l` the leader's length (DESIGN.md's convention: gap = bumper to bumper).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from acc_fusion.core.errors import InputError

#: The data set's own figures a reader may keep for the cross-check (NaN where absent): the
#: distance headway [m] (bumper to bumper or front to front, as the recording's
#: ``headway_basis`` says), the time headway [s] on the same basis and the TTC [s].
REFERENCE_COLUMNS = ("headway", "thw", "ttc")


#: The physical bounds of a recorded row, in SI units: the field of :class:`Rows`, its words in a
#: message, and its least and greatest value.  Positions within 1 000 km of the file's
#: origin; speeds from a slow reverse to 360 km/h; accelerations within 3 g (beyond any road
#: vehicle's brakes or engine); lengths from a bicycle to the longest road train; ids whole
#: numbers >= 0 (the ids' NaN, where a reader keeps it, fails too).
BOUNDS = {
    "vid": ("vehicle id", 0.0, 2.0**53),
    "s": ("position [m]", -1e6, 1e6),
    "speed": ("speed [m/s]", -10.0, 100.0),
    "accel": ("acceleration [m/s²]", -30.0, 30.0),
    "length": ("length [m]", 0.5, 60.0),
}


def whole(x: np.ndarray) -> np.ndarray:
    """A file's numbers ``x`` as whole numbers (int64), rounded towards zero; NaN, infinities
    and magnitudes of 2**53 or more (no whole number a float holds exactly) become -1 ("none"
    for a lane or a leader; refused by :data:`BOUNDS` for an id, by the readers for a frame)
    without numpy's warning for an invalid cast."""
    x = np.asarray(x, dtype=float)
    return np.where(np.abs(x) < 2.0**53, x, -1.0).astype(np.int64)


class ReplayError(InputError):
    """A recording that cannot be replayed: a missing file or column, a malformed row."""


@dataclass(frozen=True)
class Rows:
    """One window of a recording: ``(M,)`` arrays, one entry per vehicle per frame.

    Attributes:
        frame: frame index (time = ``frame * dt``).
        vid: vehicle id within the recording.
        s: front-bumper position along the driving direction [m].
        lat: lateral position of the vehicle's centre [m] (NaN where unknown).
        lane: lane id (integer; -1 where unknown).
        group: carriageway (lanes that share a driving direction).
        speed: speed along the driving direction [m/s].
        accel: acceleration along the driving direction [m/s²].
        length: vehicle length [m].
        leader: the file's leader (preceding vehicle) id, -1 for none; ``None`` when the format
            has no leader column (the leaders are then recomputed from lanes and positions).
        ref: the data set's own figures, keys among :data:`REFERENCE_COLUMNS` (NaN where the
            file gives none).
    """

    frame: np.ndarray
    vid: np.ndarray
    s: np.ndarray
    lat: np.ndarray
    lane: np.ndarray
    group: np.ndarray
    speed: np.ndarray
    accel: np.ndarray
    length: np.ndarray
    leader: np.ndarray | None = None
    ref: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.frame.shape[0])

    def take(self, index: np.ndarray) -> Rows:
        """The rows at ``index`` (an integer or boolean array)."""
        arrays = {
            name: getattr(self, name)[index]
            for name in ("frame", "vid", "s", "lat", "lane", "group", "speed", "accel", "length")
        }
        leader = None if self.leader is None else self.leader[index]
        return Rows(**arrays, leader=leader, ref={k: v[index] for k, v in self.ref.items()})

    @staticmethod
    def concat(parts: list[Rows]) -> Rows:
        """The rows of ``parts`` one after the other (at least one part)."""
        if not parts:
            raise InputError("no rows to join")
        first = parts[0]
        arrays = {
            name: np.concatenate([getattr(p, name) for p in parts])
            for name in ("frame", "vid", "s", "lat", "lane", "group", "speed", "accel", "length")
        }
        leader = None if first.leader is None else np.concatenate([p.leader for p in parts])
        ref = {k: np.concatenate([p.ref[k] for p in parts]) for k in first.ref}
        return Rows(**arrays, leader=leader, ref=ref)
