"""Every vehicle of a recording at every frame, for the traffic realism check.

A recording already holds trajectories: :func:`replay_trajectories` reads each recording of a
:class:`~acc_fusion.truth.replay.source.ReplayConfig` window by window
(:meth:`~acc_fusion.truth.replay.recording.Recording.rows`), finds every row's leader as the
replay does (:func:`~acc_fusion.truth.replay.pairs.build_pairs`: the file's own leader column,
or the nearest vehicle ahead in the same lane and carriageway) and turns the rows into
:class:`~acc_fusion.truth.trajectories.Trajectories`: time = frame × the frame period, the
recorded speed and acceleration along the driving direction, the lane within its carriageway
(``road`` = the carriageway), the gap and leader speed and length of the pairs, and an odometer
from the vehicle's first recorded position (a recording films a section, so this is the
distance since the vehicle entered the section, not since its trip began).  Vehicle ids are
made distinct across recordings.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from acc_fusion.truth.replay.pairs import build_pairs, in_track_order
from acc_fusion.truth.replay.source import ReplayConfig
from acc_fusion.truth.trajectories import COLUMNS, Trajectories


def replay_trajectories(
    config: ReplayConfig, warmup: float = 0.0, end: float | None = None, label: str = ""
) -> Trajectories:
    """The samples of every vehicle of ``config``'s recordings at recording times in
    ``[warmup, end]`` [s] (``end`` ``None``: to the end)."""
    parts: list[Trajectories] = []
    offset = 0
    recordings = config.open()
    for rec in recordings:
        dt = float(rec.dt)
        top = offset
        for f0, f1, _ in rec.windows(config.max_rows):
            rows = rec.rows(f0, f1)
            if rows is None:
                continue
            pairs = build_pairs(rows, config.recompute_leaders)
            rows, _, _ = in_track_order(rows)  # the order of the pairs
            time = rows.frame * dt
            keep = time >= warmup - 1e-9
            if end is not None:
                keep &= time <= end + 1e-9
            has = pairs.has_leader
            vid = rows.vid.astype(np.int64) + offset
            top = max(top, int(vid.max()) + 1)
            part = Trajectories(
                vehicle=vid,
                time=time,
                speed=rows.speed,
                accel=rows.accel,
                lane=rows.lane,
                road=rows.group,
                gap=np.where(has, pairs.gap, np.nan),
                lead_speed=np.where(has, pairs.lead_speed, np.nan),
                lead_length=np.where(has, pairs.lead_length, np.nan),
                odometer=rows.s,  # made relative below, over all windows
                dt=dt,
            )
            parts.append(part.subset(keep))
        offset = top
    name = label or ", ".join(getattr(r, "label", "") for r in recordings)
    if not parts:
        empty = np.zeros(0)
        return Trajectories(*(empty for _ in COLUMNS), dt=float(recordings[0].dt), label=name)
    traj = Trajectories.concat(parts, label=name)
    ids, inverse = np.unique(traj.vehicle, return_inverse=True)
    first = np.full(ids.size, np.inf)
    np.minimum.at(first, inverse, traj.odometer)
    return replace(traj, odometer=traj.odometer - first[inverse])
