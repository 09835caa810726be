r"""The 2-D world end to end: objects → radar and thermal camera → per-sensor trackers →
track-to-track association → one estimator per method on every associated object → in-path
selection → warning → metrics by class and cause.

Per step, for E egos (one per run of a scripted scene, or the equipped vehicles of a traffic
source) and F object slots each:

1. the truth source gives an :class:`~acc_fusion.truth.objects.ObjectFrame`; the conditions
   (:class:`~acc_fusion.truth.conditions.Conditions`) are the run's;
2. each 2-D sensor (:func:`acc_fusion.sensors.suite2d.sensors_2d`) returns its detections;
3. each sensor's multi-target tracker (:class:`acc_fusion.fusion.tracking.tracker.Tracker`)
   associates, confirms and deletes tracks; the tracks of the two sensors are associated into
   objects (:class:`acc_fusion.fusion.tracking.association.TrackAssociator`);
4. every method's estimator — each sensor alone, centralized, federated with its FDI, exactly
   the 1-D pipeline's — runs on the associated objects, one pair per used object slot (a
   :class:`~acc_fusion.core.slots.PairPool` keeps the pairs of the slots in use a dense
   prefix, so the estimators cost in proportion to the objects, not to the E·F slots), fed
   with the detections each sensor's track took at this step;
5. the in-path selector (:mod:`acc_fusion.warning.selection`) picks each ego's object from the
   method's estimates, and the warning logic judges it;
6. truth — the ego's true in-path lead (:meth:`ObjectFrame.lead_frame`) — gives the oracle,
   the crash-relevant situations and the alert classes (:mod:`acc_fusion.metrics.events`);
   each warning's *cause* is what the selected object is in truth at its onset
   (:func:`alert_cause`), or ``fault`` while a fault of a sensor the method uses is active.

The 1-D pipeline (:func:`acc_fusion.sim.closed_loop.simulate`) is the special case of one
object, always in path, measured without association.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit

from acc_fusion.core.borrow import borrow
from acc_fusion.core.slots import Extent, PairPool, PairState, resize_all
from acc_fusion.core.validation import broadcast
from acc_fusion.filters.ego import EgoFilterConfig, EgoMotionFilter
from acc_fusion.fusion.base import Estimate
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.fusion.tracking.association import (
    FusedObjects,
    TrackAssociator,
    fused_measurements,
)
from acc_fusion.fusion.tracking.tracker import Tracker, Tracks
from acc_fusion.metrics.summary import CAUSES
from acc_fusion.sensors.detections import Detections
from acc_fusion.sensors.localization import MapLocalization
from acc_fusion.sensors.suite import SENSOR_NAMES
from acc_fusion.sensors.suite2d import sensors_2d
from acc_fusion.sim.closed_loop import (
    ACCEL_STD,
    Perceived,
    SimConfig,
    SimResult,
    _EgoSensors,
    judge,
    simulate,
)
from acc_fusion.sim.world_config import WorldConfig
from acc_fusion.truth.frame import TruthFrame
from acc_fusion.truth.objects import STATIONARY_KINDS, ObjectFrame, ObjectKind
from acc_fusion.truth.scenes import SceneConfig, SceneSource
from acc_fusion.warning.logic import WarningLogic
from acc_fusion.warning.selection import InPathSelector

#: Lateral speed [m/s] above which a vehicle counts as changing lanes (a lane change moves
#: sideways at about 0.5-1.5 m/s; assumption).
LANE_CHANGE_SPEED = 0.5
#: The sensors a single-sensor method uses (a fusion method uses them all).
_SENSORS_OF = {"radar": ("radar",), "infrared": ("infrared",)}
#: Methods whose estimates include the thermal camera, the classifying sensor.
_CLASSIFYING = ("infrared", "centralized", "federated")
#: Pairs by which the estimators' prefix of the pair pool grows or shrinks (each resize
#: copies every estimator's state once).
POOL_QUANTUM = 1024


def alert_cause(
    frame: ObjectFrame, truth_id: np.ndarray, lead_id: np.ndarray | None = None
) -> np.ndarray:
    """``(E,)`` index into :data:`CAUSES` of what each ego's selected object is in truth.

    ``truth_id (E,)`` is the true object id behind the selected object (``-1`` for a ghost or
    clutter track); ``lead_id (E,)`` the true in-path lead's id where the caller has it
    (default: :meth:`ObjectFrame.lead_frame`'s).  A vehicle moving across its lane faster
    than :data:`LANE_CHANGE_SPEED` is ``cut_in_out``, the true lead included (it has just cut
    in, or is cutting out: a source such as SUMO makes a vehicle the ego's leader the moment
    it changes lanes); the true in-path lead otherwise is ``lead``; a stationary kind is
    ``stationary``; any other vehicle ``adjacent``; an id not in the frame (or ``-1``)
    ``ghost``.
    """
    n = frame.n_egos
    if not frame.max_objects:  # no object ahead of any ego: whatever is selected is a ghost
        return np.full(n, CAUSES.index("ghost"), dtype=np.int64)
    lead_id = frame.lead_frame().leader_id if lead_id is None else lead_id
    ids = (broadcast("truth_id", truth_id, (n,), np.int64),
           broadcast("lead_id", lead_id, (n,), np.int64))  # fmt: skip
    code = np.empty(n, dtype=np.int64)
    _cause(frame.valid, frame.object_id, frame.kind, frame.lateral_speed, *ids, _STILL_KINDS,
           int(ObjectKind.VEHICLE), LANE_CHANGE_SPEED, code)  # fmt: skip
    return _CODE_CAUSE[code]


#: The causes :func:`_cause` tells apart, by its codes 0-4 (given to it as codes, not as
#: :data:`CAUSES` indices: a cached compiled kernel keeps the constants of other modules it
#: was compiled with).
_CODE_CAUSE = np.array(
    [CAUSES.index(c) for c in ("lead", "stationary", "adjacent", "cut_in_out", "ghost")]
)
_STILL_KINDS = np.array([int(k) for k in STATIONARY_KINDS], dtype=np.int8)


@njit(cache=True)
def _cause(
    valid, object_id, kind, lateral_speed, truth_id, lead_id, still_kinds, vehicle, lane_change,
    out,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`alert_cause` of every ego into ``out`` as codes 0-4 (lead, stationary,
    adjacent, cut-in/out, ghost; :data:`_CODE_CAUSE`): the first valid slot holding the
    object ``truth_id`` decides; ``still_kinds`` the stationary kinds, ``vehicle`` the
    vehicle kind, ``lane_change`` the lateral speed [m/s] of a lane change."""
    for e in range(valid.shape[0]):
        wanted, k = truth_id[e], -1
        if wanted >= 0:
            for j in range(valid.shape[1]):
                if valid[e, j] and object_id[e, j] == wanted:
                    k = j
                    break
        if k < 0:
            out[e] = 4
            continue
        still = False
        for s in still_kinds:
            still = still or kind[e, k] == s
        changing = kind[e, k] == vehicle and abs(lateral_speed[e, k]) > lane_change
        if wanted == lead_id[e] and not changing:
            out[e] = 0
        elif changing:
            out[e] = 3
        else:
            out[e] = 1 if still else 2


@dataclass(frozen=True)
class Sensed:
    """What the 2-D world's stages made of one step, for hooks that record it (the OSI trace of
    :mod:`acc_fusion.sim.osi_trace`): views of the stages' arrays, valid within the step.

    Attributes:
        objects: the truth the sensors saw.
        detections: each sensor's detections (:data:`~acc_fusion.sensors.suite.SENSOR_NAMES`
            order).
        tracks: each sensor's tracks, in the same order.
        fused: the objects the associator made of the two sensors' tracks.
        accel: ``(E,)`` the ego's accelerometer reading [m/s²].
        wheel: ``(E,)`` the ego's wheel-speed reading [m/s].
        yaw_rate: ``(E,)`` the ego's gyro reading [rad/s].
        estimates: every method's estimates over the estimators' pairs; :meth:`per_object` lays
            one out over the E·F object slots.
        reassigned: ``(E,)`` the egos that a new vehicle took at this step (``None``: a source
            whose egos never change).
    """

    objects: ObjectFrame
    detections: list[Detections]
    tracks: list[Tracks]
    fused: FusedObjects
    accel: np.ndarray
    wheel: np.ndarray
    yaw_rate: np.ndarray
    estimates: dict[str, Estimate]
    per_object: Callable[[Estimate], Estimate]
    reassigned: np.ndarray | None


@dataclass
class WorldPerceived(Perceived):
    """What :class:`WorldPerception` perceived at one step, as the 1-D pipeline's
    :class:`~acc_fusion.sim.closed_loop.Perceived`: ``frame`` is the 1-D truth of each ego and
    its true in-path lead (:meth:`ObjectFrame.lead_frame`, which the oracle, the alert classes
    and the driver judge), ``measurements`` is empty (the sensors' reports belong to objects,
    not to egos), each method's estimate is that of the object it selected (``valid`` where it
    selected one), and ``causes`` what that object is in truth (:func:`alert_cause`, or
    ``fault``).  ``truth_id``: per method, the true id of each ego's selected object (``-1``
    for a ghost or clutter track, or without a selection); ``sensed``: what the stages made of
    the step (:class:`Sensed`)."""

    truth_id: dict[str, np.ndarray] = field(default_factory=dict)
    sensed: Sensed | None = None


class WorldPerception(PairState):
    """The 2-D world's sensing and estimation over E egos (steps 2-5 of the module docstring).

    :meth:`forget` starts some egos afresh (a slot that a new vehicle took); :meth:`resize`
    makes it perceive the first m egos only (:mod:`acc_fusion.core.slots`).
    """

    def __init__(self, config: SimConfig, n: int, seed: np.random.SeedSequence) -> None:
        s_sensors, s_ego, s_gyro = seed.spawn(3)
        world: WorldConfig = config.world
        self.config, self.world, self.n, self._capacity = config, world, n, n
        self.sensors = sensors_2d(world.sensors, s_sensors)
        self.trackers = [Tracker(s.spec.name, world.tracker, n) for s in self.sensors]
        tracks = (world.tracker.max_tracks,) * 2
        self.associator = TrackAssociator(world.association, n, tracks)
        self.slots = self.associator.n_slots
        self._read_ego = _EgoSensors(n, np.random.default_rng(s_ego))
        self._gyro = np.random.default_rng(s_gyro)
        sel = world.selection
        self._map = None if not world.map_path else MapLocalization(
            sel.map_lateral_std, sel.map_heading_std, sel.map_error_time, n,
            np.random.default_rng(seed.spawn(1)[0]),
        )  # fmt: skip
        self.ego = EgoMotionFilter(n, EgoFilterConfig(fs=1.0 / config.dt, interval_accel=True))
        filters = replace(config.fusion.filter, dt=config.dt, ego_accel_std=ACCEL_STD)
        # A fused object's R is the converted 2-D covariance of its detection, its range std
        # already taken at the track's range (fused_measurements), not the 1-D spec's range
        # law: it is used as given.
        fusion = replace(config.fusion, filter=filters, noise_at="report")
        pairs = n * self.slots
        specs = config.sensor_specs()
        self.estimators = {
            m: make_estimator(replace(fusion, method=m), SENSOR_NAMES, pairs, specs)
            for m in config.methods
        }
        self.pool = PairPool(pairs, pairs)  # object slot e·F + f → the estimators' pair
        self._pool_extent = Extent(pairs, quantum=POOL_QUANTUM)
        self.selectors = {
            m: InPathSelector(world.selection, n, self.slots, world.yaw_rate_std)
            for m in config.methods
        }
        self.oracle = WarningLogic(config.warning, n, config.dt)
        self._t_prev: float | None = None

    def _resized(self, m: int) -> None:
        self.n = m
        stages = [*self.trackers, self.associator, *self.selectors.values(), self.ego,
                  self._read_ego, self.oracle]  # fmt: skip
        resize_all(stages if self._map is None else [*stages, self._map], m)

    def _free(self, freed: np.ndarray) -> None:
        """Forget the estimators' pairs ``freed`` (a mask over the pool; all inside the
        estimators' prefix, since they were in use at the last step)."""
        if freed.any():
            pairs = freed[: self._pool_extent.size]
            for estimator in self.estimators.values():
                estimator.forget(pairs)

    def forget(self, egos: np.ndarray, wheel: np.ndarray) -> None:
        """Start ``egos`` (a boolean mask ``(E,)``) afresh in every stage: their tracks, fused
        objects, the estimators' pairs of their objects, the selectors' memory, the ego
        filter (from the wheel speed ``wheel``) and the oracle."""
        for tracker in self.trackers:
            tracker.forget(egos)
        self.associator.forget(egos)
        keys = np.zeros(self.pool.pair_of.size, dtype=bool)
        keys[: self.n * self.slots] = np.repeat(egos, self.slots)
        self._free(self.pool.release(keys))
        for selector in self.selectors.values():
            selector.forget(egos)
        if self._map is not None:
            self._map.forget(egos)
        self.ego.reset(egos, wheel)
        self.oracle.reset(egos)

    def per_slot(self, est: Estimate) -> Estimate:
        """``est`` (over the pool's pairs) laid out over the E·F object slots, ego-major; a
        slot without an object is not ``valid``, its ``x`` and ``p`` zero, its NIS NaN."""
        pair = self.pool.pair_of[: self.n * self.slots]
        has = pair >= 0
        k = np.maximum(pair, 0)

        def spread(a, fill):
            return np.where(has.reshape((-1,) + (1,) * (a.ndim - 1)), a[k], fill)

        return Estimate(est.t, spread(est.x, 0.0), spread(est.p, 0.0), spread(est.valid, False),
                        spread(est.nis, np.nan), spread(est.isolated, False))  # fmt: skip

    def step(
        self,
        frame: ObjectFrame,
        active: np.ndarray,
        reassigned: np.ndarray | None = None,
        attentive: np.ndarray | None = None,
    ) -> WorldPerceived:
        """Sense, track, fuse and select at ``frame`` (the egos in ``active`` are driven; those
        ``reassigned`` start afresh), and judge the truth with the oracle (``attentive``: the
        drivers it times as attentive, :func:`~acc_fusion.sim.closed_loop.judge`)."""
        dt = self.config.dt if self._t_prev is None else frame.t - self._t_prev
        self._t_prev = frame.t
        lead = frame.lead_frame()
        accel, wheel, yaw, detections = self._sense(frame, lead)
        if reassigned is not None and reassigned.any():
            self.forget(reassigned, wheel)
        v_ego, bias = self.ego.step(accel, wheel)
        tracks = [
            tr.step(d, v_ego, yaw, dt, copy=False, ego_shift=frame.ego_shift)  # read in this step
            for tr, d in zip(self.trackers, detections, strict=True)
        ]
        fused = self.associator.step(*tracks)
        freed = self.pool.update(fused.valid.reshape(-1))
        p = self._pool_extent.fit_stages(self.pool.used, self.estimators.values())
        self._free(freed)
        slots = self.pool.key_of[:p]
        measurements, target = fused_measurements(fused, tracks, detections, slots)
        # Each ego's acceleration over the step from the previous frame to this one.
        u = (accel - bias)[np.maximum(slots, 0) // self.slots]
        oracle, ttc, relevant = judge(
            self.oracle, self.config.alert_classes, lead, active, attentive
        )
        faulty = {s.spec.name: s.faulty(frame.t) for s in self.sensors}
        estimates, truth_id, causes = {}, {}, {}
        # what every method's path prediction reads of the objects: their tracks
        seen = (fused.object_id, *_track_view(fused.valid, fused.track, tracks[0].state,
                                              tracks[1].state))  # fmt: skip
        road_path = None  # the map as the egos place it, where the source gives one
        if self._map is not None and frame.road_path.shape[1]:
            road_path = self._map.step(frame.road_path, dt)
        raw = {}
        for m, estimator in self.estimators.items():
            est = raw[m] = estimator.step(measurements, target, u, copy=False)
            estimates[m], truth_id[m] = self._select(
                m, est, fused, tracks, v_ego, yaw, frame.road_curvature, active, dt, seen,
                road_path,
            )  # fmt: skip
            cause = alert_cause(frame, truth_id[m], lead.leader_id)
            if any(faulty[s] for s in _SENSORS_OF.get(m, faulty)):
                cause[:] = CAUSES.index("fault")
            causes[m] = cause
        sensed = Sensed(frame, detections, tracks, fused, accel, wheel, yaw, raw, self.per_slot,
                        reassigned)  # fmt: skip
        return WorldPerceived(
            lead, [], v_ego, estimates, oracle, ttc, relevant, causes, truth_id, sensed
        )

    def _sense(
        self, frame: ObjectFrame, lead: TruthFrame
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[Detections]]:
        """The egos' accelerometer, wheel-speed and gyro readings and each sensor's detections
        at ``frame`` (``lead``: its 1-D truth), drawn from the sensors' models
        (:class:`~acc_fusion.sim.osi_trace.RecordedPerception` reads them from a trace)."""
        accel, wheel = self._read_ego(lead)
        noise = self._gyro.normal(0.0, self.world.yaw_rate_std, self._capacity)[: self.n]
        detections = [s.detect(frame, self.world.conditions) for s in self.sensors]
        return accel, wheel, frame.ego_yaw_rate + noise, detections

    def _select(
        self, method, est, fused, tracks, v_ego, yaw, curvature, active, dt, seen, road_path
    ):
        """The selected object of each active ego under ``method``: its estimate (an
        :class:`~acc_fusion.fusion.base.Estimate` over the egos, ``valid`` where one is
        selected) and its true id (``est`` over the pool's pairs); ``dt`` [s] since the last
        step, ``seen`` the objects as the path prediction reads them and ``road_path`` the
        map's path as the egos place it, or ``None`` (:meth:`InPathSelector.step`)."""
        n, f = self.n, self.slots
        pair = self.pool.pair_of[: n * f].reshape(n, f)
        ids, x, ground = np.empty((n, f), np.int64), np.empty((n, f)), np.empty((n, f))
        confirmed = np.empty((n, f), dtype=bool)
        _slot_view(pair, est.x, est.valid, fused.valid, fused.object_id, fused.track, v_ego,
                   method in _CLASSIFYING, ids, x, ground, confirmed)  # fmt: skip
        lateral, cov = fused.lateral, fused.lateral_cov
        sel = self.selectors[method].step(
            ids, x, lateral[..., 0], ground, confirmed, v_ego, yaw, curvature,
            lateral[..., 1], cov[..., 0, 0], cov[..., 1, 1], dt, seen, road_path,
        )  # fmt: skip
        has = np.empty(n, dtype=bool)
        x_sel, p_sel = np.empty((n, *est.x.shape[1:])), np.empty((n, *est.p.shape[1:]))
        nis, isolated = np.empty((n, est.nis.shape[1])), np.empty((n, est.nis.shape[1]), bool)
        truth = np.empty(n, np.int64)
        _selected(sel, active, pair, est.x, est.p, est.nis, est.isolated, fused.track,
                  tracks[0].object_id, tracks[1].object_id, has, x_sel, p_sel, nis, isolated,
                  truth)  # fmt: skip
        return Estimate(est.t, x_sel, p_sel, has, nis, isolated), truth


@njit(cache=True)
def _slot_view(
    pair, x_est, valid_est, fused_valid, fused_id, track, v_ego, classifying, ids, x, ground,
    confirmed,
):  # pragma: no cover - compiled  # fmt: skip
    """What the in-path selector sees of each object slot ``(E, F)`` under one method, from the
    slots' estimator pairs ``pair`` (-1: none) and that method's estimates over the pairs:
    ``ids`` the fused object's id where its pair's estimate is valid (-1 elsewhere), ``x`` its
    range, ``ground`` its ground speed (the ego's speed plus its range-rate), ``confirmed``
    whether the thermal camera's track is in it (only for a ``classifying`` method).  A slot
    without a pair reads pair 0, masked by its id; every pair is inside the estimators'
    prefix (the pool's extent is fitted to the used pairs each step)."""
    n, f = fused_valid.shape
    for e in range(n):
        for k in range(f):
            p = pair[e, k]
            q = max(p, 0)
            ok = p >= 0 and valid_est[q] and fused_valid[e, k]
            ids[e, k] = fused_id[e, k] if ok else -1
            x[e, k] = x_est[q, 0]
            ground[e, k] = v_ego[e] + x_est[q, 1]
            confirmed[e, k] = classifying and track[e, k, 1] >= 0


@njit(cache=True)
def _track_view(valid, track, radar, camera):  # pragma: no cover - compiled
    """The range and relative longitudinal velocity ``(E, F)`` of each fused object, from its
    radar track if it has one, else its camera track (zeros in an empty slot): what the
    path prediction reads of every object, whichever method selects."""
    n, f = valid.shape
    x, vx = np.zeros((n, f)), np.zeros((n, f))
    for e in range(n):
        for k in range(f):
            if not valid[e, k]:
                continue
            r, c = track[e, k, 0], track[e, k, 1]
            state = radar[e, r] if r >= 0 else camera[e, max(c, 0)]
            x[e, k], vx[e, k] = state[0], state[1]
    return x, vx


@njit(cache=True)
def _selected(
    sel, active, pair, x, p, nis, isolated, track, radar_id, camera_id, has, x_out, p_out,
    nis_out, isolated_out, truth,
):  # pragma: no cover - compiled  # fmt: skip
    """The estimate of each ego's selected slot ``sel (E,)`` (-1: none) into the outputs
    (``has`` where an active ego selected one; the other rows hold pair 0's, unused) and
    its true id ``truth``: the radar track's object, else the camera track's (-1 where
    nothing is selected)."""
    sel, active, pair, x, p, nis, isolated, track, radar_id, camera_id = borrow(
        (sel, active, pair, x, p, nis, isolated, track, radar_id, camera_id)
    )
    has, x_out, p_out, nis_out, isolated_out, truth = borrow(
        (has, x_out, p_out, nis_out, isolated_out, truth)
    )
    for e in range(sel.size):
        has[e] = sel[e] >= 0 and active[e]
        k = sel[e] if has[e] else 0
        q = max(pair[e, k], 0)
        for i in range(x.shape[1]):
            x_out[e, i] = x[q, i]
            for j in range(x.shape[1]):
                p_out[e, i, j] = p[q, i, j]
        for s in range(nis.shape[1]):
            nis_out[e, s], isolated_out[e, s] = nis[q, s], isolated[q, s]
        truth[e] = seen_id(track, radar_id, camera_id, e, k) if has[e] else -1


@njit(cache=True, inline="always")
def seen_id(track, radar_id, camera_id, e, k):  # pragma: no cover - compiled
    """The true id of ego ``e``'s fused object ``k``: its radar track's object, else its camera
    track's (``track`` :attr:`FusedObjects.track`, the ids the two trackers' tracks hold)."""
    radar, camera = track[e, k, 0], track[e, k, 1]
    return radar_id[e, max(radar, 0)] if radar >= 0 else camera_id[e, max(camera, 0)]


def simulate_world(
    config: SimConfig,
    *,
    source=None,
    progress: bool = False,
    on_step=None,
    warnings_on: bool = True,
    perception=None,
) -> SimResult:
    """Run the 2-D pipeline (settings ``config.world``) on its scene (``config.runs`` runs,
    one ego each), or on ``source`` (anything with ``frame()`` giving an :class:`ObjectFrame`,
    ``advance()``, ``active``, ``collided``, ``t``, ``done`` and ``n_steps``; and, if it can
    make the frame of its first ``k`` slots faster than the whole, ``head(k)``): the loop of
    :func:`~acc_fusion.sim.closed_loop.simulate` with :class:`WorldPerception` as its
    perception, so ``config.drive`` closes it (the driver hears that method's warnings and
    brakes, with a source that takes brake requests), ``on_step`` sees every step and
    ``warnings_on`` false keeps the warnings from the driver; each method's summary has its
    alerts by cause.  ``perception`` builds the sensing and estimation (default
    :class:`WorldPerception`; :class:`~acc_fusion.sim.osi_trace.RecordedPerception` reads a
    trace's detections instead of drawing them).

    A source with ``reassigned`` has its egos come and go: a slot that a new vehicle took
    starts afresh in every stage and an inactive slot counts for nothing; a source of slots
    (``slotted = True``, e.g. :class:`acc_fusion.truth.sumo.world.SumoWorld`) also has every
    stage work on the prefix of slots that holds the vehicles (:mod:`acc_fusion.core.slots`)."""
    if source is None:
        s_source = np.random.SeedSequence(config.seed).spawn(1)[0]
        scene = SceneConfig(scene=config.world.scene, runs=config.runs, dt=config.dt)
        source = SceneSource(scene, np.random.default_rng(s_source), config.world.map_path)
    return simulate(
        config,
        source=source,
        progress=progress,
        on_step=on_step,
        warnings_on=warnings_on,
        perception=WorldPerception if perception is None else perception,
    )
