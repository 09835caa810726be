"""The per-sensor tracker, the numba assignment, the track-to-track association and the bridge to
the 1-D federated filter."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment
from tracking_scene import Scene, detect

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError
from acc_fusion.fusion.config import FilterConfig, FusionConfig
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.fusion.tracking.assignment import Scratch, assign, gnn
from acc_fusion.fusion.tracking.association import (
    AssociationConfig,
    TrackAssociator,
    fused_measurements,
)
from acc_fusion.fusion.tracking.tracker import Tracker, TrackerConfig, Tracks
from acc_fusion.sensors.detections import Detections

DT = 0.05


def _one_target(y=0.0, vx=-5.0, speed=20.0):
    """One ego at ``speed`` behind a vehicle 40 m ahead closing at ``vx``."""
    return Scene([np.array([[7, 40.0, y, speed + vx, 0.0]])], np.array([speed]), np.zeros(1))


def _run(scene, tracker, hits, rng, online=None, start=0):
    """Step ``tracker`` through ``hits`` (bool per frame: the object is detected); returns the
    Tracks of every frame."""
    out = []
    for i, hit in enumerate(hits):
        t = (start + i) * DT
        on = True if online is None else online[i]
        det = detect(scene, t, tracker.sensor, rng, online=on, p_detect=float(hit))
        out.append(tracker.step(det, scene.speed, scene.yaw_rate, DT))
    return out


@pytest.mark.parametrize(
    "hits, confirmed_at, deleted_at",
    [
        ([1, 1, 1], 2, None),
        ([1, 0, 1, 0, 1], 4, None),
        ([1, 0, 0, 1, 0], None, 4),  # 2 hits in 5 scans
        ([1, 0, 0, 0], None, 3),  # 1 + (5 - 4) < 3: can no longer be confirmed
    ],
)
def test_a_track_is_confirmed_after_m_of_n_hits_or_deleted(rng, hits, confirmed_at, deleted_at):
    tracker = Tracker("radar", TrackerConfig(confirm_m=3, confirm_n=5), n_egos=1)
    frames = _run(_one_target(), tracker, hits, rng)
    confirmed = [bool(f.confirmed.any()) for f in frames]
    valid = [bool(f.valid.any()) for f in frames]
    expect_confirmed = [confirmed_at is not None and i >= confirmed_at for i in range(len(hits))]
    assert confirmed == expect_confirmed
    expect_valid = [deleted_at is None or i < deleted_at for i in range(len(hits))]
    assert valid == expect_valid


def test_a_confirmed_track_is_deleted_after_the_misses_in_a_row(rng):
    tracker = Tracker("radar", TrackerConfig(delete_misses=3, max_coast=10.0), n_egos=1)
    frames = _run(_one_target(), tracker, [1, 1, 1, 0, 0, 1, 0, 0, 0], rng)
    assert [int(f.misses[0, 0]) if f.valid[0, 0] else -1 for f in frames] == [
        0, 0, 0, 1, 2, 0, 1, 2, -1,
    ]  # fmt: skip
    assert frames[5].hits[0, 0] == 4 and frames[5].detection[0, 0] == 0


def test_a_track_coasting_longer_than_max_coast_is_deleted(rng):
    tracker = Tracker("radar", TrackerConfig(max_coast=0.2, delete_misses=100), n_egos=1)
    frames = _run(_one_target(), tracker, [1, 1, 1, 0, 0, 0, 0, 0], rng)
    assert [bool(f.valid.any()) for f in frames] == [True] * 7 + [False]
    assert frames[6].age[0, 0] == pytest.approx(6 * DT)


def test_false_detections_are_not_confirmed_and_ids_are_never_reused(rng):
    scene = _one_target()
    tracker = Tracker("radar", TrackerConfig(), n_egos=1)
    ids = set()
    for i in range(100):
        det = detect(scene, i * DT, "radar", rng, clutter=3)
        tracks = tracker.step(det, scene.speed, scene.yaw_rate, DT)
        ids.update(tracks.track_id[tracks.valid].tolist())
        confirmed = tracks.confirmed & tracks.valid
        assert set(tracks.object_id[confirmed].tolist()) <= {7}
    assert confirmed.sum() == 1
    assert len(ids) > 50  # clutter started many tentative tracks, each with a new id
    tracker.reset()
    det = detect(scene, 100 * DT, "radar", rng)
    assert tracker.step(det, scene.speed, scene.yaw_rate, DT).track_id[0, 0] > max(ids)


def test_two_crossing_targets_keep_their_ids(rng):
    # Two vehicles 40 and 42 m ahead change lanes across each other at 1.2 m/s.
    objects = np.array([[1, 40.0, -2.5, 20.0, 1.2], [2, 42.0, 2.5, 20.0, -1.2]])
    scene = Scene([objects], np.array([20.0]), np.zeros(1))
    tracker = Tracker("radar", TrackerConfig(), n_egos=1)
    owner: dict[int, int] = {}
    for i in range(100):  # they cross at t = 2.08 s
        tracks = tracker.step(detect(scene, i * DT, "radar", rng), scene.speed, scene.yaw_rate, DT)
        confirmed = tracks.valid & tracks.confirmed
        assert confirmed.sum() == (2 if i >= 2 else 0)
        for tid, obj in zip(tracks.track_id[confirmed], tracks.object_id[confirmed], strict=True):
            assert owner.setdefault(int(tid), int(obj)) == int(obj)
    assert sorted(owner.values()) == [1, 2]


@pytest.mark.parametrize("compensate", [True, False])
def test_ego_motion_compensation_keeps_a_stationary_object_still(rng, compensate):
    """An ego drives a 100 m radius curve at 20 m/s; a sign post 60 m ahead and 10 m left stays
    where it is in the world, with a ground speed of 0, only when the tracker knows the yaw
    rate (without it the track follows the post's 12 m/s lateral sweep)."""
    scene = Scene([np.array([[5, 60.0, 10.0, 0.0, 0.0]])], np.array([20.0]), np.array([0.2]))
    tracker = Tracker("radar", TrackerConfig(q=0.5), n_egos=1)
    errors, speeds = [], []
    for i in range(60):
        t = i * DT
        yaw = scene.yaw_rate * compensate
        tracks = tracker.step(detect(scene, t, "radar", rng), scene.speed, yaw, DT)
        if i < 20:
            continue
        for x in tracks.state[tracks.confirmed]:
            world = scene.world(t, 0, np.array([x[0], x[2]]))
            errors.append(np.hypot(*(world - [60.0, 10.0])))
            speeds.append(np.hypot(x[1] + scene.speed[0], x[3]))  # the ground speed
    if compensate:
        assert len(errors) >= 40
        assert np.mean(errors) < 0.3 and np.mean(speeds) < 0.5
    else:
        assert len(errors) < 20 or np.mean(speeds) > 5.0  # it sees the post sweep sideways


@pytest.mark.parametrize("told", [True, False])
def test_a_track_follows_the_egos_sideways_jump_only_when_told_it(rng, told):
    """SUMO moves an ego into the next lane within one step: the car it follows, 40 m ahead,
    is 3.5 m to its right at once.  Told the jump (``ego_shift``, as the ego's odometry would
    have followed a real lane change), the tracker keeps the car's track; not told, the
    detection falls outside the gate and a new track begins."""
    before = Scene([np.array([[7, 40.0, 0.0, 20.0, 0.0]])], np.array([20.0]), np.zeros(1))
    after = Scene([np.array([[7, 40.0, -3.5, 20.0, 0.0]])], np.array([20.0]), np.zeros(1))
    tracker = Tracker("radar", TrackerConfig(), n_egos=1)
    ids, ys = [], []
    for i in range(40):
        scene, jump = (before, 0.0) if i < 20 else (after, 3.5 if i == 20 else 0.0)
        shift = np.array([jump if told else 0.0])
        tracks = tracker.step(detect(scene, i * DT, "radar", rng), scene.speed, scene.yaw_rate,
                              DT, ego_shift=shift)  # fmt: skip
        if i >= 10:
            ids.append(set(tracks.track_id[tracks.confirmed].tolist()))
            ys.append(tracks.state[tracks.confirmed][:, 2])
    if told:
        assert all(k == ids[0] and len(k) == 1 for k in ids)
        assert abs(ys[-1][0] + 3.5) < 0.3
    else:
        assert ids[-1] and ids[-1].isdisjoint(ids[0])


def test_the_ego_speed_change_is_compensated(rng):
    """An ego speeding up at 3 m/s² passes a parked car: its relative velocity changes by 6 m/s
    in 2 s, which the compensation takes from the ego's speeds (the track's ground speed
    stays 0 though the model's acceleration noise is small)."""
    scene = Scene([np.array([[5, 80.0, 3.0, 0.0, 0.0]])], np.array([15.0]), np.zeros(1),
                  accel=np.array([3.0]))  # fmt: skip
    tracker = Tracker("radar", TrackerConfig(q=0.05), n_egos=1)
    ground = []
    for i in range(40):
        t = i * DT
        speed = scene.speed_at(t)
        tracks = tracker.step(detect(scene, t, "radar", rng), speed, scene.yaw_rate, DT)
        if i >= 10:
            ground.extend(tracks.state[tracks.confirmed][:, 1] + speed[0])
    assert len(ground) >= 30 and abs(np.mean(ground)) < 0.3


def test_tracks_coast_between_the_sensor_samples(rng):
    scene = _one_target(vx=-5.0)
    tracker = Tracker("infrared", TrackerConfig(max_coast=1.0), n_egos=1)
    online = [i % 2 == 0 for i in range(30)]
    frames = _run(scene, tracker, [True] * 30, rng, online=online)
    for i in range(7, 30, 2):  # offline frames: predicted by vx dt, no miss, no detection
        before, now = frames[i - 1], frames[i]
        assert now.valid[0, 0] and now.confirmed[0, 0]
        assert now.misses[0, 0] == 0 and now.detection[0, 0] == -1
        assert now.hits[0, 0] == before.hits[0, 0]
        step = now.state[0, 0, 0] - before.state[0, 0, 0]
        assert step == pytest.approx(before.state[0, 0, 1] * DT, abs=1e-9)
        assert now.cov[0, 0, 0, 0] > before.cov[0, 0, 0, 0]
    assert frames[-1].hits[0, 0] == 15


@pytest.mark.parametrize(
    "data, message",
    [
        ({"q": -1.0}, "tracker.q must be in [0, 10000]"),
        ({"gate_probability": 1.0}, "tracker.gate_probability must be in (0, 1)"),
        ({"gate": 0}, "tracker.gate must be in (0, 1e+06]"),
        ({"confirm_m": 6}, "tracker.confirm_m must be <= confirm_n"),
        ({"confirm_n": 0}, "tracker.confirm_n must be a whole number in [1, 64]"),
        ({"delete_misses": 2.5}, "delete_misses must be a whole number"),
        ({"max_tracks": 0}, "tracker.max_tracks must be a whole number in [1, 4096]"),
        ({"init_velocity_std": 0.0}, "tracker.init_velocity_std must be in (0, 1000]"),
        ({"max_coast": "1"}, "max_coast must be a number"),
        ({"gates": 3.0}, "unknown key 'gates'"),
    ],
)
def test_a_bad_tracker_config_is_one_line_config_error(data, message):
    with pytest.raises(ConfigError) as info:
        from_mapping(TrackerConfig, data)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_the_gate_follows_the_probability_unless_given():
    assert TrackerConfig(gate_probability=0.99).gate_value == pytest.approx(9.2103404)
    assert TrackerConfig(gate=4.0).gate_value == 4.0
    with pytest.raises(ConfigError, match="association.gate_probability"):
        AssociationConfig(gate_probability=0.0)


def test_the_numba_assignment_equals_scipys_on_random_gated_matrices():
    rng = np.random.default_rng(3)
    for _ in range(300):
        n_r, n_c = rng.integers(0, 9), rng.integers(0, 12)
        d2 = rng.exponential(4.0, (n_r, n_c))
        gate = 6.0
        scratch = Scratch(max(n_r, 1), max(n_c, 1))
        out = np.empty(max(n_r, 1), np.int64)
        gnn(d2, n_r, n_c, gate, out, scratch.arrays())
        # the reference: scipy on Stone Soup's matrix [gated distances | missed diagonal]
        cost = np.full((n_r, n_c + n_r), np.inf)
        cost[:, :n_c] = np.where(d2 < gate, d2, np.inf)
        cost[np.arange(n_r), n_c + np.arange(n_r)] = gate
        rows, cols = linear_sum_assignment(cost)
        expected = np.where(cols < n_c, cols, -1)
        np.testing.assert_array_equal(out[:n_r], expected)
    # and the bare solver on rectangular matrices with forbidden entries
    for _ in range(200):
        n_r = int(rng.integers(1, 8))
        n_c = int(rng.integers(n_r, 10))
        c = rng.normal(size=(n_r, n_c))
        c[rng.random((n_r, n_c)) < 0.3] = np.inf
        c[np.arange(n_r), np.arange(n_r)] = rng.normal(size=n_r)  # keep it feasible
        s = Scratch(n_r, n_c - n_r)
        col4row, row4col = s.col4row, s.row4col
        assert assign(c, n_r, n_c, col4row, row4col, s.u, s.v, s.shortest, s.path, s.remaining,
                      s.sr, s.sc)  # fmt: skip
        _, cols = linear_sum_assignment(c)
        assert c[np.arange(n_r), col4row[:n_r]].sum() == pytest.approx(
            c[np.arange(n_r), cols].sum()
        )
        np.testing.assert_array_equal(col4row[:n_r], cols)


def test_an_infeasible_assignment_is_reported():
    s = Scratch(2, 0)
    c = np.array([[1.0, np.inf], [2.0, np.inf]])
    assert not assign(c, 2, 2, s.col4row, s.row4col, s.u, s.v, s.shortest, s.path, s.remaining,
                      s.sr, s.sc)  # fmt: skip


def _two_sensor_scene():
    """Two egos: ego 0 closes on a lead in its lane with a car in the next lane; ego 1 follows
    a lead that brakes... at constant relative speed, with a vehicle appearing later."""
    objects = [
        np.array([[1, 45.0, 0.2, 15.0, 0.0], [2, 30.0, 3.6, 24.0, 0.0]]),
        np.array([[3, 35.0, -0.3, 22.0, 0.0], [4, 70.0, 3.4, 25.0, 0.0]]),
    ]
    return Scene(objects, np.array([20.0, 22.0]), np.zeros(2), appear={4: 1.5})


def test_trackers_association_and_the_federated_filter_follow_the_lead(rng):
    scene = _two_sensor_scene()
    cfg = TrackerConfig()
    radar, infrared = Tracker("radar", cfg, 2), Tracker("infrared", cfg, 2)
    assoc = TrackAssociator(AssociationConfig(), 2, (cfg.max_tracks, cfg.max_tracks))
    fusion = FusionConfig(method="federated", filter=FilterConfig(dt=DT))
    n_slots = assoc.n_slots
    est = make_estimator(fusion, ("radar", "infrared"), 2 * n_slots)
    ir_std = (1.0, 0.002, 0.3)
    errors, paired_ids = [], {0: set(), 1: set()}
    for i in range(120):
        t = i * DT
        d_r = detect(scene, t, "radar", rng, clutter=2)
        d_i = detect(scene, t, "infrared", rng, online=i % 2 == 0, std=ir_std)
        t_r = radar.step(d_r, scene.speed, scene.yaw_rate, DT)
        t_i = infrared.step(d_i, scene.speed, scene.yaw_rate, DT)
        fused = assoc.step(t_r, t_i)
        meas, target = fused_measurements(fused, (t_r, t_i), (d_r, d_i))
        assert meas[1].online == (i % 2 == 0) and meas[0].z.flags.c_contiguous
        estimate = est.step(meas, target)
        for e, lead in ((0, 1), (1, 3)):
            f = np.flatnonzero(fused.valid[e] & (fused.track[e, :, 0] >= 0)
                               & (fused.track[e, :, 1] >= 0))  # fmt: skip
            truth = dict(zip(*(a.tolist() for a in scene.truth(t, e)[:2]), strict=True))
            for slot in f:
                obj = t_r.object_id[e, fused.track[e, slot, 0]]
                assert obj == t_i.object_id[e, fused.track[e, slot, 1]]  # one object's tracks
                if obj == lead:
                    paired_ids[e].add(int(fused.object_id[e, slot]))
                    k = e * n_slots + slot
                    if t > 3.0 and estimate.valid[k]:
                        errors.append(estimate.gap[k] - truth[lead])
                        assert fused.lateral[e, slot, 0] == pytest.approx(
                            scene.truth(t, e)[2][list(truth).index(lead)], abs=0.3
                        )
    assert len(errors) > 100
    for m, trk, det in zip(meas, (t_r, t_i), (d_r, d_i), strict=True):  # the last frame's inputs
        for k in np.flatnonzero(m.valid):
            e, f = divmod(k, n_slots)
            idx = trk.detection[e, fused.track[e, f, 0 if trk is t_r else 1]]
            np.testing.assert_allclose(m.z[k], [det.x[idx], det.range_rate[idx]])
            c, s = np.cos(det.azimuth[idx]), np.sin(det.azimuth[idx])
            var_x = (c * det.range_std[idx]) ** 2 + (s * det.range[idx] * det.azimuth_std[idx]) ** 2
            np.testing.assert_allclose(m.r[k], np.diag([var_x, det.range_rate_std[idx] ** 2]))
            assert m.ghost[k] == (det.origin[idx] < 0)  # GHOST or CLUTTER
        assert m.valid.sum() >= 4 if m.online else not m.valid.any()
    assert np.sqrt(np.mean(np.square(errors))) < 0.3
    # the pairing held (a 1 % gate miss may let a duplicate track take over once)
    assert all(1 <= len(ids) <= 2 for ids in paired_ids.values()), paired_ids
    # the vehicle that appeared in ego 1's view got its own fused object
    assert {int(o) for o in t_r.object_id[1][t_r.confirmed[1]]} == {3, 4}


def _tracks(sensor, rows, t=0.0, n=4):
    """Tracks of one ego from ``rows``: (slot, id, x, y, position std)."""
    valid = np.zeros((1, n), bool)
    ids = np.full((1, n), -1, np.int64)
    state, cov = np.zeros((1, n, 4)), np.tile(np.eye(4), (1, n, 1, 1))
    for slot, tid, x, y, std in rows:
        valid[0, slot], ids[0, slot] = True, tid
        state[0, slot] = [x, 0.0, y, 0.0]
        cov[0, slot] = np.diag([std**2, 1.0, std**2, 1.0])
    minus = np.full((1, n), -1, np.int64)
    return Tracks(t, sensor, valid, valid.copy(), ids, state, cov, minus, minus + 2, minus + 1,
                  np.zeros((1, n)), minus)  # fmt: skip


def _objects(fused, a, b):
    """The fused objects as {object id: (radar track id, infrared track id)}."""
    out = {}
    for f in np.flatnonzero(fused.valid[0]):
        i, j = fused.track[0, f]
        out[int(fused.object_id[0, f])] = (
            int(a.track_id[0, i]) if i >= 0 else -1,
            int(b.track_id[0, j]) if j >= 0 else -1,
        )
    return out


def test_the_association_is_sticky_and_a_new_pairing_is_a_new_object():
    assoc = TrackAssociator(AssociationConfig(), 1, (4, 4))
    radar = _tracks("radar", [(0, 10, 40.0, 0.0, 0.3)])
    # a radar-only object first
    ir = _tracks("infrared", [])
    assert _objects(assoc.step(radar, ir), radar, ir) == {0: (10, -1)}
    # the camera's track 20 joins it: a new pairing, a new object
    ir = _tracks("infrared", [(1, 20, 40.6, 0.0, 0.3)])
    fused = assoc.step(radar, ir)
    assert _objects(fused, radar, ir) == {1: (10, 20)}
    slot = int(np.flatnonzero(fused.valid[0])[0])
    # equal weights: the lateral mean of the two, half the variance
    assert fused.lateral[0, slot, 0] == pytest.approx(0.0)
    assert fused.lateral_cov[0, slot, 0, 0] == pytest.approx(0.09 / 2)
    # track 21 comes closer to the radar's, but 20 still gates: the pair holds, in its slot
    ir = _tracks("infrared", [(1, 20, 40.9, 0.0, 0.3), (2, 21, 40.0, 0.1, 0.3)])
    fused = assoc.step(radar, ir)
    assert _objects(fused, radar, ir) == {1: (10, 20), 2: (-1, 21)}
    assert fused.object_id[0, slot] == 1
    # 20 leaves the gate (d2 = 1.5^2 / 0.18 = 12.5 > 9.21): 21 pairs with 10, a new object
    ir = _tracks("infrared", [(1, 20, 41.5, 0.0, 0.3), (2, 21, 40.0, 0.1, 0.3)])
    fused = assoc.step(radar, ir)
    assert _objects(fused, radar, ir) == {3: (10, 21), 4: (-1, 20)}
    meas, target = fused_measurements(fused, (radar, ir), (_no_detections("radar"),
                                                         _no_detections("infrared")))  # fmt: skip
    assert sorted(target[target >= 0]) == [3, 4] and target.shape == (8,)
    assert not meas[0].valid.any() and not meas[1].valid.any()  # no detection this frame


def test_with_keep_identity_an_object_goes_on_as_a_track_joins_or_leaves():
    """``keep_identity``: an object whose one successor a track joined or left keeps its id
    (its estimator goes on); a track replaced by another does not carry the id across, and
    an object that splits in two passes it to neither."""
    assoc = TrackAssociator(AssociationConfig(keep_identity=True), 1, (4, 4))

    def step(radar, camera):
        r, c = _tracks("radar", radar), _tracks("infrared", camera)
        return _objects(assoc.step(r, c), r, c)

    radar = [(0, 10, 40.0, 0.0, 0.3)]
    assert step(radar, []) == {0: (10, -1)}
    assert step(radar, [(1, 20, 40.6, 0.0, 0.3)]) == {0: (10, 20)}  # 20 joins: still 0
    both = [(1, 20, 40.9, 0.0, 0.3), (2, 21, 40.0, 0.1, 0.3)]
    assert step(radar, both) == {0: (10, 20), 1: (-1, 21)}
    # 20 leaves the gate and 21 pairs with 10: object 0 had two successors, (10, 21) and
    # (-1, 20), and passes its id to neither; 1 is joined by the radar's track
    moved = [(1, 20, 41.5, 0.0, 0.3), (2, 21, 40.0, 0.1, 0.3)]
    assert step(radar, moved) == {1: (10, 21), 2: (-1, 20)}
    apart = [(1, 20, 41.5, 0.0, 0.3), (2, 21, 42.0, 0.1, 0.3)]
    assert step(radar, apart) == {3: (10, -1), 2: (-1, 20), 4: (-1, 21)}  # 1 split in two
    assert step(radar, [(3, 22, 40.2, 0.0, 0.3)]) == {3: (10, 22)}  # 22 joins 10's object
    # a camera track replaced by another under the same radar track: a new object
    assert step(radar, [(3, 23, 40.2, 0.0, 0.3)]) == {5: (10, 23)}
    # the camera loses the car: the radar's track goes on as the same object
    assert step(radar, []) == {5: (10, -1)}


def _no_detections(sensor):
    empty, none = np.zeros(0), np.zeros(0, np.int64)
    return Detections(0.0, sensor, 1, True, none, *(empty,) * 6, none, none.astype(np.int8))


def _far_camera_track(growth, rng, egos=16, frames=400, r=90.0):
    """The mean range error of camera-like tracks of a car ``r`` ahead of each of ``egos``
    egos (noise std 0.3 + q r² drawn at the true range and declared at the measured one),
    over their last 300 frames, with the noise model's growth q given to the tracker or not
    (0)."""
    q = 1.21e-3  # the thermal camera's sigma_y / (f H) [1/m]
    tracker, one = Tracker("infrared", TrackerConfig(), egos), np.ones(egos)
    ego, errors = np.arange(egos), []
    for i in range(frames):
        z = r + (0.3 + q * r * r) * rng.standard_normal(egos)
        det = Detections(i * DT, "infrared", egos, True, ego, z, 0 * one, 0 * one,
                         0.3 + q * z * z, 0.002 * one, 0.5 * one, ego, ego.astype(np.int8),
                         growth)  # fmt: skip
        tracks = tracker.step(det, 0 * one, 0 * one, DT)
        if i >= frames - 300:
            errors.append(tracks.state[tracks.valid][:, 0] - r)
    return float(np.mean(np.concatenate(errors)))


def test_a_camera_track_of_a_far_car_is_unbiased_with_the_std_at_the_predicted_range(rng):
    """Declared at the measured range, a std that grows as r² weights short measurements
    more and pulls the track short (4.7 m at 90 m for a weighted mean); the tracker takes
    the std at its prediction when the detections give the growth."""
    assert _far_camera_track(0.0, rng) < -2.0
    assert abs(_far_camera_track(1.21e-3, rng)) < 1.0


def test_forget_drops_one_egos_tracks_and_objects_and_ids_are_never_reused(rng):
    scene = _two_sensor_scene()
    cfg = TrackerConfig()
    trackers = [Tracker("radar", cfg, 2), Tracker("infrared", cfg, 2)]
    assoc = TrackAssociator(AssociationConfig(), 2, (cfg.max_tracks, cfg.max_tracks))

    def step(i):
        t = i * DT
        dets = [detect(scene, t, tr.sensor, rng) for tr in trackers]
        tracks = [
            tr.step(d, scene.speed, scene.yaw_rate, DT)
            for tr, d in zip(trackers, dets, strict=True)
        ]
        return tracks, assoc.step(*tracks)

    for i in range(40):
        tracks, fused = step(i)
    before = fused.object_id[1].copy()
    last_ids = [int(t.track_id.max()) for t in tracks] + [int(fused.object_id.max())]
    ego0 = np.array([True, False])
    for tr in trackers:
        tr.forget(ego0)
    assoc.forget(ego0)
    tracks, fused = step(40)
    assert not fused.valid[0].any() and not tracks[0].confirmed[0].any()
    np.testing.assert_array_equal(fused.object_id[1], before)  # ego 1 carries on
    for i in range(41, 60):
        tracks, fused = step(i)
    assert fused.valid[0].any()
    for t, last in zip(tracks, last_ids, strict=False):
        assert t.track_id[0][t.valid[0]].min() > last
    assert fused.object_id[0][fused.valid[0]].min() > last_ids[2]


def test_trackers_and_the_associator_resize_to_a_prefix_and_back(rng):
    scene = _two_sensor_scene()
    cfg = TrackerConfig()
    radar = Tracker("radar", cfg, 2)
    infrared = Tracker("infrared", cfg, 2)
    assoc = TrackAssociator(AssociationConfig(), 2, (cfg.max_tracks, cfg.max_tracks))
    for i in range(30):
        d = [detect(scene, i * DT, s, rng) for s in ("radar", "infrared")]
        fused = assoc.step(radar.step(d[0], scene.speed, scene.yaw_rate, DT),
                           infrared.step(d[1], scene.speed, scene.yaw_rate, DT))  # fmt: skip
    for part in (radar, infrared, assoc):
        part.resize(1)
        assert part.n_egos == 1
        part.resize(2)
    d = [detect(scene, 30 * DT, s, rng, p_detect=0.0) for s in ("radar", "infrared")]
    again = assoc.step(radar.step(d[0], scene.speed, scene.yaw_rate, DT),
                       infrared.step(d[1], scene.speed, scene.yaw_rate, DT))  # fmt: skip
    np.testing.assert_array_equal(again.object_id, fused.object_id)  # coasting: the same


def _many_egos(n_egos, rng):
    """``n_egos`` egos, some turning, each with eight vehicles of its own ahead, in its lane
    and beside it, driving at about its speed."""
    speed = rng.uniform(15.0, 30.0, n_egos)
    objects = []
    for e in range(n_egos):
        k = 8
        ids = 100 * e + np.arange(k)
        x0, y0 = rng.uniform(30.0, 90.0, k), rng.uniform(-6.0, 6.0, k)
        vx, vy = speed[e] + rng.normal(0.0, 3.0, k), rng.normal(0.0, 0.3, k)
        objects.append(np.column_stack([ids, x0, y0, vx, vy]))
    yaw = np.where(rng.random(n_egos) < 0.3, rng.normal(0.0, 0.02, n_egos), 0.0)
    return Scene(objects, speed, yaw)


def _chain(scene, seed, frames=30, copy=True):
    """Both trackers, the association and the federated filter over ``frames`` frames (with
    clutter, misses and an infrared camera at half rate): every output of the last frame
    (the trackers' and the filter's as copies or, ``copy`` false, views)."""
    rng = np.random.default_rng(seed)
    n = scene.n_egos
    cfg = TrackerConfig()
    radar, infrared = Tracker("radar", cfg, n), Tracker("infrared", cfg, n)
    assoc = TrackAssociator(AssociationConfig(), n, (cfg.max_tracks, cfg.max_tracks))
    fusion = FusionConfig(method="federated", filter=FilterConfig(dt=DT))
    est = make_estimator(fusion, ("radar", "infrared"), n * assoc.n_slots)
    for i in range(frames):
        t = i * DT
        d_r = detect(scene, t, "radar", rng, p_detect=0.9, clutter=1)
        d_i = detect(scene, t, "infrared", rng, online=i % 2 == 0, p_detect=0.8)
        t_r = radar.step(d_r, scene.speed, scene.yaw_rate, DT, copy=copy)
        t_i = infrared.step(d_i, scene.speed, scene.yaw_rate, DT, copy=copy)
        fused = assoc.step(t_r, t_i)
        estimate = est.step(*fused_measurements(fused, (t_r, t_i), (d_r, d_i)), copy=copy)
    assert np.shares_memory(t_r.cov, radar._p) != copy  # a view exactly when asked
    assert np.shares_memory(estimate.p, est.master.p) != copy
    return [*vars(t_r).values(), *vars(t_i).values(), *vars(fused).values(),
            *vars(estimate).values()]  # fmt: skip


def test_views_of_the_trackers_and_the_filter_equal_their_copies():
    """The 2-D pipeline reads the trackers' and the estimators' outputs within the step, as
    views (``copy=False``): the same values as the copies."""
    scene = _many_egos(6, np.random.default_rng(2))
    for a, b in zip(_chain(scene, 4, 12), _chain(scene, 4, 12, copy=False), strict=True):
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
        else:
            assert a == b


@pytest.mark.skipif(numba.get_num_threads() < 2, reason="numba has one thread: no parallel run")
def test_the_parallel_kernels_equal_the_serial_ones_bit_for_bit(monkeypatch):
    """From 64 egos the trackers and the association, and from 2 048 pairs the federated
    filter, run on numba's threads; their tracks, ids, fused objects and estimates are the
    serial kernels' exactly."""
    import acc_fusion.filters.kalman as kalman
    import acc_fusion.fusion.tracking.tracker as tracker

    scene = _many_egos(80, np.random.default_rng(5))
    assert scene.n_egos >= tracker.PARALLEL_EGOS
    assert scene.n_egos * 2 * TrackerConfig().max_tracks >= kalman.PARALLEL_PAIRS
    parallel = _chain(scene, seed=9)
    for module, name in ((tracker, "PARALLEL_EGOS"), (kalman, "PARALLEL_PAIRS")):
        monkeypatch.setattr(module, name, 10**9)
    serial = _chain(scene, seed=9)
    assert len(parallel) == len(serial)
    for a, b in zip(parallel, serial, strict=True):
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
        else:
            assert a == b
    tracks_confirmed = parallel[2]
    assert tracks_confirmed.sum() > 3 * scene.n_egos  # the scene gave the kernels work
