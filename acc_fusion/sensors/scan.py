r"""What every sensor shares: its random streams, its sample clock, and — for the 2-D sensors —
Poisson clutter, measurement noise, faults and the assembly of a :class:`Detections` frame.

Faults of the 2-D sensors
    The 1-D sensors' fault kinds (:mod:`acc_fusion.sensors.faults`, the same :class:`Fault`
    records) act on a 2-D sensor's whole frame of detections while active: ``dropout`` — no
    frame (``online`` False); ``stuck`` — the sensor repeats the last frame it output before the
    fault began (nothing if it never output one); ``bias`` — ``magnitude`` [m] added to every
    range and ``rate_magnitude`` [m/s] to every range-rate; ``spikes`` — each detection is, with
    ``probability``, an outlier of :math:`\pm a (1 + U)` on range and range-rate, as in 1-D;
    ``noise_burst`` — the measurement noise is multiplied by ``magnitude`` while the declared
    standard deviations stay (the sensor does not know).  The nominal random streams are drawn
    exactly as without faults (the spikes have a stream of their own), so a faulty run differs
    from its healthy twin only by the fault."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.units import TIME_TOL
from acc_fusion.core.validation import check_range, unchecked
from acc_fusion.sensors.detections import CLUTTER, DETECTION_FIELDS, Detections
from acc_fusion.sensors.faults import Fault
from acc_fusion.truth.conditions import Conditions
from acc_fusion.truth.objects import ObjectFrame


def streams(seed: int | np.random.SeedSequence | np.random.Generator | None, n: int) -> list:
    """``n`` independent :class:`numpy.random.Generator` streams spawned from ``seed``."""
    try:
        root = np.random.default_rng(seed)
    except (TypeError, ValueError):
        raise ConfigError(
            f"seed must be a non-negative integer, a SeedSequence, a numpy Generator or None, "
            f"got {seed!r}"
        ) from None
    return root.spawn(n)


class SampleClock:
    """The sample times ``phase + k / rate_hz``, ``k = 0, 1, ...`` of a sensor.

    :meth:`due` is true at the first frame whose time reaches the next sample time (tolerance
    :data:`~acc_fusion.core.units.TIME_TOL`); the clock then waits for the first sample time
    after that frame (samples a coarse simulation step skips are lost).
    """

    def __init__(self, rate_hz: float, phase: float) -> None:
        self.rate_hz, self.phase = rate_hz, phase
        self.k = 0  # index of the next sample time

    def due(self, t: float) -> bool:
        """Whether the sensor samples at frame time ``t``; advances the clock if so."""
        if t < self.phase + self.k / self.rate_hz - TIME_TOL:
            return False
        self.k = math.floor((t - self.phase + TIME_TOL) * self.rate_hz) + 1
        return True


@dataclass(frozen=True)
class Returns:
    """Polar returns of all egos before noise: ``ego (K,)``, ``z (3, K)`` = range [m],
    azimuth [rad], range-rate [m/s], the true ``object_id`` and ``origin`` of each."""

    ego: np.ndarray
    z: np.ndarray
    object_id: np.ndarray
    origin: np.ndarray

    def __add__(self, other: Returns) -> Returns:
        return Returns(
            np.concatenate([self.ego, other.ego]),
            np.concatenate([self.z, other.z], axis=1),
            np.concatenate([self.object_id, other.object_id]),
            np.concatenate([self.origin, other.origin]),
        )

    def take(self, index: np.ndarray) -> Returns:
        """The returns at ``index`` (a boolean mask or indices)."""
        index = np.asarray(index)
        if index.dtype == bool:  # one pass over the mask, then cheap takes
            if index.shape != self.ego.shape:
                raise IndexError(f"a mask of {index.shape} for {self.ego.size} returns")
            index = np.flatnonzero(index)
        else:
            index = index.astype(np.intp, copy=False)
        return Returns(self.ego.take(index), self.z.take(index, axis=1),
                       self.object_id.take(index), self.origin.take(index))  # fmt: skip


def stationary_clutter(
    rng: np.random.Generator,
    ego_speed: np.ndarray,
    rate: float,
    range_limits: tuple[float, float],
    half_fov: float,
) -> Returns:
    r"""False detections: a Poisson number of mean ``rate`` per ego and scan, each uniform in
    range over ``range_limits`` [m] and in azimuth over :math:`\pm` ``half_fov`` [rad] (the
    standard clutter model: Bar-Shalom, Willett and Tian, *Tracking and Data Fusion*, 2011),
    and stationary (range-rate :math:`-v_{\mathrm{ego}}\cos\theta`, like the roadside returns
    that cause FCW false alarms; assumption); ``object_id`` -1, ``origin`` :data:`CLUTTER`."""
    counts = rng.poisson(rate, ego_speed.shape[0])
    ego = np.repeat(np.arange(ego_speed.shape[0]), counts)
    r = rng.uniform(*range_limits, ego.size)
    az = rng.uniform(-half_fov, half_fov, ego.size)
    z = np.stack([r, az, -ego_speed[ego] * np.cos(az)])
    return Returns(ego, z, np.full(ego.size, -1), np.full(ego.size, CLUTTER))


def emit(
    t: float,
    name: str,
    n_egos: int,
    returns: Returns,
    z: np.ndarray,
    declared_std: np.ndarray,
    growth: tuple[float, float] = (0.0, 0.0),
) -> Detections:
    """The :class:`Detections` of ``returns`` measured as ``z (3, K)`` with the declared
    standard deviations ``declared_std (3, K)`` and the noise model's ``growth`` (range,
    range-rate: :attr:`Detections.range_std_growth`), sorted by ego (stable): made of the
    sensor's own arrays, without the constructor's checks (``z`` and ``declared_std``
    finite)."""
    ego, k = returns.ego, returns.ego.size
    z, std = np.ascontiguousarray(z, dtype=float), np.ascontiguousarray(declared_std, dtype=float)
    if z.shape != (3, k) or std.shape != (3, k):
        raise InputError(
            f"{name}: z and declared_std must have shape (3, {k}), got {z.shape}, {std.shape}"
        )
    if returns.object_id.shape != (k,) or returns.origin.shape != (k,):
        raise InputError(f"{name}: the returns' object_id and origin must have shape ({k},)")
    if k and (ego.min() < 0 or ego.max() >= n_egos):
        raise InputError(f"{name}: the returns' egos must lie in [0, {n_egos})")
    ego, z, std, object_id, origin = _by_ego(n_egos, ego, z, std, returns.object_id, returns.origin)
    values = (t, name, n_egos, True, ego, *z, *std, object_id, origin, *map(float, growth))
    return unchecked(Detections, dict(zip(DETECTION_FIELDS, values, strict=True)))


@njit(cache=True)
def _by_ego(n_egos, ego, z, std, object_id, origin):  # pragma: no cover - compiled
    """The returns' ``ego`` (each in ``[0, n_egos)``), ``z (3, K)``, ``std (3, K)``,
    ``object_id`` and ``origin``, sorted by ego (stable: a counting sort)."""
    start = np.zeros(n_egos + 1, np.int64)
    for i in range(ego.size):
        start[ego[i] + 1] += 1
    for e in range(n_egos):
        start[e + 1] += start[e]
    k = ego.size
    out_ego, out_id, out_origin = np.empty(k, np.int64), np.empty(k, np.int64), np.empty(k, np.int8)
    out_z, out_std = np.empty((3, k)), np.empty((3, k))
    for i in range(k):
        at = start[ego[i]]
        start[ego[i]] += 1
        out_ego[at], out_id[at], out_origin[at] = ego[i], object_id[i], origin[i]
        for a in range(3):
            out_z[a, at], out_std[a, at] = z[a, i], std[a, i]
    return out_ego, out_z, out_std, out_id, out_origin


def offline(t: float, name: str, n_egos: int) -> Detections:
    """The empty frame of a sensor that does not sample at ``t`` (``online`` False)."""
    none = np.zeros(0)
    ids = np.zeros(0, dtype=np.int64)
    return Detections(t, name, n_egos, False, ids, *(none,) * 6, ids, ids.astype(np.int8))


#: Intervals of spec fields, as keyword arguments of
#: :func:`~acc_fusion.core.validation.check_range`.
POSITIVE = {"lo": 0.0, "hi": math.inf, "lo_open": True, "hi_open": True}


NONNEGATIVE = {"lo": 0.0, "hi": math.inf, "hi_open": True}


_ABOVE = {"hi": math.inf, "lo_open": True, "hi_open": True}


FINITE = {"lo": -math.inf, "hi": math.inf, "lo_open": True, "hi_open": True}


PROBABILITY = {"lo": 0.0, "hi": 1.0}


def check_spec(spec: object, bounds: dict[str, dict[str, float | bool]]) -> None:
    """Validate a frozen spec in place: a non-empty ``name``, every field of ``bounds`` in
    its interval (keyword arguments of :func:`~acc_fusion.core.validation.check_range`), then
    ``max_range > min_range``; each error one sentence naming ``<name>.<field>``."""
    name = spec.name
    if not isinstance(name, str) or not name:
        raise ConfigError(f"sensor name must be a non-empty string, got {name!r}")
    for field, b in bounds.items():
        value = check_range(f"{name}.{field}", getattr(spec, field), **b)
        object.__setattr__(spec, field, value)
    limit = check_range(f"{name}.max_range", spec.max_range, spec.min_range, **_ABOVE)
    object.__setattr__(spec, "max_range", limit)


def add_noise(rng: np.random.Generator, returns: Returns, std: np.ndarray) -> np.ndarray:
    """``returns.z`` plus independent zero-mean Gaussian noise of standard deviations
    ``std`` (``(3, K)`` or ``(3, 1)``)."""
    return returns.z + std * rng.standard_normal(returns.z.shape)


class Scanner:
    """What the 2-D sensors share: the spec (of type :attr:`spec_type`, its default when
    ``None``), two random streams — detection and noise, clutter — spawned from ``seed`` (so
    that switching clutter on or off leaves the other detections unchanged), the sample clock
    and the checks of ``detect``'s arguments.

    Args:
        spec: the sensor's performance.
        seed: ``int``, :class:`numpy.random.SeedSequence`, :class:`numpy.random.Generator` or
            ``None`` (fresh entropy); the same seed and frames give the same detections.
        faults: the sensor's faults (module docstring).
    """

    #: The spec class of the sensor (set by subclasses).
    spec_type: type

    def __init__(
        self,
        spec: object | None = None,
        seed: int | np.random.SeedSequence | np.random.Generator | None = None,
        faults: tuple[Fault, ...] = (),
    ) -> None:
        self.spec = self.spec_type() if spec is None else spec
        if not isinstance(self.spec, self.spec_type):
            raise ConfigError(
                f"spec must be a {self.spec_type.__name__}, got {type(self.spec).__name__}"
            )
        if not all(isinstance(f, Fault) for f in faults):
            raise ConfigError(f"{self.spec.name} faults must be Fault records")
        self.faults = tuple(faults)
        self._rng, self._rng_clutter, self._rng_spikes = streams(seed, 3)
        self.reset()

    def reset(self, seed: int | np.random.SeedSequence | np.random.Generator | None = None) -> None:
        """Restart the sample clock for a new run (frame times may start again); with a
        ``seed``, also restart the random streams (without, they continue: fresh noise)."""
        if seed is not None:
            self._rng, self._rng_clutter, self._rng_spikes = streams(seed, 3)
        self._clock = SampleClock(self.spec.rate_hz, self.spec.phase)
        self._t_prev = -math.inf
        self._held: Detections | None = None

    def faulty(self, t: float) -> bool:
        """Whether a fault of this sensor is active at ``t``."""
        return any(f.active(t) for f in self.faults)

    def _due(self, frame: ObjectFrame, conditions: Conditions) -> bool:
        """Check the arguments of ``detect`` (types, increasing time); whether it scans."""
        if not isinstance(frame, ObjectFrame):
            raise InputError(f"detect() needs an ObjectFrame, got {type(frame).__name__}")
        if not isinstance(conditions, Conditions):
            raise InputError(f"detect() needs Conditions, got {type(conditions).__name__}")
        if not frame.t > self._t_prev:
            raise InputError(
                f"frame.t must increase from one detect() call to the next, "
                f"got {frame.t!r} after {self._t_prev!r}"
            )
        self._t_prev = frame.t
        return self._clock.due(frame.t)

    def _report(
        self, frame: ObjectFrame, found: Returns, clutter_rate: float, half_fov: float
    ) -> Detections:
        """The frame's :class:`Detections`: the ``found`` returns and Poisson clutter (mean
        ``clutter_rate`` per ego, within the range limits and :math:`\\pm` ``half_fov``), with
        the noise of ``spec.noise_std`` at the true range, declared at the measured range."""
        s = self.spec
        limits = (s.min_range, s.max_range)
        clutter = stationary_clutter(
            self._rng_clutter, frame.ego_speed, clutter_rate, limits, half_fov
        )
        active = [f for f in self.faults if f.active(frame.t)]
        burst = math.prod(f.magnitude for f in active if f.kind == "noise_burst")
        z = np.concatenate(
            [
                add_noise(self._rng, found, burst * s.noise_std(found.z[0])),
                add_noise(self._rng_clutter, clutter, burst * s.noise_std(clutter.z[0])),
            ],
            axis=1,
        )
        for f in active:
            if f.kind == "bias":
                z[0] += f.magnitude
                z[2] += f.rate_magnitude
            elif f.kind == "spikes":
                z += self._spikes(f, z.shape[1])
        z[0] = np.maximum(z[0], 0.0)  # a sensor reports no negative range (noise, bias)
        declared = s.noise_std(z[0])
        out = emit(frame.t, s.name, frame.n_egos, found + clutter, z, declared, s.noise_growth())
        kinds = {f.kind for f in active}
        if "dropout" in kinds:
            return offline(frame.t, s.name, frame.n_egos)
        if "stuck" in kinds:
            held = self._held
            return (
                offline(frame.t, s.name, frame.n_egos) if held is None else replace(held, t=frame.t)
            )
        self._held = out
        return out

    def _spikes(self, fault: Fault, k: int) -> np.ndarray:
        r"""``(3, K)`` outliers of a spikes fault: with ``probability`` per detection,
        :math:`\pm a (1 + U)` on range and range-rate (none on azimuth)."""
        rng = self._rng_spikes
        hit = rng.random(k) < fault.probability
        size = np.array([fault.magnitude, 0.0, fault.rate_magnitude])[:, None]
        sign = rng.choice((-1.0, 1.0), (3, k))
        return np.where(hit, sign * size * (1.0 + rng.random((3, k))), 0.0)
