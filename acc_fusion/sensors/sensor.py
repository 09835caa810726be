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

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.motion import MEAS_DIM
from acc_fusion.core.slots import PairState, pair_mask
from acc_fusion.sensors.faults import Fault, Report, apply_faults
from acc_fusion.sensors.kernels import _emit, _forget, _move_ghosts, _observe, _observe_emit
from acc_fusion.sensors.scan import SampleClock, streams
from acc_fusion.sensors.spec import SensorSpec, infrared_spec, radar_spec
from acc_fusion.truth.frame import TruthFrame


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
        self._rng_noise, self._rng_ghost, self._rng_fault = streams(seed, 3)
        self.reset()
        _warmup()

    def reset(self, seed: int | np.random.Generator | None = None) -> None:
        """Clear the state for a new run; with a ``seed``, also restart the random streams.

        Without a seed the streams continue, so successive runs see fresh noise (as in
        gymnasium's ``reset``).  The next :meth:`measure` fixes the number of pairs N.
        """
        if seed is not None:
            self._rng_noise, self._rng_ghost, self._rng_fault = streams(seed, 3)
        self._n: int | None = None
        self._capacity = 0  # the pairs the random draws are made for (>= N)
        self._t_prev = -math.inf
        self._clock = SampleClock(self.spec.rate_hz, self.spec.phase)
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
        return self._clock.due(t)


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


class RadarSensor(Sensor):
    """A :class:`Sensor` whose spec defaults to :func:`radar_spec`."""

    default_spec = staticmethod(radar_spec)


class InfraredSensor(Sensor):
    """A :class:`Sensor` whose spec defaults to :func:`infrared_spec`."""

    default_spec = staticmethod(infrared_spec)
