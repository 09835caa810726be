r"""Synthetic recordings written in the highD, NGSIM and mapped-CSV formats, for the tests, the
benchmark and the examples (no data set is shipped: see the guide for where to get them).

:func:`simulate_traffic` drives vehicles with the Intelligent Driver Model (Treiber, Hennecke,
Helbing, *Congested traffic states in empirical observations and microscopic simulations*,
Phys. Rev. E 62, 2000) over a straight recorded section of ``section`` metres, lane by lane:

.. math::

    \dot v = a \Big[1 - (v / v_0)^4 - \big(s^*(v, \Delta v) / g\big)^2\Big], \qquad
    s^* = s_0 + v T + \frac{v \Delta v}{2 \sqrt{a b}}

with the gap :math:`g` to the vehicle ahead in the lane and :math:`\Delta v = v - v_l`; each
lane's first vehicle follows a lead whose speed swings (a sine, so followers close in and
fall back).  Vehicles enter at :math:`s = 0` with a headway of ``spacing`` metres, each with
its own desired speed, and leave at the end of the section.  One vehicle changes lane (a
lateral move over 2 s at ``lane_change_at`` seconds; its lane switches halfway), so a replay
sees a leader change.  Every quantity is the model's own ground truth, so a reader that
handles a format's geometry right reproduces the gaps exactly (up to the files' rounding).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acc_fusion.truth.replay.ngsim import FOOT

#: IDM parameters (Treiber 2000, table 1: car): a [m/s²], b [m/s²], s0 [m], T [s].
IDM_A, IDM_B, IDM_S0, IDM_T = 1.0, 1.5, 2.0, 1.2
#: Lane width [m].
LANE_WIDTH = 3.75


@dataclass
class Traffic:
    """Rows of a synthetic recording in road coordinates (``(M,)`` arrays, one per vehicle
    per frame, ordered by vehicle then frame): ``frame``, ``vid``, ``s`` (front bumper [m]),
    ``lane``, ``lat`` (centre [m]), ``speed`` [m/s], ``accel`` [m/s²], ``length`` [m],
    ``direction`` (1 or 2, highD's carriageways), ``leader`` (the vehicle ahead in the lane
    within the section, -1: none), the frame period ``dt`` [s], ``section`` [m] and the
    ``lanes`` per carriageway (lanes ``0 .. lanes - 1`` drive in direction 1, the others in
    direction 2; lane ``k``'s centre is at ``(k + 1/2) LANE_WIDTH``)."""

    frame: np.ndarray
    vid: np.ndarray
    s: np.ndarray
    lane: np.ndarray
    lat: np.ndarray
    speed: np.ndarray
    accel: np.ndarray
    length: np.ndarray
    direction: np.ndarray
    leader: np.ndarray
    dt: float
    section: float
    lanes: int

    def _leader_rows(self) -> np.ndarray:
        """Row index of each row's leader (-1: none)."""
        key = self.frame * np.int64(self.vid.max() + 1) + self.vid
        order = np.argsort(key)
        want = self.frame * np.int64(self.vid.max() + 1) + np.maximum(self.leader, 0)
        pos = np.minimum(np.searchsorted(key[order], want), key.size - 1)
        return np.where(self.leader >= 0, order[pos], -1)

    def gap(self) -> np.ndarray:
        """Bumper-to-bumper gap to the leader [m] (NaN: none)."""
        lr = self._leader_rows()
        has = lr >= 0
        return np.where(has, self.s[lr] - self.length[lr] - self.s, np.nan)

    def lead(self, name: str) -> np.ndarray:
        """The leader's ``name`` (NaN where none)."""
        lr = self._leader_rows()
        return np.where(lr >= 0, getattr(self, name)[lr], np.nan)


def simulate_traffic(
    lanes: int = 2,
    duration: float = 60.0,
    dt: float = 0.04,
    section: float = 420.0,
    spacing: float = 45.0,
    speed: float = 25.0,
    seed: int = 0,
    lane_change_at: float | None = 10.0,
) -> Traffic:
    """Simulate ``lanes`` lanes per carriageway (both highD directions) for ``duration``
    seconds at frame period ``dt`` (see the module docstring)."""
    rng = np.random.default_rng(seed)
    n_steps = int(round(duration / dt))
    cap = int(2 * lanes * (section / spacing + duration * speed / spacing + 4))
    s = np.full(cap, np.nan)
    v, a = np.zeros(cap), np.zeros(cap)
    lane = np.zeros(cap, dtype=np.int64)
    lat = np.zeros(cap)
    v0 = rng.uniform(0.9, 1.25, cap) * speed
    length = np.where(rng.random(cap) < 0.15, rng.uniform(10, 16, cap), rng.uniform(4.0, 5.0, cap))
    n = 0
    n_lanes = 2 * lanes  # lanes 0..lanes-1 direction 1, lanes..2 lanes-1 direction 2
    phase = rng.uniform(0, 2 * np.pi, n_lanes)
    changer, change_from = -1, 0
    out = []
    for k in range(n_steps):
        t = k * dt
        # Entries: a new vehicle where the lane's last one is ``spacing`` in.
        for ln in range(n_lanes):
            inlane = np.flatnonzero(lane[:n] == ln) if n else np.zeros(0, dtype=np.int64)
            inlane = inlane[np.isfinite(s[inlane])]
            last = s[inlane].min() - length[inlane[np.argmin(s[inlane])]] if inlane.size else 1e9
            if last >= spacing * rng.uniform(0.7, 1.3) and n < cap:
                s[n], lane[n], lat[n] = 0.0, ln, (ln + 0.5) * LANE_WIDTH
                v[n] = min(v0[n], speed) if not inlane.size else v[inlane[np.argmin(s[inlane])]]
                n += 1
        live = np.flatnonzero(np.isfinite(s[:n]))
        if lane_change_at is not None and changer < 0 and t >= lane_change_at:
            mid = live[(lane[live] == 0) & (s[live] > 0.2 * section) & (s[live] < 0.7 * section)]
            own, other = s[live[lane[live] == 0]], s[live[lane[live] == 1]]
            room = [
                i for i in mid
                if other.size and np.abs(other - s[i]).min() > 15.0
                and (other > s[i]).any() and (own > s[i]).any()
            ]  # fmt: skip
            if room:  # 15 m each way in the next lane, a leader in both lanes
                changer, change_from = int(room[0]), k
        if changer >= 0 and k - change_from <= int(round(2.0 / dt)):
            frac = (k - change_from) * dt / 2.0
            lat[changer] = (0.5 + frac) * LANE_WIDTH
            lane[changer] = 1 if frac >= 0.5 else 0
        # Leaders: next vehicle ahead in the lane.
        order = live[np.lexsort((s[live], lane[live]))]
        same = lane[order[1:]] == lane[order[:-1]]
        lead = np.full(cap, -1, dtype=np.int64)
        lead[order[:-1][same]] = order[1:][same]
        has = lead[live] >= 0
        lv = np.where(has, v[np.maximum(lead[live], 0)], 0.0)
        gap = np.where(has, s[np.maximum(lead[live], 0)] - length[np.maximum(lead[live], 0)]
                       - s[live], np.inf)  # fmt: skip
        # Each lane's first vehicle follows a virtual lead whose speed swings.
        first = ~has
        lead_speed = speed * (0.85 + 0.25 * np.sin(0.08 * t + phase[lane[live]]))
        lv = np.where(first, lead_speed, lv)
        gap = np.where(first, 60.0, gap)
        vi = v[live]
        star = IDM_S0 + vi * IDM_T + vi * (vi - lv) / (2.0 * np.sqrt(IDM_A * IDM_B))
        acc = IDM_A * (
            1.0 - (vi / v0[live]) ** 4 - (np.maximum(star, 0.0) / np.maximum(gap, 0.1)) ** 2
        )
        acc = np.clip(acc, -8.0, IDM_A)
        a[live] = acc
        inside = live[(s[live] - length[live] >= 0.0) & (s[live] <= section)]
        ahead = lead[inside]
        ahead = np.where((ahead >= 0) & (s[np.maximum(ahead, 0)] <= section), ahead, -1)
        out.append((np.full(inside.size, k), inside, s[inside], lane[inside], lat[inside],
                    v[inside], a[inside], length[inside], ahead))  # fmt: skip
        v_new = np.maximum(vi + acc * dt, 0.0)
        s[live] += 0.5 * (vi + v_new) * dt
        v[live] = v_new
        s[live[s[live] - length[live] > section]] = np.nan
    cols = [np.concatenate(c) for c in zip(*out, strict=True)]
    frame, vid, ss, ln, la, sp, ac, le, ld = cols
    order = np.lexsort((frame, vid))
    frame, vid, ss, ln, la, sp, ac, le, ld = (c[order] for c in cols)
    direction = np.where(ln < lanes, 1, 2)
    return Traffic(frame + 1, vid + 1, ss, ln, la, sp, ac, le, direction,
                   np.where(ld >= 0, ld + 1, -1), dt, section, lanes)  # fmt: skip


def _write(path: Path, columns: dict[str, np.ndarray], fmt: dict[str, str]) -> Path:
    """Write ``columns`` as CSV (``fmt``: a printf format per column, default ``%d``)."""
    names = list(columns)
    data = np.column_stack([columns[c].astype(float) for c in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="",
               fmt=[fmt.get(c, "%d") for c in names])  # fmt: skip
    return path


def write_highd(traffic: Traffic, folder: str | Path, number: int = 1) -> Path:
    """Write ``traffic`` as highD recording ``number`` (three files) in ``folder``; returns
    the tracks file.  Positions and speeds are rounded to 0.01 as highD's are; ``dhw`` is the
    bumper-to-bumper gap, ``thw = dhw / v``, ``ttc = dhw / (v - v_lead)`` (negative where the
    gap opens), all 0 without a leader."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    tr, stem = traffic, f"{number:02d}"
    left = tr.direction == 1
    x = np.where(left, tr.section + 20.0 - tr.s, tr.s - tr.length)
    width_y = 2.0
    median = 2.0  # the lower carriageway's markings start 2 m below the upper's last
    y = np.where(left, 0.0, median) + tr.lat - 0.5 * width_y
    sign = np.where(left, -1.0, 1.0)
    gap = tr.gap()
    has = np.isfinite(gap)
    lead_v = tr.lead("speed")
    with np.errstate(divide="ignore", invalid="ignore"):
        thw = np.where(has & (tr.speed > 0), gap / tr.speed, 0.0)
        ttc = np.where(has & (tr.speed != lead_v), gap / (tr.speed - lead_v), 0.0)
    tracks = {
        "frame": tr.frame, "id": tr.vid, "x": x, "y": y, "width": tr.length,
        "height": np.full(tr.s.size, width_y), "xVelocity": sign * tr.speed,
        "yVelocity": np.zeros(tr.s.size), "xAcceleration": sign * tr.accel,
        "yAcceleration": np.zeros(tr.s.size), "frontSightDistance": tr.section - tr.s,
        "backSightDistance": tr.s, "dhw": np.where(has, gap, 0.0), "thw": thw, "ttc": ttc,
        "precedingXVelocity": np.where(has, sign * lead_v, 0.0),
        "precedingId": np.maximum(tr.leader, 0), "followingId": np.zeros(tr.s.size),
        "laneId": np.where(left, 2 + tr.lane, 3 + tr.lane),
    }  # fmt: skip
    two = "%.2f"
    fmt = dict.fromkeys(
        ("x", "y", "width", "height", "xVelocity", "yVelocity", "xAcceleration",
         "yAcceleration", "frontSightDistance", "backSightDistance", "dhw", "thw", "ttc",
         "precedingXVelocity"), two,
    )  # fmt: skip
    path = _write(folder / f"{stem}_tracks.csv", tracks, fmt)
    ids, first = np.unique(tr.vid, return_index=True)
    last = np.r_[first[1:], tr.vid.size] - 1
    _write(
        folder / f"{stem}_tracksMeta.csv",
        {"id": ids, "width": tr.length[first], "height": np.full(ids.size, width_y),
         "initialFrame": tr.frame[first], "finalFrame": tr.frame[last],
         "numFrames": last - first + 1, "drivingDirection": tr.direction[first]},
        {"width": two, "height": two},
    )  # fmt: skip
    with (folder / f"{stem}_recordingMeta.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["id", "frameRate", "locationId", "speedLimit", "duration",
                    "upperLaneMarkings", "lowerLaneMarkings"])  # fmt: skip
        upper = ";".join(f"{m:g}" for m in LANE_WIDTH * np.arange(tr.lanes + 1))
        k = np.arange(tr.lanes, 2 * tr.lanes + 1)
        lower = ";".join(f"{m:g}" for m in median + LANE_WIDTH * k)
        w.writerow([number, round(1.0 / tr.dt), 1, -1, tr.frame.max() * tr.dt, upper, lower])
    return path


def write_ngsim(traffic: Traffic, path: str | Path) -> Path:
    """Write the lower carriageway of ``traffic`` (frame period 0.1 s) as an NGSIM CSV in
    feet: ``Local_Y`` the front centre, ``Space_Headway`` front to front."""
    tr = traffic
    keep = tr.direction == 2
    gap = tr.gap()[keep]
    has = np.isfinite(gap)
    spacing = np.where(has, gap + tr.lead("length")[keep], 0.0)
    v = tr.speed[keep]
    with np.errstate(divide="ignore", invalid="ignore"):
        thw = np.where(has, np.where(v > 0, spacing / v, 9999.99), 0.0)
    cols = {
        "Vehicle_ID": tr.vid[keep], "Frame_ID": tr.frame[keep],
        "Local_X": tr.lat[keep] / FOOT, "Local_Y": tr.s[keep] / FOOT,
        "v_length": tr.length[keep] / FOOT, "v_Width": np.full(v.size, 6.0),
        "v_Vel": v / FOOT, "v_Acc": tr.accel[keep] / FOOT, "Lane_ID": tr.lane[keep] + 1,
        "Preceding": np.maximum(tr.leader[keep], 0), "Space_Headway": spacing / FOOT,
        "Time_Headway": thw,
    }  # fmt: skip
    fmt = {k: "%.3f" for k in cols if k not in ("Vehicle_ID", "Frame_ID", "Lane_ID", "Preceding")}
    return _write(Path(path), cols, fmt)


def write_csv(traffic: Traffic, path: str | Path, leader: bool = True) -> Path:
    """Write the lower carriageway of ``traffic`` as a generic CSV: ``t`` [s], ``id``,
    ``s_mid`` (the centre's arc length [m]), ``y`` (lateral [m]), ``v``, ``a``, ``length`` and,
    with ``leader``, ``lead`` (0: none)."""
    tr = traffic
    keep = tr.direction == 2
    cols = {
        "t": tr.frame[keep] * tr.dt, "id": tr.vid[keep],
        "s_mid": tr.s[keep] - 0.5 * tr.length[keep], "y": tr.lat[keep] - 2 * LANE_WIDTH,
        "v": tr.speed[keep], "a": tr.accel[keep], "length": tr.length[keep],
    }  # fmt: skip
    if leader:
        cols["lead"] = np.maximum(tr.leader[keep], 0)
    fmt = {k: "%.4f" for k in ("t", "s_mid", "y", "v", "a", "length")}
    return _write(Path(path), cols, fmt)
