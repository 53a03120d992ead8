"""numpy/scipy interoperability: cdf/sf/ppf against scipy's binomial, pickling and printing of the
result types, unpacking like scipy's results, equality of laws, and the two-sample chi-square test
(shown to reject two different laws and to keep its false-rejection rate on equal ones)."""
import pickle

import numpy as np
import pytest
import scipy.stats

import glintlab as gl


def test_cdf_sf_ppf_match_scipy_binomial_vectorized():
    law = gl.law("binomial")
    k = np.arange(-1, 18)[:, None]
    n, p = np.array([16.0, 17.0]), np.array([0.1, 0.7])
    np.testing.assert_allclose(law.cdf(k, n, p), scipy.stats.binom.cdf(k, n, p), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(law.sf(k, n, p), scipy.stats.binom.sf(k, n, p), rtol=1e-9, atol=1e-14)
    q = np.array([0.0 + 1e-12, 0.01, 0.3, 0.5, 0.9, 0.999])[:, None]
    np.testing.assert_array_equal(law.ppf(q, n, p), scipy.stats.binom.ppf(q, n, p))
    assert np.ndim(law.cdf(3, 16, 0.5)) == 0
    # sf from the upper tail: far in it, 1 - cdf would be 0.
    assert law.sf(15, 16, 0.01) == pytest.approx(16 * 0.01 ** 15 * 0.99 + 0.01 ** 16, rel=1e-9)


def test_cdf_bad_input_is_named():
    law = gl.law("gated")
    with pytest.raises(ValueError, match="q = 1.5"):
        law.ppf(1.5, 16, 0.1)
    with pytest.raises(ValueError, match="^k = "):
        law.cdf("x", 16, 0.1)
    with pytest.raises(NotImplementedError):
        gl.custom_law(lambda n, p, u: n * p + 0 * u[..., 0], 1, name="nopmf").cdf(1, 16, 0.1)


def test_result_types_print_pickle_and_unpack():
    d = gl.law("gated").pmf(16, 0.3)
    d2 = pickle.loads(pickle.dumps(d))
    np.testing.assert_array_equal(d2.support, d.support)
    np.testing.assert_array_equal(d2.probs, d.probs)
    assert (d2.trimmed_below, d2.trimmed_above) == (d.trimmed_below, d.trimmed_above)
    assert repr(d).startswith("Distribution(") and "mean=" in repr(d)
    x = gl.law("gated").sample(16, 0.3, size=5000, seed=2)
    r = gl.chi2_test(x, d)
    stat, pvalue = r
    assert (stat, pvalue) == (r.statistic, r.pvalue) and r[0] == stat and r[-1] == pvalue
    r2 = pickle.loads(pickle.dumps(r))
    assert (r2.statistic, r2.pvalue, r2.dof, r2.samples, r2.note) == (r.statistic, r.pvalue, r.dof, r.samples, r.note)
    np.testing.assert_array_equal(r2.observed, r.observed)
    assert "pvalue=" in repr(r)
    assert gl.Distribution.__doc__ and gl.Chi2Result.__doc__


def test_equal_laws_compare_equal():
    assert gl.law("gaussian") == gl.law("gaussian")
    assert gl.law("gaussian", rounding="round") != gl.law("gaussian")
    assert gl.law("gated") != gl.law("head_cf")
    assert len({gl.law("gated"), gl.law("gated"), gl.law("head_cf")}) == 2
    assert pickle.loads(pickle.dumps(gl.law("zk16", cap=4))) == gl.law("zk16", cap=4)
    f = lambda n, p, u: np.floor(n * p + u[..., 0])  # noqa: E731
    assert gl.custom_law(f, 1, name="same") == gl.custom_law(f, 1, name="same")
    assert gl.custom_law(f, 1, name="same") != gl.custom_law(f, 1, name="other")


def test_two_sample_chi2_rejects_different_laws_and_not_equal_ones():
    binomial, gated = gl.law("binomial"), gl.law("gated")
    # Different laws (gated at p = 0.9 is far from the binomial: TV ~0.9): rejected.
    a = binomial.sample(16, 0.9, size=4000, seed=1)
    b = gated.sample(16, 0.9, size=4000, seed=2)
    assert gl.chi2_test_two_sample(a, b).pvalue < 1e-6
    # The same law, 200 independent pairs: the rejection rate at alpha = 0.05 is 0.05. With 200
    # trials the count of rejections is Binomial(200, 0.05); it exceeds 22 with probability ~1e-5,
    # and so does it fall below 1 (the bounds, fixed seeds, false failure < 1e-4).
    rejections = sum(gl.chi2_test_two_sample(binomial.sample(40, 0.3, size=300, seed=2 * i),
                                             binomial.sample(40, 0.3, size=500, seed=2 * i + 1)).pvalue < 0.05
                     for i in range(200))
    assert 1 <= rejections <= 22, rejections
    # Agrees with scipy's contingency test on the same merged table.
    a = binomial.sample(8, 0.5, size=2000, seed=5)
    b = binomial.sample(8, 0.5, size=1000, seed=6)
    r = gl.chi2_test_two_sample(a, b)
    ob = np.array([np.sum((b >= lo) & (b <= hi)) for lo, hi in zip(r.lower, r.upper)])
    ref = scipy.stats.chi2_contingency(np.vstack([r.observed, ob]), correction=False)
    assert r.statistic == pytest.approx(ref.statistic, rel=1e-10) and r.dof == ref.dof
    assert r.pvalue == pytest.approx(ref.pvalue, rel=1e-8)


def test_two_sample_chi2_without_power_says_so():
    r = gl.chi2_test_two_sample([0.0, 1.0, 1.0], [5.0, 6.0])
    assert np.isnan(r.pvalue) and "no power" in r.note
    with pytest.raises(ValueError, match="^a = "):
        gl.chi2_test_two_sample([], [1.0])
    with pytest.raises(ValueError, match="^b = nan"):
        gl.chi2_test_two_sample([1.0], [np.nan])
