"""Distances (gl.distance) and the chi-square goodness-of-fit test (gl.chi2_test), docs/math/metrics.md.

Hand-worked cases first (each value derived in a comment), then the general properties (identity,
disjoint supports, symmetry), then agreement with scipy where scipy has the same quantity.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.spatial.distance
import scipy.stats as st

import glintlab as gl

D = gl.Distribution
METRICS = ["tv", "chi2_distance", "hellinger", "kl", "js", "w1", "ks"]
SYMMETRIC = [m for m in METRICS if m != "kl"]
LOG2 = math.log(2.0)


def test_metric_list():
    assert sorted(gl.METRICS) == sorted(METRICS), f"gl.METRICS = {gl.METRICS}"


# ----------------------------------------------------------------------------------------------
# Hand-worked cases
# ----------------------------------------------------------------------------------------------

# Case A: a = {0: 1/2, 1: 1/2}, b = {0: 1/4, 1: 3/4}.
#   tv        = 1/2 (|1/2 - 1/4| + |1/2 - 3/4|)                  = 1/4
#   chi2_dist = 1/2 ((1/4)^2 / (3/4) + (1/4)^2 / (5/4))          = 1/2 (1/12 + 1/20) = 1/15
#   hellinger = sqrt(1 - sum sqrt(a b)) = sqrt(1 - sqrt(1/8) - sqrt(3/8))
#   kl(a||b)  = 1/2 log(2) + 1/2 log(2/3)                        = 1/2 log(4/3)
#   kl(b||a)  = 1/4 log(1/2) + 3/4 log(3/2)
#   js        with m = {3/8, 5/8}: KL(a||m) = 1/2 log(4/3) + 1/2 log(4/5) = 1/2 log(16/15),
#             KL(b||m) = 1/4 log(2/3) + 3/4 log(6/5);  js = (KL(a||m) + KL(b||m)) / 2
#   w1        = |F_a(0) - F_b(0)| (1 - 0)                          = 1/4
#   ks        = max(|1/2 - 1/4|, |1 - 1|)                          = 1/4
CASE_A = (D([0.0, 1.0], [0.5, 0.5]), D([0.0, 1.0], [0.25, 0.75]), {
    "tv": 0.25,
    "chi2_distance": 1 / 15,
    "hellinger": math.sqrt(1 - math.sqrt(1 / 8) - math.sqrt(3 / 8)),
    "kl": 0.5 * math.log(4 / 3),
    "js": 0.5 * (0.5 * math.log(16 / 15) + 0.25 * math.log(2 / 3) + 0.75 * math.log(6 / 5)),
    "w1": 0.25,
    "ks": 0.25,
})

# Case B: a = {0: 0.2, 2: 0.5, 5: 0.3}, b = {1: 0.5, 2: 0.5}; union of supports 0, 1, 2, 5.
#   F_a = 0.2, 0.2, 0.7, 1 and F_b = 0, 0.5, 1, 1 at x = 0, 1, 2, 5.
#   tv        = 1/2 (0.2 + 0.5 + 0 + 0.3)                           = 0.5
#   chi2_dist = 1/2 (0.2^2/0.2 + 0.5^2/0.5 + 0 + 0.3^2/0.3)         = 0.5
#   hellinger = sqrt(1 - sqrt(0.5 * 0.5))                            = sqrt(1/2)
#   kl        = inf both ways (each puts mass where the other has none)
#   js        : where only one law has mass q, m = q/2 and that law contributes q/2 log 2;
#               at x = 2 a = b = m contributes 0: js = (0.2 + 0.5 + 0.3)/2 log 2 = log(2)/2
#   w1        = 0.2 (1 - 0) + |0.2 - 0.5| (2 - 1) + |0.7 - 1| (5 - 2) = 0.2 + 0.3 + 0.9 = 1.4
#   ks        = max(0.2, 0.3, 0.3, 0)                               = 0.3
CASE_B = (D([0.0, 2.0, 5.0], [0.2, 0.5, 0.3]), D([1.0, 2.0], [0.5, 0.5]), {
    "tv": 0.5,
    "chi2_distance": 0.5,
    "hellinger": math.sqrt(0.5),
    "kl": math.inf,
    "js": 0.5 * LOG2,
    "w1": 1.4,
    "ks": 0.3,
})


@pytest.mark.parametrize("metric", METRICS)
@pytest.mark.parametrize("case", [CASE_A, CASE_B], ids=["A-two-point", "B-three-point"])
def test_hand_worked(case, metric):
    a, b, expected = case
    got = gl.distance(a, b, metric)
    want = expected[metric]
    if math.isinf(want):
        assert got == math.inf, f"{metric}: got {got!r}, expected inf"
    else:
        assert got == pytest.approx(want, rel=1e-13, abs=1e-15), f"{metric}: got {got!r}, expected {want!r}"


def test_kl_is_not_symmetric():
    a, b, _ = CASE_A
    ab, ba = gl.distance(a, b, "kl"), gl.distance(b, a, "kl")
    assert ab == pytest.approx(0.5 * math.log(4 / 3), rel=1e-13)
    assert ba == pytest.approx(0.25 * math.log(0.5) + 0.75 * math.log(1.5), rel=1e-13)
    assert abs(ab - ba) > 1e-3


def test_kl_ignores_points_where_a_is_zero():
    # KL(a||b) with a = {0: 1}, b = {0: 1/2, 1: 1/2}: 1 log(1 / (1/2)) = log 2 (b's point 1 adds 0).
    assert gl.distance(D([0.0], [1.0]), D([0.0, 1.0], [0.5, 0.5]), "kl") == pytest.approx(LOG2, rel=1e-14)


# ----------------------------------------------------------------------------------------------
# General properties
# ----------------------------------------------------------------------------------------------

LAWS_FOR_PROPERTIES = [
    ("binomial(20, 0.3)", lambda: gl.law("binomial").pmf(20, 0.3)),
    ("poisson(7.5)", lambda: gl.law("poisson").pmf(7.5, 1.0)),
    ("three points", lambda: D([-1.5, 0.25, 10.0], [0.1, 0.6, 0.3])),
]


@pytest.mark.parametrize("metric", METRICS)
@pytest.mark.parametrize("name, make", LAWS_FOR_PROPERTIES, ids=[c[0] for c in LAWS_FOR_PROPERTIES])
def test_identity_gives_zero(name, make, metric):
    d = make()
    assert gl.distance(d, d, metric) == 0.0, f"{metric}({name}, itself) != 0"


@pytest.mark.parametrize("metric", METRICS)
def test_identity_of_samples_gives_zero(metric):
    samples = gl.law("binomial").sample(20, 0.3, size=5000, seed=11)
    assert gl.distance(samples, samples, metric) == 0.0, f"{metric}(samples, same samples) != 0 (n=20, p=0.3, seed=11)"
    shuffled = np.random.default_rng(12).permutation(samples)
    assert gl.distance(samples, shuffled, metric) == 0.0, f"{metric}(samples, shuffled samples) != 0"


DISJOINT_EXPECTED = {"tv": 1.0, "hellinger": 1.0, "js": LOG2, "kl": math.inf, "chi2_distance": 1.0}


@pytest.mark.parametrize("metric", sorted(DISJOINT_EXPECTED) + ["ks"])
@pytest.mark.parametrize("a, b, ks", [
    (D([0.0], [1.0]), D([1.0], [1.0]), 1.0),
    (D([0.0, 1.0], [0.3, 0.7]), D([2.0, 3.0, 7.0], [0.2, 0.2, 0.6]), 1.0),
    # interleaved: F_a - F_b at x = 0..4 is 0.5, -0.4, -0.15, -0.25, 0, so ks = 0.5, not 1
    (D([0.0, 2.0, 4.0], [0.5, 0.25, 0.25]), D([1.0, 3.0], [0.9, 0.1]), 0.5),
], ids=["points", "separated", "interleaved"])
def test_disjoint_supports(a, b, ks, metric):
    got, want = gl.distance(a, b, metric), ks if metric == "ks" else DISJOINT_EXPECTED[metric]
    if math.isinf(want):
        assert got == math.inf, f"{metric} on disjoint supports: {got!r}, expected inf"
    else:
        assert got == pytest.approx(want, rel=1e-14), f"{metric} on disjoint supports: {got!r}, expected {want!r}"


def test_w1_of_point_masses_is_their_distance():
    # W1(delta_x, delta_y) = |x - y|; a shifted law moves by the shift.
    assert gl.distance(D([2.0], [1.0]), D([7.5], [1.0]), "w1") == pytest.approx(5.5, rel=1e-15)
    a = gl.law("binomial").pmf(30, 0.4)
    shifted = D(a.support + 3.0, a.probs)
    assert gl.distance(a, shifted, "w1") == pytest.approx(3.0, rel=1e-12)


@pytest.mark.parametrize("metric", SYMMETRIC)
def test_symmetric_metrics(metric):
    a = gl.law("binomial").pmf(40, 0.3)
    b = gl.law("poisson").pmf(40, 0.3)
    ab, ba = gl.distance(a, b, metric), gl.distance(b, a, metric)
    assert ab > 0 and ab == pytest.approx(ba, rel=1e-12), f"{metric}: d(a, b) = {ab!r}, d(b, a) = {ba!r}"


def test_metric_orderings():
    """Standard inequalities between the distances (binomial(40, 0.3) vs Poisson(12))."""
    a, b = gl.law("binomial").pmf(40, 0.3), gl.law("poisson").pmf(40, 0.3)
    d = {m: gl.distance(a, b, m) for m in METRICS}
    assert d["hellinger"] ** 2 <= d["tv"] <= math.sqrt(2) * d["hellinger"], d   # H^2 <= TV <= sqrt(2) H
    assert d["tv"] <= math.sqrt(d["kl"] / 2), d                                 # Pinsker
    assert d["ks"] <= d["tv"], d
    assert d["js"] <= LOG2 and d["chi2_distance"] <= d["tv"], d


# ----------------------------------------------------------------------------------------------
# Against scipy
# ----------------------------------------------------------------------------------------------

SAMPLE_PAIRS = [
    pytest.param(lambda: (gl.law("binomial").sample(20, 0.3, size=4000, seed=21),
                          gl.law("binomial").sample(20, 0.35, size=3000, seed=22)), id="binomial-samples"),
    pytest.param(lambda: (np.random.default_rng(23).normal(0, 1, 2500),
                          np.random.default_rng(24).normal(0.3, 1.5, 1500)), id="real-valued-samples"),
    pytest.param(lambda: (np.array([0.0, 0, 1, 3]), np.array([1.0, 2, 2])), id="tiny"),
]


@pytest.mark.parametrize("make", SAMPLE_PAIRS)
def test_w1_matches_scipy_wasserstein(make):
    x, y = make()
    got, ref = gl.distance(x, y, "w1"), st.wasserstein_distance(x, y)
    assert got == pytest.approx(ref, rel=1e-12, abs=1e-14), f"w1 {got!r} vs scipy {ref!r}"


@pytest.mark.parametrize("make", SAMPLE_PAIRS)
def test_ks_matches_scipy_ks_2samp(make):
    x, y = make()
    got, ref = gl.distance(x, y, "ks"), st.ks_2samp(x, y).statistic
    assert got == pytest.approx(ref, rel=1e-12, abs=1e-15), f"ks {got!r} vs scipy {ref!r}"


def _common_support_pairs():
    rng = np.random.default_rng(31)
    pairs = []
    for size in (2, 5, 40):
        pa, pb = rng.random(size), rng.random(size)
        pairs.append((np.arange(size, dtype=float), pa / pa.sum(), pb / pb.sum()))
    b = gl.law("binomial").pmf(40, 0.3)
    pois = gl.law("poisson").pmf(40, 0.3)
    support = np.union1d(b.support, pois.support)

    def on_support(d):
        probs = dict(zip(d.support.tolist(), d.probs.tolist()))
        return np.array([probs.get(x, 0.0) for x in support.tolist()])

    pairs.append((support, on_support(b), on_support(pois)))
    return pairs


@pytest.mark.parametrize("support, pa, pb", _common_support_pairs(),
                         ids=["2-points", "5-points", "40-points", "binomial-vs-poisson"])
def test_js_and_kl_match_scipy(support, pa, pb):
    keep_a, keep_b = pa > 0, pb > 0
    a, b = D(support[keep_a], pa[keep_a], normalize=True), D(support[keep_b], pb[keep_b], normalize=True)
    pa, pb = pa / pa.sum(), pb / pb.sum()
    js_ref = scipy.spatial.distance.jensenshannon(pa, pb) ** 2  # natural log by default
    assert gl.distance(a, b, "js") == pytest.approx(js_ref, rel=1e-9), "js vs scipy jensenshannon**2"
    kl_ref = st.entropy(pa, pb)
    assert np.isfinite(kl_ref)
    got = gl.distance(a, b, "kl")
    assert got == pytest.approx(kl_ref, rel=1e-11), f"kl {got!r} vs scipy entropy {kl_ref!r}"


# ----------------------------------------------------------------------------------------------
# Distribution / sample forms
# ----------------------------------------------------------------------------------------------

def test_empirical_distribution():
    e = D.empirical(np.array([3.0, 1.0, 3.0, 3.0, 0.5]))
    assert e.support.tolist() == [0.5, 1.0, 3.0] and e.probs.tolist() == [0.2, 0.2, 0.6]
    assert e.mean == pytest.approx(2.1, rel=1e-15)  # (0.5 + 1 + 9)/5


def test_distribution_versus_samples():
    # samples {0, 0, 1, 1, 1, 2}: frequencies 1/3, 1/2, 1/6; d = {0: 1/4, 1: 1/2, 2: 1/4}.
    # tv = 1/2 (1/12 + 0 + 1/12) = 1/12; ks = max(|1/3 - 1/4|, |5/6 - 3/4|, 0) = 1/12;
    # w1 = 1/12 (1 - 0) + 1/12 (2 - 1) = 1/6.
    samples = np.array([0.0, 0, 1, 1, 1, 2])
    d = D([0.0, 1.0, 2.0], [0.25, 0.5, 0.25])
    for metric, want in (("tv", 1 / 12), ("ks", 1 / 12), ("w1", 1 / 6)):
        assert gl.distance(samples, d, metric) == pytest.approx(want, rel=1e-13), metric
        assert gl.distance(d, samples, metric) == pytest.approx(want, rel=1e-13), metric
    for metric in METRICS:  # a sample array means exactly its empirical law
        assert gl.distance(samples, d, metric) == gl.distance(D.empirical(samples), d, metric), metric


def test_sample_tv_bias_shrinks_with_samples():
    """TV between samples and their exact law falls roughly like sqrt(#values / M) (docs/math/metrics.md#metric-sampled-bias)."""
    law = gl.law("binomial")
    d = law.pmf(100, 0.3)
    tv = [gl.distance(law.sample(100, 0.3, size=m, seed=41), d, "tv") for m in (10**3, 10**5)]
    assert tv[1] < tv[0] / 4, f"TV(samples, pmf) at M = 1e3, 1e5 (n=100, p=0.3, seed=41): {tv}"
    assert tv[1] < 2 * math.sqrt(len(d) / 10**5), f"TV at M = 1e5 too large: {tv[1]}"


@pytest.mark.parametrize("bad", [np.zeros((2, 2)), np.array([]), np.array([0.0, np.nan]), "abc"])
def test_distance_rejects_bad_samples(bad):
    with pytest.raises(ValueError):
        gl.distance(bad, np.array([0.0, 1.0]), "tv")


def test_distance_rejects_unknown_metric():
    with pytest.raises(ValueError, match="metric.*foo"):
        gl.distance(np.array([0.0]), np.array([1.0]), "foo")


# ----------------------------------------------------------------------------------------------
# chi2_test
# ----------------------------------------------------------------------------------------------

def test_chi2_hand_checked():
    # Law {0: 0.5, 1: 0.3, 2: 0.2}; 100 samples with counts 45, 35, 20 -> expected 50, 30, 20.
    # statistic = 5^2/50 + 5^2/30 + 0 = 0.5 + 5/6 = 4/3; dof = 3 - 1 = 2; p-value = exp(-(4/3)/2).
    dist = D([0.0, 1.0, 2.0], [0.5, 0.3, 0.2])
    samples = np.repeat([0.0, 1.0, 2.0], [45, 35, 20])
    r = gl.chi2_test(samples, dist)
    assert r.statistic == pytest.approx(4 / 3, rel=1e-12)
    assert r.dof == 2
    assert r.pvalue == pytest.approx(math.exp(-2 / 3), rel=1e-12)
    assert r.observed.tolist() == [45, 35, 20] and np.allclose(r.expected, [50, 30, 20], rtol=1e-12)
    assert r.samples == 100 and r.note == ""
    r1 = gl.chi2_test(samples, dist, fitted_params=1)
    assert r1.dof == 1 and r1.pvalue == pytest.approx(st.chi2.sf(4 / 3, 1), rel=1e-12)


def test_chi2_merges_tails_until_expected_at_least_5():
    # Binomial(20, 0.1) with 200 samples: expected counts 200 pmf(k) are 24.3 at k = 0 and fall
    # below 5 from k = 6 on (200 pmf(6) = 1.8): the right tail must be merged.
    n, p, seed = 20, 0.1, 51
    dist = gl.law("binomial").pmf(n, p)
    x = gl.law("binomial").sample(n, p, size=200, seed=seed)
    r = gl.chi2_test(x, dist)
    exp, obs = np.asarray(r.expected), np.asarray(r.observed)
    msg = f"n={n}, p={p}, seed={seed}: bins {list(zip(r.lower, r.upper, obs, exp))}"
    assert np.all(exp >= 5.0), msg
    assert len(exp) < len(dist), msg  # something was merged
    assert r.dof == len(exp) - 1, msg
    assert exp.sum() == pytest.approx(200, rel=1e-12) and obs.sum() == 200, msg
    assert r.lower[0] == dist.support[0] and r.upper[-1] == dist.support[-1], msg
    assert np.all(np.asarray(r.lower)[1:] > np.asarray(r.upper)[:-1]), msg  # contiguous, no overlap
    want = ((obs - exp) ** 2 / exp).sum()
    assert r.statistic == pytest.approx(want, rel=1e-12), msg


@pytest.mark.parametrize("min_expected", [1.0, 5.0, 20.0])
def test_chi2_min_expected(min_expected):
    dist = gl.law("poisson").pmf(3.0, 1.0)
    x = gl.law("poisson").sample(3.0, 1.0, size=500, seed=52)
    r = gl.chi2_test(x, dist, min_expected=min_expected)
    assert np.all(np.asarray(r.expected) >= min_expected), f"min_expected={min_expected}: {r.expected}"


@pytest.mark.parametrize("n, p, size, seed", [(30, 0.3, 10**4, 61), (1000, 0.5, 10**5, 62), (10.5, 0.9, 5000, 63)])
def test_chi2_pvalue_is_the_chi2_tail(n, p, size, seed):
    x = gl.law("binomial").sample(n, p, size=size, seed=seed)
    dist = gl.law("binomial").pmf(n, p)
    r = gl.chi2_test(x, dist)
    assert r.pvalue == pytest.approx(st.chi2.sf(r.statistic, r.dof), rel=1e-10), f"n={n}, p={p}, seed={seed}"
    # and a wrong law gives a tiny p-value, equal to the tail too
    r2 = gl.chi2_test(x + 1, gl.law("binomial").pmf(n + 1, p))
    assert r2.pvalue == pytest.approx(st.chi2.sf(r2.statistic, r2.dof), rel=1e-9, abs=1e-300)


@pytest.mark.parametrize("bad_value", [0.5, -1.0, 21.0, 3.25])
def test_chi2_impossible_sample_fails_outright(bad_value):
    dist = gl.law("binomial").pmf(20, 0.5)   # support 0..20, nothing trimmed at either end
    x = np.concatenate([gl.law("binomial").sample(20, 0.5, size=1000, seed=71), [bad_value]])
    r = gl.chi2_test(x, dist)
    assert r.pvalue == 0.0 and r.statistic == math.inf, f"sample {bad_value}: p-value {r.pvalue}"
    assert "sample" in r.note and f"{bad_value:g}" in r.note, f"sample {bad_value}: note {r.note!r}"


def test_chi2_integer_samples_beyond_a_trimmed_tail_count_in_the_tail_bin():
    dist = gl.law("poisson").pmf(2.0, 1.0)   # right tail trimmed at ~1e-14
    assert dist.trimmed_above
    x = np.concatenate([gl.law("poisson").sample(2.0, 1.0, size=1000, seed=72), [dist.support[-1] + 5]])
    r = gl.chi2_test(x, dist)
    assert np.isfinite(r.statistic) and r.observed.sum() == 1001, f"lam=2, seed=72, extra sample {x[-1]}: {r.note!r}"


@pytest.mark.parametrize("law, n, p, bad", [("binomial", 5, 0.0, 1.0), ("binomial", 5, 1.0, 4.0),
                                            ("poisson", 5, 0.0, 3.0), ("binomial", 10.5, 1.0, 9.0)])
def test_chi2_impossible_sample_of_a_degenerate_law(law, n, p, bad):
    """A law that cannot produce `bad` at all (p = 0 or 1) must reject it, not absorb it in a tail bin."""
    dist = gl.law(law).pmf(n, p)
    r = gl.chi2_test(np.full(100, bad), dist)
    assert r.pvalue == 0.0, (f"{law}(n={n}, p={p}) support {dist.support}: 100 samples of {bad} got "
                             f"p-value {r.pvalue} ({r.note!r})")


def test_chi2_with_too_few_samples_is_exact_and_still_rejects():
    # Too few samples for two merged bins: the chi-square approximation is invalid, and merging would
    # hide the evidence. An all-or-nothing law's 8 samples (K = 0 or 16 at n = 16, p = 0.1, TV ~ 1 to
    # the binomial) used to get dof 0 and p = 1.0; the exact likelihood-ratio test rejects them.
    b = gl.law("binomial").pmf(16, 0.1)
    aon = gl.custom_law(lambda n, p, u: (u[:, 0] < p) * n, n_uniforms=1, name="all_or_nothing_chi2_test")
    x = aon.sample(16, 0.1, size=8, seed=2)
    r = gl.chi2_test(x, b)
    assert r.dof == 0 and "exact likelihood-ratio" in r.note and r.pvalue < 1e-3, (x, r.pvalue, r.note)
    assert gl.chi2_test(x, b).pvalue == r.pvalue  # a fixed key: the same samples, the same p-value
    # Three zeros of Binomial(10, 1/2) have probability 2^-30: rejected too.
    assert gl.chi2_test(np.zeros(3), gl.law("binomial").pmf(10, 0.5)).pvalue < 1e-3


def test_exact_small_sample_test_holds_its_level():
    # Under the law itself the exact test's p-values are (conservatively) uniform: of 200 fixed
    # seeds of 4 draws, about 10 % fall below 0.1 (sd 2.1 %); more than 20 % would be a broken test
    # (probability < 1e-5 for a valid one), and so would p-values that never go below 0.5.
    law = gl.law("binomial")
    d = law.pmf(16, 0.1)
    ps = np.array([gl.chi2_test(law.sample(16, 0.1, size=4, seed=s), d).pvalue for s in range(200)])
    assert np.mean(ps < 0.1) < 0.2 and np.mean(ps < 0.5) > 0.2, np.quantile(ps, [0.1, 0.5, 0.9])


def test_chi2_without_degrees_of_freedom_cannot_pass():
    x = gl.law("binomial").sample(16, 0.1, size=10**4, seed=3)
    r = gl.chi2_test(x, gl.law("binomial").pmf(16, 0.1), fitted_params=100)
    assert r.dof == 0 and np.isnan(r.pvalue) and "fitted_params = 100" in r.note


def test_chi2_rejects_bad_arguments():
    dist = D([0.0, 1.0], [0.5, 0.5])
    with pytest.raises(ValueError, match="dist"):
        gl.chi2_test([0.0, 1.0], [0.5, 0.5])
    with pytest.raises(ValueError, match="samples"):
        gl.chi2_test([], dist)
    with pytest.raises(ValueError, match="samples"):
        gl.chi2_test([0.0, np.nan], dist)
    with pytest.raises(ValueError, match="min_expected"):
        gl.chi2_test([0.0, 1.0], dist, min_expected=0.0)
    with pytest.raises(ValueError, match="fitted_params"):
        gl.chi2_test([0.0, 1.0], dist, fitted_params=-1)


@pytest.mark.parametrize("alpha, tests", [(1e-3, 1), (1e-3, 10), (0.05, 3), (1e-6, 1000)])
def test_sidak_alpha(alpha, tests):
    got = gl.sidak_alpha(alpha, tests)
    assert got == pytest.approx(1 - (1 - alpha) ** (1 / tests), rel=1e-9)
    assert 1 - (1 - got) ** tests == pytest.approx(alpha, rel=1e-9)  # the family-wise rate
