"""Settings of the fusion center and its local filters (:class:`FusionConfig`,
:class:`FilterConfig`) and the names of the methods, reset modes and information-sharing rules.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.validation import check_choice, check_range
from acc_fusion.filters.engines import ENGINES
from acc_fusion.fusion.fdi import FDIConfig

FUSION_METHODS = ("centralized", "centralized_stacked", "federated", "plain")


RESET_MODES = ("fusion", "zero", "none")


BETA_METHODS = ("equal", "trace")


LOCAL_FILTERS = ("full", "steady")


NOISE_POINTS = ("prediction", "report")


@dataclass(frozen=True)
class FilterConfig:
    """Local-filter model, shared by every method.

    Attributes:
        dt: step of the estimation loop [s] (default 0.05: the radar's 20 Hz); in a
            :class:`~acc_fusion.sim.closed_loop.SimConfig` it is derived from the config's ``dt``.
        jerk_std: relative-jerk standard deviation :math:`\\sigma_j` of the constant-
            acceleration model [m/s³] (default 2.0: ordinary driving, braking onsets of a few
            m/s³; see :mod:`acc_fusion.core.motion`).
        init_accel_std: standard deviation of the relative acceleration at initialisation
            [m/s²] (default 3.0: ±1 g covers emergency braking at 3 σ).
        max_coast: seconds without a usable measurement after which a track is dropped
            (default 1.0).
        ego_accel_std: noise of the ego-acceleration input [m/s²] (the accelerometer's),
            added to the process noise as :math:`\\Gamma\\Gamma^\top\\sigma_u^2`
            (default 0: no input, or a perfect one).
    """

    dt: float = field(default=0.05, metadata={"derived_from": "dt"})
    jerk_std: float = 2.0
    init_accel_std: float = 3.0
    max_coast: float = 1.0
    ego_accel_std: float = 0.0

    def __post_init__(self) -> None:
        check_range("filter.dt", self.dt, 0.0, 10.0, lo_open=True)
        check_range("filter.jerk_std", self.jerk_std, 0.0, 1e3)
        check_range("filter.init_accel_std", self.init_accel_std, 0.0, 1e3, lo_open=True)
        check_range("filter.max_coast", self.max_coast, 0.0, 1e6, lo_open=True)
        check_range("filter.ego_accel_std", self.ego_accel_std, 0.0, 100.0)


@dataclass(frozen=True)
class FusionConfig:
    """Which estimator to run and how (one typed place for every fusion default).

    Attributes:
        method: a sensor name (that sensor alone) or one of :data:`FUSION_METHODS`.
        engine: ``"batched"`` (numba, default) or ``"filterpy"`` (reference).
        beta: information-sharing factors: ``"equal"``, ``"trace"`` or one value per sensor
            (each in (0, 1], summing to 1).
        reset: federated reset mode, one of :data:`RESET_MODES`.
        fusion_period: steps between two fusions of the federated filter (>= 1).
        fdi: fault detection and isolation of the federated filter, ``None`` to disable.
        filter: the local-filter model.
        local: ``"full"`` Kalman filter, or ``"steady"``: the constant-gain filter of the
            algebraic Riccati equation (single-sensor methods only; needs the sensor's
            :class:`~acc_fusion.sensors.spec.SensorSpec` for its rate and noise).
        steady_range: range [m] at which a range-dependent noise is evaluated for the
            constant gain (default 40 m).
        noise_at: where a range noise that grows with range (the infrared camera's
            :math:`\\sigma_r = \\sigma_0 + q r^2`) is evaluated for a pair with a track:
            ``"prediction"`` (default), at the predicted gap, or ``"report"``, at the reported
            range, as the sensor's own ``r`` has it.  A covariance evaluated at the measurement
            is correlated with its error: a report that falls short gets a small variance,
            too much weight and a NIS that understates its error, so the estimate is biased
            short and the camera "contradicts" a correct radar report (for a 5 % error at
            60 m the camera's stated sigma is 10 % too small, at 95 m with -37 m 2.3x too
            small).  Evaluating it at the prediction decorrelates the two (the decorrelated
            converted-measurement filter of Bordonaro, Willett & Bar-Shalom, IEEE Trans.
            AES 50(2):1431-1444, 2014).  Needs the sensors' specs (``make_estimator(...,
            specs=...)``); without them and for a new track the report's ``r`` is used.  The
            2-D world sets ``"report"``: its fused objects carry their detections' converted
            covariances, whose range std the bridge has already taken at the track's range
            (:func:`~acc_fusion.fusion.tracking.association.fused_measurements`).
    """

    method: str = "federated"
    engine: str = "batched"
    beta: str | tuple[float, ...] = "equal"
    reset: str = "fusion"
    fusion_period: int = 1
    fdi: FDIConfig | None = field(default_factory=FDIConfig)
    filter: FilterConfig = field(default_factory=FilterConfig)
    local: str = "full"
    steady_range: float = 40.0
    noise_at: str = "prediction"

    def __post_init__(self) -> None:
        check_choice("fusion.engine", self.engine, ENGINES)
        check_choice("fusion.local", self.local, LOCAL_FILTERS)
        check_choice("fusion.noise_at", self.noise_at, NOISE_POINTS)
        check_range("fusion.steady_range", self.steady_range, 0.0, 1e4, lo_open=True)
        check_choice("fusion.reset", self.reset, RESET_MODES)
        if isinstance(self.beta, str):
            check_choice("fusion.beta", self.beta, BETA_METHODS)
        else:
            values = tuple(
                check_range("fusion.beta[i]", b, 0.0, 1.0, lo_open=True) for b in self.beta
            )
            if abs(sum(values) - 1.0) > 1e-9:
                raise ConfigError(f"fusion.beta values must sum to 1, got {sum(values):g}")
            object.__setattr__(self, "beta", values)
        if not isinstance(self.fusion_period, int) or self.fusion_period < 1:
            raise ConfigError(
                f"fusion.fusion_period must be a whole number >= 1, got {self.fusion_period!r}"
            )
