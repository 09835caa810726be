r"""In-path target selection: which of the objects ahead the warning judges.

Among the fused objects of each ego, the selected one is the nearest object ahead whose
lateral position lies within a corridor around the ego's *predicted path*; the warning sees
that object's gap, range-rate and acceleration.  Choosing the wrong object — an adjacent-lane
car on the straight extension of the path before a curve, a parked car on the shoulder, an
overhead gantry, a cut-in taken late — is the main source of false and nuisance alerts in
the field, and this module is where the tool reproduces it.

Path prediction (``path``)
    The path is a circular arc of curvature :math:`\kappa` through the ego, tangent to its
    heading; at longitudinal distance :math:`x` its lateral offset is, for
    :math:`|\kappa x| \ll 1`,

    .. math::

        y_p(x) = \tfrac12\,\kappa\,x^2 .

    ``"straight"``: :math:`\kappa = 0`; ``"yaw_rate"``: :math:`\kappa = \dot\psi / v` from the
    yaw-rate gyro and the speed — the classic FCW/ACC path estimate, which assumes that the
    present curvature continues, so it is wrong at curve entry and exit (the limitation that
    motivates path prediction from more sources in Polychronopoulos, Tsogas, Amditis &
    Andreone, "Sensor fusion for predicting vehicles' path for collision avoidance systems",
    IEEE Trans. Intelligent Transportation Systems 8(3), 2007);
    ``"lane"``: :math:`\kappa` of the ego lane at the ego (a lane-aware system that knows the
    road ahead, e.g. from a camera's lane model or a map; it still assumes constant curvature
    over the field);
    ``"fused"`` (default): the curvature *and its rate* along the road, estimated from the
    yaw rate, the headings of the moving vehicles ahead and, where a map gives it, the
    lane's curvature, with their covariance (:mod:`acc_fusion.warning.path`):
    :math:`y_p(x) = \tfrac12 c_0 x^2 + \tfrac16 c_1 x^3`, whose uncertainty widens with
    distance;
    ``"map"``: the centreline of the ego's lane and of the lanes it continues into along its
    route, as a lane-level map gives it (:attr:`acc_fusion.truth.objects.ObjectFrame.road_path`:
    SUMO's sources, highway-env and the scripted scenes), placed with the error of the ego's
    localisation on the map (:mod:`acc_fusion.sensors.localization`): the offset's variance is
    the track's plus :math:`\sigma_{e_y}^2 + x^2\sigma_{e_\psi}^2`
    (:func:`acc_fusion.warning.path.map_offset`; an object beyond where the ego's lane turns
    back is not on it).
    It follows the lanes that split from or merge into the ego's, which no curvature at
    the ego, measured or estimated, describes.

Corridor (``half_width``)
    An object is in path when :math:`|y - y_p(x)| \le w/2`; the default :math:`w/2` = 1.75 m
    is half a 3.5 m lane (an assumption: ISO 15623:2013, the FVCWS standard, asks the system to
    discriminate targets in the subject vehicle's lane without fixing a corridor width).
    With the ``"fused"`` and ``"map"`` paths the offset is uncertain (the path's covariance
    or the localisation's, and the track's lateral variance): an object is in path when its
    in-path probability :math:`P_\text{in}`
    (:func:`acc_fusion.warning.path.in_path_probability`) reaches ``enter_probability``;
    with ``keep_probability`` below it, the object selected at the previous step stays in
    path down to that probability (hysteresis, off by default: it kept a cutting-out lead
    selected too long, see :mod:`acc_fusion.warning.path`'s theory
    page; both thresholds are assumptions).

Lateral motion (``lateral_horizon``)
    With a horizon :math:`\tau > 0` an object is judged where its lateral motion relative to
    the ego takes it in :math:`\tau`: at the offset :math:`o + v_y \tau`, of variance
    :math:`\sigma_o^2 + \tau^2 \sigma_{v_y}^2` (its track's lateral velocity and that
    velocity's variance).  A vehicle cutting in is taken before it reaches the corridor, one
    cutting out is let go before it leaves it, uncovering what it hid; the ego's own lane
    change moves every object across its frame, so the vehicles of the lane it enters come in
    and those of the lane it leaves go out.  Selecting the target from the lane-change
    intention of the vehicles ahead is the approach of *Target vehicle selection algorithm
    for adaptive cruise control based on lane-changing intention of preceding vehicle*
    (Chinese Journal of Mechanical Engineering 34, 2021, doi:10.1186/s10033-021-00650-8),
    which infers the intention from the lateral offset with a trained classifier; the
    constant-velocity extrapolation and its horizon are this project's assumptions.  Off by
    default (0).

Stationary objects (``stationary``)
    A track whose estimated ground speed is below ``stationary_speed`` is stationary.
    ``"all"``: stationary objects are selectable like any other; ``"ignore"``: never (the
    policy of early radar-only ACC/FCW, which therefore misses a stopped car); ``"confirmed"``
    (default): selectable only when a classifying sensor (the thermal camera's vehicle
    detector) has confirmed the object, or the object was seen moving, since it was first
    tracked — the radar alone then ignores gantries, bridges and parked cars, and with them a
    car revealed standing still.  The memory is the fused object's: it lasts as long as the
    object's id, which by default changes with the tracks behind it (so a stopped car that
    the camera loses at close range is dropped), and with
    ``world.association.keep_identity`` outlives the camera's track.

Oncoming objects (``oncoming``)
    A track whose estimated ground speed is below :math:`-`\ ``stationary_speed`` comes
    toward the ego.  An FCW warns of rear-end collisions with vehicles ahead (ISO 15623:2013,
    scope: "a potential rear-end collision with other vehicles ahead of the subject
    vehicle"), so by default (``oncoming = False``) such a track is never selected; ``True``
    makes it selectable, to study what the scope leaves out.  Without the rule, a path
    predicted from a noisy yaw rate swept the other carriageway's traffic, well ahead and
    closing at both speeds, into the corridor: most of the 2-D pipeline's sensing-false
    alerts on the bundled motorway (2026-11-27, docs/guide/world.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import InputError
from acc_fusion.core.slots import PairState
from acc_fusion.core.validation import broadcast, check_choice, check_interval, check_range
from acc_fusion.truth.objects import PATH_STATIONS
from acc_fusion.warning import path as fp

#: Path models (see the module docstring).
PATHS = ("straight", "yaw_rate", "lane", "fused", "map")
#: Policies for stationary objects.
STATIONARY_POLICIES = ("all", "confirmed", "ignore")
#: The stationary policies as the compiled selection takes them.
_CONFIRMED, _IGNORE = STATIONARY_POLICIES.index("confirmed"), STATIONARY_POLICIES.index("ignore")
#: Widest half corridor the selection accepts [m].
MAX_HALF_WIDTH = 20.0


@dataclass(frozen=True)
class SelectionConfig:
    r"""In-path selection settings (see the module docstring for the sources).

    Attributes:
        path: ``"straight"``, ``"yaw_rate"``, ``"lane"``, ``"fused"`` (default) or ``"map"``.
        half_width: half the in-path corridor [m]; 1.75 (half a 3.5 m lane; assumption).
        enter_probability, keep_probability: in-path probability at which an object becomes
            selectable, and at which the object selected at the last step stays so (``"fused"``
            and ``"map"`` paths); 0.5 and 0.5, no hysteresis (assumptions).
        heading_std: std of a vehicle's heading about its lane's tangent, as its track gives it
            [rad]; 0.03 (lane keeping, 0.3 m/s of lateral speed at 30 m/s, is 0.01; a
            constant-velocity track's heading lags its turning vehicle's in a curve; on the
            bundled motorway 0.03 took a third fewer adjacent-lane alerts than 0.01;
            assumption).
        ego_heading_std: the road filter's initial std of the ego's heading to its lane
            [rad]; 0.02 (assumption).
        curvature_std: its initial std of the road's curvature [1/m]; 0.004 (a 250 m radius;
            assumption).
        curvature_rate_std: its initial std of the curvature's rate along the road [1/m²];
            1e-4 (a clothoid of parameter :math:`A` = 100 m; design guidelines ask :math:`A
            \ge R/3`, FGSV RAA 2008; assumption).
        curvature_walk: random walk of the curvature per metre driven [1/m/√m]; 1e-5 (1e-4
            over 100 m; assumption).
        curvature_rate_walk: random walk of the curvature's rate per metre driven [1/m²/√m];
            3e-6 (3e-5 over 100 m: a clothoid begins within about 100 m; assumption).
        steer_curvature_std: std of the ego's path curvature about the road's [1/m]; 1e-4 (0.1
            m/s² of lateral acceleration at 30 m/s; assumption).
        map_curvature_std: std of a map's lane curvature at the ego [1/m]; 0 (default): no map.
        map_lateral_std, map_heading_std: std of the ego's lateral position [m] and heading
            [rad] on the map (the ``"map"`` path); 0.10 and 0.0045 (the 95 % accuracies of 0.20
            m and 0.51° that Reid et al., SAE Int. J. CAV 2(3), 2019, require of an automated
            vehicle's localisation on freeways, read as 2σ).
        map_error_time: correlation time of those errors [s]; 2.0 (assumption).
        trail_range: nearest and farthest range [m] of the vehicles whose headings are used;
            (5, 150) (the field of the sensors; assumption).
        outlier_gate: normalised innovation [standard deviations] beyond which a vehicle's
            heading or a trail's step is left out (a vehicle changing lanes); 3.
        rail_band: the range of offsets [m] from the path, on either side, in which stationary
            objects are taken for a roadside trail; (2.5, 8.0) (beyond the ego lane, within a
            shoulder and a guardrail's reach; assumption).
        rail_gate: the largest difference [m] between the offsets of two neighbours of one
            trail; 0.75 (assumption).
        rail_std: the irregularity of a trail about a line parallel to the road [m]; 0.1
            (assumption).
        lateral_horizon: time [s] over which each object's lateral motion relative to the
            ego is carried forward for the in-path test (module docstring, "Lateral
            motion"); 0 (default): the offset now.
        stationary: ``"all"``, ``"confirmed"`` (default) or ``"ignore"``.
        stationary_speed: ground speed below which a track is stationary [m/s]; 2.0
            (assumption: above the speed noise of a converged track).
        oncoming: select tracks coming toward the ego (ground speed below
            ``-stationary_speed``); False (ISO 15623's rear-end scope).
        min_speed: speed below which the yaw-rate curvature is not formed [m/s]; 1.0.
    """

    path: str = "fused"
    half_width: float = 1.75
    enter_probability: float = 0.5
    keep_probability: float = 0.5
    heading_std: float = 0.03
    ego_heading_std: float = 0.02
    curvature_std: float = 0.004
    curvature_rate_std: float = 1e-4
    curvature_walk: float = 1e-5
    curvature_rate_walk: float = 3e-6
    steer_curvature_std: float = 1e-4
    map_curvature_std: float = 0.0
    map_lateral_std: float = 0.10
    map_heading_std: float = 0.0045
    map_error_time: float = 2.0
    trail_range: tuple[float, float] = (5.0, 150.0)
    outlier_gate: float = 3.0
    rail_band: tuple[float, float] = (2.5, 8.0)
    rail_gate: float = 0.75
    rail_std: float = 0.1
    lateral_horizon: float = 0.0
    stationary: str = "confirmed"
    stationary_speed: float = 2.0
    oncoming: bool = False
    min_speed: float = 1.0

    def __post_init__(self) -> None:
        check_choice("selection.path", self.path, PATHS)
        check_choice("selection.stationary", self.stationary, STATIONARY_POLICIES)
        check_range("selection.half_width", self.half_width, 0.0, MAX_HALF_WIDTH, lo_open=True)
        check_range("selection.stationary_speed", self.stationary_speed, 0.0, 50.0)
        check_range("selection.lateral_horizon", self.lateral_horizon, 0.0, 5.0)
        check_range("selection.min_speed", self.min_speed, 0.0, 50.0, lo_open=True)
        check_range("selection.enter_probability", self.enter_probability, 0.0, 1.0, lo_open=True)
        check_range("selection.keep_probability", self.keep_probability, 0.0,
                    self.enter_probability, lo_open=True)  # fmt: skip
        for name in ("heading_std", "ego_heading_std", "curvature_std", "curvature_rate_std",
                     "curvature_walk", "curvature_rate_walk", "steer_curvature_std"):  # fmt: skip
            check_range(f"selection.{name}", getattr(self, name), 0.0, 1.0, lo_open=True)
        check_range("selection.map_curvature_std", self.map_curvature_std, 0.0, 1.0)
        check_range("selection.map_lateral_std", self.map_lateral_std, 0.0, 10.0)
        check_range("selection.map_heading_std", self.map_heading_std, 0.0, 1.0)
        check_range("selection.map_error_time", self.map_error_time, 0.0, 3600.0, lo_open=True)
        check_interval("selection.trail_range", self.trail_range, lo_open=False)
        check_range("selection.outlier_gate", self.outlier_gate, 0.0, lo_open=True)
        check_interval("selection.rail_band", self.rail_band, lo_open=False)
        check_range("selection.rail_gate", self.rail_gate, 0.0, 10.0)
        check_range("selection.rail_std", self.rail_std, 0.0, 10.0, lo_open=True)

    def path_parameters(self) -> np.ndarray:
        """The parameters of :func:`acc_fusion.warning.path.road_step`, in its order."""
        prm = np.empty(fp.N_PARAMS)
        prm[[fp.HEADING_VAR, fp.STEER_VAR, fp.MAP_VAR, fp.C0_WALK, fp.C1_WALK]] = (
            np.array([self.heading_std, self.steer_curvature_std, self.map_curvature_std,
                      self.curvature_walk, self.curvature_rate_walk]) ** 2
        )  # fmt: skip
        prm[fp.MIN_SPEED], prm[fp.GATE] = self.min_speed, self.outlier_gate
        prm[fp.MIN_RANGE], prm[fp.MAX_RANGE] = self.trail_range
        prm[fp.RAIL_VAR], prm[fp.RAIL_GATE] = self.rail_std**2, self.rail_gate
        prm[fp.RAIL_MIN], prm[fp.RAIL_MAX] = self.rail_band
        return prm

    def initial_road_cov(self) -> np.ndarray:
        """The road filter's initial covariance ``(3, 3)`` (:mod:`acc_fusion.warning.path`)."""
        return np.diag([self.ego_heading_std, self.curvature_std, self.curvature_rate_std]) ** 2


def path_curvature(
    config: SelectionConfig, speed: np.ndarray, yaw_rate: np.ndarray, road_curvature: np.ndarray
) -> np.ndarray:
    """``(E,)`` curvature [1/m] of each ego's predicted path under ``config.path``, for the
    models of constant curvature (``"fused"`` fits it per step: :class:`InPathSelector`)."""
    if config.path == "straight":
        return np.zeros_like(speed)
    if config.path in ("lane", "map"):  # "map": where the map gives no path
        return np.array(road_curvature, dtype=float)
    return np.where(speed >= config.min_speed, yaw_rate / np.maximum(speed, config.min_speed), 0.0)


class InPathSelector(PairState):
    """Selects the in-path object of E egos among F object slots each, step by step.

    It remembers, per slot, whether the object in it has been seen moving or confirmed by a
    classifying sensor (a slot's memory starts afresh when its object id changes), and per ego the
    object it selected last.  After each :meth:`step` it holds that step's path and corridor for
    observers (the world environment's observation): ``curvature (E,)`` of the predicted path at the
    ego [1/m] (:math:`c_0`; with ``"map"`` the lane's at the ego, the map's path being no
    clothoid), ``curvature_rate (E,)`` [1/m²] (:math:`c_1`, 0 but for the ``"fused"``
    path), ``offset (E, F)`` each object's lateral offset from it, :math:`y - y_p(x)` [m],
    ``probability (E, F)`` its in-path probability (0 for an empty slot and for an object that the
    stationary and oncoming rules or a place behind the ego exclude), ``in_path (E, F)`` the objects
    it could select and ``selected (E,)`` the slot it returned.

    ``yaw_rate_std`` [rad/s] is the noise of the yaw rate it is given (the ``"fused"`` path
    weighs the gyro by it).
    """

    _PAIR_AXES = {"_ids": 0, "_vouched": 0, "_last": 0, "_theta": 0, "_cov": 0}

    def __init__(
        self, config: SelectionConfig, n_egos: int, n_slots: int, yaw_rate_std: float = 0.0
    ) -> None:
        self.config = config
        self._fused = config.path == "fused"
        self._prm = config.path_parameters()
        self._map_prm = np.array([PATH_STATIONS[1] - PATH_STATIONS[0], config.map_lateral_std**2,
                                  config.map_heading_std**2])  # fmt: skip
        self._gyro_var = float(yaw_rate_std) ** 2
        self._ids = np.full((n_egos, n_slots), -1, dtype=np.int64)
        self._vouched = np.zeros((n_egos, n_slots), dtype=bool)
        self._last = np.full(n_egos, -1, dtype=np.int64)
        self._theta = np.zeros((n_egos, 3))
        self._cov = np.tile(config.initial_road_cov(), (n_egos, 1, 1))
        self.curvature = np.zeros(n_egos)
        self.curvature_rate = np.zeros(n_egos)
        self.offset = np.zeros((n_egos, n_slots))
        self.probability = np.zeros((n_egos, n_slots))
        self.in_path = np.zeros((n_egos, n_slots), dtype=bool)
        self.selected = np.full(n_egos, -1, dtype=np.int64)

    def forget(self, egos: np.ndarray) -> None:
        """Forget what was seen of the objects of ``egos`` (a boolean mask ``(E,)``), e.g. a
        slot that a new vehicle took."""
        self._ids[egos] = -1
        self._vouched[egos] = False
        self._last[egos] = -1
        self._theta[egos] = 0.0
        self._cov[egos] = self.config.initial_road_cov()

    def step(
        self,
        object_id: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        ground_speed: np.ndarray,
        confirmed: np.ndarray,
        speed: np.ndarray,
        yaw_rate: np.ndarray,
        road_curvature: np.ndarray,
        vy: np.ndarray | float = 0.0,
        y_var: np.ndarray | float = 0.0,
        vy_var: np.ndarray | float = 0.0,
        dt: float = 0.1,
        seen: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
        road_path: np.ndarray | None = None,
    ) -> np.ndarray:
        """The selected slot of each ego, ``(E,)`` int64, ``-1`` where none is in path.

        Args:
            object_id: ``(E, F)`` id of the object in each slot, ``-1`` for an empty slot.
            x, y: ``(E, F)`` estimated position in the ego frame [m].
            ground_speed: ``(E, F)`` estimated ground speed of the object [m/s].
            confirmed: ``(E, F)`` a classifying sensor confirms the object as a vehicle.
            speed, yaw_rate, road_curvature: ``(E,)`` ego speed [m/s], measured yaw rate
                [rad/s] and the ego lane's curvature [1/m] (used by ``path="lane"``, by
                ``"fused"`` with a map, and by ``"map"`` where the map gives no path).
            vy, y_var, vy_var: ``(E, F)`` the objects' estimated lateral velocity relative to
                the ego [m/s], and the variances of ``y`` (used by ``"fused"`` and ``"map"``)
                and ``vy`` (``"fused"``; ``vy`` and ``vy_var`` by every path with a
                ``lateral_horizon``).
            dt: time since the last step [s] (the ``"fused"`` path's road filter).
            seen: ``(object_id, x, vx)``, each ``(E, F)``: what the road filter reads of the
                objects (their ids, ranges and relative longitudinal velocities), when it is
                not what the selection judges them by (default: ``object_id``, ``x`` and
                ``ground_speed - speed``) — the world's sensors' tracks of every object,
                where the selection sees one method's estimates of the objects it estimates.
            road_path: ``(E, len(PATH_STATIONS))`` the map's path of each ego as the ego
                places it (:class:`~acc_fusion.sensors.localization.MapLocalization`), for
                ``path="map"``.

        Raises:
            InputError: a wrong shape, or ``path="map"`` without ``road_path``.
        """
        cfg = self.config
        object_id = np.asarray(object_id)
        if object_id.shape != self._ids.shape:
            raise InputError(f"object_id must have shape {self._ids.shape}, got {object_id.shape}")
        n, f = object_id.shape
        grid = {name: broadcast(name, a, (n, f), t) for name, a, t in (
            ("x", x, float), ("y", y, float), ("ground_speed", ground_speed, float),
            ("confirmed", confirmed, bool), ("vy", vy, float), ("y_var", y_var, float),
            ("vy_var", vy_var, float))}  # fmt: skip
        ego = {name: broadcast(name, a, (n,), float) for name, a in (("speed", speed),
               ("yaw_rate", yaw_rate), ("road_curvature", road_curvature))}  # fmt: skip
        if seen is None:
            seen = (object_id, grid["x"], grid["ground_speed"] - ego["speed"][:, None])
        road_ids = broadcast("seen object_id", seen[0], (n, f), np.int64)
        road_x, road_vx = (broadcast(f"seen {name}", a, (n, f), float)
                           for name, a in (("x", seen[1]), ("vx", seen[2])))  # fmt: skip
        mapped = cfg.path == "map"
        if mapped and road_path is None:
            raise InputError(
                "world.selection.path = 'map' needs the lanes ahead from a map, which SUMO, "
                "highway-env and the scripted scenes give; choose another path for this source"
            )
        road_path = check_array("road_path", road_path, (n, PATH_STATIONS.size), finite=False) \
            if mapped else np.zeros((n, 0))  # fmt: skip
        kappa = np.zeros(n) if self._fused else path_curvature(cfg, *ego.values())
        self.curvature = broadcast("the path curvature", kappa, (n,), float)
        self.curvature_rate = np.zeros(n)
        self.offset, self.probability = np.empty((n, f)), np.empty((n, f))
        self.in_path = np.empty((n, f), dtype=bool)
        self.selected = np.empty(n, dtype=np.int64)
        _select(
            object_id.astype(np.int64, copy=False), *grid.values(), *ego.values(), road_ids,
            road_x, road_vx, self._fused, float(dt), self._gyro_var, self._prm, self._theta,
            self._cov, mapped, road_path, self._map_prm, cfg.half_width, cfg.enter_probability,
            cfg.keep_probability, cfg.lateral_horizon, cfg.stationary_speed, cfg.oncoming,
            STATIONARY_POLICIES.index(cfg.stationary), self._ids, self._vouched, self._last,
            self.curvature, self.curvature_rate, self.offset, self.probability, self.in_path,
            self.selected,
        )  # fmt: skip
        return self.selected


@njit(cache=True)
def _select(
    object_id, x, y, ground, confirmed, vy, y_var, vy_var, speed, yaw, road, road_ids, road_x,
    road_vx, fused, dt, gyro_var, prm, road_theta, road_cov, mapped, road_path, map_prm,
    half_width, enter, keep, horizon, still,
    oncoming, policy, ids, vouched, last, kappa, rate, offset, prob, in_path, selected,
):  # pragma: no cover - compiled  # fmt: skip
    r""":meth:`InPathSelector.step` of every ego, one pass over its slots: the memory ``ids``,
    ``vouched`` and ``last`` in place; with ``fused``, each ego's road filter ``road_theta``,
    ``road_cov`` one step on (:func:`~acc_fusion.warning.path.road_step`, reading the objects
    ``road_ids``, ``road_x``, ``road_vx``), its curvature and rate into ``kappa`` and
    ``rate`` (else ``kappa`` is given, the offset certain; with ``mapped`` the offset is
    from each ego's ``road_path`` with the localisation's variances ``map_prm[1:]``, its
    stations every ``map_prm[0]`` metres, ``kappa`` where it gives none);
    ``offset`` :math:`= y - y_p(x)`, ``prob`` (at the offset ``horizon`` seconds on, with
    ``vy`` and ``vy_var``, where ``horizon > 0``; 0 for an object the stationary, oncoming
    and behind-the-ego rules exclude), ``in_path`` and ``selected`` (the nearest
    in-path slot, the first of equals; -1 for none) written.  ``policy``: the index of the
    stationary policy in :data:`STATIONARY_POLICIES`."""
    n, f = object_id.shape
    usable, rest = np.empty(f, dtype=np.bool_), np.empty(f, dtype=np.bool_)
    band_off, band_order = np.empty(f), np.empty(f, dtype=np.int64)  # road_step's scratch
    for e in range(n):
        for k in range(f):
            oid = object_id[e, k]
            if oid != ids[e, k]:  # a new object in the slot: not yet seen moving or confirmed
                vouched[e, k] = False
            ids[e, k] = oid
            stationary = abs(ground[e, k]) < still
            vouched[e, k] = vouched[e, k] or (oid >= 0 and (not stationary or confirmed[e, k]))
            # the target selected last does not vouch for its own path (its cut-out must
            # not bend the path away from what it reveals)
            rid, rx, rg = road_ids[e, k], road_x[e, k], speed[e] + road_vx[e, k]
            usable[k] = rid >= 0 and rid != last[e] and rg >= still and rx > 0.0
            rest[k] = rid >= 0 and abs(rg) < still and rx > 0.0
        if fused:
            fp.road_step(road_theta[e], road_cov[e], dt, road_x[e], y[e], road_vx[e], vy[e],
                         y_var[e], vy_var[e], usable, rest, speed[e], yaw[e], gyro_var, road[e],
                         prm, band_off, band_order)  # fmt: skip
            kappa[e], rate[e] = road_theta[e, 1], road_theta[e, 2]
        best, nearest = -1, np.inf
        for k in range(f):
            oid = object_id[e, k]
            xk = x[e, k]
            if fused:
                off, var = fp.path_offset(road_theta[e], road_cov[e], xk, y[e, k], y_var[e, k])
            elif mapped:
                off, var = fp.map_offset(road_path[e], map_prm[0], xk, y[e, k], y_var[e, k],
                                         map_prm[1], map_prm[2], kappa[e])  # fmt: skip
            else:
                off, var = y[e, k] - 0.5 * kappa[e] * xk * xk, 0.0
            offset[e, k] = off
            if horizon > 0.0:  # where its lateral motion takes it (module docstring)
                off, var = off + vy[e, k] * horizon, var + horizon * horizon * vy_var[e, k]
            stationary = abs(ground[e, k]) < still
            ok = oid >= 0 and xk > 0.0
            if not oncoming:
                ok = ok and ground[e, k] > -still
            if policy == _IGNORE:
                ok = ok and not stationary
            elif policy == _CONFIRMED:
                ok = ok and (not stationary or vouched[e, k])
            # the probability only of an object the other rules let through (the erf pair
            # is the loop's cost)
            p = fp.in_path_probability(off, var, half_width) if ok else 0.0
            prob[e, k] = p
            ok = ok and (p >= enter or (oid == last[e] and p >= keep))
            in_path[e, k] = ok
            if ok and xk < nearest:
                best, nearest = k, xk
        selected[e] = best
        last[e] = object_id[e, best] if best >= 0 else -1
