"""The tracker against an independent reference: the same detections through Stone Soup's Kalman
predictor and updater, distance hypothesiser and 2-D-assignment GNN.

The scene is a straight road at constant ego speed (the ego-motion compensation is then the
identity, which Stone Soup does not have) with two egos: two targets close together, two
crossing laterally, one appearing, clutter, and a sensor dropout.  Stone Soup's state vector is
ordered ``[x, vx, y, vy]`` as the tracker's.  The test runs twice: with ``SquaredMahalanobis``
and ``missed_distance`` the chi-square gate, the 2-D assignment minimises the same sum of
squared distances as the tracker; with ``Mahalanobis`` and the gate's square root, the gate is
the same but the sum is one of distances, which can prefer another assignment where two pairs
compete closely (not in this scene).  Track birth, M-of-N confirmation and deletion are
written out below with the rules of the tracker's docstring.
"""

from __future__ import annotations

from datetime import datetime, timedelta

import numpy as np
import pytest
from tracking_scene import Scene, detect

from acc_fusion.fusion.tracking.tracker import Tracker, TrackerConfig

pytest.importorskip("stonesoup")

from stonesoup.dataassociator.neighbour import GNNWith2DAssignment  # noqa: E402
from stonesoup.hypothesiser.distance import DistanceHypothesiser  # noqa: E402
from stonesoup.measures import Mahalanobis, SquaredMahalanobis  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel,
    ConstantVelocity,
)
from stonesoup.predictor.kalman import KalmanPredictor  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402
from stonesoup.updater.kalman import KalmanUpdater  # noqa: E402

DT = 0.05
START = datetime(2026, 1, 1)


def _scene() -> Scene:
    ego0 = np.array([
        [1, 40.0, 0.0, 15.0, 0.0],  # the lead, closing at 5 m/s
        [2, 41.5, 0.8, 15.0, 0.0],  # close to it
        [3, 60.0, -3.0, 21.0, 0.8],  # these two cross laterally
        [4, 62.0, 3.0, 21.0, -0.8],
        [5, 30.0, 3.5, 23.0, 0.0],  # appears at 1.5 s
    ])  # fmt: skip
    ego1 = np.array([[6, 25.0, -0.2, 18.0, 0.0], [7, 55.0, 3.4, 25.0, 0.0]])
    return Scene([ego0, ego1], np.array([20.0, 22.0]), np.zeros(2), appear={5: 1.5})


def _converted(r, a, sr, sa):
    j = np.array([[np.cos(a), -r * np.sin(a)], [np.sin(a), r * np.cos(a)]])
    return np.array([r * np.cos(a), r * np.sin(a)]), j @ np.diag([sr**2, sa**2]) @ j.T


def _birth(det, k, cfg):
    z, rz = _converted(det.range[k], det.azimuth[k], det.range_std[k], det.azimuth_std[k])
    e = np.array([np.cos(det.azimuth[k]), np.sin(det.azimuth[k])])
    n = np.array([-e[1], e[0]])
    pv = det.range_rate_std[k] ** 2 * np.outer(e, e) + cfg.init_velocity_std**2 * np.outer(n, n)
    x = np.array([z[0], det.range_rate[k] * e[0], z[1], det.range_rate[k] * e[1]])
    p = np.zeros((4, 4))
    p[np.ix_([0, 2], [0, 2])], p[np.ix_([1, 3], [1, 3])] = rz, pv
    return x, p


class Reference:
    """The tracker's rules around Stone Soup's filter and GNN, one ego."""

    def __init__(self, cfg: TrackerConfig, next_id: list[int], squared: bool):
        self.cfg, self.next_id = cfg, next_id
        q = cfg.q
        self.predictor = KalmanPredictor(
            CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
        )
        self.updater = KalmanUpdater(measurement_model=None)
        measure, gate = (
            (SquaredMahalanobis(), cfg.gate_value)
            if squared
            else (Mahalanobis(), cfg.gate_value**0.5)
        )
        hyp = DistanceHypothesiser(self.predictor, self.updater, measure, missed_distance=gate)
        self.gnn = GNNWith2DAssignment(hyp)
        self.tracks: dict[int, dict] = {}

    def step(self, det, rows, e, when):
        cfg = self.cfg
        dets = []
        for k in range(rows[e], rows[e + 1]):
            z, rz = _converted(det.range[k], det.azimuth[k], det.range_std[k], det.azimuth_std[k])
            model = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=rz)
            dets.append(
                Detection(
                    z.reshape(2, 1), timestamp=when, measurement_model=model, metadata={"k": k}
                )
            )
        for t in self.tracks.values():
            t["detection"] = -1
        if not det.online:
            for t in self.tracks.values():
                t["track"].append(self.predictor.predict(t["track"], timestamp=when))
        else:
            by_track = {id(t["track"]): t for t in self.tracks.values()}
            hyps = self.gnn.associate({t["track"] for t in self.tracks.values()}, set(dets), when)
            for track, hyp in hyps.items():
                t = by_track[id(track)]
                t["scans"] += 1
                if hyp:
                    track.append(self.updater.update(hyp))
                    t["detection"] = hyp.measurement.metadata["k"]
                    t["hits"], t["misses"], t["last"] = t["hits"] + 1, 0, when
                else:
                    track.append(hyp.prediction)
                    t["misses"] += 1
        for tid, t in list(self.tracks.items()):
            if not t["confirmed"]:
                if t["hits"] >= cfg.confirm_m:
                    t["confirmed"] = True
                elif t["hits"] + cfg.confirm_n - t["scans"] < cfg.confirm_m:
                    del self.tracks[tid]
                    continue
            coast = (when - t["last"]).total_seconds()
            if (t["confirmed"] and t["misses"] >= cfg.delete_misses) or coast > cfg.max_coast:
                del self.tracks[tid]
        if det.online:
            taken = {t["detection"] for t in self.tracks.values()}
            for d in dets:
                if d.metadata["k"] in taken:
                    continue
                x, p = _birth(det, d.metadata["k"], cfg)
                self.tracks[self.next_id[0]] = {
                    "track": Track([GaussianState(x.reshape(4, 1), p, when)]),
                    "detection": d.metadata["k"], "hits": 1, "misses": 0, "scans": 1,
                    "confirmed": cfg.confirm_m <= 1, "last": when,
                }  # fmt: skip
                self.next_id[0] += 1


@pytest.mark.parametrize("squared", [True, False])
def test_the_tracker_matches_stone_soup_step_by_step(squared):
    """With ``Mahalanobis`` (``squared`` false) the gate is the same and, in this scene where no
    two pairs compete that closely, so is every assignment."""
    cfg = TrackerConfig(q=2.0, max_coast=0.33)
    scene = _scene()
    rng = np.random.default_rng(11)
    tracker = Tracker("radar", cfg, n_egos=2)
    next_id = [0]
    refs = [Reference(cfg, next_id, squared) for _ in range(2)]
    worst, compared, confirmed = 0.0, 0, set()
    for i in range(100):
        when = START + timedelta(microseconds=50_000 * i)
        online = not 40 <= i < 46  # a dropout of 0.3 s
        det = detect(scene, i * DT, "radar", rng, online=online, clutter=2)
        tracks = tracker.step(det, scene.speed, scene.yaw_rate, DT)
        rows = det.rows()
        for e, ref in enumerate(refs):
            ref.step(det, rows, e, when)
            mine = {int(tracks.track_id[e, s]): s for s in np.flatnonzero(tracks.valid[e])}
            assert sorted(mine) == sorted(ref.tracks), (i, e)
            for tid, s in mine.items():
                t = ref.tracks[tid]
                state = t["track"].state
                worst = max(
                    worst,
                    np.abs(tracks.state[e, s] - state.state_vector.ravel()).max(),
                    np.abs(tracks.cov[e, s] - state.covar).max(),
                )
                assert tracks.detection[e, s] == t["detection"], (i, e, tid)
                assert tracks.confirmed[e, s] == t["confirmed"], (i, e, tid)
                if t["confirmed"]:
                    confirmed.add(int(tracks.object_id[e, s]))
                compared += 1
    assert worst < 1e-9, worst
    assert compared > 500
    assert {1, 2, 3, 4, 5, 6, 7} <= confirmed  # every target was tracked
