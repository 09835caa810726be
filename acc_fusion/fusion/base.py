"""What every estimator shares (:class:`Estimator`): per-pair tracks over N pairs, track
initialisation, coasting and loss, confirmation, and the :class:`Estimate` it returns.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import ConfigError, InputError
from acc_fusion.core.motion import (
    MEASUREMENT_MATRIX,
    STATE_DIM,
    ca_process_noise,
    ca_transition,
    ego_input,
)
from acc_fusion.core.slots import PairState
from acc_fusion.filters.engines import Engine
from acc_fusion.fusion.config import FusionConfig
from acc_fusion.fusion.kernels import (
    _first_reports,
    _gather,
    _lose,
    _noise_at_prediction,
)
from acc_fusion.sensors.sensor import Measurement
from acc_fusion.sensors.spec import SensorSpec


@dataclass(frozen=True)
class Estimate:
    """What an estimator knows about every pair after one step.

    Attributes:
        t: time [s].
        x: state estimates ``(N, 3)``: gap [m], range-rate [m/s], the lead's acceleration
            [m/s²] (the relative one without the ego's input; :mod:`acc_fusion.core.motion`).
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

    def __init__(
        self,
        sensors: Sequence[str],
        n_pairs: int,
        config: FusionConfig,
        specs: Sequence[SensorSpec] | None = None,
    ) -> None:
        if n_pairs < 1:
            raise ConfigError(f"n_pairs must be >= 1, got {n_pairs}")
        self.sensors = tuple(sensors)
        # Each sensor's range noise (sigma_0, q), where it is re-evaluated at the prediction.
        self._noise = (
            np.array([[sp.range_std, sp.range_std_quadratic] for sp in specs])
            if specs is not None and config.noise_at == "prediction"
            else None
        )
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
            self._drop(pairs, True)

    @abstractmethod
    def _reset_state(self) -> None: ...

    @abstractmethod
    def _advance(self, z, r, valid) -> np.ndarray:
        """One predict/update cycle; returns the pairs that used a measurement."""

    @abstractmethod
    def _drop(self, pairs: np.ndarray, new_vehicle: bool) -> None:
        """Forget the tracks of ``pairs`` (their filters are re-initialised later); a
        ``new_vehicle`` (:meth:`forget`) is new to the sensors too."""

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
        copy: bool = True,
    ) -> Estimate:
        """Advance every pair by one step with this step's measurements (one per sensor).

        The :class:`Estimate`'s ``x``, ``p`` and ``nis`` are copies, or with ``copy`` false
        views of the estimator's arrays, which its next step changes (for a caller that reads
        them before: the 2-D pipeline).

        ``ego_accel (N,)`` is the ego's measured acceleration [m/s²] over the step this call
        predicts, from the previous measurements to these
        (:attr:`~acc_fusion.truth.frame.TruthFrame.ego_accel`): the known input of the motion
        model (:func:`acc_fusion.core.motion.ego_input`).
        """
        z, r, valid, target_id = self._check(measurements, target_id)
        if ego_accel is not None:
            ego_accel = check_array("ego_accel", ego_accel, (self.n_pairs,))
        self._u = ego_accel
        t = float(measurements[0].t)
        lost = np.empty(self.n_pairs, dtype=bool)
        limit = self._coast_limit
        if _lose(self.initialised, self._target, target_id, self._last, t, limit, lost):
            self._drop(lost, False)
        if self._noise is not None:
            x, _ = self._state()
            u = np.empty(0) if ego_accel is None else ego_accel
            _noise_at_prediction(
                np.asarray(x), self.f[0], self.b[0], u, self.initialised, valid, self._noise, r
            )
        self._nis[:] = np.nan
        self._t = t
        self._online = np.array([bool(getattr(m, "online", True)) for m in measurements])
        used = self._advance(z, r, valid)
        self._last[used] = t
        x, p = self._state()
        x, p, nis = (np.array(a) for a in (x, p, self._nis)) if copy else (x, p, self._nis)
        return Estimate(t=t, x=x, p=p, valid=self._reported(), nis=nis, isolated=self._isolated())

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
        (meaningful in the rows of ``init`` only) are ``None`` when no pair starts a track at
        this step.
        """
        n = self.n_pairs
        init, consumed = np.empty(n, dtype=bool), np.zeros_like(valid)
        x0, p0 = np.empty((n, STATE_DIM)), np.empty((n, STATE_DIM, STATE_DIM))
        var = self.config.filter.init_accel_std**2
        if not _first_reports(self.initialised, z, r, valid, var, init, x0, p0, consumed):
            return init, None, None, consumed
        return init, x0, p0, consumed

    @staticmethod
    def _rows(mask: np.ndarray, m: int = 2) -> np.ndarray:
        return np.repeat(mask[:, None], m, axis=1)
