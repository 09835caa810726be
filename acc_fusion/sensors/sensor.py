r"""Sensors: turn ground truth into what a radar or an infrared camera reports.

Pipeline stage 2 (truth source → **sensors** → local filters).  A :class:`Sensor` takes one
:class:`~acc_fusion.truth.frame.TruthFrame` per simulation step and returns a :class:`Measurement`
of ``[range, range-rate]`` for each of the N follower→leader pairs (the measurement model of
:mod:`acc_fusion.core.motion`, :math:`Z = H X + W`, :math:`H = [I_2\ 0]`).

Sample timing
    A sensor samples at ``phase + k / rate_hz``, ``k = 0, 1, ...``; it reports at the first
    frame whose ``t`` reaches its next sample time (tolerance ``1e-9`` s), then waits for the
    first sample time after that frame (samples a coarse simulation step skips are lost; at most
    one report per frame).  On the other frames ``valid`` is all False.  With a 0.05 s step the
    20 Hz radar reports every step and the 10 Hz infrared camera every second step, so the
    local filters are updated asynchronously.

Visibility
    The target of pair ``i`` is visible when the pair has a leader, ``min_range <= gap <=
    max_range`` and the bearing :math:`|\operatorname{atan2}(y_{\mathrm{lat}}, d)| \le
    \mathrm{fov}/2`; a visible return is then reported with probability ``detection_prob``.

Noise
    Independent zero-mean Gaussian, with the standard deviations

    .. math::

        \sigma_r(r) = \sigma_0 + q\, r^2,\qquad \sigma_{\dot r} = \text{range\_rate\_std}

    evaluated at the true range of the reported object.  ``q = 0`` for the radar (FMCW range
    accuracy does not depend on range to first order); for the monocular infrared camera the
    quadratic term is the range error bound of Stein, Mano & Shashua (2003), see
    :func:`infrared_spec`.  The sensor *declares* the covariance
    :math:`R = \operatorname{diag}(\sigma_r(\hat r)^2, \sigma_{\dot r}^2)` at its *measured*
    range :math:`\hat r` (it does not know the truth); under a noise-burst fault the actual
    noise is larger than the declared R (:mod:`acc_fusion.sensors.faults`).

Clutter (ghost targets)
    With ``ghost_rate > 0`` each pair sees stationary roadside objects (overhead signs, guard
    rails, manhole covers — the classic cause of radar FCW false alarms).  Arrivals form a
    Poisson process of rate ``ghost_rate`` [1/s]; a ghost appears at range
    :math:`U(\text{ghost\_range})`, lives :math:`U(\text{ghost\_duration})` seconds and, being
    stationary, closes at the ego speed: its range decreases by ``ego_speed * dt`` per frame
    and its true range-rate is ``-ego_speed``.  While a ghost is within the range limits and
    closer than the visible target (or there is no visible target) the sensor reports the
    ghost instead, with the same noise model and the ``ghost`` flag set.  A pair holds at most
    one ghost: arrivals while a ghost lives are lost (an M/G/1/1 loss system), so the fraction
    of time a pair has a ghost is :math:`\lambda \bar D / (1 + \lambda \bar D)` with
    :math:`\bar D` the mean lifetime.

Randomness and reproducibility
    The seed (``int``, :class:`numpy.random.Generator` or ``None``) is split with
    :meth:`numpy.random.Generator.spawn` into three independent streams: detection and noise,
    ghosts, faults.  Every draw has a fixed shape per pair, whatever the masks, so the same
    seed and frames give identical measurements, one pair's visibility never changes another
    pair's noise, and switching clutter or faults on does not change the nominal noise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.core.config import from_mapping
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.motion import MEAS_DIM
from acc_fusion.core.slots import PairState, pair_mask
from acc_fusion.core.units import TIME_TOL
from acc_fusion.core.validation import check_interval, check_range
from acc_fusion.sensors.faults import Fault, Report, apply_faults
from acc_fusion.truth.frame import TruthFrame

# Bounds of the SensorSpec fields, as keyword arguments of ``check_range``.
_FINITE = {"hi": math.inf, "hi_open": True}
_ABOVE = {**_FINITE, "lo_open": True}
_SPEC_BOUNDS: dict[str, dict[str, float | bool]] = {
    "rate_hz": {"lo": 0.0, **_ABOVE},
    "range_std": {"lo": 0.0, **_ABOVE},
    "range_std_quadratic": {"lo": 0.0, **_FINITE},
    "range_rate_std": {"lo": 0.0, **_ABOVE},
    "min_range": {"lo": 0.0, **_FINITE},
    "fov_deg": {"lo": 0.0, "hi": 360.0, "lo_open": True},
    "detection_prob": {"lo": 0.0, "hi": 1.0},
    "phase": {"lo": 0.0, **_FINITE},
    "ghost_rate": {"lo": 0.0, **_FINITE},
}


@dataclass(frozen=True)
class SensorSpec:
    r"""Performance of one range/range-rate sensor (all fields validated on construction).

    Attributes:
        name: sensor name (``"radar"``, ``"infrared"``); prefixes the field names in errors.
        rate_hz: sample rate [Hz], ``> 0``.
        range_std: constant part :math:`\sigma_0` of the range noise std [m], ``> 0``.
        range_std_quadratic: :math:`q` [1/m] in :math:`\sigma_r = \sigma_0 + q r^2`, ``>= 0``.
        range_rate_std: range-rate noise std [m/s], ``> 0``.
        min_range: shortest range the sensor reports [m], ``>= 0``.
        max_range: longest range the sensor reports [m], ``> min_range``.
        fov_deg: full horizontal field of view [deg], in (0, 360].
        detection_prob: probability that a visible return is reported, in [0, 1].
        phase: time of the first sample [s], ``>= 0``.
        ghost_rate: clutter ghosts spawned per second per pair [1/s], ``>= 0`` (0: off).
        ghost_range: ``(low, high)`` uniform spawn range of a ghost [m], ``0 <= low <= high``.
        ghost_duration: ``(low, high)`` uniform lifetime of a ghost [s], ``0 < low <= high``.
    """

    name: str
    rate_hz: float
    range_std: float
    range_std_quadratic: float
    range_rate_std: float
    min_range: float
    max_range: float
    fov_deg: float
    detection_prob: float
    phase: float = 0.0
    ghost_rate: float = 0.0
    ghost_range: tuple[float, float] = (20.0, 120.0)
    ghost_duration: tuple[float, float] = (0.5, 2.0)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError(f"sensor name must be a non-empty string, got {self.name!r}")
        p = f"{self.name}."
        values = {f: check_range(p + f, getattr(self, f), **b) for f, b in _SPEC_BOUNDS.items()}
        values["max_range"] = check_range(
            p + "max_range", self.max_range, values["min_range"], **_ABOVE
        )
        values["ghost_range"] = check_interval(p + "ghost_range", self.ghost_range, lo_open=False)
        values["ghost_duration"] = check_interval(
            p + "ghost_duration", self.ghost_duration, lo_open=True
        )
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def range_noise_std(self, r: np.ndarray) -> np.ndarray:
        """Range noise std [m] at range ``r`` [m]: ``range_std + range_std_quadratic * r**2``."""
        r = np.asarray(r, dtype=float)
        return self.range_std + self.range_std_quadratic * r * r


def _spec(defaults: dict[str, object], overrides: dict[str, object]) -> SensorSpec:
    """Build a :class:`SensorSpec` from defaults and overrides; unknown keys are ConfigErrors."""
    data = {**defaults, **overrides}
    return from_mapping(SensorSpec, data, prefix=f"{data['name']}.")


def radar_spec(**overrides: object) -> SensorSpec:
    """Defaults of a 77 GHz long-range ACC radar, with any field overridden by keyword.

    ===================  ========  =====  ===================================================
    parameter            value     unit   source
    ===================  ========  =====  ===================================================
    rate_hz              20        Hz     project choice; series long-range radars cycle in
                                          50-80 ms (12.5-20 Hz): Delphi ESR 50 ms, Bosch
                                          LRR3 80 ms (de Ponte Müller 2017)
    range_std            0.25      m      between the LRR3 accuracy 0.1 m (de Ponte Müller
                                          2017) and the ~0.4 m far-range accuracy typical of
                                          ARS 408-class radars
    range_std_quadratic  0         1/m    FMCW range error does not grow with range
    range_rate_std       0.12      m/s    Bosch LRR3: 0.12 m/s (de Ponte Müller 2017);
                                          the LRR3 brochure states ±0.1 m/s
    min_range            0.5       m      Bosch LRR3 brochure: distance 0.5-250 m
    max_range            250       m      Bosch LRR3 brochure
    fov_deg              30        deg    Bosch LRR3: ±15° azimuth (de Ponte Müller 2017)
    detection_prob       0.98      --     typical of a tracked vehicle target in the main
                                          lobe (assumption, not a datasheet value)
    phase                0         s      --
    ghost_rate           0         1/s    clutter off by default
    ===================  ========  =====  ===================================================

    Sources: Bosch Engineering, *Long-Range Radar LRR3* product brochure (distance
    0.5-250 m, 76-77 GHz); F. de Ponte Müller, "Survey on ranging sensors and cooperative
    techniques for relative positioning of vehicles", Sensors 17(2):271, 2017,
    doi:10.3390/s17020271 (its table of automotive radars: LRR3 250 m, ±15°, 0.1 m,
    0.12 m/s, 80 ms; Delphi ESR 50 ms cycle).
    """
    defaults: dict[str, object] = {
        "name": "radar",
        "rate_hz": 20.0,
        "range_std": 0.25,
        "range_std_quadratic": 0.0,
        "range_rate_std": 0.12,
        "min_range": 0.5,
        "max_range": 250.0,
        "fov_deg": 30.0,
        "detection_prob": 0.98,
    }
    return _spec(defaults, overrides)


#: Infrared camera geometry behind the default range-noise slope (see :func:`infrared_spec`).
IR_IMAGE_WIDTH_PX = 640
IR_HFOV_DEG = 50.0
IR_FOCAL_PX = (IR_IMAGE_WIDTH_PX / 2) / math.tan(math.radians(IR_HFOV_DEG / 2))  # ≈ 686 px
IR_CAMERA_HEIGHT_M = 1.2
IR_ROW_STD_PX = 1.0


def infrared_spec(**overrides: object) -> SensorSpec:
    r"""Defaults of a far-infrared (thermal) camera with monocular ranging, any field overridable.

    Monocular range comes from the image row :math:`y` of the target's road contact point,
    :math:`Z = f H / y` (Stein, Mano & Shashua 2003, with :math:`f` the focal length in
    pixels and :math:`H` the camera height); differentiating, an error of :math:`\sigma_y`
    pixels in :math:`y` gives the range error

    .. math::

        \sigma_Z = \frac{Z^2\, \sigma_y}{f H}

    so ``range_std_quadratic`` :math:`= \sigma_y / (f H)` with :math:`f` = 640 px /
    (2 tan 25°) ≈ 686 px (640x512 sensor, 50° HFOV), :math:`H` = 1.2 m and
    :math:`\sigma_y` = 1 px: :math:`q \approx 1.21\times10^{-3}` 1/m, i.e. 5 % of the range at
    44 m and 11 % at 90 m, close to the errors Stein et al. report for their camera (about
    5 % at 44 m, 10 % at 90 m).

    ===================  ========  =====  ===================================================
    parameter            value     unit   source
    ===================  ========  =====  ===================================================
    rate_hz              10        Hz     project choice: detector output rate; the FLIR ADK
                                          streams 30/60 Hz video
    range_std            0.3       m      small constant part (detection box jitter),
                                          assumption
    range_std_quadratic  1.21e-3   1/m    :math:`\sigma_y/(fH)` above (Stein et al. 2003)
    range_rate_std       0.5       m/s    assumption: monocular range-rate (from image
                                          scale change) is far noisier than Doppler
    min_range            1         m      assumption (closer, the target overflows the image)
    max_range            100       m      typical vehicle detection range of a 640-px thermal
                                          camera (assumption)
    fov_deg              50        deg    FLIR ADK lens options 24°/32°/50°/75° HFOV
    detection_prob       0.95      --     assumption, below the radar's
    phase                0         s      --
    ghost_rate           0         1/s    clutter off
    ===================  ========  =====  ===================================================

    Sources: G. P. Stein, O. Mano, A. Shashua, "Vision-based ACC with a single camera:
    bounds on range and range rate accuracy", IEEE Intelligent Vehicles Symposium 2003,
    pp. 120-125; FLIR ADK (Automotive Development Kit): 640x512 LWIR, HFOV options as listed
    in the Autoware reference-hardware page for thermal cameras.
    """
    defaults: dict[str, object] = {
        "name": "infrared",
        "rate_hz": 10.0,
        "range_std": 0.3,
        "range_std_quadratic": IR_ROW_STD_PX / (IR_FOCAL_PX * IR_CAMERA_HEIGHT_M),
        "range_rate_std": 0.5,
        "min_range": 1.0,
        "max_range": 100.0,
        "fov_deg": IR_HFOV_DEG,
        "detection_prob": 0.95,
    }
    return _spec(defaults, overrides)


@dataclass(frozen=True)
class Measurement:
    """What one sensor reports at one frame for N pairs.

    Attributes:
        t: frame time [s].
        sensor: name of the sensor (``SensorSpec.name``).
        z: ``(N, 2)`` [range m, range-rate m/s]; NaN where not ``valid``.
        r: ``(N, 2, 2)`` covariance the sensor declares,
            ``diag(range_noise_std(z[:, 0])**2, range_rate_std**2)``; identity where not valid.
        valid: ``(N,)`` bool: the sensor reported a return for the pair at this frame.
        ghost: ``(N,)`` bool: the return is a clutter ghost (diagnostics and metrics only;
            filters must not read it).
        online: the sensor delivered a frame at this time (it sampled and is not in a
            dropout), whether or not it detected anything: the health signal a real sensor
            gives its ECU.  ``False`` between sample times.

    ``z`` and ``r`` are laid out in memory with the pair axis last (``z.T`` and
    ``r.transpose(1, 2, 0)`` are contiguous), the layout of :mod:`acc_fusion.filters.kalman`.
    """

    t: float
    sensor: str
    z: np.ndarray
    r: np.ndarray
    valid: np.ndarray
    ghost: np.ndarray
    online: bool = True

    @property
    def n_pairs(self) -> int:
        """Number of pairs N."""
        return int(self.valid.shape[0])


def _streams(seed: int | np.random.Generator | None) -> list[np.random.Generator]:
    """Three independent generators (noise, ghosts, faults) spawned from ``seed``."""
    try:
        root = np.random.default_rng(seed)
    except (TypeError, ValueError):
        raise ConfigError(
            f"seed must be a non-negative integer, a numpy Generator or None, got {seed!r}"
        ) from None
    return root.spawn(3)


class Sensor(PairState):
    """A range/range-rate sensor over N pairs: timing, limits, noise, clutter and faults.

    The model is described in the module docstring.  State (sample clock, clutter, the value a
    stuck sensor repeats) lives here; :meth:`reset` clears it for a new run.

    Args:
        spec: the sensor's performance (:func:`radar_spec`, :func:`infrared_spec`).
        faults: faults to inject (:class:`~acc_fusion.sensors.faults.Fault`).
        seed: ``int``, :class:`numpy.random.Generator` or ``None`` (fresh entropy).

    Example:
        >>> import numpy as np
        >>> from acc_fusion.truth.frame import TruthFrame
        >>> radar = RadarSensor(seed=1)
        >>> frame = TruthFrame(t=0.0, ego_speed=np.array([25.0]), ego_accel=np.zeros(1),
        ...                    gap=np.array([40.0]), lead_speed=np.array([20.0]),
        ...                    lead_accel=np.zeros(1), leader_id=np.array([7]))
        >>> m = radar.measure(frame)
        >>> m.z.shape, m.r.shape, bool(m.valid[0])
        ((1, 2), (1, 2, 2), True)
    """

    #: Spec used when none is given (subclasses set it); ``None``: a spec is required.
    default_spec = None
    _PAIR_AXES = {
        "_held_z": 1, "_held_valid": 0, "_held_ghost": 0, "_ghost_range": 0, "_ghost_life": 0
    }  # fmt: skip

    def __init__(
        self,
        spec: SensorSpec | None = None,
        faults: Sequence[Fault] = (),
        seed: int | np.random.Generator | None = None,
    ) -> None:
        if spec is None and self.default_spec is not None:
            spec = self.default_spec()
        if not isinstance(spec, SensorSpec):
            raise ConfigError(f"spec must be a SensorSpec, got {type(spec).__name__}")
        for i, fault in enumerate(faults):
            if not isinstance(fault, Fault):
                raise ConfigError(
                    f"{spec.name}.faults[{i}] must be a Fault, got {type(fault).__name__}"
                )
        self.spec = spec
        self.faults = tuple(faults)
        # The spec's scalars in the order the kernels take them.
        self._observe_params = (
            spec.min_range, spec.max_range, math.radians(spec.fov_deg) / 2, spec.detection_prob,
            spec.range_std, spec.range_std_quadratic, spec.range_rate_std,
        )  # fmt: skip
        self._emit_params = (spec.range_std, spec.range_std_quadratic, spec.range_rate_std**2)
        self._rng_noise, self._rng_ghost, self._rng_fault = _streams(seed)
        self.reset()
        _warmup()

    def reset(self, seed: int | np.random.Generator | None = None) -> None:
        """Clear the state for a new run; with a ``seed``, also restart the random streams.

        Without a seed the streams continue, so successive runs see fresh noise (as in
        gymnasium's ``reset``).  The next :meth:`measure` fixes the number of pairs N.
        """
        if seed is not None:
            self._rng_noise, self._rng_ghost, self._rng_fault = _streams(seed)
        self._n: int | None = None
        self._capacity = 0  # the pairs the random draws are made for (>= N)
        self._t_prev = -math.inf
        self._k = 0  # index of the next sample time phase + k / rate_hz
        self._held_z: np.ndarray | None = None  # (2, N): the last output, what stuck repeats
        self._held_valid: np.ndarray | None = None
        self._held_ghost: np.ndarray | None = None
        self._ghost_range: np.ndarray | None = None
        self._ghost_life: np.ndarray | None = None
        self.__dict__.pop("_parked", None)

    def allocate(self, n: int) -> None:
        """Fix the number of pairs N (the first :meth:`measure` does it with its frame's N).

        The random draws are made for these N pairs even after :meth:`resize` to fewer."""
        self._n = self._capacity = n
        self._held_z = np.full((MEAS_DIM, n), np.nan)
        self._held_valid = np.zeros(n, dtype=bool)
        self._held_ghost = np.zeros(n, dtype=bool)
        self._ghost_range = np.full(n, np.inf)
        self._ghost_life = np.zeros(n)

    def _resized(self, m: int) -> None:
        self._n = m

    def forget(self, pairs: np.ndarray) -> None:
        """Clear the clutter and the held output of ``pairs`` (a slot that got a new
        vehicle: its sensor has seen nothing yet)."""
        _forget(
            pair_mask(pairs, self._n), self._held_z, self._held_valid, self._held_ghost,
            self._ghost_range, self._ghost_life,
        )  # fmt: skip

    def _draw(self, draw, rows: int = 0) -> np.ndarray:
        """``draw(shape)`` for every allocated pair (``rows`` > 0: ``(rows, pairs)``), cut to
        the N pairs held now, so that each pair's draws do not depend on N."""
        n, cap = self._n, self._capacity
        if rows == 0:
            return draw(cap)[:n]
        return np.ascontiguousarray(draw((rows, cap))[:, :n])

    def measure(self, frame: TruthFrame) -> Measurement:
        """Return the sensor's measurement of ``frame`` (``valid`` all False between samples).

        The random draws are made here, with fixed shapes, and the per-pair work is done by the
        compiled kernels :func:`_observe` (visibility, clutter, true value, noise) and
        :func:`_emit` (held value, output, declared R); the faults act in between.
        """
        n, dt = self._start_frame(frame)
        self._advance_ghosts(frame, dt)
        if not self._sample_due(frame.t):
            return _empty(frame.t, self.spec.name, n)
        detect_u = self._draw(self._rng_noise.random)
        e = self._draw(self._rng_noise.standard_normal, MEAS_DIM)
        # numpy's arctan2 (SIMD) and libm's may differ in the last bit: the bearings come from
        # numpy, unless every offset is zero (the kernel then uses the exact atan2(0, gap)).
        lat = frame.lateral_offset
        bearing = np.arctan2(lat, frame.gap) if np.count_nonzero(lat) else None
        truth = (frame.gap, frame.leader_id, frame.ego_speed, frame.lead_speed, bearing)
        ghosts = (self._ghost_range, self._ghost_life)
        held = (self._held_z, self._held_valid, self._held_ghost)
        z, r = np.empty((MEAS_DIM, n)), np.empty((MEAS_DIM, MEAS_DIM, n))
        valid, ghost = np.empty(n, dtype=bool), np.empty(n, dtype=bool)
        active = [f for f in self.faults if f.active(frame.t)]
        if active:
            clean, noise = np.empty((MEAS_DIM, n)), np.empty((MEAS_DIM, n))
            seen, seen_ghost = np.empty(n, dtype=bool), np.empty(n, dtype=bool)
            _observe(
                *truth, *ghosts, detect_u, e, self._observe_params, clean, noise, seen, seen_ghost
            )
            out = apply_faults(
                active, frame.t, Report(clean.T, seen, seen_ghost), noise.T,
                Report(self._held_z.T, self._held_valid, self._held_ghost), self._rng_fault,
                self._capacity,
            )  # fmt: skip
            _emit(out.z.T, out.valid, out.ghost, *held, self._emit_params, z, r, valid, ghost)
        else:  # no fault acts between the two kernels: both in one pass
            _observe_emit(
                *truth, *ghosts, detect_u, e, self._observe_params, *held, self._emit_params,
                z, r, valid, ghost,
            )  # fmt: skip
        online = not any(f.kind == "dropout" for f in active)
        return Measurement(frame.t, self.spec.name, z.T, r.transpose(2, 0, 1), valid, ghost, online)

    def _start_frame(self, frame: TruthFrame) -> tuple[int, float]:
        """Check N and time order against the previous frames; return N and the time step."""
        if not isinstance(frame, TruthFrame):
            raise InputError(f"measure() needs a TruthFrame, got {type(frame).__name__}")
        n = frame.n_pairs
        if self._n is None:
            self.allocate(n)
        elif n != self._n:
            raise InputError(
                f"frame has {n} pairs but {self.spec.name} was started with {self._n}; "
                "call reset() before changing the number of pairs"
            )
        if not frame.t > self._t_prev:
            raise InputError(
                f"frame.t must increase from one measure() call to the next, "
                f"got {frame.t!r} after {self._t_prev!r}"
            )
        dt = 0.0 if math.isinf(self._t_prev) else frame.t - self._t_prev
        self._t_prev = frame.t
        return n, dt

    def _advance_ghosts(self, frame: TruthFrame, dt: float) -> None:
        r"""Move and age the clutter ghosts by ``dt`` and spawn new ones (in place).

        A pair spawns a ghost when its slot is free and at least one Poisson arrival falls in
        the step, probability :math:`1 - e^{-\lambda\,dt}`.  Without clutter the slots stay
        free (lifetime 0, range inf) and nothing is drawn.
        """
        spec = self.spec
        if spec.ghost_rate == 0.0:
            return
        u = self._draw(self._rng_ghost.random, 3)
        _move_ghosts(
            u, frame.ego_speed, dt, -math.expm1(-spec.ghost_rate * dt), *spec.ghost_range,
            *spec.ghost_duration, self._ghost_range, self._ghost_life,
        )  # fmt: skip

    def _sample_due(self, t: float) -> bool:
        """Whether the sensor samples at frame time ``t``; advances the sample clock if so."""
        rate, phase = self.spec.rate_hz, self.spec.phase
        if t < phase + self._k / rate - TIME_TOL:
            return False
        self._k = math.floor((t - phase + TIME_TOL) * rate) + 1
        return True


def _empty(t: float, name: str, n: int) -> Measurement:
    """The measurement of a frame at which the sensor does not sample: nothing valid."""
    return Measurement(
        t=t,
        sensor=name,
        z=np.full((MEAS_DIM, n), np.nan).T,
        r=np.eye(MEAS_DIM)[:, :, None].repeat(n, axis=2).transpose(2, 0, 1),
        valid=np.zeros(n, dtype=bool),
        ghost=np.zeros(n, dtype=bool),
        online=False,
    )


def _warmup() -> None:
    """Compile (or load from numba's cache) the kernels for frames of contiguous arrays.

    :class:`Sensor` calls it on construction, so that its first :meth:`~Sensor.measure` costs
    what the next ones do (other array types compile on first use).
    """
    x, flag, ids = np.zeros(1), np.zeros(1, dtype=bool), np.zeros(1, dtype=np.int64)
    pair, cov = np.zeros((MEAS_DIM, 1)), np.zeros((MEAS_DIM, MEAS_DIM, 1))
    _move_ghosts(np.zeros((3, 1)), x, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, x, x)
    for bearing in (None, x):
        _observe(x, ids, x, x, bearing, x, x, x, pair, (0.0,) * 7, pair, pair, flag, flag)
    _emit(pair, flag, flag, pair, flag, flag, (0.0,) * 3, pair, cov, flag, flag)
    for bearing in (None, x):
        _observe_emit(
            x, ids, x, x, bearing, x, x, x, pair, (0.0,) * 7, pair, flag, flag, (0.0,) * 3, pair,
            cov, flag, flag,
        )  # fmt: skip


@njit(cache=True)
def _forget(pairs, held_z, held_valid, held_ghost, ghost_range, ghost_life):  # pragma: no cover
    """:meth:`Sensor.forget` of the pairs in ``pairs (N,)``, in place: no held output
    (``held_z (2, N)`` NaN, not valid, no ghost) and a free clutter slot (range inf,
    lifetime 0)."""
    for i in range(pairs.size):
        if pairs[i]:
            for a in range(held_z.shape[0]):
                held_z[a, i] = np.nan
            held_valid[i] = False
            held_ghost[i] = False
            ghost_range[i] = np.inf
            ghost_life[i] = 0.0


@njit(cache=True)
def _move_ghosts(
    u, ego_speed, dt, p_spawn, r_lo, r_hi, d_lo, d_hi, ghost_range, ghost_life
):  # pragma: no cover - compiled
    """Age every pair's ghost by ``dt`` and close it at ``ego_speed``, or spawn a new one.

    A free slot (lifetime ``<= 0`` after ageing) spawns when ``u[0] < p_spawn``, at range
    ``r_lo + (r_hi - r_lo) u[1]`` with lifetime ``d_lo + (d_hi - d_lo) u[2]``;
    ``ghost_range`` and ``ghost_life`` ``(N,)`` are updated in place.
    """
    for i in range(ghost_life.size):
        life = ghost_life[i] - dt
        if life <= 0 and u[0, i] < p_spawn:
            ghost_range[i] = r_lo + (r_hi - r_lo) * u[1, i]
            ghost_life[i] = d_lo + (d_hi - d_lo) * u[2, i]
        else:
            ghost_range[i] = ghost_range[i] - ego_speed[i] * dt
            ghost_life[i] = life


@njit(cache=True)
def _observe(
    gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e, params,
    clean, noise, seen, ghost,
):  # pragma: no cover - compiled  # fmt: skip
    """What the sensor sees of each pair, before faults (:func:`_observe_one` of every pair).

    Writes ``clean (2, N)`` the true [range, range-rate] of the reported object, ``noise
    (2, N)`` the scaled noise, ``seen (N,)`` visible and detected, ``ghost (N,)`` the reported
    object is a ghost.
    """
    for i in range(gap.size):
        clean[0, i], clean[1, i], noise[0, i], noise[1, i], seen[i], ghost[i] = _observe_one(
            i, gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e,
            params,
        )  # fmt: skip


# The per-pair helpers are left to LLVM to inline: numba's own inlining (inline="always")
# made the loop of _observe_emit three times slower.
@njit(cache=True)
def _observe_one(
    i, gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e, params
):  # pragma: no cover - compiled
    """What the sensor sees of pair ``i``, before faults (the model of the module docstring).

    The target is visible with a leader, ``min_range <= gap <= max_range`` and
    ``|bearing| <= half_fov`` (``bearing`` ``None``: every lateral offset is zero, the bearing
    is ``atan2(0, gap)``); a live ghost in the range limits is reported instead unless the
    visible target is closer.  A visible return is detected when ``u < detection_prob``.
    Returns the true range and range-rate of the reported object, the draws ``e[:, i]``
    scaled by ``[range_noise_std(true range), range_rate_std]``, whether the object is seen
    (visible and detected) and whether it is a ghost.
    """
    min_range, max_range, half_fov, detection_prob, range_std, quadratic, rate_std = params
    g = gap[i]
    target = leader_id[i] >= 0 and g >= min_range and g <= max_range
    if target:
        if bearing is not None:
            b = bearing[i]
        else:  # atan2(0, g) is 0 for g > 0; g = +-0 gives 0 or pi
            b = 0.0 if g > 0.0 else np.arctan2(0.0, g)
        target = abs(b) <= half_fov
    gr = ghost_range[i]
    in_view = ghost_life[i] > 0 and gr >= min_range and gr <= max_range
    use_ghost = in_view and not (target and g <= gr)
    if use_ghost:
        true_range, true_rate = gr, -ego_speed[i]
    else:
        true_range, true_rate = g, lead_speed[i] - ego_speed[i]
    noise_range = e[0, i] * (range_std + quadratic * true_range * true_range)
    noise_rate = e[1, i] * rate_std
    seen = (target or use_ghost) and u[i] < detection_prob
    return true_range, true_rate, noise_range, noise_rate, seen, use_ghost


@njit(cache=True)
def _emit(
    out_z, out_valid, out_ghost, held_z, held_valid, held_ghost, params, z, r, valid, ghost
):  # pragma: no cover - compiled
    """Turn the (faulted) report ``out_*`` (``out_z (2, N)``) into the measurement
    (:func:`_emit_one` of every pair)."""
    for i in range(valid.size):
        _emit_one(
            i, out_z[0, i], out_z[1, i], out_valid[i], out_ghost[i], held_z, held_valid,
            held_ghost, params, z, r, valid, ghost,
        )  # fmt: skip


@njit(cache=True)
def _emit_one(
    i, out_range, out_rate, out_valid, out_ghost, held_z, held_valid, held_ghost, params, z, r,
    valid, ghost,
):  # pragma: no cover - compiled  # fmt: skip
    """Turn pair ``i``'s report into its measurement; remember what was output.

    Where ``out_valid``: ``held_*`` takes the report (in place), ``z (2, N)`` is the report
    with the range clipped at 0 (a range sensor cannot report a negative range; as with
    ``np.maximum``, NaN stays NaN and -0 becomes +0) and ``r (2, 2, N)`` is
    ``diag(range_noise_std(z[0])**2, range_rate_std**2)``; elsewhere ``z`` is NaN and ``r``
    the identity.  ``valid`` and ``ghost (N,)`` are the output flags.
    """
    range_std, quadratic, rate_var = params
    if out_valid:
        held_z[0, i] = out_range
        held_z[1, i] = out_rate
        held_valid[i] = True
        held_ghost[i] = out_ghost
        dist = 0.0 if out_range <= 0.0 else out_range
        std = range_std + quadratic * dist * dist
        z[0, i] = dist
        z[1, i] = out_rate
        r[0, 0, i] = std * std
        r[1, 1, i] = rate_var
    else:
        z[0, i] = np.nan
        z[1, i] = np.nan
        r[0, 0, i] = 1.0
        r[1, 1, i] = 1.0
    r[0, 1, i] = 0.0
    r[1, 0, i] = 0.0
    valid[i] = out_valid
    ghost[i] = out_valid and out_ghost


@njit(cache=True)
def _observe_emit(
    gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e,
    observe_params, held_z, held_valid, held_ghost, emit_params, z, r, valid, ghost,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_observe` then :func:`_emit` of the unfaulted report (clean value plus noise),
    pair by pair in one pass."""
    for i in range(gap.size):
        true_range, true_rate, noise_range, noise_rate, seen, use_ghost = _observe_one(
            i, gap, leader_id, ego_speed, lead_speed, bearing, ghost_range, ghost_life, u, e,
            observe_params,
        )  # fmt: skip
        _emit_one(
            i, true_range + noise_range, true_rate + noise_rate, seen, use_ghost, held_z,
            held_valid, held_ghost, emit_params, z, r, valid, ghost,
        )  # fmt: skip


class RadarSensor(Sensor):
    """A :class:`Sensor` whose spec defaults to :func:`radar_spec`."""

    default_spec = staticmethod(radar_spec)


class InfraredSensor(Sensor):
    """A :class:`Sensor` whose spec defaults to :func:`infrared_spec`."""

    default_spec = staticmethod(infrared_spec)
