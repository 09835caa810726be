"""Confidence intervals and streamed histograms against scipy / numpy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binomtest, poisson

from acc_fusion.core.errors import AccFusionError, InputError
from acc_fusion.metrics.stats import Histogram, Rate, poisson_rate_interval, wilson_interval


@pytest.mark.parametrize("confidence", [0.9, 0.95, 0.99])
@pytest.mark.parametrize("k, n", [(0, 1), (1, 1), (0, 10), (10, 10), (3, 10), (7, 50), (1, 1000)])
def test_wilson_matches_scipy(k, n, confidence):
    ci = binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    lo, hi = wilson_interval(k, n, confidence)
    assert isinstance(lo, float) and isinstance(hi, float)
    assert lo == pytest.approx(ci.low, abs=1e-12)
    assert hi == pytest.approx(ci.high, abs=1e-12)


def test_wilson_edges_and_vectorised():
    assert wilson_interval(0, 0) == (0.0, 1.0)
    assert wilson_interval(0, 20)[0] == 0.0
    assert wilson_interval(20, 20)[1] == 1.0
    k = np.array([0, 4, 20, 0])
    n = np.array([20, 20, 20, 0])
    lo, hi = wilson_interval(k, n)
    assert lo.shape == hi.shape == (4,)
    for i in range(4):
        assert (lo[i], hi[i]) == pytest.approx(wilson_interval(int(k[i]), int(n[i])))


@pytest.mark.parametrize("confidence", [0.9, 0.95])
@pytest.mark.parametrize("k", [1, 2, 5, 40])
@pytest.mark.parametrize("exposure", [0.5, 3.0, 250.0])
def test_poisson_interval_is_exact(k, exposure, confidence):
    """The Garwood limits put exactly alpha/2 of the Poisson mass beyond k on each side."""
    alpha = 1.0 - confidence
    lo, hi = poisson_rate_interval(k, exposure, confidence)
    assert poisson.sf(k - 1, lo * exposure) == pytest.approx(alpha / 2, rel=1e-9)
    assert poisson.cdf(k, hi * exposure) == pytest.approx(alpha / 2, rel=1e-9)
    assert lo < k / exposure < hi


def test_poisson_interval_zero_count_and_exposure():
    lo, hi = poisson_rate_interval(0, 2.0)
    assert lo == 0.0
    assert hi == pytest.approx(-math.log(0.025) / 2.0, rel=1e-12)
    assert poisson_rate_interval(3, 0.0) == (0.0, math.inf)
    lo, hi = poisson_rate_interval(np.array([0, 3]), np.array([1.0, 2.0]))
    assert hi[1] == pytest.approx(poisson_rate_interval(3, 2.0)[1])


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: wilson_interval(-1, 5), "k must be a whole number >= 0, got -1"),
        (lambda: wilson_interval(6, 5), "k must be at most n, got k = 6 with n = 5"),
        (lambda: wilson_interval(1.5, 5), "k must be a whole number"),
        (lambda: wilson_interval(1, -5), "n must be a whole number >= 0"),
        (lambda: poisson_rate_interval(-2, 1.0), "k must be a whole number >= 0"),
        (lambda: poisson_rate_interval(2, -1.0), "exposure must be a finite number >= 0"),
    ],
)
def test_bad_input(call, match):
    with pytest.raises(InputError, match=match):
        call()


def test_bad_confidence():
    with pytest.raises(AccFusionError, match=r"confidence must be in \(0, 1\)"):
        wilson_interval(1, 5, confidence=1.5)


def test_rate():
    assert Rate(3.2, 1.1, 7.4).format() == "3.2 [1.1, 7.4]"
    r = Rate.poisson(4, 2.0)
    assert r.value == 2.0 and (r.lo, r.hi) == poisson_rate_interval(4, 2.0)
    p = Rate.proportion(1, 4)
    assert p.value == 0.25 and (p.lo, p.hi) == wilson_interval(1, 4)
    assert math.isnan(Rate.proportion(0, 0).value)


def test_histogram_quantiles_mean_and_merge():
    rng = np.random.default_rng(5)
    x = rng.normal(1.0, 0.7, 5000)
    a, b, whole = Histogram(-5, 5, 0.01), Histogram(-5, 5, 0.01), Histogram(-5, 5, 0.01)
    a.add(x[:3000])
    b.add(x[3000:])
    whole.add(x)
    a.merge(b)
    assert np.array_equal(a.counts, whole.counts)
    d = a.distribution()
    assert d.count == d.finite == 5000
    assert d.mean == pytest.approx(x.mean(), rel=1e-12)
    for q, got in ((0.1, d.p10), (0.5, d.median), (0.9, d.p90)):
        assert abs(got - np.quantile(x, q)) <= 0.011


def test_histogram_edges():
    h = Histogram(0, 10, 0.01)
    assert math.isnan(h.distribution().median)
    h.add([1.0, math.inf, math.inf, 20.0, -3.0])
    d = h.distribution()
    assert (d.count, d.finite) == (5, 3)
    assert d.mean == pytest.approx(6.0)
    assert d.p10 == -math.inf and d.median == math.inf
    with pytest.raises(InputError, match="bins are the same"):
        h.merge(Histogram(0, 10, 0.1))
