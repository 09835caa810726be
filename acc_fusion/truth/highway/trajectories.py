"""Every vehicle of a highway-env run at every simulation step, for the realism check.

:func:`highway_trajectories` drives a :class:`~acc_fusion.truth.highway.source.HighwaySource`
with ``pairs="all"`` (every vehicle on the road is an ego) and no brake request (highway-env's
own drivers: IDM and MOBIL for the traffic, the controlled vehicle holding its lane and target
speed), and turns each frame into samples of
:class:`~acc_fusion.truth.trajectories.Trajectories`: the frame's speed, acceleration, gap and
leader speed (so the leader is the source's, on the vehicle's own lane), the leader's
``LENGTH``, the lane index and road ``(from, to)`` of highway-env's ``lane_index``, and an
odometer summed from the speeds.  Time is the time within the episode, so the warm-up applies
to every episode (each starts from highway-env's random placement); vehicle ids are never
reused across episodes.  Crashed vehicles are left out from the step after their crash, as
the source does.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from tqdm.auto import tqdm

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_range
from acc_fusion.truth.highway.config import HighwayConfig
from acc_fusion.truth.highway.source import HighwaySource
from acc_fusion.truth.trajectories import COLUMNS, Trajectories


def highway_trajectories(
    config: HighwayConfig,
    warmup: float = 0.0,
    end: float | None = None,
    *,
    progress: bool = True,
    label: str = "",
) -> Trajectories:
    """The samples of every vehicle of ``config``'s episodes (run with ``pairs="all"``) from
    ``warmup`` [s into each episode] on, over ``config.episodes`` episodes or, with ``end``,
    over episodes one after another until ``end`` seconds of simulated time.

    Raises:
        ConfigError: ``warmup`` is not shorter than an episode, or a bad config.
    """
    if end is not None:
        check_range("end", end, 0.0, math.inf, lo_open=True, hi_open=True)
        config = replace(config, episodes=10_000_000)  # the run stops at ``end``
    columns: dict[str, list[np.ndarray]] = {name: [] for name in COLUMNS}
    roads: dict[tuple, int] = {}
    odometer: dict[int, float] = {}
    with HighwaySource(replace(config, pairs="all")) as src:
        if not 0 <= warmup < src.duration:
            raise ConfigError(
                f"warmup must be in [0, {src.duration:g}) s, the length of a {config.env} "
                f"episode (it applies to every episode), got {warmup:g}"
            )
        total = end if end is not None else config.episodes * src.duration
        bar = tqdm(total=round(total), disable=None if progress else True, desc=config.env)
        while True:
            _append(src, columns, roads, odometer, warmup)
            bar.update(round(src.t) - bar.n)
            if src.done or (end is not None and src.t >= end - 1e-9):
                break
            src.advance()
        bar.close()
        dt = src.dt
    return Trajectories.from_columns(columns, dt, label or config.env)


def _append(
    src: HighwaySource,
    columns: dict[str, list[np.ndarray]],
    roads: dict[tuple, int],
    odometer: dict[int, float],
    warmup: float,
) -> None:
    """Append the samples of the source's current frame (after the warm-up)."""
    frame, env = src.frame(), src.env
    slots = np.flatnonzero(src.active)
    vehicles = src.vehicles
    ids = src.road_ids[src.slot_vehicle_index[slots]]
    speed = frame.ego_speed[slots]
    for vid, v in zip(ids.tolist(), speed.tolist(), strict=True):
        odometer[vid] = odometer.get(vid, -v * src.dt) + v * src.dt  # 0 at the first sample
    if env.time < warmup - 1e-9 or not slots.size:
        return
    lengths = dict(zip(src.road_ids.tolist(), (v.LENGTH for v in env.road.vehicles), strict=True))
    lane = [vehicles[i].lane_index for i in slots]
    lead = frame.leader_id[slots]
    columns["vehicle"].append(ids.astype(np.int64))
    columns["time"].append(np.full(slots.size, float(env.time)))
    columns["speed"].append(speed)
    columns["accel"].append(frame.ego_accel[slots])
    columns["lane"].append(np.array([li[2] for li in lane], dtype=np.int64))
    columns["road"].append(
        np.array([roads.setdefault(li[:2], len(roads)) for li in lane], dtype=np.int64)
    )
    has = lead >= 0
    columns["gap"].append(np.where(has, frame.gap[slots], np.nan))
    columns["lead_speed"].append(np.where(has, frame.lead_speed[slots], np.nan))
    columns["lead_length"].append(
        np.array([lengths.get(x, np.nan) if x >= 0 else np.nan for x in lead.tolist()])
    )
    columns["odometer"].append(np.array([odometer[x] for x in ids.tolist()]))
