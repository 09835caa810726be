r"""Motion and measurement models of the lead vehicle's motion relative to the ego vehicle.

State (per follower→leader pair), SI units:

=====  ===========================  ======
index  meaning                      unit
=====  ===========================  ======
0      gap (bumper to bumper)       m
1      range-rate  :math:`\dot d`   m/s (negative when closing)
2      lead vehicle's acceleration  m/s²
=====  ===========================  ======

The ego's own acceleration :math:`u` (from its accelerometer) is a known input, so the
ego's braking is not a surprise to the filter (ego-motion compensation):
:math:`\ddot d = a_\text{lead} - u`.  Without that input (``u = 0``) the third state is
the relative acceleration, as in kong2011.

The local model of kong2011 (eq. 1), :math:`X(k+1) = \Phi X(k) + G V(k)`, with the state
"distance, speed and acceleration of the target" is the constant-acceleration (discrete
Wiener-process acceleration) model of Bar-Shalom, Li & Kirubarajan, *Estimation with
Applications to Tracking and Navigation* (2001), §6.3.3:

.. math::

    \Phi = \begin{bmatrix} 1 & T & T^2/2 \\ 0 & 1 & T \\ 0 & 0 & 1 \end{bmatrix},\qquad
    Q = G G^\top \sigma_v^2,\quad G = [T^2/2,\ T,\ 1]^\top,\quad \sigma_v = \sigma_j T

where :math:`\sigma_j` [m/s³] is the standard deviation of the relative jerk, so that the
acceleration increment over one step has standard deviation :math:`\sigma_j T`.
:math:`Q` is computed by filterpy's ``Q_discrete_white_noise``.  Both sensors measure range and
range-rate, :math:`Z = H X + W` with :math:`H = [I_2\ 0]`.
"""

from __future__ import annotations

import numpy as np

from acc_fusion.core.validation import check_range

STATE_DIM = 3
MEAS_DIM = 2
STATE_LABELS = ("gap [m]", "range-rate [m/s]", "lead acceleration [m/s²]")
#: Measurement matrix of both sensors: range and range-rate.
MEASUREMENT_MATRIX = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def ca_transition(dt: float) -> np.ndarray:
    r"""Constant-acceleration transition matrix :math:`\Phi(T)` for a step of ``dt`` seconds."""
    dt = check_range("dt", dt, 0.0, lo_open=True)
    return np.array([[1.0, dt, 0.5 * dt * dt], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])


def ego_input(dt: float) -> np.ndarray:
    r"""Input vector :math:`\Gamma = [-T^2/2,\ -T,\ 0]^\top` of the ego acceleration ``u``:
    :math:`X(k+1) = \Phi X(k) + \Gamma u(k) + w(k)`."""
    dt = check_range("dt", dt, 0.0, lo_open=True)
    return np.array([-0.5 * dt * dt, -dt, 0.0])


def ca_process_noise(dt: float, jerk_std: float) -> np.ndarray:
    r"""Process noise :math:`Q = G G^\top (\sigma_j T)^2`, :math:`G = [T^2/2,\ T,\ 1]^\top`
    (Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking and
    Navigation*, 2001, p. 274): filterpy's ``Q_discrete_white_noise(dim=3, dt, var)``, the
    same expressions, bit for bit (``tests/test_engines.py``), without importing filterpy,
    which brings scipy.stats (about 0.8 s) into every simulating process.

    ``jerk_std`` is :math:`\sigma_j` in m/s³.
    """
    dt = check_range("dt", dt, 0.0, lo_open=True)
    jerk_std = check_range("jerk_std", jerk_std, 0.0)
    g_gt = [
        [0.25 * dt**4, 0.5 * dt**3, 0.5 * dt**2],
        [0.5 * dt**3, dt**2, dt],
        [0.5 * dt**2, dt, 1.0],
    ]
    return np.array(g_gt) * (jerk_std * dt) ** 2
