"""The baselines the federated filter is judged against: one sensor alone
(:class:`SingleSensorFilter`), the centralized Kalman filter with sequential or stacked updates
(:class:`CentralizedFilter`, the qa thread on serial / parallel multi-sensor filters), and the
constant-gain steady-state filter (:class:`SteadyStateFilter`, CN103196450A).
"""

from __future__ import annotations

import numpy as np

from acc_fusion.core.motion import (
    MEASUREMENT_MATRIX,
    STATE_DIM,
    ca_process_noise,
    ca_transition,
)
from acc_fusion.filters.steady_state import periodic_steady_state
from acc_fusion.fusion.base import Estimator
from acc_fusion.sensors.spec import SensorSpec


class _OneFilter(Estimator):
    """An estimator made of one Kalman filter per pair."""

    def _reset_state(self):
        self.bank = self.engine.bank(1, self.n_pairs, STATE_DIM)

    def _resized(self, m):
        super()._resized(m)
        self.bank.resize(m)

    def _drop(self, pairs, new_vehicle):
        pass  # the filter is overwritten when the pair initialises again

    def _state(self):
        return self.bank.x[0], self.bank.p[0]


class SingleSensorFilter(_OneFilter):
    """One sensor alone: its local Kalman filter (kong2011 eqs. 1-4)."""

    def __init__(self, sensors, n_pairs, config, sensor: str, specs=None) -> None:
        self.index = list(sensors).index(sensor)
        super().__init__(sensors, n_pairs, config, specs)

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

    def __init__(self, sensors, n_pairs, config, stacked: bool = False, specs=None) -> None:
        self.stacked = stacked
        super().__init__(sensors, n_pairs, config, specs)

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

    def _drop(self, pairs, new_vehicle):
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
