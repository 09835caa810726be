"""The quantiles of acc_fusion.core.distributions equal scipy.stats' bit for bit."""

import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import binom, chi2, norm

from acc_fusion.core.distributions import binom_isf, chi2_ppf, norm_ppf
from acc_fusion.fusion.variance_test import NOISE_TERM_PROB


def test_chi2_and_normal_quantiles_are_scipy_stats_bit_for_bit():
    rng = np.random.default_rng(0)
    q = np.concatenate([rng.uniform(0, 1, 5000), [0.0, 1.0, 0.5, 0.025, 0.975, -0.1, 1.1]])
    df = np.concatenate([rng.uniform(0.05, 500, 5000), [1, 2, 3, 0.0, -1.0, 4, 5]])
    np.testing.assert_array_equal(chi2_ppf(q, df), chi2.ppf(q, df))
    np.testing.assert_array_equal(norm_ppf(q), norm.ppf(q))
    for qq, d in [(0.975, 1), (0.01, 2), (0.5, 1), (1e-5, 40)]:
        assert chi2_ppf(qq, d) == chi2.ppf(qq, d)
        assert np.ndim(chi2_ppf(qq, d)) == 0


@pytest.mark.parametrize("q", [1e-9, 1e-6, 1e-5, 1e-3, 0.02, 0.1])
def test_binomial_isf_is_scipy_stats_for_the_noise_burst_test(q):
    p = 1.0 - NOISE_TERM_PROB
    for n in range(1, 300):
        assert binom_isf(q, n, p) == binom.isf(q, n, p), n


def test_binomial_isf_is_the_smallest_count_beyond_which_the_tail_is_at_most_q():
    assert binom_isf(0.3, 10, 0.5) == 6  # P(X > 6) = 0.172 <= 0.3 < P(X > 5) = 0.377
    assert binom_isf(1e-12, 4, 0.5) == 4


def test_a_simulation_does_not_import_scipy_stats_matplotlib_nor_filterpy():
    """Each takes 0.5-1 s to import, paid by every command and every worker of a sweep."""
    code = (
        "import sys, acc_fusion.sweep.chunks, acc_fusion.cli.main\n"
        "from acc_fusion.sim.closed_loop import SimConfig, simulate\n"
        "simulate(SimConfig(runs=2, duration=1.0, seed=0))\n"
        "print(sorted(m for m in ('scipy.stats', 'matplotlib', 'filterpy') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
