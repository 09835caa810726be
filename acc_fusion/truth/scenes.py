r"""Scripted 2-D scenes: where single sensors' false and missed alerts come from.

Each scene is a road (plan curvature and vertical profile), an ego that drives its lane with the
Intelligent Driver Model behind its true in-path lead, and scripted actors — vehicles with a
speed program and lane changes, stationary roadside and overhead objects — batched over N runs
with per-run jitter.  Every step gives an :class:`~acc_fusion.truth.objects.ObjectFrame` (one ego
per run), so the 2-D sensors, trackers and in-path selection of the world pipeline meet the
situations in which field FCW systems choose the wrong target.

Scenes (:data:`SCENES`)
    ==============  ==========================================================================
    name            situation (the false-alarm or miss mechanism it reproduces)
    ==============  ==========================================================================
    lead_brakes     straight road, the lead brakes hard: the crash-relevant reference (the 1-D
                    pipeline's special case in 2-D)
    curve_adjacent  approaching a left curve, a slower car in the right lane lies on the
                    straight extension of the ego's path (adjacent-lane mis-selection)
    cut_in          a slower car changes into the ego lane close ahead
    cut_out         the lead changes lane and reveals a stopped car (radar systems that ignore
                    stationary targets miss it)
    gantry_crest    a sign gantry at the top of a crest, in the radar's elevation beam while
                    the ego climbs (an overhead stationary false target)
    parked_curve    approaching a left curve, a car parked on the right shoulder lies on the
                    straight extension of the path (a stationary false target)
    ==============  ==========================================================================

All scenes have guardrail posts along the right edge (sparse representative roadside metal).
Weather and light are not part of a scene: they are a separate axis
(:class:`~acc_fusion.truth.conditions.Conditions`) that the sensors read.

Geometry: the ego lane's centreline is parameterised by arc length :math:`s` with
piecewise-constant plan curvature :math:`\kappa(s)` (heading :math:`\theta = \int \kappa\,ds`)
and vertical curvature :math:`\kappa_v(s)` (grade :math:`g = \int \kappa_v\,ds`, height
:math:`z = \int g\,ds`); an actor at :math:`(s, d)` (``d`` lateral, left positive, lanes
``LANE_WIDTH`` apart) sits at :math:`P(s) + d\,n(s)`, :math:`n` the left normal.  An object's
``elevation`` is the height of its lower edge above the plane through the ego's wheels along
the ego's grade, :math:`e = h_0 + z(s) - z(s_e) - g(s_e)(s - s_e)` (so on a crest an overhead
gantry sinks toward a forward-looking sensor's boresight).

Object signatures (:data:`SIGNATURES`) are assumptions anchored where a source exists: a
passenger car's 77 GHz RCS is of the order of 10 dBsm (measurements spread over 0-20 dBsm with
aspect; e.g. Kamel, Peden & Pezeshki, "RCS modeling and measurements for automotive radar
applications in the W band", EuCAP 2017); large metal structures (gantries, bridges) return
far more (assumption: 25 dBsm), a guardrail post little (assumption: 0 dBsm).  Thermal contrasts
(assumption): a driven car's tyres, exhaust and engine about 10 K above the road, a parked car
with a cold engine 2 K, unheated steel about 0.5 K.  A steel trench plate flat on the road (FMVSS
127 S9.2: 2.4 m × 3.7 m × 25 mm, 3.7 m along the road) reflects its face away from a radar at
grazing incidence; its leading edge returns about a straight edge's :math:`L^2/\pi` (2.6 dBsm
for 2.4 m; Knott, Shaeffer & Tuley, *Radar Cross Section*, 2004) less a grazing loss: 0 dBsm.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_choice, check_range
from acc_fusion.truth.manoeuvre_params import IDM, LANE_WIDTH
from acc_fusion.truth.objects import OFF_ROAD, ObjectFrame, ObjectKind
from acc_fusion.truth.road import Road, RoadGeometry
from acc_fusion.truth.speed_changes import SpeedChanges

#: (length, width, height [m], rcs [dBsm], thermal contrast [K]) per kind; see the module
#: docstring for the sources and assumptions.
SIGNATURES: dict[ObjectKind, tuple[float, float, float, float, float]] = {
    ObjectKind.VEHICLE: (4.5, 1.8, 1.5, 10.0, 10.0),
    ObjectKind.PARKED: (4.5, 1.8, 1.5, 10.0, 2.0),
    ObjectKind.GANTRY: (0.5, 3 * LANE_WIDTH + 6.0, 2.0, 25.0, 0.5),
    ObjectKind.BRIDGE: (10.0, 3 * LANE_WIDTH + 10.0, 1.5, 25.0, 0.5),
    ObjectKind.GUARDRAIL: (0.2, 0.2, 0.8, 0.0, 0.5),
    ObjectKind.SIGN: (0.1, 1.0, 2.0, 5.0, 0.5),
    ObjectKind.PLATE: (3.7, 2.4, 0.025, 0.0, 0.5),
}

#: Longest range [m] (beyond any sensor's range) and half width [m] of the forward field the
#: scenes report.
FIELD_RANGE, FIELD_HALF_WIDTH = 300.0, 40.0
#: Spacing of the guardrail posts [m] (sparse representatives of the rail; assumption).
GUARDRAIL_SPACING = 25.0
#: Lateral position of the right guardrail [m]: half a lane, a 2.5 m hard shoulder, 0.5 m.
GUARDRAIL_OFFSET = -(LANE_WIDTH / 2 + 3.0)
#: Lateral position of a car parked on the right hard shoulder [m].
SHOULDER_OFFSET = -(LANE_WIDTH / 2 + 1.5)
#: Length and width of the ego (the subject vehicle) [m]: a vehicle's (:data:`SIGNATURES`).
EGO_LENGTH, EGO_WIDTH = SIGNATURES[ObjectKind.VEHICLE][:2]
#: The ego models of a :class:`Scene` and its rules for the in-path lead.
EGO_MODELS, LEAD_RULES = ("idm", "cruise"), ("lane", "overlap")


@dataclass
class Actors:
    r"""Scripted actors, arrays ``(N, A)`` (runs × actors).

    A vehicle's centre moves along the road at speed ``v0`` until ``brake_time``, then slows
    at ``brake_decel`` (reached linearly over ``brake_rise``, 0: a step) to a stop; its lateral
    offset moves from ``d0`` to ``d1`` between ``lc_time`` and ``lc_time + lc_duration`` (a
    cosine blend).  Stationary objects have ``v0 = 0``.  ``clearance`` is the height of the
    lower edge above its road [m].  ``present`` (bool; ``None``: all) marks the actors a run
    has (absent ones pad a batch whose runs differ: in no frame, never a lead).  ``speed_changes``
    (``None``: none) add scripted transitions to the speed (:mod:`acc_fusion.truth.speed_changes`).
    """

    kind: np.ndarray
    s0: np.ndarray
    v0: np.ndarray
    d0: np.ndarray
    d1: np.ndarray
    brake_time: np.ndarray
    brake_decel: np.ndarray
    lc_time: np.ndarray
    lc_duration: np.ndarray
    clearance: np.ndarray
    brake_rise: np.ndarray | None = None
    present: np.ndarray | None = None
    speed_changes: SpeedChanges | None = None

    def centre(self, t: float | np.ndarray) -> tuple[np.ndarray, ...]:
        """Arc length, speed, acceleration, lateral offset and its rate at time ``t`` (or at
        each run's own time, ``(N, 1)``)."""
        tb = np.minimum(t, self.brake_time)
        tau = np.maximum(t - self.brake_time, 0.0)
        stop = np.divide(self.v0, self.brake_decel, out=np.full_like(self.v0, np.inf),
                         where=self.brake_decel > 0)  # fmt: skip
        tau = np.minimum(tau, stop)
        v = self.v0 - self.brake_decel * tau
        s = self.s0 + self.v0 * tb + self.v0 * tau - 0.5 * self.brake_decel * tau**2
        braking = (t > self.brake_time) & (tau < stop)
        a = np.where(braking, -self.brake_decel, 0.0)
        if self.brake_rise is not None and np.any(self.brake_rise > 0.0):  # ramped braking
            x, vr, dr, _ = ramp_braking(self.v0, self.brake_decel, self.brake_rise, t - tb)
            on = self.brake_rise > 0.0
            s, v = np.where(on, self.s0 + self.v0 * tb + x, s), np.where(on, vr, v)
            a = np.where(on, np.where(t > self.brake_time, -dr, 0.0), a)
        if self.speed_changes is not None:
            s, v, a = self.speed_changes.apply(t, s, v, a)
        u = np.clip((t - self.lc_time) / self.lc_duration, 0.0, 1.0)
        d = self.d0 + (self.d1 - self.d0) * 0.5 * (1.0 - np.cos(np.pi * u))
        inside = (u > 0.0) & (u < 1.0)
        rate = (self.d1 - self.d0) * 0.5 * np.pi * np.sin(np.pi * u) / self.lc_duration
        return s, v, a, d, np.where(inside, rate, 0.0)


def ramp_braking(v0, decel, rise, tau) -> tuple[np.ndarray, ...]:
    """Braking from ``v0`` [m/s], the deceleration rising linearly to ``decel`` [m/s²] over
    ``rise`` [s]: after ``tau`` [s] (``inf``: to the stop), the distance [m], speed [m/s] and
    deceleration [m/s²] (0 once stopped); and the time to the stop [s]."""
    v0, dec, r = np.asarray(v0, dtype=float), np.asarray(decel, dtype=float), np.maximum(rise, 1e-9)
    safe = np.where(dec > 0.0, dec, 1.0)
    short = np.sqrt(2.0 * r * v0 / safe)  # it stops within the ramp (v0 <= D R / 2)
    stop = np.where(dec > 0.0, np.where(v0 <= 0.5 * dec * r, short, v0 / safe + r / 2), np.inf)
    tau = np.minimum(tau, stop)
    t1, t2 = np.minimum(tau, r), np.maximum(tau - r, 0.0)
    v1 = v0 - dec * t1**2 / (2.0 * r)
    x = v0 * t1 - dec * t1**3 / (6.0 * r) + v1 * t2 - 0.5 * dec * t2**2
    decel_now = np.where(tau < stop, dec * np.minimum(tau / r, 1.0), 0.0)
    return x, np.maximum(v1 - dec * t2, 0.0), decel_now, stop


def _actors(n: int, specs: list[dict[str, object]], changes: SpeedChanges | None = None) -> Actors:
    """Stack actor specs (scalars or ``(n,)`` arrays per field) into :class:`Actors`."""
    defaults = {"v0": 0.0, "d0": 0.0, "brake_time": np.inf, "brake_decel": 0.0,
                "lc_time": np.inf, "lc_duration": 1.0, "clearance": 0.0, "brake_rise": 0.0,
                "present": 1.0}  # fmt: skip
    columns: dict[str, list] = {k: [] for k in Actors.__dataclass_fields__ if k != "speed_changes"}
    for spec in specs:
        full = {**defaults, **spec}
        full.setdefault("d1", full["d0"])
        for key in columns:
            columns[key].append(np.broadcast_to(np.asarray(full[key], dtype=float), (n,)))
    arrays = {k: np.stack(v, axis=1) for k, v in columns.items()}
    arrays["kind"] = arrays["kind"].astype(np.int8)
    arrays["present"] = arrays["present"] != 0.0
    return Actors(**arrays, speed_changes=changes)


@dataclass
class Scene:
    """A scene batched over N runs: the road, the actors, the ego's start and driving: the IDM
    behind the in-path lead (``ego_model = "idm"``, ``ego_desired_speed``, ``ego_headway``) or
    a constant speed (``"cruise"``, a test driver); the lead is the nearest vehicle ahead in
    the ego's lane (``lead_rule = "lane"``) or whose body overlaps the ego's laterally,
    :math:`|d| < (w + W_e)/2` (``"overlap"``)."""

    name: str
    road: Road
    actors: Actors
    ego_speed: np.ndarray
    ego_desired_speed: np.ndarray
    ego_headway: np.ndarray
    duration: float
    ego_model: str = "idm"
    lead_rule: str = "lane"

    def __post_init__(self) -> None:
        check_choice("ego_model", self.ego_model, EGO_MODELS)
        check_choice("lead_rule", self.lead_rule, LEAD_RULES)


def _guardrail(n: int, road: Road) -> list[dict[str, object]]:
    posts = np.arange(-50.0, road.length - 100.0, GUARDRAIL_SPACING)
    return [{"kind": ObjectKind.GUARDRAIL, "s0": p, "d0": GUARDRAIL_OFFSET} for p in posts]


def _u(rng: np.random.Generator, lo: float, hi: float, n: int) -> np.ndarray:
    return rng.uniform(lo, hi, n)


def lead_brakes(n: int, rng: np.random.Generator) -> Scene:
    """Straight road; the lead (0.8-1.6 s ahead, 22-30 m/s, the ego following at its own
    speed) brakes at 4-8 m/s² to a stop after 4-6 s."""
    road = Road()
    v = _u(rng, 22.0, 30.0, n)
    gap = v * _u(rng, 0.8, 1.6, n)
    lead = {"kind": ObjectKind.VEHICLE, "s0": gap + 2.25, "v0": v,
            "brake_time": _u(rng, 4.0, 6.0, n), "brake_decel": _u(rng, 4.0, 8.0, n)}  # fmt: skip
    return Scene("lead_brakes", road, _actors(n, [lead, *_guardrail(n, road)]),
                 v, v, gap / v, 12.0)  # fmt: skip


def curve_adjacent(n: int, rng: np.random.Generator) -> Scene:
    r"""A left curve (R 300-500 m) starts 150 m ahead of the ego (30 m/s); a slow vehicle in
    the right lane (12-18 m/s, a truck on a grade) is :math:`\sqrt{2 w R}` (± 5 m) into the
    curve when the ego reaches it — where the right lane crosses the straight extension of the
    ego's path."""
    radius = rng.uniform(300.0, 500.0)
    road = Road(curves=((150.0, 1.0 / radius),))
    v = np.full(n, 30.0)
    v_other = _u(rng, 12.0, 18.0, n)
    into = np.sqrt(2.0 * LANE_WIDTH * radius) + _u(rng, -5.0, 5.0, n)
    other = {"kind": ObjectKind.VEHICLE, "s0": 150.0 + into - v_other * 150.0 / v,
             "v0": v_other, "d0": -LANE_WIDTH}  # fmt: skip
    return Scene("curve_adjacent", road, _actors(n, [other, *_guardrail(n, road)]),
                 v, v, np.full(n, 1.5), 10.0)  # fmt: skip


def cut_in(n: int, rng: np.random.Generator) -> Scene:
    """A car in the left lane, 15-30 m ahead and 2-5 m/s slower than the ego (25 m/s),
    changes into the ego lane after 0.5-1.5 s, taking 2-3 s: a close cut-in (a time gap of
    0.6-1.2 s; assumption), some of them crash-relevant, some a nuisance, and some warned on
    while the car is still crossing into the lane (the cut-in mis-selection)."""
    road = Road()
    v = np.full(n, 25.0)
    car = {"kind": ObjectKind.VEHICLE, "s0": _u(rng, 15.0, 30.0, n),
           "v0": v - _u(rng, 2.0, 5.0, n), "d0": LANE_WIDTH, "d1": 0.0,
           "lc_time": _u(rng, 0.5, 1.5, n), "lc_duration": _u(rng, 2.0, 3.0, n)}  # fmt: skip
    return Scene("cut_in", road, _actors(n, [car, *_guardrail(n, road)]),
                 v, v + 2.0, np.full(n, 1.5), 10.0)  # fmt: skip


def cut_out(n: int, rng: np.random.Generator) -> Scene:
    """The ego (22 m/s) follows a lead 1.5 s ahead; a car stands in the lane 180-220 m ahead;
    the lead changes to the left lane (2 s) when it is 40-55 m from the stopped car."""
    road = Road()
    v = np.full(n, 22.0)
    lead_s0 = v * 1.5 + 2.25
    stopped_s = _u(rng, 180.0, 220.0, n)
    lc = (stopped_s - _u(rng, 40.0, 55.0, n) - lead_s0) / v
    lead = {"kind": ObjectKind.VEHICLE, "s0": lead_s0, "v0": v, "d1": LANE_WIDTH,
            "lc_time": lc, "lc_duration": 2.0}  # fmt: skip
    stopped = {"kind": ObjectKind.VEHICLE, "s0": stopped_s}
    return Scene("cut_out", road, _actors(n, [lead, stopped, *_guardrail(n, road)]),
                 v, v + 2.0, np.full(n, 1.5), 14.0)  # fmt: skip


def gantry_crest(n: int, rng: np.random.Generator) -> Scene:
    """A sign gantry (clearance 5.2-5.5 m) stands at the top of a crest 200 m ahead (vertical
    radius 2-4 km over ±100 m); the ego drives at 30 m/s with no lead."""
    radius = rng.uniform(2000.0, 4000.0)
    road = Road(vertical=((100.0, 300.0, -1.0 / radius),))
    v = np.full(n, 30.0)
    gantry = {"kind": ObjectKind.GANTRY, "s0": 200.0, "clearance": _u(rng, 5.2, 5.5, n)}
    return Scene("gantry_crest", road, _actors(n, [gantry, *_guardrail(n, road)]),
                 v, v + 2.0, np.full(n, 1.5), 8.0)  # fmt: skip


def parked_curve(n: int, rng: np.random.Generator) -> Scene:
    r"""A left curve (R 250-400 m) starts 150 m ahead; a car is parked on the right shoulder
    where the straight extension of the ego's path crosses it,
    :math:`\sqrt{2|d|/\kappa}` into the curve; the ego drives at 25 m/s."""
    radius = rng.uniform(250.0, 400.0)
    road = Road(curves=((150.0, 1.0 / radius),))
    v = np.full(n, 25.0)
    into = np.sqrt(2.0 * abs(SHOULDER_OFFSET) * radius)
    parked = {"kind": ObjectKind.PARKED, "s0": 150.0 + into + _u(rng, -5.0, 5.0, n),
              "d0": SHOULDER_OFFSET}  # fmt: skip
    return Scene("parked_curve", road, _actors(n, [parked, *_guardrail(n, road)]),
                 v, v + 2.0, np.full(n, 1.5), 10.0)  # fmt: skip


#: The scenes by name.
SCENES: dict[str, Callable[[int, np.random.Generator], Scene]] = {
    f.__name__: f
    for f in (lead_brakes, curve_adjacent, cut_in, cut_out, gantry_crest, parked_curve)
}


@dataclass(frozen=True)
class SceneConfig:
    """Which scene, how many runs and the step.

    Attributes:
        scene: a name of :data:`SCENES`.
        runs: Monte Carlo runs (one ego each), ``>= 1``.
        dt: step [s].
    """

    scene: str = "cut_out"
    runs: int = 50
    dt: float = 0.05

    def __post_init__(self) -> None:
        check_choice("scene", self.scene, SCENES)
        if not isinstance(self.runs, int) or self.runs < 1:
            raise ConfigError(f"runs must be an integer >= 1, got {self.runs!r}")
        check_range("dt", self.dt, 0.0, 1.0, lo_open=True)


class SceneSource:
    """A scene as a truth source: :meth:`frame` is the :class:`ObjectFrame` of the current
    step, :meth:`advance` moves one step (the egos by the IDM behind their true in-path
    lead, or at constant speed).  ``collided`` marks runs whose ego reached its lead (it then
    moves with it).  ``active``: the runs going on; all, unless a subclass ends runs at
    ``_end_t`` (:class:`acc_fusion.truth.procedures.TrackSource`)."""

    #: Give each frame the road ahead as a map would (:attr:`ObjectFrame.road_path`).
    map_path = False

    def __init__(
        self,
        config: SceneConfig,
        seed: int | np.random.Generator | None = None,
        map_path: bool = False,
    ):
        self.config: SceneConfig | None = config
        self.map_path = bool(map_path)
        self._setup(SCENES[config.scene](config.runs, np.random.default_rng(seed)), config.dt)

    def _setup(self, scene: Scene, dt: float) -> None:
        self.scene, self.dt = scene, dt
        self._geo = RoadGeometry(scene.road)
        n = scene.ego_speed.shape[0]
        self.t = 0.0
        self._s, self._a = np.zeros(n), np.zeros(n)  # ego front bumper, acceleration
        self._v = scene.ego_speed.astype(float).copy()
        self.collided, self.active = np.zeros(n, dtype=bool), np.ones(n, dtype=bool)
        self._collision_speed = np.full(n, np.nan)
        self._end_t = np.full(n, np.inf)  # when each run ended
        table = np.array([SIGNATURES[ObjectKind(k)] for k in range(len(ObjectKind))])
        self._sig = table[scene.actors.kind]  # (N, A, 5)
        present = scene.actors.present  # (N, A): actors a run has
        self._present = np.ones(self._sig.shape[:2], bool) if present is None else present

    @property
    def collision_speed(self) -> np.ndarray:
        """``(N,)`` closing speed at each run's first collision [m/s], NaN where none."""
        return self._collision_speed.copy()

    @property
    def n_steps(self) -> int:
        """Steps in the scene."""
        return int(round(self.scene.duration / self.dt))

    @property
    def done(self) -> bool:
        """The scene's duration has passed, or every run has ended."""
        return self.t >= self.scene.duration - 1e-9 or not self.active.any()

    def _lead(self, s, d, kind) -> tuple[np.ndarray, np.ndarray]:
        """The true in-path lead of each ego (slot, ``-1``) and the gap to it [m]."""
        length = self._sig[..., 0]
        rear = s - length / 2
        vehicle = (kind == ObjectKind.VEHICLE) & self._present
        if self.scene.lead_rule == "lane":
            in_lane = vehicle & (np.rint(d / LANE_WIDTH) == 0)
        else:  # the bodies overlap laterally
            in_lane = vehicle & (np.abs(d) < (self._sig[..., 1] + EGO_WIDTH) / 2)
        ahead = in_lane & (rear > self._s[:, None] - 1.0)
        gap = np.where(ahead, rear - self._s[:, None], np.inf)
        lead = np.argmin(gap, axis=1)
        g = gap[np.arange(gap.shape[0]), lead]
        return np.where(np.isfinite(g), lead, -1), g

    def frame(self) -> ObjectFrame:
        """The objects ahead of each ego now."""
        geo, act = self._geo, self.scene.actors
        t_act = self.t if self.active.all() else np.minimum(self.t, self._end_t)[:, None]
        s, v, a, d, d_rate = act.centre(t_act)  # an ended run's actors at its end
        lead, _ = self._lead(s, d, act.kind)
        length, width, height, rcs, contrast = np.moveaxis(self._sig, -1, 0)
        se = self._s[:, None]
        ahead = s >= se
        face = np.where(ahead, s - length / 2, s + length / 2)
        px, py = geo.point(face, d)
        ex, ey = geo.point(self._s, np.zeros_like(self._s))
        th_e = geo.at("theta", self._s)[:, None]
        c, sn = np.cos(th_e), np.sin(th_e)
        dx, dy = px - ex[:, None], py - ey[:, None]
        x, y = c * dx + sn * dy, -sn * dx + c * dy
        psi = geo.at("theta", s) + np.arctan2(d_rate, np.maximum(v, 1e-3))
        ground = np.hypot(v, d_rate)
        gvx = ground * np.cos(psi) - (self._v[:, None] * c)
        gvy = ground * np.sin(psi) - (self._v[:, None] * sn)
        vx, vy = c * gvx + sn * gvy, -sn * gvx + c * gvy
        z_e, grade_e = geo.at("z", self._s)[:, None], geo.at("grade", self._s)[:, None]
        elevation = act.clearance + geo.at("z", s) - z_e - grade_e * (s - se)
        on_lane = (act.kind == ObjectKind.VEHICLE) | (act.kind == ObjectKind.PLATE)
        lane = np.where(on_lane, np.rint(d / LANE_WIDTH), OFF_ROAD).astype(np.int64)
        valid = (x > 0.0) & (x <= FIELD_RANGE) & (np.abs(y) <= FIELD_HALF_WIDTH) & self._present
        rows = np.arange(lead.shape[0])
        lead = np.where((lead >= 0) & valid[rows, np.maximum(lead, 0)] & self.active, lead, -1)
        n_actors = act.kind.shape[1]
        kappa = geo.at("kappa", self._s)
        yaw = kappa * self._v
        return ObjectFrame(
            t=self.t, ego_speed=self._v.copy(), ego_accel=self._a.copy(), ego_yaw_rate=yaw,
            road_curvature=kappa, valid=valid,
            object_id=np.broadcast_to(np.arange(n_actors), valid.shape).copy(),
            kind=act.kind, x=x, y=y, elevation=elevation, vx=vx, vy=vy,
            speed=np.broadcast_to(ground, valid.shape).copy(), accel=a, heading=psi - th_e,
            length=length, width=width, height=height, rcs=rcs, thermal_contrast=contrast,
            lane=lane, lead=lead, lateral_speed=d_rate,
            road_path=self._geo.lane_ahead(self._s, ex, ey, th_e[:, 0]) if self.map_path else None,
        )  # fmt: skip

    def advance(self, ego_brake: np.ndarray | None = None) -> None:
        r"""One step: the egos follow their leads with the IDM (or hold their speed); a gap
        <= 0 is a collision.

        ``ego_brake (N,)`` [m/s², >= 0] is the deceleration a driver (reacting to a warning,
        :class:`acc_fusion.truth.driver.Driver`) or an AEB requests; where it is positive the
        ego brakes at least that hard: :math:`a = \min(a_\text{IDM}, -b)` (a cruising ego:
        :math:`-b`, and it keeps its speed when the request ends).  ``None``: no request.
        """
        dt, act = self.dt, self.scene.actors
        s, v, _, d, _ = act.centre(self.t)
        lead, gap = self._lead(s, d, act.kind)
        has = lead >= 0
        rows = np.arange(lead.shape[0])
        v_lead = np.where(has, v[rows, np.maximum(lead, 0)], self._v)
        hit = has & (gap <= 0.0)
        first = hit & ~self.collided
        self._collision_speed[first] = (self._v - v_lead)[first]
        self.collided |= hit
        accel = np.where(self.collided, 0.0, self._accel(gap, v_lead, has, ego_brake))
        v_new = np.maximum(self._v + accel * dt, 0.0)
        self._a = np.where(self.collided, 0.0, (v_new - self._v) / dt)  # over this step
        self._v = np.where(self.collided, v_lead, v_new)
        self._s += self._v * dt
        self.t += dt

    def _accel(self, gap, v_lead, has, ego_brake) -> np.ndarray:
        """The egos' acceleration by the ego model, with the brake requests."""
        sc = self.scene
        if sc.ego_model == "idm":
            accel = IDM.accel(self._v, sc.ego_desired_speed, sc.ego_headway, gap, v_lead, has)
        else:
            accel = np.zeros_like(self._v)
        if ego_brake is not None:
            brake = np.asarray(ego_brake, dtype=float)
            accel = np.where(brake > 0.0, np.minimum(accel, -brake), accel)
        return accel
