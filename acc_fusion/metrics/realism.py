r"""Does a traffic source drive like people?  Its kinematics beside naturalistic driving.

:func:`realism_stats` reduces the :class:`~acc_fusion.truth.trajectories.Trajectories` of a
source (every vehicle, every step, after a warm-up; SUMO, highway-env or a recording) to the
figures of :class:`RealismStats`; :func:`check` puts each beside its published reference
(:data:`REFERENCES`) and says whether it lies in the reference's band. Pure numpy.

The figures, over samples :math:`i` (one vehicle at one step of length :math:`\Delta t`):

Braking onsets per 100 km, at each threshold :math:`b` (:data:`BRAKING_THRESHOLDS`)
    An onset is a sample with :math:`a_i \le -b` whose vehicle was not braking that hard at
    its previous step (or has no previous step: it entered, or the warm-up ended, while
    braking), the count of ``scripts/hard_braking.py``; divided by the distance driven,
    :math:`\sum_i v_i \Delta t`.  Naturalistic studies count *events* of a deceleration
    beyond a trigger the same way (Simons-Morton et al. 2011, below).
Time headway of car following
    :math:`h_i = (g_i + \ell_{\text{lead},i}) / v_i`, front to front (bumper gap plus the
    leader's length), over samples with a leader and :math:`v_i >` :data:`MIN_SPEED`, kept
    where :math:`h_i \le` :data:`MAX_HEADWAY` (car following, as King et al. 2022 cut their
    headways): the median and the shares under 1 s and 2 s.
Time to collision
    :math:`\text{TTC}_i = g_i / (v_i - v_{\text{lead},i})` where closing
    (:math:`v_i > v_{\text{lead},i}`), infinite otherwise: the shares of car-following
    samples (as above) with TTC under 3 s and under 1.5 s.
Speed and acceleration
    Mean, standard deviation and percentiles of :math:`v_i` and :math:`a_i` over all samples
    (time-weighted, since every sample is one step).
Lane changes per 100 km
    Samples whose lane differs from the vehicle's previous step on the same road segment
    (a new road renumbers the lanes and is not counted), per distance driven.

References and their bands are in :data:`REFERENCES`, each with its definition and source;
where no published figure was found the figure is printed without one
(``status = "no reference"``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from acc_fusion.core.errors import InputError
from acc_fusion.truth.trajectories import Trajectories

#: Braking thresholds of the onset rates [m/s²]: ITE's comfortable deceleration 3.0, 8 mph/s
#: (3.6) and 0.45 g (4.4, Simons-Morton et al. 2011's hard stop).
BRAKING_THRESHOLDS = (3.0, 3.6, 4.4)
#: Car following: followers faster than this [m/s] ...
MIN_SPEED = 5.0
#: ... with a time headway up to this [s] (King et al. 2022's cut-off).
MAX_HEADWAY = 5.0
#: TTC thresholds of the exposure shares [s].
TTC_THRESHOLDS = (3.0, 1.5)
#: Percentiles of the speed and acceleration distributions.
SPEED_PERCENTILES = (5, 50, 95)
ACCEL_PERCENTILES = (1, 5, 95, 99)


# ---------------------------------------------------------------------- per-sample pieces
def track_order(traj: Trajectories) -> tuple[np.ndarray, np.ndarray]:
    """The sample order by vehicle then time, and, in that order, whether each sample
    continues its vehicle's previous one (same vehicle, one step later)."""
    order = np.lexsort((traj.time, traj.vehicle))
    v, t = traj.vehicle[order], traj.time[order]
    cont = np.zeros(order.size, dtype=bool)
    cont[1:] = (v[1:] == v[:-1]) & (np.abs(t[1:] - t[:-1] - traj.dt) <= 0.5 * traj.dt)
    return order, cont


def braking_onsets(traj: Trajectories, threshold: float) -> np.ndarray:
    """Per sample, whether a braking of ``threshold`` [m/s², > 0] or harder starts there."""
    if not threshold > 0:
        raise InputError(f"threshold must be > 0 m/s², got {threshold:g}")
    order, cont = track_order(traj)
    hard = traj.accel[order] <= -threshold
    start = hard.copy()
    start[1:] &= ~(hard[:-1] & cont[1:])
    out = np.zeros(len(traj), dtype=bool)
    out[order] = start
    return out


def car_following(traj: Trajectories) -> np.ndarray:
    """Per sample, whether it is car following: a leader, speed > :data:`MIN_SPEED` and a time
    headway up to :data:`MAX_HEADWAY`."""
    with np.errstate(invalid="ignore", divide="ignore"):
        h = (traj.gap + traj.lead_length) / traj.speed
    return np.isfinite(traj.gap) & (traj.speed > MIN_SPEED) & (h <= MAX_HEADWAY)


def time_headways(traj: Trajectories) -> np.ndarray:
    """The front-to-front time headways [s] of the car-following samples."""
    f = car_following(traj)
    return (traj.gap[f] + traj.lead_length[f]) / traj.speed[f]


def time_to_collision(traj: Trajectories) -> np.ndarray:
    """Per sample, gap over closing speed [s] where closing on a leader, else ``inf``."""
    closing = traj.speed - traj.lead_speed
    ok = np.isfinite(traj.gap) & (closing > 0)
    out = np.full(len(traj), np.inf)
    out[ok] = np.maximum(traj.gap[ok], 0.0) / closing[ok]
    return out


def lane_changes(traj: Trajectories) -> np.ndarray:
    """Per sample, whether its vehicle changed lane since its previous step on the same road
    (both lanes known)."""
    order, cont = track_order(traj)
    lane, road = traj.lane[order], traj.road[order]
    change = np.zeros(order.size, dtype=bool)
    change[1:] = (
        cont[1:]
        & (road[1:] == road[:-1])
        & (lane[1:] != lane[:-1])
        & (lane[1:] >= 0)
        & (lane[:-1] >= 0)
    )
    out = np.zeros(len(traj), dtype=bool)
    out[order] = change
    return out


def by_odometer(
    traj: Trajectories, flags: np.ndarray, bins: tuple[float, ...]
) -> tuple[np.ndarray, np.ndarray]:
    """The count of ``flags`` (per sample, e.g. :func:`braking_onsets`) and the kilometres
    driven in each bin of the distance driven since entering (edges ``bins`` [m])."""
    b = np.clip(np.searchsorted(bins, traj.odometer, side="right") - 1, 0, len(bins) - 2)
    counts = np.bincount(b, weights=flags.astype(float), minlength=len(bins) - 1)
    km = np.bincount(b, weights=traj.speed * traj.dt / 1000.0, minlength=len(bins) - 1)
    return counts, km


# ---------------------------------------------------------------------- the figures
@dataclass(frozen=True)
class Figure:
    """One figure of the check: its key, what it is, its unit and its value."""

    key: str
    label: str
    unit: str
    value: float


@dataclass(frozen=True)
class RealismStats:
    """The figures of :func:`realism_stats` (NaN where undefined: no driving, no following).

    Attributes:
        label: what the samples are of.
        km: kilometres driven.
        hours: vehicle-hours driven.
        vehicles: distinct vehicles.
        thresholds: braking thresholds [m/s²]; ``onsets`` their onset counts.
        braking_share: per threshold, the share of driving time braking that hard.
        following_share: share of the driving time in car following.
        headways: car-following headway samples.
        headway_median, headway_below_1s, headway_below_2s: their median [s] and shares.
        ttc_below: per :data:`TTC_THRESHOLDS`, the share of car-following samples under it.
        speed_mean, speed_sd: [m/s]; ``speed_percentiles`` at :data:`SPEED_PERCENTILES`.
        accel_mean, accel_sd: [m/s²]; ``accel_percentiles`` at :data:`ACCEL_PERCENTILES`.
        lane_changes: lane changes counted.
    """

    label: str
    km: float
    hours: float
    vehicles: int
    thresholds: tuple[float, ...]
    onsets: tuple[int, ...]
    braking_share: tuple[float, ...]
    following_share: float
    headways: int
    headway_median: float
    headway_below_1s: float
    headway_below_2s: float
    ttc_below: tuple[float, ...]
    speed_mean: float
    speed_sd: float
    speed_percentiles: tuple[float, ...]
    accel_mean: float
    accel_sd: float
    accel_percentiles: tuple[float, ...]
    lane_changes: int

    def per_100km(self, count: float) -> float:
        """``count`` per 100 km of this driving (NaN without driving)."""
        return 100.0 * count / self.km if self.km > 0 else math.nan

    def onsets_per_100km(self, threshold: float) -> float:
        """Braking onsets of ``threshold`` (one of :attr:`thresholds`) per 100 km."""
        return self.per_100km(self.onsets[self.thresholds.index(threshold)])

    def figures(self) -> list[Figure]:
        """The figures of the check, in the order of the table."""
        out = [
            Figure(f"onsets_{b:g}", f"braking onsets ≥ {b:g} m/s²", "per 100 km", self.per_100km(n))
            for b, n in zip(self.thresholds, self.onsets, strict=True)
        ]
        out += [
            Figure("headway_median", "time headway, median", "s", self.headway_median),
            Figure("headway_below_1s", "time headway < 1 s", "share", self.headway_below_1s),
            Figure("headway_below_2s", "time headway < 2 s", "share", self.headway_below_2s),
            Figure("following_share", "time in car following", "share", self.following_share),
        ]
        out += [
            Figure(f"ttc_below_{t:g}s", f"car following with TTC < {t:g} s", "share", s)
            for t, s in zip(TTC_THRESHOLDS, self.ttc_below, strict=True)
        ]
        out.append(
            Figure("lane_changes", "lane changes", "per 100 km", self.per_100km(self.lane_changes))
        )
        out += _distribution("speed", "speed", "m/s", self.speed_mean, self.speed_sd,
                             SPEED_PERCENTILES, self.speed_percentiles)  # fmt: skip
        out += _distribution("accel", "acceleration", "m/s²", self.accel_mean, self.accel_sd,
                             ACCEL_PERCENTILES, self.accel_percentiles)  # fmt: skip
        return out


def _distribution(
    key: str,
    label: str,
    unit: str,
    mean: float,
    sd: float,
    percentiles: tuple[int, ...],
    values: tuple[float, ...],
) -> list[Figure]:
    """The figures of a distribution: its mean, sd and percentiles."""
    out = [Figure(f"{key}_mean", f"{label}, mean", unit, mean)]
    out.append(Figure(f"{key}_sd", f"{label}, sd", unit, sd))
    out += [
        Figure(f"{key}_p{p:02d}", f"{label}, p{p}", unit, x)
        for p, x in zip(percentiles, values, strict=True)
    ]
    return out


def _share(mask: np.ndarray) -> float:
    return float(mask.mean()) if mask.size else math.nan


def _percentiles(x: np.ndarray, ps: tuple[int, ...]) -> tuple[float, ...]:
    if not x.size:
        return tuple(math.nan for _ in ps)
    return tuple(float(v) for v in np.percentile(x, ps))


def realism_stats(
    traj: Trajectories, thresholds: tuple[float, ...] = BRAKING_THRESHOLDS
) -> RealismStats:
    """The figures of :class:`RealismStats` over every sample of ``traj`` (apply the warm-up
    first: :meth:`Trajectories.after`)."""
    onsets, shares = [], []
    for b in thresholds:
        onsets.append(int(braking_onsets(traj, b).sum()))
        shares.append(_share(traj.accel <= -b))
    follow = car_following(traj)
    h = time_headways(traj)
    ttc = time_to_collision(traj)[follow]
    n = len(traj)
    return RealismStats(
        label=traj.label,
        km=traj.km,
        hours=traj.hours,
        vehicles=int(np.unique(traj.vehicle).size),
        thresholds=tuple(float(b) for b in thresholds),
        onsets=tuple(onsets),
        braking_share=tuple(shares),
        following_share=_share(follow),
        headways=int(h.size),
        headway_median=float(np.median(h)) if h.size else math.nan,
        headway_below_1s=_share(h < 1.0),
        headway_below_2s=_share(h < 2.0),
        ttc_below=tuple(_share(ttc < t) for t in TTC_THRESHOLDS),
        speed_mean=float(traj.speed.mean()) if n else math.nan,
        speed_sd=float(traj.speed.std()) if n else math.nan,
        speed_percentiles=_percentiles(traj.speed, SPEED_PERCENTILES),
        accel_mean=float(traj.accel.mean()) if n else math.nan,
        accel_sd=float(traj.accel.std()) if n else math.nan,
        accel_percentiles=_percentiles(traj.accel, ACCEL_PERCENTILES),
        lane_changes=int(lane_changes(traj).sum()),
    )
