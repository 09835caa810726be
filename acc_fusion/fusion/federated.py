"""Carlson's federated Kalman filter (:class:`FederatedFilter`): one local filter per sensor, a
master filter fusing them, information sharing β and the reset modes (hu2005; kong2011).
"""

from __future__ import annotations

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.motion import (
    STATE_DIM,
)
from acc_fusion.core.threads import blocks
from acc_fusion.filters import kalman
from acc_fusion.filters.kalman import input_args
from acc_fusion.fusion.base import Estimator
from acc_fusion.fusion.fdi import WindowedChiSquare
from acc_fusion.fusion.kernels import (
    _NO_FDI,
    _NO_TESTS,
    _confirmed,
    _drop_pairs,
    _federated_step,
    _federated_step_parallel,
    _share_pairs,
    jump_start,
    jump_vectors,
)


class FederatedFilter(Estimator):
    """Carlson's federated Kalman filter (the equations: :mod:`acc_fusion.fusion.estimators`);
    ``plain`` = no sharing.

    Usually made by :func:`acc_fusion.fusion.estimators.make_estimator` with
    ``FusionConfig(method="federated")`` (or ``"plain"``); :meth:`step` advances every pair by
    one step and returns the fused :class:`~acc_fusion.fusion.base.Estimate`.

    Args:
        sensors: the sensors' names, in the order of the measurements given to :meth:`step`.
        n_pairs: N, the number of follower→leader pairs filtered at once.
        config: the fusion settings (:class:`~acc_fusion.fusion.config.FusionConfig`): the
            sharing factors ``beta``, the ``reset`` mode, the fusion period, the local
            filters' model and the fault detector ``fdi`` (``None``: none).
        plain: kong2011's plain fusion formula instead: independent local filters, no
            information sharing, no reset, no fault detection.
        specs: the sensors' specifications (:class:`~acc_fusion.sensors.spec.SensorSpec`),
            for their range limits (a track is confirmed by every sensor that should see it)
            and the range noise evaluated at the prediction; ``None``: neither.

    Attributes:
        locals: the local filters, one bank per sensor, arrays ``(S, N, 3)`` and
            ``(S, N, 3, 3)``.
        master: the master filter, the fused estimate.
        beta: the information-sharing factors ``(S, N)``, summing to 1 over the sensors.
        fdi: the fault detector (:class:`~acc_fusion.fusion.fdi.WindowedChiSquare`), or
            ``None``.

    Raises:
        ConfigError: explicit ``beta`` values whose number is not the number of sensors.
    """

    _PAIR_AXES = {
        **Estimator._PAIR_AXES, "beta": 1, "_seen": 1, "_needed": 1, "_reported_at": 1,
        "_explained_at": 1,
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
        super().__init__(sensors, n_pairs, config, specs)

    def _reset_state(self):
        n, s = self.n_pairs, self.n_sensors
        self.locals = self.engine.bank(s, n, STATE_DIM)
        self.master = self.engine.bank(1, n, STATE_DIM)
        self.beta = np.repeat(self._beta0[:, None], n, axis=1)
        self._infl: np.ndarray | None = None  # 1 / beta, recomputed after beta changes
        fdi = None if self.plain else self.config.fdi
        fc = self.config.filter
        self.fdi = (
            None
            if fdi is None
            else WindowedChiSquare(n, s, fdi, fc.dt, accel_std=fc.init_accel_std)
        )
        self._confirm = fdi is not None and fdi.confirm_tracks and self._coverage is not None
        self._seen = np.zeros((s, n), dtype=bool)
        self._needed = np.zeros((s, n), dtype=bool)
        self._online_at = np.full(s, -np.inf)
        self._reported_at = np.full((s, n), -np.inf)
        self._explained_at = np.full((s, n), -np.inf)  # the model last explained each sensor
        self._k = 0

    def _resized(self, m):
        super()._resized(m)
        self._infl = None
        for part in (self.locals, self.master, self.fdi):
            if part is not None:
                part.resize(m)

    def _drop(self, pairs, new_vehicle):
        _drop_pairs(np.asarray(pairs, dtype=bool), new_vehicle, *self._track_arrays())
        self._infl = None

    def _track_arrays(self) -> tuple:
        """The arrays :func:`_drop_one` resets: sharing factors (and their initial values),
        confirmation flags and the fault detector's windows (empty without one)."""
        fdi = self.fdi.arrays()[:9] if self.fdi is not None else _NO_FDI[:9]
        return (self.beta, self._beta0, self._seen, self._needed, self.fdi is not None, *fdi)

    def forget(self, pairs):
        """Drop the tracks of ``pairs`` (a boolean mask ``(N,)``), e.g. when a slot gets a new
        vehicle; their fault detector's tests restart too, its sensors' among them."""
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
        target beyond the camera's range needs the radar alone.  A needed sensor that has gone
        offline (a dropout) or been isolated (stuck, say) since no longer blocks the track: a
        lead that cuts in during a dropout of the radar was never reported before (7 missed
        crash-relevant situations in 100 runs of the random suite, ``scripts/fault_tolerance.py``).
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

        # A new track starts from the first reporting sensor that is not frozen.
        starts = valid if self.fdi is None else valid & ~self.fdi.frozen.T
        init, x0, p0, consumed = self._initial(z, r, starts)
        if x0 is not None:
            self._drop(init, False)
            self.master.assign(0, init, x0, p0)
            infl = self._inflation()
            for s in s_all:
                self.locals.assign(s, init, x0, p0, infl[s])
            ini = self.initialised = ini | init
            self._explained_at[:, init] = self._t

        if self.fdi is not None:  # a noise burst's adapted R, an estimated bias removed
            r = r * self.fdi.noise_scale.T[:, :, None, None]
            z = self.fdi.correct(z)
        reporting = ini[None] & valid & ~consumed
        xm, pm = np.array(self.master.x[0]), np.array(self.master.p[0])
        nis = np.stack(
            [self.engine.nis(xm, pm, z[s], r[s], self.h, self._rows(reporting[s])) for s in s_all]
        )
        self._nis[:] = nis.T
        if self.fdi is not None:
            fdi, var = self.fdi, self.fdi.accel_var
            beyond = reporting & (nis > fdi.gate)
            wide = np.full(nis.shape, np.inf)  # only reports beyond the gate are tested wide
            if beyond.any():  # (a jump needs a report beyond the gate)
                g = jump_vectors(self._t, self._explained_at, fdi.dt, fdi.config.common_steps)
                for s in s_all:
                    pw = pm + (var * g[s])[:, :, None] * g[s][:, None, :]
                    wide[s] = self.engine.nis(xm, pw, z[s], r[s], self.h, self._rows(beyond[s]))
                wide[~beyond] = np.inf
            accepted, rejoined, manoeuvre, jumped = fdi.step(nis.T, reporting.T, z, r, wide.T)
            accepted, rejoined = accepted.T, rejoined.T
            if manoeuvre.any():
                self._take_manoeuvre(manoeuvre, var)
            if jumped.any():  # since the model last explained a report it now fails to
                start = jump_start(accepted, nis, fdi.gate, self._explained_at)
                jumped &= start < np.inf  # none used (isolated meanwhile): no jump to take
                g = jump_vectors(self._t, start[None], fdi.dt, fdi.config.common_steps)[0]
                self._take_jump(jumped, var, g[jumped])
            self._explained_at[accepted & ((nis <= fdi.gate) | jumped[None])] = self._t
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
            self._drop(lost, False)
        return (accepted | consumed).any(axis=0)

    def _take_manoeuvre(self, pairs: np.ndarray, var: float) -> None:
        r"""A jump of the acceleration at one of the last ``common_steps`` steps c, which one
        unknown, in ``pairs (N,)``: the mean of :math:`\sigma_a^2 g g^\top` over
        :math:`\tau = T, \dots, cT` (``var``: :math:`\sigma_a^2`), added as
        :func:`_federated_step` does (:mod:`acc_fusion.fusion.fdi`, "manoeuvre first")."""
        fdi = self.fdi
        span = max(fdi.config.common_steps, 1)
        for j in range(1, span + 1):
            g = jump_vectors(j * fdi.dt, np.zeros((1, 1)), fdi.dt, span)[0, 0]
            self._take_jump(pairs, var / span, np.broadcast_to(g, (int(pairs.sum()), 3)))

    def _take_jump(self, pairs: np.ndarray, var: float, g: np.ndarray) -> None:
        r"""Add :math:`\sigma_a^2 g g^\top` (``var``, ``g (P, 3)``: an acceleration jump of
        each of the P ``pairs (N,)``, :mod:`acc_fusion.fusion.fdi`) to the priors of the
        master and of every local filter of those pairs (the locals' times their inflation),
        in :func:`_federated_step`'s order of operations."""
        pm = np.array(self.master.p[0])
        pm[pairs] += (var * g)[:, :, None] * g[:, None, :]
        self.master.assign(0, pairs, np.array(self.master.x[0]), pm)
        infl = self._inflation()
        for s in range(self.n_sensors):
            pl = np.array(self.locals.p[s])
            pl[pairs] += ((var * infl[s][pairs])[:, None] * g)[:, :, None] * g[:, None, :]
            self.locals.assign(s, pairs, np.array(self.locals.x[s]), pl)

    def _advance_batched(self, z, r, valid):
        """:meth:`_advance` as one call of :func:`_federated_step` (the same arithmetic, in
        the same order, pair by pair: equal to it bit for bit)."""
        used = np.empty(self.n_pairs, dtype=bool)
        fdi = self.fdi
        fc = self.config.filter
        args = (
            self.master.x[0], self.master.p[0], self.locals.x, self.locals.p, self.f, self.q,
            *input_args(self.b, self._u), self.h, z, r, valid, self.initialised,
            self._reported_at, self._explained_at, *self._track_arrays(),
            *(fdi.tests() if fdi is not None else _NO_TESTS),
            fdi.arrays()[9] if fdi is not None else _NO_FDI[9],
            self._inflate, self._feedback, self._increments, self.config.beta == "trace",
            self._k % self.config.fusion_period == 0, fc.init_accel_std**2, self._t,
            self._coast_limit, self._nis, used,
        )  # fmt: skip
        chunks = blocks(self.n_pairs, kalman.PARALLEL_PAIRS)
        if chunks:
            _federated_step_parallel(*args, chunks)
        else:
            _federated_step(*args)
        self._infl = None
        self._online_at[self._online] = self._t
        self._k += 1
        return used
