r"""Path prediction from the ego's yaw rate and the headings of the vehicles ahead: the road's
curvature and its rate, with their covariance, and each object's probability of being in the
ego's path.  The ``"fused"`` path of :mod:`acc_fusion.warning.selection`.

Road model
    The road ahead is a clothoid (curvature linear in arc length, the road-design element
    between straights and arcs; Dickmanns & Mysliwetz, "Recursive 3-D road and relative
    ego-state recognition", *IEEE Trans. PAMI* 14(2), 1992): at longitudinal distance
    :math:`x` ahead (:math:`|\kappa x| \ll 1`, arc length :math:`\approx x`) its curvature is
    :math:`c_0 + c_1 x`, and the tangent's angle to the ego's heading

    .. math::

        \psi(x) = \psi_0 + c_0 x + \tfrac12 c_1 x^2 ,

    with :math:`\psi_0` the ego's heading error to its lane (lane-keeping wander, or a lane
    change).  The predicted path is the curve through the ego, tangent to its heading, that
    bends as the road does:

    .. math::

        y_p(x) = \tfrac12 c_0 x^2 + \tfrac16 c_1 x^3 .

A recursive estimate of :math:`\boldsymbol\theta = [\psi_0,\ c_0,\ c_1]^\top`
    A Kalman filter per ego, in the manner of Dickmanns & Mysliwetz (1992), whose road state
    moves with the ego.  Over a step of :math:`T` seconds at speed :math:`v` the ego drives
    :math:`\Delta s = vT` along the road:

    .. math::

        c_0 \leftarrow c_0 + c_1 \Delta s,\qquad
        c_1 \leftarrow c_1,\qquad
        \psi_0 \leftarrow \psi_0 + (\dot\psi - v c_0)\,T ,

    the last because the ego turns at its measured yaw rate :math:`\dot\psi` while the road
    turns at :math:`v c_0`; the process noise is a random walk of :math:`c_0` and :math:`c_1`
    per metre driven (``curvature_walk``, ``curvature_rate_walk``: the road is not exactly
    a clothoid, and a clothoid begins where a straight ends) and the gyro's noise integrated
    into :math:`\psi_0`.  Measurements, each a scalar update:

    * The yaw-rate gyro: :math:`\dot\psi / v = c_0 + n`, with variance :math:`\sigma_g^2 / v^2
      + \sigma_d^2`: the gyro's noise :math:`\sigma_g` and the driver's steering about the
      road's curvature :math:`\sigma_d` (``steer_curvature_std``).  Filtered over the steps,
      this is the low-passed yaw rate of a production path estimate.  (The same gyro sample
      also drives :math:`\psi_0`; the correlation is neglected.)
    * Every moving vehicle ahead, tracked at :math:`(x_k, y_k)` with relative velocity
      :math:`(v_{x,k}, v_{y,k})`: its ground heading in the ego frame :math:`h_k =
      \operatorname{atan2}(v_{y,k},\ v + v_{x,k}) = \psi_0 + c_0 x_k + \tfrac12 c_1 x_k^2 + n_k`,
      with variance :math:`\sigma_h^2 + \sigma_{v_y,k}^2 / (v + v_{x,k})^2` (the vehicle's
      own lane-keeping, ``heading_std``, and the track's lateral-velocity variance).  This is
      how vehicles ahead reveal the curvature the ego has not yet reached (Eidehall &
      Gustafsson, "Combined road prediction and target tracking in collision avoidance",
      *IEEE Intelligent Vehicles Symposium* 2004, 619-624: the motion of other vehicles
      improves the lane-curvature estimate; the curvature-change term is what a yaw-rate path
      lacks at curve entry and exit, Polychronopoulos et al. 2007).  A vehicle whose
      normalised innovation exceeds ``outlier_gate``\ :sup:`2` is left out (a vehicle
      changing lanes does not follow its lane's tangent), and so is the target selected at
      the last step: its cut-out must not bend the path away from the stopped car it
      reveals, and a target cannot vouch for its own path.
    * Roadside trails: stationary objects beside the road (guardrail posts, a row of
      parked cars) lie on a line parallel to the road, :math:`y_k = d + \psi_0 x_k + \tfrac12
      c_0 x_k^2 + \tfrac16 c_1 x_k^3` with an unknown offset :math:`d`.  Two neighbours
      :math:`j < k` along one side of the path cancel :math:`d`:

      .. math::

          y_k - y_j = \psi_0 (x_k - x_j) + \tfrac12 c_0 (x_k^2 - x_j^2)
                      + \tfrac16 c_1 (x_k^3 - x_j^3) + n ,

      with variance :math:`\sigma_{y,j}^2 + \sigma_{y,k}^2 + 2\sigma_\text{rail}^2`.  The
      stationary tracks whose offset from the predicted path lies within ``rail_band`` on
      either side are sorted by range, and each pair of neighbours whose offsets differ by
      less than ``rail_gate`` is one measurement (the neighbours' differences share a track,
      a correlation neglected).  The guardrail is a classic cue to the road's course for
      forward-looking radar (e.g. Lundquist, Orguner & Gustafsson, "Extended target tracking
      using polynomials with applications to road-map estimation", *IEEE Trans. Signal
      Processing* 59(1), 2011, who estimate road edges as polynomials from radar returns of
      the guardrail).
    * Where a map gives it (``map_curvature_std`` > 0): the lane's curvature at the ego,
      :math:`\kappa_\text{map} = c_0 + n`.

    A new ego starts from :math:`\boldsymbol\theta = 0` with the covariance
    :math:`\operatorname{diag}(\sigma_{\psi}^2, \sigma_{c_0}^2, \sigma_{c_1}^2)`
    (``ego_heading_std``, ``curvature_std``, ``curvature_rate_std``).

In-path probability
    An object at :math:`(x, y)` with lateral variance :math:`\sigma_y^2` is offset
    :math:`o = y - y_p(x)` from the path, with variance :math:`\sigma_o^2 = \sigma_y^2 +
    \mathbf j^\top C \mathbf j`, :math:`\mathbf j = [0,\ x^2/2,\ x^3/6]^\top` (the path's
    uncertainty widens with distance as :math:`x^2` and :math:`x^3`); the probability that it
    is inside the corridor of half width :math:`w/2` is, for a Gaussian offset,

    .. math::

        P_\text{in} = \Phi\!\left(\frac{w/2 - o}{\sigma_o}\right)
                    - \Phi\!\left(\frac{-w/2 - o}{\sigma_o}\right)

    (the in-lane probability of threat assessment; Eidehall & Gustafsson 2004 gate targets on
    the lane likewise).  Every standard deviation above is an assumption of order of
    magnitude, stated on :class:`~acc_fusion.warning.selection.SelectionConfig`.
"""

from __future__ import annotations

import math

from numba import njit

#: The indices of the parameters :func:`road_step` takes in its ``prm`` array.
(HEADING_VAR, STEER_VAR, MAP_VAR, C0_WALK, C1_WALK, MIN_SPEED, MIN_RANGE, MAX_RANGE,
 GATE, RAIL_VAR, RAIL_MIN, RAIL_MAX, RAIL_GATE) = range(13)  # fmt: skip
N_PARAMS = 13


@njit(cache=True)
def _update(theta, cov, h0, h1, h2, z, r, gate):  # pragma: no cover - compiled
    """One scalar Kalman update of ``theta (3,)``, ``cov (3, 3)`` with the measurement ``z``
    of ``h · theta`` and variance ``r``; skipped (False returned) when the normalised
    innovation exceeds ``gate`` (0: never)."""
    ph0 = cov[0, 0] * h0 + cov[0, 1] * h1 + cov[0, 2] * h2
    ph1 = cov[1, 0] * h0 + cov[1, 1] * h1 + cov[1, 2] * h2
    ph2 = cov[2, 0] * h0 + cov[2, 1] * h1 + cov[2, 2] * h2
    s = h0 * ph0 + h1 * ph1 + h2 * ph2 + r
    nu = z - (h0 * theta[0] + h1 * theta[1] + h2 * theta[2])
    if gate > 0.0 and nu * nu > gate * s:
        return False
    k0, k1, k2 = ph0 / s, ph1 / s, ph2 / s
    theta[0] += k0 * nu
    theta[1] += k1 * nu
    theta[2] += k2 * nu
    ph = (ph0, ph1, ph2)
    k = (k0, k1, k2)
    for i in range(3):
        for j in range(3):
            cov[i, j] -= k[i] * ph[j]
    for i in range(3):  # keep it symmetric against rounding
        for j in range(i + 1, 3):
            m = 0.5 * (cov[i, j] + cov[j, i])
            cov[i, j] = m
            cov[j, i] = m
    return True


@njit(cache=True)
def road_step(
    theta, cov, dt, x, y, vx, vy, y_var, vy_var, usable, still, speed, yaw_rate, gyro_var,
    map_curvature, prm, off, order,
):  # pragma: no cover - compiled  # fmt: skip
    r"""One step of one ego's road filter (module docstring): predict ``theta (3,)`` and
    ``cov (3, 3)`` over ``dt`` [s], then update them with the yaw rate, the map and the
    vehicles ahead and the roadside trails.

    ``x, y, vx, vy, y_var, vy_var (F,)``: each object's position [m], relative velocity
    [m/s] and the variances of ``y`` and ``vy``; ``usable (F,)`` the objects that may serve
    as heading observations (moving vehicles ahead, not oncoming), ``still (F,)`` the
    stationary ones (candidates for a roadside trail); ``speed`` [m/s], ``yaw_rate``
    [rad/s], ``gyro_var`` its noise variance, ``map_curvature`` [1/m] (used when
    ``prm[MAP_VAR] > 0``); ``prm`` the parameters by :data:`HEADING_VAR` ... :data:`GATE`;
    ``off (F,)`` float and ``order (F,)`` int64 scratch space (overwritten)."""
    ds = max(speed, 0.0) * dt
    # Predict: F = [[1, -a, 0], [0, 1, b], [0, 0, 1]] with a = v T, b = Δs; u = [ψ̇ T, 0, 0].
    a, b = speed * dt, ds
    theta[0] += yaw_rate * dt - a * theta[1]
    theta[1] += b * theta[2]
    # cov <- F cov Fᵀ, element by element (no temporaries on the per-ego hot path)
    p00, p01, p02 = cov[0, 0], cov[0, 1], cov[0, 2]
    p11, p12, p22 = cov[1, 1], cov[1, 2], cov[2, 2]
    q01, q11, q12 = p01 - a * p11, p11 + b * p12, p12 + b * p22  # rows of F cov
    q02 = p02 - a * p12
    cov[0, 0] = p00 - a * p01 - a * q01 + gyro_var * dt * dt
    cov[0, 1] = cov[1, 0] = q01 + b * q02
    cov[0, 2] = cov[2, 0] = q02
    cov[1, 1] = q11 + b * q12 + prm[C0_WALK] * ds
    cov[1, 2] = cov[2, 1] = q12
    cov[2, 2] = p22 + prm[C1_WALK] * ds
    if speed >= prm[MIN_SPEED]:
        r = gyro_var / (speed * speed) + prm[STEER_VAR]
        _update(theta, cov, 0.0, 1.0, 0.0, yaw_rate / speed, r, 0.0)
    if prm[MAP_VAR] > 0.0:
        _update(theta, cov, 0.0, 1.0, 0.0, map_curvature, prm[MAP_VAR], 0.0)
    gate = prm[GATE] * prm[GATE]
    for k in range(x.size):
        ground = speed + vx[k]
        if usable[k] and prm[MIN_RANGE] <= x[k] <= prm[MAX_RANGE] and ground >= prm[MIN_SPEED]:
            r = prm[HEADING_VAR] + vy_var[k] / (ground * ground)
            z = math.atan2(vy[k], ground)
            _update(theta, cov, 1.0, x[k], 0.5 * x[k] * x[k], z, r, gate)
    _trails(theta, cov, x, y, y_var, still, prm, off, order)


@njit(cache=True)
def _trails(theta, cov, x, y, y_var, still, prm, off, order):  # pragma: no cover - compiled
    """The roadside-trail updates of :func:`road_step` (module docstring): on each side of
    the path, the neighbours along the range among the stationary objects in the band.
    ``off`` and ``order`` are scratch space: the band's objects' offsets from the path, and
    their indices sorted by range (an insertion sort: a few objects, no allocation)."""
    m = 0
    for k in range(x.size):
        if still[k] and prm[MIN_RANGE] <= x[k] <= prm[MAX_RANGE]:
            o = y[k] - (0.5 * theta[1] * x[k] * x[k] + theta[2] * x[k] * x[k] * x[k] / 6.0)
            if prm[RAIL_MIN] <= abs(o) <= prm[RAIL_MAX]:
                off[k] = o
                i = m
                while i > 0 and x[order[i - 1]] > x[k]:
                    order[i] = order[i - 1]
                    i -= 1
                order[i] = k
                m += 1
    gate = prm[GATE] * prm[GATE]
    for right in (False, True):
        prev = -1
        for i in range(m):
            k = order[i]
            if (off[k] > 0.0) != right:
                continue
            if prev >= 0 and abs(off[k] - off[prev]) <= prm[RAIL_GATE]:
                a, b = x[prev], x[k]
                r = y_var[k] + y_var[prev] + 2.0 * prm[RAIL_VAR]
                h2 = (b * b * b - a * a * a) / 6.0
                _update(theta, cov, b - a, 0.5 * (b * b - a * a), h2, y[k] - y[prev], r, gate)
            prev = k


@njit(cache=True)
def in_path_probability(offset, variance, half_width):  # pragma: no cover - compiled
    """The probability that a Gaussian offset of mean ``offset`` [m] and ``variance`` [m²]
    lies within ``±half_width`` (module docstring); 1 or 0 for a zero variance."""
    if variance <= 0.0:
        return 1.0 if abs(offset) <= half_width else 0.0
    out = abs(offset) - half_width
    if out > 0.0 and out * out > 70.0 * variance:  # beyond 8.4 σ outside: P < 1e-16
        return 0.0
    s = math.sqrt(2.0 * variance)
    return 0.5 * (math.erf((half_width - offset) / s) - math.erf((-half_width - offset) / s))


@njit(cache=True)
def path_offset(theta, cov, x, y, y_var):  # pragma: no cover - compiled
    r"""The offset :math:`o = y - y_p(x)` [m] of an object from the path of road parameters
    ``theta`` and its variance :math:`\sigma_y^2 + \mathbf j^\top C \mathbf j` (module
    docstring) as a pair."""
    j1, j2 = 0.5 * x * x, x * x * x / 6.0
    off = y - (j1 * theta[1] + j2 * theta[2])
    var = y_var + j1 * j1 * cov[1, 1] + 2.0 * j1 * j2 * cov[1, 2] + j2 * j2 * cov[2, 2]
    return off, var


@njit(cache=True)
def map_offset(row, step, x, y, y_var, lat_var, heading_var, kappa):  # pragma: no cover - compiled
    r"""The offset [m] of an object at ``(x, y)`` of lateral variance ``y_var`` from the map's
    path ``row``, the path's lateral position every ``step`` metres from the ego (linear
    between, along the last interval beyond), and its variance :math:`\sigma_y^2 +
    \sigma_{e_y}^2 + x^2 \sigma_{e_\psi}^2` (``lat_var``, ``heading_var``: the
    localisation's, :mod:`acc_fusion.sensors.localization`), as a pair.  Where the row gives
    no path at ``x``:

    - the ego on no lane (the whole row NaN): the circle of the lane's curvature ``kappa`` at
      the ego, as the ``"lane"`` path, the offset's variance then the track's alone;
    - the path turned back before ``x`` (a loop tighter than the field: the stations after
      the last one it reaches, :math:`X_L`, are NaN, and its farthest point lies before
      :math:`X_L` + ``step``): an object at or beyond :math:`X_L` + ``step`` is where the
      ego's lane never goes, an infinite offset; nearer, the path goes on along its last
      interval (the circle where the path reaches no station past the ego's)."""
    u = max(x, 0.0) / step
    i = min(int(u), row.size - 2)
    yp = row[i] + (u - i) * (row[i + 1] - row[i])
    if not math.isfinite(yp):
        if not math.isfinite(row[0]):  # the ego on no lane
            return y - 0.5 * kappa * x * x, y_var
        last = 0  # the last station the path reaches before it turns back
        while last + 1 < row.size and math.isfinite(row[last + 1]):
            last += 1
        if u >= last + 1:  # beyond the farthest the path goes
            return math.inf, y_var
        if last == 0:
            return y - 0.5 * kappa * x * x, y_var
        yp = row[last] + (u - last) * (row[last] - row[last - 1])
    return y - yp, y_var + lat_var + x * x * heading_var
