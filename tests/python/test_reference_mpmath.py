"""The exact laws against 40-digit references from mpmath, where Boost/scipy are not accurate.

At n = 1e12..1e15 scipy.stats.binom (Boost underneath) loses digits (P(K = 0) at n = 1e12,
p = 1e-12 is off by 2e-5), so the references here are mpmath's loggamma and explicit sums.
Deterministic: no randomness, tolerances are accuracy claims (README, "What is exact").
"""
import math

import mpmath as mp
import numpy as np
import pytest

import glintlab as gl

mp.mp.dps = 40


def ref_logpmf(k, n, p):
    n, k, p = mp.mpf(n), mp.mpf(k), mp.mpf(p)
    return (mp.loggamma(n + 1) - mp.loggamma(k + 1) - mp.loggamma(n - k + 1)
            + k * mp.log(p) + (n - k) * mp.log1p(-p))


def ref_upper_tail(k, n, p):
    """P(K > k) by an explicit sum of the pmf from k + 1 up (40 digits)."""
    n_, p_ = mp.mpf(n), mp.mpf(p)
    q = 1 - p_
    j = k + 1
    f = mp.exp(ref_logpmf(j, n, p))
    total = mp.mpf(0)
    while f > total * mp.mpf(10) ** -30 and j <= n:
        total += f
        f *= (n_ - j) / (j + 1) * p_ / q
        j += 1
    return total


@pytest.mark.parametrize("n", [1e9, 1e12, 1e15])
@pytest.mark.parametrize("p", [1e-300, 1e-13, 1e-6, 0.3, 0.5, 1 - 1e-7])
def test_logpmf_against_mpmath(n, p):
    mean, sd = n * p, math.sqrt(n * p * (1 - p))
    for z in (-6, -1, 0, 0.5, 3, 8):
        k = min(max(math.floor(mean + z * sd), 0), n)
        want = ref_logpmf(k, n, p)
        got = float(gl.binomial.logpmf(k, n, p))
        if want < -700:  # pmf underflows in double: compare the log itself
            assert got == pytest.approx(float(want), rel=1e-12), (k, n, p)
        else:  # the pmf to 1e-9 relative (log error 1e-9 absolute)
            assert abs(got - float(want)) < 1e-9, (k, n, p, got, float(want))


@pytest.mark.parametrize("n,p", [(1e4, 0.3), (1e6, 1e-3), (2e6, 0.5), (1e12, 1e-9), (1e15, 1e-13)])
def test_tail_masses_against_mpmath(n, p):
    mean, sd = n * p, math.sqrt(n * p * (1 - p))
    for z in (-4, -1, 0, 1, 4, 9):
        k = max(math.floor(mean + z * sd), 0)
        up = ref_upper_tail(k, n, p)
        got_up, got_lo = float(gl.binomial.sf(k, n, p)), float(gl.binomial.cdf(k, n, p))
        if up < 0.5:
            assert got_up == pytest.approx(float(up), rel=1e-10), (k, n, p)
        else:
            assert got_lo == pytest.approx(float(1 - up), rel=1e-10), (k, n, p)


@pytest.mark.parametrize("lam", [0.5, 30.0, 1e4, 1e8])
def test_poisson_tails_against_mpmath(lam):
    for z in (-5, 0, 0.7, 6):
        k = max(math.floor(lam + z * math.sqrt(lam)), 0)
        want_lo = mp.gammainc(k + 1, lam, mp.inf, regularized=True)  # P(K <= k) = Q(k + 1, lam)
        got_lo, got_up = float(gl.poisson.cdf(k, lam)), float(gl.poisson.sf(k, lam))
        if want_lo < 0.5:
            assert got_lo == pytest.approx(float(want_lo), rel=1e-10), (k, lam)
        else:
            assert got_up == pytest.approx(float(1 - want_lo), rel=1e-10), (k, lam)


def test_huge_n_distribution_mass_and_moments():
    d = gl.law("binomial").pmf(1e15, 1e-12)  # mean 1000
    assert abs(d.probs.sum() - 1) < 1e-12
    assert d.mean == pytest.approx(1000, rel=1e-12)
    assert d.var == pytest.approx(1e15 * 1e-12 * (1 - 1e-12), rel=1e-10)
    assert np.all(np.diff(d.support) == 1)
