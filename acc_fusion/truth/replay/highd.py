r"""The highD data set (Krajewski et al., *The highD Dataset*, ITSC 2018; format:
levelXdata's *highD format* document): German motorways filmed from a drone, 25 Hz.

A recording ``NN`` is three files in one folder: ``NN_recordingMeta.csv`` (``frameRate``,
``upperLaneMarkings``, ``lowerLaneMarkings``, ...), ``NN_tracksMeta.csv`` (one row per
vehicle: ``id``, ``drivingDirection``, ...) and ``NN_tracks.csv`` (one row per vehicle per
frame).  The image's x axis runs along the road; the upper carriageway
(``drivingDirection`` 1) drives left, towards negative x, the lower one (2) drives right.
``x, y`` is the **upper-left corner** of the vehicle's bounding box, ``width`` its length
along x and ``height`` its width.  So the front bumper is at ``x`` when driving left and at
``x + width`` when driving right, and along the driving direction

.. math::

    s = \begin{cases} -x & \text{direction 1} \\ x + w & \text{direction 2} \end{cases},
    \qquad u = \pm\, \dot x, \qquad a = \pm\, \ddot x

(``xVelocity`` and ``xAcceleration`` are signed along the image axis).  The lateral position
is the box's centre :math:`y_c = y + h/2`; the lane is the interval of the carriageway's lane
markings (``upperLaneMarkings`` for direction 1, ``lowerLaneMarkings`` for 2: y positions
separated by ``;``) that holds :math:`y_c`, as highD derives its own ``laneId`` (so leaders
recomputed from positions use the markings, not ``laneId``); the carriageway (group) is the
driving direction.  The leader is ``precedingId`` (0: none).  highD's own ``dhw``, ``thw`` and
``ttc`` (0 where there is no leader or no valid TTC) are kept for the cross-check
(:mod:`acc_fusion.truth.replay.crosscheck`): ``dhw`` is taken as the bumper-to-bumper
distance, an assumption the format document leaves open, which the cross-check measures.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from acc_fusion.core.paths import path_kind
from acc_fusion.truth.replay import csvfile
from acc_fusion.truth.replay.recording import Recording
from acc_fusion.truth.replay.rows import ReplayError, Rows, whole

#: The columns of ``NN_tracks.csv`` the replay reads.
TRACK_COLUMNS = (
    "frame", "id", "x", "y", "width", "height", "xVelocity", "xAcceleration", "precedingId",
    "dhw", "thw", "ttc",
)  # fmt: skip


#: The columns of ``NN_tracksMeta.csv`` the replay reads.
META_COLUMNS = ("id", "drivingDirection", "initialFrame", "numFrames")


def _positive_or_nan(x: np.ndarray) -> np.ndarray:
    """``x`` with its zeros (highD's "none") as NaN."""
    return np.where(x != 0.0, x, np.nan)


class HighDRecording(Recording):
    """highD recording ``number`` in the folder ``folder``."""

    headway_basis = "gap"
    sources = {"frame": "frame", "vid": "id", "s": "x", "speed": "xVelocity",
               "accel": "xAcceleration", "length": "width"}  # fmt: skip

    def __init__(self, folder: str | Path, number: int) -> None:
        folder = Path(folder)
        stem = f"{number:02d}"
        self.label = f"highD {stem}"
        self.path = csvfile.existing(folder / f"{stem}_tracks.csv", "highD tracks file")
        meta_path = csvfile.existing(folder / f"{stem}_recordingMeta.csv", "highD recording meta")
        tracks_meta = csvfile.existing(folder / f"{stem}_tracksMeta.csv", "highD tracks meta")
        self.frame_rate, upper, lower = _recording_meta(meta_path)
        self.dt = 1.0 / self.frame_rate
        self._markings = {1: upper, 2: lower}
        self.numbers = csvfile.resolve(self.path, TRACK_COLUMNS)
        names = csvfile.resolve(tracks_meta, META_COLUMNS)
        meta = {k: [] for k in META_COLUMNS}
        for batch in csvfile.stream(tracks_meta, names):
            for k in META_COLUMNS:
                meta[k].append(batch[k])
        ids, dirs, first, count = (whole(np.concatenate(meta[k])) for k in META_COLUMNS)
        bad = ~np.isin(dirs, (1, 2))
        if bad.any():
            line = int(np.flatnonzero(bad)[0]) + 2
            raise ReplayError(
                f"{tracks_meta}, line {line}, column 'drivingDirection': must be 1 or 2, "
                f"got {dirs[bad][0]}"
            )
        order = np.argsort(ids)
        self._meta_id, self._meta_dir = ids[order], dirs[order]
        self._meta_path = tracks_meta
        self._spans = np.maximum(first, 0), np.maximum(count, 0)

    def frame_counts(self) -> np.ndarray:
        """Rows per frame from ``tracksMeta`` (``initialFrame``, ``numFrames``), without a
        pass over the tracks file."""
        first, count = self._spans
        diff = np.zeros(int((first + count).max(initial=0)) + 1, dtype=np.int64)
        np.add.at(diff, first, 1)
        np.add.at(diff, first + count, -1)
        return np.cumsum(diff)[:-1]

    def _frames(self, batch: dict[str, np.ndarray]) -> np.ndarray:
        return whole(batch["frame"])

    def _rows(self, b: dict[str, np.ndarray], frame: np.ndarray) -> Rows:
        vid = whole(b["id"])
        k = np.minimum(np.searchsorted(self._meta_id, vid), self._meta_id.size - 1)
        unknown = self._meta_id[k] != vid
        if unknown.any():
            raise ReplayError(
                f"{self.path}: vehicle {vid[unknown][0]} is not in {self._meta_path.name}"
            )
        left = self._meta_dir[k] == 1
        sign = np.where(left, -1.0, 1.0)
        centre = b["y"] + 0.5 * b["height"]
        lane = np.where(
            left,
            np.searchsorted(self._markings[1], centre, side="right"),
            np.searchsorted(self._markings[2], centre, side="right"),
        )
        leader = whole(b["precedingId"])
        return Rows(
            frame=frame,
            vid=vid,
            s=np.where(left, -b["x"], b["x"] + b["width"]),
            lat=centre,
            lane=whole(lane),
            group=self._meta_dir[k],
            speed=sign * b["xVelocity"],
            accel=sign * b["xAcceleration"],
            length=b["width"],
            leader=np.where(leader > 0, leader, -1),
            ref={
                "headway": _positive_or_nan(b["dhw"]),
                "thw": _positive_or_nan(b["thw"]),
                "ttc": _positive_or_nan(b["ttc"]),
            },
        )


def _recording_meta(path: Path) -> tuple[float, np.ndarray, np.ndarray]:
    """The ``frameRate`` [Hz] and the upper and lower lane markings [m] of a recording meta
    file."""
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        raise ReplayError(f"{path}, line 2: no recording row")
    row = {k.strip(): (v or "").strip() for k, v in rows[0].items() if k}

    def numbers(name: str) -> np.ndarray:
        if name not in row:
            raise ReplayError(f"{path}, line 1: no column {name!r}")
        try:
            values = np.array([float(x) for x in row[name].split(";")])
        except ValueError:
            raise ReplayError(
                f"{path}, line 2, column {name!r}: {row[name]!r} is not a number or a list "
                "of numbers separated by ';'"
            ) from None
        if not np.isfinite(values).all() or np.any(np.diff(values) <= 0):
            raise ReplayError(f"{path}, line 2, column {name!r}: must be finite and increasing")
        return values

    rate = float(numbers("frameRate")[0])
    if not rate > 0:
        raise ReplayError(f"{path}, line 2, column 'frameRate': must be > 0, got {rate:g}")
    return rate, numbers("upperLaneMarkings"), numbers("lowerLaneMarkings")


def highd_recordings(path: str | Path, numbers: list[int] | None = None) -> list[HighDRecording]:
    """The recordings ``numbers`` of the highD folder ``path`` (default: every
    ``NN_tracks.csv`` in it); ``path`` may also be one ``NN_tracks.csv`` file."""
    p = Path(path)
    if p.is_file():
        stem = p.name.split("_")[0]
        if not (p.name.endswith("_tracks.csv") and stem.isdigit()):
            raise ReplayError(f"{str(p)!r} is not a highD NN_tracks.csv file")
        p, numbers = p.parent, numbers or [int(stem)]
    if not p.is_dir():
        kind = path_kind(p)
        what = "does not exist" if kind == "missing" else f"is {kind}, not a folder"
        raise ReplayError(f"highD folder {str(p)!r} {what}")
    if not numbers:
        found = sorted(p.glob("[0-9][0-9]_tracks.csv"))
        if not found:
            raise ReplayError(f"highD folder {str(p)!r} has no NN_tracks.csv file")
        numbers = [int(f.name[:2]) for f in found]
    return [HighDRecording(p, n) for n in numbers]
