r"""The FDI's variance tests of a sensor's successive reports — frozen output and noise burst
— and the cross check of a report against another sensor's (the methods and their sources:
:mod:`acc_fusion.fusion.fdi`), with the quadratic form they share."""

from __future__ import annotations

import numpy as np
from numba import njit

from acc_fusion.core.distributions import chi2_ppf


@njit(cache=True, inline="always")
def _quad(d0, d1, a, b, c, e):  # pragma: no cover - compiled
    """:math:`d^\\top A^{-1} d` for :math:`d = (d_0, d_1)`, :math:`A = [[a, b], [c, e]]`
    (infinite when :math:`A` is singular)."""
    det = a * e - b * c
    return (d0 * d0 * e - d0 * d1 * (b + c) + d1 * d1 * a) / det if det > 0.0 else np.inf


#: Layout of ``last[i, s]`` (:func:`_variance_test`): the latest report (range, range-rate), its
#: R row by row, the frozen sum, the reports in the current test, the R factor, the bias
#: estimate (range, range-rate), the differences in it and the sum of their range variances
#: (:func:`acc_fusion.fusion.fdi.bias_one`); then the K noise terms of the test.
Z_RANGE, Z_RATE, R_00, R_01, R_10, R_11, FROZEN_SUM, COUNT, SCALE = range(9)
BIAS_RANGE, BIAS_RATE, BIAS_COUNT, BIAS_VAR = 9, 10, 11, 12
LAST_SIZE = 13
#: A noise term beyond its ``NOISE_TERM_PROB`` point counts towards a noise burst.
NOISE_TERM_PROB = 0.99
_TERM_LIMIT = float(chi2_ppf(NOISE_TERM_PROB, 1))
_TERM_MEDIAN = float(chi2_ppf(0.5, 1))


@njit(cache=True, inline="always")
def _variance_test(i, s, z, r, var, steps, last, frozen):  # pragma: no cover - compiled
    r"""Add sensor ``s``'s report to pair ``i``'s variance tests (module docstring: frozen
    output, noise burst) and keep it as the latest report.

    ``z``, ``r``: this step's reports, ``r`` already times the sensor's R factor
    :math:`\lambda` (``last[i, s, SCALE]``), which the tests undo (they test the declared R);
    ``var``: :math:`(\chi^2_{mK}(\alpha_s), K, c_n, \Delta t, \lambda_{max},
    \chi^2_1(0.99), \chi^2_1(0.5))`; ``steps``: steps since the sensor's previous report.
    At the end of a test (2K reports) ``frozen[i, s]`` and :math:`\lambda` take their new
    values.  Returns 1 if the sensor newly froze, 2 if :math:`\lambda` changed, else 0."""
    v = last[i, s]
    n = int(v[COUNT])
    if n % 2 == 1:  # the second report of a pair
        d0, d1 = z[s, i, 0] - v[Z_RANGE], z[s, i, 1] - v[Z_RATE]
        scale = v[SCALE]
        v[FROZEN_SUM] += (
            0.5 * scale * _quad(d0, d1, r[s, i, 0, 0], r[s, i, 0, 1], r[s, i, 1, 0], r[s, i, 1, 1])
        )
        moved = d0 - steps * var[3] * 0.5 * (z[s, i, 1] + v[Z_RATE])  # trapezoidal motion
        v[LAST_SIZE + n // 2] = scale * moved * moved / (r[s, i, 0, 0] + v[R_00])
    v[Z_RANGE], v[Z_RATE], v[COUNT] = z[s, i, 0], z[s, i, 1], n + 1
    v[R_00], v[R_01], v[R_10], v[R_11] = r[s, i, 0, 0], r[s, i, 0, 1], r[s, i, 1, 0], r[s, i, 1, 1]
    if n + 1 < 2 * var[1]:
        return 0
    was = frozen[i, s]
    frozen[i, s] = v[FROZEN_SUM] < var[0]
    old = v[SCALE]
    terms = v[LAST_SIZE:]
    if np.sum(terms > var[5]) >= (var[2] if old == 1.0 else 1.0):  # a burst lasts until clear
        v[SCALE] = min(max(np.median(terms) / var[6], 1.0), var[4])
    else:
        v[SCALE] = 1.0
    v[FROZEN_SUM], v[COUNT] = 0.0, 0.0
    if frozen[i, s] and not was:
        return 1
    return 2 if v[SCALE] != old else 0


@njit(cache=True, inline="always")
def cross_nis_one(
    i, s, z, r, last, age, verdict, isolated, max_age, dt, accel_var
):  # pragma: no cover - compiled
    r"""The smallest normalised difference between sensor ``s``'s report of pair ``i`` and
    the latest report of another non-isolated sensor that reported within ``max_age`` steps
    (inf without one): :math:`d^\top (R_s + F_\tau R_o F_\tau^\top + \sigma_a^2 G_\tau
    G_\tau^\top)^{-1} d` with :math:`d = z_s - F_\tau z_o`, :math:`z_o, R_o` the other
    sensor's latest report (``last``), :math:`\tau` its age (steps times ``dt``),
    :math:`F_\tau = [[1, \tau], [0, 1]]` (the range carried forward at the reported
    range-rate) and :math:`G_\tau = [\tau^2/2, \tau]^\top`: the relative acceleration
    over :math:`\tau`, unknown, of variance ``accel_var`` (the filters' ``init_accel_std``
    squared, 3 m/s², the prior they start a track with).  Without that term a one-step-old
    camera report at SUMO's 0.5 s step contradicted every radar report after a lead's
    acceleration step (1.5 m/s of range-rate in 0.5 s at 3 m/s², three times the camera's
    0.5 m/s), and the radar was gated out.  :math:`\chi^2_m` for two healthy sensors,
    whatever the motion model predicted."""
    least = np.inf
    for o in range(last.shape[1]):
        if o == s or isolated[i, o] or verdict[i, o] == 0 or age[i, o] > max_age:
            continue
        tau = age[i, o] * dt
        r00, r01, r10, r11 = last[i, o, 2], last[i, o, 3], last[i, o, 4], last[i, o, 5]
        a0, a1 = 0.5 * tau * tau * accel_var, tau * accel_var  # sigma_a^2 G_tau
        q = _quad(
            z[s, i, 0] - last[i, o, 0] - tau * last[i, o, 1], z[s, i, 1] - last[i, o, 1],
            r[s, i, 0, 0] + r00 + tau * (r01 + r10) + tau * tau * r11 + 0.5 * tau * tau * a0,
            r[s, i, 0, 1] + r01 + tau * r11 + 0.5 * tau * tau * a1,
            r[s, i, 1, 0] + r10 + tau * r11 + tau * a0,
            r[s, i, 1, 1] + r11 + tau * a1,
        )  # fmt: skip
        least = min(least, q)
    return least
