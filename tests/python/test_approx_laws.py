"""Approximate (constant-time) laws: exact pmf against the law itself, samplers against the pmf, the
extremes of docs/math/extremes.md in float64 and float32, and bad parameters.

Each law here maps one uniform through a monotone quantile-like function, so its exact pmf can be
checked deterministically first: P(K = k) is the length of the set of u with evaluate(u) = k, which
a fine grid of u measures to within its spacing. Chi-square tests come second: fixed seeds, 1e6
samples, family-wise false-failure rate 1e-3 split over the module's checks with Sidak.
"""

import numpy as np
import pytest

import glintlab as gl

# Every approximation's declared test variants (core/laws/*.cpp): a new law is tested here unedited.
APPROX = gl.law_variants("test", reference=False)
POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (10.5, 0.3), (1, 0.5), (1e6, 1e-6), (40, 0.97), (3.7, 0.6),
          (40, 0.1), (0.4, 0.9)]
ALPHA = gl.sidak_alpha(1e-3, len(APPROX) * len(POINTS))


def ids(case):
    name, params = case
    return name + "".join(f"-{k}={v}" for k, v in params.items())


@pytest.mark.parametrize("case", APPROX, ids=ids)
@pytest.mark.parametrize("n,p", POINTS)
def test_pmf_matches_the_law_on_a_fine_grid_of_u(case, n, p):
    """Deterministic: the exact pmf against the measure of {u : evaluate(u) = k} on a grid of u
    (1-D for one-uniform laws, 2-D for two); laws with more uniforms are left to chi-square."""
    name, params = case
    law = gl.law(name, **params)
    d = law.pmf(n, p)
    assert abs(d.probs.sum() - 1) < 1e-12
    if law.n_uniforms == 1:
        m = 2_000_000
        u = ((np.arange(m) + 0.5) / m).reshape(-1, 1)
        cells = m
    elif law.n_uniforms == 2:
        m = 1500
        g = (np.arange(m) + 0.5) / m
        u = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
        cells = m
    else:
        pytest.skip(f"{law.n_uniforms} uniforms: no grid")
    k = law.bin(law.evaluate(n, p, u))
    values, counts = np.unique(k, return_counts=True)
    grid = gl.Distribution(values, counts / len(k))
    # Each value's region is off by at most one grid cell along each boundary it has.
    assert gl.distance(grid, d, "tv") <= (len(values) + 1) * 2 / cells + 1e-12, (name, params, n, p)


@pytest.mark.parametrize("case", APPROX, ids=ids)
@pytest.mark.parametrize("n,p", POINTS)
def test_sampler_matches_pmf(case, n, p):
    name, params = case
    law = gl.law(name, **params)
    seed = 4000 + POINTS.index((n, p))
    x = law.bin(law.sample(n, p, size=10**6, seed=seed))
    d = law.pmf(n, p)
    if len(d) == 1:  # a deterministic output: every sample is that value
        assert np.all(x == d.support[0]), (name, params, n, p)
        return
    r = gl.chi2_test(x, d)
    assert r.pvalue > ALPHA, f"{name} {params} n={n} p={p} seed={seed}: chi2={r.statistic} dof={r.dof} p={r.pvalue} {r.note}"


def test_the_check_rejects_the_wrong_rounding():
    # Samples of the floor variant against the round variant's pmf must fail.
    x = gl.law("gaussian", rounding="floor").sample(16, 0.1, size=10**6, seed=9)
    assert gl.chi2_test(x, gl.law("gaussian", rounding="round").pmf(16, 0.1)).pvalue < 1e-10


EXTREME_N = [0.0, 1e-6, 0.5, 1.0, 2.0, 16.0, 17.0, 1e9, 1e15]
EXTREME_P = [0.0, 1e-300, 1e-12, 1e-7, 0.5, 1 - 1e-7, 1.0]
EXTREME_U = np.array([0.0, 2.0**-53, 1e-300, 0.5, 1 - 2.0**-53, 1.0, 0.999969482421875,  # a float16 value
                      np.float64(np.float16(0.3))])


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("case", APPROX, ids=ids)
def test_extremes_give_finite_counts_in_range(case, precision):
    name, params = case
    law = gl.law(name, **params)
    nn, pp, uu = np.meshgrid(EXTREME_N, EXTREME_P, EXTREME_U, indexing="ij")
    # Row i gives uniform j the extreme value (i + j) mod len: every column sees every extreme.
    shift = np.searchsorted(np.sort(EXTREME_U), uu.ravel())  # any fixed per-row offset works
    cols = (shift[:, None] + np.arange(law.n_uniforms)[None, :]) % len(EXTREME_U)
    u = np.sort(EXTREME_U)[cols]
    k = law.evaluate(nn.ravel(), pp.ravel(), u, precision=precision)
    # The bounds each law declares with its code: K <= ceil(n), or ceil(n) + 1 for the public shader's
    # gate (1 + clamp(floor(G), 0, n)); integer counts unless its output is declared real (a mean, a
    # soft gate, a continuous law).
    traits = law.traits
    top = np.ceil(nn.ravel()) + (1 if traits["support"] == "n_plus_one" else 0)
    integer = (k == np.floor(k)) | (traits["output"] == "real")
    bad = ~(np.isfinite(k) & (k >= 0) & (k <= top) & integer)
    assert not bad.any(), [(n, p, tuple(row), kk) for n, p, row, kk in
                           zip(nn.ravel()[bad], pp.ravel()[bad], u[bad], k[bad])][:5]


# Integer laws of one uniform with a float32 path: the same uniform goes through the same quantile.
ONE_UNIFORM_F32 = [c for c in APPROX if gl.law(c[0], **c[1]).n_uniforms == 1
                   and "float32" in gl.law(c[0], **c[1]).precisions and gl.law_traits(c[0])["output"] == "integer"]


@pytest.mark.parametrize("case", ONE_UNIFORM_F32, ids=ids)
def test_float32_is_the_same_law_where_float_resolves_it(case):
    # At moderate n the float32 evaluation of the same uniforms gives the same counts (almost
    # always); at n p ~ 3e5 float spacing (0.03) moves a measurable share of the floor boundaries.
    name, params = case
    law = gl.law(name, **params)
    u = gl.uniforms(200_000, 1, seed=5)
    same = law.evaluate(16, 0.1, u) == law.evaluate(16, 0.1, u, precision="float32")
    assert same.mean() > 0.999
    far = law.evaluate(1e6, 0.3, u) != law.evaluate(1e6, 0.3, u, precision="float32")
    assert far.mean() > 1e-3


def test_documented_effects():
    b = gl.law("binomial")
    # gated: P(K = 0) = (1 - p)^n exactly (the gate as intended, not as printed).
    for n, p in [(16, 0.1), (1e3, 1e-2), (10.5, 0.3)]:
        d = gl.law("gated").pmf(n, p)
        assert d.probs[0] == pytest.approx((1 - p) ** n, rel=1e-12)
    # zk16: below the switch with n <= cap the loop is the exact binomial; n > cap truncates to cap.
    assert gl.distance(gl.law("zk16").pmf(16, 0.1), b.pmf(16, 0.1), "tv") < 1e-12
    assert gl.law("zk16").pmf(40, 0.1).mean == pytest.approx(16 * 0.1)
    # threshold: exact below T, the mean (zero variance) above.
    assert gl.distance(gl.law("threshold").pmf(40, 0.1), b.pmf(40, 0.1), "tv") < 1e-12
    d = gl.law("threshold").pmf(1e6, 0.3)
    assert len(d) == 1 and d.var == 0 and d.mean == pytest.approx(3e5)


def test_head_cf_beats_gated_on_the_worst_case():
    """glintlab's law against DB23's gated Gaussian: exact TV to the binomial over a log grid of n
    (integers and not) and p on both sides of 1/2; the worst case must be far lower."""
    b, h, g = gl.law("binomial"), gl.law("head_cf"), gl.law("gated")
    worst_h = worst_g = 0.0
    for n in np.concatenate([np.logspace(0, 5, 11), [2.5, 7.3, 150.5]]):
        for p in [1e-6, 1e-3, 0.02, 0.1, 0.3, 0.5, 0.7, 0.9, 0.98, 1 - 1e-3, 1 - 1e-6]:
            ref = b.pmf(n, p)
            worst_h = max(worst_h, gl.distance(h.pmf(n, p), ref, "tv"))
            worst_g = max(worst_g, gl.distance(g.pmf(n, p), ref, "tv"))
    assert worst_h < 0.01, worst_h
    assert worst_g > 0.3, worst_g  # DB23's gate as intended, near p = 1 (docs/math/laws.md#law-gated: above 0.5)


def test_gated_shader_measured_defects():
    s = gl.law("gated_shader")
    assert s.binning == "round" and gl.law("gated").binning == "none"
    # K can exceed n: floor(z sd + mu) is clamped to n, then 1 is added.
    assert s.pmf(100, 0.999).support.max() == 101
    # Half-float Gaussians leave gaps at large n: far fewer reachable counts than the binomial.
    assert len(s.pmf(1e6, 0.3)) < 0.7 * len(gl.law("binomial").pmf(1e6, 0.3))
    # Dropouts: where P1 rounds to 1.0f the hard gate theta0 < P1 fails for the half-float uniform
    # 1.0 (u > 1 - 2^-12), so K = 0 with probability 2^-12 even at n = 1e6, p = 1/2.
    d = s.pmf(1e6, 0.5)
    assert d.support[0] == 0 and d.probs[0] == pytest.approx(2.0**-12, rel=1e-9)
    assert d.var > 100 * gl.law("binomial").pmf(1e6, 0.5).var
    # The soft gate makes counts non-integer near P1 (here P1 = 1 - 0.9^16 = 0.81).
    u = np.column_stack([np.linspace(0.72, 0.9, 2000), np.full(2000, 0.5)])
    k = s.evaluate(16, 0.1, u)
    assert np.any(k != np.floor(k))


def test_kk_laws_documented_effects():
    b, c, d = gl.law("binomial"), gl.law("gated_continuous"), gl.law("dual_gated")
    assert c.binning == "round" and d.binning == "round"
    # KK24 below one facet: a Bernoulli(n p) gate, so the mean is exact; above, P(K = 0) = (1-p)^n.
    assert c.pmf(0.4, 0.9).probs[0] == pytest.approx(1 - 0.36, rel=1e-14)
    assert c.pmf(16, 0.1).probs[0] == pytest.approx(0.9**16, rel=1e-12)
    # ... and its mean is biased upwards at small n p (the gated Gaussian's conditional mean).
    assert c.pmf(16, 0.1).mean > 1.2 * 1.6
    # KK25 is the exact binomial at n <= 2, and the stratified binomial between 1 and 2.
    for n in (0.3, 1, 1.5, 2):
        for p in (1e-3, 0.3, 0.9):
            assert gl.distance(d.pmf(n, p), b.pmf(n, p), "tv") < 1e-14, (n, p)
    # Its two gates make p and 1 - p mirror images at integer n: K(n, 1-p) ~ n - K(n, p).
    for n, p in [(16, 0.1), (40, 0.03), (1e3, 0.2)]:
        lo, hi = d.pmf(n, p), d.pmf(n, 1 - p)
        mirrored = gl.Distribution(n - lo.support[::-1], lo.probs[::-1])
        assert gl.distance(mirrored, hi, "tv") < 1e-12, (n, p)
    # P(K = 0) = (1-p)^n and P(K = n) = p^n exactly.
    q = d.pmf(16, 0.8)
    assert q.probs[0] == pytest.approx(0.2**16, rel=1e-9) and q.probs[-1] == pytest.approx(0.8**16, rel=1e-12)
    # Where DB23's gate fails (p near 1), the dual gate does not: exact TV to the binomial.
    for n, p in [(16, 1 - 1e-3), (1e4, 1 - 1e-6)]:
        assert gl.distance(d.pmf(n, p), b.pmf(n, p), "tv") < 0.01
        assert gl.distance(gl.law("gated").pmf(n, p), b.pmf(n, p), "tv") > 0.5


def test_bad_parameters_are_named():
    with pytest.raises(ValueError, match="cap = 0"):
        gl.law("zk16", cap=0)
    with pytest.raises(ValueError, match="cap = 65"):
        gl.law("zk16", cap=65)
    with pytest.raises(ValueError, match="T = -1"):
        gl.law("threshold", T=-1)
    with pytest.raises(ValueError, match="rounding = 'up'"):
        gl.law("gaussian", rounding="up")
    with pytest.raises(ValueError, match="unknown parameter 'cap'"):
        gl.law("gaussian", cap=3)
    with pytest.raises(ValueError, match="precision"):
        gl.law("gaussian").sample(1, 0.5, size=3, seed=1, precision="float16")
    with pytest.raises(ValueError, match="precision = 'float32'"):
        gl.law("binomial").sample(1, 0.5, size=3, seed=1, precision="float32")
    with pytest.raises(ValueError, match=r"p = 1\.5"):
        gl.law("gaussian").sample(1, 1.5, size=3, seed=1)


def test_sample_is_evaluate_on_the_sample_uniforms():
    law = gl.law("gaussian", rounding="round")
    for precision in ("float64", "float32"):
        x = law.sample(1e3, 0.01, size=5000, seed=11, precision=precision)
        y = law.evaluate(1e3, 0.01, gl.uniforms(5000, 1, seed=11), precision=precision)
        assert np.array_equal(x, y), precision
