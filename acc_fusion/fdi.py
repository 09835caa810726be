r"""Fault detection and isolation: a windowed chi-square test on each sensor's NIS.

For every pair and sensor the fusion center computes the normalised innovation squared of
the sensor's measurement against its own one-step prediction,
:math:`\epsilon_\nu = \nu^\top S^{-1}\nu` with :math:`S = H P^- H^\top + R`, which is
:math:`\chi^2_m` distributed (m = 2: range and range-rate) for a healthy sensor and a
consistent filter (Bar-Shalom, Li & Kirubarajan 2001, §5.4; in fusion-reset mode this is the
local filter's own innovation with its information share undone).  Two tests use it:

* **Gate** (per report): a measurement with :math:`\epsilon_\nu > \chi^2_{m}(p_g)` is not used
  in the update (an outlier: a spike, a ghost, the first report of a bias).  When two or
  more non-isolated sensors of a pair have reported within the last ``common_steps`` steps
  and the latest report of *every one* failed the gate, the cause is common to all of them
  (a manoeuvre the motion model did not expect, such as the ego's own hard braking), so the
  measurements are used and not counted as evidence of a fault.
* **Window** (per sensor): the sum of the last W NIS values, each clipped at
  :math:`\chi^2_m(p_c)`, is compared with :math:`\chi^2_{mW}(1-\alpha)`.  A failing sensor is
  *isolated*: left out of the fusion.  Its window is then refilled with its NIS against the
  fusion center's prediction, and when a full window passes the test again the sensor
  rejoins (the fusion center re-initialises its local filter from the fused estimate).
  Clipping keeps one spike from isolating a sensor (it adds at most
  :math:`\chi^2_m(p_c)` = 9.2 for m = 2), while a persistent fault (bias, stuck value, noise
  burst) fills the window with large values and isolates it after W reports.

The state (windows, isolation flags) is per pair and per sensor, stored in arrays, so the
test costs a few vector operations per step whatever the number of pairs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from acc_fusion.errors import ConfigError
from acc_fusion.validation import check_range


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
    """

    window: int = 10
    alpha: float = 0.001
    gate_prob: float = 0.9999
    clip_prob: float = 0.99
    confirm_tracks: bool = True
    common_steps: int = 3

    def __post_init__(self) -> None:
        if not isinstance(self.window, int) or not 1 <= self.window <= 10_000:
            raise ConfigError(
                f"fdi.window must be a whole number in [1, 10000], got {self.window!r}"
            )
        check_range("fdi.alpha", self.alpha, 0.0, 1.0, lo_open=True, hi_open=True)
        check_range("fdi.gate_prob", self.gate_prob, 0.0, 1.0, lo_open=True, hi_open=True)
        check_range("fdi.clip_prob", self.clip_prob, 0.0, 1.0, lo_open=True, hi_open=True)
        if not isinstance(self.common_steps, int) or not 0 <= self.common_steps <= 1000:
            raise ConfigError(
                f"fdi.common_steps must be a whole number in [0, 1000], got {self.common_steps!r}"
            )


class WindowedChiSquare:
    """Per pair and per sensor NIS gate and window test (see the module docstring)."""

    def __init__(self, n_pairs: int, n_sensors: int, config: FDIConfig, dof: int = 2) -> None:
        self.config = config
        w = int(config.window)
        self.gate = float(chi2.ppf(config.gate_prob, dof))
        self.clip = float(chi2.ppf(config.clip_prob, dof))
        self.threshold = float(chi2.ppf(1.0 - config.alpha, dof * w))
        self._buf = np.zeros((n_pairs, n_sensors, w))
        self._sum = np.zeros((n_pairs, n_sensors))
        self._count = np.zeros((n_pairs, n_sensors), dtype=np.int64)
        self._pos = np.zeros((n_pairs, n_sensors), dtype=np.int64)
        self.isolated = np.zeros((n_pairs, n_sensors), dtype=bool)
        self._verdict = np.zeros((n_pairs, n_sensors), dtype=np.int8)
        self._age = np.zeros((n_pairs, n_sensors), dtype=np.int64)

    def reset(self, pairs: np.ndarray) -> None:
        """Forget windows and isolation of the pairs in the boolean mask ``pairs``."""
        self._clear(pairs)
        self.isolated[pairs] = False
        self._verdict[pairs] = 0

    def _clear(self, mask: np.ndarray) -> None:
        self._buf[mask] = 0.0
        self._sum[mask] = 0.0
        self._count[mask] = 0
        self._pos[mask] = 0

    def step(self, nis: np.ndarray, reported: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Test one step of NIS values ``(N, S)`` where ``reported (N, S)``.

        Returns ``(accepted, rejoined)``: the measurements to use in the update, and the
        sensors that passed a full window while isolated and rejoin now.  ``self.isolated``
        holds the isolation state after this step.
        """
        passed = reported & (nis <= self.gate)
        healthy = reported & ~self.isolated
        # Each sensor's latest gate verdict (1 pass, 2 fail) and its age in steps.
        self._verdict = np.where(reported, np.where(passed, 1, 2), self._verdict)
        self._age = np.where(reported, 0, self._age + 1)
        recent = ~self.isolated & (self._verdict > 0) & (self._age <= self.config.common_steps)
        # Common cause: two or more healthy sensors have a recent verdict and all failed.
        common = (recent.sum(axis=1) >= 2) & ~(recent & (self._verdict == 1)).any(axis=1)
        accepted = healthy & (passed | common[:, None])
        record = reported & ~common[:, None]

        w = self._buf.shape[2]
        slot = self._pos[..., None]
        old = np.take_along_axis(self._buf, slot, axis=2)[..., 0]
        value = np.where(record, np.minimum(nis, self.clip), old)
        np.put_along_axis(self._buf, slot, value[..., None], axis=2)
        self._sum += value - old
        self._pos = np.where(record, (self._pos + 1) % w, self._pos)
        self._count = np.where(record, np.minimum(self._count + 1, w), self._count)

        full = self._count == w
        fail = full & (self._sum > self.threshold)
        newly = fail & ~self.isolated
        rejoined = full & ~fail & self.isolated
        self.isolated |= newly
        self.isolated &= ~rejoined
        self._clear(newly | rejoined)
        return accepted & ~newly, rejoined
