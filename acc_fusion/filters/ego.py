r"""Ego-motion filter: ego speed from wheel speed + a longitudinal accelerometer with bias.

Every safety-distance model needs the ego vehicle's own speed.  Following yang2009 (Yang,
Zeng & Huang, "Discussion of Kalman filter in multi-sensor fusion", *Modern Electronics
Technique* 32(14), 2009, §3), a speed sensor (there an optical encoder, here the wheel speed)
is fused with an accelerometer whose constant offset :math:`b` is a state.  The continuous
model is yang2009 eq. (12),

.. math::

    \dot v = a_i - b,\qquad \dot b = 0,\qquad v_i = v + w_v,

i.e. the accelerometer reads :math:`a_i = \dot v + b + w_a`, and Euler discretisation at the
sample rate :math:`f_s` (eq. 13) gives eqs. (14)-(15), with state :math:`x = [v,\ b]^\top`
(m/s, m/s²):

.. math::

    x(k) = \underbrace{\begin{bmatrix} 1 & -1/f_s \\ 0 & 1 \end{bmatrix}}_{F} x(k-1)
         + \underbrace{\begin{bmatrix} 1/f_s \\ 0 \end{bmatrix}}_{B} a_i(k-1) + w(k-1),
    \qquad v_i(k) = [1\ 0]\, x(k) + w_v(k),

.. math::

    Q = \begin{bmatrix} \operatorname{var}(w_a)/f_s^2 & 0 \\ 0 & q_b/f_s \end{bmatrix},
    \qquad R = \operatorname{var}(w_v).

The paper keeps the bias exactly constant (:math:`q_b = 0`).  In a car the "bias" also holds
the gravity component of the road grade, which changes along the road, so the default
configuration lets it drift as a random walk of intensity :math:`q_b` (m²/s⁵); with
:math:`q_b = 0` the bias gain decays to zero and a grade change would never be learnt.
The filter equations are those of filterpy's ``KalmanFilter`` (yang2009 eqs. 10-11), written
in closed form for the 2-state, scalar-measurement case and vectorised over N vehicles.

Sign of the bias (what the original says).  yang2009 defines :math:`b` as the
accelerometer's constant offset ("加速度计常值偏差") and :math:`a_i` as the accelerometer's
measured value ("加速度计测量值"); eq. (12) subtracts it, :math:`\dot v = a_i - b`, and the
printed :math:`A = [[1, -0.01], [0, 1]]` agrees.  The simulation of §4 feeds
:math:`v_i = \sin 5t + w_v` and :math:`a_i = 5\cos 5t - 10 + w_a`; since
:math:`\dot v = 5 \cos 5t`, the offset of :math:`a_i` is :math:`b = a_i - \dot v = -10`,
and that is where this model's estimate converges (within about 0.5 s, as the paper says).
The text of the paper never prints the converged value: it says only that the offset
estimate of :math:`a_i` is accurate and converges within 0.5 s (the figure is not in the
text copy).  A value of +10 would need either :math:`F_{01} = +1/f_s` (the bias defined as
a correction added to the reading) or :math:`a_i = 5\cos 5t + 10`; both contradict the printed
equations and data, so :func:`simulate_yang2009` reproduces the paper as printed and its bias
estimate approaches **-10** (magnitude 10).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.slots import PairState
from acc_fusion.core.validation import check_mask, check_range

#: Measurement matrix of the wheel-speed sensor, :math:`H = [1\ 0]`.
SPEED_MEASUREMENT = np.array([[1.0, 0.0]])
#: Constant offset of the accelerometer in yang2009's simulation (§4), m/s².
YANG2009_ACCEL_OFFSET = -10.0


def _check_count(name: str, value: int) -> int:
    """Return ``value`` if it is an integer >= 1, else raise :class:`ConfigError`."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ConfigError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


@dataclass(frozen=True)
class EgoFilterConfig:
    """Noise model and initial uncertainty of the ego-motion filter (defaults: a real car).

    The defaults are typical values, not measurements of a particular vehicle; use
    :meth:`yang2009` for the paper's exact parameters.

    Attributes:
        fs: sample rate of wheel speed and accelerometer [Hz]; default 100 Hz, a typical
            rate of ESC wheel-speed and inertial signals on the chassis CAN bus.
        accel_noise_var: variance of the accelerometer's white noise :math:`w_a` [(m/s²)²];
            default 0.1²; the MEMS noise floor alone is about 2.3 mg ≈ 0.023 m/s² RMS at
            30 Hz bandwidth (yang2009 eqs. 3-4, MMA7260); body vibration and pitch on a road
            raise it to the order of 0.1 m/s² (typical).
        speed_noise_var: variance of the wheel-speed noise :math:`w_v` [(m/s)²]; default
            0.1², typical for wheel speed from ABS tone wheels (tooth quantisation, tyre and
            road irregularities).
        bias_walk_psd: intensity :math:`q_b` of the bias random walk [(m/s²)²/s]; default
            0.01², so the bias can follow road-grade changes of about 0.1 m/s² (1 % grade)
            over 100 s (typical assumption); 0 in yang2009.
        speed_var0: initial variance of the speed estimate [(m/s)²]; default 1.0.
        bias_var0: initial variance of the bias estimate [(m/s²)²]; default 0.5², which
            covers a MEMS zero-g offset plus the gravity component of a 5 % grade
            (9.81 m/s² · 0.05 ≈ 0.49 m/s²).
        interval_accel: the reading of sample :math:`k` is the mean acceleration over the
            interval from sample :math:`k-1` to :math:`k` (a simulator's speed difference, as
            :attr:`~acc_fusion.truth.frame.TruthFrame.ego_accel`), so the prediction to
            :math:`k` uses it, :math:`x(k) = F x(k-1) + B a_i(k)`: exact for an acceleration
            constant over each interval.  False (default, yang2009 eq. 14): forward Euler with
            the reading of sample :math:`k-1`, one sample late for such a reading (at a
            0.5 s step, a 9.6 m/s² change of the ego's acceleration is then a 4.8 m/s
            prediction error).
    """

    fs: float = 100.0
    accel_noise_var: float = 0.1**2
    speed_noise_var: float = 0.1**2
    bias_walk_psd: float = 0.01**2
    speed_var0: float = 1.0
    bias_var0: float = 0.5**2
    interval_accel: bool = False

    def __post_init__(self) -> None:
        check_range("fs", self.fs, 0.0, lo_open=True)
        check_range("accel_noise_var", self.accel_noise_var, 0.0)
        check_range("speed_noise_var", self.speed_noise_var, 0.0, lo_open=True)
        check_range("bias_walk_psd", self.bias_walk_psd, 0.0)
        check_range("speed_var0", self.speed_var0, 0.0)
        check_range("bias_var0", self.bias_var0, 0.0)

    @classmethod
    def yang2009(cls) -> EgoFilterConfig:
        r"""The parameters of yang2009 §4: :math:`f_s = 100` Hz, :math:`Q = \mathrm{diag}(10^{-4},
        0)`, :math:`R = 0.04`, :math:`P_0 = I` (with :math:`x_0 = 0` from :meth:`reset`)."""
        return cls(
            fs=100.0,
            accel_noise_var=1.0,
            speed_noise_var=0.04,
            bias_walk_psd=0.0,
            speed_var0=1.0,
            bias_var0=1.0,
        )

    @property
    def transition(self) -> np.ndarray:
        """Transition matrix :math:`F` (yang2009 eq. 14)."""
        return np.array([[1.0, -1.0 / self.fs], [0.0, 1.0]])

    @property
    def input_matrix(self) -> np.ndarray:
        """Input matrix :math:`B` of shape (2, 1), applied to the accelerometer reading."""
        return np.array([[1.0 / self.fs], [0.0]])

    @property
    def process_noise(self) -> np.ndarray:
        """Process noise :math:`Q` (yang2009 eq. 15, plus the bias random walk)."""
        return np.diag([self.accel_noise_var / self.fs**2, self.bias_walk_psd / self.fs])

    @property
    def initial_covariance(self) -> np.ndarray:
        """Initial covariance :math:`P_0 = \\mathrm{diag}(\\sigma_{v,0}^2, \\sigma_{b,0}^2)`."""
        return np.diag([self.speed_var0, self.bias_var0])


class EgoMotionFilter(PairState):
    """Kalman filter of ego speed and accelerometer bias for N vehicles at once.

    Each :meth:`step` receives the accelerometer reading and the wheel speed of sample
    :math:`k`.  It predicts with the accelerometer reading of sample :math:`k-1` (yang2009
    eq. 14), or of sample :math:`k` with :attr:`EgoFilterConfig.interval_accel` (the first
    step after a reset has no previous reading and only updates, so :math:`x_0, P_0` is the
    prior at the first sample), then updates with the wheel speed where it is valid.  All
    vehicles are processed at once, in one compiled loop.

    >>> f = EgoMotionFilter(2, EgoFilterConfig.yang2009())
    >>> speed, bias = f.step([0.0, 0.0], [0.1, 0.2])
    >>> speed.shape, f.covariance.shape
    ((2,), (2, 2, 2))
    """

    _PAIR_AXES = dict.fromkeys(("_v", "_b", "_p00", "_p01", "_p11", "_prev_accel", "_has_prev"), 0)

    def __init__(self, n_vehicles: int, config: EgoFilterConfig | None = None) -> None:
        self.n_vehicles = _check_count("n_vehicles", n_vehicles)
        self.config = EgoFilterConfig() if config is None else config
        q = self.config.process_noise
        self._dt = 1.0 / self.config.fs
        self._q_speed = q[0, 0]
        self._q_bias = q[1, 1]
        self._r = self.config.speed_noise_var
        n = self.n_vehicles
        self._v = np.zeros(n)
        self._b = np.zeros(n)
        self._p00 = np.zeros(n)
        self._p01 = np.zeros(n)
        self._p11 = np.zeros(n)
        self._prev_accel = np.zeros(n)
        self._has_prev = np.zeros(n, dtype=bool)
        self.reset()

    def reset(self, mask: np.ndarray | None = None, speed: np.ndarray | None = None) -> None:
        """Re-initialise the vehicles in ``mask`` (all if ``None``).

        Speed starts at ``speed`` [m/s] (shape (N,), used where ``mask``; 0 if ``None``, as
        in yang2009), the bias at 0, the covariance at :attr:`EgoFilterConfig.initial_covariance`,
        and the next step of those vehicles only updates.
        """
        n = self.n_vehicles
        sel = self._mask("mask", mask)
        v0 = np.zeros(n) if speed is None else check_array("speed", speed, (n,), where=sel)
        _reset(
            sel, v0, self.config.speed_var0, self.config.bias_var0, self._v, self._b, self._p00,
            self._p01, self._p11, self._has_prev,
        )  # fmt: skip

    def _resized(self, m: int) -> None:
        self.n_vehicles = m

    def step(
        self,
        accel_meas: np.ndarray,
        speed_meas: np.ndarray,
        speed_valid: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        r"""Advance one sample; return ``(speed_est, bias_est)`` [m/s, m/s²], each (N,).

        ``accel_meas`` is :math:`a_i(k)` [m/s²] and must be finite; ``speed_meas`` is
        :math:`v_i(k)` [m/s] and may hold NaN where ``speed_valid`` is false (a wheel-speed
        dropout: the filter then coasts on the accelerometer).
        """
        n = self.n_vehicles
        accel = np.asarray(accel_meas, dtype=float)
        speed = np.asarray(speed_meas, dtype=float)
        valid = np.ones(n, dtype=bool) if speed_valid is None else np.asarray(speed_valid)
        if not (
            accel.shape == speed.shape == valid.shape == (n,)
            and valid.dtype == bool
            and _usable(accel, speed, valid)
        ):  # the checks raise the error of the first bad input
            check_array("accel_meas", accel, (n,))
            valid = self._mask("speed_valid", speed_valid)
            check_array("speed_meas", speed, (n,), where=valid)
        _step(
            accel, speed, valid, self._dt, self._q_speed, self._q_bias, self._r, self._v,
            self._b, self._p00, self._p01, self._p11, self._prev_accel, self._has_prev,
            self.config.interval_accel,
        )  # fmt: skip
        return self._v.copy(), self._b.copy()

    @property
    def state(self) -> np.ndarray:
        """State estimates ``(N, 2)``: speed [m/s], accelerometer bias [m/s²]."""
        return np.stack([self._v, self._b], axis=1)

    @property
    def covariance(self) -> np.ndarray:
        """Error covariances ``(N, 2, 2)`` of :attr:`state`."""
        return np.stack(
            [np.stack([self._p00, self._p01], axis=1), np.stack([self._p01, self._p11], axis=1)],
            axis=1,
        )

    def _mask(self, name: str, value: np.ndarray | None) -> np.ndarray:
        """Boolean (N,) array from ``value``; all true if ``None``."""
        if value is None:
            return np.ones(self.n_vehicles, dtype=bool)
        return check_mask(name, value, self.n_vehicles)


@njit(cache=True)
def _usable(accel, speed, valid):  # pragma: no cover - compiled
    """True if ``accel`` is finite, and ``speed`` finite where ``valid`` (arrays ``(N,)``)."""
    for i in range(valid.size):
        if not np.isfinite(accel[i]) or (valid[i] and not np.isfinite(speed[i])):
            return False
    return True


@njit(cache=True)
def _reset(sel, v0, speed_var0, bias_var0, v, b, p00, p01, p11, has_prev):  # pragma: no cover
    """:meth:`EgoMotionFilter.reset` of the vehicles in ``sel (N,)``, in place: speed ``v0``,
    bias 0, covariance ``diag(speed_var0, bias_var0)``, no previous sample."""
    for i in range(sel.size):
        if sel[i]:
            v[i], b[i] = v0[i], 0.0
            p00[i], p01[i], p11[i] = speed_var0, 0.0, bias_var0
            has_prev[i] = False


@njit(cache=True, error_model="numpy")
def _step(
    accel, speed, valid, dt, q_speed, q_bias, r, v, b, p00, p01, p11, prev_accel, has_prev,
    interval,
):  # pragma: no cover - compiled  # fmt: skip
    r"""One sample of :meth:`EgoMotionFilter.step` for every vehicle, in place.

    Where ``has_prev``, predict: :math:`x^- = F x + B a_i(k-1)` (``interval``:
    :math:`a_i(k)`, :attr:`EgoFilterConfig.interval_accel`), :math:`P^- = F P F^\top + Q`.
    Where ``valid``, update with the wheel speed :math:`v_i(k)` = ``speed``:
    :math:`K = P^- H^\top / (H P^- H^\top + R)`, :math:`x = x^- + K (v_i - v^-)`,
    :math:`P = (I - K H) P^-`.  Then ``accel`` becomes :math:`a_i(k-1)` of the next sample.
    (``error_model="numpy"``: IEEE division as in numpy, which lets the loop vectorise.)
    """
    for i in range(v.size):
        vi, bi, p00i, p01i, p11i = v[i], b[i], p00[i], p01[i], p11[i]
        if has_prev[i]:
            vi = vi + dt * ((accel[i] if interval else prev_accel[i]) - bi)
            p00i = p00i - 2.0 * dt * p01i + dt * dt * p11i + q_speed
            p01i = p01i - dt * p11i
            p11i = p11i + q_bias
        if valid[i]:
            s = p00i + r
            k0 = p00i / s
            k1 = p01i / s
            y = speed[i] - vi
            vi = vi + k0 * y
            bi = bi + k1 * y
            p11i = p11i - k1 * p01i
            p00i = p00i - k0 * p00i
            p01i = p01i - k0 * p01i
        v[i], b[i], p00[i], p01[i], p11[i] = vi, bi, p00i, p01i, p11i
        prev_accel[i] = accel[i]
        has_prev[i] = True


@dataclass(frozen=True)
class Yang2009Run:
    """One reproduction of yang2009 §4; arrays over time have shape (T,) or (T, n_runs).

    Attributes:
        t: sample times [s].
        true_speed: :math:`\\sin 5t` [m/s].
        speed_meas: wheel-speed (encoder) readings :math:`v_i` [m/s].
        accel_meas: accelerometer readings :math:`a_i` [m/s²].
        speed_est: filtered speed :math:`v_o` [m/s].
        bias_est: bias estimate :math:`b` [m/s²] (converges to ``YANG2009_ACCEL_OFFSET``).
    """

    t: np.ndarray
    true_speed: np.ndarray
    speed_meas: np.ndarray
    accel_meas: np.ndarray
    speed_est: np.ndarray
    bias_est: np.ndarray


def simulate_yang2009(duration: float = 4.0, n_runs: int = 1, seed: int = 0) -> Yang2009Run:
    r"""Reproduce the simulation of yang2009 §4 (``n_runs`` independent noise draws).

    :math:`v_i = \sin 5t + w_v`, :math:`\operatorname{var} w_v = 0.04`;
    :math:`a_i = 5\cos 5t - 10 + w_a`, :math:`\operatorname{var} w_a = 1`; :math:`f_s = 100`
    Hz; filter parameters from :meth:`EgoFilterConfig.yang2009`, :math:`x_0 = 0`.
    """
    duration = check_range("duration", duration, 0.0, lo_open=True)
    n_runs = _check_count("n_runs", n_runs)
    config = EgoFilterConfig.yang2009()
    rng = np.random.default_rng(seed)
    t = np.arange(round(duration * config.fs) + 1) / config.fs
    true_speed = np.sin(5.0 * t)
    shape = (t.size, n_runs)
    speed_meas = true_speed[:, None] + rng.normal(0.0, np.sqrt(0.04), shape)
    accel_meas = (5.0 * np.cos(5.0 * t) + YANG2009_ACCEL_OFFSET)[:, None] + rng.normal(
        0.0, 1.0, shape
    )
    filt = EgoMotionFilter(n_runs, config)
    speed_est = np.empty(shape)
    bias_est = np.empty(shape)
    for k in range(t.size):
        speed_est[k], bias_est[k] = filt.step(accel_meas[k], speed_meas[k])
    return Yang2009Run(t, true_speed, speed_meas, accel_meas, speed_est, bias_est)
