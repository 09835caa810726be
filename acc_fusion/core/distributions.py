"""The quantiles of the χ², normal and binomial distributions that the pipeline needs.

``scipy.stats`` takes about 0.8 s to import (it imports ``scipy.optimize``,
``scipy.sparse`` and ``scipy.spatial``), paid by every process that simulates: each
``acc-fusion`` command and each worker of a sweep or of ``--seeds``. These functions call the
``scipy.special`` functions that ``scipy.stats`` itself calls for the same quantities
(``chi2.ppf`` is ``2·gammaincinv(df/2, q)``, ``norm.ppf`` is ``ndtri(q)``), so their results are
``scipy.stats``' bit for bit; ``tests/test_distributions.py`` holds them equal.
"""

from __future__ import annotations

import numpy as np
from scipy import special


def chi2_ppf(q, df):
    """The ``q`` quantile of χ² with ``df`` degrees of freedom (``scipy.stats.chi2.ppf``):
    :math:`x = 2\\,P^{-1}(df/2, q)`, the inverse of the regularised lower incomplete gamma
    function; 0 at ``q = 0``, ``inf`` at ``q = 1``, NaN outside [0, 1] or for ``df <= 0``."""
    q, df = np.asarray(q, dtype=float), np.asarray(df, dtype=float)
    with np.errstate(invalid="ignore"):
        x = 2.0 * special.gammaincinv(df / 2.0, q)
    x = np.where((q < 0) | (q > 1) | ~(df > 0), np.nan, x)
    return x[()] if x.ndim == 0 else x


def norm_ppf(q):
    """The ``q`` quantile of the standard normal distribution (``scipy.stats.norm.ppf``)."""
    return special.ndtri(q)


def binom_isf(q: float, n: int, p: float) -> int:
    """The smallest count ``m`` with :math:`P(X > m) \\le q` for :math:`X \\sim Bin(n, p)`
    (``scipy.stats.binom.isf`` for ``0 < q < 1``), from the exact survival function
    ``bdtrc(m, n, p)``."""
    for m in range(int(n) + 1):
        if special.bdtrc(m, int(n), p) <= q:
            return m
    return int(n)
