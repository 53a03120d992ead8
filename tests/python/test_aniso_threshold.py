"""AnisoCounter.pmf over an inner law whose value leaves the integers ("threshold" above its T returns
the mean n p): a NotImplementedError that says why, not a RuntimeError from inside the convolution
(issue 31, item 16); below T the exact law still holds."""
from __future__ import annotations

import re

import pytest

import glintlab as gl

N = 1024.0**2
A0 = 1.0 / N


def test_threshold_inner_law_above_t_has_no_exact_sum():
    c = gl.aniso_counter("db23_trilinear", inner="threshold", base_area=A0)
    assert c.has_pmf  # integer counts below T: the exact law exists there
    # Below T (n p well under 16 per term): the exact law, and the sampler agrees with it
    # (chi-square p-value above 1e-4: false-failure rate 1e-4).
    P, r, phi, p = 20 * A0, 3.0, 0.4, 0.3
    d = c.pmf(N, P, r, phi, p)
    assert abs(sum(d.probs) - 1) < 1e-12
    x = c.sample(N, P, r, phi, p, size=20_000, seed=3)
    assert gl.chi2_test(x, d).pvalue > 1e-4
    # Above T: a point mass at a non-integer n p per term; the sum has no exact law on counts.
    with pytest.raises(NotImplementedError, match=r"inner='threshold'.*non-integer value"):
        c.pmf(N, 3000 * A0, 3.0, 0.4, 0.37)


@pytest.mark.parametrize("blend, params", [("distributed", {}), ("nearest", {}), ("roulette", {"epsilon": 0.0}),
                                           ("zk16_linear", {})])
def test_every_blend_over_threshold_says_why_it_has_no_exact_law(blend, params):
    # The blends' pmf over "threshold" (issue 31, item 16's case for blended_law): above T a level's count
    # is the real number n p, and the blend's pmf must refuse by name (n and p), never fail inside the
    # convolution or scaled sum. Swept over level positions (P) and p, with T = 3 so that both levels
    # and one of them cross T.
    law = gl.blended_law(blend, inner=gl.law("threshold", T=3.0), **params)
    refused = 0
    for P in (0.3, 1.7, 2.5, 9.0):
        for p in (0.1, 0.37, 0.9):
            try:
                d = law.pmf(40.0, P, p)
            except NotImplementedError as e:
                refused += 1
                assert "inner='threshold'" in str(e) and "non-integer count" in str(e), str(e)
                named = re.search(r"at n = ([0-9.e+-]+), p = ([0-9.e+-]+)", str(e))
                assert named and float(named.group(2)) == p, str(e)
                continue
            assert abs(sum(d.probs) - 1) < 1e-12
    assert refused > 0
    # Below T everywhere (n p <= 1.6 per level: trials 4 and 16): the exact law, and the sampler agrees with it
    # (chi-square p-value above 1e-4: false-failure rate 1e-4 per blend).
    d = law.pmf(4.0, 1.7, 0.1)
    x = law.sample(4.0, 1.7, 0.1, size=20_000, seed=11)
    assert gl.chi2_test(law.bin(x), d).pvalue > 1e-4
    # The check has power: the same draws against the law at p = 0.13 fail it.
    assert gl.chi2_test(law.bin(x), law.pmf(4.0, 1.7, 0.13)).pvalue < 1e-4
