r"""Fusion center: Carlson's federated Kalman filter and the baselines it is judged against.

All estimators share one interface: ``step(measurements, target_id) -> Estimate``, batched
over N follower→leader pairs, one step of ``FilterConfig.dt`` seconds per call, run on either
engine (:mod:`acc_fusion.filters.engines`).  Methods (:data:`FUSION_METHODS`, plus any sensor name):

``<sensor name>`` (e.g. ``"radar"``)
    That sensor alone: one Kalman filter on its measurements (kong2011's local filter).
``"centralized"`` / ``"centralized_stacked"``
    One Kalman filter fed by every sensor: predict once, then update with each reporting
    sensor in turn (*sequential*) or with all of them stacked into one measurement vector
    (*stacked*); both are the optimal linear estimate (qa-multisensor thread).
``"federated"``
    Carlson's federated filter (Carlson 1990; hu2005 eqs. 3-10; kong2011 eqs. 1-6): one local
    filter per sensor and a master filter.  The information-sharing factors
    :math:`\beta_i` (:math:`\sum_i \beta_i = 1`) divide the process-noise and prior
    information among the locals, :math:`Q_i = \beta_i^{-1} Q`, :math:`P_i = \beta_i^{-1} P_m`,
    which removes the correlation the common process noise would otherwise create; the
    master fuses :math:`P_m = (\sum_i P_i^{-1})^{-1}`, :math:`\hat x_m = P_m\sum_i P_i^{-1}\hat
    x_i` every ``fusion_period`` steps.  Reset modes:

    * ``fusion`` (fusion-reset, :math:`\beta_m = 0`): after each fusion every local restarts from
      the fused estimate with :math:`P_i = \beta_i^{-1} P_m`.  Fused at every step this equals
      the centralized filter exactly.
    * ``zero`` (zero-reset, :math:`\beta_m = 1`): the master keeps all the process-noise and
      prior information; each local restarts from the fused estimate and reports only the
      information it gathered since, :math:`P_m^{-1} = P_m^{-,-1} + \sum_i (P_i^{-1} -
      P_m^{-,-1})` (information-increment form).  Also exact when fused every step.
    * ``none`` (no-reset): locals start with :math:`\beta_i^{-1}`-inflated prior and process
      noise and are never reset; the fused covariance is then an upper bound (conservative).

    :math:`\beta` is ``"equal"`` (:math:`1/n`), ``"trace"`` (covariance-based: the more
    precise local gets the larger share, :math:`\beta_i \propto 1/\mathrm{tr}(\beta_i P_i)`;
    hu2005's diagonal method prints the ratio the other way up and per state component, which
    breaks :math:`\sum_i P_i^{-1} = P_m^{-1}`, so acc_fusion uses its scalar, information-
    preserving form), or explicit values.  Fault detection and isolation
    (:mod:`acc_fusion.fusion.fdi`) leaves failing sensors out of the fusion.
``"plain"``
    kong2011's fusion formula without information sharing: independent full local filters
    (:math:`\beta_i = 1`, no reset) fused as if uncorrelated.  Over-confident, because the
    locals share the process noise and the initial measurement (hu2005's point).

Track management (all methods): a pair's filters (re)initialise from the first measurement
after its target id changes (a new leader, from the truth source's leader ids: the data
association of a real tracker) or after ``max_coast`` seconds without a usable measurement:
:math:`\hat x_0 = [r, \dot r, 0]`, :math:`P_0 = \mathrm{diag}(R, \sigma_{a,0}^2)`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.motion import (
    MEAS_DIM,
    MEASUREMENT_MATRIX,
    STATE_DIM,
    ca_process_noise,
    ca_transition,
    ego_input,
)
from acc_fusion.core.slots import PairState
from acc_fusion.core.validation import check_array, check_choice, check_range
from acc_fusion.filters.engines import ENGINES, Engine
from acc_fusion.filters.kalman import (
    assign_one,
    fuse_one,
    input_args,
    nis_one,
    predict_one,
    update_one,
)
from acc_fusion.fusion.fdi import FDIConfig, WindowedChiSquare, reset_one, window_one

if TYPE_CHECKING:
    from acc_fusion.sensors.sensor import Measurement, SensorSpec

FUSION_METHODS = ("centralized", "centralized_stacked", "federated", "plain")
RESET_MODES = ("fusion", "zero", "none")
BETA_METHODS = ("equal", "trace")
LOCAL_FILTERS = ("full", "steady")


@dataclass(frozen=True)
class FilterConfig:
    """Local-filter model, shared by every method.

    Attributes:
        dt: step of the estimation loop [s] (default 0.05: the radar's 20 Hz).
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

    dt: float = 0.05
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
            :class:`~acc_fusion.sensors.sensor.SensorSpec` for its rate and noise).
        steady_range: range [m] at which a range-dependent noise is evaluated for the
            constant gain (default 40 m).
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

    def __post_init__(self) -> None:
        check_choice("fusion.engine", self.engine, ENGINES)
        check_choice("fusion.local", self.local, LOCAL_FILTERS)
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


@dataclass(frozen=True)
class Estimate:
    """What an estimator knows about every pair after one step.

    Attributes:
        t: time [s].
        x: state estimates ``(N, 3)``: gap [m], range-rate [m/s], relative accel [m/s²].
        p: covariances ``(N, 3, 3)``.
        valid: ``(N,)`` pairs with an initialised track (``x`` is meaningless elsewhere).
        nis: ``(N, S)`` NIS of each sensor's measurement against the estimator's prediction
            at this step (NaN where the sensor did not report).
        isolated: ``(N, S)`` sensors the fault detection has left out of the fusion.
    """

    t: float
    x: np.ndarray
    p: np.ndarray
    valid: np.ndarray
    nis: np.ndarray
    isolated: np.ndarray

    @property
    def gap(self) -> np.ndarray:
        """Estimated gap [m] ``(N,)``."""
        return self.x[:, 0]

    @property
    def gap_std(self) -> np.ndarray:
        """Standard deviation of the gap estimate [m] ``(N,)``."""
        return np.sqrt(self.p[:, 0, 0])


class Estimator(PairState, ABC):
    """Common track management and input checks; subclasses implement ``_advance``."""

    _PAIR_AXES = {"initialised": 0, "_target": 0, "_last": 0, "_nis": 0}

    def __init__(self, sensors: Sequence[str], n_pairs: int, config: FusionConfig) -> None:
        if n_pairs < 1:
            raise ConfigError(f"n_pairs must be >= 1, got {n_pairs}")
        self.sensors = tuple(sensors)
        self.n_pairs = int(n_pairs)
        self.config = config
        self.engine = Engine(config.engine)
        fc = config.filter
        self.f = ca_transition(fc.dt)
        self.b = ego_input(fc.dt)
        self.q = (
            ca_process_noise(fc.dt, fc.jerk_std) + np.outer(self.b, self.b) * fc.ego_accel_std**2
        )
        self.h = MEASUREMENT_MATRIX
        self._u = None
        self.reset()

    @property
    def n_sensors(self) -> int:
        return len(self.sensors)

    def _resized(self, m: int) -> None:
        self.n_pairs = m

    def reset(self) -> None:
        """Forget every track."""
        n = self.n_pairs
        self.initialised = np.zeros(n, dtype=bool)
        self._target = np.full(n, np.iinfo(np.int64).min, dtype=np.int64)
        self._last = np.zeros(n)
        self._nis = np.full((n, self.n_sensors), np.nan)
        self._reset_state()

    def forget(self, pairs: np.ndarray) -> None:
        """Drop the tracks of ``pairs`` (a boolean mask), e.g. when a slot gets a new vehicle."""
        pairs = np.asarray(pairs, dtype=bool)
        if pairs.any():
            self.initialised &= ~pairs
            self._target[pairs] = np.iinfo(np.int64).min
            self._drop(pairs)

    @abstractmethod
    def _reset_state(self) -> None: ...

    @abstractmethod
    def _advance(self, z, r, valid) -> np.ndarray:
        """One predict/update cycle; returns the pairs that used a measurement."""

    @abstractmethod
    def _drop(self, pairs: np.ndarray) -> None:
        """Forget the tracks of ``pairs`` (their filters are re-initialised later)."""

    @abstractmethod
    def _state(self) -> tuple[np.ndarray, np.ndarray]: ...

    @property
    def _coast_limit(self) -> float:
        """Seconds a track may go without a measurement before it is lost (``max_coast``,
        with a tolerance for the rounding of summed time steps)."""
        return self.config.filter.max_coast + 1e-9

    def _isolated(self) -> np.ndarray:
        return np.zeros((self.n_pairs, self.n_sensors), dtype=bool)

    def _reported(self) -> np.ndarray:
        """The pairs whose estimate is reported as valid (a copy)."""
        return self.initialised.copy()

    def step(
        self,
        measurements: Sequence[Measurement],
        target_id: np.ndarray,
        ego_accel: np.ndarray | None = None,
    ) -> Estimate:
        """Advance every pair by one step with this step's measurements (one per sensor).

        ``ego_accel (N,)`` is the ego's measured acceleration over the coming step [m/s²]:
        the known input of the motion model (:func:`acc_fusion.core.motion.ego_input`).
        """
        z, r, valid, target_id = self._check(measurements, target_id)
        if ego_accel is not None:
            ego_accel = check_array("ego_accel", ego_accel, (self.n_pairs,))
        self._u = ego_accel
        t = float(measurements[0].t)
        lost = np.empty(self.n_pairs, dtype=bool)
        limit = self._coast_limit
        if _lose(self.initialised, self._target, target_id, self._last, t, limit, lost):
            self._drop(lost)
        self._nis[:] = np.nan
        self._t = t
        self._online = np.array([bool(getattr(m, "online", True)) for m in measurements])
        used = self._advance(z, r, valid)
        self._last[used] = t
        x, p = self._state()
        return Estimate(
            t=t,
            x=np.array(x),
            p=np.array(p),
            valid=self._reported(),
            nis=self._nis.copy(),
            isolated=self._isolated(),
        )

    def _check(self, measurements, target_id):
        n, s = self.n_pairs, self.n_sensors
        if len(measurements) != s:
            raise InputError(
                f"expected {s} measurements ({', '.join(self.sensors)}), got {len(measurements)}"
            )
        target_id = np.asarray(target_id)
        if target_id.shape != (n,) or not np.issubdtype(target_id.dtype, np.integer):
            raise InputError(
                f"target_id must be an integer array of shape ({n},), got {target_id.shape}"
            )
        valid = np.empty((s, n), dtype=bool)
        z, r = np.empty((s, n, 2)), np.empty((s, n, 2, 2))
        finite, low, positive = [], [], []
        for i, m in enumerate(measurements):
            if np.shape(m.z) != (n, 2) or np.shape(m.r) != (n, 2, 2) or np.shape(m.valid) != (n,):
                raise InputError(
                    f"{self._name(i)} must have z (N, 2), r (N, 2, 2), valid (N,) with N = {n}, "
                    f"got {np.shape(m.z)}, {np.shape(m.r)}, {np.shape(m.valid)}"
                )
            ok, lowest, pos = _gather(
                np.asarray(m.z, dtype=float), np.asarray(m.r, dtype=float),
                np.asarray(m.valid, dtype=bool), z[i], r[i], valid[i],
            )  # fmt: skip
            finite.append(ok)
            low.append(lowest)
            positive.append(pos)
        if not all(finite):
            raise InputError(
                f"{self._name(finite.index(False))} has NaN or inf in a valid measurement or its "
                "covariance"
            )
        if min(low) < 0:
            i = low.index(min(low))
            raise InputError(
                f"{self._name(i)} has a negative range ({low[i]:g} m); ranges must be >= 0"
            )
        if not all(positive):
            raise InputError(
                f"{self._name(positive.index(False))} has a non-positive measurement variance; it "
                "must be > 0"
            )
        return z, r, valid, target_id.astype(np.int64, copy=False)

    def _name(self, i: int) -> str:
        """How an error names measurement ``i``."""
        return f"measurements[{int(i)}] ({self.sensors[int(i)]})"

    def _initial(self, z, r, valid):
        """Initial states from the first reporting sensor of each uninitialised pair.

        Returns ``(init (N,), x0 (N, 3), p0 (N, 3, 3), consumed (S, N))``; ``x0`` and ``p0``
        are ``None`` when no pair starts a track at this step.
        """
        init = ~self.initialised & valid.any(axis=0)
        if not init.any():
            return init, None, None, np.zeros_like(valid)
        first = np.argmax(valid, axis=0)
        cols = np.arange(self.n_pairs)
        zf, rf = z[first, cols], r[first, cols]
        x0 = np.zeros((self.n_pairs, STATE_DIM))
        x0[:, :2] = zf
        p0 = np.zeros((self.n_pairs, STATE_DIM, STATE_DIM))
        p0[:, :2, :2] = rf
        p0[:, 2, 2] = self.config.filter.init_accel_std**2
        consumed = (np.arange(self.n_sensors)[:, None] == first[None, :]) & init[None, :]
        return init, x0, p0, consumed

    @staticmethod
    def _rows(mask: np.ndarray, m: int = 2) -> np.ndarray:
        return np.repeat(mask[:, None], m, axis=1)


class _OneFilter(Estimator):
    """An estimator made of one Kalman filter per pair."""

    def _reset_state(self):
        self.bank = self.engine.bank(1, self.n_pairs, STATE_DIM)

    def _resized(self, m):
        super()._resized(m)
        self.bank.resize(m)

    def _drop(self, pairs):
        pass  # the filter is overwritten when the pair initialises again

    def _state(self):
        return self.bank.x[0], self.bank.p[0]


class SingleSensorFilter(_OneFilter):
    """One sensor alone: its local Kalman filter (kong2011 eqs. 1-4)."""

    def __init__(self, sensors, n_pairs, config, sensor: str) -> None:
        self.index = list(sensors).index(sensor)
        super().__init__(sensors, n_pairs, config)

    def _advance(self, z, r, valid):
        j = self.index
        self.bank.predict(self.f, self.q, 1.0, self.initialised[None], self.b, self._u)
        only = np.zeros_like(valid)
        only[j] = valid[j]
        init, x0, p0, _ = self._initial(z, r, only)
        if x0 is not None:
            self.bank.assign(0, init, x0, p0)
            self.initialised |= init
        rows = self._rows(self.initialised & valid[j] & ~init)
        self._nis[:, j] = self.bank.update(0, z[j], r[j], self.h, rows)
        return valid[j] & self.initialised


class CentralizedFilter(_OneFilter):
    """One Kalman filter updated by every sensor, sequentially or stacked."""

    def __init__(self, sensors, n_pairs, config, stacked: bool = False) -> None:
        self.stacked = stacked
        super().__init__(sensors, n_pairs, config)

    def _advance(self, z, r, valid):
        self.bank.predict(self.f, self.q, 1.0, self.initialised[None], self.b, self._u)
        init, x0, p0, consumed = self._initial(z, r, valid)
        if x0 is not None:
            self.bank.assign(0, init, x0, p0)
            self.initialised |= init
        use = self.initialised[None] & valid & ~consumed
        x_prior, p_prior = np.array(self.bank.x[0]), np.array(self.bank.p[0])
        for s in range(self.n_sensors):
            self._nis[:, s] = self.engine.nis(
                x_prior, p_prior, z[s], r[s], self.h, self._rows(use[s])
            )
        if self.stacked:
            s = self.n_sensors
            r_all = np.zeros((self.n_pairs, 2 * s, 2 * s))
            for i in range(s):
                r_all[:, 2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = r[i]
            self.bank.update(
                0,
                np.concatenate(list(z), axis=1),
                r_all,
                np.vstack([self.h] * s),
                np.concatenate([self._rows(u) for u in use], axis=1),
            )
        else:
            for i in range(self.n_sensors):
                self.bank.update(0, z[i], r[i], self.h, self._rows(use[i]))
        return (use | consumed).any(axis=0)


class FederatedFilter(Estimator):
    """Carlson's federated Kalman filter (see the module docstring); ``plain`` = no sharing."""

    _PAIR_AXES = {
        **Estimator._PAIR_AXES, "beta": 1, "_seen": 1, "_needed": 1, "_reported_at": 1
    }  # fmt: skip

    def __init__(self, sensors, n_pairs, config, plain: bool = False, specs=None) -> None:
        self.plain = plain
        self._coverage = (
            None
            if specs is None
            else np.array([[sp.min_range for sp in specs], [sp.max_range for sp in specs]])
        )
        reset = "none" if plain else config.reset
        self._feedback = reset in ("fusion", "zero")
        self._increments = reset == "zero"
        self._inflate = not plain and reset != "zero"
        if not isinstance(config.beta, str) and len(config.beta) != len(sensors):
            raise ConfigError(
                f"fusion.beta has {len(config.beta)} values but there are {len(sensors)} sensors"
            )
        b = config.beta
        # The initial sharing factors (also a new track's).
        self._beta0 = (
            np.full(len(sensors), 1.0 / len(sensors))
            if isinstance(b, str)
            else np.array(b, dtype=float)
        )
        super().__init__(sensors, n_pairs, config)

    def _reset_state(self):
        n, s = self.n_pairs, self.n_sensors
        self.locals = self.engine.bank(s, n, STATE_DIM)
        self.master = self.engine.bank(1, n, STATE_DIM)
        self.beta = np.repeat(self._beta0[:, None], n, axis=1)
        self._infl: np.ndarray | None = None  # 1 / beta, recomputed after beta changes
        fdi = None if self.plain else self.config.fdi
        self.fdi = None if fdi is None else WindowedChiSquare(n, s, fdi)
        self._confirm = fdi is not None and fdi.confirm_tracks and self._coverage is not None
        self._seen = np.zeros((s, n), dtype=bool)
        self._needed = np.zeros((s, n), dtype=bool)
        self._online_at = np.full(s, -np.inf)
        self._reported_at = np.full((s, n), -np.inf)
        self._k = 0

    def _resized(self, m):
        super()._resized(m)
        self._infl = None
        for part in (self.locals, self.master, self.fdi):
            if part is not None:
                part.resize(m)

    def _drop(self, pairs):
        _drop_pairs(np.asarray(pairs, dtype=bool), *self._track_arrays())
        self._infl = None

    def _track_arrays(self) -> tuple:
        """The arrays :func:`_drop_one` resets: sharing factors (and their initial values),
        confirmation flags and the fault detector's windows (empty without one)."""
        fdi = self.fdi.arrays()[:6] if self.fdi is not None else _NO_FDI[:6]
        return (self.beta, self._beta0, self._seen, self._needed, self.fdi is not None, *fdi)

    def forget(self, pairs):
        super().forget(pairs)
        self._reported_at[:, np.asarray(pairs, dtype=bool)] = -np.inf  # a new vehicle's track

    def _reported(self) -> np.ndarray:
        r"""Tracks confirmed by every sensor that should see them.

        With fault detection on and the sensors' specs known, a new track is reported only
        once each sensor that should have seen it has contributed a measurement to it.  A
        sensor should see a track once it is online (it delivered a frame within
        ``max_coast``), not isolated, and the estimated gap has been inside its range
        interval at some step of the track.  A radar ghost (a stationary roadside object, the
        classic cause of FCW false alarms) that the infrared camera should see but does not
        is never reported, not even when its coasting estimate leaves the camera's range; a
        target beyond the camera's range needs the radar alone.
        """
        if not self._confirm:
            return self.initialised.copy()
        lo, hi = self._coverage
        out = np.empty(self.n_pairs, dtype=bool)
        _confirmed(
            self._needed, self._seen, self._online_at, self._t,
            self._coast_limit, self.master.x[0], lo, hi, self.fdi.isolated,
            self.initialised, out,
        )  # fmt: skip
        return out

    def _state(self):
        return self.master.x[0], self.master.p[0]

    def _isolated(self):
        return self._isolation().T.copy()

    def _isolation(self) -> np.ndarray:
        """``(S, N)`` isolation flags."""
        if self.fdi is None:
            return np.zeros((self.n_sensors, self.n_pairs), dtype=bool)
        return self.fdi.isolated.T

    def _inflation(self) -> np.ndarray:
        """``(S, N)`` factor :math:`1/\\beta_i` applied to a local's prior and process noise
        (kept until :math:`\\beta` changes)."""
        if self._infl is None and self._inflate:
            ok = self.beta > 0
            self._infl = np.where(ok, 1.0 / np.where(ok, self.beta, 1.0), 1.0)
        elif self._infl is None:
            self._infl = np.ones_like(self.beta)
        return self._infl

    def _share(self, active: np.ndarray) -> None:
        """Recompute :math:`\\beta` over the active locals of every pair (:func:`_share_one`)."""
        _share_pairs(
            np.ascontiguousarray(active), self.locals.p, self.beta, self._beta0,
            self.config.beta == "trace",
        )  # fmt: skip
        self._infl = None

    def _advance(self, z, r, valid):
        """One step of the federated filter on the engine's banks, operation by operation
        over all pairs: the reference (the filterpy engine runs it); the batched engine runs
        the same step pair by pair in one kernel (:meth:`_advance_batched`)."""
        if self.engine.name == "batched":
            return self._advance_batched(z, r, valid)
        s_all = range(self.n_sensors)
        ini = self.initialised
        self.master.predict(self.f, self.q, 1.0, ini[None], self.b, self._u)
        self.locals.predict(self.f, self.q, self._inflation(), ini[None], self.b, self._u)

        init, x0, p0, consumed = self._initial(z, r, valid)
        if x0 is not None:
            self._drop(init)
            self.master.assign(0, init, x0, p0)
            infl = self._inflation()
            for s in s_all:
                self.locals.assign(s, init, x0, p0, infl[s])
            ini = self.initialised = ini | init

        reporting = ini[None] & valid & ~consumed
        xm, pm = np.array(self.master.x[0]), np.array(self.master.p[0])
        nis = np.stack(
            [self.engine.nis(xm, pm, z[s], r[s], self.h, self._rows(reporting[s])) for s in s_all]
        )
        self._nis[:] = nis.T
        if self.fdi is not None:
            accepted, rejoined = (a.T for a in self.fdi.step(nis.T, reporting.T))
        else:
            accepted, rejoined = reporting, np.zeros_like(reporting)
        for s in s_all:
            self.locals.update(s, z[s], r[s], self.h, self._rows(accepted[s]))

        active = ini[None] & ~self._isolation()
        if self._k % self.config.fusion_period == 0:
            xf, pf = self.engine.fuse(
                self.locals.x,
                self.locals.p,
                active,
                self.master.x[0],
                self.master.p[0],
                self._increments,
            )
            self.master.assign(0, ini, xf, pf)
            if self._feedback:
                self._share(active)
                infl = self._inflation()
                for s in s_all:
                    self.locals.assign(s, active[s], xf, pf, infl[s])
        if rejoined.any():
            self._share(active)
            infl = self._inflation()
            xm, pm = self.master.x[0], self.master.p[0]
            for s in s_all:
                self.locals.assign(s, rejoined[s] & ini, xm, pm, infl[s])
        self._online_at[self._online] = self._t
        self._seen |= accepted | consumed
        self._reported_at[reporting | consumed] = self._t
        self._k += 1
        # A track whose every recently reporting sensor is isolated is lost: start again.
        isolated = self._isolation()
        silent = self._t - self._reported_at > self._coast_limit
        lost = ini & isolated.any(axis=0) & (isolated | silent).all(axis=0)
        if lost.any():
            self.initialised &= ~lost
            self._drop(lost)
        return (accepted | consumed).any(axis=0)

    def _advance_batched(self, z, r, valid):
        """:meth:`_advance` as one call of :func:`_federated_step` (the same arithmetic, in
        the same order, pair by pair: equal to it bit for bit)."""
        used = np.empty(self.n_pairs, dtype=bool)
        fdi = self.fdi
        fc = self.config.filter
        _federated_step(
            self.master.x[0], self.master.p[0], self.locals.x, self.locals.p, self.f, self.q,
            *input_args(self.b, self._u), self.h, z, r, valid, self.initialised,
            self._reported_at, *self._track_arrays(),
            *(fdi.tests() if fdi is not None else _NO_TESTS),
            fdi.arrays()[6] if fdi is not None else _NO_FDI[6],
            self._inflate, self._feedback, self._increments, self.config.beta == "trace",
            self._k % self.config.fusion_period == 0, fc.init_accel_std**2, self._t,
            self._coast_limit, self._nis, used,
        )  # fmt: skip
        self._infl = None
        self._online_at[self._online] = self._t
        self._k += 1
        return used


class SteadyStateFilter(Estimator):
    r"""One sensor alone with a constant-gain filter (patent CN103196450A, discrete form).

    The gain is the steady state of the Riccati recursion for a sensor that reports every
    :math:`m = \mathrm{round}(1 / (f_s\,T))` steps (:func:`~acc_fusion.filters.steady_state.
    periodic_steady_state`), with :math:`R` evaluated at ``steady_range``.  Per step it costs
    one matrix-vector product: :math:`\hat x \leftarrow F\hat x`, and on a report
    :math:`\hat x \leftarrow \hat x + K (z - H\hat x)`.  The covariance it reports is the
    steady-state one for the number of steps since the last report, which is optimistic during
    the transient after initialisation (the price of the constant gain).
    """

    def __init__(self, sensors, n_pairs, config, spec: SensorSpec) -> None:
        from acc_fusion.filters.steady_state import periodic_steady_state

        self.index = list(sensors).index(spec.name)
        fc = config.filter
        period = max(1, int(round(1.0 / (spec.rate_hz * fc.dt))))
        f, q = ca_transition(fc.dt), ca_process_noise(fc.dt, fc.jerk_std)
        r = np.diag([spec.range_noise_std(config.steady_range) ** 2, spec.range_rate_std**2])
        ss = periodic_steady_state(f, q, MEASUREMENT_MATRIX, r, period)
        self.gain, self.r_nominal = ss.K, r
        # Covariance k steps after a report, for k up to the longest coast.
        n_cov = int(np.ceil(fc.max_coast / fc.dt)) + 2
        covs = [ss.P_post]
        for _ in range(n_cov):
            covs.append(f @ covs[-1] @ f.T + q)
        self.cov_table = np.array(covs)
        super().__init__(sensors, n_pairs, config)

    _PAIR_AXES = {**Estimator._PAIR_AXES, "x": 0, "since": 0}

    def _reset_state(self):
        self.x = np.zeros((self.n_pairs, STATE_DIM))
        self.since = np.zeros(self.n_pairs, dtype=np.int64)

    def _drop(self, pairs):
        self.x[pairs] = 0.0

    def _state(self):
        k = np.minimum(self.since, len(self.cov_table) - 1)
        return self.x, self.cov_table[k]

    def _advance(self, z, r, valid):
        j = self.index
        self.x = self.x @ self.f.T  # every pair: cheaper than selecting the tracked ones
        if self._u is not None:
            self.x += self._u[:, None] * self.b
        self.since += 1
        only = np.zeros_like(valid)
        only[j] = valid[j]
        init, x0, _, _ = self._initial(z, r, only)
        if x0 is not None:
            self.x[init] = x0[init]
            self.since[init] = 0
            self.initialised |= init
        upd = self.initialised & valid[j] & ~init
        prior = self.cov_table[np.minimum(self.since, len(self.cov_table) - 1)]
        self._nis[:, j] = self.engine.nis(
            self.x,
            prior,
            z[j],
            np.broadcast_to(self.r_nominal, r[j].shape),
            self.h,
            self._rows(upd),
        )
        self.x += ((z[j] - self.x @ self.h.T) * upd[:, None]) @ self.gain.T
        self.since[upd] = 0
        return valid[j] & self.initialised


@njit(cache=True)
def _gather(z_in, r_in, valid_in, z, r, valid):  # pragma: no cover - compiled
    """One sensor's valid measurements ``z (N, 2)`` and covariances ``r (N, 2, 2)`` from its
    ``z_in``, ``r_in`` and ``valid_in (N,)`` (copied to ``valid``), zero and identity where
    not valid, in one pass; returns whether every value is finite, the lowest range (0
    without a valid one) and whether every variance is positive."""
    finite, low, positive = True, 0.0, True
    for k in range(valid.size):
        ok = valid_in[k]
        valid[k] = ok
        for a in range(2):
            v = z_in[k, a] if ok else 0.0
            z[k, a] = v
            finite &= np.isfinite(v)
            for b in range(2):
                w = r_in[k, a, b] if ok else (1.0 if a == b else 0.0)
                r[k, a, b] = w
                finite &= np.isfinite(w)
        low = min(low, z[k, 0])
        positive &= r[k, 0, 0] > 0 and r[k, 1, 1] > 0
    return finite, low, positive


@njit(cache=True)
def _lose(initialised, target, target_id, last, t, coast_limit, lost):  # pragma: no cover
    """The tracks lost at time ``t``: ``lost (N,)`` receives the initialised pairs whose target
    id changed (``target`` takes ``target_id``, in place) or whose last measurement, at
    ``last``, is more than ``coast_limit`` old; they are no longer ``initialised``.  Returns
    whether any was lost."""
    any_lost = False
    for k in range(lost.size):
        lost[k] = initialised[k] and (target_id[k] != target[k] or t - last[k] > coast_limit)
        target[k] = target_id[k]
        initialised[k] = initialised[k] and not lost[k]
        any_lost = any_lost or lost[k]
    return any_lost


@njit(cache=True)
def _confirmed(
    needed, seen, online_at, t, coast_limit, x, lo, hi, isolated, initialised, out
):  # pragma: no cover - compiled
    """:meth:`FederatedFilter._reported` in one pass: sensor ``s`` of an initialised pair
    becomes *needed* when it is online (it delivered a frame at ``online_at[s]``, at most
    ``coast_limit`` before ``t``), not isolated (``isolated (N, S)``) and the estimated gap
    ``x[k, 0]`` lies in ``[lo[s], hi[s]]``; ``out[k]``: the pair is initialised and every
    needed sensor has been seen."""
    n_sensors, n_pairs = needed.shape
    online = np.empty(n_sensors, dtype=np.bool_)
    for s in range(n_sensors):
        online[s] = t - online_at[s] <= coast_limit
    for k in range(n_pairs):
        gap, ok = x[k, 0], initialised[k]
        confirmed = ok
        for s in range(n_sensors):
            if online[s] and gap >= lo[s] and gap <= hi[s] and not isolated[k, s] and ok:
                needed[s, k] = True
            confirmed &= seen[s, k] or not needed[s, k]
        out[k] = confirmed


#: Stand-ins for a federated filter without fault detection: its (empty) window arrays and
#: thresholds.
_NO_FDI = (
    np.zeros((0, 0, 0)), np.zeros((0, 0)), np.zeros((0, 0), dtype=np.int64),
    np.zeros((0, 0), dtype=np.int64), np.zeros((0, 0), dtype=bool),
    np.zeros((0, 0), dtype=np.int8), np.zeros((0, 0), dtype=np.int64),
)  # fmt: skip
_NO_TESTS = (0.0, 0.0, 0.0, 0)


@njit(cache=True)
def _federated_step(
    xm, pm, xl, pl, f, q, b, u, h, z, r, valid, initialised, reported_at, beta, beta0, seen,
    needed, has_fdi, buf, total, count, pos, isolated, verdict, gate, clip, threshold,
    common_steps, age, inflate, feedback, increments, trace, fuse_now, accel_var, t,
    coast_limit, nis, used,
):  # pragma: no cover - compiled  # fmt: skip
    """:meth:`FederatedFilter._advance` of every pair, in place, pair by pair.

    Master ``xm (N, n)``, ``pm (N, n, n)`` and locals ``xl (S, N, n)``, ``pl (S, N, n, n)``;
    measurements ``z (S, N, m)``, ``r (S, N, m, m)``, ``valid (S, N)``; track state
    ``initialised (N,)``, ``reported_at``, ``beta``, ``seen``, ``needed (S, N)``; the fault
    detector's windows (``has_fdi``; arrays of :class:`~acc_fusion.fusion.fdi.WindowedChiSquare`).
    Writes the NIS against the master's prior ``nis (N, S)`` and the pairs that used a
    measurement ``used (N,)``.  The first pass runs each pair's predict, initialisation,
    fault tests, local updates and fusion with feedback; the second, once the whole step's
    rejoining sensors are known, the re-sharing they cause (of every pair, as the reference
    does), the bookkeeping and the loss of tracks whose every sensor is isolated or silent.
    """
    n_s, n_pairs = valid.shape
    n, m = STATE_DIM, MEAS_DIM
    xt, fp, x0, p0 = np.empty(n), np.empty((n, n)), np.empty(n), np.empty((n, n))
    pht, kg, y = np.empty((n, m)), np.empty((n, m)), np.empty(m)
    s_mat, si, work_m = np.empty((m, m)), np.empty((m, m)), np.empty((m, m))
    info, vec, yi, ym, work = (
        np.empty((n, n)), np.empty(n), np.empty((n, n)), np.empty((n, n)), np.empty((n, n))
    )  # fmt: skip
    xf, pf, w = np.empty(n), np.empty((n, n)), np.empty(n_s)
    reporting = np.zeros((n_pairs, n_s), dtype=np.bool_)
    consumed = np.zeros((n_pairs, n_s), dtype=np.bool_)
    accepted = np.zeros((n_pairs, n_s), dtype=np.bool_)
    rejoined = np.zeros((n_pairs, n_s), dtype=np.bool_)
    active = np.zeros((n_s, n_pairs), dtype=np.bool_)
    any_rejoined = False
    for k in range(n_pairs):
        uk = u[k % u.size]
        if initialised[k]:
            predict_one(xm[k], pm[k], f, q, 1.0, b, uk, xt, fp)
            for s in range(n_s):
                scale = _inflation_one(beta[s, k], inflate)
                predict_one(xl[s, k], pl[s, k], f, q, scale, b, uk, xt, fp)
        else:  # a new track from the first reporting sensor
            first = -1
            for s in range(n_s):
                if valid[s, k]:
                    first = s
                    break
            if first >= 0:
                _drop_one(k, beta, beta0, seen, needed, has_fdi, buf, total, count, pos,
                          isolated, verdict)  # fmt: skip
                p0[:] = 0.0
                for i in range(m):
                    x0[i] = z[first, k, i]
                    for j in range(m):
                        p0[i, j] = r[first, k, i, j]
                x0[n - 1] = 0.0
                p0[n - 1, n - 1] = accel_var
                assign_one(xm[k], pm[k], x0, p0, 1.0)
                for s in range(n_s):
                    assign_one(xl[s, k], pl[s, k], x0, p0, _inflation_one(beta[s, k], inflate))
                initialised[k] = True
                consumed[k, first] = True
        ini = initialised[k]
        for s in range(n_s):
            reporting[k, s] = ini and valid[s, k] and not consumed[k, s]
            if reporting[k, s]:
                nis[k, s] = nis_one(xm[k], pm[k], h, z[s, k], r[s, k], m, s_mat, si, work_m, y)
            else:
                nis[k, s] = np.nan
        if has_fdi:
            window_one(k, nis, reporting, gate, clip, threshold, common_steps, buf, total,
                       count, pos, isolated, verdict, age, accepted, rejoined)  # fmt: skip
        else:
            accepted[k] = reporting[k]
        for s in range(n_s):
            if accepted[k, s]:
                update_one(xl[s, k], pl[s, k], h, z[s, k], r[s, k], m, pht, kg, s_mat, si,
                           work_m, y)  # fmt: skip
            active[s, k] = ini and not (has_fdi and isolated[k, s])
            any_rejoined = any_rejoined or rejoined[k, s]
        if fuse_now and ini:
            fuse_one(xl, pl, active, k, xm[k], pm[k], increments, xf, pf, info, vec, yi, ym,
                     work)  # fmt: skip
            assign_one(xm[k], pm[k], xf, pf, 1.0)
            if feedback:
                _share_one(k, active, pl, beta, beta0, trace, w)
                for s in range(n_s):
                    if active[s, k]:
                        assign_one(xl[s, k], pl[s, k], xf, pf, _inflation_one(beta[s, k], inflate))
    for k in range(n_pairs):
        ini = initialised[k]
        if any_rejoined:
            _share_one(k, active, pl, beta, beta0, trace, w)
            for s in range(n_s):
                if rejoined[k, s] and ini:
                    assign_one(
                        xl[s, k], pl[s, k], xm[k], pm[k], _inflation_one(beta[s, k], inflate)
                    )
        any_isolated, all_out, took_any = False, True, False
        for s in range(n_s):
            took = accepted[k, s] or consumed[k, s]
            seen[s, k] = seen[s, k] or took
            took_any = took_any or took
            if reporting[k, s] or consumed[k, s]:
                reported_at[s, k] = t
            iso = has_fdi and isolated[k, s]
            any_isolated = any_isolated or iso
            all_out = all_out and (iso or t - reported_at[s, k] > coast_limit)
        used[k] = took_any
        if ini and any_isolated and all_out:  # every recently reporting sensor is isolated
            initialised[k] = False
            _drop_one(k, beta, beta0, seen, needed, has_fdi, buf, total, count, pos, isolated,
                      verdict)  # fmt: skip


@njit(cache=True, inline="always")
def _inflation_one(beta, inflate):  # pragma: no cover - compiled
    """The factor :math:`1/\\beta_i` of a local's prior and process noise (1 without
    inflation or with :math:`\\beta_i = 0`)."""
    return 1.0 / beta if inflate and beta > 0 else 1.0


@njit(cache=True, inline="always")
def _share_one(k, active, pl, beta, beta0, trace, w):  # pragma: no cover - compiled
    """Recompute pair ``k``'s :math:`\\beta` over its active locals (sum 1; unchanged
    without one): :math:`\\beta_i \\propto 1/\\mathrm{tr}(\\beta_i P_i)` (``trace``) or the
    initial factors ``beta0`` (``w (S,)``: scratch)."""
    total = 0.0
    for s in range(beta.shape[0]):
        if not active[s, k]:
            w[s] = 0.0
        elif trace:
            b = beta[s, k] if beta[s, k] > 0 else 1.0
            w[s] = 1.0 / ((pl[s, k, 0, 0] + pl[s, k, 1, 1] + pl[s, k, 2, 2]) * b)
        else:
            w[s] = beta0[s]
        total += w[s]
    if total > 0:
        for s in range(beta.shape[0]):
            beta[s, k] = w[s] / total


@njit(cache=True)
def _share_pairs(active, pl, beta, beta0, trace):  # pragma: no cover - compiled
    """:func:`_share_one` of every pair."""
    w = np.empty(beta.shape[0])
    for k in range(beta.shape[1]):
        _share_one(k, active, pl, beta, beta0, trace, w)


@njit(cache=True, inline="always")
def _drop_one(
    k, beta, beta0, seen, needed, has_fdi, buf, total, count, pos, isolated, verdict
):  # pragma: no cover - compiled
    """Forget pair ``k``'s track state: initial sharing factors, no sensor seen or needed,
    fresh fault-detection windows."""
    for s in range(beta.shape[0]):
        beta[s, k] = beta0[s]
        seen[s, k] = False
        needed[s, k] = False
    if has_fdi:
        reset_one(k, buf, total, count, pos, isolated, verdict)


@njit(cache=True)
def _drop_pairs(
    pairs, beta, beta0, seen, needed, has_fdi, buf, total, count, pos, isolated, verdict
):  # pragma: no cover - compiled
    """:func:`_drop_one` of the pairs in ``pairs (N,)``."""
    for k in range(pairs.size):
        if pairs[k]:
            _drop_one(k, beta, beta0, seen, needed, has_fdi, buf, total, count, pos, isolated,
                      verdict)  # fmt: skip


def make_estimator(
    config: FusionConfig | str,
    sensors: Sequence[str],
    n_pairs: int,
    specs: Sequence[SensorSpec] | None = None,
) -> Estimator:
    """Build the estimator named by ``config.method`` (or by a method name with defaults).

    ``specs`` (the sensors' :class:`~acc_fusion.sensors.sensor.SensorSpec`, in the order of
    ``sensors``) is needed by the constant-gain filter (``local="steady"``) and enables the
    federated filter's track confirmation (each sensor's range interval).

    >>> est = make_estimator("federated", ("radar", "infrared"), n_pairs=4)
    >>> type(est).__name__
    'FederatedFilter'
    """
    if isinstance(config, str):
        config = FusionConfig(method=config)
    sensors = tuple(sensors)
    method = check_choice("fusion.method", config.method, sensors + FUSION_METHODS)
    if config.local == "steady":
        if method not in sensors:
            raise ConfigError(
                f"fusion.local='steady' applies to single-sensor methods "
                f"({', '.join(sensors)}), not to {method!r}"
            )
        if specs is None:
            raise ConfigError("fusion.local='steady' needs the sensors' specs (specs=...)")
        return SteadyStateFilter(sensors, n_pairs, config, spec=specs[sensors.index(method)])
    if method in sensors:
        return SingleSensorFilter(sensors, n_pairs, config, sensor=method)
    if method.startswith("centralized"):
        return CentralizedFilter(sensors, n_pairs, config, stacked=method.endswith("stacked"))
    return FederatedFilter(sensors, n_pairs, config, plain=method == "plain", specs=specs)
