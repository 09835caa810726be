r"""Forward collision warning end to end: scenario → sensors → fusion → warning → metrics.

:func:`simulate` runs one :class:`SimConfig`: a batch of runs of a scripted scenario (or the
randomised suite), the radar and infrared sensors, the ego-motion filter (ego speed from
wheel speed + accelerometer, yang2009), one estimator per compared method, the warning
logic of each method, the *oracle* (the same warning rule on ground truth) and the
streaming metrics of each method against the oracle (:mod:`acc_fusion.metrics.events`).

Open loop (``drive=None``) every method observes the same truth, so their false-alarm and
miss rates are compared on identical runs.  Closed loop (``drive="federated"``, say) the
simulated driver (:mod:`acc_fusion.truth.driver`) reacts to that method's warnings and brakes,
so the truth itself depends on the warnings; collisions with warnings on and off are then
compared on the same seeds (:func:`compare`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit
from tqdm.auto import tqdm

from acc_fusion.braking.aeb import AEB, AEBConfig
from acc_fusion.core.errors import AccFusionError, ConfigError
from acc_fusion.core.levels import IMMINENT
from acc_fusion.core.slots import Extent, PairState, resize_all
from acc_fusion.core.validation import check_choice, check_range
from acc_fusion.filters.ego import EgoFilterConfig, EgoMotionFilter
from acc_fusion.fusion.base import Estimate
from acc_fusion.fusion.config import FUSION_METHODS, FilterConfig, FusionConfig
from acc_fusion.fusion.estimators import make_estimator
from acc_fusion.metrics.alert_classes import AlertClassConfig, crash_relevant
from acc_fusion.metrics.events import FCWMetrics
from acc_fusion.metrics.summary import FCWSummary
from acc_fusion.sensors.driver_monitor import DriverMonitor
from acc_fusion.sensors.faults import Fault
from acc_fusion.sensors.sensor import Measurement
from acc_fusion.sensors.spec import infrared_spec, radar_spec
from acc_fusion.sensors.suite import SENSOR_NAMES, make_sensors
from acc_fusion.sim.world_config import WorldConfig
from acc_fusion.truth.driver import Driver, DriverConfig
from acc_fusion.truth.frame import TruthFrame
from acc_fusion.truth.manoeuvres import SCENARIOS
from acc_fusion.truth.scripted import make_scenario
from acc_fusion.warning.logic import WarningConfig, WarningLogic
from acc_fusion.warning.ttc import time_to_collision

#: The methods compared by default: each sensor alone, centralized and federated fusion.
DEFAULT_METHODS = ("radar", "infrared", "centralized", "federated")
#: Wheel-speed and accelerometer noise of the simulated ego sensors, and the spread of the
#: accelerometer's constant offset (see :class:`acc_fusion.filters.ego.EgoFilterConfig`).
WHEEL_SPEED_STD, ACCEL_STD, ACCEL_BIAS_STD = 0.1, 0.1, 0.3


@dataclass(frozen=True)
class SimConfig:
    """Everything a simulation needs: one typed schema for config files and CLI flags.

    Attributes:
        scenario: a name of :data:`acc_fusion.truth.manoeuvres.SCENARIOS` (``"random"``: the
            randomised Monte Carlo suite).
        runs: number of runs (batched).
        seed: seed of truth, sensor noise and driver draws.
        dt: simulation step [s]; the filters' step ``fusion.filter.dt`` is derived from it.
        duration: run length [s] (``None``: the scenario's own).
        methods: compared methods (sensor names or fusion methods).
        drive: method whose warnings the driver reacts to (closed loop); ``None``: open loop.
        fusion: fusion settings shared by every method (its ``method`` field is ignored).
        warning: safety-distance model and warning logic (also used by the oracle).
        driver: reaction time and deceleration of the simulated driver (by default he reacts
            to the imminent alert).
        alert_classes: when truth says the driver must act (the crash-relevant situations the
            warnings are classed against, :mod:`acc_fusion.metrics.alert_classes`).
        tolerance: time window [s] within which a warning and an oracle threat match.
        warn_level: the level that counts as a warning in the metrics: 2, imminent (the FCW
            alert; default) or 1, caution.
        radar, infrared: overrides of the sensors' default specs (e.g. ``{"ghost_rate": 0.1}``).
        radar_faults, infrared_faults: faults injected into each sensor.
        world: the 2-D world's settings (scene, conditions, 2-D sensors, trackers,
            association, in-path selection), used by :func:`acc_fusion.sim.world.simulate_world`.
        aeb: automatic emergency braking after the warning (:mod:`acc_fusion.braking.aeb`;
            off by default: FCW only).
    """

    scenario: str = "random"
    runs: int = 200
    seed: int = 0
    dt: float = 0.05
    duration: float | None = None
    methods: tuple[str, ...] = DEFAULT_METHODS
    drive: str | None = None
    fusion: FusionConfig = field(default_factory=FusionConfig)
    warning: WarningConfig = field(default_factory=WarningConfig)
    driver: DriverConfig = field(default_factory=lambda: DriverConfig(react_to_level=IMMINENT))
    alert_classes: AlertClassConfig = field(default_factory=AlertClassConfig)
    tolerance: float = 1.0
    warn_level: int = IMMINENT
    radar: dict = field(default_factory=dict)
    infrared: dict = field(default_factory=dict)
    radar_faults: tuple[Fault, ...] = ()
    infrared_faults: tuple[Fault, ...] = ()
    world: WorldConfig = field(default_factory=WorldConfig)
    aeb: AEBConfig = field(default_factory=AEBConfig)

    def __post_init__(self) -> None:
        check_choice("scenario", self.scenario, tuple(SCENARIOS))
        if not isinstance(self.runs, int) or not 1 <= self.runs <= 10_000_000:
            raise ConfigError(f"runs must be a whole number in [1, 10000000], got {self.runs!r}")
        if not isinstance(self.seed, int) or not 0 <= self.seed < 2**63:
            raise ConfigError(f"seed must be a whole number in [0, 2**63), got {self.seed!r}")
        check_range("dt", self.dt, 0.0, 1.0, lo_open=True)
        # The filters' step is the simulation's: derived here, once, not set twice.
        step = self.fusion.filter.dt
        if step != self.dt and step != FilterConfig.dt:
            raise ConfigError(
                f"fusion.filter.dt is the simulation step dt ({self.dt:g} s), derived from it; "
                f"set dt instead of fusion.filter.dt = {step!r}"
            )
        filters = replace(self.fusion.filter, dt=self.dt)
        object.__setattr__(self, "fusion", replace(self.fusion, filter=filters))
        if self.duration is not None:
            check_range("duration", self.duration, 0.0, 1e6, lo_open=True)
        object.__setattr__(self, "methods", tuple(self.methods))
        if not self.methods:
            raise ConfigError("methods must name at least one method")
        for m in self.methods:
            check_choice("methods[i]", m, SENSOR_NAMES + FUSION_METHODS)
        if self.drive is not None:
            check_choice("drive", self.drive, self.methods)
        if self.aeb.method is not None:
            check_choice("aeb.method", self.aeb.method, self.methods)
        check_range("tolerance", self.tolerance, 0.0, 60.0)
        check_choice("warn_level", str(self.warn_level), ("1", "2"))
        # Build the specs once so that a bad override fails here, naming the field.
        self.sensor_specs()

    def sensor_specs(self):
        """The radar and infrared specs with this config's overrides."""
        return radar_spec(**self.radar), infrared_spec(**self.infrared)

    @property
    def aeb_method(self) -> str:
        """The method whose in-path estimate AEB reads: ``aeb.method``, else ``drive``, else
        the last of ``methods``."""
        return self.aeb.method or self.drive or self.methods[-1]


@dataclass
class StepView:
    """What one step of :func:`simulate` produced (handed to ``on_step`` callbacks).

    With a source of slots (SUMO, highway-env) the arrays cover the first
    ``frame.n_pairs`` slots, which hold every vehicle (:mod:`acc_fusion.core.slots`)."""

    frame: TruthFrame
    measurements: list[Measurement]
    estimates: dict[str, Estimate]
    levels: dict[str, np.ndarray]
    oracle: np.ndarray
    ttc: np.ndarray
    relevant: np.ndarray
    driver: Driver | None = None
    """The drivers (closed loop), after their step: their brake requests for this step."""
    aeb: AEB | None = None
    """The AEB (``config.aeb.enabled``), after its step: its stage and braking this step."""
    perceived: Perceived | None = None
    """What the perception made of the step (the 2-D world's: what each stage made of it)."""


@dataclass
class SimResult:
    """Metrics of every method, and the outcome of the runs."""

    config: SimConfig
    summaries: dict[str, FCWSummary]
    collided: np.ndarray
    collision_speed: np.ndarray | None
    steps: int
    aeb: FCWSummary | None = None
    """AEB's activations classed as the warnings are (a false one: nuisance, sensing-false)."""


class _EgoSensors(PairState):
    """Wheel-speed and accelerometer readings of N vehicles (with a constant accelerometer
    offset per vehicle); the draws are made for the N vehicles even when resized to fewer."""

    _PAIR_AXES = {"_bias": 0}

    def __init__(self, n: int, rng: np.random.Generator) -> None:
        self._rng, self._capacity, self._n = rng, n, n
        self._bias = rng.normal(0.0, ACCEL_BIAS_STD, n)

    def _resized(self, m: int) -> None:
        self._n = m

    def __call__(self, frame: TruthFrame) -> tuple[np.ndarray, np.ndarray]:
        n, cap = self._n, self._capacity
        accel = frame.ego_accel + self._bias + self._rng.normal(0.0, ACCEL_STD, cap)[:n]
        noise = self._rng.normal(0.0, WHEEL_SPEED_STD, cap)[:n]
        return accel, np.maximum(frame.ego_speed + noise, 0.0)


@dataclass
class Perceived:
    """What the equipped vehicles know at one step, with the oracle's view of the truth and
    the pairs in a crash-relevant situation."""

    frame: TruthFrame
    measurements: list[Measurement]
    v_ego: np.ndarray
    estimates: dict[str, Estimate]
    oracle: np.ndarray
    ttc: np.ndarray
    relevant: np.ndarray
    causes: dict[str, np.ndarray] | None = None
    """Per method, what each pair's warning is about in truth (an index into
    :data:`acc_fusion.metrics.summary.CAUSES`; the 2-D world); ``None``: the true lead."""


class Perception(PairState):
    """Sensors, ego-motion filter, every method's estimator, and the oracle, over N pairs.

    One step of :meth:`step` turns a truth frame into measurements, the ego-speed estimate,
    one :class:`~acc_fusion.fusion.base.Estimate` per method, the oracle's warning level (the
    warning rule on ground truth), the true TTC and the pairs in a crash-relevant situation.
    :func:`simulate` adds each method's warning logic, the metrics and the driver; the
    gymnasium environment adds a policy.
    :meth:`resize` makes it perceive the first m pairs only (:mod:`acc_fusion.core.slots`).
    """

    def __init__(self, config: SimConfig, n: int, seeds: np.random.SeedSequence) -> None:
        cfg, dt = config, config.dt
        s_sensors, s_ego = seeds.spawn(2)
        self.config, self.n = cfg, n
        specs = cfg.sensor_specs()
        self.sensors = make_sensors(
            int(s_sensors.generate_state(1)[0]),
            *specs,
            radar_faults=cfg.radar_faults,
            infrared_faults=cfg.infrared_faults,
        )
        for sensor in self.sensors:
            sensor.allocate(n)
        self._read_ego = _EgoSensors(n, np.random.default_rng(s_ego))
        self.ego = EgoMotionFilter(n, EgoFilterConfig(fs=1.0 / dt, interval_accel=True))
        # The accelerometer (offset removed by the ego filter) is the model's known input.
        fusion = replace(
            cfg.fusion, filter=replace(cfg.fusion.filter, dt=dt, ego_accel_std=ACCEL_STD)
        )
        self.estimators = {
            m: make_estimator(replace(fusion, method=m), SENSOR_NAMES, n, specs)
            for m in cfg.methods
        }
        self.oracle = WarningLogic(cfg.warning, n, dt)

    def _resized(self, m: int) -> None:
        self.n = m
        parts = (*self.sensors, self._read_ego, self.ego, self.oracle, *self.estimators.values())
        resize_all(parts, m)

    def forget(self, pairs: np.ndarray, wheel: np.ndarray) -> None:
        """Start afresh for ``pairs`` (a slot that got a new vehicle)."""
        for sensor in self.sensors:
            sensor.forget(pairs)
        self.ego.reset(pairs, wheel)
        self.oracle.reset(pairs)
        for est in self.estimators.values():
            est.forget(pairs)

    def step(
        self, frame: TruthFrame, active: np.ndarray, reassigned=None, attentive=None
    ) -> Perceived:
        """Perceive ``frame`` (the pairs in ``active`` are being driven; the drivers in
        ``attentive``, if given, attend to the road: the oracle's adaptive timing)."""
        accel, wheel = self._read_ego(frame)
        if reassigned is not None and reassigned.any():
            self.forget(reassigned, wheel)
        meas = [s.measure(frame) for s in self.sensors]
        v_ego, bias = self.ego.step(accel, wheel)
        u = accel - bias  # over the step from the previous frame to this one
        oracle, ttc, relevant = judge(
            self.oracle, self.config.alert_classes, frame, active, attentive
        )
        ests = {m: e.step(meas, frame.leader_id, u) for m, e in self.estimators.items()}
        return Perceived(frame, meas, v_ego, ests, oracle, ttc, relevant)


def judge(
    oracle: WarningLogic,
    classes: AlertClassConfig,
    frame: TruthFrame,
    active: np.ndarray,
    attentive: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What truth says at ``frame``: the oracle's warning level (the rule on ground truth,
    advancing ``oracle``; ``attentive``: the drivers timed as attentive, for an adaptive rule,
    :meth:`~acc_fusion.warning.logic.AdaptiveConfig.attentive`), the true TTC (constant
    speeds, as SUMO's SSM device defines it; inf without a leader) and the pairs in a
    crash-relevant situation."""
    has = frame.has_leader & active
    rate = np.where(has, frame.range_rate, 0.0)
    level = oracle.step(
        np.where(has, frame.gap, 0.0),
        frame.ego_speed,
        rate,
        np.where(has, frame.lead_accel, 0.0),
        valid=has,
        attentive=attentive,
    )
    ttc = time_to_collision(np.where(has, frame.gap, 1.0), rate)
    relevant = active & crash_relevant(
        classes, frame.has_leader, frame.gap, frame.ego_speed, frame.lead_speed, frame.lead_accel
    )
    return level, ttc, relevant


def warning_inputs(p: Perceived, method: str, active: np.ndarray) -> dict[str, np.ndarray]:
    """The arguments of :meth:`WarningLogic.step` for ``method``'s estimate."""
    est = p.estimates[method]
    ok = est.valid & active
    gap, v_rel, a_lead, gap_std = np.empty((4, ok.size))
    _track_inputs(ok, est.x, est.p, gap, v_rel, a_lead, gap_std)
    return {"gap": gap, "v_ego": p.v_ego, "v_rel": v_rel, "a_lead": a_lead, "gap_std": gap_std,
            "valid": ok}  # fmt: skip


@njit(cache=True)
def _track_inputs(ok, x, p, gap, v_rel, a_lead, gap_std):  # pragma: no cover - compiled
    r"""Where ``ok (N,)``: the columns of the estimates ``x (N, 3)`` (``gap``, ``v_rel``,
    ``a_lead``) and the gap's standard deviation :math:`\sqrt{P_{00}}` of ``p (N, 3, 3)``
    (``gap_std``); 0 elsewhere (outputs ``(N,)``)."""
    for i in range(ok.size):
        if ok[i]:
            gap[i], v_rel[i], a_lead[i] = x[i, 0], x[i, 1], x[i, 2]
            gap_std[i] = np.sqrt(p[i, 0, 0])
        else:
            gap[i] = v_rel[i] = a_lead[i] = gap_std[i] = 0.0


def _head(source, k: int):
    """The frame of ``source``'s first ``k`` slots: its ``head(k)`` where it has one (a source
    that makes the frame of a prefix faster than the whole, e.g.
    :class:`~acc_fusion.truth.sumo.world.SumoWorld`), else ``frame().head(k)``."""
    head = getattr(source, "head", None)
    return source.frame().head(k) if head is None else head(k)


def simulate(
    config: SimConfig,
    *,
    source=None,
    progress: bool = False,
    on_step: Callable[[StepView], None] | None = None,
    warnings_on: bool = True,
    perception: Callable[[SimConfig, int, np.random.SeedSequence], Perception] = Perception,
) -> SimResult:
    """Run ``config``; with ``warnings_on`` false the driver never hears a warning and AEB
    (``config.aeb``) never brakes: no assistance.

    ``on_step`` (e.g. a :class:`Trace` or :class:`FirstWarning`) sees every step.  ``source``
    replaces the scripted scenario of ``config`` by another truth source with the same
    interface (e.g. :class:`acc_fusion.truth.sumo.source.SumoSource`); its slots are the pairs,
    its step is ``dt``, and a slot it ``reassigned`` to a new vehicle starts afresh.
    ``perception`` builds what turns the source's frames into :class:`Perceived` (the 2-D
    world's: :func:`acc_fusion.sim.world.simulate_world`); everything after it (warnings,
    metrics, driver) reads the 1-D frame it returns.
    """
    cfg = config
    dt = cfg.dt
    s_source, s_perception, s_driver = np.random.SeedSequence(cfg.seed).spawn(3)
    if source is None:
        overrides = {"dt": dt} if cfg.duration is None else {"dt": dt, "duration": cfg.duration}
        source = make_scenario(
            cfg.scenario, cfg.runs, seed=np.random.default_rng(s_source), **overrides
        )
    closed = cfg.drive is not None or cfg.aeb.enabled
    if closed and not getattr(source, "accepts_brakes", True):
        what = f"drive = {cfg.drive!r}" if cfg.drive is not None else "aeb.enabled"
        raise ConfigError(
            f"{type(source).__name__} cannot apply brake requests, so it cannot run a closed "
            f"loop ({what}); use a source that does (e.g. SumoSource)"
        )
    if cfg.drive is not None and cfg.driver.distraction.rate > 0:
        if not getattr(source, "accepts_hold", False):
            raise ConfigError(
                f"{type(source).__name__} cannot hold a distracted driver's vehicle, so it "
                "cannot run driver.distraction; use a source that can (e.g. SumoSource)"
            )
    n = len(source.active)
    perception = perception(cfg, n, s_perception)
    logic = {m: WarningLogic(cfg.warning, n, dt) for m in cfg.methods}
    metrics = {m: FCWMetrics(n, dt, cfg.tolerance, cfg.warn_level) for m in cfg.methods}
    driver = Driver(n, cfg.driver, seed=np.random.default_rng(s_driver)) if cfg.drive else None
    adaptive = cfg.warning.adaptive
    monitor = (
        DriverMonitor(n, adaptive.latency, adaptive.recovery)
        if driver is not None and driver.distracts and adaptive.enabled
        else None
    )
    # With a source of slots (SUMO, highway-env), every stage works on the prefix of slots
    # that holds the vehicles (acc_fusion.core.slots); a scripted batch keeps all its runs.
    aeb = AEB(cfg.aeb, n, dt) if cfg.aeb.enabled and warnings_on else None
    aeb_metrics = None if aeb is None else FCWMetrics(n, dt, cfg.tolerance, IMMINENT)
    stages = [perception, *logic.values(), *metrics.values(),
              *(s for s in (driver, monitor, aeb, aeb_metrics) if s is not None)]  # fmt: skip
    extent = Extent(n) if getattr(source, "slotted", False) else Extent(n, quantum=n)

    steps = 0
    t_last = source.t
    try:
        for _ in tqdm(
            range(source.n_steps),
            disable=None if progress else True,
            desc=cfg.scenario if perception is Perception else "2-D world",
            unit="step",
            leave=False,
        ):
            active, collided = source.active, source.collided
            new = getattr(source, "reassigned", None)
            k = extent.fit_stages(active, stages)
            frame = source.frame() if k == n else _head(source, k)
            if k < n:
                active, collided = active[:k], collided[:k]
                new = None if new is None else new[:k]
            looking = None if monitor is None else monitor.watch(frame.t, driver.eyes_off, new)
            attentive = adaptive.attentive(looking, frame.ego_accel)
            p = perception.step(frame, active, new, attentive)
            frame = p.frame
            if new is not None and new.any():
                for m in cfg.methods:
                    logic[m].reset(new)
                    metrics[m].reset(new)
                if driver is not None:
                    driver.new_vehicles(new, getattr(source, "vehicle_ids", None))
                if aeb is not None:
                    aeb.reset(new)
                    aeb_metrics.reset(new)
            levels = {}
            for m in cfg.methods:
                inputs = warning_inputs(p, m, active)
                levels[m] = logic[m].step(**inputs, attentive=attentive)
                if aeb is not None and m == cfg.aeb_method:
                    aeb_brake = aeb.step(inputs["gap"], inputs["v_ego"], inputs["v_rel"],
                                         inputs["a_lead"], inputs["valid"], active)  # fmt: skip
                cause = None if p.causes is None else p.causes[m]
                metrics[m].update(frame.t, levels[m], p.oracle, p.ttc, frame.ego_speed, active,
                                  collided, p.relevant, cause)  # fmt: skip
            if aeb is not None:  # AEB's activations classed as the warnings are
                engaged, cause = (aeb.stage > 0) * np.int8(IMMINENT), p.causes or {}
                aeb_metrics.update(frame.t, engaged, p.oracle, p.ttc, frame.ego_speed, active,
                                   collided, p.relevant, cause.get(cfg.aeb_method))  # fmt: skip
            t_last = frame.t
            # the brake requests (the slots beyond the prefix: none); the stronger one wins
            brake = None if driver is None and aeb is None else np.zeros(n)
            if driver is not None:
                heard = levels[cfg.drive] if warnings_on else np.zeros(frame.n_pairs, np.int8)
                brake[: frame.n_pairs] = driver.step(heard, frame, p.relevant)
            if aeb is not None:
                brake[: frame.n_pairs] = np.maximum(brake[: frame.n_pairs], aeb_brake)
            if on_step is not None:
                view = (frame, p.measurements, p.estimates, levels, p.oracle, p.ttc, p.relevant)
                on_step(StepView(*view, driver, aeb, p))
            if brake is None:
                source.advance()
            elif driver is not None and driver.distracts:
                hold = np.zeros(n, dtype=bool)
                hold[: frame.n_pairs] = driver.holding
                source.advance(brake, hold)
            else:
                source.advance(brake)
            steps += 1
            if source.done:
                break
    except AccFusionError as exc:  # the source failed mid-run: keep what was measured
        resize_all(metrics.values(), n)
        for m in metrics.values():
            m.finish(t_last)
        exc.summaries = {m: metrics[m].summary() for m in cfg.methods}
        raise
    t_end = source.t
    finished = [*metrics.values(), *([] if aeb_metrics is None else [aeb_metrics])]
    resize_all(finished, n)
    for m in finished:
        m.finish(t_end, source.collided)
    return SimResult(
        config=cfg,
        summaries={m: metrics[m].summary() for m in cfg.methods},
        collided=source.collided,
        collision_speed=getattr(source, "collision_speed", None),
        steps=steps,
        aeb=None if aeb_metrics is None else aeb_metrics.summary(),
    )
