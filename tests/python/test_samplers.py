"""Samplers (law.sample) and inversion (law.evaluate) against exact laws, by Pearson chi-square.

Accepted false-failure rate: every goodness-of-fit test in this module uses a fixed seed and
rejects when its p-value is below ALPHA = gl.sidak_alpha(1e-3, N_GOF), N_GOF being the number of
such tests here. For a correct sampler the chance that any of them fails is therefore 1e-3
family-wise (Sidak; the tests use disjoint seeds). With the seeds fixed every run gives the same
result: a failure appearing after a change to a sampler is a real signal at that level, and can be
reproduced from the (n, p, seed) printed in its message.

Power: test_wrong_samplers_are_rejected runs the same machinery on deliberately wrong samplers and
requires p-values below 1e-6.

The grid covers both branches of each sampler (binomial: inversion when floor(n) min(p, 1 - p) < 10,
BTRD otherwise; Poisson: inversion for lam < 10, PTRD otherwise), the p > 1/2 symmetry flip, the
stratified non-integer n rule and n up to 1e15. Where the exact pmf would be too wide (variance
~1e14), samples are binned at quantiles and compared with bin masses from cdf / sf.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.stats as st

import glintlab as gl

BINOMIAL = gl.law("binomial")
POISSON = gl.law("poisson")
SAMPLES = 10**6
EVAL_SAMPLES = 2 * 10**5  # evaluate() inverts the cdf per sample: ~10x the cost of sample()


def _seeded(cases, base):
    """Gives each case its own fixed seed (base + index), so that no two tests share numbers."""
    return [pytest.param(n, p, base + i, id=f"{label}-n={n:g}-p={p:g}")
            for i, (n, p, label) in enumerate(cases)]


BINOMIAL_CASES = _seeded([
    (1, 0.5, "inversion"),
    (16, 0.5, "inversion"),                 # m min(p, q) = 8
    (20, 0.45, "inversion"),                # 9
    (1000, 0.01, "inversion"),              # 10: BTRD's own lower limit, inverted here
    (1000, 0.0299, "inversion"),            # 29.9: just below the switch
    (1000, 0.03, "btrd"),                   # 30: at the switch
    (30, 0.5, "inversion"),
    (100, 0.31, "btrd"),
    (1000, 0.3, "btrd"),
    (1e6, 0.5, "btrd"),
    (20, 0.8, "inversion-flipped"),
    (100, 0.95, "inversion-flipped"),
    (1000, 0.999, "inversion-flipped"),
    (50, 0.7, "inversion-flipped-15"),
    (150, 0.7, "btrd-flipped"),
    (1000, 0.9, "btrd-flipped"),
    (0.5, 0.5, "fractional-facet-only"),
    (10.5, 0.3, "nonint-inversion"),
    (20.5, 0.6, "nonint-inversion-flipped"),
    (1000.25, 0.2, "nonint-btrd"),
    (1000.25, 0.9, "nonint-btrd-flipped"),
    (10.5, 1.0, "nonint-p1"),               # K = 10 + Bernoulli(1/2)
    (1e6, 1e-7, "inversion-tiny-mean"),
    (1e9, 1e-9, "inversion-n1e9"),
    (1e9, 1e-6, "btrd-n1e9"),
    (1e15, 5e-15, "inversion-n1e15"),
    (1e15, 1e-12, "btrd-n1e15"),
], base=1000)

POISSON_CASES = _seeded([
    (1e-3, 1.0, "inversion"),
    (1, 0.5, "inversion"),
    (29.99, 1.0, "inversion"),              # lam just below the switch
    (30, 1.0, "ptrd"),                      # lam = 30: at the switch
    (10, 1.0, "inversion-10"),              # PTRD's own lower limit, inverted here
    (100, 0.3, "ptrd"),
    (33.5, 0.9, "ptrd"),
    (1e6, 0.5, "ptrd"),
    (1e9, 1e-6, "ptrd-n1e9"),
    (1e15, 1e-12, "ptrd-n1e15"),
], base=2000)

# Laws too wide for law.pmf: (law name, n, p).
BINNED_CASES = [
    pytest.param("binomial", 1e15, 0.3, 3000, id="binomial-n=1e15-p=0.3"),
    pytest.param("binomial", 1e15, 0.5, 3001, id="binomial-n=1e15-p=0.5"),
    pytest.param("binomial", 1e12, 0.9, 3002, id="binomial-n=1e12-p=0.9"),
    pytest.param("poisson", 1e13, 1.0, 3003, id="poisson-lam=1e13"),
]

EVAL_CASES = [
    pytest.param("binomial", 1000, 0.3, 4000, id="binomial-n=1000-p=0.3"),
    pytest.param("binomial", 10.5, 0.9, 4001, id="binomial-n=10.5-p=0.9"),
    pytest.param("binomial", 1e9, 1e-6, 4002, id="binomial-n=1e9-p=1e-6"),
    pytest.param("poisson", 100, 0.3, 4003, id="poisson-lam=30"),
]

CALIBRATION_RUNS = 300
N_GOF = len(BINOMIAL_CASES) + len(POISSON_CASES) + len(BINNED_CASES) + len(EVAL_CASES) + 1
ALPHA = gl.sidak_alpha(1e-3, N_GOF)


def describe_bins(r, count=3):
    """The bins contributing most to the statistic, for failure messages."""
    obs, exp = np.asarray(r.observed), np.asarray(r.expected)
    contrib = (obs - exp) ** 2 / exp
    worst = np.argsort(contrib)[::-1][:count]
    return "; ".join(f"[{r.lower[i]:g}, {r.upper[i]:g}] observed {obs[i]:.0f} expected {exp[i]:.1f}"
                     for i in worst)


def assert_fits(samples, dist, what):
    r = gl.chi2_test(samples, dist)
    assert r.dof >= 1, f"{what}: the chi-square test has no power ({r.note})"
    assert r.pvalue >= ALPHA, (
        f"{what}: chi2 = {r.statistic:.2f} on {r.dof} dof, p-value {r.pvalue:.3e} < alpha {ALPHA:.2e} "
        f"{r.note}; worst bins: {describe_bins(r)}")
    return r


def assert_counts(x, n, p, seed, top):
    assert x.dtype == np.float64, f"n={n!r}, p={p!r}, seed={seed}: dtype {x.dtype}"
    bad = ~(np.isfinite(x) & (x >= 0) & (x <= top) & (x == np.floor(x)))
    assert not bad.any(), (f"n={n!r}, p={p!r}, seed={seed}: sample {x[bad][0]!r} at index "
                           f"{np.flatnonzero(bad)[0]} is not an integer count in [0, {top}]")


@pytest.mark.parametrize("n, p, seed", BINOMIAL_CASES)
def test_binomial_sampler(n, p, seed):
    x = BINOMIAL.sample(n, p, size=SAMPLES, seed=seed)
    assert_counts(x, n, p, seed, math.ceil(n))
    assert_fits(x, BINOMIAL.pmf(n, p), f"binomial.sample(n={n!r}, p={p!r}, seed={seed})")


@pytest.mark.parametrize("n, p, seed", POISSON_CASES)
def test_poisson_sampler(n, p, seed):
    x = POISSON.sample(n, p, size=SAMPLES, seed=seed)
    assert_counts(x, n, p, seed, math.inf)
    assert_fits(x, POISSON.pmf(n, p), f"poisson.sample(n={n!r}, p={p!r}, lam={n * p!r}, seed={seed})")


def binned_law(name, n, p, zs=np.linspace(-4.5, 4.5, 61)):
    """Bin edges at mean + z sd and a Distribution on the bin indices with masses from cdf / sf."""
    if name == "binomial":
        mean, sd = n * p, math.sqrt(n * p * (1 - p))
        cdf, sf = (lambda k: gl.binomial.cdf(k, n, p)), (lambda k: gl.binomial.sf(k, n, p))
    else:
        mean, sd = n * p, math.sqrt(n * p)
        cdf, sf = (lambda k: gl.poisson.cdf(k, n * p)), (lambda k: gl.poisson.sf(k, n * p))
    edges = np.unique(np.floor(mean + zs * sd))
    lower = np.array([cdf(e) for e in edges])
    probs = np.concatenate([[lower[0]], np.diff(lower[: len(edges) // 2 + 1]),
                            -np.diff([sf(e) for e in edges[len(edges) // 2:]]), [sf(edges[-1])]])
    return edges, gl.Distribution(np.arange(len(probs), dtype=float), probs)


@pytest.mark.parametrize("name, n, p, seed", BINNED_CASES)
def test_sampler_binned_at_huge_variance(name, n, p, seed):
    edges, dist = binned_law(name, n, p)
    x = gl.law(name).sample(n, p, size=SAMPLES, seed=seed)
    assert_counts(x, n, p, seed, n if name == "binomial" else math.inf)
    bins = np.searchsorted(edges, x, side="left").astype(float)  # bin i: edges[i-1] < x <= edges[i]
    assert_fits(bins, dist, f"{name}.sample(n={n!r}, p={p!r}, seed={seed}) in {len(edges) + 1} quantile bins")


@pytest.mark.parametrize("name, n, p, seed", EVAL_CASES)
def test_evaluate_with_uniforms(name, n, p, seed):
    law = gl.law(name)
    u = gl.uniforms(EVAL_SAMPLES, law.n_uniforms, seed=seed)
    x = law.evaluate(n, p, u)
    assert_counts(x, n, p, seed, math.ceil(n) if name == "binomial" else math.inf)
    assert_fits(x, law.pmf(n, p), f"{name}.evaluate(n={n!r}, p={p!r}, gl.uniforms(seed={seed}))")


def test_chi2_pvalues_are_calibrated():
    """Under the null the p-values of many independent runs are uniform (KS test)."""
    n, p = 30, 0.3
    dist = BINOMIAL.pmf(n, p)
    pvalues = [gl.chi2_test(BINOMIAL.sample(n, p, size=10**4, seed=5000 + s), dist).pvalue
               for s in range(CALIBRATION_RUNS)]
    ks = st.kstest(pvalues, "uniform")
    assert ks.pvalue >= ALPHA, (
        f"p-values of {CALIBRATION_RUNS} chi-square tests (n={n}, p={p}, seeds 5000..) are not "
        f"uniform: KS statistic {ks.statistic:.3f}, p-value {ks.pvalue:.2e}")


# ----------------------------------------------------------------------------------------------
# The machinery can fail
# ----------------------------------------------------------------------------------------------

def _custom_binomial_with_p_times_1_02(n, p, size, seed):
    law = gl.custom_law(lambda nn, pp, u: BINOMIAL.evaluate(nn, np.minimum(1.02 * pp, 1.0), u),
                        n_uniforms=1, name="test_samplers_p_times_1_02")
    return law.sample(n, p, size=size, seed=seed)


WRONG_SAMPLERS = [
    # (sampler(n, p, size, seed), n, p): each must be rejected against binomial.pmf(n, p)
    pytest.param(_custom_binomial_with_p_times_1_02, 50, 0.3, id="custom-law-binomial-p-times-1.02"),
    pytest.param(lambda n, p, size, seed: POISSON.sample(n, p, size=size, seed=seed), 50, 0.3,
                 id="poisson-instead-of-binomial"),
    pytest.param(lambda n, p, size, seed: BINOMIAL.sample(n, 1 - p, size=size, seed=seed), 50, 0.7,
                 id="symmetry-flip-forgotten"),
    pytest.param(lambda n, p, size, seed: BINOMIAL.sample(math.ceil(n), p, size=size, seed=seed), 10.5, 0.5,
                 id="n-rounded-up-instead-of-stratified"),
]


@pytest.mark.parametrize("sampler, n, p", WRONG_SAMPLERS)
def test_wrong_samplers_are_rejected(sampler, n, p):
    seed = 6000
    x = sampler(n, p, 2 * 10**5, seed)
    r = gl.chi2_test(x, BINOMIAL.pmf(n, p))
    assert r.pvalue < 1e-6, (
        f"a wrong sampler passed against binomial.pmf(n={n!r}, p={p!r}), seed={seed}: "
        f"chi2 = {r.statistic:.2f} on {r.dof} dof, p-value {r.pvalue:.3e}")


# ----------------------------------------------------------------------------------------------
# Deterministic cases and numerical extremes (docs/math/extremes.md)
# ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("n, p, value", [(0, 0.5, 0.0), (16, 0.0, 0.0), (16, 1.0, 16.0), (1e15, 0.0, 0.0),
                                         (1e15, 1.0, 1e15), (0.75, 0.0, 0.0), (0, 1.0, 0.0)])
def test_degenerate_binomial_is_constant(n, p, value):
    x = BINOMIAL.sample(n, p, size=10**4, seed=7)
    assert np.all(x == value), f"binomial.sample(n={n!r}, p={p!r}, seed=7) gave {np.unique(x)}, expected {value}"


@pytest.mark.parametrize("n, p", [(0, 0.5), (16, 0.0), (1e15, 0.0)])
def test_degenerate_poisson_is_zero(n, p):
    x = POISSON.sample(n, p, size=10**4, seed=7)
    assert np.all(x == 0.0), f"poisson.sample(n={n!r}, p={p!r}, seed=7) gave {np.unique(x)}"


EXTREME_NS = [0, 1e-6, 0.5, 1, 2, 16, 17, 1e9, 1e15]
EXTREME_PS = [0.0, 1e-300, 1e-12, 1e-7, 0.5, 1 - 1e-7, 1.0]


@pytest.mark.parametrize("p", EXTREME_PS)
@pytest.mark.parametrize("n", EXTREME_NS)
def test_samples_at_extremes_are_valid_counts(n, p):
    """Every sample is a finite integer in [0, ceil(n)] (binomial) or >= 0 (Poisson), and the sample
    mean is within 6 standard errors of n p."""
    size, seed = 20000, 8
    for law, top, var in ((BINOMIAL, math.ceil(n), n * p * (1 - p) + 0.25 * p),
                          (POISSON, math.inf, n * p)):
        x = law.sample(n, p, size=size, seed=seed)
        assert_counts(x, n, p, seed, top)
        err = abs(x.mean() - n * p)
        assert err <= 6 * math.sqrt(var / size) + 1e-9 * n * p, (
            f"{law.name}.sample(n={n!r}, p={p!r}, seed={seed}): mean {x.mean()!r}, expected {n * p!r}")
