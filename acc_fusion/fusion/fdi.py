r"""Fault detection and isolation: a windowed chi-square test on each sensor's NIS.

For every pair and sensor the fusion center computes the normalised innovation squared of
the sensor's measurement against its own one-step prediction,
:math:`\epsilon_\nu = \nu^\top S^{-1}\nu` with :math:`S = H P^- H^\top + R`, which is
:math:`\chi^2_m` distributed (m = 2: range and range-rate) for a healthy sensor and a
consistent filter (Bar-Shalom, Li & Kirubarajan 2001, §5.4; in fusion-reset mode this is the
local filter's own innovation with its information share undone).  Two tests use it:

* **Gate** (per report): a measurement with :math:`\epsilon_\nu > \chi^2_{m}(p_g)` is not used
  in the update (an outlier: a spike, a ghost, the first report of a bias), unless another
  non-isolated sensor confirms it: the *cross NIS*
  :math:`\epsilon_\times = d^\top (R_s + F_\tau R_o F_\tau^\top + \sigma_a^2 G_\tau
  G_\tau^\top)^{-1} d \le \chi^2_m(p_c)` with :math:`d = z_s - F_\tau z_o` against the
  latest report :math:`z_o` of sensor o, at most ``common_steps`` steps (:math:`\tau`) old,
  carried forward at its own range-rate, the relative acceleration meanwhile unknown
  (:func:`~acc_fusion.fusion.variance_test.cross_nis_one`; the analytical-redundancy check
  of two sensors measuring one quantity, Isermann 2006, ch. 10).  A confirmed report is the
  road, not a fault, and is not counted as evidence of one: a lead's braking onset shows at
  once in the radar's precise range-rate, beyond the gate of a model that expected no jerk,
  and the infrared camera reports the same, while a spike, a ghost or a stuck value
  disagrees with it.  Two unrelated spikes of the two sensors within a few steps fail the
  gate together but disagree; when every failing report was used (a "common cause") the
  federated gap RMSE with 2 % spikes on both was 1.87x healthy, 1.00x with the check.
  Checking against the latest report, not only one of the same step, keeps the radar's
  reports between two camera frames (Euro NCAP ``ccrb``, 50 healthy runs: 133 isolated
  pair-sensor-steps before, 0 after).
* **Acceleration jump** (per pair): when every reporting sensor in the fusion fails the
  gate and no report confirms another, the sensors agree that the model is wrong, not that
  one of them is (two independent healthy sensors fail a 0.9999 gate together with
  probability 1e-8).  A report that passes the gate against the prior widened by a jump of
  the relative acceleration, :math:`P^- + \sigma_a^2 g g^\top` with :math:`g = [\tau^2/2,
  \tau, 1]^\top` and :math:`\sigma_a` the filters' ``init_accel_std`` (Bar-Shalom, Li &
  Kirubarajan 2001, §11.2: a manoeuvre as a jump of the unknown input), is used, and the
  priors take the widening before the update; it still counts in the window.  The jump
  came after the model last explained (by the gate or a jump) a report of each sensor it
  takes: a report is tested with :math:`\tau` since its sensor's, the priors take the
  earliest, at least one step T and at most ``common_steps`` steps (from a later step it
  read two steps' range-rate error as the acceleration, −9.5 m/s² for −4.5).  A spike or a
  ghost jumps in range far beyond the widening (0.4 m at τ = 0.5 s).  Without the jump,
  sensors failing together locked the filter onto a stale acceleration (docs/theory/federated.md).
* **Window** (per sensor): the sum of the last W values
  :math:`\min(\epsilon_\nu, \epsilon_\times, \chi^2_m(p_c))`, is compared with
  :math:`\chi^2_{mW}(1-\alpha)` (reports confirmed beyond the gate stay out).  A failing
  sensor is *isolated*: left out of the fusion.  Its window is then refilled in the same
  way, and when a full window passes the test again the sensor rejoins (the fusion center
  re-initialises its local filter from the fused estimate).  The last sensor in the fusion
  is not isolated: its failing window is taken for a manoeuvre (isolating it ended the
  track, and the next started from a sensor already isolated, a biased radar's raw report:
  ``scripts/fault_tolerance.py --seeds 10``, radar bias, 1.35x the bound on seed 1, 0.91x
  now).  Clipping keeps one spike from isolating a sensor (it adds at most
  :math:`\chi^2_m(p_c)` = 9.2 for m = 2), while a persistent fault (bias, stuck value, noise
  burst) fills the window with large values.  The NIS alone mixes the sensor's error with
  the motion model's, which every sensor shares (on SUMO's A10KW, 0.5 s steps, the windows
  of healthy sensors failed).  The cross NIS is :math:`\chi^2_m` for healthy sensors
  whatever the model predicted, and a fault shows in both (it disagrees with the prediction
  *and* with the other sensor), so the smaller of the two is the evidence; never larger than
  the NIS, it can only lower the false-isolation rate.  Without another sensor's recent
  report the NIS alone decides (``scripts/federated_breakdown.py``, docs/theory/federated.md).
* **Manoeuvre first** (``manoeuvre``, default on): a sensor's first failing window is taken for
  a manoeuvre the motion model did not expect, not for a fault: the pair's priors take a jump
  of the relative acceleration at one of the last :math:`c` = ``common_steps`` steps, which
  one unknown, :math:`P^- + \tfrac{\sigma_a^2}{c}\sum_{j=1}^{c} g_j g_j^\top` with
  :math:`g_j = [(jT)^2/2, jT, 1]^\top` (a manoeuvre as a jump of the unknown input at an
  unknown time, Bar-Shalom, Li & Kirubarajan 2001, §11.2-11.3: the filter re-learns the
  acceleration within a few reports), the sensor is marked *suspect* and its window restarts
  after W/2 untested reports. The jump is taken only if the report that completes the window
  is used: one the gate rejects disagrees with the model *and* the other sensors, a fault's
  sign, not a model error's (a biased radar's raise let the camera's next report set the
  acceleration). A window often fails after the model has caught up; the same update then
  tests the jump, and a precise range-rate that agrees shows it small (a raise of the
  acceleration variance alone let a camera-only step set it; over one step, :math:`c = 1`,
  the jump read the completing report's noise as acceleration; docs/theory/federated.md). A
  second failing window in a row isolates the sensor; a passing one clears the suspicion, so
  a persistent fault is isolated after 2.5W reports instead of W. The rule gives the
  noise-burst test time to adapt R (``--set fusion.fdi.manoeuvre=false``: docs/theory/federated.md).
* **Frozen output** (per sensor, a stuck sensor): a healthy sensor's successive reports
  differ by at least their noise, a stuck one repeats itself.  Over K disjoint pairs of
  successive reports (:math:`z_{2j}, z_{2j+1}`), the differences :math:`d_j = z_{2j+1} -
  z_{2j}` are independent with covariance :math:`2R` plus the target's motion, so

  .. math::

      T_f = \sum_{j=1}^{K} \tfrac12\, d_j^\top R^{-1} d_j \ \ge\ \chi^2_{mK}
      \text{ in distribution,}

  with equality for a target that does not move (the motion only adds to it).  A sensor
  with :math:`T_f < \chi^2_{mK}(\alpha_s)` (the lower tail: far less variation than its R
  promises; 0 for an exact repeat) is *frozen* and isolated at once (no manoeuvre makes a
  sensor repeat itself); its false-alarm probability per test is at most
  :math:`\alpha_s`.  This is the variance-ratio idea of von Neumann's successive-difference
  test (von Neumann, Kent, Bellinson & Hart, Ann. Math. Stat. 12, 1941) applied to the
  stuck-at sensor fault of Isermann (2006, ch. 10).  It rejoins only after a test that
  passes *and* a passing window.  Without it a stuck radar, the precise sensor, dragged the
  fused estimate with it and the infrared camera was isolated instead (27x healthy RMSE).
* **Noise burst** (per sensor, accommodated by adapting R): the same pairs of reports give
  K range differences with the target's motion removed by the trapezoidal rule,
  :math:`e_j = r_{2j+1} - r_{2j} - \tfrac{\Delta t}{2}(\dot r_{2j+1} + \dot r_{2j})`
  (exact for a constant relative acceleration), and the terms
  :math:`u_j = e_j^2 / (R^{rr}_{2j+1} + R^{rr}_{2j})`, each :math:`\chi^2_1` for a healthy
  sensor, whatever its bias or the lead's manoeuvre.  A burst is declared when at least
  :math:`c_n` of the K terms exceed :math:`\chi^2_1(0.99)`, with :math:`c_n` the least
  count of probability :math:`P(\mathrm{Bin}(K, 0.01) \ge c_n) \le \alpha_n` (3 of 5
  for :math:`\alpha_n = 10^{-5}`): a count, not a sum, so that one spike (one term) never
  reads as a burst.  The sensor's R is then multiplied by the robust innovation-based
  estimate :math:`\lambda = \mathrm{median}_j(u_j) / \chi^2_1(0.5)`, bounded to
  :math:`[1, \lambda_{max}]` (never trust a sensor more than it declares; the
  innovation-based adaptive estimation of R of Mehra, IEEE TAC 15(2), 1970, and Mohamed &
  Schwarz, J. Geodesy 73, 1999, here on differences so that it does not depend on the
  filter), the NIS window is emptied (it held NIS of the wrong R) and the sensor stays in
  the fusion at its true weight instead of being isolated.  While :math:`\lambda > 1` one
  term beyond :math:`\chi^2_1(0.99)` of K keeps the burst; a test without one (probability
  0.95 for a healthy sensor) ends it (:math:`\lambda = 1`).  A x10 noise burst on the
  radar: federated gap RMSE 6.76x healthy when it was isolated after the window test, 5.0x
  with R adapted (infrared alone: 5.8x).
* **Bias** (per sensor, accommodated by estimating it): an isolated sensor's bias is
  estimated against a sensor still in the fusion, then removed from its reports, and it
  rejoins (:mod:`acc_fusion.fusion.bias`, Friedland's separate-bias estimator).
* **Dropout** (per sensor, by the age of its last report): a sensor that has not reported
  for a pair for ``dropout_time`` seconds is *silent* (:attr:`WindowedChiSquare.silent`).
  Nothing needs isolating (a silent sensor adds nothing to the fusion); the flag tells the
  driver and the metrics that the estimate rests on the other sensors.  With the default
  0.5 s (an assumption: 10 radar or 5 infrared periods), a healthy infrared camera
  (detection probability 0.95) is flagged by five misses in a row, probability
  :math:`0.05^5 \approx 3\times10^{-7}` per report.

The state (windows, isolation flags) is per pair and per sensor, stored in arrays, so the
test costs a few vector operations per step whatever the number of pairs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.core.distributions import binom_isf, chi2_ppf
from acc_fusion.core.errors import ConfigError
from acc_fusion.core.slots import PairState
from acc_fusion.core.units import TIME_TOL
from acc_fusion.core.validation import check_range
from acc_fusion.fusion.bias import bias_one, forget_bias, uncorrect_other
from acc_fusion.fusion.variance_test import (
    _TERM_LIMIT,
    _TERM_MEDIAN,
    BIAS_COUNT,
    BIAS_RANGE,
    BIAS_RATE,
    LAST_SIZE,
    NOISE_TERM_PROB,
    SCALE,
    _variance_test,
    cross_nis_one,
)


@dataclass(frozen=True)
class FDIConfig:
    """Parameters of the windowed chi-square fault detection and isolation.

    Attributes:
        window: number of reports W summed by the window test (default 10: 0.5 s of radar,
            1 s of infrared at their default rates).
        alpha: false-isolation probability of one window test of a healthy sensor
            (default 0.001; windows overlap, so a healthy sensor is isolated about
            0.2 % of the time at this level).
        gate_prob: probability mass of the per-report gate :math:`\\chi^2_m(p_g)`
            (default 0.9999, i.e. 18.4 for m = 2).
        clip_prob: probability mass of the clip of each NIS in the window (default 0.99).
        confirm_tracks: confirm a track only once every sensor that should see it does.
        common_steps: reports of another sensor at most this many steps old confirm a report
            (default 3).
        manoeuvre: take a sensor's first failing window for a manoeuvre (the filters' priors
            take a jump of the acceleration) and isolate only on a second one (default True;
            the last sensor in the fusion is never isolated by its window either way).
        stuck_pairs: disjoint pairs of successive reports K summed by the frozen-output test
            (default 5: 10 reports, 0.5 s of radar, 1 s of infrared).
        stuck_alpha: probability that the frozen-output test flags a healthy sensor whose
            target does not move (default 1e-6, an assumption: about 0.007 false alarms per
            pair-hour of a 20 Hz radar; a moving target makes it smaller still).
        noise_alpha: largest probability that the noise-burst test flags a healthy sensor
            (default 1e-5, an assumption: a false alarm only down-weights the sensor for one
            test, about 0.07 per pair-hour of a 20 Hz radar).
        dropout_time: seconds without a report after which a sensor is *silent* for a pair
            (default 0.5; see the module docstring).
        max_noise_scale: upper bound of the factor on a sensor's declared R during a noise
            burst (default 400: a noise standard deviation up to 20 times the declared one;
            an assumption).
        bias_reports: fewest differences in an isolated sensor's bias estimate before its
            measurements are corrected (default 10; an assumption); 0 turns the bias
            accommodation off.
        bias_std: largest standard error of the range bias estimate [m] at which the
            correction starts (default 0.1, an assumption: well below the radar's 0.25 m
            range noise, so that what is left of the bias is small beside it).
    """

    window: int = 10
    alpha: float = 0.001
    gate_prob: float = 0.9999
    clip_prob: float = 0.99
    confirm_tracks: bool = True
    common_steps: int = 3
    manoeuvre: bool = True
    stuck_pairs: int = 5
    stuck_alpha: float = 1e-6
    noise_alpha: float = 1e-5
    max_noise_scale: float = 400.0
    dropout_time: float = 0.5
    bias_reports: int = 10
    bias_std: float = 0.1

    def __post_init__(self) -> None:
        for name, lo, hi in (
            ("window", 1, 10_000), ("stuck_pairs", 1, 10_000), ("bias_reports", 0, 10_000),
            ("common_steps", 0, 1000),
        ):  # fmt: skip
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
                raise ConfigError(
                    f"fdi.{name} must be a whole number in [{lo}, {hi}], got {value!r}"
                )
        check_range("fdi.alpha", self.alpha, 0.0, 1.0, lo_open=True, hi_open=True)
        check_range("fdi.gate_prob", self.gate_prob, 0.0, 1.0, lo_open=True, hi_open=True)
        check_range("fdi.clip_prob", self.clip_prob, 0.0, 1.0, lo_open=True, hi_open=True)
        check_range("fdi.stuck_alpha", self.stuck_alpha, 0.0, 1.0, lo_open=True, hi_open=True)
        check_range("fdi.noise_alpha", self.noise_alpha, 0.0, 1.0, lo_open=True, hi_open=True)
        check_range("fdi.max_noise_scale", self.max_noise_scale, 1.0, 1e6)
        check_range("fdi.dropout_time", self.dropout_time, 0.0, 1e6, lo_open=True)
        check_range("fdi.bias_std", self.bias_std, 0.0, 1e3, lo_open=True)


class WindowedChiSquare(PairState):
    """Per pair and per sensor NIS gate and window test (see the module docstring)."""

    _PAIR_AXES = dict.fromkeys(
        (
            "_buf",
            "_sum",
            "_count",
            "_pos",
            "isolated",
            "_verdict",
            "_suspect",
            "_last",
            "frozen",
            "_age",
        ),
        0,
    )

    def __init__(
        self, n_pairs: int, n_sensors: int, config: FDIConfig, dt: float, dof: int = 2,
        accel_std: float = 3.0,
    ) -> None:  # fmt: skip
        self.config = config
        self.dt = float(dt)
        self.accel_var = float(accel_std) ** 2  # of a report carried forward (cross NIS)
        w = int(config.window)
        self.gate = float(chi2_ppf(config.gate_prob, dof))
        self.clip = float(chi2_ppf(config.clip_prob, dof))
        self.threshold = float(chi2_ppf(1.0 - config.alpha, dof * w))
        self._buf = np.zeros((n_pairs, n_sensors, w))
        self._sum = np.zeros((n_pairs, n_sensors))
        self._count = np.zeros((n_pairs, n_sensors), dtype=np.int64)
        self._pos = np.zeros((n_pairs, n_sensors), dtype=np.int64)
        self.isolated = np.zeros((n_pairs, n_sensors), dtype=bool)
        self._verdict = np.zeros((n_pairs, n_sensors), dtype=np.int8)
        self._suspect = np.zeros((n_pairs, n_sensors), dtype=bool)
        k = config.stuck_pairs
        self.still = float(chi2_ppf(config.stuck_alpha, dof * k))
        # Noise burst: c of the K terms beyond their 99 % point, P(Bin(K, 0.01) >= c) <= alpha.
        self.noisy = float(binom_isf(config.noise_alpha, k, 1.0 - NOISE_TERM_PROB) + 1)
        self._last = np.zeros((n_pairs, n_sensors, LAST_SIZE + k))
        self._last[..., SCALE] = 1.0
        self.frozen = np.zeros((n_pairs, n_sensors), dtype=bool)
        self._age = np.zeros((n_pairs, n_sensors), dtype=np.int64)

    def tests(self) -> tuple[float, float, float, int, bool, tuple[float, ...]]:
        """The gate, the clip value, the window threshold, the age limit of a confirming report
        (steps), whether a first failing window is taken for a manoeuvre and the variance
        tests' constants (``var`` of ``variance_test._variance_test``)."""
        cfg = self.config
        return (
            self.gate, self.clip, self.threshold, int(cfg.common_steps), bool(cfg.manoeuvre),
            (
                self.still, float(cfg.stuck_pairs), self.noisy, self.dt, cfg.max_noise_scale,
                _TERM_LIMIT, _TERM_MEDIAN, float(cfg.bias_reports), cfg.bias_std**2,
                self.accel_var,
            ),
        )  # fmt: skip

    @property
    def silent(self) -> np.ndarray:
        """``(N, S)`` sensors that have not reported for ``dropout_time`` (a dropout)."""
        return self._age * self.dt > self.config.dropout_time + TIME_TOL

    @property
    def noise_scale(self) -> np.ndarray:
        """``(N, S)`` factor on each sensor's declared R (1 outside a noise burst)."""
        return self._last[..., SCALE]

    @property
    def bias(self) -> np.ndarray:
        """``(N, S, 2)`` bias estimates [m, m/s] (:mod:`acc_fusion.fusion.bias`), a copy."""
        return self._last[..., BIAS_RANGE : BIAS_RATE + 1].copy()

    @property
    def bias_corrected(self) -> np.ndarray:
        """``(N, S)`` sensors whose measurements are corrected by their bias estimate."""
        return self._last[..., BIAS_COUNT] < 0

    def correct(self, z: np.ndarray) -> np.ndarray:
        """The measurements ``z (S, N, 2)`` with every established bias removed (a copy)."""
        correction = np.where(self.bias_corrected[..., None], self.bias, 0.0)
        return z - correction.transpose(1, 0, 2)  # as correct_bias_one, pair by pair

    def arrays(self) -> tuple[np.ndarray, ...]:
        """The state arrays, in the order of :func:`window_one`'s arguments after the
        thresholds: window ring, its sum, count and position, isolation, verdict, suspicion,
        latest report and variance tests (``last`` of ``variance_test._variance_test``), frozen
        verdict, age."""
        return (
            self._buf, self._sum, self._count, self._pos, self.isolated, self._verdict,
            self._suspect, self._last, self.frozen, self._age,
        )  # fmt: skip

    def step(
        self, nis: np.ndarray, reported: np.ndarray, z: np.ndarray, r: np.ndarray,
        wide: np.ndarray | None = None,
    ) -> tuple[np.ndarray, ...]:  # fmt: skip
        """Test one step of NIS values ``(N, S)`` where ``reported (N, S)``, with the
        measurements ``z (S, N, 2)`` and their covariances ``r (S, N, 2, 2)`` (for the
        cross-check) and the NIS ``wide (N, S)`` against the prior widened by an acceleration
        jump (``None``: not known, no report is taken for one).

        Returns ``(accepted, rejoined, manoeuvre, jump)``: the measurements to use in the
        update, the sensors that passed a full window while isolated and rejoin now, the
        pairs ``(N,)`` whose filters should take a manoeuvre (a first failing window) and
        those whose priors should take the acceleration jump before the update.
        ``self.isolated`` holds the isolation state after this step.
        """
        accepted = np.empty_like(self.isolated)
        rejoined = np.empty_like(self.isolated)
        manoeuvre = np.zeros(self.isolated.shape[0], dtype=bool)
        jump = np.zeros_like(manoeuvre)
        wide = np.full(nis.shape, np.inf) if wide is None else wide
        _window_step(
            np.ascontiguousarray(nis, dtype=float), np.ascontiguousarray(reported, dtype=bool),
            np.ascontiguousarray(z, dtype=float), np.ascontiguousarray(r, dtype=float),
            *self.tests(), *self.arrays(), accepted, rejoined, manoeuvre,
            np.ascontiguousarray(wide, dtype=float), jump,
        )  # fmt: skip
        return accepted, rejoined, manoeuvre, jump


@njit(cache=True)
def _window_step(
    nis, reported, z, r, gate, clip, threshold, common_steps, manoeuvre_first, var, buf, total,
    count, pos, isolated, verdict, suspect, last, frozen, age, accepted, rejoined, manoeuvre,
    wide, jump,
):  # pragma: no cover - compiled  # fmt: skip
    """:meth:`WindowedChiSquare.step` for every pair, in place (rules in the module docstring)."""
    for i in range(buf.shape[0]):
        window_one(
            i, nis, reported, z, r, gate, clip, threshold, common_steps, manoeuvre_first, var,
            buf, total, count, pos, isolated, verdict, suspect, last, frozen, age, accepted,
            rejoined, manoeuvre, wide, jump,
        )  # fmt: skip


@njit(cache=True, inline="always")
def window_one(
    i, nis, reported, z, r, gate, clip, threshold, common_steps, manoeuvre_first, var, buf, total,
    count, pos, isolated, verdict, suspect, last, frozen, age, accepted, rejoined, manoeuvre,
    wide, jump,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_window_step` of pair ``i``: per sensor, the frozen-output test, the gate
    verdict (1 pass, 2 fail) and its age; the cross check against the other sensors; an
    acceleration jump (``jump[i]``); the smaller of the NIS and the cross NIS, clipped, into
    the window ring; the window test, a first failure being taken for a manoeuvre
    (``manoeuvre[i]``)."""
    n_sensors, w = buf.shape[1], buf.shape[2]
    for s in range(n_sensors):
        if reported[i, s]:
            change = _variance_test(i, s, z, r, var, age[i, s] + 1, last, frozen)
            if change == 1 and not isolated[i, s]:
                isolated[i, s] = True  # a frozen output: no manoeuvre explains it
            if change > 0:  # the window's NIS assumed another noise level
                suspect[i, s] = False
                _clear_window(i, s, buf, total, count, pos)
            verdict[i, s] = 1 if nis[i, s] <= gate else 2
            age[i, s] = 0
        else:
            age[i, s] += 1
    passed = False  # a sensor in the fusion agrees with the prediction: no jump
    for s in range(n_sensors):
        passed = passed or (reported[i, s] and not isolated[i, s] and nis[i, s] <= gate)
    for s in range(n_sensors):
        rep = reported[i, s]
        cross = (
            cross_nis_one(i, s, z, r, last, age, verdict, isolated, common_steps, var[3], var[9])
            if rep
            else np.inf
        )
        # A report beyond the gate that another sensor's latest report confirms is the road,
        # not a fault (a spike, a ghost or a stuck value disagrees with it).
        shared = rep and nis[i, s] > gate and cross <= clip
        if (
            rep
            and not frozen[i, s]
            and var[7] > 0
            and (isolated[i, s] or last[i, s, BIAS_COUNT] < 0)
        ):
            if bias_one(i, s, z, r, last, age, verdict, isolated, var[7], var[8]):
                suspect[i, s] = False  # corrected from now on: test the corrected reports
                _clear_window(i, s, buf, total, count, pos)
        rejoined[i, s] = False
        jumped = rep and not isolated[i, s] and not passed and not shared and wide[i, s] <= gate
        accepted[i, s] = rep and not isolated[i, s] and (nis[i, s] <= gate or shared or jumped)
        jump[i] = jump[i] or jumped
        if rep and not shared and count[i, s] < 0:  # settling after a manoeuvre: not tested
            count[i, s] += 1
        elif rep and not shared:
            k = pos[i, s]
            old = buf[i, s, k]
            value = min(nis[i, s], cross, clip)  # a fault shows against both
            buf[i, s, k] = value
            total[i, s] += value - old
            pos[i, s] = (k + 1) % w
            count[i, s] = min(count[i, s] + 1, w)
        if count[i, s] == w:
            fail = total[i, s] > threshold
            if not fail:
                suspect[i, s] = False
            if fail and isolated[i, s] and last[i, s, BIAS_COUNT] < 0:  # the bias changed
                forget_bias(i, s, last)
            alone = isolated[i].sum() == n_sensors - 1  # isolating it would end the track
            if fail and not isolated[i, s] and (manoeuvre_first and not suspect[i, s] or alone):
                suspect[i, s] = True  # a manoeuvre, unless the next window fails too
                manoeuvre[i] = manoeuvre[i] or accepted[i, s]  # (shows in a used report)
                _clear_window(i, s, buf, total, count, pos)
                count[i, s] = -(w // 2)
            elif fail != isolated[i, s] and not frozen[i, s]:  # newly isolated, or rejoining
                if fail and uncorrect_other(i, s, last, isolated):
                    fail = False  # a corrected sensor is the first suspect: it lost its bias
                elif fail:
                    accepted[i, s] = False
                    forget_bias(i, s, last)  # a new bias, if any
                else:
                    rejoined[i, s] = True
                isolated[i, s] = fail
                suspect[i, s] = False
                _clear_window(i, s, buf, total, count, pos)


@njit(cache=True, inline="always")
def _clear_window(i, s, buf, total, count, pos):  # pragma: no cover - compiled
    """Empty the window of pair ``i``'s sensor ``s``."""
    buf[i, s, :] = 0.0
    total[i, s] = 0.0
    count[i, s] = 0
    pos[i, s] = 0


@njit(cache=True, inline="always")
def reset_sensors_one(i, last, frozen):  # pragma: no cover - compiled
    """Forget pair ``i``'s sensor-level tests (the variance tests and their frozen verdicts)
    for a new vehicle; :func:`reset_one` forgets its track-level tests after."""
    for s in range(last.shape[1]):
        last[i, s, :] = 0.0
        last[i, s, SCALE] = 1.0
        frozen[i, s] = False


@njit(cache=True, inline="always")
def reset_one(
    i, buf, total, count, pos, isolated, verdict, suspect, last, frozen
):  # pragma: no cover
    """Forget pair ``i``'s track-level tests (windows, suspicion, gate verdicts) for a new
    track.  The variance tests (``last``) judge each sensor's output, not the track, and go on:
    a frozen sensor stays frozen and isolated, a noise burst keeps its R factor."""
    for s in range(buf.shape[1]):
        for k in range(buf.shape[2]):
            buf[i, s, k] = 0.0
        total[i, s] = 0.0
        count[i, s] = 0
        pos[i, s] = 0
        isolated[i, s] = frozen[i, s]
        verdict[i, s] = 0
        suspect[i, s] = False
