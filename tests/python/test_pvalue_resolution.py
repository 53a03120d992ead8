"""A p-value is never coarser than the alpha it is compared with (issue 31, item 8;
docs/math/metrics.md#metric-chi2-test): the small-sample exact likelihood-ratio test enumerates every
outcome when they are few, and otherwise bounds or refines its Monte Carlo estimate, reporting the
p-value's resolution."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import glintlab as gl


def _aon_samples():
    # Eight samples of an all-or-nothing law (K = 0 or 16 at n = 16, p = 0.1): TV ~ 1 to the binomial.
    aon = gl.custom_law(lambda n, p, u: (u[:, 0] < p) * n, n_uniforms=1, name="all_or_nothing_resolution_test")
    return aon.sample(16, 0.1, size=8, seed=2)


def test_all_or_nothing_law_fails_a_sidak_corrected_alpha():
    # A sweep of 10^4 cells at a family-wise 1e-3 tests each cell at about 1e-7: a p-value floored at
    # 1/(1 + 9999) = 1e-4 let the wrong law pass every cell. The exact enumeration gives ~1e-20.
    x = _aon_samples()
    alpha = gl.sidak_alpha(1e-3, 10**4)
    r = gl.chi2_test(x, gl.law("binomial").pmf(16, 0.1))
    assert r.pvalue < alpha and r.pvalue < 1e-15, (x, r.pvalue, r.note)
    assert r.resolution == 0.0 and "enumeration" in r.note, r.note
    # The binomial's own samples of the same size still pass at that alpha.
    ok = gl.chi2_test(gl.law("binomial").sample(16, 0.1, size=8, seed=2), gl.law("binomial").pmf(16, 0.1))
    assert ok.pvalue > alpha, ok


def _brute_force_pvalue(obs_counts, q):
    """P(G >= G_obs) over every count vector of the same size, written independently of the C++."""
    n = int(sum(obs_counts))

    def g(counts):
        return 2 * sum(o * math.log(o / (n * qk)) for o, qk in zip(counts, q) if o > 0)

    g_obs = g(obs_counts)
    total = 0.0
    for cells in itertools.combinations_with_replacement(range(len(q)), n):
        counts = np.bincount(cells, minlength=len(q))
        if g(counts) >= g_obs - 1e-9 * max(1.0, abs(g_obs)):
            prob = math.factorial(n) * math.prod(qk**o / math.factorial(o) for o, qk in zip(counts, q))
            total += prob
    return total


@pytest.mark.parametrize("sample", [[0, 0, 0], [1, 2, 2], [4, 4, 0, 4]])
def test_enumerated_pvalue_is_the_exact_one(sample):
    d = gl.law("binomial").pmf(4, 0.3)
    r = gl.chi2_test(np.array(sample, float), d)
    obs = np.bincount(np.array(sample), minlength=5)
    exact = _brute_force_pvalue(obs, np.asarray(d.probs) / np.sum(d.probs))
    assert r.dof == 0 and r.resolution == 0.0
    assert r.pvalue == pytest.approx(exact, rel=1e-10), (sample, r.pvalue, exact, r.note)


def test_monte_carlo_pvalue_refines_to_the_given_alpha():
    # Eight samples against Binomial(1000, 1/2) (about 10^15 possible count vectors: no enumeration,
    # and the method-of-types bound is 0.3), all on the value 520: without alpha the estimate stops at
    # its floor 1/(1 + 9999); with alpha = 5e-5 it draws on until its resolution is below alpha and the
    # decision is clear (640k draws).
    d = gl.law("binomial").pmf(1000, 0.5)
    x = np.full(8, 520.0)
    coarse = gl.chi2_test(x, d)
    assert coarse.resolution == pytest.approx(1 / 10000) and coarse.pvalue == pytest.approx(1 / 10000), coarse.note
    fine = gl.chi2_test(x, d, alpha=5e-5)
    assert fine.resolution < 5e-5 and fine.pvalue < 5e-5, fine.note
    # A sample of the law itself is decided the other way at once (no extra draws needed).
    y = gl.law("binomial").sample(1000, 0.5, size=8, seed=4)
    ok = gl.chi2_test(y, d, alpha=5e-5)
    assert ok.pvalue > 5e-5 and ok.resolution == pytest.approx(1 / 10000), ok.note
    with pytest.raises(ValueError, match="alpha"):
        gl.chi2_test(y, d, alpha=1.5)


def test_chi2_result_pickles_its_resolution():
    import pickle
    r = gl.chi2_test(np.full(8, 520.0), gl.law("binomial").pmf(1000, 0.5))
    assert pickle.loads(pickle.dumps(r)).resolution == r.resolution > 0


def test_glintlab_check_does_not_pass_a_minimum_below_the_pvalue_resolution():
    # A chi2_pvalue bound of 1e-6 on 8 samples at n = 1000: the small-sample test runs by Monte Carlo
    # (resolution 1e-4). A law stuck at 520 gets p = 1e-4, which used to pass the bound; now the check
    # says the p-value cannot show p >= 1e-6. The binomial's own samples still pass.
    import json

    from glintlab.validation.bounds import DEFAULT_BOUNDS, check
    doc = json.loads(DEFAULT_BOUNDS.read_text())
    bound = {"id": "coarse", "law": "binomial", "metric": "chi2_pvalue", "minimum": 1e-6, "samples": 8, "seed": 2,
             "regime": {"n": [1000], "p": [0.5]}, "reference": {"law": "binomial"}}
    stuck = gl.custom_law(lambda n, p, u: 0 * u[:, 0] + 520.0, n_uniforms=1, name="stuck_at_520_resolution_test")
    bad = check(dict(doc, bounds=[bound]), substitute={"binomial": stuck})
    assert not bad.ok.iloc[0] and "resolution" in bad.note.iloc[0], bad.to_string()
    assert check(dict(doc, bounds=[bound])).ok.iloc[0]
