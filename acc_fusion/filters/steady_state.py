r"""Steady-state (constant-gain) Kalman filters: the algebraic Riccati equation.

For a time-invariant model the Kalman filter's covariance recursion converges, and so does its
gain; a filter that uses the limit gain from the first step is a fixed linear system, the
cheapest filter an embedded FCW unit can run.  Patent CN103196450A (Wuhan University, 2013)
builds such a filter from op-amps: it solves the continuous-time Riccati equation to its steady
state so that "the filter parameters become constants" and every operation is an analog adder,
integrator or PI block.  This module gives the discrete and continuous steady states;
``scripts/reproduce_cn103196450a.py`` reproduces the patent's gyro + inclinometer example.

Discrete filter (Simon, *Optimal State Estimation*, Wiley 2006, §7.3; Anderson & Moore,
*Optimal Filtering*, 1979, §4.4).  For :math:`x_{k+1} = F x_k + w_k`,
:math:`z_k = H x_k + v_k`, :math:`w \sim (0, Q)`, :math:`v \sim (0, R)`, the a-priori
covariance :math:`P^-` of the steady state solves the discrete algebraic Riccati equation (DARE)

.. math::

    P^- = F P^- F^\top - F P^- H^\top (H P^- H^\top + R)^{-1} H P^- F^\top + Q,

    K = P^- H^\top (H P^- H^\top + R)^{-1},\qquad P^+ = (I - K H) P^-.

It has a unique stabilising solution, the limit of the Riccati recursion from any
:math:`P_0 \ge 0`, when :math:`(F, H)` is detectable and :math:`(F, Q^{1/2})` is
stabilisable, i.e. every mode of :math:`F` with :math:`|\lambda| \ge 1` is seen by
:math:`H` and driven by :math:`Q`.  A constant state with no process noise (the bias of
yang2009 with :math:`Q_{bb} = 0`) violates the second condition: its steady-state gain is zero
and a constant-gain filter would never correct it, so that case is rejected.

Continuous filter (CN103196450A eq. 4; Simon 2006, §8.3).  For
:math:`\dot x = A x + B u + w`, :math:`z = C x + v` with intensities :math:`Q_c, R_c`,

.. math::

    \dot P = A P + P A^\top + Q_c - P C^\top R_c^{-1} C P = 0,\qquad K_c = P C^\top R_c^{-1},

and the filter is the fixed linear system
:math:`\dot{\hat x} = A \hat x + B u + K_c (z - C \hat x)`.  For a small sample interval
:math:`T`, the discrete model :math:`F = e^{AT}`, :math:`Q \approx Q_c T`, :math:`R = R_c / T`
has :math:`K \approx K_c T`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

from acc_fusion.core.arrays import check_array
from acc_fusion.core.errors import ConfigError, InputError

# Relative tolerance for symmetry / definiteness checks and for "on the stability boundary".
_TOL = 1e-9


@dataclass(frozen=True)
class SteadyStateGain:
    """Steady state of a discrete Kalman filter.

    Attributes:
        K: constant Kalman gain, shape (n, m).
        P_prior: a-priori (predicted) covariance :math:`P^-`, the DARE solution, (n, n).
        P_post: a-posteriori (updated) covariance :math:`P^+ = (I - KH) P^-`, (n, n).
    """

    K: np.ndarray
    P_prior: np.ndarray
    P_post: np.ndarray


@dataclass(frozen=True)
class PeriodicSteadyState:
    """Steady state of a filter that predicts every base step and updates every m-th step.

    Attributes:
        period_steps: m, the number of base steps between two reports of the sensor.
        K: constant gain used at report steps, shape (n, m_z).
        P_prior: covariance just before a report (after m predictions), (n, n).
        P_post: covariance just after a report, (n, n).
        P_between: covariances after j = 1 .. m-1 pure predictions, shape (m-1, n, n)
            (empty for m = 1).
    """

    period_steps: int
    K: np.ndarray
    P_prior: np.ndarray
    P_post: np.ndarray
    P_between: np.ndarray

    def covariance_after(self, steps: int) -> np.ndarray:
        """Covariance ``steps`` base steps after a report (0 → :attr:`P_post`, m →
        :attr:`P_prior`), so a constant-gain filter can report a covariance every step."""
        m = self.period_steps
        is_int = isinstance(steps, (int, np.integer)) and not isinstance(steps, bool)
        if not is_int or not 0 <= steps <= m:
            raise InputError(f"steps must be an integer in [0, {m}], got {steps!r}")
        if steps == 0:
            return self.P_post
        if steps == m:
            return self.P_prior
        return self.P_between[steps - 1]


@dataclass(frozen=True)
class ContinuousSteadyStateGain:
    """Steady state of a continuous-time Kalman(-Bucy) filter.

    Attributes:
        K: constant gain :math:`K_c = P C^\\top R_c^{-1}`, shape (n, m).
        P: steady error covariance, the CARE solution, (n, n).
    """

    K: np.ndarray
    P: np.ndarray


def _check_model(
    f: ArrayLike, q: ArrayLike, h: ArrayLike, r: ArrayLike, names: tuple[str, str, str, str]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Validate the shapes and definiteness of a state-space noise model."""
    nf, nq, nh, nr = names
    f_arr = check_array(nf, f, (None, None))
    n = f_arr.shape[0]
    if f_arr.shape != (n, n) or n == 0:
        raise InputError(f"{nf} must be a non-empty square matrix, got shape {f_arr.shape}")
    q_arr = check_array(nq, q, (n, n))
    h_arr = check_array(nh, h, (None, n))
    m = h_arr.shape[0]
    if m == 0:
        raise InputError(f"{nh} must have at least one row, got shape {h_arr.shape}")
    r_arr = check_array(nr, r, (m, m))
    for name, arr, strict in ((nq, q_arr, False), (nr, r_arr, True)):
        scale = float(np.max(np.abs(arr)))
        if not np.allclose(arr, arr.T, rtol=0.0, atol=_TOL * scale):
            raise InputError(f"{name} must be symmetric")
        low = float(np.min(np.linalg.eigvalsh(arr)))
        if (low <= 0.0) if strict else (low < -_TOL * scale):
            kind = "positive definite" if strict else "positive semi-definite"
            raise InputError(f"{name} must be {kind}, got a smallest eigenvalue of {low:g}")
    return f_arr, q_arr, h_arr, r_arr


def _no_steady_state(names: tuple[str, str, str, str], boundary: str) -> ConfigError:
    nf, nq, nh, _ = names
    return ConfigError(
        f"{nf}, {nq}, {nh} have no stabilising steady state: every mode of {nf} with "
        f"{boundary} must be seen through {nh} (detectable) and driven by {nq} (stabilisable)"
    )


def steady_state_gain(F: ArrayLike, Q: ArrayLike, H: ArrayLike, R: ArrayLike) -> SteadyStateGain:
    r"""Steady-state gain and covariances of the discrete Kalman filter (DARE).

    :math:`P^-` from ``scipy.linalg.solve_discrete_are(F.T, H.T, Q, R)`` (the filtering DARE
    is the control DARE of the dual system), :math:`K = P^- H^\top S^{-1}` with
    :math:`S = H P^- H^\top + R`, and :math:`P^+ = (I - KH) P^-`, computed as
    :math:`P^- - K S K^\top` (the same matrix, exactly symmetric).

    Raises:
        InputError: a matrix has the wrong shape, is not finite, Q is not symmetric positive
            semi-definite or R not symmetric positive definite.
        ConfigError: the model has no stabilising steady state (see the module docstring).
    """
    names = ("F", "Q", "H", "R")
    f, q, h, r = _check_model(F, Q, H, R, names)
    try:
        p = scipy.linalg.solve_discrete_are(f.T, h.T, q, r)
    except (np.linalg.LinAlgError, ValueError):
        raise _no_steady_state(names, "|eigenvalue| >= 1") from None
    p = 0.5 * (p + p.T)
    s = h @ p @ h.T + r
    k = np.linalg.solve(s, h @ p).T
    closed_loop = f @ (np.eye(f.shape[0]) - k @ h)
    if np.max(np.abs(np.linalg.eigvals(closed_loop))) >= 1.0 - _TOL:
        raise _no_steady_state(names, "|eigenvalue| >= 1")
    p_post = p - k @ s @ k.T
    return SteadyStateGain(K=k, P_prior=p, P_post=0.5 * (p_post + p_post.T))


def periodic_steady_state(
    F: ArrayLike, Q: ArrayLike, H: ArrayLike, R: ArrayLike, period_steps: int
) -> PeriodicSteadyState:
    r"""Steady state of a filter predicting every base step and updating every m-th step.

    A sensor that reports every :math:`m`-th step of the base loop (an infrared sensor at
    10 Hz in a 20 Hz loop: :math:`m = 2`) sees, between reports, the :math:`m`-step system

    .. math::

        F_m = F^m,\qquad Q_m = \sum_{i=0}^{m-1} F^i Q F^{i\top},

    whose DARE (:func:`steady_state_gain`) gives :math:`K`, :math:`P^-` and :math:`P^+` at the
    report steps.  Between reports the covariance follows the pure predictions
    :math:`P_j = F P_{j-1} F^\top + Q`, :math:`P_0 = P^+`, for :math:`j = 1 .. m-1`, and
    :math:`P_m = P^-` closes the cycle (a fixed point).  This is the covariance a
    constant-gain ("steady-state") local filter reports at every base step.
    """
    if (
        isinstance(period_steps, bool)
        or not isinstance(period_steps, (int, np.integer))
        or period_steps < 1
    ):
        raise ConfigError(f"period_steps must be an integer >= 1, got {period_steps!r}")
    m = int(period_steps)
    f, q, h, r = _check_model(F, Q, H, R, ("F", "Q", "H", "R"))
    f_m = np.eye(f.shape[0])
    q_m = np.zeros_like(q)
    for _ in range(m):
        q_m = f @ q_m @ f.T + q
        f_m = f @ f_m
    gain = steady_state_gain(f_m, q_m, h, r)
    between = [gain.P_post]
    for _ in range(m - 1):
        between.append(f @ between[-1] @ f.T + q)
    return PeriodicSteadyState(
        period_steps=m,
        K=gain.K,
        P_prior=gain.P_prior,
        P_post=gain.P_post,
        P_between=np.array(between[1:]).reshape(m - 1, *f.shape),
    )


def continuous_steady_state_gain(
    A: ArrayLike, Qc: ArrayLike, C: ArrayLike, Rc: ArrayLike
) -> ContinuousSteadyStateGain:
    r"""Steady-state gain of the continuous-time filter (CARE), CN103196450A eqs. (4), (19).

    :math:`P` from ``scipy.linalg.solve_continuous_are(A.T, C.T, Qc, Rc)`` and
    :math:`K_c = P C^\top R_c^{-1}`; ``Qc`` and ``Rc`` are noise intensities (power spectral
    densities), e.g. (rad/s)²/Hz.

    Raises:
        InputError: as :func:`steady_state_gain`.
        ConfigError: the model has no stabilising steady state (a mode of A with real part
            >= 0 unseen by C or undriven by Qc).
    """
    names = ("A", "Qc", "C", "Rc")
    a, q, c, r = _check_model(A, Qc, C, Rc, names)
    try:
        p = scipy.linalg.solve_continuous_are(a.T, c.T, q, r)
    except (np.linalg.LinAlgError, ValueError):
        raise _no_steady_state(names, "real part >= 0") from None
    p = 0.5 * (p + p.T)
    k = np.linalg.solve(r, c @ p).T
    if np.max(np.linalg.eigvals(a - k @ c).real) >= -_TOL:
        raise _no_steady_state(names, "real part >= 0")
    return ContinuousSteadyStateGain(K=k, P=p)
