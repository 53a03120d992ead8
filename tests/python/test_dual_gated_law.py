"""dual_gated's central part is 1 + Binomial(n - 2, p) in its normal form (docs/math/laws.md#law-dual-gated),
not the binomial conditioned on 1 <= K <= n - 1 (issue 31, item 17): the exact pmf, the sampler and the
page's formula agree at n = 4, p = 0.1, where the two readings differ (central mean 1.2 against the
conditional 1.1623). Thresholds: a chi-square p-value below 1e-3 fails (false-failure rate 1e-3); the
wrong reading must get a p-value below 1e-9."""
from __future__ import annotations

import math

import numpy as np

import glintlab as gl

N, P = 4, 0.1


def _phi(x):
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


def doc_pmf(n, p, mean, sd):
    """The page's formula at an integer n >= 2: K = n with probability p^n, K = 0 with (1 - p)^n, and the
    central normal N(mean, sd) clamped to [1, n - 1] and rounded half up with the rest."""
    q = 1.0 - p
    central = 1.0 - p**n - q**n
    probs = {0: q**n, n: p**n}
    for k in range(1, n):
        lo = -math.inf if k == 1 else (k - 0.5 - mean) / sd
        hi = math.inf if k == n - 1 else (k + 0.5 - mean) / sd
        probs[k] = central * (_phi(hi) - _phi(lo))
    ks = np.arange(n + 1, dtype=float)
    return gl.Distribution(ks, np.array([probs[k] for k in range(n + 1)]))


def conditional_binomial_moments(n, p):
    """Mean and sd of Binomial(n, p) conditioned on 1 <= K <= n - 1."""
    k = np.arange(1, n)
    w = np.array([math.comb(n, int(j)) * p**j * (1 - p) ** (n - j) for j in k])
    w /= w.sum()
    mean = float((k * w).sum())
    return mean, math.sqrt(float(((k - mean) ** 2 * w).sum()))


def test_dual_gated_pmf_sampler_and_doc_formula_agree_at_n4():
    law = gl.law("dual_gated")
    exact = law.pmf(N, P)
    # The page's formula, with the central part 1 + Binomial(n - 2, p): mean 1.2, sd sqrt(0.18).
    doc = doc_pmf(N, P, 1 + (N - 2) * P, math.sqrt((N - 2) * P * (1 - P)))
    np.testing.assert_array_equal(exact.support, doc.support)
    np.testing.assert_allclose(exact.probs, doc.probs, rtol=1e-12, atol=1e-15)
    # The sampler against the exact pmf (chi-square, 2e5 samples).
    x = law.bin(law.sample(N, P, size=200_000, seed=17))
    r = gl.chi2_test(x, exact)
    assert r.pvalue > 1e-3, (r.pvalue, r.note)
    # The other reading (the conditional binomial's moments: mean 1.1623) is a different law that the
    # same samples reject: the test above can tell the two apart.
    mean_c, sd_c = conditional_binomial_moments(N, P)
    assert abs(mean_c - 1.1623) < 1e-4
    wrong = doc_pmf(N, P, mean_c, sd_c)
    assert gl.chi2_test(x, wrong).pvalue < 1e-9
