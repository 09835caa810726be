r"""Statistics for event counts: confidence intervals and streamed distributions.

Two intervals, both for counts of events:

* **Wilson score interval** for a proportion :math:`\hat p = k/n` (Wilson, *JASA* 22:209,
  1927), with :math:`z = \Phi^{-1}(1 - \alpha/2)`:

  .. math::
      \frac{k + z^2/2}{n + z^2} \pm \frac{z}{n + z^2}\sqrt{\frac{k(n-k)}{n} + \frac{z^2}{4}}

  It keeps its coverage near 0 and 1 (unlike the normal approximation), which is where miss
  rates and false-alarm ratios live.
* **Exact (Garwood) interval** for a Poisson rate: :math:`k` events over an exposure
  :math:`E` (hours, or units of 100 km), :math:`\lambda = k/E` (Garwood, *Biometrika* 28:437,
  1936):

  .. math::
      \lambda_{lo} = \frac{\chi^2_{2k}(\alpha/2)}{2E}\ (0 \text{ if } k = 0), \qquad
      \lambda_{hi} = \frac{\chi^2_{2k+2}(1 - \alpha/2)}{2E}

Both are vectorised over numpy arrays; scalars in give floats out.

:class:`Histogram` summarises a stream of values in constant memory (fixed bins, a running
sum), so a mean and quantiles can be reported for runs of any length and histograms of
parallel runs add exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from acc_fusion.core.distributions import chi2_ppf, norm_ppf
from acc_fusion.core.errors import InputError
from acc_fusion.core.validation import check_range


def _counts(name: str, value: object) -> np.ndarray:
    """``value`` as a float array of whole numbers >= 0, else :class:`InputError`."""
    arr = np.asarray(value, dtype=float)
    bad = ~np.isfinite(arr) | (arr < 0) | (arr != np.floor(arr))
    if np.any(bad):
        raise InputError(f"{name} must be a whole number >= 0, got {arr[bad].flat[0]:g}")
    return arr


def _alpha(confidence: float) -> float:
    return 1.0 - check_range("confidence", confidence, 0.0, 1.0, lo_open=True, hi_open=True)


def _out(x: np.ndarray) -> float | np.ndarray:
    return float(x) if np.ndim(x) == 0 else x


def wilson_interval(
    k: float | np.ndarray, n: float | np.ndarray, confidence: float = 0.95
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """Wilson score interval ``(lo, hi)`` for ``k`` successes in ``n`` trials (n = 0: (0, 1)).

    >>> lo, hi = wilson_interval(0, 10)
    >>> round(lo, 4), round(hi, 4)
    (0.0, 0.2775)
    """
    k, n = np.broadcast_arrays(_counts("k", k), _counts("n", n))
    over = k > n
    if np.any(over):
        raise InputError(f"k must be at most n, got k = {k[over][0]:g} with n = {n[over][0]:g}")
    z = norm_ppf(1.0 - _alpha(confidence) / 2.0)
    safe_n = np.where(n > 0, n, 1.0)
    centre = (k + z * z / 2.0) / (safe_n + z * z)
    half = z / (safe_n + z * z) * np.sqrt(k * (safe_n - k) / safe_n + z * z / 4.0)
    # Exact limits at k = 0 and k = n (which also covers n = 0), free of rounding.
    lo = np.where(k > 0, np.clip(centre - half, 0.0, 1.0), 0.0)
    hi = np.where(k < n, np.clip(centre + half, 0.0, 1.0), 1.0)
    return _out(lo), _out(hi)


def poisson_rate_interval(
    k: float | np.ndarray, exposure: float | np.ndarray, confidence: float = 0.95
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """Exact (Garwood) interval ``(lo, hi)`` for the rate of ``k`` events over ``exposure``.

    ``exposure`` is in the unit the rate is wanted per (hours, units of 100 km); zero
    exposure gives (0, inf).

    >>> lo, hi = poisson_rate_interval(0, 1.0)
    >>> lo, round(hi, 4)
    (0.0, 3.6889)
    """
    k = _counts("k", k)
    exposure = np.asarray(exposure, dtype=float)
    if np.any(~np.isfinite(exposure) | (exposure < 0)):
        raise InputError("exposure must be a finite number >= 0")
    alpha = _alpha(confidence)
    with np.errstate(divide="ignore", invalid="ignore"):
        lo = np.where(k > 0, chi2_ppf(alpha / 2.0, np.maximum(2.0 * k, 1.0)) / 2.0, 0.0)
        hi = chi2_ppf(1.0 - alpha / 2.0, 2.0 * k + 2.0) / 2.0
        lo = np.where(exposure > 0, lo / exposure, 0.0)
        hi = np.where(exposure > 0, hi / exposure, np.inf)
    return _out(lo), _out(hi)


@dataclass(frozen=True)
class Rate:
    """A rate or proportion with its confidence interval ``[lo, hi]`` (NaN value if undefined)."""

    value: float
    lo: float
    hi: float

    @classmethod
    def poisson(cls, k: int, exposure: float, confidence: float = 0.95) -> Rate:
        """``k`` events per unit of ``exposure``, with the exact Poisson interval."""
        lo, hi = poisson_rate_interval(k, exposure, confidence)
        return cls(k / exposure if exposure > 0 else math.nan, lo, hi)

    @classmethod
    def proportion(cls, k: int, n: int, confidence: float = 0.95) -> Rate:
        """The proportion ``k / n``, with the Wilson interval."""
        lo, hi = wilson_interval(k, n, confidence)
        return cls(k / n if n > 0 else math.nan, lo, hi)

    def format(self, spec: str = ".3g") -> str:
        """``"3.2 [1.1, 7.4]"``: the value and its interval."""
        return f"{self.value:{spec}} [{self.lo:{spec}}, {self.hi:{spec}}]"


@dataclass(frozen=True)
class Distribution:
    """Summary of a streamed sample: ``count`` values, of which ``finite`` were finite.

    ``mean`` is over the finite values; the quantiles are over all of them, to within one
    histogram bin, and are ±inf when they lie beyond the histogram's range.  Everything is
    NaN for an empty sample.
    """

    count: int
    finite: int
    mean: float
    p10: float
    median: float
    p90: float

    def format(self, spec: str = ".3g") -> str:
        """``"mean 0.52, p10 0.3, median 0.5, p90 0.8 (n = 12)"``."""
        return (
            f"mean {self.mean:{spec}}, p10 {self.p10:{spec}}, median {self.median:{spec}}, "
            f"p90 {self.p90:{spec}} (n = {self.count})"
        )


class Histogram:
    """Fixed-width bins over ``[lo, hi)`` plus an underflow and an overflow bin.

    Memory is constant whatever the number of values added; :meth:`merge` adds another
    histogram with the same bins exactly.  Quantiles interpolate linearly inside a bin, so
    they are exact to one bin width.
    """

    def __init__(self, lo: float, hi: float, width: float) -> None:
        self.lo = float(lo)
        self.width = float(width)
        self.counts = np.zeros(round((hi - lo) / width) + 2, dtype=np.int64)
        self.finite = 0
        self.finite_sum = 0.0

    def add(self, values: np.ndarray) -> None:
        """Add values (finite or ±inf; NaN is not allowed)."""
        v = np.asarray(values, dtype=float).ravel()
        if v.size == 0:
            return
        finite = np.empty(v.size)
        n_finite = _bin(v, self.lo, self.width, self.counts, finite)
        if n_finite < 0:
            raise InputError("histogram values must not be NaN")
        self.finite += n_finite
        self.finite_sum += float(finite[:n_finite].sum())

    def merge(self, other: Histogram) -> None:
        """Add the counts of ``other`` (which must have the same bins)."""
        if (other.lo, other.width, other.counts.size) != (self.lo, self.width, self.counts.size):
            raise InputError("histograms can only be merged when their bins are the same")
        self.counts += other.counts
        self.finite += other.finite
        self.finite_sum += other.finite_sum

    def quantile(self, q: float) -> float:
        """The ``q`` quantile (0 < q < 1); NaN when empty, ±inf when beyond the bins."""
        cum = np.cumsum(self.counts)
        if cum[-1] == 0:
            return math.nan
        rank = q * cum[-1]
        i = int(np.searchsorted(cum, rank, side="left"))
        if i == 0:
            return -math.inf
        if i == self.counts.size - 1:
            return math.inf
        frac = (rank - cum[i - 1]) / self.counts[i]
        return self.lo + (i - 1 + frac) * self.width

    def distribution(self) -> Distribution:
        """Count, mean of the finite values, and the 10 %, 50 % and 90 % quantiles."""
        return Distribution(
            count=int(self.counts.sum()),
            finite=self.finite,
            mean=self.finite_sum / self.finite if self.finite else math.nan,
            p10=self.quantile(0.1),
            median=self.quantile(0.5),
            p90=self.quantile(0.9),
        )


@njit(cache=True, error_model="numpy")  # IEEE division, as numpy
def _bin(values, lo, width, counts, finite):  # pragma: no cover - compiled
    """Count ``values`` into the bins ``counts`` of :class:`Histogram` (bin
    ``floor((v - lo) / width) + 1``, clipped to the underflow and overflow bins) and copy the
    finite ones to the front of ``finite``; their number, or -1 (and nothing counted) if a
    value is NaN."""
    for v in values:
        if np.isnan(v):
            return -1
    n_finite = 0
    last = counts.size - 1
    for v in values:
        x = np.floor((v - lo) / width) + 1.0
        counts[0 if x <= 0.0 else (last if x >= last else int(x))] += 1
        if np.isfinite(v):
            finite[n_finite] = v
            n_finite += 1
    return n_finite
