"""AnisoCounter.pmf over an inner law whose value leaves the integers ("threshold" above its T returns
the mean n p): a NotImplementedError that says why, not a RuntimeError from inside the convolution
(issue 31, item 16); below T the exact law still holds."""
from __future__ import annotations

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
